//! Emulated camera: renders the swarm as the real camera would film it from below, from radii
//! given by a model (a closure or a [`SharedSwarm`] the bridge's emulator updates).
//!
//! The swarm is an ellipse with semi-axes r1 <= r2 (mm, converted with `mm_per_px`) whose r2
//! axis turns at the rate omega; it is filled with particles (dark dots on a slightly lighter
//! interstitial level, moving with the swarm), its edge is blurred by a Gaussian point-spread
//! function, and the sensor adds Gaussian noise. Frames come at `fps`, in real time or as fast as
//! they are asked for.

use crate::camera::{sleep_until, Camera, CameraError, Frame};
use crate::image::GrayImage;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What the swarm looks like now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwarmState {
    /// Semi-axes in mm (the smaller is drawn as r1 whatever the order).
    pub r1_mm: f64,
    pub r2_mm: f64,
    /// Rotation rate of the swarm's axes in rad/s (positive: from +x towards +y).
    pub omega_rad_s: f64,
}

/// A swarm state shared between the model that drives it and the camera that films it.
#[derive(Clone, Debug)]
pub struct SharedSwarm(Arc<Mutex<SwarmState>>);

impl SharedSwarm {
    pub fn new(s: SwarmState) -> Self {
        SharedSwarm(Arc::new(Mutex::new(s)))
    }
    pub fn set(&self, s: SwarmState) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = s;
    }
    pub fn get(&self) -> SwarmState {
        *self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
    /// A source closure for [`EmulatedCamera::new`].
    pub fn source(&self) -> impl FnMut(f64) -> SwarmState + Send + 'static {
        let s = self.clone();
        move |_t| s.get()
    }
}

/// How the emulated camera images the swarm.
#[derive(Clone, Debug, PartialEq)]
pub struct EmulatorConfig {
    pub width: usize,
    pub height: usize,
    pub mm_per_px: f64,
    pub fps: f64,
    /// true: frame k is delivered at t0 + k / fps; false: as fast as asked (t_s still k / fps).
    pub realtime: bool,
    /// Swarm centre in pixels (default: the frame centre).
    pub center_px: Option<(f64, f64)>,
    /// Angle of the r2 axis at t = 0, degrees.
    pub angle0_deg: f64,
    pub swarm_level: u8,
    pub background_level: u8,
    /// Lighter level between particles, added to `swarm_level` (0: a uniform swarm).
    pub texture: u8,
    /// Particle dot radius in pixels.
    pub particle_radius_px: f64,
    pub blur_sigma_px: f64,
    pub noise_sigma: f64,
    /// Small dark specks (radius 2 to 5 px) at fixed random places (debris on the reservoir
    /// floor), away from a centred swarm.
    pub debris: usize,
    pub seed: u64,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        EmulatorConfig {
            width: 1920,
            height: 1200,
            mm_per_px: 0.05,
            fps: 50.0,
            realtime: true,
            center_px: None,
            angle0_deg: 0.0,
            swarm_level: 50,
            background_level: 200,
            texture: 40,
            particle_radius_px: 2.5,
            blur_sigma_px: 1.2,
            noise_sigma: 4.0,
            debris: 3,
            seed: 1,
        }
    }
}

/// Renders swarm frames (used by [`EmulatedCamera`]; usable on its own to make test frames).
pub struct SwarmRenderer {
    cfg: EmulatorConfig,
    /// Particle positions in the unit disc, body frame (x along r2).
    particles: Vec<(f32, f32)>,
    noise: Vec<i16>,
    debris: Vec<(f64, f64, f64)>,
    rng: rand::rngs::SmallRng,
    density: Vec<f32>,
}

