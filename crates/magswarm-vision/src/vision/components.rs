//! The swarm as the largest connected component of the thresholded region of interest: runs
//! of swarm pixels per row (64 pixels per step), joined across rows with a union-find
//! (8-connectivity), and the moments of the largest component summed per run in closed form.

use super::threshold::{histogram, otsu};
use super::{Edges, Invalid, Measurement, Roi, Threshold, VisionConfig};
use crate::image::GrayView;

/// A run of swarm pixels `x0..x1` (ROI-relative columns) in one row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    x0: u32,
    x1: u32,
}

/// Reusable scratch buffers: keep one per camera stream so no frame allocates.
#[derive(Default, Debug)]
pub struct Vision {
    runs: Vec<Run>,
    row_start: Vec<u32>,
    parent: Vec<u32>,
    area: Vec<u64>,
}

/// Measures one frame with fresh buffers (see [`Vision::measure`] to reuse them).
pub fn measure_frame(img: GrayView<'_>, cfg: &VisionConfig) -> Measurement {
    Vision::default().measure(img, cfg)
}

impl Vision {
    pub fn new() -> Self {
        Self::default()
    }

    /// Measures the swarm in `img` (see the module documentation).
    pub fn measure(&mut self, img: GrayView<'_>, cfg: &VisionConfig) -> Measurement {
        let roi = cfg.roi.unwrap_or(Roi {
            x: 0,
            y: 0,
            w: img.width(),
            h: img.height(),
        });
        let inside = roi.w > 0
            && roi.h > 0
            && roi.x.checked_add(roi.w).is_some_and(|e| e <= img.width())
            && roi.y.checked_add(roi.h).is_some_and(|e| e <= img.height());
        if !inside || roi.w > u32::MAX as usize / 2 || roi.h > u32::MAX as usize / 2 {
            return Measurement::invalid(
                0,
                Invalid::BadRoi {
                    roi,
                    width: img.width(),
                    height: img.height(),
                },
            );
        }

        let threshold = match cfg.threshold {
            Threshold::Fixed(t) => t,
            Threshold::Otsu => {
                let hist = histogram(img, roi);
                match otsu(&hist) {
                    Some(o) if o.light_mean - o.dark_mean >= cfg.min_contrast as f64 => o.level,
                    Some(o) => {
                        return Measurement::invalid(
                            o.level,
                            Invalid::NoContrast {
                                dark_mean: o.dark_mean,
                                light_mean: o.light_mean,
                                min_contrast: cfg.min_contrast,
                            },
                        )
                    }
                    None => {
                        let v = hist.iter().position(|&c| c > 0).unwrap_or(0) as f64;
                        return Measurement::invalid(
                            0,
                            Invalid::NoContrast {
                                dark_mean: v,
                                light_mean: v,
                                min_contrast: cfg.min_contrast,
                            },
                        );
                    }
                }
            }
        };

        self.extract_runs(img, roi, threshold, cfg.invert);
        self.label();
        self.largest(roi, threshold, cfg)
    }

    /// Binary image as runs, row by row.
    fn extract_runs(&mut self, img: GrayView<'_>, roi: Roi, t: u8, invert: bool) {
        self.runs.clear();
        self.row_start.clear();
        let flip = if invert { u64::MAX } else { 0 };
        for y in 0..roi.h {
            self.row_start.push(self.runs.len() as u32);
            let row = &img.row(roi.y + y)[roi.x..roi.x + roi.w];
            let mut open: Option<u32> = None; // start of a run that continues into this word
            let mut chunks = row.chunks_exact(64);
            let mut base = 0u32;
            for c in chunks.by_ref() {
                let m = mask64(c.try_into().unwrap(), t) ^ flip;
                push_runs(&mut self.runs, &mut open, m, 64, base);
                base += 64;
            }
            let rest = chunks.remainder();
            if !rest.is_empty() {
                let mut m = 0u64;
                for (i, &v) in rest.iter().enumerate() {
                    m |= ((v <= t) as u64) << i;
                }
                m ^= flip;
                m &= (1u64 << rest.len()) - 1;
                push_runs(&mut self.runs, &mut open, m, rest.len() as u32, base);
                base += rest.len() as u32;
            }
            if let Some(s) = open {
                self.runs.push(Run { x0: s, x1: base });
            }
        }
        self.row_start.push(self.runs.len() as u32);
    }

    /// Union-find over runs; 8-connectivity between neighbouring rows.
    fn label(&mut self) {
        let n = self.runs.len();
        self.parent.clear();
        self.parent.extend(0..n as u32);
        let runs = &self.runs;
        let parent = &mut self.parent;
        for y in 1..self.row_start.len() - 1 {
            let (pa, pb) = (self.row_start[y - 1] as usize, self.row_start[y] as usize);
            let (a, b) = (self.row_start[y] as usize, self.row_start[y + 1] as usize);
            let mut j = pa;
            for i in a..b {
                let Run { x0: s, x1: e } = runs[i];
                // previous-row runs whose last pixel (x1 - 1) is left of s - 1 cannot touch
                while j < pb && runs[j].x1 < s {
                    j += 1;
                }
                let mut k = j;
                while k < pb && runs[k].x0 <= e {
                    union(parent, i as u32, k as u32);
                    k += 1;
                }
            }
        }
        // flatten: parent[i] is the root
        for i in 0..n {
            let r = find(parent, i as u32);
            parent[i] = r;
        }
    }

