//! Topology of a level (spec §5): what the modes share. Rotation bytes (§5.2), the parent level
//! as the next level's context (`Parent`), the edge numbering of the canonical subdivision (§5.4),
//! and the sentinels of the plain per-face and per-corner arrays. One file per mode beside it:
//! `base` (mode 0, §5.1), `generic` (mode 1, §5.4), `lattice` (lattice faces of modes 2 and 3,
//! §5.3; mode 2, §5.7), `first_use` (mode 3, §5.9); `names` holds §5.5 and §5.6 (names, splits,
//! corners: modes 1 and 2), `slots` the lattice keys of §5.3 and §5.8.

pub mod base;
pub mod first_use;
pub mod generic;
pub mod lattice;
pub mod names;
pub mod slots;

/// `rotated(r, i)` (spec §5.2) for every rotation byte `r < 8` and corner `i < 4`.
pub const ROTATIONS: [[u8; 4]; 8] = {
    let mut t = [[0u8; 4]; 8];
    let mut r = 0;
    while r < 8 {
        let mut i = 0;
        while i < 4 {
            let turn = r & 3;
            t[r][i] = (if r & 4 == 0 { (turn + i) % 4 } else { (turn + 4 - i) % 4 }) as u8;
            i += 1;
        }
        r += 1;
    }
    t
};

/// "No parent" in plain parent arrays.
pub const NO_PARENT: u32 = u32::MAX;
/// "No prediction" in per-corner arrays.
pub const NONE: u32 = u32::MAX;
/// "No canonical position" in per-corner position arrays.
pub const NO_POS: u8 = u8::MAX;

/// Canonical position of face corner `k` under rotation byte `rot` (spec §5.2).
pub fn rotated(rot: u8, k: usize) -> usize {
    let r = usize::from(rot & 3);
    if rot & 4 == 0 { (r + k) % 4 } else { (r + 4 - k) % 4 }
}

/// Edge numbering of a polygon mesh in order of first appearance (spec §5.4): for every face
/// corner, the id of the edge from it to the next corner, and the number of edges.
///
/// No hashing: corners are bucketed by the smaller vertex of their edge (counting sort, corner
/// order kept), each corner finds the first corner of its bucket with the same larger vertex (a
/// scan in small buckets, a sort in large ones), and ids follow in corner order.
pub fn number_edges(offsets: &[u32], indices: &[u32]) -> (Vec<u32>, u32) {
    let nc = indices.len();
    let nv = indices.iter().map(|&v| v as usize + 1).max().unwrap_or(0);
    // The other end of every corner's edge.
    let mut other = vec![0u32; nc];
    for w in offsets.windows(2) {
        let (a, b) = (w[0] as usize, w[1] as usize);
        for c in a..b {
            other[c] = indices[if c + 1 == b { a } else { c + 1 }];
        }
    }
    let mut start = vec![0u32; nv + 1];
    for c in 0..nc {
        start[indices[c].min(other[c]) as usize + 1] += 1;
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut bucket = vec![0u32; nc];
    let mut fill = start.clone();
    for c in 0..nc {
        let lo = indices[c].min(other[c]) as usize;
        bucket[fill[lo] as usize] = c as u32;
        fill[lo] += 1;
    }
    drop(fill);
    // first[c]: the first corner (in corner order) with the same unordered edge.
    let mut first = vec![0u32; nc];
    let hi = |c: u32| indices[c as usize].max(other[c as usize]);
    let mut scratch: Vec<(u32, u32)> = Vec::new();
    for w in start.windows(2) {
        let group = &bucket[w[0] as usize..w[1] as usize];
        if group.len() <= 16 {
            for (i, &c) in group.iter().enumerate() {
                let h = hi(c);
                let f = group[..i].iter().find(|&&d| hi(d) == h).copied().unwrap_or(c);
                first[c as usize] = f;
            }
        } else {
            scratch.clear();
            scratch.extend(group.iter().map(|&c| (hi(c), c)));
            scratch.sort_unstable();
            let mut lead: Option<(u32, u32)> = None;
            for &(h, c) in &scratch {
                if lead.is_none_or(|l| l.0 != h) {
                    lead = Some((h, c));
                }
                first[c as usize] = lead.map_or(c, |l| l.1);
            }
        }
    }
    let mut edge_of_corner = vec![0u32; nc];
    let mut next = 0u32;
    for c in 0..nc {
        let f = first[c] as usize;
        if f == c {
            edge_of_corner[c] = next;
            next += 1;
        } else {
            edge_of_corner[c] = edge_of_corner[f];
        }
    }
    (edge_of_corner, next)
}

/// A canonical quad: its vertices in canonical corner order and its orientation byte.
pub type Quad = ([u32; 4], u8);

/// The parent level, as the refinement coders see it.
pub struct Parent<'a> {
    /// Face offsets (CSR).
    pub offsets: &'a [u32],
    /// Face corner indices.
    pub indices: &'a [u32],
    /// Grid coordinates of the parent's vertices (empty for exact files).
    pub q: &'a [[i64; 3]],
    /// Lattice slots of the parent's faces, if any.
    pub slots: Option<&'a [([u32; 3], u8)]>,
    /// Lattice corners of the parent's vertices, if any.
    pub corners: Option<&'a [[u32; 3]]>,
    /// Per face, its orientation when known in advance (`u8::MAX`: compute it), or empty.
    pub rotation_hints: &'a [u8],
    /// Where the canonical quads are kept once computed, if anywhere.
    pub quad_cache: Option<&'a crate::level_decode::QuadCache>,
}

