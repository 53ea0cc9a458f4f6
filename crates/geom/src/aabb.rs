//! Axis-aligned bounding boxes.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// An axis-aligned box `[min, max]` in world units. The empty box has `min > max` on every axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: contains nothing, and growing it by a point gives that point's box.
    pub const EMPTY: Self = Self { min: DVec3::INFINITY, max: DVec3::NEG_INFINITY };

    /// The smallest box holding every point; [`Aabb::EMPTY`] for none. Non-finite points are skipped.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.grow(*p);
        }
        b
    }

    /// Grows the box to hold `p`; non-finite points are ignored.
    pub fn grow(&mut self, p: DVec3) {
        if p.is_finite() {
            self.min = self.min.min(p);
            self.max = self.max.max(p);
        }
    }

    /// The union of two boxes.
    #[must_use]
    pub fn union(&self, other: &Self) -> Self {
        Self { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Whether the box holds no point.
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// Edge lengths (zero for the empty box).
    pub fn size(&self) -> DVec3 {
        if self.is_empty() { DVec3::ZERO } else { self.max - self.min }
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the main diagonal (zero for the empty box).
    pub fn diagonal(&self) -> f64 {
        self.size().length()
    }

    /// Whether `p` lies in the closed box.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The cube that the octree starts from: centred on this box, with edge equal to the longest
    /// box edge times `1 + 2 * padding`, so that no point lies on the cube's faces.
    ///
    /// A degenerate box (a single point, or all points equal) gets an edge of 1 world unit, so that
    /// the octree always has a positive cell size. Returns `None` for the empty box.
    pub fn bounding_cube(&self, padding: f64) -> Option<Self> {
        if self.is_empty() {
            return None;
        }
        let mut edge = self.size().max_element() * (1.0 + 2.0 * padding);
        if edge.is_nan() || edge <= 0.0 || edge.is_infinite() {
            edge = 1.0;
        }
        let half = DVec3::splat(edge * 0.5);
        let c = self.center();
        Some(Self { min: c - half, max: c + half })
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_grows_to_points() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        assert_eq!(b.diagonal(), 0.0);
        b.grow(DVec3::new(1.0, 2.0, 3.0));
        assert!(!b.is_empty());
        b.grow(DVec3::new(-1.0, 0.0, 5.0));
        b.grow(DVec3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(b.min, DVec3::new(-1.0, 0.0, 3.0));
        assert_eq!(b.max, DVec3::new(1.0, 2.0, 5.0));
    }

    #[test]
    fn bounding_cube_is_padded_and_cubic() {
        let b = Aabb { min: DVec3::ZERO, max: DVec3::new(2.0, 1.0, 0.5) };
        let c = b.bounding_cube(0.01).unwrap();
        let s = c.size();
        assert!((s.x - 2.04).abs() < 1e-12 && (s.y - s.x).abs() < 1e-12 && (s.z - s.x).abs() < 1e-12);
        assert!(c.contains(b.min) && c.contains(b.max));
        assert_eq!(c.center(), b.center());
        let point = Aabb::from_points(&[DVec3::ONE]);
        assert_eq!(point.bounding_cube(0.0).unwrap().size(), DVec3::ONE);
        assert!(Aabb::EMPTY.bounding_cube(0.1).is_none());
    }
}
