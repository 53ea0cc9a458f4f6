//! Crack-free meshes from a selection of chunks of different levels (spec §11.5, the crack rule).
//!
//! A *cut* is a set of chunks no one of which refines another (an antichain of the chunk tree).
//! Its chunks are decoded and merged in three steps, on the vertices' lattice corners brought to
//! the finest selected level `M` (a corner `c` of level `k` is the lattice point `c · 2^(M-k)`):
//!
//! 1. **Merge**: vertices of one level merge across chunks as in spec §11.4.
//! 2. **Snap**: a vertex on its chunk's cell boundary takes the place of the vertex of the finest
//!    level selected at the same lattice point (so a coarse chunk's seam vertices are the fine
//!    chunk's).
//! 3. **Fill**: an edge of a coarse face with no twin gains, as polygon corners, the vertices of
//!    the finer faces' path along the same lattice segment (a T-junction becomes a corner).
//!
//! Then a **check**: an edge still without a twin that lies on its chunk's cell boundary, with a
//! chunk of another level across it, is a crack; so are two vertices of one level snapped onto one
//! vertex, a face that snapping degenerates, an edge used twice in one direction, and a vertex
//! where the faces of several chunks make more than one fan. The coarser
//! chunk of each is replaced by the chunks refining it, and the steps run again, until no crack is
//! left or the chunk to refine has no children (counted as unresolved).
//!
//! Every step works in chunk index order and face order (hash maps only look up), so a cut's mesh
//! depends only on the file and the selection.

use std::collections::{HashMap, HashSet};

use octowrap_mesh::{DVec3, FaceList, Mesh};

use crate::level_decode::PlainLevel;

/// A crack-free mesh of a cut ([`crate::ChunkedMrq::cut`]).
#[derive(Clone, Debug)]
pub struct Cut {
    /// The merged mesh, positions in world units; coarse faces beside finer ones are polygons.
    pub mesh: Mesh,
    /// Per face of `mesh`: the chunk it comes from.
    pub face_chunks: Vec<u32>,
    /// Per vertex of `mesh`: its lattice corner at level `lattice_level` (a corner `c` of level `k`
    /// is `c · 2^(lattice_level - k)`); `u64::MAX` on each axis without lattice coordinates.
    pub lattice: Vec<[u64; 3]>,
    /// The finest level drawn.
    pub lattice_level: u32,
    /// The chunks drawn, after refinement (index order).
    pub drawn: Vec<u32>,
    /// Chunks the crack rule replaced by the chunks refining them.
    pub refined: u32,
    /// Cracks left because the coarser chunk has no chunk refining it.
    pub unresolved: u32,
}

/// Why a cut could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CutError {
    /// Reading or decoding a chunk failed.
    #[error(transparent)]
    Decode(#[from] crate::DecodeError),
    /// The selection is not a cut (explained).
    #[error("bad chunk selection: {0}")]
    Selection(String),
}

/// One selected chunk, decoded.
pub(crate) struct Part<'a> {
    /// Its index in the chunk index.
    pub chunk: u32,
    /// Its level.
    pub level: u32,
    /// Its level's cell depth.
    pub depth: u32,
    /// Its cell.
    pub cell: [u32; 3],
    /// Its decoded faces and vertices.
    pub lv: &'a PlainLevel,
}

/// The stitched mesh of parts, or the parts to refine.
pub(crate) struct Stitched {
    /// World positions.
    pub positions: Vec<DVec3>,
    /// Faces.
    pub faces: FaceList,
    /// Per face: its part.
    pub face_parts: Vec<u32>,
    /// Per vertex: its lattice point at the finest selected level.
    pub lattice: Vec<[u64; 3]>,
    /// The finest selected level.
    pub lattice_level: u32,
    /// Cracks, each as the parts on either side (part indices, sorted, deduplicated).
    pub conflicts: Vec<Vec<u32>>,
}

/// Vertices of all parts, merged and snapped (steps 1 and 2).
struct Vertices {
    /// World position.
    pos: Vec<DVec3>,
    /// Lattice point at the finest selected level.
    key: Vec<[u64; 3]>,
    /// Level.
    level: Vec<u32>,
    /// The part that made it.
    owner: Vec<u32>,
    /// Per part, per local vertex: the merged and snapped vertex.
    local: Vec<Vec<u32>>,
}