impl<'a> Parent<'a> {
    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.offsets.len() - 1
    }
    /// Corners of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.indices[self.offsets[f] as usize..self.offsets[f + 1] as usize]
    }

    /// For lattice refinement (spec §5.3): per parent face, its orientation byte (the first
    /// rotation byte, `0..8`, matching the most corners' lattice points to the slot's canonical
    /// corners) and its vertices in canonical corner order. `Err(f)`: face `f` is not a quad, or
    /// the level has no lattice coordinates.
    pub fn canonical_quads(&self) -> Result<std::borrow::Cow<'a, [Quad]>, usize> {
        match self.quad_cache {
            Some(cache) => match cache.get(|| self.compute_canonical_quads()) {
                Ok(q) => Ok(std::borrow::Cow::Borrowed(&q[..])),
                Err(f) => Err(*f),
            },
            None => self.compute_canonical_quads().map(std::borrow::Cow::Owned),
        }
    }

    /// [`Self::canonical_quads`], computed.
    #[allow(clippy::needless_range_loop)]
    fn compute_canonical_quads(&self) -> crate::level_decode::CanonicalQuads {
        let (Some(slots), Some(corners)) = (self.slots, self.corners) else { return Err(0) };
        let mut out = Vec::with_capacity(self.face_count());
        for f in 0..self.face_count() {
            let face = self.face(f);
            if face.len() != 4 {
                return Err(f);
            }
            if let Some(&r) = self.rotation_hints.get(f).filter(|&&r| r < 8) {
                // A mode 3 face without exceptions: every corner sits on the slot corner its
                // rotation byte puts it at, so that rotation is the only one matching all four.
                let mut quad = [0u32; 4];
                for (k, &vi) in face.iter().enumerate() {
                    quad[rotated(r, k)] = vi;
                }
                out.push((quad, r));
                continue;
            }
            let (v, d) = slots[f];
            let sc = slots::slot_corners(v, d);
            let at = |k: usize| corners.get(face[k] as usize);
            let full = |r: u8| (0..4).all(|k| at(k) == Some(&sc[rotated(r, k)]));
            // The common case: corner 0 names a slot corner and the rotation through it matches
            // all four (then no other rotation can, so it is the first best).
            let first = sc.iter().position(|c| at(0) == Some(c)).map(|t| t as u8);
            let rot = match first {
                Some(t) if full(t) => t,
                Some(t) if full(t | 4) => t | 4,
                _ => best_rotation(|r, k| at(k) == Some(&sc[rotated(r, k)])),
            };
            let mut quad = [0u32; 4];
            for (k, &vi) in face.iter().enumerate() {
                quad[rotated(rot, k)] = vi;
            }
            out.push((quad, rot));
        }
        Ok(out)
    }
}

/// The first rotation byte (`0..8`) under which the most of the four corners match.
pub fn best_rotation(mut matches: impl FnMut(u8, usize) -> bool) -> u8 {
    let mut best = (0usize, 0u8);
    for rot in 0..8u8 {
        let m = (0..4).filter(|&i| matches(rot, i)).count();
        if m > best.0 {
            best = (m, rot);
        }
        if m == 4 {
            break;
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::number_edges;

    #[test]
    fn edges_numbered_like_a_hash_map_would() {
        let reference = |offsets: &[u32], indices: &[u32]| {
            let mut ids = std::collections::HashMap::new();
            let mut out = Vec::new();
            for w in offsets.windows(2) {
                let (a, b) = (w[0] as usize, w[1] as usize);
                for c in a..b {
                    let (u, v) = (indices[c], indices[if c + 1 == b { a } else { c + 1 }]);
                    let n = ids.len() as u32;
                    out.push(*ids.entry((u.min(v), u.max(v))).or_insert(n));
                }
            }
            let n = ids.len() as u32;
            (out, n)
        };
        let mut x = 12_345u64;
        let mut next = |m: u64| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            ((x >> 33) % m) as u32
        };
        // Random polygons over few vertices (big buckets, repeated and degenerate edges) and many.
        for nv in [3u64, 5, 40, 1000] {
            let mut offsets = vec![0u32];
            let mut indices = Vec::new();
            for _ in 0..300 {
                let n = 3 + next(4);
                for _ in 0..n {
                    indices.push(next(nv));
                }
                offsets.push(indices.len() as u32);
            }
            assert_eq!(number_edges(&offsets, &indices), reference(&offsets, &indices), "nv {nv}");
        }
        assert_eq!(number_edges(&[0], &[]), (vec![], 0));
    }
}
