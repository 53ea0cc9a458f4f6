//! Hierarchical space partitioning (Keller et al., §3.2).
//!
//! The root voxel is the points' bounding cube, padded by [`crate::ReconOptions::padding`] of its
//! edge on every side ([`octowrap_geom::Aabb::bounding_cube`]); level `j` splits it into `2^j`
//! voxels per axis and keeps the non-empty ones (the paper's `V_j`).
//!
//! Reading: the paper builds an octree with neighbour navigation after Bhattacharya (2001). We
//! sort the points once by their 63-bit Morton code (21 bits per axis); the voxel of a point at
//! level `j` is then its code shifted right by `3 (21 - j)`, so every level's voxels are the runs
//! of equal prefixes in one sorted array: each voxel knows its points as a contiguous range, the
//! voxels of a level are in Morton order, and the eight children of a voxel are consecutive.
//! Building a level is one O(|P|) scan (the paper's bound), done in parallel; neighbour look-ups
//! go through an index from Morton code to voxel index ([`crate::rankmap`]), O(1).
//!
//! Coordinates are local: `u = (p - cube.min) / cube.edge`, in `[0, 1)^3`, stored as `f32`
//! (2^-24 of the cube, far below any level's voxel). Moments are accumulated in `f64`.

use std::ops::Range;

use octowrap_geom::{Aabb, DVec3, Moments, glam::Vec3, morton};
use rayon::prelude::*;

use crate::Error;
use crate::rankmap::RankMap;

/// Bits per axis of the full-depth codes.
const CODE_BITS: u32 = morton::MAX_DEPTH;

/// The local frame: `world = origin + local * edge`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    /// The cube's smallest corner.
    pub origin: DVec3,
    /// The cube's edge in world units.
    pub edge: f64,
}

impl Frame {
    /// World position of a local point.
    pub(crate) fn to_world(self, local: DVec3) -> DVec3 {
        self.origin + local * self.edge
    }

    /// The cube as a box.
    pub(crate) fn cube(self) -> Aabb {
        Aabb { min: self.origin, max: self.origin + DVec3::splat(self.edge) }
    }
}

/// The occupied voxels of one level.
#[derive(Debug, Default)]
pub(crate) struct Cells {
    /// The level.
    pub level: u32,
    /// Morton code of each occupied voxel, ascending.
    pub keys: Vec<u64>,
    /// Voxel `i` holds points `starts[i]..starts[i + 1]` of [`Octree::points`].
    pub starts: Vec<u32>,
    /// Moments of each voxel's points (local coordinates).
    pub moments: Vec<Moments>,
    /// Morton code to voxel index.
    pub index: RankMap,
    /// Per voxel, whether it is *filled*: a child of a voxel whose region was too sparse for
    /// this level ([`crate::regions`]), present whether it holds points or not. Empty when no
    /// voxel is.
    pub filled: Vec<bool>,
}

/// Most points per occupied neighbour, on average, around a gap that [`Cells::fill_gaps`] fills.
pub(crate) const GAP_POINTS: usize = 8;

/// Largest spread (standard deviation, in voxels) of the gap's neighbours' points across the
/// sheet, for [`Cells::fill_gaps`].
pub(crate) const GAP_SPREAD: f64 = 0.2;

impl Cells {
    /// Number of occupied voxels.
    pub(crate) fn len(&self) -> usize {
        self.keys.len()
    }

    /// The index of the voxel with Morton code `key`, if occupied.
    #[inline]
    pub(crate) fn find(&self, key: u64) -> Option<usize> {
        self.index.get(key).map(|i| i as usize)
    }

    /// Whether the voxel `key` is occupied.
    #[inline]
    pub(crate) fn occupied(&self, key: u64) -> bool {
        self.index.contains(key)
    }

    /// Whether voxel `i` is filled ([`Cells::filled`]).
    #[inline]
    pub(crate) fn is_filled(&self, i: usize) -> bool {
        self.filled.get(i).copied().unwrap_or(false)
    }

    /// The point range of voxel `i`.
    #[inline]
    pub(crate) fn range(&self, i: usize) -> Range<usize> {
        self.starts[i] as usize..self.starts[i + 1] as usize
    }

