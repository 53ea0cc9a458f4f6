//! Point moments and least-squares plane fitting (principal component analysis), the plane fit
//! of the paper's vertex mapping (Keller et al., §3.6).

use glam::{DMat3, DVec3};

use crate::eigen::sym_eigen3;

/// Running first and second moments of a point set: enough to fit a plane, and additive, so the
/// moments of a cell's children sum to the cell's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Number of points (a weight sum when points are weighted).
    pub count: f64,
    /// Sum of the points.
    pub sum: DVec3,
    /// Sum of `p p^T` (upper triangle: xx, xy, xz, yy, yz, zz).
    pub outer: [f64; 6],
}

impl Moments {
    /// Adds one point with weight 1.
    pub fn add(&mut self, p: DVec3) {
        self.add_weighted(p, 1.0);
    }

    /// Adds one point with weight `w`.
    pub fn add_weighted(&mut self, p: DVec3, w: f64) {
        self.count += w;
        self.sum += p * w;
        self.outer[0] += w * p.x * p.x;
        self.outer[1] += w * p.x * p.y;
        self.outer[2] += w * p.x * p.z;
        self.outer[3] += w * p.y * p.y;
        self.outer[4] += w * p.y * p.z;
        self.outer[5] += w * p.z * p.z;
    }

    /// Adds the moments of another set.
    pub fn merge(&mut self, other: &Self) {
        self.count += other.count;
        self.sum += other.sum;
        for (a, b) in self.outer.iter_mut().zip(other.outer) {
            *a += b;
        }
    }

    /// Mean of the points, if any.
    pub fn mean(&self) -> Option<DVec3> {
        (self.count > 0.0).then(|| self.sum / self.count)
    }

    /// Covariance matrix (divided by the count); zero for fewer than one point.
    pub fn covariance(&self) -> DMat3 {
        if self.count <= 0.0 {
            return DMat3::ZERO;
        }
        let m = self.sum / self.count;
        let o = self.outer.map(|x| x / self.count);
        let xx = o[0] - m.x * m.x;
        let xy = o[1] - m.x * m.y;
        let xz = o[2] - m.x * m.z;
        let yy = o[3] - m.y * m.y;
        let yz = o[4] - m.y * m.z;
        let zz = o[5] - m.z * m.z;
        DMat3::from_cols(DVec3::new(xx, xy, xz), DVec3::new(xy, yy, yz), DVec3::new(xz, yz, zz))
    }

    /// The least-squares plane through the points: centroid and the eigenvector of the smallest
    /// covariance eigenvalue. `None` for fewer than 3 points or non-finite data.
    ///
    /// Moments summed in world coordinates lose precision far from the origin; callers with
    /// georeferenced data accumulate relative to a local origin.
    pub fn fit_plane(&self) -> Option<Plane> {
        if self.count < 3.0 {
            return None;
        }
        let centroid = self.mean()?;
        let e = sym_eigen3(self.covariance());
        if !e.values.iter().all(|v| v.is_finite()) || !centroid.is_finite() {
            return None;
        }
        Some(Plane { point: centroid, normal: e.vectors[0], eigenvalues: e.values.map(|v| v.max(0.0)) })
    }
}

/// A plane through `point` with unit `normal`, plus the eigenvalues of the fit it came from
/// (ascending; the smallest is the mean squared distance of the points to the plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane (the centroid of the fitted points).
    pub point: DVec3,
    /// Unit normal; its sign is arbitrary for a fitted plane.
    pub normal: DVec3,
    /// Covariance eigenvalues of the fit, ascending (all zero for a plane not made by a fit).
    pub eigenvalues: [f64; 3],
}

impl Plane {
    /// Signed distance of `p` along the normal.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        (p - self.point).dot(self.normal)
    }

    /// Orthogonal projection of `p` onto the plane: `p - ((p - c) . n) n`.
    pub fn project(&self, p: DVec3) -> DVec3 {
        p - self.normal * self.signed_distance(p)
    }

    /// RMS distance of the fitted points to the plane.
    pub fn rms_residual(&self) -> f64 {
        self.eigenvalues[0].max(0.0).sqrt()
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn fits_a_tilted_plane() {
        let n = DVec3::new(1.0, 2.0, 2.0).normalize();
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        let c = DVec3::new(5.0, -3.0, 2.0);
        let mut m = Moments::default();
        for i in 0..10 {
            for j in 0..10 {
                m.add(c + u * f64::from(i) + v * f64::from(j) * 0.5);
            }
        }
        let p = m.fit_plane().unwrap();
        assert!(p.normal.dot(n).abs() > 1.0 - 1e-9);
        assert!(p.signed_distance(c).abs() < 1e-9);
        assert!(p.rms_residual() < 1e-6);
        let q = c + n * 3.0 + u;
        assert!((p.project(q) - (c + u)).length() < 1e-9);
    }

    #[test]
    fn too_few_points_give_no_plane() {
        let mut m = Moments::default();
        m.add(DVec3::ZERO);
        m.add(DVec3::X);
        assert!(m.fit_plane().is_none());
        let mut a = Moments::default();
        a.add(DVec3::Y);
        a.merge(&m);
        assert_eq!(a.count, 3.0);
        assert!(a.fit_plane().is_some());
    }
}