/// Stitches `parts` (steps 1 to 5 of spec §11.5); `world(lv, v)` is vertex `v`'s position.
pub(crate) fn stitch(parts: &[Part<'_>], world: impl Fn(&PlainLevel, usize) -> DVec3) -> Stitched {
    let m = parts.iter().map(|p| p.level).max().unwrap_or(0);
    let mut conflicts: Vec<Vec<u32>> = Vec::new();
    let verts = merge_and_snap(parts, m, &world, &mut conflicts);
    let (faces, face_parts) = snapped_faces(parts, &verts, &mut conflicts);
    let filled = fill_and_check(parts, m, &verts, &faces, &face_parts, &mut conflicts);
    let part_levels: Vec<u32> = parts.iter().map(|p| p.level).collect();
    pinches(&filled, &face_parts, &part_levels, verts.pos.len(), &mut conflicts);
    for c in &mut conflicts {
        c.sort_unstable();
        c.dedup();
    }
    conflicts.sort_unstable();
    conflicts.dedup();
    // Vertices no face uses (snapped away) are dropped.
    let mut new_index = vec![u32::MAX; verts.pos.len()];
    for &a in filled.iter().flatten() {
        new_index[a as usize] = 0;
    }
    let (mut positions, mut lattice) = (Vec::new(), Vec::new());
    for (g, n) in new_index.iter_mut().enumerate() {
        if *n == 0 {
            *n = positions.len() as u32;
            positions.push(verts.pos[g]);
            lattice.push(verts.key[g]);
        }
    }
    let mut out = FaceList::with_capacity(filled.len(), filled.iter().map(Vec::len).sum());
    let mut corners = Vec::new();
    for f in &filled {
        corners.clear();
        corners.extend(f.iter().map(|&a| new_index[a as usize]));
        out.push(&corners);
    }
    Stitched { positions, faces: out, face_parts, lattice, lattice_level: m, conflicts }
}

/// Step 3: every part's faces through the snapped vertices, and their parts; a face that
/// snapping degenerates is a crack (and loses its repeated corners).
fn snapped_faces(parts: &[Part<'_>], verts: &Vertices, conflicts: &mut Vec<Vec<u32>>) -> (Vec<Vec<u32>>, Vec<u32>) {
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut face_parts: Vec<u32> = Vec::new();
    for (pi, p) in parts.iter().enumerate() {
        for w in p.lv.offsets.windows(2) {
            let mut f: Vec<u32> =
                p.lv.indices[w[0] as usize..w[1] as usize].iter().map(|&v| verts.local[pi][v as usize]).collect();
            let n = f.len();
            if (0..n).any(|i| f[i + 1..].contains(&f[i])) {
                conflicts.push(vec![pi as u32]);
                f.dedup();
                while f.len() > 1 && f.first() == f.last() {
                    f.pop();
                }
                if f.len() < 3 {
                    continue;
                }
            }
            faces.push(f);
            face_parts.push(pi as u32);
        }
    }
    (faces, face_parts)
}

/// Steps 3 (edges used twice), 4 (fill) and 5 (open edges on a cell boundary with another level
/// across): the faces with their filled corners.
fn fill_and_check(
    parts: &[Part<'_>],
    m: u32,
    verts: &Vertices,
    faces: &[Vec<u32>],
    face_parts: &[u32],
    conflicts: &mut Vec<Vec<u32>>,
) -> Vec<Vec<u32>> {
    let level_of_face = |f: usize| parts[face_parts[f] as usize].level;
    // Half-edges; one used twice in one direction by parts of two levels is a crack between them
    // (within one level, it is the level's own).
    let mut half: HashMap<(u32, u32), u32> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        for (a, b) in edges(f) {
            if let Some(&other) = half.get(&(a, b)) {
                if level_of_face(other as usize) != level_of_face(fi) {
                    conflicts.push(vec![face_parts[other as usize], face_parts[fi]]);
                }
            } else {
                half.insert((a, b), fi as u32);
            }
        }
    }
    // Open half-edges, and by their start for the fill.
    let mut open: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    let mut unmatched: Vec<(u32, u32, u32)> = Vec::new();
    for (fi, f) in faces.iter().enumerate() {
        for (a, b) in edges(f) {
            if !half.contains_key(&(b, a)) {
                open.entry(a).or_default().push((b, fi as u32));
                unmatched.push((a, b, fi as u32));
            }
        }
    }
    let mut consumed: HashSet<(u32, u32)> = HashSet::new();
    let mut inserts: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for &(u, v, fi) in &unmatched {
        let k = level_of_face(fi as usize);
        if k == m || consumed.contains(&(u, v)) {
            continue;
        }
        let along = Along { u, v, k, m, key: &verts.key };
        if let Some(path) = fill_path(&along, &open, &consumed, &level_of_face) {
            consumed.insert((u, v));
            let mut prev = v;
            for &x in path.iter().chain([&u]) {
                consumed.insert((prev, x));
                prev = x;
            }
            inserts.insert((fi, u), path.into_iter().rev().collect());
        }
    }
    let cells = CellLookup::new(parts, m);
    for &(a, b, fi) in &unmatched {
        if consumed.contains(&(a, b)) {
            continue;
        }
        let pi = face_parts[fi as usize];
        for pj in cells.across(&parts[pi as usize], verts.key[a as usize], verts.key[b as usize]) {
            if parts[pj as usize].level != parts[pi as usize].level {
                conflicts.push(vec![pi, pj]);
            }
        }
    }
    faces
        .iter()
        .enumerate()
        .map(|(fi, f)| {
            let mut out = Vec::with_capacity(f.len());
            for &a in f {
                out.push(a);
                if let Some(add) = inserts.get(&(fi as u32, a)) {
                    out.extend(add);
                }
            }
            out
        })
        .collect()
}

/// The check's last part: a vertex where faces of parts of several levels meet, and whose faces
/// there do not make one fan (joined through the edges they share), is a crack between those
/// parts. (Where parts of one level meet, the fans are the level's own.)
fn pinches(faces: &[Vec<u32>], face_parts: &[u32], part_levels: &[u32], nv: usize, conflicts: &mut Vec<Vec<u32>>) {
    // Per vertex, its corners: (face, previous corner, next corner).
    // A vertex is on a seam when faces of parts of two levels use it.
    let mut first_part = vec![u32::MAX; nv];
    let mut seam = vec![false; nv];
    for (fi, f) in faces.iter().enumerate() {
        for &a in f {
            let p = face_parts[fi];
            if first_part[a as usize] == u32::MAX {
                first_part[a as usize] = p;
            } else if part_levels[first_part[a as usize] as usize] != part_levels[p as usize] {
                seam[a as usize] = true;
            }
        }
    }
    let mut around: HashMap<u32, Vec<(u32, u32, u32)>> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        let n = f.len();
        for i in 0..n {
            if seam[f[i] as usize] {
                around.entry(f[i]).or_default().push((fi as u32, f[(i + n - 1) % n], f[(i + 1) % n]));
            }
        }
    }
    let mut seams: Vec<u32> = around.keys().copied().collect();
    seams.sort_unstable();
    for v in seams {
        let corners = &around[&v];
        // Union-find over the corners: two corners join when one's next is the other's previous.
        let mut root: Vec<usize> = (0..corners.len()).collect();
        let mut by_next: HashMap<u32, usize> = HashMap::new();
        for (i, c) in corners.iter().enumerate() {
            by_next.insert(c.2, i);
        }
        for (i, c) in corners.iter().enumerate() {
            if let Some(&j) = by_next.get(&c.1) {
                let (a, b) = (find(&mut root, i), find(&mut root, j));
                root[a] = b;
            }
        }
        let fans = (0..corners.len()).filter(|&i| find(&mut root, i) == i).count();
        if fans > 1 {
            conflicts.push(corners.iter().map(|c| face_parts[c.0 as usize]).collect());
        }
    }
}

/// The root of `i` in the union-find forest `root`, halving paths on the way.
fn find(root: &mut [usize], mut i: usize) -> usize {
    while root[i] != i {
        root[i] = root[root[i]];
        i = root[i];
    }
    i
}

/// The directed edges of face `f`.
fn edges(f: &[u32]) -> impl Iterator<Item = (u32, u32)> + '_ {
    (0..f.len()).map(move |i| (f[i], f[(i + 1) % f.len()]))
}