    /// Median number of points per occupied voxel.
    pub(crate) fn median_count(&self) -> f64 {
        let mut c: Vec<u32> = self.starts.windows(2).map(|w| w[1] - w[0]).collect();
        if c.is_empty() {
            return 0.0;
        }
        let mid = c.len() / 2;
        let (_, m, _) = c.select_nth_unstable(mid);
        f64::from(*m)
    }

    /// Fills one-voxel gaps in thinly sampled sheets: an empty voxel gets an empty (point-less)
    /// entry when, across some axis, at least 3 of its 4 neighbours in the plane are occupied,
    /// one of its two neighbours along the axis is empty (it lies on the surface, not inside),
    /// those occupied neighbours hold at most [`GAP_POINTS`] points on average (a gap in sparse
    /// sampling, not a hole in densely sampled data), and their points spread less than
    /// [`GAP_SPREAD`] voxel along the axis (a sheet across it, not the walls and floor of a
    /// narrow groove, which would be bridged). Returns the number filled.
    ///
    /// Without this, the oriented-sheet mask ([`crate::sheet`]) keeps such a gap open as it
    /// keeps any hole in a sheet: the dragon's sparsely sampled underside showed dozens of
    /// one- and two-quad holes at level 7. Filled voxels carry faces like any other; they have
    /// no points, so their sheets are unreliable (every slot allowed) and their vertices are
    /// mapped from the neighbours' points.
    pub(crate) fn fill_gaps(&mut self) -> usize {
        let level = self.level;
        let h = self.voxel();
        let mut candidates: Vec<u64> = (0..self.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let key = self.keys[i];
                (0..6u8).filter_map(move |d| crate::lattice::offset(key, crate::lattice::step(d), level))
            })
            .filter(|&w| !self.occupied(w))
            .collect();
        candidates.par_sort_unstable();
        candidates.dedup();
        let fill: Vec<u64> = candidates
            .into_par_iter()
            .filter(|&w| {
                let points = |delta: [i32; 3]| {
                    crate::lattice::offset(w, delta, level).and_then(|k| self.find(k)).map(|i| self.range(i).len())
                };
                (0..3).any(|a| {
                    let mut along = [0i32; 3];
                    along[a] = 1;
                    let (b, e) = ((a + 1) % 3, (a + 2) % 3);
                    let (mut occupied, mut total) = (0usize, 0usize);
                    let mut sheet = Moments::default();
                    for (axis, sign) in [(b, 1), (b, -1), (e, 1), (e, -1)] {
                        let mut delta = [0i32; 3];
                        delta[axis] = sign;
                        if let Some(i) = crate::lattice::offset(w, delta, level).and_then(|k| self.find(k)) {
                            occupied += 1;
                            total += self.range(i).len();
                            if let Some(m) = self.moments.get(i) {
                                sheet.merge(m);
                            }
                        }
                    }
                    // The neighbours' points form a sheet across the axis (not the walls and
                    // floor of a groove, whose points spread over the voxels' whole depth).
                    let flat = || {
                        let spread = sheet.covariance().col(a)[a];
                        sheet.count >= 3.0 && spread < (GAP_SPREAD * h) * (GAP_SPREAD * h)
                    };
                    occupied >= 3
                        && total <= GAP_POINTS * occupied
                        && (points(along).is_none() || points(along.map(|x| -x)).is_none())
                        && flat()
                })
            })
            .collect();
        self.insert_empty(&fill);
        fill.len()
    }

    /// Inserts voxels without points (`extra`: sorted, none occupied yet), keeping every
    /// per-voxel array in step (moments zero, not filled).
    pub(crate) fn insert_empty(&mut self, extra: &[u64]) {
        if extra.is_empty() {
            return;
        }
        // Merge the empty voxels in (both lists are sorted).
        let total = self.keys.len() + extra.len();
        let (mut keys, mut starts) = (Vec::with_capacity(total), Vec::with_capacity(total + 1));
        let mut moments = Vec::with_capacity(if self.moments.is_empty() { 0 } else { total });
        let mut filled = Vec::with_capacity(if self.filled.is_empty() { 0 } else { total });
        let (mut i, mut k) = (0, 0);
        while i < self.keys.len() || k < extra.len() {
            if k < extra.len() && (i == self.keys.len() || extra[k] < self.keys[i]) {
                keys.push(extra[k]);
                starts.push(self.starts[i]);
                if !self.moments.is_empty() {
                    moments.push(Moments::default());
                }
                if !self.filled.is_empty() {
                    filled.push(false);
                }
                k += 1;
            } else {
                keys.push(self.keys[i]);
                starts.push(self.starts[i]);
                if !self.moments.is_empty() {
                    moments.push(self.moments[i]);
                }
                if !self.filled.is_empty() {
                    filled.push(self.filled[i]);
                }
                i += 1;
            }
        }
        starts.push(*self.starts.last().unwrap_or(&0));
        self.index = RankMap::from_sorted(&keys);
        self.keys = keys;
        self.starts = starts;
        self.moments = moments;
        self.filled = filled;
    }

    /// Edge length of this level's voxels in local units.
    pub(crate) fn voxel(&self) -> f64 {
        voxel_size(self.level)
    }
}

