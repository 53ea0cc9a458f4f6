//! A closed-form plane fit for the hot loops (the sheets of [`crate::sheet`], the diagonal test of
//! [`crate::irregular`], the vertex mapping of [`crate::mapping`]).
//!
//! The covariance eigenvalues are the roots of the characteristic cubic, normalised as in the
//! trigonometric solution (Smith 1961) but found without `acos`/`cos` (a polynomial start and two
//! Newton steps, [`smallest_root`]), the normal from the largest cross product of two rows of
//! `C - l0 I`. That is
//! several times faster than the cyclic Jacobi of [`octowrap_geom::sym_eigen3`], which remains the
//! fallback when the smallest eigenvalue is (nearly) repeated and the cross products vanish.

use octowrap_geom::{DVec3, Moments, Plane, sym_eigen3};

/// The least-squares plane of the moments, as [`Moments::fit_plane`] gives it: `None` for fewer
/// than 3 points or non-finite data.
pub(crate) fn plane(m: &Moments) -> Option<Plane> {
    solve::<true>(m)
}

/// The centroid and unit normal of [`plane`], the same bits, without the two larger eigenvalues:
/// the vertex mapping needs only the plane, and the largest eigenvalue costs a `cos` (about a
/// fifth of the fit). It is still computed where the fallback test below cannot be settled
/// without it.
pub(crate) fn normal(m: &Moments) -> Option<(DVec3, DVec3)> {
    solve::<false>(m).map(|p| (p.point, p.normal))
}

/// [`plane`]; with `ALL` false, only the smallest eigenvalue is computed whenever the fallback test
/// passes without the largest one (the others are then reported as zero).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must take the fallback
fn solve<const ALL: bool>(m: &Moments) -> Option<Plane> {
    if m.count < 3.0 {
        return None;
    }
    let c = m.mean()?;
    let cov = m.covariance();
    let (a00, a01, a02) = (cov.x_axis.x, cov.y_axis.x, cov.z_axis.x);
    let (a11, a12, a22) = (cov.y_axis.y, cov.z_axis.y, cov.z_axis.z);
    let scale = [a00, a01, a02, a11, a12, a22].iter().fold(0.0f64, |s, v| s.max(v.abs()));
    if !scale.is_finite() || !c.is_finite() {
        return None;
    }
    let jacobi = || {
        let e = sym_eigen3(cov);
        e.values.iter().all(|v| v.is_finite()).then(|| Plane {
            point: c,
            normal: e.vectors[0],
            eigenvalues: e.values.map(|v| v.max(0.0)),
        })
    };
    if scale == 0.0 {
        return jacobi();
    }
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    let q = (a00 + a11 + a22) / 3.0;
    let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    if p <= 1e-9 * scale {
        return jacobi();
    }
    let (b00, b11, b22) = ((a00 - q) / p, (a11 - q) / p, (a22 - q) / p);
    let (b01, b02, b12) = (a01 / p, a02 / p, a12 / p);
    let det = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02);
    let s = (det / 2.0).clamp(-1.0, 1.0);
    let l0 = q + p * smallest_root(s);
    let r0 = DVec3::new(a00 - l0, a01, a02);
    let r1 = DVec3::new(a01, a11 - l0, a12);
    let r2 = DVec3::new(a02, a12, a22 - l0);
    let (c01, c02, c12) = (r0.cross(r1), r0.cross(r2), r1.cross(r2));
    let (d01, d02, d12) = (c01.length_squared(), c02.length_squared(), c12.length_squared());
    let (best, d) = if d01 >= d02 && d01 >= d12 {
        (c01, d01)
    } else if d02 >= d12 {
        (c02, d02)
    } else {
        (c12, d12)
    };
    // The rows span only a line when l0 is (nearly) double: the cross products vanish. The test
    // needs `l2 - l0`, which lies in [3 p, 2 sqrt(3) p] (the normalised roots are `2 cos(phi + 2 pi
    // k / 3)` with `phi` in [0, pi / 3]; rounding moves it by far less than 1e-6 p, as
    // `p > 1e-9 scale` and `|q| <= scale`): with `d` above the bound
    // for `3.5 p` the test passes for any `l2`, so the plane alone skips computing it.
    if !ALL && d > 1e-12 * (3.5 * p).powi(4) {
        return Some(Plane { point: c, normal: best / d.sqrt(), eigenvalues: [l0.max(0.0), 0.0, 0.0] });
    }
    // The largest root of the cubic is minus the smallest of the cubic with `-s`.
    let l2 = q - p * smallest_root(-s);
    let l1 = 3.0 * q - l0 - l2;
    if !(d > 1e-12 * (l2 - l0).powi(4)) || !(l2 - l0 > 0.0) {
        return jacobi();
    }
    Some(Plane { point: c, normal: best / d.sqrt(), eigenvalues: [l0.max(0.0), l1.max(0.0), l2.max(0.0)] })
}