/// Steps 1 and 2: merges one level's vertices across parts (spec §11.4), then snaps every vertex
/// on its cell's boundary to the finest selected level's vertex at the same lattice point.
fn merge_and_snap(
    parts: &[Part<'_>],
    m: u32,
    world: &impl Fn(&PlainLevel, usize) -> DVec3,
    conflicts: &mut Vec<Vec<u32>>,
) -> Vertices {
    let mut vs = Vertices { pos: Vec::new(), key: Vec::new(), level: Vec::new(), owner: Vec::new(), local: Vec::new() };
    let mut boundary: Vec<bool> = Vec::new();
    // The standard hasher is keyed at random: a file cannot choose keys that collide.
    let mut same: HashMap<(u32, [u32; 3], [u64; 3]), u32> = HashMap::new();
    for (pi, p) in parts.iter().enumerate() {
        let nv = p.lv.q.len().max(p.lv.exact.len());
        let mask = (1u64 << (p.level - p.depth)) - 1;
        let mut local = Vec::with_capacity(nv);
        for v in 0..nv {
            let corner = p.lv.corners.as_ref().and_then(|c| c.get(v)).copied();
            let on_boundary = corner.is_some_and(|c| c.iter().any(|&x| u64::from(x) & mask == 0));
            let next = vs.pos.len() as u32;
            let id = match corner.filter(|_| on_boundary) {
                Some(c) => {
                    let bits = if p.lv.exact.is_empty() {
                        p.lv.q[v].map(|x| x as u64)
                    } else {
                        p.lv.exact[v].map(f64::to_bits)
                    };
                    *same.entry((p.level, c, bits)).or_insert(next)
                }
                None => next,
            };
            if id == next {
                vs.pos.push(world(p.lv, v));
                vs.key.push(corner.map_or([u64::MAX; 3], |c| c.map(|x| u64::from(x) << (m - p.level))));
                vs.level.push(p.level);
                vs.owner.push(pi as u32);
                boundary.push(on_boundary);
            }
            local.push(id);
        }
        vs.local.push(local);
    }
    // The finest level's vertices at each boundary lattice point.
    let mut finest: HashMap<[u64; 3], (u32, Vec<u32>)> = HashMap::new();
    for g in (0..vs.pos.len()).filter(|&g| boundary[g]) {
        let e = finest.entry(vs.key[g]).or_insert((vs.level[g], Vec::new()));
        if vs.level[g] > e.0 {
            *e = (vs.level[g], Vec::new());
        }
        if vs.level[g] == e.0 {
            e.1.push(g as u32);
        }
    }
    let mut target: Vec<u32> = (0..vs.pos.len() as u32).collect();
    let mut claims: HashMap<(u32, u32), u32> = HashMap::new();
    for g in (0..vs.pos.len()).filter(|&g| boundary[g]) {
        let (level, ids) = &finest[&vs.key[g]];
        if *level == vs.level[g] {
            continue;
        }
        let mut c: Vec<u32> = ids.iter().map(|&i| vs.owner[i as usize]).collect();
        c.push(vs.owner[g]);
        if ids.len() != 1 {
            conflicts.push(c);
            continue;
        }
        if let Some(&other) = claims.get(&(ids[0], vs.level[g])) {
            c.push(vs.owner[other as usize]);
            conflicts.push(c);
        } else {
            claims.insert((ids[0], vs.level[g]), g as u32);
            target[g] = ids[0];
        }
    }
    for l in &mut vs.local {
        for v in l.iter_mut() {
            *v = target[*v as usize];
        }
    }
    vs
}

/// The open edge a fill looks along: `u → v` of a level `k` face, `m` the finest level, `key`
/// the vertices' lattice points.
struct Along<'a> {
    u: u32,
    v: u32,
    k: u32,
    m: u32,
    key: &'a [[u64; 3]],
}