/// Edge of a level-`j` voxel in local units.
pub(crate) fn voxel_size(level: u32) -> f64 {
    1.0 / f64::from(1u32 << level)
}

/// The points sorted along the Morton curve, and the occupied voxels of levels `0..=depth`.
#[derive(Debug)]
pub(crate) struct Octree {
    /// World from local.
    pub frame: Frame,
    /// Local positions, in Morton order.
    pub points: Vec<Vec3>,
    /// Full-depth Morton codes of [`Octree::points`].
    codes: Vec<u64>,
    /// Per point, the coarsest level at which it is the first of its voxel (`u8::MAX` for a
    /// duplicate of the point before it; point 0 starts every voxel, 0): a level's voxels start
    /// where this is at most the level, so building a level reads a byte per point, not two
    /// codes.
    split: Vec<u8>,
    /// `levels[j]`: the occupied voxels of level `j`.
    pub levels: Vec<Cells>,
    /// Number of distinct quantised positions.
    pub distinct: usize,
    /// The largest side of the points' bounding box, in world units.
    pub extent: f64,
}

impl Octree {
    /// Sorts the points and builds level 0. `points` must be finite and non-empty.
    ///
    /// Each point's local position travels through the sort with its code (no gather from the
    /// input in sorted order afterwards: on the 4.3 M point case that gather, one cache miss per
    /// point, cost more than the sort). The sort is stable, so points with equal codes keep
    /// their input order.
    pub(crate) fn new(points: &[DVec3], padding: f64) -> Self {
        let bounds = points.par_chunks(1 << 16).map(Aabb::from_points).reduce(|| Aabb::EMPTY, |a, b| a.union(&b));
        let extent = bounds.size().max_element();
        let cube = bounds.bounding_cube(padding).unwrap_or(Aabb { min: DVec3::ZERO, max: DVec3::ONE });
        let frame = Frame { origin: cube.min, edge: cube.size().x };
        let inv = 1.0 / frame.edge;
        let full = f64::from(1u32 << CODE_BITS);
        let top = (1u32 << CODE_BITS) - 1;
        let codes: Vec<u64> = points
            .par_iter()
            .map(|p| {
                let u = (*p - frame.origin) * inv;
                let q = |x: f64| ((x * full).max(0.0) as u32).min(top);
                morton::encode(q(u.x), q(u.y), q(u.z))
            })
            .collect();
        let pairs = sort_by_code(&codes, 3 * CODE_BITS, |i| {
            let u = (points[i] - frame.origin) * inv;
            u.as_vec3().clamp(Vec3::ZERO, Vec3::splat(1.0 - f32::EPSILON))
        });
        drop(codes);
        let distinct = 1 + (1..pairs.len()).into_par_iter().filter(|&i| pairs[i].0 != pairs[i - 1].0).count();
        let (codes, local): (Vec<u64>, Vec<Vec3>) = pairs.par_iter().copied().unzip();
        drop(pairs);
        // Codes `a < b` lie in one level-`j` voxel while they agree above bit `3 (21 - j)`: the
        // highest differing bit `h` separates them from level `21 - h / 3` on.
        let split: Vec<u8> = (0..codes.len())
            .into_par_iter()
            .map(|i| match i.checked_sub(1).map(|k| codes[i] ^ codes[k]) {
                None => 0,
                Some(0) => u8::MAX,
                Some(x) => (CODE_BITS - x.ilog2() / 3) as u8,
            })
            .collect();
        let n = local.len() as u32;
        let root = Cells {
            level: 0,
            keys: vec![0],
            starts: vec![0, n],
            moments: Vec::new(),
            index: RankMap::from_sorted(&[0]),
            filled: Vec::new(),
        };
        Self { frame, points: local, codes, split, levels: vec![root], distinct, extent }
    }

