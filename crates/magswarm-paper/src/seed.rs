//! The seed's reported figures, in one place. Section references are to the seed paper
//! ("Physics-Based Reduced-Order Modeling of Magnetic Microparticle Swarms for Biomedical
//! Control", `../shared/seed/000_150bc7726678dff6.txt`).

/// Median of the fitted S_x over the experimental conditions (Table I, "Median Stiffness").
pub const MEDIAN_S_X: f64 = 0.393;
/// Median of the fitted S_y over the experimental conditions (Table I, "Median Stiffness").
pub const MEDIAN_S_Y: f64 = 2.455;
/// Stiffness anisotropy S_x/S_y (Abstract; Sec. III-C d; Sec. IV a). Read here as the ratio
/// of the two medians (0.393/2.455 = 0.160).
pub const S_RATIO: f64 = 0.16;
/// Near-isotropy of the squared-field curvature, k_xx/k_yy (Sec. III-C d).
pub const K_RATIO: f64 = 1.04;
/// Range (max - min) of r1 over the data \[mm\] (Sec. III-C d, "range 2.02 mm").
pub const R1_RANGE_MM: f64 = 2.02;
/// Range (max - min) of r2 over the data \[mm\] (Sec. III-C d, "range 5.66 mm").
pub const R2_RANGE_MM: f64 = 5.66;
/// Closed-loop model predictions (r1, r2) \[mm\] at the three PID operating points
/// (Sec. III-D a): "r1 = 7.61, 8.14, 8.50 mm and r2 = 10.43, 11.23, 11.70 mm".
pub const CLOSED_LOOP_MM: [(f64, f64); 3] = [(7.61, 10.43), (8.14, 11.23), (8.50, 11.70)];
/// Collapse of the medians onto Phi: "within 5-10 % across most bins" (Sec. III-C c);
/// the upper end, as a fraction.
pub const COLLAPSE_TOL: f64 = 0.10;
/// Validation RMSE of r1 \[mm\] (Table I), used as the noise of the synthetic collapse.
pub const RMSE_R1_MM: f64 = 0.248;
/// Validation RMSE of r2 \[mm\] (Table I), used as the noise of the synthetic collapse.
pub const RMSE_R2_MM: f64 = 0.415;
/// Repeated measurements per operating point (Sec. III-C).
pub const REPEATS: usize = 10;
