//! Eigen-decomposition of symmetric 3x3 matrices by the cyclic Jacobi method
//! (Golub & Van Loan, *Matrix Computations*, 4th ed., §8.5.2).
//!
//! Jacobi is slower than a closed-form cubic solve but accurate for nearly repeated eigenvalues,
//! which is the common case for flat point neighbourhoods (two large, one tiny eigenvalue).

use glam::{DMat3, DVec3};

/// Eigenvalues in ascending order with their unit eigenvectors (`vectors[i]` belongs to `values[i]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymEigen3 {
    /// Eigenvalues, ascending.
    pub values: [f64; 3],
    /// Unit eigenvectors, a right-handed orthonormal frame.
    pub vectors: [DVec3; 3],
}

/// Decomposes the symmetric matrix `m` (only its upper triangle is read).
///
/// Non-finite input gives non-finite output; callers check [`f64::is_finite`] on the values.
#[allow(clippy::needless_range_loop)] // index form mirrors the rotation formulas
pub fn sym_eigen3(m: DMat3) -> SymEigen3 {
    // a[i][j] = row i, column j.
    let mut a = [
        [m.x_axis.x, m.y_axis.x, m.z_axis.x],
        [m.y_axis.x, m.y_axis.y, m.z_axis.y],
        [m.z_axis.x, m.z_axis.y, m.z_axis.z],
    ];
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= diag * 1e-30 || !off.is_finite() {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A' = J^T A J with J the rotation in the (p, q) plane.
            for k in 0..3 {
                let akp = a[k][p];
                let akq = a[k][q];
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let apk = a[p][k];
                let aqk = a[q][k];
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let col = |j: usize| DVec3::new(v[0][j], v[1][j], v[2][j]);
    let e0 = col(order[0]);
    let e1 = col(order[1]);
    // Make the frame right-handed and exactly orthonormal.
    let e2 = e0.cross(e1);
    SymEigen3 { values: [a[order[0]][order[0]], a[order[1]][order[1]], a[order[2]][order[2]]], vectors: [e0, e1, e2] }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(m: DMat3) {
        let e = sym_eigen3(m);
        assert!(e.values[0] <= e.values[1] && e.values[1] <= e.values[2]);
        let scale = m.to_cols_array().iter().fold(1e-300_f64, |s, x| s.max(x.abs()));
        for i in 0..3 {
            let v = e.vectors[i];
            assert!((v.length() - 1.0).abs() < 1e-9, "not unit: {v}");
            let r = m * v - v * e.values[i];
            assert!(r.length() <= 1e-9 * scale, "residual {r} for {m:?}");
        }
    }

    #[test]
    fn diagonal_and_repeated() {
        check(DMat3::from_diagonal(DVec3::new(3.0, 1.0, 2.0)));
        check(DMat3::IDENTITY);
        check(DMat3::ZERO);
        let e = sym_eigen3(DMat3::from_diagonal(DVec3::new(3.0, 1.0, 2.0)));
        assert_eq!(e.values, [1.0, 2.0, 3.0]);
        assert!((e.vectors[0].y.abs() - 1.0).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn random_symmetric(a in -1e3f64..1e3, b in -1e3f64..1e3, c in -1e3f64..1e3,
                            d in -1e3f64..1e3, e in -1e3f64..1e3, f in -1e3f64..1e3) {
            check(DMat3::from_cols(DVec3::new(a, b, c), DVec3::new(b, d, e), DVec3::new(c, e, f)));
        }
    }
}