    /// Whether the points can span a surface: an extent that the local frame can normalise (a
    /// subnormal one has no finite reciprocal; one past `f64::MAX / 3` overflows once padded),
    /// and at least `needed` distinct quantised positions.
    pub(crate) fn check(&self, needed: usize) -> Result<(), Error> {
        let (min, max) = (f64::MIN_POSITIVE, f64::MAX / 3.0);
        if self.extent != 0.0 && !(min..=max).contains(&self.extent) {
            return Err(Error::ExtentOutOfRange { extent: self.extent, min, max });
        }
        if self.distinct < needed {
            return Err(Error::TooFewDistinct { distinct: self.distinct, needed });
        }
        Ok(())
    }

    /// Frees the points and the voxels of every level (the frame stays).
    pub(crate) fn release(&mut self) {
        self.points = Vec::new();
        self.codes = Vec::new();
        self.split = Vec::new();
        self.levels = Vec::new();
    }

    /// The deepest level built so far.
    pub(crate) fn depth(&self) -> u32 {
        self.levels.len() as u32 - 1
    }

    /// Builds the next level (one O(|P|) scan, in parallel).
    pub(crate) fn push_level(&mut self) {
        let level = self.depth() + 1;
        let shift = 3 * (CODE_BITS - level);
        let (codes, split) = (&self.codes, &self.split);
        let n = codes.len();
        let mut starts: Vec<u32> = Vec::with_capacity(self.levels[level as usize - 1].len() * 4 + 2);
        starts.push(0);
        starts.par_extend((1..n).into_par_iter().filter(|&i| u32::from(split[i]) <= level).map(|i| i as u32));
        starts.push(n as u32);
        let keys: Vec<u64> = starts[..starts.len() - 1].iter().map(|&s| codes[s as usize] >> shift).collect();
        let index = RankMap::from_sorted(&keys);
        self.levels.push(Cells { level, keys, starts, moments: Vec::new(), index, filled: Vec::new() });
    }

    /// Computes the moments of levels `0..=deepest`: `deepest` from the points, the others by
    /// summing children (deeper levels get none). Call once, after the last
    /// [`Octree::push_level`]; frees the codes.
    pub(crate) fn finish(&mut self, deepest: u32) {
        self.codes = Vec::new();
        self.split = Vec::new();
        let deepest = (deepest as usize).min(self.levels.len() - 1);
        let pts = &self.points;
        let cells = &self.levels[deepest];
        let moments: Vec<Moments> = (0..cells.len())
            .into_par_iter()
            .map(|i| {
                let mut m = Moments::default();
                for p in &pts[cells.range(i)] {
                    m.add(p.as_dvec3());
                }
                m
            })
            .collect();
        self.levels[deepest].moments = moments;
        for j in (0..deepest).rev() {
            let (coarse, fine) = self.levels.split_at_mut(j + 1);
            let (coarse, fine) = (&mut coarse[j], &fine[0]);
            let mut out = vec![Moments::default(); coarse.len()];
            // Children are consecutive and in parent order.
            let mut parent = 0;
            for (k, m) in fine.keys.iter().zip(&fine.moments) {
                while coarse.keys[parent] != k >> 3 {
                    parent += 1;
                }
                out[parent].merge(m);
            }
            coarse.moments = out;
        }
    }
}

