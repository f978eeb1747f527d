//! Counter-based random draws, implemented identically in `examples/sweep_dask.py`.
//!
//! Every number is a pure function of (seed, run, parameter index): no generator state, so
//! any run can be computed on any thread or machine, in any order, and Rust and Python agree
//! bit for bit (integer arithmetic modulo 2^64, then IEEE operations and libm's `log`, `cos`
//! and `sqrt`, which both languages take from the platform's C library).
//!
//! ```text
//! splitmix64(x): x += 0x9E3779B97F4A7C15; z = x;
//!                z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9;
//!                z = (z ^ (z >> 27)) * 0x94D049BB133111EB;
//!                return z ^ (z >> 31)                          (all mod 2^64)
//! bits(seed, run, j)  = splitmix64(splitmix64(splitmix64(seed) ^ run) ^ j)
//! uniform(seed, run, j) = ((bits >> 11) + 0.5) / 2^53           in (0, 1), never 0 or 1
//! normal(seed, run, i)  = sqrt(-2 ln u1) cos(2 pi u2),  u1 = uniform(.., 2 i), u2 = uniform(.., 2 i + 1)
//! ```
//!
//! Parameter `i` of run `run` uses `uniform(seed, run, 2 i)` for a range and `normal(seed, run, i)`
//! for a covariance.

/// SplitMix64's output function (Steele, Lea, Flood 2014), one step from state `x`.
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 64 random bits for (seed, run, stream j).
pub fn bits(seed: u64, run: u64, j: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(seed) ^ run) ^ j)
}

/// A uniform number in (0, 1) for (seed, run, stream j).
pub fn uniform(seed: u64, run: u64, j: u64) -> f64 {
    ((bits(seed, run, j) >> 11) as f64 + 0.5) * (1.0 / 9_007_199_254_740_992.0)
}

/// A standard normal number for (seed, run, parameter i) (Box-Muller, cosine branch).
pub fn normal(seed: u64, run: u64, i: u64) -> f64 {
    let u1 = uniform(seed, run, 2 * i);
    let u2 = uniform(seed, run, 2 * i + 1);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Lower Cholesky factor of a symmetric positive semi-definite matrix (row-major, n x n), by
/// the textbook loop (the same loop, in the same order, as the Python side). Pivots below
/// 1e-300 (a degenerate direction) give a zero column instead of a failure.
pub fn cholesky(a: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, String> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        if a[i].len() != n {
            return Err(format!(
                "covariance row {i} has {} entries, expected {n}",
                a[i].len()
            ));
        }
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s < -1e-12 * a[i][i].abs().max(1e-300) {
                    return Err(format!(
                        "covariance is not positive semi-definite (pivot {i} = {s:e})"
                    ));
                }
                l[i][i] = if s > 1e-300 { s.sqrt() } else { 0.0 };
            } else {
                l[i][j] = if l[j][j] > 0.0 { s / l[j][j] } else { 0.0 };
            }
        }
    }
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_reference_values() {
        // First outputs of the reference SplitMix64 generator seeded with 0 (state advances
        // by the golden gamma each call): splitmix64(k * gamma) for k = 0, 1, 2.
        assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
        assert_eq!(splitmix64(0x9E37_79B9_7F4A_7C15), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(
            splitmix64(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(2)),
            0x06C4_5D18_8009_454F
        );
    }

    #[test]
    fn uniforms_are_in_the_open_interval_and_normals_have_unit_variance() {
        let n = 20_000u64;
        let (mut s, mut s2) = (0.0, 0.0);
        for r in 0..n {
            let u = uniform(7, r, 3);
            assert!(u > 0.0 && u < 1.0);
            let z = normal(7, r, 1);
            s += z;
            s2 += z * z;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var - 1.0).abs() < 0.04, "variance {var}");
    }

    #[test]
    fn cholesky_reproduces_the_matrix() {
        let a = vec![
            vec![4.0, 2.0, 0.4],
            vec![2.0, 5.0, 1.0],
            vec![0.4, 1.0, 3.0],
        ];
        let l = cholesky(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| l[i][k] * l[j][k]).sum();
                assert!((v - a[i][j]).abs() < 1e-12);
            }
        }
        assert!(cholesky(&[vec![1.0, 2.0], vec![2.0, 1.0]]).is_err());
    }
}
