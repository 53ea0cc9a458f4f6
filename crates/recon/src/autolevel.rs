//! The finest level of [`crate::MaxLevel::Auto`]: past the deepest level the sampling density
//! supports, levels are subdivided and mapped (§4.2) while each one is worth its four-fold faces.
//!
//! After the trusted level and after every subdivided level, the points-to-mesh RMS distance of
//! the level is measured (a fixed stride of at most [`SAMPLES`] points, each against the faces
//! of the 3x3x3 voxels around it; points with no face that near, over a hole, are left out). A
//! subdivided level is kept when its RMS is at most `1 /`
//! [`crate::ReconOptions::auto_min_gain`] of its parent's; otherwise it is dropped and its parent
//! is the finest level. A further level is built only while its faces (four times the last
//! level's) stay within [`crate::ReconOptions::auto_faces_per_point`] times the input points,
//! [`crate::ReconOptions::auto_max_faces`] and [`crate::ReconOptions::max_faces`], and at most
//! [`EXTRA_LEVELS`] levels past the trusted one.
//!
//! The measure depends only on the level's positions and the points, summed in point order, so
//! the choice is the same whatever the number of threads.

use octowrap_geom::glam::Vec3;
use octowrap_geom::{DVec3, morton, point_triangle_squared};
use rayon::prelude::*;

use crate::{AutoChoice, AutoStop};

/// Points measured at most (a fixed stride of the input).
pub(crate) const SAMPLES: usize = 200_000;

/// Levels subdivided past the trusted level at most.
pub(crate) const EXTRA_LEVELS: u32 = 3;

/// What to do after a level is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Build the next level.
    Continue,
    /// This level is the finest.
    Stop,
    /// Drop this level: its parent is the finest.
    Drop,
}

/// The state of the choice while the levels are built.
pub(crate) struct AutoLevel {
    /// The trusted level (the first level measured).
    trusted: u32,
    /// The deepest level that may be built.
    pub(crate) cap: u32,
    min_gain: f64,
    max_faces: f64,
    /// Measured `(level, RMS)` so far, in the root cube's units.
    errors: Vec<(u32, f64)>,
    stop: Option<(u32, AutoStop)>,
}

impl AutoLevel {
    /// The choice for `points` input points past trusted level `trusted`.
    pub(crate) fn new(trusted: u32, deepest: u32, points: usize, opts: &crate::ReconOptions) -> Self {
        let per_point = if opts.auto_faces_per_point.is_finite() { opts.auto_faces_per_point.max(0.0) } else { 0.0 };
        let min_gain = if opts.auto_min_gain.is_finite() { opts.auto_min_gain.max(1.0) } else { f64::INFINITY };
        Self {
            trusted,
            cap: trusted.saturating_add(EXTRA_LEVELS).min(deepest),
            min_gain,
            max_faces: (per_point * points as f64).min(opts.max_faces as f64).min(opts.auto_max_faces as f64),
            errors: Vec::new(),
            stop: None,
        }
    }

    /// Whether level `j` is measured (the trusted level and the subdivided ones).
    pub(crate) fn measures(&self, j: u32) -> bool {
        j >= self.trusted
    }

    /// Decides after level `j` (`faces` faces, RMS `rms` from [`rms_to_mesh`]) is built.
    pub(crate) fn verdict(&mut self, j: u32, faces: usize, rms: f64) -> Verdict {
        if j > self.trusted {
            let parent = self.errors.last().map_or(f64::INFINITY, |e| e.1);
            let gain = if rms > 0.0 { parent / rms } else { f64::INFINITY };
            if gain < self.min_gain {
                self.stop = Some((j - 1, AutoStop::SmallGain { level: j, gain }));
                return Verdict::Drop;
            }
        }
        self.errors.push((j, rms));
        let next = 4.0 * faces as f64;
        if next > self.max_faces {
            self.stop = Some((j, AutoStop::TooManyFaces { next_faces: next as u64, limit: self.max_faces as u64 }));
            return Verdict::Stop;
        }
        if j >= self.cap {
            self.stop = Some((j, AutoStop::Deepest));
            return Verdict::Stop;
        }
        Verdict::Continue
    }

    /// The outcome, with the errors in world units (`edge`: the root cube's edge).
    pub(crate) fn finish(self, edge: f64) -> Option<AutoChoice> {
        let (level, stop) = self.stop?;
        let errors = self.errors.into_iter().map(|(j, e)| (j, e * edge)).collect();
        Some(AutoChoice { level, trusted: self.trusted, stop, errors })
    }
}