/// Step 4 for one open edge `u → v`: the path `v → x1 → … → u` of open half-edges of finer faces
/// whose lattice points lie on the segment from `v` to `u`, in order; returns `x1, …, xr`
/// (`None` when there is no such path, or more than one).
fn fill_path(
    e: &Along<'_>,
    open: &HashMap<u32, Vec<(u32, u32)>>,
    consumed: &HashSet<(u32, u32)>,
    level_of_face: &impl Fn(usize) -> u32,
) -> Option<Vec<u32>> {
    let (u, k, key) = (e.u, e.k, e.key);
    let (ku, kv) = (key[u as usize], key[e.v as usize]);
    if ku[0] == u64::MAX || kv[0] == u64::MAX {
        return None;
    }
    let differ: Vec<usize> = (0..3).filter(|&a| ku[a] != kv[a]).collect();
    let [axis] = differ[..] else { return None };
    let toward =
        |from: u64, x: u64| if ku[axis] > kv[axis] { x > from && x <= ku[axis] } else { x < from && x >= ku[axis] };
    let mut path = Vec::new();
    let mut cur = e.v;
    for _ in 0..=(1u64 << (e.m - k).min(20)) {
        let kc = key[cur as usize][axis];
        let step: Vec<u32> = open
            .get(&cur)
            .into_iter()
            .flatten()
            .filter(|&&(x, f)| {
                let kx = key[x as usize];
                level_of_face(f as usize) > k
                    && !consumed.contains(&(cur, x))
                    && (0..3).all(|a| a == axis || kx[a] == ku[a])
                    && toward(kc, kx[axis])
            })
            .map(|&(x, _)| x)
            .collect();
        let [x] = step[..] else { return None };
        if x == u {
            return Some(path);
        }
        path.push(x);
        cur = x;
    }
    None
}

