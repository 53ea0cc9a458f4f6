//! Compact moments of the children of every voxel of a level, for the vertex mapping of
//! subdivided levels ([`crate::mapping::map_free`]).
//!
//! A subdivided level `k` has no wrapped voxels of its own, and its vertices are four times as
//! many per level. Gathering the points of the 2x2x2 level-`k - 1` voxels around each vertex one
//! by one costs about 50 points per vertex on the 4.3 M-point dragon at level 10, more than any
//! other stage of the reconstruction. Instead, one pass over the points sums, for every occupied
//! level-`k` voxel (a child of an occupied level-`k - 1` voxel), its count, mean and central
//! covariance (relative to the child's corner, in units of its edge, in `f32`: 40 bytes a child);
//! a vertex's plane is then the sum of its eight surrounding children's moments (the parallel
//! axis theorem, in `f64`, relative to the vertex), with no pass over points.
//!
//! The points are the tree's, in Morton order, so a voxel's children are contiguous; the child
//! of a point is read from its position against the voxel's centre (a point on the centre plane
//! by rounding goes to either side, which moves it by 2^-24 of the cube at most).

use octowrap_geom::{DVec3, Moments, morton};
use rayon::prelude::*;

use crate::octree::{Cells, Octree};

/// One child's moments: count, mean and central covariance (xx, xy, xz, yy, yz, zz), the last two
/// relative to the child's smallest corner in units of its edge.
#[derive(Clone, Copy, Debug, Default)]
struct Child {
    count: u32,
    mean: [f32; 3],
    cov: [f32; 6],
}

/// The moments of the occupied children of every voxel of `parents`.
#[derive(Debug)]
pub(crate) struct ChildMoments {
    /// The children's level.
    pub level: u32,
    /// Per parent voxel, a bit per occupied child (bit `x | y << 1 | z << 2`, Morton order).
    mask: Vec<u8>,
    /// Per parent voxel, the index of its first child in `children`.
    first: Vec<u32>,
    /// The occupied children, by parent, then in Morton order.
    children: Vec<Child>,
    /// The parents' own moments (the sums of their children), relative to their corners in units
    /// of their edge.
    parents: Vec<Child>,
}