/// The pairs `(codes[i], payload(i))`, whose codes have at most `key_bits` bits, sorted
/// stably by code (equal codes keep their order, so with the index as payload the order is
/// that of sorting the pairs): a bucket pass by the top 12 bits (for the full-depth codes of
/// the points, the level-4 voxel), then the buckets in parallel. `par_sort_unstable`
/// partitions its top levels on one thread; this sorts fully in parallel.
///
/// The bucket pass is parallel too: the input is cut into a fixed number of chunks (not one per
/// thread), each chunk counts its pairs per bucket, and the output is split, bucket by bucket,
/// into one sub-slice per chunk, so every chunk scatters into slices of its own, in input order
/// whatever the threads.
///
/// Each bucket is sorted by counting passes on its next bits too, until its parts are small
/// ([`sort_bucket`]): a comparison sort of whole buckets (thousands of pairs on surface data)
/// did more work (the 4.3 M case's points: 1.06 G instructions in the buckets' quicksorts).
pub(crate) fn sort_by_code<T: Copy + Default + Send + Sync>(
    codes: &[u64],
    key_bits: u32,
    payload: impl Fn(usize) -> T + Sync,
) -> Vec<(u64, T)> {
    const BITS: u32 = 12;
    const BUCKETS: usize = 1 << BITS;
    let n = codes.len();
    // At most 64 chunks, each of at least 2^14 pairs (fewer for small inputs).
    let chunk = n.div_ceil(64).max(1 << 14);
    let chunks: Vec<Range<usize>> = (0..n).step_by(chunk).map(|s| s..(s + chunk).min(n)).collect();
    let shift = key_bits.saturating_sub(BITS);
    let bucket = |code: u64| (code >> shift) as usize;
    // The payloads are made where they are placed (no array of pairs before the sort).
    let counts: Vec<Vec<u32>> = chunks
        .par_iter()
        .map(|c| {
            let mut h = vec![0u32; BUCKETS];
            for i in c.clone() {
                h[bucket(codes[i])] += 1;
            }
            h
        })
        .collect();
    let mut out = vec![(0u64, T::default()); n];
    let mut sizes = vec![0usize; BUCKETS];
    {
        // Bucket-major, chunk-minor sub-slices, handed to their chunks.
        let mut targets: Vec<Vec<&mut [(u64, T)]>> = counts.iter().map(|_| Vec::with_capacity(BUCKETS)).collect();
        let mut rest = out.as_mut_slice();
        for (b, size) in sizes.iter_mut().enumerate() {
            for (h, t) in counts.iter().zip(&mut targets) {
                let (here, tail) = rest.split_at_mut(h[b] as usize);
                t.push(here);
                rest = tail;
                *size += h[b] as usize;
            }
        }
        chunks.par_iter().zip(targets).for_each(|(c, mut t)| {
            let mut fill = vec![0usize; BUCKETS];
            for i in c.clone() {
                let b = bucket(codes[i]);
                t[b][fill[b]] = (codes[i], payload(i));
                fill[b] += 1;
            }
        });
    }
    let mut buckets = Vec::with_capacity(BUCKETS);
    let mut rest = out.as_mut_slice();
    for &size in &sizes {
        let (bucket, tail) = rest.split_at_mut(size);
        if !bucket.is_empty() {
            buckets.push(bucket);
        }
        rest = tail;
    }
    buckets.into_par_iter().for_each(|b| sort_bucket(b, shift, &mut Vec::new()));
    out
}

/// Pairs below which [`sort_bucket`] sorts by comparison.
const SMALL_BUCKET: usize = 32;