impl SwarmRenderer {
    pub fn new(cfg: EmulatorConfig) -> Self {
        let mut rng = rand::rngs::SmallRng::seed_from_u64(cfg.seed);
        // enough particles for the largest swarm that fits the frame
        let rmax = 0.5 * cfg.width.min(cfg.height) as f64;
        let rp = cfg.particle_radius_px.max(0.5);
        let n = ((rmax * rmax) / (rp * rp) * 0.9).clamp(100.0, 60_000.0) as usize;
        let mut particles = Vec::with_capacity(n);
        while particles.len() < n {
            let x: f32 = rng.random_range(-1.0..1.0);
            let y: f32 = rng.random_range(-1.0..1.0);
            if x * x + y * y <= 1.0 {
                particles.push((x, y));
            }
        }
        let normal = Normal::new(0.0, cfg.noise_sigma.max(0.0)).unwrap();
        // 2^16 samples plus one row more, so any row can read a contiguous slice
        let noise = (0..(1 << 16) + cfg.width)
            .map(|_| {
                if cfg.noise_sigma > 0.0 {
                    normal.sample(&mut rng).round().clamp(-255.0, 255.0) as i16
                } else {
                    0
                }
            })
            .collect();
        let debris = (0..cfg.debris)
            .map(|_| {
                // in the outer band of the frame, away from a centred swarm
                let x = if rng.random::<bool>() {
                    rng.random_range(0.03..0.12)
                } else {
                    rng.random_range(0.88..0.97)
                } * cfg.width as f64;
                let y = rng.random_range(0.05..0.95) * cfg.height as f64;
                (x, y, rng.random_range(2.0..5.0))
            })
            .collect();
        SwarmRenderer {
            cfg,
            particles,
            noise,
            debris,
            rng,
            density: Vec::new(),
        }
    }

    pub fn config(&self) -> &EmulatorConfig {
        &self.cfg
    }