/// The smallest root of `b^3 - 3 b - 2 s` for `s` in `[-1, 1]` (the normalised characteristic cubic
/// of the covariance: its roots are `2 cos(acos(s) / 3 + 2 pi k / 3)`), without trigonometry.
///
/// The root is `-1 - e` with `e` in `[0, 1]` the root of `e^3 + 3 e^2 = 2 w^2`, `w^2 = 1 - s`:
/// smooth in `w` (in `s`, the root has a square-root singularity at the double root `s = 1`). A
/// cubic polynomial in `w` (least-squares fit, relative error under 2e-4) starts two Newton steps
/// (relative error 2e-8, then rounding). `h(e) = e^3 + 3 e^2 - 2 w^2` is convex and increasing on
/// `e > 0`, so the steps cannot leave `(0, 1]`.
#[inline]
fn smallest_root(s: f64) -> f64 {
    let w2 = (1.0 - s).max(0.0);
    if w2 == 0.0 {
        return -1.0;
    }
    let w = w2.sqrt();
    let mut e = w
        * (0.816_496_580_927_726
            + w * (-0.109_203_646_885_705_86 + w * (0.030_202_850_638_577_8 - w * 0.005_449_653_632_357_36)));
    for _ in 0..2 {
        e -= (e * e * (e + 3.0) - 2.0 * w2) / (3.0 * e * (e + 2.0));
    }
    -1.0 - e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agrees_with_jacobi() {
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for case in 0..200 {
            let n = DVec3::new(rnd(), rnd(), rnd()).normalize();
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let thick = [0.0, 1e-6, 0.01, 0.1, 0.5][case % 5];
            let mut m = Moments::default();
            for _ in 0..50 {
                m.add(DVec3::new(3.0, -2.0, 1.0) + u * rnd() + v * rnd() * 0.7 + n * rnd() * thick);
            }
            let a = plane(&m).unwrap();
            let b = m.fit_plane().unwrap();
            for k in 0..3 {
                assert!((a.eigenvalues[k] - b.eigenvalues[k]).abs() < 1e-9, "case {case}");
            }
            if thick < 0.5 {
                assert!(a.normal.dot(b.normal).abs() > 1.0 - 1e-6, "case {case}: {:?} {:?}", a.normal, b.normal);
            }
            // The plane alone is the same bits.
            assert_eq!(normal(&m), Some((a.point, a.normal)), "case {case}");
        }
    }

    /// The trig-free root is the trigonometric one to rounding, over the whole range, including
    /// the double root (`s = 1`) and the ends.
    #[test]
    fn smallest_root_matches_the_trigonometric_solution() {
        let mut worst = 0.0f64;
        for i in 0..=20_000 {
            let s = -1.0 + f64::from(i) / 10_000.0;
            let s = if i == 19_999 { 1.0 - f64::EPSILON } else { s };
            let trig = 2.0 * (s.acos() / 3.0 + 2.0 * std::f64::consts::FRAC_PI_3).cos();
            let b = smallest_root(s);
            assert!((-2.0..=-1.0).contains(&b), "s {s}: {b}");
            // A root of the cubic, to rounding.
            assert!((b * b * b - 3.0 * b - 2.0 * s).abs() < 1e-14, "s {s}: {b}");
            worst = worst.max((b - trig).abs());
            let largest = -smallest_root(-s);
            let trig_largest = 2.0 * (s.acos() / 3.0).cos();
            worst = worst.max((largest - trig_largest).abs());
            // Away from the double roots, to a few units in the last place.
            if s.abs() < 0.99 {
                assert!((b - trig).abs() < 1e-14 && (largest - trig_largest).abs() < 1e-14, "s {s}");
            }
        }
        // Near the double root the trigonometric form itself loses digits (like `sqrt(1 - s)`).
        assert!(worst < 1e-7, "{worst}");
        assert_eq!(smallest_root(1.0).to_bits(), (-1.0f64).to_bits());
        assert!((smallest_root(-1.0) + 2.0).abs() < 1e-15);
    }
}