    fn largest(&mut self, roi: Roi, threshold: u8, cfg: &VisionConfig) -> Measurement {
        let n = self.runs.len();
        self.area.clear();
        self.area.resize(n, 0);
        let mut components = 0usize;
        for i in 0..n {
            let r = self.parent[i] as usize;
            if r == i {
                components += 1;
            }
            self.area[r] += (self.runs[i].x1 - self.runs[i].x0) as u64;
        }
        let mut best = usize::MAX;
        let mut best_area = 0u64;
        for i in 0..n {
            if self.parent[i] as usize == i && self.area[i] > best_area {
                best = i;
                best_area = self.area[i];
            }
        }
        if best == usize::MAX || best_area < cfg.min_area_px.max(1) {
            let mut m = Measurement::invalid(
                threshold,
                Invalid::NoSwarm {
                    largest_px: best_area,
                    min_area_px: cfg.min_area_px,
                },
            );
            m.components = components;
            return m;
        }

        // moments of the chosen component, exact integer sums (ROI-relative coordinates)
        let (mut s0, mut sx, mut sy, mut sxx, mut syy, mut sxy) =
            (0u64, 0u64, 0u64, 0u64, 0u64, 0u64);
        let mut edges = Edges::default();
        let (w, h) = (roi.w as u32, roi.h as u32);
        let best = best as u32;
        for y in 0..self.row_start.len() - 1 {
            let (a, b) = (self.row_start[y] as usize, self.row_start[y + 1] as usize);
            let yy = y as u64;
            for i in a..b {
                if self.parent[i] != best {
                    continue;
                }
                let Run { x0, x1 } = self.runs[i];
                let n = (x1 - x0) as u64;
                let rx = (x0 as u64 + x1 as u64 - 1) * n / 2;
                let rxx = sum_sq(x1 as u64) - sum_sq(x0 as u64);
                s0 += n;
                sx += rx;
                sxx += rxx;
                sy += n * yy;
                syy += n * yy * yy;
                sxy += rx * yy;
                edges.left |= x0 == 0;
                edges.right |= x1 == w;
                edges.top |= y == 0;
                edges.bottom |= y as u32 == h - 1;
            }
        }
        let n = s0 as f64;
        let mx = sx as f64 / n;
        let my = sy as f64 / n;
        // central moments of the pixel centres, plus 1/12 for each pixel's own extent
        let mu20 = (sxx as f64 / n - mx * mx).max(0.0) + 1.0 / 12.0;
        let mu02 = (syy as f64 / n - my * my).max(0.0) + 1.0 / 12.0;
        let mu11 = sxy as f64 / n - mx * my;
        let half_tr = 0.5 * (mu20 + mu02);
        let disc = (0.25 * (mu20 - mu02) * (mu20 - mu02) + mu11 * mu11).sqrt();
        let l1 = (half_tr - disc).max(0.0);
        let l2 = half_tr + disc;
        let mut angle = 0.5 * (2.0 * mu11).atan2(mu20 - mu02);
        if angle <= -std::f64::consts::FRAC_PI_2 + 1e-15 {
            angle += std::f64::consts::PI;
        }
        let invalid = edges.any().then_some(Invalid::TouchesEdge {
            edges,
            area_px: s0,
            roi_px: roi.w as u64 * roi.h as u64,
        });
        Measurement {
            threshold,
            area_px: s0,
            r1_px: 2.0 * l1.sqrt(),
            r2_px: 2.0 * l2.sqrt(),
            angle_deg: angle.to_degrees(),
            cx_px: roi.x as f64 + mx,
            cy_px: roi.y as f64 + my,
            components,
            invalid,
        }
    }
}

/// sum of k^2 for k in 0..n
#[inline]
fn sum_sq(n: u64) -> u64 {
    if n == 0 {
        0
    } else {
        (n - 1) * n * (2 * n - 1) / 6
    }
}

#[inline]
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

#[inline]
fn union(parent: &mut [u32], a: u32, b: u32) {
    let ra = find(parent, a);
    let rb = find(parent, b);
    if ra != rb {
        // the smaller index (earlier run) stays the root
        if ra < rb {
            parent[rb as usize] = ra;
        } else {
            parent[ra as usize] = rb;
        }
    }
}

