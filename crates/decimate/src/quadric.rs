//! Error quadrics (Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics",
//! SIGGRAPH 1997, §5 and §6.1): the weighted sum of squared distances to a set of planes, as a
//! symmetric 4x4 matrix stored by its 10 distinct coefficients, plus the total weight so that the
//! error can be read as a weighted *mean* squared distance (as meshoptimizer does).

use octowrap_geom::DVec3;

/// `Σ wᵢ (nᵢ·p + dᵢ)²` as `pᵀ A p + 2 b·p + c`, with `w = Σ wᵢ`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Quadric {
    /// `A` = `[xx xy xz; xy yy yz; xz yz zz]`.
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
    w: f64,
}

impl Quadric {
    /// The plane `n·p + d = 0` (`n` unit) with weight `w`.
    pub(crate) fn plane(n: DVec3, d: f64, w: f64) -> Self {
        Self {
            a: [w * n.x * n.x, w * n.x * n.y, w * n.x * n.z, w * n.y * n.y, w * n.y * n.z, w * n.z * n.z],
            b: [w * n.x * d, w * n.y * d, w * n.z * d],
            c: w * d * d,
            w,
        }
    }

    /// The plane through `p` with unit normal `n`, weight `w`.
    pub(crate) fn plane_through(p: DVec3, n: DVec3, w: f64) -> Self {
        Self::plane(n, -n.dot(p), w)
    }

    /// The total weight.
    pub(crate) fn weight(&self) -> f64 {
        self.w
    }

    /// Adds `o` to `self`.
    pub(crate) fn add(&mut self, o: &Self) {
        for (x, y) in self.a.iter_mut().zip(o.a) {
            *x += y;
        }
        for (x, y) in self.b.iter_mut().zip(o.b) {
            *x += y;
        }
        self.c += o.c;
        self.w += o.w;
    }

    /// `self + o`.
    pub(crate) fn sum(&self, o: &Self) -> Self {
        let mut s = *self;
        s.add(o);
        s
    }

    /// The weighted sum of squared distances at `p`.
    fn eval(&self, p: DVec3) -> f64 {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let (x, y, z) = (p.x, p.y, p.z);
        x * (xx * x + 2.0 * (xy * y + xz * z + self.b[0]))
            + y * (yy * y + 2.0 * (yz * z + self.b[1]))
            + z * (zz * z + 2.0 * self.b[2])
            + self.c
    }

    /// The weighted mean squared distance at `p` (0 for an empty quadric).
    pub(crate) fn error(&self, p: DVec3) -> f64 {
        let e = if self.w > 0.0 { self.eval(p) / self.w } else { 0.0 };
        // Never -0.0 or NaN-free negatives: callers sort errors by their bit patterns.
        if e > 0.0 { e } else { 0.0 }
    }

    /// The point minimizing the quadric, when the system is well conditioned: with the weights
    /// normalized, `trace(A / w) = 1`, and a determinant below `1e-9` means the planes nearly share
    /// a direction (flat or cylindrical regions), where the minimum is a line or plane of points.
    pub(crate) fn optimum(&self) -> Option<DVec3> {
        if self.w <= 0.0 {
            return None;
        }
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let (r0, r1, r2) = (DVec3::new(xx, xy, xz), DVec3::new(xy, yy, yz), DVec3::new(xz, yz, zz));
        // A is symmetric: its inverse is the cofactor matrix (rows r1 x r2, r2 x r0, r0 x r1) over
        // the determinant; det(A / w) = det(A) / w³.
        let (c0, c1, c2) = (r1.cross(r2), r2.cross(r0), r0.cross(r1));
        let det = r0.dot(c0);
        if det.is_nan() || det.abs() <= 1e-9 * self.w * self.w * self.w {
            return None;
        }
        let p = -(c0 * self.b[0] + c1 * self.b[1] + c2 * self.b[2]) / det;
        p.is_finite().then_some(p)
    }

    /// The point of segment `a..b` minimizing the quadric.
    pub(crate) fn segment_optimum(&self, a: DVec3, b: DVec3) -> DVec3 {
        // e(t) = e(a + t d) is quadratic in t: e(t) = e(a) + 2 t g + t² h.
        let d = b - a;
        let [xx, xy, xz, yy, yz, zz] = self.a;
        let ad =
            DVec3::new(xx * d.x + xy * d.y + xz * d.z, xy * d.x + yy * d.y + yz * d.z, xz * d.x + yz * d.y + zz * d.z);
        let h = d.dot(ad);
        let g = a.dot(ad) + DVec3::from(self.b).dot(d);
        let t = if h > 0.0 {
            (-g / h).clamp(0.0, 1.0)
        } else if self.eval(b) < self.eval(a) {
            1.0
        } else {
            0.0
        };
        a + d * t
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact results are expected
mod tests {
    use super::*;

    #[test]
    fn three_planes_meet_at_their_corner() {
        let mut q = Quadric::plane_through(DVec3::new(1.0, 0.0, 0.0), DVec3::X, 1.0);
        q.add(&Quadric::plane_through(DVec3::new(0.0, 2.0, 0.0), DVec3::Y, 2.0));
        q.add(&Quadric::plane_through(DVec3::new(0.0, 0.0, 3.0), DVec3::Z, 3.0));
        let p = q.optimum().unwrap();
        assert!((p - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!(q.error(p) < 1e-20);
        // Distance 1 from all three planes: mean squared distance 1.
        assert!((q.error(DVec3::new(2.0, 3.0, 4.0)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_single_plane_has_no_unique_optimum() {
        let q = Quadric::plane_through(DVec3::ZERO, DVec3::Z, 1.0);
        assert!(q.optimum().is_none());
        let p = q.segment_optimum(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -3.0));
        assert!(p.z.abs() < 1e-12);
        assert_eq!(Quadric::default().error(DVec3::ONE), 0.0);
    }
}
