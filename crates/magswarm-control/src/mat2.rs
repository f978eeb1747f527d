//! Tiny 2x2 linear algebra (row-major `[[f64; 2]; 2]`), enough for the controller's hot path
//! without an allocation or a dependency.

/// 2x2 matrix, row-major.
pub type M2 = [[f64; 2]; 2];

/// Determinant.
pub fn det(a: &M2) -> f64 {
    a[0][0] * a[1][1] - a[0][1] * a[1][0]
}

/// Matrix-vector product.
pub fn mul_v(a: &M2, x: [f64; 2]) -> [f64; 2] {
    [
        a[0][0] * x[0] + a[0][1] * x[1],
        a[1][0] * x[0] + a[1][1] * x[1],
    ]
}

/// Matrix product a b.
pub fn mul(a: &M2, b: &M2) -> M2 {
    let mut c = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
        }
    }
    c
}

/// Transpose.
pub fn t(a: &M2) -> M2 {
    [[a[0][0], a[1][0]], [a[0][1], a[1][1]]]
}

/// Inverse, `None` when singular (|det| below `1e-300`).
pub fn inv(a: &M2) -> Option<M2> {
    let d = det(a);
    if d.abs() <= 1e-300 || !d.is_finite() {
        return None;
    }
    Some([[a[1][1] / d, -a[0][1] / d], [-a[1][0] / d, a[0][0] / d]])
}

/// Singular values (largest first).
pub fn singular_values(a: &M2) -> [f64; 2] {
    // Eigenvalues of a^T a.
    let ata = mul(&t(a), a);
    let tr = ata[0][0] + ata[1][1];
    let d = det(&ata);
    let disc = (tr * tr / 4.0 - d).max(0.0).sqrt();
    let l1 = (tr / 2.0 + disc).max(0.0);
    let l2 = (tr / 2.0 - disc).max(0.0);
    [l1.sqrt(), l2.sqrt()]
}

/// Damped least-squares inverse `a^T (a a^T + lambda^2 I)^-1`: equal to the inverse when
/// `lambda = 0` and `a` is regular, bounded (by `1 / (2 lambda)`) and continuous through a
/// singular `a`.
pub fn damped_inverse(a: &M2, lambda: f64) -> M2 {
    let mut aat = mul(a, &t(a));
    aat[0][0] += lambda * lambda;
    aat[1][1] += lambda * lambda;
    match inv(&aat) {
        Some(m) => mul(&t(a), &m),
        None => [[0.0; 2]; 2],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn damped_inverse_is_the_inverse_without_damping_and_bounded_with() {
        let a = [[2.0, 1.0], [0.5, 3.0]];
        let i = inv(&a).unwrap();
        let d = damped_inverse(&a, 0.0);
        for r in 0..2 {
            for c in 0..2 {
                assert!((i[r][c] - d[r][c]).abs() < 1e-12);
            }
        }
        // Singular: bounded by 1 / (2 lambda).
        let s = [[1.0, 2.0], [2.0, 4.0]];
        let d = damped_inverse(&s, 0.1);
        let sv = singular_values(&d);
        assert!(sv[0] <= 1.0 / 0.2 + 1e-12, "{sv:?}");
        let sv = singular_values(&[[3.0, 0.0], [0.0, -2.0]]);
        assert!((sv[0] - 3.0).abs() < 1e-12 && (sv[1] - 2.0).abs() < 1e-12);
    }
}
