//! Synthetic hierarchies for tests, fixtures, fuzzing and benchmarks (deterministic from a seed).
//!
//! [`cube_hierarchy`] builds what reconstruction produces, in miniature: the six faces of the root
//! voxel, each level the regular refinement of the one above with lattice coordinates, then edited
//! (children removed or pushed one voxel inwards, faces created, vertices split, a few corners
//! joined to other vertices), positions mapped towards a sphere and perturbed, and faces and
//! vertices shuffled. [`polygon_mesh`] builds an arbitrary (not manifold) polygon soup.

use octowrap_mesh::{Aabb, DVec3, FaceList, FaceOrigin, Hierarchy, Level, LevelLattice, Mesh, Quadrant};

use crate::topology::slots as lattice;

/// The generator the synthetic hierarchies draw from (deterministic from a seed).
pub use octowrap_geom::SplitMix64 as Rng;

/// How much editing [`cube_hierarchy`] applies per level.
#[derive(Clone, Copy, Debug)]
pub struct Edits {
    /// Probability that a child is removed.
    pub remove: f64,
    /// Probability that a child is pushed one voxel inwards.
    pub inner: f64,
    /// Created faces per level, as a fraction of the level's faces.
    pub create: f64,
    /// Probability that a face corner gets a split-off vertex.
    pub split: f64,
    /// Probability that a face corner is joined to another vertex (an exception).
    pub join: f64,
    /// Position noise in voxels of the level.
    pub noise: f64,
    /// Shuffle faces and vertices.
    pub shuffle: bool,
}

impl Default for Edits {
    fn default() -> Self {
        Self { remove: 0.05, inner: 0.1, create: 0.05, split: 0.01, join: 0.002, noise: 0.2, shuffle: true }
    }
}

impl Edits {
    /// No edits at all: every level is the canonical subdivision of its parent, in order.
    pub fn none() -> Self {
        Self { remove: 0.0, inner: 0.0, create: 0.0, split: 0.0, join: 0.0, noise: 0.0, shuffle: false }
    }
}

/// A hierarchy of `levels` levels over the unit cube `[0, 1]^3` (see the module docs).
pub fn cube_hierarchy(levels: usize, edits: Edits, seed: u64) -> Hierarchy {
    let mut rng = Rng::new(seed);
    let mut h = Hierarchy { levels: Vec::new(), cube: Some(Aabb { min: DVec3::ZERO, max: DVec3::ONE }) };
    // Level 0: the six faces of voxel (0,0,0).
    let mut slots: Vec<([u32; 3], u8)> = (0..6).map(|d| ([0, 0, 0], d)).collect();
    let mut parents: Vec<FaceOrigin> = vec![FaceOrigin::Created; 6];
    for k in 0..levels {
        let depth = k as u32;
        if k > 0 {
            let prev = h.levels.last().expect("level above");
            let pl = prev.lattice.as_ref().expect("lattice");
            slots.clear();
            parents.clear();
            let mut taken = std::collections::BTreeSet::new();
            for (pf, &(pv, pd)) in pl.face_slots.iter().enumerate() {
                let face = prev.mesh.faces.face(pf);
                for q in 0..4u8 {
                    if rng.chance(edits.remove) {
                        continue;
                    }
                    let pc = pl.vertex_corners[face[usize::from(q)] as usize];
                    let inner = rng.chance(edits.inner);
                    let Some(slot) = lattice::child_slot(pv, pd, pc, inner) else { continue };
                    if !taken.insert(lattice::slot_key(slot.0, slot.1, depth)) {
                        continue;
                    }
                    slots.push(slot);
                    parents.push(FaceOrigin::Subface { parent: pf as u32, quadrant: Quadrant(q) });
                }
            }
            let n = 1u32 << depth;
            let extra = (slots.len() as f64 * edits.create).round() as usize;
            for _ in 0..extra {
                let v = [rng.below(n as usize) as u32, rng.below(n as usize) as u32, rng.below(n as usize) as u32];
                let d = rng.below(6) as u8;
                if taken.insert(lattice::slot_key(v, d, depth)) {
                    slots.push((v, d));
                    parents.push(FaceOrigin::Created);
                }
            }
        }
        h.levels.push(build_level(&slots, &parents, depth, edits, &mut rng));
    }
    if edits.shuffle {
        shuffle(&mut h, &mut rng);
    }
    h
}