/// Sorts `pairs` stably by code, whose codes agree above bit `bits`: below [`SMALL_BUCKET`]
/// pairs by insertion, with no bits left not at all (the codes are equal), else by a counting
/// pass on the next bits (a quarter to a half as many bins as pairs, at most 12 bits; from a
/// copy in `tmp`) and each part recursively.
fn sort_bucket<T: Copy>(pairs: &mut [(u64, T)], bits: u32, tmp: &mut Vec<(u64, T)>) {
    if bits == 0 {
        return;
    }
    if pairs.len() < SMALL_BUCKET {
        insertion_sort(pairs);
        return;
    }
    let digit = bits.min(12).min(pairs.len().ilog2() - 1);
    let shift = bits - digit;
    let mask = (1u64 << digit) - 1;
    let at = |p: &(u64, T)| ((p.0 >> shift) & mask) as usize;
    let bins = 1usize << digit;
    // Counts at `d + 2`, summed: `starts[d + 1]` is where bin `d` starts, and advances while it
    // fills, to where bin `d + 1` starts (no copy of the offsets). Small counts on the stack.
    let (mut small, mut large) = ([0u32; 258], Vec::new());
    let starts: &mut [u32] = if bins + 2 <= small.len() {
        &mut small[..bins + 2]
    } else {
        large.resize(bins + 2, 0);
        &mut large
    };
    for p in pairs.iter() {
        starts[at(p) + 2] += 1;
    }
    for i in 2..bins + 2 {
        starts[i] += starts[i - 1];
    }
    tmp.clear();
    tmp.extend_from_slice(pairs);
    for p in tmp.iter() {
        let slot = &mut starts[at(p) + 1];
        pairs[*slot as usize] = *p;
        *slot += 1;
    }
    for d in 0..bins {
        let part = &mut pairs[starts[d] as usize..starts[d + 1] as usize];
        if part.len() > 1 {
            sort_bucket(part, shift, tmp);
        }
    }
}

/// Stable insertion sort by code (for the small parts of [`sort_bucket`]).
fn insertion_sort<T: Copy>(pairs: &mut [(u64, T)]) {
    for i in 1..pairs.len() {
        let p = pairs[i];
        let mut j = i;
        while j > 0 && pairs[j - 1].0 > p.0 {
            pairs[j] = pairs[j - 1];
            j -= 1;
        }
        pairs[j] = p;
    }
}

