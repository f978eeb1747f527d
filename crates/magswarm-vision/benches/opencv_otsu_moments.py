#!/usr/bin/env python3
"""OpenCV side of the vision bench: Otsu threshold + moments on one 8-bit grayscale frame.

    python opencv_otsu_moments.py FRAME.png [--reps N] [--invert] [--serve]

Prints one JSON object: OpenCV's version, the median/min time per frame (ms) of
  - otsu_moments: cv2.threshold(THRESH_OTSU) + cv2.moments(binaryImage=True) on the whole image,
  - otsu_cc_moments: the same plus cv2.connectedComponentsWithStats (8-connectivity) and the
    moments of the largest component only (what magswarm-vision computes),
and the radii/centroid each gives (r_i = 2 sqrt(lambda_i), pixel units). One thread
(cv2.setNumThreads(1)), as the Rust side.

--serve: after a warm-up, read a number K per line on stdin, time K repetitions of each variant
and answer with one JSON line {"otsu_moments": [ms...], "otsu_cc_moments": [ms...]}; at end of
input print the summary as above over all repetitions. The Rust bench uses this to interleave
blocks of its own and OpenCV's repetitions, so both see the same machine load.
"""
import argparse
import json
import math
import statistics
import sys
import time


def radii(m):
    n = m["m00"]
    if n <= 0:
        return dict(r1=float("nan"), r2=float("nan"), cx=float("nan"), cy=float("nan"), area=0)
    # OpenCV's central moments are of the pixel centres; + 1/12 for each pixel's extent, as ours
    mu20 = m["mu20"] / n + 1 / 12
    mu02 = m["mu02"] / n + 1 / 12
    mu11 = m["mu11"] / n
    half = 0.5 * (mu20 + mu02)
    d = math.sqrt(0.25 * (mu20 - mu02) ** 2 + mu11 ** 2)
    return dict(r1=2 * math.sqrt(max(half - d, 0)), r2=2 * math.sqrt(half + d),
                cx=m["m10"] / n, cy=m["m01"] / n, area=n)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("frame")
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--invert", action="store_true", help="light swarm on dark background")
    ap.add_argument("--serve", action="store_true", help="time blocks on request (see above)")
    a = ap.parse_args()
    try:
        import cv2
        import numpy as np
    except ImportError as e:
        print(json.dumps({"error": f"{e} (pip install opencv-python-headless)"}))
        return 2
    cv2.setNumThreads(1)
    img = cv2.imread(a.frame, cv2.IMREAD_UNCHANGED)
    if img is None or img.dtype != np.uint8 or img.ndim != 2:
        print(json.dumps({"error": f"{a.frame}: not an 8-bit grayscale image"}))
        return 2
    mode = (cv2.THRESH_BINARY if a.invert else cv2.THRESH_BINARY_INV) | cv2.THRESH_OTSU

    # the binary image is written into a preallocated buffer (no 2.3 MB allocation per call)
    binary = np.empty_like(img)

    def otsu_moments():
        t, b = cv2.threshold(img, 0, 255, mode, dst=binary)
        return t, cv2.moments(b, binaryImage=True)

    def otsu_cc_moments():
        t, b = cv2.threshold(img, 0, 255, mode, dst=binary)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(b, connectivity=8)
        if n < 2:
            return t, {"m00": 0}
        k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        x, y, w, h = (int(v) for v in stats[k, :4])
        sub = (labels[y:y + h, x:x + w] == k).astype(np.uint8)
        m = cv2.moments(sub, binaryImage=True)
        m = dict(m)
        m["m10"] += x * m["m00"]
        m["m01"] += y * m["m00"]
        return t, m

    variants = (("otsu_moments", otsu_moments), ("otsu_cc_moments", otsu_cc_moments))
    times = {name: [] for name, _ in variants}
    last = {}

    def block(k):
        for name, fn in variants:
            for _ in range(k):
                t0 = time.perf_counter_ns()
                last[name] = fn()
                times[name].append((time.perf_counter_ns() - t0) / 1e6)

    for _, fn in variants:
        for _ in range(10):
            fn()
    if a.serve:
        print("ready", flush=True)
        for line in sys.stdin:
            k = int(line)
            n0 = {name: len(v) for name, v in times.items()}
            block(k)
            print(json.dumps({name: v[n0[name]:] for name, v in times.items()}), flush=True)
    else:
        block(a.reps)
    out = {"opencv": cv2.__version__, "reps": len(times["otsu_moments"]),
           "width": img.shape[1], "height": img.shape[0]}
    for name, _ in variants:
        thr, m = last[name]
        ts = times[name]
        out[name] = dict(median_ms=statistics.median(ts), min_ms=min(ts), threshold=thr, **radii(m))
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