impl ChildMoments {
    /// Sums the children of every voxel of `parents` (one pass over the points, in parallel).
    pub(crate) fn new(tree: &Octree, parents: &Cells) -> Self {
        let level = parents.level + 1;
        let l = crate::octree::voxel_size(level);
        let octant = |p: DVec3, centre: DVec3| -> usize {
            usize::from(p.x >= centre.x) | usize::from(p.y >= centre.y) << 1 | usize::from(p.z >= centre.z) << 2
        };
        let centre = |i: usize| {
            let v = morton::decode(parents.keys[i]);
            DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])) * (2.0 * l) + DVec3::splat(l)
        };
        let mask: Vec<u8> = (0..parents.len())
            .into_par_iter()
            .map(|i| {
                let c = centre(i);
                tree.points[parents.range(i)].iter().fold(0u8, |m, p| m | 1 << octant(p.as_dvec3(), c))
            })
            .collect();
        let mut first = Vec::with_capacity(mask.len());
        let mut total = 0u32;
        for m in &mask {
            first.push(total);
            total += m.count_ones();
        }
        let mut children = vec![Child::default(); total as usize];
        let mut slices: Vec<&mut [Child]> = Vec::with_capacity(mask.len());
        let mut rest = children.as_mut_slice();
        for m in &mask {
            let (here, tail) = rest.split_at_mut(m.count_ones() as usize);
            slices.push(here);
            rest = tail;
        }
        let mut whole = vec![Child::default(); mask.len()];
        slices.into_par_iter().zip(whole.par_iter_mut()).enumerate().for_each(|(i, (out, whole))| {
            let c = centre(i);
            let mut acc = [Moments::default(); 8];
            for p in &tree.points[parents.range(i)] {
                let p = p.as_dvec3();
                let o = octant(p, c);
                // Relative to the child's corner, in units of its edge.
                let corner =
                    c - DVec3::splat(l) + DVec3::new((o & 1) as f64, ((o >> 1) & 1) as f64, (o >> 2) as f64) * l;
                acc[o].add((p - corner) / l);
            }
            // The parent's moments relative to its corner, in units of its edge.
            let mut sum = Moments::default();
            for (o, m) in acc.iter().enumerate() {
                let shift = DVec3::new((o & 1) as f64, ((o >> 1) & 1) as f64, (o >> 2) as f64);
                add_shifted(m, shift, 0.5, &mut sum);
            }
            *whole = Child::from_moments(&sum);
            for (slot, m) in out.iter_mut().zip(acc.iter().filter(|m| m.count > 0.0)) {
                *slot = Child::from_moments(m);
            }
        });
        Self { level, mask, first, children, parents: whole }
    }

    /// The index of child voxel `child` (coordinates at the children's level) of parent voxel
    /// `parent` (its index in the parents' cells), if that child is occupied.
    #[inline]
    pub(crate) fn child(&self, parent: usize, child: [u32; 3]) -> Option<usize> {
        let octant = (child[0] & 1 | (child[1] & 1) << 1 | (child[2] & 1) << 2) as usize;
        let mask = self.mask[parent];
        (mask & (1 << octant) != 0)
            .then(|| self.first[parent] as usize + (mask & ((1u8 << octant) - 1)).count_ones() as usize)
    }

    /// The number of points of child `i` (from [`ChildMoments::child`]).
    #[inline]
    pub(crate) fn count(&self, i: usize) -> u32 {
        self.children[i].count
    }

    /// Adds to `m` the moments of child `i` (from [`ChildMoments::child`]) at coordinates
    /// `coords`, relative to `x`, all in units of the children's edge (see [`Units`]).
    #[inline]
    pub(crate) fn add_child(&self, i: usize, coords: [u32; 3], x: DVec3, m: &mut Moments) {
        self.children[i].add_to(coords, x, m);
    }

    /// Adds to `m` the moments of parent voxel `parent` (its index in the parents' cells, at
    /// coordinates `coords` of the parents' level), relative to `x`, all in units of the parents'
    /// edge (see [`Units`]).
    #[inline]
    pub(crate) fn add_parent(&self, parent: usize, coords: [u32; 3], x: DVec3, m: &mut Moments) {
        self.parents[parent].add_to(coords, x, m);
    }
}

/// Moments summed in units of a voxel edge `e` (a power of two), then scaled back.
///
/// Scaling by a power of two is exact and commutes with rounding (no value here comes near the
/// subnormals), so `corner + mean e - x` summed in units of `e` and scaled is the same number as
/// summed in local units, and so are the products and sums of the moments: the same bits, with
/// the scaling done once per vertex instead of once per voxel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Units(pub f64);

impl Units {
    /// `x` in these units.
    #[inline]
    pub(crate) fn of(self, x: DVec3) -> DVec3 {
        x / self.0
    }

    /// Moments summed in these units, in local units.
    #[inline]
    pub(crate) fn scale(self, m: &mut Moments) {
        let e = self.0;
        m.sum *= e;
        for o in &mut m.outer {
            *o = *o * e * e;
        }
    }
}

impl Child {
    /// Compacts moments taken in the voxel's unit frame.
    fn from_moments(m: &Moments) -> Self {
        if m.count <= 0.0 {
            return Self::default();
        }
        let mean = m.sum / m.count;
        let cov = m.covariance();
        Self {
            count: m.count as u32,
            mean: mean.as_vec3().to_array(),
            cov: [cov.x_axis.x, cov.y_axis.x, cov.z_axis.x, cov.y_axis.y, cov.z_axis.y, cov.z_axis.z].map(|v| v as f32),
        }
    }