/// The 26 neighbour offsets plus the centre, in a fixed order.
pub(crate) const BLOCK: [[i32; 3]; 27] = {
    let mut out = [[0; 3]; 27];
    let mut i = 0;
    while i < 27 {
        out[i] = [(i % 3) as i32 - 1, ((i / 3) % 3) as i32 - 1, (i / 9) as i32 - 1];
        i += 1;
    }
    out
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_extent_beyond_normalisation_is_named() {
        // 3,000 distinct points within a subnormal extent: 1 / extent is infinite.
        let tiny: Vec<DVec3> =
            (0..3000).map(|k| DVec3::new(f64::from(k) * 1e-312, 0.0, f64::from(k % 7) * 1e-312)).collect();
        let e = crate::reconstruct(&tiny, &crate::ReconOptions::default()).unwrap_err();
        assert!(
            matches!(e, Error::ExtentOutOfRange { extent, .. } if extent > 0.0 && extent < f64::MIN_POSITIVE),
            "{e}"
        );
        assert!(e.to_string().starts_with("the points span 2.999e-309, outside the extent"), "{e}");
        // The unit cube plus two points at +-1.7e308: the extent overflows.
        let mut far: Vec<DVec3> = (0..3000).map(|k| DVec3::splat(f64::from(k) / 3000.0)).collect();
        far.extend([DVec3::splat(1.7e308), DVec3::splat(-1.7e308)]);
        let e = crate::reconstruct(&far, &crate::ReconOptions::default()).unwrap_err();
        assert!(matches!(e, Error::ExtentOutOfRange { extent, .. } if extent.is_infinite()), "{e}");
        // Coincident points keep their own message.
        let same = vec![DVec3::splat(1e-312); 10];
        let e = crate::reconstruct(&same, &crate::ReconOptions::default()).unwrap_err();
        assert_eq!(e, Error::TooFewDistinct { distinct: 1, needed: 3 });
    }

    /// A sheet of voxel centres at level 4 with voxel (7, 7, 8) left out, `per` points per voxel.
    fn sheet_with_gap(per: usize) -> Octree {
        let mut pts = vec![DVec3::ZERO, DVec3::ONE];
        for i in 0..16 {
            for k in 0..16 {
                if (i, k) == (7, 7) {
                    continue;
                }
                for r in 0..per {
                    let jitter = r as f64 * 0.002;
                    pts.push(DVec3::new((f64::from(i) + 0.5) / 16.0 + jitter, (f64::from(k) + 0.5) / 16.0, 8.5 / 16.0));
                }
            }
        }
        let mut o = Octree::new(&pts, 0.0);
        for _ in 0..4 {
            o.push_level();
        }
        o.finish(4);
        o
    }

    #[test]
    fn gaps_of_sparse_sheets_are_filled_and_dense_holes_kept() {
        let mut o = sheet_with_gap(2);
        let before = o.levels[4].len();
        assert_eq!(o.levels[4].fill_gaps(), 1);
        let cells = &o.levels[4];
        assert_eq!(cells.len(), before + 1);
        let gap = cells.find(morton::encode(7, 7, 8)).expect("the gap is filled");
        assert!(cells.range(gap).is_empty());
        assert!(cells.moments[gap].mean().is_none());
        assert!(cells.keys.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(cells.starts.len(), cells.len() + 1);
        for (i, &k) in cells.keys.iter().enumerate() {
            assert_eq!(cells.find(k), Some(i));
        }
        // Filling again finds nothing new.
        assert_eq!(o.levels[4].fill_gaps(), 0);
        // Densely sampled, the same hole is data.
        let mut o = sheet_with_gap(12);
        assert_eq!(o.levels[4].fill_gaps(), 0);
    }

    /// The bucket and radix passes give a stable sort's order: clustered codes (a surface-like
    /// few buckets, duplicates in input order), sparse codes, short keys.
    #[test]
    fn sort_by_code_is_a_stable_sort() {
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            seed >> 11
        };
        for (n, bits, cluster) in
            [(200_000usize, 63u32, 20u32), (50_000, 63, 63), (30_000, 33, 14), (5_000, 9, 9), (3, 63, 2)]
        {
            let base = rnd() & ((1u64 << bits) - 1) & !((1u64 << cluster) - 1);
            let mut pairs: Vec<(u64, u32)> =
                (0..n).map(|i| ((base | (rnd() & ((1u64 << cluster) - 1))) & !3 | (i as u64 & 1), i as u32)).collect();
            // Duplicated codes.
            for i in (0..n).step_by(7) {
                let j = (i * 13) % n;
                pairs[i].0 = pairs[j].0;
            }
            // Any payload keeps its input order among equal codes (a stable sort by code).
            let reversed: Vec<(u64, u32)> = pairs.iter().map(|&(c, i)| (c, n as u32 - i)).collect();
            let mut expected = pairs.clone();
            expected.sort_unstable();
            let codes: Vec<u64> = pairs.iter().map(|p| p.0).collect();
            assert_eq!(sort_by_code(&codes, bits, |i| pairs[i].1), expected, "n {n} bits {bits}");
            let mut expected = reversed.clone();
            expected.sort_by_key(|p| p.0);
            assert_eq!(sort_by_code(&codes, bits, |i| reversed[i].1), expected, "n {n} bits {bits}, reversed payload");
        }
    }

    #[test]
    fn levels_partition_the_points() {
        let pts: Vec<DVec3> = (0..1000)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                DVec3::new(t.sin(), t.cos(), t * 0.1)
            })
            .collect();
        let mut o = Octree::new(&pts, 0.01);
        for _ in 0..5 {
            o.push_level();
        }
        o.finish(5);
        for (j, cells) in o.levels.iter().enumerate() {
            assert_eq!(*cells.starts.last().unwrap() as usize, pts.len());
            assert!(cells.keys.windows(2).all(|w| w[0] < w[1]));
            let total: f64 = cells.moments.iter().map(|m| m.count).sum();
            assert_eq!(total as usize, pts.len(), "level {j}");
            // Every point lies in its voxel.
            let h = cells.voxel() as f32;
            for i in 0..cells.len() {
                let c = morton::decode(cells.keys[i]);
                for p in &o.points[cells.range(i)] {
                    for a in 0..3 {
                        let lo = c[a] as f32 * h;
                        assert!(p[a] >= lo - 1e-6 && p[a] <= lo + h + 1e-6);
                    }
                }
            }
        }
    }
}