    /// One frame: semi-axes `r1_px <= r2_px` (swapped if not), r2 axis at `angle_rad`.
    pub fn render(&mut self, r1_px: f64, r2_px: f64, angle_rad: f64) -> GrayImage {
        let (r1, r2) = if r1_px <= r2_px {
            (r1_px, r2_px)
        } else {
            (r2_px, r1_px)
        };
        let c = &self.cfg;
        let (w, h) = (c.width, c.height);
        let (cx, cy) = c
            .center_px
            .unwrap_or(((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0));
        let mut img = GrayImage::filled(w, h, c.background_level);
        let sigma = c.blur_sigma_px.max(0.35);

        // debris: blurred dark discs at fixed places
        let debris = self.debris.clone();
        for (x, y, r) in debris {
            self.shade_ellipse(&mut img, x, y, r, r, 0.0, sigma, None);
        }
        if r1 > 0.5 && r2 > 0.5 {
            // particle density map over the swarm's bounding box
            let rp = c.particle_radius_px.max(0.5);
            let frac = if c.texture > 0 {
                let n = ((r1 * r2) / (rp * rp)).ceil() as usize;
                n.min(self.particles.len())
            } else {
                0
            };
            let bx0 = (cx - r2 - 4.0 * sigma - 2.0).floor().max(0.0) as usize;
            let by0 = (cy - r2 - 4.0 * sigma - 2.0).floor().max(0.0) as usize;
            let bx1 = ((cx + r2 + 4.0 * sigma + 2.0).ceil() as usize).min(w);
            let by1 = ((cy + r2 + 4.0 * sigma + 2.0).ceil() as usize).min(h);
            let bw = bx1.saturating_sub(bx0);
            let bh = by1.saturating_sub(by0);
            self.density.clear();
            self.density.resize(bw * bh, 0.0);
            let (s, co) = angle_rad.sin_cos();
            for &(px, py) in &self.particles[..frac] {
                let u = px as f64 * r2;
                let v = py as f64 * r1;
                let x = cx + co * u - s * v;
                let y = cy + s * u + co * v;
                let ix0 = ((x - rp).floor().max(bx0 as f64)) as usize;
                let iy0 = ((y - rp).floor().max(by0 as f64)) as usize;
                let ix1 = ((x + rp).ceil() as usize).min(bx1.saturating_sub(1));
                let iy1 = ((y + rp).ceil() as usize).min(by1.saturating_sub(1));
                for iy in iy0..=iy1 {
                    for ix in ix0..=ix1 {
                        let d2 = (ix as f64 - x).powi(2) + (iy as f64 - y).powi(2);
                        if d2 <= rp * rp {
                            self.density[(iy - by0) * bw + (ix - bx0)] = 1.0;
                        }
                    }
                }
            }
            let box_ = (bx0, by0, bw, bh);
            self.shade_ellipse(&mut img, cx, cy, r1, r2, angle_rad, sigma, Some(box_));
        }
        // sensor noise: a Gaussian table read from a random offset per row
        if c.noise_sigma > 0.0 {
            for y in 0..h {
                let off: usize = self.rng.random_range(0..1usize << 16);
                let noise = &self.noise[off..off + w];
                for (p, &n) in img.row_mut(y).iter_mut().zip(noise) {
                    *p = (*p as i16 + n).clamp(0, 255) as u8;
                }
            }
        }
        img
    }

    /// Darkens an ellipse (semi-axes a = r2 along `angle`, b = r1) with a Gaussian-blurred edge;
    /// inside, the level is the swarm level, lightened between particles when a density map is
    /// given (box: x0, y0, w, h of the map).
    #[allow(clippy::too_many_arguments)]
    fn shade_ellipse(
        &self,
        img: &mut GrayImage,
        cx: f64,
        cy: f64,
        r1: f64,
        r2: f64,
        angle: f64,
        sigma: f64,
        density: Option<(usize, usize, usize, usize)>,
    ) {
        let c = &self.cfg;
        let (w, h) = (img.width(), img.height());
        let reach = r2 + 5.0 * sigma + 1.0;
        let x0 = (cx - reach).floor().max(0.0) as usize;
        let y0 = (cy - reach).floor().max(0.0) as usize;
        let x1 = ((cx + reach).ceil().max(0.0) as usize).min(w);
        let y1 = ((cy + reach).ceil().max(0.0) as usize).min(h);
        let (s, co) = angle.sin_cos();
        let (ia2, ib2) = (1.0 / (r2 * r2), 1.0 / (r1 * r1));
        let bg = c.background_level as f64;
        let dark = c.swarm_level as f64;
        let tex = c.texture as f64;
        // q below this: deeper than 6 sigma inside the boundary (full coverage, no edge maths)
        let q_in = (1.0 - (6.0 * sigma + 1.0) / r1).max(0.0).powi(2);
        // q above this: further than the blur reaches outside; per row, the columns inside it
        // solve a quadratic: qa dx^2 + qb dy dx + qc dy^2 = q_out
        let q_out = (1.0 + (5.0 * sigma + 2.0) / r1).powi(2);
        let qa = co * co * ia2 + s * s * ib2;
        let qb = 2.0 * co * s * (ia2 - ib2);
        let qc = s * s * ia2 + co * co * ib2;
        for y in y0..y1 {
            let dy = y as f64 - cy;
            let disc = (qb * dy).powi(2) - 4.0 * qa * (qc * dy * dy - q_out);
            if disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            let xa = (cx + (-qb * dy - sq) / (2.0 * qa)).floor().max(x0 as f64) as usize;
            let xb = ((cx + (-qb * dy + sq) / (2.0 * qa)).ceil() + 1.0).max(0.0) as usize;
            let xb = xb.min(x1);
            let row = img.row_mut(y);
            for (x, p) in row.iter_mut().enumerate().take(xb).skip(xa) {
                let dx = x as f64 - cx;
                let u = co * dx + s * dy;
                let v = -s * dx + co * dy;
                let q = u * u * ia2 + v * v * ib2;
                let cover = if q < q_in {
                    1.0
                } else {
                    // signed distance to the boundary, first order: (q - 1) / |grad q|
                    let g = 2.0 * ((u * ia2).powi(2) + (v * ib2).powi(2)).sqrt();
                    let d = if g > 0.0 { (q - 1.0) / g } else { -r1 };
                    if d > 5.0 * sigma {
                        continue;
                    }
                    phi(-d / sigma)
                };
                let inner = match density {
                    Some((bx, by, bw, bh)) if x >= bx && y >= by && x < bx + bw && y < by + bh => {
                        dark + tex * (1.0 - self.density[(y - by) * bw + (x - bx)] as f64)
                    }
                    _ => dark,
                };
                let base = (*p as f64).min(bg);
                let v = base + (inner - bg) * cover;
                *p = v.round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

/// Standard normal CDF (Abramowitz & Stegun 7.1.26 for erf, |error| < 1.5e-7).
fn phi(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    if z >= 0.0 {
        0.5 * (1.0 + y)
    } else {
        0.5 * (1.0 - y)
    }
}

type Source = Box<dyn FnMut(f64) -> SwarmState + Send>;

/// A camera that films the swarm given by `source(t_s)`.
pub struct EmulatedCamera {
    renderer: SwarmRenderer,
    source: Source,
    t0: Option<Instant>,
    seq: u64,
    angle: f64,
    last_t: f64,
}

impl EmulatedCamera {
    /// `source` is called once per frame with the frame's t_s and returns the swarm to draw.
    pub fn new(
        cfg: EmulatorConfig,
        source: impl FnMut(f64) -> SwarmState + Send + 'static,
    ) -> Self {
        let angle = cfg.angle0_deg.to_radians();
        EmulatedCamera {
            renderer: SwarmRenderer::new(cfg),
            source: Box::new(source),
            t0: None,
            seq: 0,
            angle,
            last_t: 0.0,
        }
    }

    pub fn config(&self) -> &EmulatorConfig {
        self.renderer.config()
    }
}

impl Camera for EmulatedCamera {
    fn start(&mut self, t0: Instant) -> Result<(), CameraError> {
        self.t0 = Some(t0);
        Ok(())
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError> {
        let cfg = self.renderer.config().clone();
        if !(cfg.fps > 0.0 && cfg.fps.is_finite() && cfg.mm_per_px > 0.0) {
            return Err(CameraError::Device(format!(
                "emulated camera: fps ({}) and mm_per_px ({}) must be positive",
                cfg.fps, cfg.mm_per_px
            )));
        }
        let now = Instant::now();
        let t0 = *self.t0.get_or_insert(now);
        let t_s = self.seq as f64 / cfg.fps;
        if cfg.realtime {
            let due = t0 + Duration::from_secs_f64(t_s);
            if due > now + timeout {
                sleep_until(now + timeout);
                return Err(CameraError::Timeout(timeout));
            }
        }
        let st = (self.source)(t_s);
        self.angle += st.omega_rad_s * (t_s - self.last_t);
        self.angle = self.angle.rem_euclid(2.0 * std::f64::consts::PI);
        self.last_t = t_s;
        let image = self.renderer.render(
            st.r1_mm / cfg.mm_per_px,
            st.r2_mm / cfg.mm_per_px,
            self.angle,
        );
        if cfg.realtime {
            sleep_until(t0 + Duration::from_secs_f64(t_s));
        }
        let seq = self.seq;
        self.seq += 1;
        Ok(Frame {
            seq,
            t_s,
            arrived: Instant::now(),
            image,
            name: None,
        })
    }

    fn describe(&self) -> String {
        let c = self.renderer.config();
        format!(
            "emulated camera: {}x{} px at {} fps, {} mm/px, blur {} px, noise {} gray levels",
            c.width, c.height, c.fps, c.mm_per_px, c.blur_sigma_px, c.noise_sigma
        )
    }
}
