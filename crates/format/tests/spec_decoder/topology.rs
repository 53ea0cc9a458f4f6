//! Spec §5: the topology of a level, one function per mode (§5.1, §5.4, §5.7, §5.9), and the
//! steps they share (§5.2, §5.3, §5.5, §5.6, §5.8).

use std::collections::BTreeMap;

use super::block::{
    BlockHeader, CHILD_MASKS, CHOICES, CORNERS, CREATED_KEYS, DEPTHS, EXCEPTIONS, EXTRA_KEYS, EXTRA_NAMES, FACE_SIZES,
    RAW_LATTICE, ROTATIONS, SPLIT_KEYS, SPLITS,
};
use super::primitives::{Result, Stream, gap_next, invalid, require};

/// A decoded level (spec §2): faces, origins, lattice coordinates and positions.
#[derive(Clone, Debug, Default)]
pub struct Level {
    pub faces: Vec<Vec<u32>>,
    /// Per face: `(parent, quadrant)` of a subface, `None` for a created face.
    pub origins: Vec<Option<(u32, u8)>>,
    pub slots: Option<Vec<([u32; 3], u8)>>,
    pub vertex_corners: Option<Vec<[u32; 3]>>,
    /// Grid files: per vertex its grid coordinates.
    pub q: Vec<[i64; 3]>,
    /// Exact files: per vertex its position.
    pub exact: Vec<[f64; 3]>,
}

/// A level's topology, with what its geometry section needs besides.
pub struct Topology {
    pub level: Level,
    pub vertex_count: usize,
    /// Per corner (level order): its canonical position, if it has one (§5.3, §5.4, §5.6, §5.9).
    pub pos: Vec<Option<u8>>,
    /// Modes 2 and 3: per parent face its canonical quad and orientation (§5.3).
    pub parent_quads: Vec<([u32; 4], u8)>,
}

/// Corner `c`'s face and index within it, for every corner in level order.
pub fn corner_list(faces: &[Vec<u32>]) -> Vec<(usize, usize)> {
    faces.iter().enumerate().flat_map(|(f, face)| (0..face.len()).map(move |i| (f, i))).collect()
}

// ---------------------------------------------------------------------------------------------
// §5.1 Mode 0: base level