    /// Adds these moments, of the voxel at `coords`, to `m`, relative to `x`, in units of the
    /// voxel's edge (the parallel axis theorem; see [`Units`]).
    #[inline]
    fn add_to(&self, coords: [u32; 3], x: DVec3, m: &mut Moments) {
        let corner = DVec3::new(f64::from(coords[0]), f64::from(coords[1]), f64::from(coords[2]));
        let mean = DVec3::new(f64::from(self.mean[0]), f64::from(self.mean[1]), f64::from(self.mean[2]));
        let n = f64::from(self.count);
        let d = corner + mean - x;
        let s = self.cov.map(f64::from);
        m.count += n;
        m.sum += d * n;
        m.outer[0] += n * (s[0] + d.x * d.x);
        m.outer[1] += n * (s[1] + d.x * d.y);
        m.outer[2] += n * (s[2] + d.x * d.z);
        m.outer[3] += n * (s[3] + d.y * d.y);
        m.outer[4] += n * (s[4] + d.y * d.z);
        m.outer[5] += n * (s[5] + d.z * d.z);
    }
}

/// Adds raw moments `m` (of points in a unit frame) to `out`, shifted by `shift` and scaled by
/// `scale` (`p -> (p + shift) * scale`).
fn add_shifted(m: &Moments, shift: DVec3, scale: f64, out: &mut Moments) {
    if m.count <= 0.0 {
        return;
    }
    let (n, s) = (m.count, m.sum);
    let o = m.outer;
    let ss = scale * scale;
    out.count += n;
    out.sum += (s + shift * n) * scale;
    // (p + t)(p + t)^T summed = O + s t^T + t s^T + n t t^T.
    let t = shift;
    out.outer[0] += ss * (o[0] + 2.0 * s.x * t.x + n * t.x * t.x);
    out.outer[1] += ss * (o[1] + s.x * t.y + t.x * s.y + n * t.x * t.y);
    out.outer[2] += ss * (o[2] + s.x * t.z + t.x * s.z + n * t.x * t.z);
    out.outer[3] += ss * (o[3] + 2.0 * s.y * t.y + n * t.y * t.y);
    out.outer[4] += ss * (o[4] + s.y * t.z + t.y * s.z + n * t.y * t.z);
    out.outer[5] += ss * (o[5] + 2.0 * s.z * t.z + n * t.z * t.z);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The children's and parents' compact moments, moved to any point, are the points' own.
    #[test]
    fn compact_moments_match_the_points() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let pts: Vec<DVec3> = (0..3000).map(|_| DVec3::new(rnd(), rnd() * 0.5, 0.3 * rnd())).collect();
        let mut tree = Octree::new(&pts, 0.01);
        for _ in 0..3 {
            tree.push_level();
        }
        let parents = &tree.levels[2];
        let kids = ChildMoments::new(&tree, parents);
        let l = crate::octree::voxel_size(3);
        let close = |a: &Moments, b: &Moments| {
            let scale = b.outer.iter().fold(1e-12f64, |s, v| s.max(v.abs()));
            (a.count - b.count).abs() < 1e-9
                && (a.sum - b.sum).length() < 1e-6 * b.count * l
                && a.outer.iter().zip(b.outer).all(|(x, y)| (x - y).abs() < 1e-5 * scale)
        };
        let mut children = 0;
        for i in 0..parents.len() {
            let x = DVec3::new(rnd(), rnd(), rnd()) * 0.3;
            let pv = morton::decode(parents.keys[i]);
            let (mut direct, mut merged) = (Moments::default(), Moments::default());
            for p in &tree.points[parents.range(i)] {
                direct.add(p.as_dvec3() - x);
            }
            let units = Units(2.0 * l);
            kids.add_parent(i, pv, units.of(x), &mut merged);
            units.scale(&mut merged);
            assert!(close(&merged, &direct), "parent {i}: {merged:?} {direct:?}");
            let mut sum = Moments::default();
            let units = Units(l);
            for o in 0..8u32 {
                let child = [2 * pv[0] + (o & 1), 2 * pv[1] + ((o >> 1) & 1), 2 * pv[2] + (o >> 2)];
                if let Some(c) = kids.child(i, child) {
                    kids.add_child(c, child, units.of(x), &mut sum);
                    children += 1;
                }
            }
            units.scale(&mut sum);
            assert!(close(&sum, &direct), "children of {i}");
        }
        assert_eq!(children, tree.levels[3].len());
    }
}