fn build_level(slots: &[([u32; 3], u8)], parents: &[FaceOrigin], depth: u32, e: Edits, rng: &mut Rng) -> Level {
    let mut vertex_of = std::collections::BTreeMap::new();
    let mut corners: Vec<[u32; 3]> = Vec::new();
    let mut quads = Vec::with_capacity(slots.len());
    for &(v, d) in slots {
        let sc = lattice::slot_corners(v, d);
        let rot = if e.shuffle { rng.below(4) } else { 0 };
        let mut quad = [0u32; 4];
        for i in 0..4 {
            let c = sc[(i + rot) % 4];
            let id = *vertex_of.entry(lattice::corner_key(c, depth)).or_insert_with(|| {
                corners.push(c);
                corners.len() as u32 - 1
            });
            quad[i] = id;
        }
        quads.push(quad);
    }
    // Splits and joins.
    let base_count = corners.len();
    for quad in &mut quads {
        for i in 0..4 {
            if rng.chance(e.split) {
                corners.push(corners[quad[i] as usize]);
                quad[i] = corners.len() as u32 - 1;
            } else if base_count > 0 && rng.chance(e.join) {
                quad[i] = rng.below(base_count) as u32;
            }
        }
    }
    let n = f64::from(1u32 << depth);
    let voxel = 1.0 / n;
    let positions = corners
        .iter()
        .map(|c| {
            let l = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2])) / n;
            let centre = DVec3::splat(0.5);
            let r = (l - centre).length().max(1e-9);
            let on_sphere = centre + (l - centre) * (0.45 / r);
            let p = l.lerp(on_sphere, 0.6);
            let noise = DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5) * (e.noise * voxel);
            p + noise
        })
        .collect();
    let mut mesh = Mesh::from_positions(positions);
    mesh.faces = FaceList::from_quads(&quads);
    Level {
        mesh,
        origins: parents.to_vec(),
        lattice: Some(LevelLattice { face_slots: slots.to_vec(), vertex_corners: corners }),
    }
}

fn permutation(n: usize, rng: &mut Rng) -> Vec<u32> {
    let mut p: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        p.swap(i, rng.below(i + 1));
    }
    p
}

/// Shuffles the faces and vertices of every level, keeping links and lattice arrays consistent.
pub fn shuffle(h: &mut Hierarchy, rng: &mut Rng) {
    let mut prev_face_new: Vec<u32> = Vec::new();
    for l in &mut h.levels {
        let nf = l.mesh.faces.len();
        let nv = l.mesh.vertices.len();
        let fperm = permutation(nf, rng); // new position -> old face
        let vperm = permutation(nv, rng);
        let mut vnew = vec![0u32; nv];
        for (new, &old) in vperm.iter().enumerate() {
            vnew[old as usize] = new as u32;
        }
        let mut faces = FaceList::with_capacity(nf, l.mesh.faces.corner_count());
        for &old in &fperm {
            faces.push_iter(l.mesh.faces.face(old as usize).iter().map(|&v| vnew[v as usize]));
        }
        let origins = fperm
            .iter()
            .map(|&old| match l.origins[old as usize] {
                FaceOrigin::Subface { parent, quadrant } => {
                    FaceOrigin::Subface { parent: prev_face_new[parent as usize], quadrant }
                }
                FaceOrigin::Created => FaceOrigin::Created,
            })
            .collect();
        let positions = vperm.iter().map(|&old| l.mesh.vertices.positions[old as usize]).collect();
        if let Some(lat) = &mut l.lattice {
            lat.face_slots = fperm.iter().map(|&old| lat.face_slots[old as usize]).collect();
            lat.vertex_corners = vperm.iter().map(|&old| lat.vertex_corners[old as usize]).collect();
        }
        l.mesh = Mesh { vertices: octowrap_mesh::PointCloud::from_positions(positions), faces };
        l.origins = origins;
        let mut face_new = vec![0u32; nf];
        for (new, &old) in fperm.iter().enumerate() {
            face_new[old as usize] = new as u32;
        }
        prev_face_new = face_new;
    }
}

/// The same hierarchy without lattice coordinates or cube (exercises the generic refinement).
pub fn without_lattice(mut h: Hierarchy) -> Hierarchy {
    for l in &mut h.levels {
        l.lattice = None;
    }
    h.cube = None;
    h
}

/// A polygon soup: `vertices` random points in `[-10, 10]^3`, `faces` faces of 3 to 7 random
/// corners (vertex indices may repeat across faces arbitrarily).
pub fn polygon_mesh(vertices: usize, faces: usize, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let positions =
        (0..vertices).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64()) * 20.0 - DVec3::splat(10.0)).collect();
    let mut mesh = Mesh::from_positions(positions);
    if vertices > 0 {
        for _ in 0..faces {
            let n = 3 + rng.below(5);
            mesh.faces.push_iter((0..n).map(|_| rng.below(vertices) as u32));
        }
    }
    mesh
}
