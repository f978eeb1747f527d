//! The gray level between swarm and background: the histogram of the region of interest and
//! Otsu's method on it.

use super::Roi;
use crate::image::GrayView;

/// Histogram of the region of interest. Eight interleaved tables of counters, so that runs of
/// equal gray levels (a flat background) do not serialise on one counter's load-add-store.
pub fn histogram(img: GrayView<'_>, roi: Roi) -> [u32; 256] {
    const K: usize = 8;
    let mut t = [[0u32; 256]; K];
    for y in roi.y..roi.y + roi.h {
        let row = &img.row(y)[roi.x..roi.x + roi.w];
        let mut chunks = row.chunks_exact(16);
        for c in chunks.by_ref() {
            let a = u64::from_le_bytes(c[..8].try_into().unwrap());
            let b = u64::from_le_bytes(c[8..].try_into().unwrap());
            for k in 0..8 {
                t[k][((a >> (8 * k)) & 0xff) as usize] += 1;
            }
            for k in 0..8 {
                t[k][((b >> (8 * k)) & 0xff) as usize] += 1;
            }
        }
        for &v in chunks.remainder() {
            t[0][v as usize] += 1;
        }
    }
    let mut h = [0u32; 256];
    for (i, hv) in h.iter_mut().enumerate() {
        *hv = t.iter().map(|tk| tk[i]).sum();
    }
    h
}

/// Otsu's threshold: the level `T` splitting the histogram into `<= T` and `> T` with the largest
/// between-class variance (the middle of a plateau of equal maxima), and the two class means.
/// At the maximum the level lies midway between the class means (the stationarity condition),
/// which is where a blurred edge crosses its true position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Otsu {
    pub level: u8,
    pub dark_mean: f64,
    pub light_mean: f64,
}

/// `None` when the histogram has fewer than two occupied levels.
pub fn otsu(hist: &[u32; 256]) -> Option<Otsu> {
    let total: u64 = hist.iter().map(|&c| c as u64).sum();
    let sum: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &c)| i as f64 * c as f64)
        .sum();
    let mut w0 = 0u64;
    let mut sum0 = 0.0f64;
    let mut best = -1.0f64;
    let (mut lo, mut hi) = (0usize, 0usize);
    for (t, &count) in hist.iter().enumerate().take(255) {
        w0 += count as u64;
        sum0 += t as f64 * count as f64;
        if w0 == 0 {
            continue;
        }
        let w1 = total - w0;
        if w1 == 0 {
            break;
        }
        let m0 = sum0 / w0 as f64;
        let m1 = (sum - sum0) / w1 as f64;
        let between = w0 as f64 * w1 as f64 * (m0 - m1) * (m0 - m1);
        if between > best * (1.0 + 1e-12) {
            best = between;
            lo = t;
            hi = t;
        } else if between >= best * (1.0 - 1e-12) {
            hi = t;
        }
    }
    if best < 0.0 {
        return None;
    }
    let level = (lo + hi) / 2;
    let w0: u64 = hist[..=level].iter().map(|&c| c as u64).sum();
    let s0: f64 = hist[..=level]
        .iter()
        .enumerate()
        .map(|(i, &c)| i as f64 * c as f64)
        .sum();
    Some(Otsu {
        level: level as u8,
        dark_mean: s0 / w0 as f64,
        light_mean: (sum - s0) / (total - w0) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::GrayImage;

    #[test]
    fn otsu_splits_two_levels_in_the_middle_of_the_gap() {
        let mut h = [0u32; 256];
        h[40] = 100;
        h[200] = 900;
        let o = otsu(&h).unwrap();
        assert!((40..200).contains(&(o.level as usize)));
        assert_eq!(o.level, 119);
        assert_eq!(o.dark_mean, 40.0);
        assert_eq!(o.light_mean, 200.0);
        let mut flat = [0u32; 256];
        flat[77] = 10;
        assert!(otsu(&flat).is_none());
    }

    #[test]
    fn histogram_counts_every_roi_pixel_once() {
        let data: Vec<u8> = (0..37 * 11).map(|i| (i * 7 % 256) as u8).collect();
        let img = GrayImage::from_vec(37, 11, data).unwrap();
        let roi = Roi {
            x: 3,
            y: 2,
            w: 29,
            h: 7,
        };
        let h = histogram(img.view(), roi);
        let mut naive = [0u32; 256];
        for y in 2..9 {
            for x in 3..32 {
                naive[img.get(x, y) as usize] += 1;
            }
        }
        assert_eq!(h, naive);
    }
}