/// The RMS distance from a fixed stride of `points` (local frame) to the quads (each split
/// 0-1-2, 0-2-3) of a level whose faces are about `cell` wide; points with no face in the 3x3x3
/// cells around them are left out. 0 when no point has a face near.
pub(crate) fn rms_to_mesh(points: &[Vec3], quads: &[[u32; 4]], positions: &[DVec3], cell: f64) -> f64 {
    if quads.is_empty() || points.is_empty() || cell.is_nan() || cell <= 0.0 {
        return 0.0;
    }
    let n = (1.0 / cell).ceil().max(1.0);
    let key = |p: DVec3| p.map(|x| (x / cell).floor().clamp(0.0, n - 1.0)).as_uvec3();
    // (cell code, face) for every cell a face's box overlaps, sorted.
    let mut entries: Vec<(u64, u32)> = quads
        .par_iter()
        .enumerate()
        .flat_map_iter(|(f, q)| {
            let c = q.map(|v| positions[v as usize]);
            let (lo, hi) = (key(c[0].min(c[1]).min(c[2]).min(c[3])), key(c[0].max(c[1]).max(c[2]).max(c[3])));
            let mut out = Vec::new();
            // A face wider than 4 cells (a stray vertex) is listed in its corners' cells only.
            if (hi - lo).max_element() > 4 {
                out.extend(c.iter().map(|&p| {
                    let k = key(p);
                    (morton::encode(k.x, k.y, k.z), f as u32)
                }));
                return out.into_iter();
            }
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        out.push((morton::encode(x, y, z), f as u32));
                    }
                }
            }
            out.into_iter()
        })
        .collect();
    entries.par_sort_unstable();
    entries.dedup();
    let stride = points.len().div_ceil(SAMPLES).max(1);
    let top = n as i64 - 1;
    let d2: Vec<f64> = points
        .par_iter()
        .step_by(stride)
        .map(|p| {
            let p = p.as_dvec3();
            let k = key(p).as_i64vec3();
            let mut best = f64::INFINITY;
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let c = k + octowrap_geom::glam::I64Vec3::new(dx, dy, dz);
                        if c.min_element() < 0 || c.max_element() > top {
                            continue;
                        }
                        let code = morton::encode(c.x as u32, c.y as u32, c.z as u32);
                        let start = entries.partition_point(|e| e.0 < code);
                        for &(_, f) in entries[start..].iter().take_while(|e| e.0 == code) {
                            let q = quads[f as usize].map(|v| positions[v as usize]);
                            best = best
                                .min(point_triangle_squared(p, &[q[0], q[1], q[2]]))
                                .min(point_triangle_squared(p, &[q[0], q[2], q[3]]));
                        }
                    }
                }
            }
            best
        })
        .collect();
    let (sum, count) = d2.iter().filter(|d| d.is_finite()).fold((0.0, 0usize), |(s, c), d| (s + d, c + 1));
    if count == 0 { 0.0 } else { (sum / count as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square split into `k x k` quads at height `z`.
    fn grid(k: u32, z: f64) -> (Vec<[u32; 4]>, Vec<DVec3>) {
        let mut pos = Vec::new();
        for y in 0..=k {
            for x in 0..=k {
                pos.push(DVec3::new(
                    0.2 + 0.6 * f64::from(x) / f64::from(k),
                    0.2 + 0.6 * f64::from(y) / f64::from(k),
                    z,
                ));
            }
        }
        let mut quads = Vec::new();
        for y in 0..k {
            for x in 0..k {
                let v = y * (k + 1) + x;
                quads.push([v, v + 1, v + k + 2, v + k + 1]);
            }
        }
        (quads, pos)
    }

    #[test]
    fn rms_is_the_height_above_a_flat_mesh() {
        let (quads, pos) = grid(8, 0.5);
        let points: Vec<Vec3> =
            (0..100).map(|i| Vec3::new(0.3 + 0.004 * i as f32, 0.5, if i % 2 == 0 { 0.51 } else { 0.49 })).collect();
        let rms = rms_to_mesh(&points, &quads, &pos, 0.6 / 8.0);
        assert!((rms - 0.01).abs() < 1e-6, "{rms}");
        // Points far from every face are left out.
        let far = vec![Vec3::new(0.9, 0.9, 0.95)];
        assert!(rms_to_mesh(&far, &quads, &pos, 0.6 / 8.0).abs() < f64::EPSILON);
    }

    #[test]
    fn verdicts_follow_the_gain_and_the_size() {
        let opts = crate::ReconOptions { auto_min_gain: 1.5, auto_faces_per_point: 2.0, ..Default::default() };
        let mut a = AutoLevel::new(5, 20, 1000, &opts);
        assert!(a.measures(5) && !a.measures(4));
        assert_eq!(a.verdict(5, 100, 1.0), Verdict::Continue);
        assert_eq!(a.verdict(6, 600, 0.5), Verdict::Stop, "2,400 faces next, more than 2 per point");
        let c = a.finish(2.0).expect("stopped");
        assert_eq!((c.level, c.errors), (6, vec![(5, 2.0), (6, 1.0)]));
        assert!(matches!(c.stop, AutoStop::TooManyFaces { next_faces: 2400, limit: 2000 }));
        let mut a = AutoLevel::new(5, 20, 1000, &opts);
        assert_eq!(a.verdict(5, 10, 1.0), Verdict::Continue);
        assert_eq!(a.verdict(6, 40, 0.8), Verdict::Drop, "a fall of 1.25x is not worth it");
        let c = a.finish(1.0).expect("stopped");
        assert_eq!(c.level, 5);
        assert!(matches!(c.stop, AutoStop::SmallGain { level: 6, .. }));
        let mut a = AutoLevel::new(5, 6, 1_000_000, &opts);
        assert_eq!(a.verdict(5, 10, 1.0), Verdict::Continue);
        assert_eq!(a.verdict(6, 40, 0.1), Verdict::Stop);
        assert!(matches!(a.finish(1.0).map(|c| c.stop), Some(AutoStop::Deepest)));
    }
}