pub fn mode0(h: &BlockHeader, st: &mut [Stream<'_>]) -> Result<Topology> {
    // Step 1: face sizes.
    let mut faces = Vec::new();
    let mut total = 0u64;
    let mut sizes = Vec::new();
    for _ in 0..h.face_count {
        let n = st[FACE_SIZES].varint()?.checked_add(3);
        total = total.saturating_add(n.unwrap_or(u64::MAX));
        require(total <= h.corner_count as u64, || "face sizes exceed corner_count".into())?;
        sizes.push(n.expect("checked by the total") as usize);
    }
    require(total == h.corner_count as u64, || "face sizes do not add up to corner_count".into())?;
    // Step 2: corners, as deltas.
    let mut v = 0i128;
    for n in sizes {
        let mut face = Vec::with_capacity(n);
        for _ in 0..n {
            v += i128::from(st[CORNERS].signed()?);
            require(v >= 0 && v < h.vertex_count as i128, || format!("vertex index {v} out of range"))?;
            face.push(v as u32);
        }
        faces.push(face);
    }
    let origins = vec![None; faces.len()];
    let mut level = Level { faces, origins, ..Level::default() };
    // Step 3.
    if h.lattice {
        raw_lattice(0, h, &mut st[RAW_LATTICE], &mut level)?;
    }
    let nc = h.corner_count;
    Ok(Topology { level, vertex_count: h.vertex_count, pos: vec![None; nc], parent_quads: Vec::new() })
}

// ---------------------------------------------------------------------------------------------
// §5.2 Rotation bytes

pub fn rotation_byte(s: &mut Stream<'_>) -> Result<u8> {
    let r = s.u8()?;
    require(r & !7 == 0, || format!("rotation byte {r:#x} with reserved bits"))?;
    Ok(r)
}

pub fn pos(r: u8, i: usize) -> usize {
    let turn = usize::from(r & 3);
    if r & 4 == 0 { (turn + i) % 4 } else { (turn + 4 - i) % 4 }
}

// ---------------------------------------------------------------------------------------------
// §5.3 Lattice faces (modes 2 and 3)

/// In-plane axes `(u, w)` of each side.
pub fn axes(d: u8) -> (usize, usize) {
    [(1, 2), (2, 1), (2, 0), (0, 2), (0, 1), (1, 0)][usize::from(d)]
}

/// In-plane offsets of the canonical corners.
pub const OFF: [(u32, u32); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// The canonical corners `sc_0 .. sc_3` of slot `(v, d)`.
pub fn canonical_corners(v: [u32; 3], d: u8) -> [[u32; 3]; 4] {
    let n = usize::from(d / 2);
    let (u, w) = axes(d);
    let mut b = v;
    if d % 2 == 0 {
        b[n] += 1;
    }
    OFF.map(|(du, dw)| {
        let mut c = b;
        c[u] += du;
        c[w] += dw;
        c
    })
}

pub fn corner_key(c: [u32; 3], k: usize) -> u64 {
    let m = (1u64 << k) + 1;
    (u64::from(c[2]) * m + u64::from(c[1])) * m + u64::from(c[0])
}

/// A corner key read back, if valid at depth `k`.
pub fn corner_of_key(key: u64, k: usize) -> Option<[u32; 3]> {
    let m = (1u64 << k) + 1;
    (key < m * m * m).then(|| [(key % m) as u32, (key / m % m) as u32, (key / (m * m)) as u32])
}

/// A slot key read back, if valid at depth `k`.
fn slot_of_key(key: u64, k: usize) -> Option<([u32; 3], u8)> {
    let n = 1u64 << k;
    let m = key / 6;
    (key < 6 * n * n * n).then(|| ([(m % n) as u32, (m / n % n) as u32, (m / (n * n)) as u32], (key % 6) as u8))
}

/// A Morton key read back, if valid at depth `k`: bit `3b + a` of `floor(key / 6)` is bit `b` of
/// axis `a`.
fn slot_of_morton_key(key: u64, k: usize) -> Option<([u32; 3], u8)> {
    let n = 1u64 << k;
    if key >= 6 * n * n * n {
        return None;
    }
    let m = key / 6;
    let mut v = [0u32; 3];
    for bit in 0..k {
        for (a, x) in v.iter_mut().enumerate() {
            *x |= ((m >> (3 * bit + a) & 1) as u32) << bit;
        }
    }
    Some((v, (key % 6) as u8))
}

/// Parent orientation: per parent face, its canonical quad and `rot_p`.
pub fn parent_orientations(parent: &Level) -> Result<Vec<([u32; 4], u8)>> {
    let (Some(slots), Some(lc)) = (&parent.slots, &parent.vertex_corners) else {
        return invalid("lattice mode under a parent without lattice coordinates");
    };
    let mut out = Vec::new();
    for (p, face) in parent.faces.iter().enumerate() {
        require(face.len() == 4, || format!("lattice mode under parent face {p} of {} corners", face.len()))?;
        let sc = canonical_corners(slots[p].0, slots[p].1);
        let mut best = (0usize, 0u8);
        for r in 0..8u8 {
            let matches = (0..4).filter(|&i| lc[face[i] as usize] == sc[pos(r, i)]).count();
            if matches > best.0 {
                best = (matches, r);
            }
        }
        let rot = best.1;
        let mut quad = [0u32; 4];
        for i in 0..4 {
            quad[pos(rot, i)] = face[i];
        }
        out.push((quad, rot));
    }
    Ok(out)
}

/// The faces of a lattice level: per face its slot, origin and rotation byte; per corner its
/// predicted key and canonical position.
pub struct LatticeFaces {
    pub slots: Vec<([u32; 3], u8)>,
    pub origins: Vec<Option<(u32, u8)>>,
    pub pk: Vec<u64>,
    pub pos: Vec<Option<u8>>,
    pub parent_quads: Vec<([u32; 4], u8)>,
}

pub fn lattice_faces(k: usize, h: &BlockHeader, st: &mut [Stream<'_>], parent: &Level) -> Result<LatticeFaces> {
    let parent_quads = parent_orientations(parent)?;
    let pslots = parent.slots.as_ref().expect("checked by parent_orientations");
    // Stream 1: child masks.
    let mut subs = Vec::new(); // (parent face, quadrant)
    for p in 0..parent.faces.len() {
        let mask = st[CHILD_MASKS].u8()?;
        require(mask & 0xf0 == 0, || format!("child mask {mask:#x} with bits 4-7"))?;
        for q in 0..4u8 {
            if mask >> q & 1 == 1 {
                subs.push((p as u32, q));
            }
        }
        require(subs.len() <= h.face_count, || "more subfaces than face_count".into())?;
    }
    let s = subs.len();
    // Stream 2: depths.
    let depths = st[DEPTHS].bytes(s.div_ceil(8))?;
    require(s % 8 == 0 || depths[s / 8] >> (s % 8) == 0, || "unused depth bits".into())?;
    let mut slots = Vec::new();
    let mut origins = Vec::new();
    for (j, &(p, q)) in subs.iter().enumerate() {
        // Child slot.
        let (v, d) = pslots[p as usize];
        let (rot, n) = (parent_quads[p as usize].1, usize::from(d / 2));
        let corner = canonical_corners(v, d)[pos(rot, usize::from(q))];
        let (u, w) = axes(d);
        let mut c = [0u32; 3];
        for a in [u, w] {
            c[a] = 2 * v[a] + (corner[a] - v[a]);
        }
        let outer = if d % 2 == 0 { 2 * v[n] + 1 } else { 2 * v[n] };
        let inner = depths[j / 8] >> (j % 8) & 1 == 1;
        c[n] = if inner { outer ^ 1 } else { outer };
        slots.push((c, d));
        origins.push(Some((p, q)));
    }
    // Stream 3: created keys.
    let mut key = None;
    for _ in s..h.face_count {
        let gap = st[CREATED_KEYS].varint()?;
        key = gap_next(key, gap);
        let Some(slot) = key.and_then(|x| slot_of_morton_key(x, k)) else {
            return invalid("created key is no valid Morton key");
        };
        slots.push(slot);
        origins.push(None);
    }
    // Step 4.
    require(h.corner_count == 4 * h.face_count, || "corner_count is not 4 face_count".into())?;
    // Stream 5: rotations; the predicted keys and canonical positions.
    let mut pk = Vec::new();
    let mut cpos = Vec::new();
    for (f, &(v, d)) in slots.iter().enumerate() {
        let r = rotation_byte(&mut st[ROTATIONS])?;
        let sc = canonical_corners(v, d);
        for i in 0..4 {
            pk.push(corner_key(sc[pos(r, i)], k));
            cpos.push((f < s).then_some(pos(r, i) as u8));
        }
    }
    Ok(LatticeFaces { slots, origins, pk, pos: cpos, parent_quads })
}

// ---------------------------------------------------------------------------------------------
// §5.4 Mode 1: generic refinement

pub fn mode1(k: usize, h: &BlockHeader, st: &mut [Stream<'_>], parent: &Level) -> Result<Topology> {
    // Step 1: the canonical subdivision's names.
    let vp = parent_vertex_count(parent);
    let mut edge_numbers: BTreeMap<(u32, u32), u64> = BTreeMap::new();
    let mut corner_edge: Vec<Vec<u64>> = Vec::new();
    for face in &parent.faces {
        let n = face.len();
        let mut edges = Vec::new();
        for i in 0..n {
            let (a, b) = (face[i], face[(i + 1) % n]);
            let next = edge_numbers.len() as u64;
            edges.push(*edge_numbers.entry((a.min(b), a.max(b))).or_insert(next));
        }
        corner_edge.push(edges);
    }
    let ep = edge_numbers.len() as u64;
    // Step 2: subfaces.
    let mut faces = Vec::new();
    let mut origins = Vec::new();
    let mut predicted: Vec<Option<u64>> = Vec::new();
    let mut cpos: Vec<Option<u8>> = Vec::new();
    for (p, face) in parent.faces.iter().enumerate() {
        let n = face.len();
        let mask = st[CHILD_MASKS].bytes(n.div_ceil(8))?;
        require(n % 8 == 0 || mask[n / 8] >> (n % 8) == 0, || "child mask bits beyond the face".into())?;
        for q in 0..n {
            if mask[q / 8] >> (q % 8) & 1 == 0 {
                continue;
            }
            require(q < 256, || "a quadrant above 255".into())?;
            require(faces.len() < h.face_count && 4 * (faces.len() + 1) <= h.corner_count, || {
                "more subfaces than face_count or corner_count allow".into()
            })?;
            let r = rotation_byte(&mut st[ROTATIONS])?;
            let layout =
                [u64::from(face[q]), vp + corner_edge[p][q], vp + ep + p as u64, vp + corner_edge[p][(q + n - 1) % n]];
            for i in 0..4 {
                predicted.push(Some(layout[pos(r, i)]));
                cpos.push(Some(pos(r, i) as u8));
            }
            faces.push(vec![0u32; 4]);
            origins.push(Some((p as u32, q as u8)));
        }
    }
    // Step 3: created faces.
    let mut corners = 4 * faces.len() as u64;
    while faces.len() < h.face_count {
        let n = st[FACE_SIZES].varint()?.saturating_add(3);
        corners = corners.saturating_add(n);
        require(corners <= h.corner_count as u64, || "faces hold more than corner_count corners".into())?;
        faces.push(vec![0u32; n as usize]);
        origins.push(None);
        predicted.extend((0..n).map(|_| None));
        cpos.extend((0..n).map(|_| None));
    }
    require(corners == h.corner_count as u64, || "faces hold fewer than corner_count corners".into())?;
    // Step 4: names, splits, corners.
    let names = names_and_splits(h, st, &predicted, None)?;
    let indices = resolve_corners(h, st, &predicted, &names, &mut cpos)?;
    fill_faces(&mut faces, &indices);
    let mut level = Level { faces, origins, ..Level::default() };
    // Step 5.
    if h.lattice {
        raw_lattice(k, h, &mut st[RAW_LATTICE], &mut level)?;
    }
    Ok(Topology { level, vertex_count: h.vertex_count, pos: cpos, parent_quads: Vec::new() })
}

/// `V_P`: the parent's vertex count.
fn parent_vertex_count(parent: &Level) -> u64 {
    parent.q.len().max(parent.exact.len()) as u64
}

fn fill_faces(faces: &mut [Vec<u32>], indices: &[u32]) {
    let mut c = 0;
    for face in faces {
        for x in face.iter_mut() {
            *x = indices[c];
            c += 1;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// §5.5 Names and splits (modes 1 and 2)

/// The name set: names in increasing order with their vertex counts and first vertex.
pub struct Names {
    pub first: BTreeMap<u64, (u64, u64)>,
}

/// `lattice_depth`: `Some(k)` in mode 2 (extra names are valid corner keys).
fn names_and_splits(
    h: &BlockHeader,
    st: &mut [Stream<'_>],
    predicted: &[Option<u64>],
    lattice_depth: Option<usize>,
) -> Result<Names> {
    let mut set: Vec<u64> = predicted.iter().flatten().copied().collect();
    set.sort_unstable();
    set.dedup();
    let predicted_set = set.clone();
    let count = st[EXTRA_NAMES].varint_at_most(h.vertex_count as u64, "extra name count")?;
    let mut name = None;
    for _ in 0..count {
        let gap = st[EXTRA_NAMES].varint()?;
        name = gap_next(name, gap);
        let Some(x) = name.filter(|&x| x != u64::MAX) else {
            return invalid("extra name beyond 2^64 - 2");
        };
        require(predicted_set.binary_search(&x).is_err(), || format!("extra name {x} is predicted"))?;
        if let Some(k) = lattice_depth {
            require(corner_of_key(x, k).is_some(), || format!("extra name {x} is no corner key"))?;
        }
        set.push(x);
    }
    set.sort_unstable();
    let mut vertices = vec![1u64; set.len()];
    let nsplit = st[SPLITS].varint_at_most(set.len() as u64, "split count")?;
    let mut index = None;
    for _ in 0..nsplit {
        let gap = st[SPLITS].varint()?;
        index = gap_next(index, gap);
        let Some(i) = index.filter(|&i| i < set.len() as u64) else {
            return invalid("split index beyond the name set");
        };
        let m = st[SPLITS].varint()?;
        require(m != 1, || "a split entry of 1".into())?;
        vertices[i as usize] = m;
    }
    let total = vertices.iter().try_fold(0u64, |acc, &m| acc.checked_add(m));
    require(total == Some(h.vertex_count as u64), || "names and splits do not make vertex_count vertices".into())?;
    let mut first = BTreeMap::new();
    let mut acc = 0u64;
    for (i, &x) in set.iter().enumerate() {
        first.insert(x, (acc, vertices[i]));
        acc += vertices[i];
    }
    Ok(Names { first })
}

// ---------------------------------------------------------------------------------------------
// §5.6 Corners (modes 1 and 2)

fn resolve_corners(
    h: &BlockHeader,
    st: &mut [Stream<'_>],
    predicted: &[Option<u64>],
    names: &Names,
    cpos: &mut [Option<u8>],
) -> Result<Vec<u32>> {
    let nc = h.corner_count as u64;
    let count = st[EXCEPTIONS].varint_at_most(nc, "exception count")?;
    let mut exceptions = BTreeMap::new();
    let mut at = None;
    for _ in 0..count {
        let gap = st[EXCEPTIONS].varint()?;
        at = gap_next(at, gap);
        let Some(c) = at.filter(|&c| c < nc) else {
            return invalid("exception corner beyond corner_count");
        };
        let v = st[EXCEPTIONS].varint()?;
        require(v < h.vertex_count as u64, || format!("exception vertex {v}"))?;
        require(predicted[c as usize].is_some(), || format!("exception at corner {c} without a prediction"))?;
        exceptions.insert(c as usize, v as u32);
    }
    let mut indices = Vec::with_capacity(predicted.len());
    let mut previous = 0i128;
    for (c, p) in predicted.iter().enumerate() {
        let v = match p {
            None => {
                previous += i128::from(st[CORNERS].signed()?);
                require(previous >= 0 && previous < h.vertex_count as i128, || format!("vertex {previous}"))?;
                previous as u32
            }
            Some(_) if exceptions.contains_key(&c) => {
                cpos[c] = None;
                exceptions[&c]
            }
            Some(name) => {
                let (first, m) = names.first[name];
                match m {
                    0 => return invalid(format!("corner {c} names {name}, which has no vertex")),
                    1 => first as u32,
                    _ => {
                        let choice = st[CHOICES].varint()?;
                        require(choice < m, || format!("choice {choice} of {m}"))?;
                        (first + choice) as u32
                    }
                }
            }
        };
        indices.push(v);
    }
    Ok(indices)
}

// ---------------------------------------------------------------------------------------------
// §5.7 Mode 2: lattice refinement

pub fn mode2(k: usize, h: &BlockHeader, st: &mut [Stream<'_>], parent: &Level) -> Result<Topology> {
    // Step 1.
    let lf = lattice_faces(k, h, st, parent)?;
    // Steps 2-3.
    let predicted: Vec<Option<u64>> = lf.pk.iter().map(|&x| Some(x)).collect();
    let names = names_and_splits(h, st, &predicted, Some(k))?;
    let mut cpos = lf.pos.clone();
    let indices = resolve_corners(h, st, &predicted, &names, &mut cpos)?;
    // Step 4: lattice corners from names.
    let mut vertex_corners = Vec::new();
    for (&name, &(_, m)) in &names.first {
        let c = corner_of_key(name, k).expect("names of mode 2 are valid corner keys");
        vertex_corners.extend((0..m).map(|_| c));
    }
    Ok(lattice_topology(h, lf, &indices, vertex_corners, cpos))
}

/// The decoded level of mode 2 or 3: quads in the order of §5.3, with their corners' vertices.
fn lattice_topology(
    h: &BlockHeader,
    lf: LatticeFaces,
    indices: &[u32],
    vertex_corners: Vec<[u32; 3]>,
    cpos: Vec<Option<u8>>,
) -> Topology {
    let mut faces = vec![vec![0u32; 4]; h.face_count];
    fill_faces(&mut faces, indices);
    let level = Level {
        faces,
        origins: lf.origins,
        slots: Some(lf.slots),
        vertex_corners: Some(vertex_corners),
        ..Level::default()
    };
    Topology { level, vertex_count: h.vertex_count, pos: cpos, parent_quads: lf.parent_quads }
}

// ---------------------------------------------------------------------------------------------
// §5.8 Raw lattice (modes 0 and 1 with LATTICE)

fn raw_lattice(k: usize, h: &BlockHeader, s: &mut Stream<'_>, level: &mut Level) -> Result<()> {
    let mut key = 0i128;
    let mut slots = Vec::new();
    for _ in 0..h.face_count {
        key += i128::from(s.signed()?);
        let slot = u64::try_from(key).ok().and_then(|x| slot_of_key(x, k));
        let Some(slot) = slot else { return invalid(format!("slot key {key} invalid")) };
        slots.push(slot);
    }
    key = 0;
    let mut corners = Vec::new();
    for _ in 0..h.vertex_count {
        key += i128::from(s.signed()?);
        let c = u64::try_from(key).ok().and_then(|x| corner_of_key(x, k));
        let Some(c) = c else { return invalid(format!("corner key {key} invalid")) };
        corners.push(c);
    }
    level.slots = Some(slots);
    level.vertex_corners = Some(corners);
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// §5.9 Mode 3: lattice refinement, first-use numbering

/// What a key holds in mode 3's key table (§5.9 step 3).
enum Entry {
    Vertex(u32),
    List(Vec<u32>),
}

/// Mode 3's numbering state (§5.9 step 3): the key table and the corners of the vertices
/// numbered so far.
struct Numbering {
    k: usize,
    vertex_count: usize,
    table: BTreeMap<u64, Entry>,
    vertex_corners: Vec<[u32; 3]>,
}

impl Numbering {
    /// Step 2: the split keys, each with an empty list.
    fn new(k: usize, h: &BlockHeader, split_keys: &mut Stream<'_>) -> Result<Self> {
        let mut table = BTreeMap::new();
        let ns = split_keys.varint_at_most(h.corner_count as u64, "split key count")?;
        let mut key = None;
        for _ in 0..ns {
            let gap = split_keys.varint()?;
            key = gap_next(key, gap);
            let Some(x) = key.filter(|&x| corner_of_key(x, k).is_some()) else {
                return invalid("split key is no valid corner key");
            };
            table.insert(x, Entry::List(Vec::new()));
        }
        Ok(Self { k, vertex_count: h.vertex_count, table, vertex_corners: Vec::new() })
    }

    /// Step 3: numbers the next vertex, at `key`.
    fn number(&mut self, key: u64) -> Result<u32> {
        let vc = &mut self.vertex_corners;
        require(vc.len() < self.vertex_count, || "corners number more than vertex_count vertices".into())?;
        vc.push(corner_of_key(key, self.k).expect("a valid key"));
        Ok(vc.len() as u32 - 1)
    }

    /// Step 5, an exception corner whose predicted key is `pk`: a vertex numbered before, or a
    /// new one at `pk` plus a delta, registered under its key.
    fn exception(&mut self, pk: u64, exceptions: &mut Stream<'_>) -> Result<u32> {
        let next = self.vertex_corners.len() as u64;
        let v = exceptions.varint()?;
        require(v <= next, || format!("exception vertex {v} beyond next {next}"))?;
        if v < next {
            return Ok(v as u32);
        }
        let delta = exceptions.signed()?;
        let key = i128::from(pk) + i128::from(delta);
        let key = u64::try_from(key).ok().filter(|&x| corner_of_key(x, self.k).is_some());
        let Some(key) = key else { return invalid("exception key is no valid corner key") };
        let v = self.number(key)?;
        match self.table.get_mut(&key) {
            Some(Entry::List(list)) => list.push(v),
            Some(Entry::Vertex(_)) => return invalid(format!("key {key} numbered twice")),
            None => {
                self.table.insert(key, Entry::Vertex(v));
            }
        }
        Ok(v)
    }

    /// Step 5, any other corner: the vertex registered under its key `pk`, a choice from a split
    /// key's list (or a new vertex appended to it), or a new vertex registered under `pk`.
    fn ordinary(&mut self, pk: u64, choices: &mut Stream<'_>) -> Result<u32> {
        let list_len = match self.table.get(&pk) {
            Some(Entry::Vertex(v)) => return Ok(*v),
            Some(Entry::List(list)) => list.len(),
            None => {
                let v = self.number(pk)?;
                self.table.insert(pk, Entry::Vertex(v));
                return Ok(v);
            }
        };
        let o = choices.varint()?;
        let m = list_len as u64;
        require(o <= m, || format!("choice {o} beyond a list of {m}"))?;
        if o < m {
            let Some(Entry::List(list)) = self.table.get(&pk) else { unreachable!("a list above") };
            return Ok(list[o as usize]);
        }
        let v = self.number(pk)?;
        if let Some(Entry::List(list)) = self.table.get_mut(&pk) {
            list.push(v);
        }
        Ok(v)
    }

    /// Step 6: the extra vertices, numbered after the corners' and not registered.
    fn extras(mut self, extra_keys: &mut Stream<'_>) -> Result<Vec<[u32; 3]>> {
        let e = extra_keys.varint()?;
        require(e == (self.vertex_count - self.vertex_corners.len()) as u64, || "extra_keys count".into())?;
        let mut key = 0i128;
        for _ in 0..e {
            key += i128::from(extra_keys.signed()?);
            let c = u64::try_from(key).ok().and_then(|x| corner_of_key(x, self.k));
            let Some(c) = c else { return invalid("extra key is no valid corner key") };
            self.vertex_corners.push(c);
        }
        Ok(self.vertex_corners)
    }
}

/// Mode 3 (§5.9), step by step.
pub fn mode3(k: usize, h: &BlockHeader, st: &mut [Stream<'_>], parent: &Level) -> Result<Topology> {
    let nc = h.corner_count as u64;
    // Step 1.
    let lf = lattice_faces(k, h, st, parent)?;
    let mut cpos = lf.pos.clone();
    // Steps 2 and 3.
    let mut numbering = Numbering::new(k, h, &mut st[SPLIT_KEYS])?;
    // Step 4: the exception count, and the first exception's corner.
    let count = st[EXCEPTIONS].varint_at_most(nc, "exception count")?;
    let mut left = count;
    let mut next_exception = None;
    if left > 0 {
        next_exception = Some(st[EXCEPTIONS].varint()?);
    }
    // Step 5: resolution.
    let mut indices = Vec::with_capacity(h.corner_count);
    for (c, &pk) in lf.pk.iter().enumerate() {
        if next_exception != Some(c as u64) {
            indices.push(numbering.ordinary(pk, &mut st[CHOICES])?);
            continue;
        }
        indices.push(numbering.exception(pk, &mut st[EXCEPTIONS])?);
        cpos[c] = None;
        left -= 1;
        next_exception = if left > 0 {
            let gap = st[EXCEPTIONS].varint()?;
            Some(gap_next(Some(c as u64), gap).unwrap_or(u64::MAX))
        } else {
            None
        };
    }
    require(next_exception.is_none(), || "exception corner beyond corner_count".into())?;
    // Step 6.
    let vertex_corners = numbering.extras(&mut st[EXTRA_KEYS])?;
    Ok(lattice_topology(h, lf, &indices, vertex_corners, cpos))
}
