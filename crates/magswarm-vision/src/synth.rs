//! Synthetic frames with a known truth, for tests, benches and demos: an ellipse rendered by
//! exact-area sampling (16x16 sub-pixels on the boundary), blurred by a Gaussian point-spread
//! function (separable convolution) and overlaid with Gaussian sensor noise.

use crate::image::GrayImage;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// An ellipse and how it is imaged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipseSpec {
    /// Centre, pixel-centre coordinates (x right, y down).
    pub cx: f64,
    pub cy: f64,
    /// Semi-axes in pixels, `r1 <= r2`.
    pub r1: f64,
    pub r2: f64,
    /// Angle of the r2 axis from +x towards +y, degrees.
    pub angle_deg: f64,
    /// Gray level of the swarm and of the background.
    pub swarm: u8,
    pub background: u8,
    /// Gaussian blur (point-spread function) standard deviation in pixels; 0: none.
    pub blur_sigma_px: f64,
    /// Additive Gaussian noise standard deviation in gray levels; 0: none.
    pub noise_sigma: f64,
}

impl EllipseSpec {
    /// Implicit form: < 1 inside.
    fn q(&self, x: f64, y: f64) -> f64 {
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let dx = x - self.cx;
        let dy = y - self.cy;
        let u = c * dx + s * dy; // along r2
        let v = -s * dx + c * dy; // along r1
        (u / self.r2).powi(2) + (v / self.r1).powi(2)
    }
}

/// Renders `spec` into a `width` x `height` frame; `seed` fixes the noise.
pub fn ellipse_frame(width: usize, height: usize, spec: &EllipseSpec, seed: u64) -> GrayImage {
    let mut cover = vec![0f32; width * height];
    add_ellipse_coverage(&mut cover, width, height, spec, 1.0);
    finish(
        width,
        height,
        cover,
        spec.swarm,
        spec.background,
        spec.blur_sigma_px,
        spec.noise_sigma,
        seed,
    )
}

/// Coverage (0..1 of each pixel's area) of the ellipse, added into `cover`.
pub fn add_ellipse_coverage(
    cover: &mut [f32],
    width: usize,
    height: usize,
    spec: &EllipseSpec,
    weight: f32,
) {
    const SUB: usize = 16;
    let rmax = spec.r2 + 2.0;
    let x0 = ((spec.cx - rmax).floor().max(0.0)) as usize;
    let x1 = ((spec.cx + rmax).ceil().min(width as f64 - 1.0)).max(0.0) as usize;
    let y0 = ((spec.cy - rmax).floor().max(0.0)) as usize;
    let y1 = ((spec.cy + rmax).ceil().min(height as f64 - 1.0)).max(0.0) as usize;
    // a pixel is fully inside/outside when its corners' q values agree and it is far from the
    // boundary: test the q of the centre against a band
    let band = 1.5 / spec.r1; // in units of the normalised radius
    for y in y0..=y1 {
        for x in x0..=x1 {
            let qc = spec.q(x as f64, y as f64).sqrt();
            let c = if qc < 1.0 - band {
                1.0
            } else if qc > 1.0 + band {
                0.0
            } else {
                let mut n = 0;
                for sy in 0..SUB {
                    for sx in 0..SUB {
                        let px = x as f64 - 0.5 + (sx as f64 + 0.5) / SUB as f64;
                        let py = y as f64 - 0.5 + (sy as f64 + 0.5) / SUB as f64;
                        if spec.q(px, py) < 1.0 {
                            n += 1;
                        }
                    }
                }
                n as f32 / (SUB * SUB) as f32
            };
            cover[y * width + x] += weight * c;
        }
    }
}

/// Blur a coverage map, map it to gray levels, add noise, quantise.
#[allow(clippy::too_many_arguments)]
pub fn finish(
    width: usize,
    height: usize,
    mut cover: Vec<f32>,
    swarm: u8,
    background: u8,
    blur_sigma_px: f64,
    noise_sigma: f64,
    seed: u64,
) -> GrayImage {
    if blur_sigma_px > 0.0 {
        gaussian_blur(&mut cover, width, height, blur_sigma_px);
    }
    let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_sigma.max(0.0)).unwrap();
    let (s, b) = (swarm as f64, background as f64);
    let data = cover
        .iter()
        .map(|&c| {
            let c = (c as f64).clamp(0.0, 1.0);
            let mut v = b + (s - b) * c;
            if noise_sigma > 0.0 {
                v += noise.sample(&mut rng);
            }
            v.round().clamp(0.0, 255.0) as u8
        })
        .collect();
    GrayImage::from_vec(width, height, data).unwrap()
}

/// Separable Gaussian blur with edge clamping, kernel radius ceil(4 sigma).
pub fn gaussian_blur(img: &mut [f32], width: usize, height: usize, sigma: f64) {
    let r = (4.0 * sigma).ceil() as isize;
    let k: Vec<f32> = (-r..=r)
        .map(|i| (-(i as f64).powi(2) / (2.0 * sigma * sigma)).exp() as f32)
        .collect();
    let ksum: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|v| v / ksum).collect();
    let mut tmp = vec![0f32; img.len()];
    let clampi = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    for y in 0..height {
        let row = &img[y * width..(y + 1) * width];
        for x in 0..width {
            let mut acc = 0f32;
            for (j, kv) in k.iter().enumerate() {
                acc += kv * row[clampi(x as isize + j as isize - r, width)];
            }
            tmp[y * width + x] = acc;
        }
    }
    for y in 0..height {
        for x in 0..width {
            let mut acc = 0f32;
            for (j, kv) in k.iter().enumerate() {
                acc += kv * tmp[clampi(y as isize + j as isize - r, height) * width + x];
            }
            img[y * width + x] = acc;
        }
    }
}