/// Which part's cell holds a lattice point.
struct CellLookup {
    m: u32,
    depths: Vec<u32>,
    by_cell: HashMap<(u32, [u32; 3]), Vec<u32>>,
}

impl CellLookup {
    fn new(parts: &[Part<'_>], m: u32) -> Self {
        let mut by_cell: HashMap<(u32, [u32; 3]), Vec<u32>> = HashMap::new();
        let mut depths = Vec::new();
        for (pi, p) in parts.iter().enumerate() {
            by_cell.entry((p.depth, p.cell)).or_default().push(pi as u32);
            depths.push(p.depth);
        }
        depths.sort_unstable();
        depths.dedup();
        Self { m, depths, by_cell }
    }

    /// The parts across the edge `a → b` of a face of `p`, when the edge lies on `p`'s cell
    /// boundary: those whose cells hold a point just off the edge, a quarter along it.
    fn across(&self, p: &Part<'_>, a: [u64; 3], b: [u64; 3]) -> Vec<u32> {
        let mut out = Vec::new();
        if a[0] == u64::MAX || b[0] == u64::MAX {
            return out;
        }
        let span = self.m - p.depth;
        let lo = p.cell.map(|x| u64::from(x) << span);
        let hi = p.cell.map(|x| (u64::from(x) + 1) << span);
        if !(0..3).any(|ax| a[ax] == b[ax] && (a[ax] == lo[ax] || a[ax] == hi[ax])) {
            return out;
        }
        // In units of a quarter lattice step.
        let base: [i64; 3] = [0, 1, 2].map(|ax| (3 * a[ax] + b[ax]) as i64);
        for o in 0..27 {
            let off = [o % 3, o / 3 % 3, o / 9].map(|x| x as i64 - 1);
            if off == [0, 0, 0] || (0..3).any(|ax| off[ax] != 0 && a[ax] != b[ax]) {
                continue;
            }
            let probe = [0, 1, 2].map(|ax| base[ax] + off[ax]);
            if probe.iter().any(|&x| x < 0) {
                continue;
            }
            for &d in &self.depths {
                let sh = self.m - d + 2;
                let cell = probe.map(|x| u32::try_from((x as u64) >> sh).unwrap_or(u32::MAX));
                for &j in self.by_cell.get(&(d, cell)).into_iter().flatten() {
                    if !out.contains(&j) {
                        out.push(j);
                    }
                }
            }
        }
        out
    }
}