/// Appends the runs of the set bits of `m` (the low `len` bits, columns `base..base+len`);
/// `open` carries a run that started in an earlier word.
#[inline]
fn push_runs(runs: &mut Vec<Run>, open: &mut Option<u32>, m: u64, len: u32, base: u32) {
    let full = if len == 64 {
        u64::MAX
    } else {
        (1u64 << len) - 1
    };
    match (*open, m) {
        (None, 0) => return,
        (Some(_), x) if x == full => return,
        _ => {}
    }
    // bit i of `edges` is set where bit i differs from bit i-1 (bit -1: whether a run is open)
    let carry = open.is_some() as u64;
    let mut edges = (m ^ ((m << 1) | carry)) & full;
    while edges != 0 {
        let i = edges.trailing_zeros();
        edges &= edges - 1;
        match open.take() {
            None => *open = Some(base + i),
            Some(s) => runs.push(Run {
                x0: s,
                x1: base + i,
            }),
        }
    }
}

/// Bit i set when `c[i] <= t`.
#[inline]
fn mask64(c: &[u8; 64], t: u8) -> u64 {
    #[cfg(target_arch = "x86_64")]
    {
        // SSE2 is part of the x86_64 baseline.
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is always available on x86_64; the loads are unaligned loads of 16 bytes
        // inside the 64-byte array.
        unsafe {
            let tv = _mm_set1_epi8(t as i8);
            let p = c.as_ptr() as *const __m128i;
            let mut m = 0u64;
            for k in 0..4 {
                let v = _mm_loadu_si128(p.add(k));
                let le = _mm_cmpeq_epi8(_mm_min_epu8(v, tv), v);
                m |= ((_mm_movemask_epi8(le) as u32 as u64) & 0xffff) << (16 * k);
            }
            m
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut m = 0u64;
        for (i, &v) in c.iter().enumerate() {
            m |= ((v <= t) as u64) << i;
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::GrayImage;

    fn runs_of(row: &[u8], t: u8, invert: bool) -> Vec<(u32, u32)> {
        let img = GrayImage::from_vec(row.len(), 1, row.to_vec()).unwrap();
        let mut v = Vision::new();
        let roi = Roi {
            x: 0,
            y: 0,
            w: row.len(),
            h: 1,
        };
        v.extract_runs(img.view(), roi, t, invert);
        v.runs.iter().map(|r| (r.x0, r.x1)).collect()
    }

    fn runs_naive(row: &[u8], t: u8, invert: bool) -> Vec<(u32, u32)> {
        let mut out = vec![];
        let mut s = None;
        for (i, &v) in row.iter().enumerate() {
            let fg = (v <= t) != invert;
            match (fg, s) {
                (true, None) => s = Some(i as u32),
                (false, Some(a)) => {
                    out.push((a, i as u32));
                    s = None
                }
                _ => {}
            }
        }
        if let Some(a) = s {
            out.push((a, row.len() as u32));
        }
        out
    }

    #[test]
    fn runs_match_a_naive_scan() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(7);
        for len in [1usize, 5, 63, 64, 65, 127, 128, 129, 200, 1920] {
            for density in [0.0, 0.02, 0.5, 0.98, 1.0] {
                let row: Vec<u8> = (0..len)
                    .map(|_| {
                        if rng.random::<f64>() < density {
                            rng.random_range(0..=100u8)
                        } else {
                            rng.random_range(101..=255u8)
                        }
                    })
                    .collect();
                for invert in [false, true] {
                    assert_eq!(
                        runs_of(&row, 100, invert),
                        runs_naive(&row, 100, invert),
                        "len {len} density {density} invert {invert}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_filled_axis_aligned_rectangle_has_exact_moments() {
        // 20 x 10 block: variance of a uniform unit-square tiling is L^2/12 per axis
        let mut img = GrayImage::filled(60, 40, 220);
        for y in 12..22 {
            for x in 15..35 {
                img.row_mut(y)[x] = 30;
            }
        }
        let m = measure_frame(img.view(), &VisionConfig::default());
        assert!(m.valid(), "{:?}", m.invalid);
        assert_eq!(m.area_px, 200);
        assert!((m.cx_px - 24.5).abs() < 1e-12 && (m.cy_px - 16.5).abs() < 1e-12);
        // lambda = L^2 / 12 -> r = 2 sqrt(lambda) = L / sqrt(3)
        assert!((m.r2_px - 20.0 / 3f64.sqrt()).abs() < 1e-9, "{}", m.r2_px);
        assert!((m.r1_px - 10.0 / 3f64.sqrt()).abs() < 1e-9, "{}", m.r1_px);
        assert!(m.angle_deg.abs() < 1e-9);
    }

    #[test]
    fn diagonal_runs_join_under_8_connectivity() {
        let mut img = GrayImage::filled(10, 10, 255);
        for i in 1..9 {
            img.row_mut(i)[i] = 0;
        }
        let cfg = VisionConfig {
            threshold: Threshold::Fixed(100),
            min_area_px: 1,
            ..Default::default()
        };
        let m = measure_frame(img.view(), &cfg);
        assert_eq!(m.components, 1);
        assert_eq!(m.area_px, 8);
        assert!((m.angle_deg - 45.0).abs() < 1e-9, "{}", m.angle_deg);
    }
}
