//! Point clouds: positions plus optional per-point attributes.

use octowrap_geom::{Aabb, DVec3, Vec3};

/// An 8-bit RGB colour.
pub type Rgb = [u8; 3];

/// Points with optional attributes. Every present attribute array has one entry per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// Positions in world units (metres for georeferenced data).
    pub positions: Vec<DVec3>,
    /// Unit normals, when the source has them.
    pub normals: Option<Vec<Vec3>>,
    /// Colours, when the source has them (16-bit sources are scaled to 8 bits).
    pub colors: Option<Vec<Rgb>>,
    /// Intensities or reflectances as stored by the source (LAS: 0-65535; E57: as given).
    pub intensities: Option<Vec<f32>>,
}

impl PointCloud {
    /// A cloud of bare positions.
    pub fn from_positions(positions: Vec<DVec3>) -> Self {
        Self { positions, ..Self::default() }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Bounding box of the finite positions.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// Number of positions with a NaN or infinite coordinate.
    pub fn non_finite_count(&self) -> usize {
        self.positions.iter().filter(|p| !p.is_finite()).count()
    }

    /// Appends all points of `other`. An attribute survives only if both clouds have it
    /// (or `self` is empty, in which case `other`'s attributes are taken as they are).
    pub fn append(&mut self, other: PointCloud) {
        fn join<T>(a: &mut Option<Vec<T>>, b: Option<Vec<T>>) {
            match (a.as_mut(), b) {
                (Some(x), Some(y)) => x.extend(y),
                _ => *a = None,
            }
        }
        if self.positions.is_empty() {
            *self = other;
            return;
        }
        join(&mut self.normals, other.normals);
        join(&mut self.colors, other.colors);
        join(&mut self.intensities, other.intensities);
        self.positions.extend(other.positions);
    }

    /// Names of the attributes present besides positions, for reports.
    pub fn attribute_names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.normals.is_some() {
            v.push("normal");
        }
        if self.colors.is_some() {
            v.push("color");
        }
        if self.intensities.is_some() {
            v.push("intensity");
        }
        v
    }

    /// Checks that every attribute array has one entry per position.
    pub fn attributes_consistent(&self) -> bool {
        let n = self.positions.len();
        self.normals.as_ref().is_none_or(|v| v.len() == n)
            && self.colors.as_ref().is_none_or(|v| v.len() == n)
            && self.intensities.as_ref().is_none_or(|v| v.len() == n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn append_keeps_only_shared_attributes() {
        let mut a = PointCloud::from_positions(vec![DVec3::ZERO]);
        a.normals = Some(vec![Vec3::Z]);
        a.colors = Some(vec![[1, 2, 3]]);
        let mut b = PointCloud::from_positions(vec![DVec3::ONE, DVec3::X]);
        b.normals = Some(vec![Vec3::X, Vec3::Y]);
        a.append(b);
        assert_eq!(a.len(), 3);
        assert_eq!(a.normals.as_ref().unwrap().len(), 3);
        assert!(a.colors.is_none());
        assert!(a.attributes_consistent());
        assert_eq!(a.attribute_names(), vec!["normal"]);
    }
}
