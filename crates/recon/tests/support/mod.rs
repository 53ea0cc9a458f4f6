//! Test support: a small independent manifold checker and synthetic point clouds.
#![allow(dead_code)] // each test file uses its own subset

use std::collections::{BTreeMap, BTreeSet};

use octowrap_geom::{DVec3, SplitMix64};
use octowrap_mesh::Mesh;

/// What the checker found.
#[derive(Debug, Default, Clone)]
pub struct Topology {
    pub faces: usize,
    pub vertices: usize,
    pub edges: usize,
    pub boundary_edges: usize,
    pub boundary_loops: usize,
    pub components: usize,
    /// V - E + F.
    pub euler: i64,
}

/// Checks the mesh is a two-manifold quad mesh with consistent orientation, from the face list
/// alone; returns its topology or a description of the first defect.
pub fn check_manifold(mesh: &Mesh) -> Result<Topology, String> {
    let (directed, incident) = directed_edges(mesh)?;
    let (edges, boundary) = undirected_edges(&directed);
    single_fans(mesh, &directed, &incident, &boundary)?;
    let nf = mesh.faces.len();
    let nv = mesh.vertices.len();
    Ok(Topology {
        faces: nf,
        vertices: nv,
        edges,
        boundary_edges: boundary.values().map(Vec::len).sum(),
        boundary_loops: boundary_loops(&boundary),
        components: components(nf, &directed),
        euler: nv as i64 - edges as i64 + nf as i64,
    })
}

/// Each directed edge `(a, b)` with the face that runs it.
type Directed = BTreeMap<(u32, u32), usize>;

/// Every directed edge with its face (each used once), and every vertex's faces; an error for a
/// face that is not a quad of four distinct in-range vertices.
fn directed_edges(mesh: &Mesh) -> Result<(Directed, Vec<Vec<usize>>), String> {
    let nv = mesh.vertices.len();
    let mut directed = Directed::new();
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for (f, face) in mesh.faces.iter().enumerate() {
        if face.len() != 4 {
            return Err(format!("face {f} has {} corners", face.len()));
        }
        for k in 0..4 {
            let (a, b) = (face[k], face[(k + 1) % 4]);
            if a as usize >= nv {
                return Err(format!("face {f} indexes vertex {a} of {nv}"));
            }
            if a == b {
                return Err(format!("face {f} repeats vertex {a}"));
            }
            if directed.insert((a, b), f).is_some() {
                return Err(format!("edge {a}->{b} is used twice in the same direction (face {f})"));
            }
            incident[a as usize].push(f);
        }
        let set: BTreeSet<u32> = face.iter().copied().collect();
        if set.len() != 4 {
            return Err(format!("face {f} repeats a vertex"));
        }
    }
    Ok((directed, incident))
}

/// The number of undirected edges (at most two faces each, as the directed edges are unique) and
/// the boundary edges by their start vertex.
fn undirected_edges(directed: &Directed) -> (usize, BTreeMap<u32, Vec<u32>>) {
    let mut edges = 0;
    let mut boundary: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for &(a, b) in directed.keys() {
        if !directed.contains_key(&(b, a)) {
            edges += 1;
            boundary.entry(a).or_default().push(b);
        } else if a < b {
            edges += 1;
        }
    }
    (edges, boundary)
}

/// Every vertex is used, and its faces form one fan (connected through edges at the vertex) with
/// at most one boundary edge leaving it.
fn single_fans(
    mesh: &Mesh,
    directed: &Directed,
    incident: &[Vec<usize>],
    boundary: &BTreeMap<u32, Vec<u32>>,
) -> Result<(), String> {
    for (v, fs) in incident.iter().enumerate() {
        if fs.is_empty() {
            return Err(format!("vertex {v} is unused"));
        }
        // Faces at v connect when they share an edge (v, w).
        let mut seen = BTreeSet::new();
        let mut stack = vec![fs[0]];
        while let Some(f) = stack.pop() {
            if !seen.insert(f) {
                continue;
            }
            let face = mesh.faces.face(f);
            let k = face.iter().position(|&x| x as usize == v).expect("incident");
            let next = face[(k + 1) % 4];
            let prev = face[(k + 3) % 4];
            for (a, b) in [(next, v as u32), (v as u32, prev)] {
                if let Some(&g) = directed.get(&(a, b)) {
                    stack.push(g);
                }
            }
        }
        if seen.len() != fs.len() {
            return Err(format!("vertex {v} has {} faces in {} fans or more", fs.len(), 2));
        }
        if boundary.get(&(v as u32)).map_or(0, Vec::len) > 1 {
            return Err(format!("vertex {v} has several boundary fans"));
        }
    }
    Ok(())
}

/// Boundary loops: chains of boundary edges, each followed from its start vertex.
fn boundary_loops(boundary: &BTreeMap<u32, Vec<u32>>) -> usize {
    let mut used = BTreeSet::new();
    let mut loops = 0;
    for (&a, outs) in boundary {
        for &b in outs {
            if used.contains(&(a, b)) {
                continue;
            }
            loops += 1;
            let (mut x, mut y) = (a, b);
            while used.insert((x, y)) {
                let Some(n) = boundary.get(&y).and_then(|o| o.first()) else { break };
                x = y;
                y = *n;
            }
        }
    }
    loops
}

/// Connected components of the faces, joined across edges, by union-find.
fn components(nf: usize, directed: &Directed) -> usize {
    fn root(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut parent: Vec<usize> = (0..nf).collect();
    for (&(a, b), &f) in directed {
        if let Some(&g) = directed.get(&(b, a)) {
            let (ra, rb) = (root(&mut parent, f), root(&mut parent, g));
            parent[ra] = rb;
        }
    }
    (0..nf).filter(|&f| root(&mut parent, f) == f).count()
}

/// Face normal (cross product of the diagonals) and centroid.
pub fn face_frames(mesh: &Mesh) -> Vec<(DVec3, DVec3)> {
    let p = &mesh.vertices.positions;
    mesh.faces
        .iter()
        .map(|f| {
            let q: Vec<DVec3> = f.iter().map(|&v| p[v as usize]).collect();
            let n = (q[2] - q[0]).cross(q[3] - q[1]);
            let c = q.iter().sum::<DVec3>() / q.len() as f64;
            (n.normalize_or_zero(), c)
        })
        .collect()
}

/// Fibonacci points on the unit sphere.
pub fn sphere(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let phi = i as f64 * 2.399_963_229_728_653;
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// A torus around Z, radii `big` and `small`, on a jittered angle grid.
pub fn torus(n: usize, big: f64, small: f64) -> Vec<DVec3> {
    let mut rng = SplitMix64::from_state(7);
    (0..n)
        .map(|_| {
            let u = rng.f64() * std::f64::consts::TAU;
            // Area-uniform: accept v with density (big + small cos v).
            let v = loop {
                let v = rng.f64() * std::f64::consts::TAU;
                if rng.f64() * (big + small) <= big + small * v.cos() {
                    break v;
                }
            };
            let r = big + small * v.cos();
            DVec3::new(r * u.cos(), r * u.sin(), small * v.sin())
        })
        .collect()
}

/// The lower unit hemisphere below `z = -cut` (an open bowl), one-sided.
pub fn bowl(n: usize, cut: f64) -> Vec<DVec3> {
    sphere(n).into_iter().filter(|p| p.z < -cut).collect()
}

/// A flat annulus in the plane z = 0 with radii `inner`..1, area-uniform, tiny noise.
pub fn annulus(n: usize, inner: f64) -> Vec<DVec3> {
    let mut rng = SplitMix64::from_state(11);
    (0..n)
        .map(|_| {
            let r = (inner * inner + rng.f64() * (1.0 - inner * inner)).sqrt();
            let a = rng.f64() * std::f64::consts::TAU;
            DVec3::new(r * a.cos(), r * a.sin(), (rng.f64() - 0.5) * 1e-4)
        })
        .collect()
}

/// Points on the surface of the box `[lo, hi]`, area-uniform.
pub fn box_surface(n: usize, lo: DVec3, hi: DVec3, seed: u64) -> Vec<DVec3> {
    let s = hi - lo;
    let areas = [s.y * s.z, s.y * s.z, s.x * s.z, s.x * s.z, s.x * s.y, s.x * s.y];
    let total: f64 = areas.iter().sum();
    let mut rng = SplitMix64::from_state(seed);
    (0..n)
        .map(|_| {
            let mut pick = rng.f64() * total;
            let mut side = 0;
            while side < 5 && pick >= areas[side] {
                pick -= areas[side];
                side += 1;
            }
            let (u, v) = (rng.f64(), rng.f64());
            let mut p = lo + s * DVec3::new(rng.f64(), u, v);
            let a = side / 2;
            p[a] = if side % 2 == 0 { hi[a] } else { lo[a] };
            p
        })
        .collect()
}

/// A square sheet `[0, 1]^2` at height `z`, jittered grid, one-sided.
pub fn sheet(side: usize, z: f64, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64::from_state(seed);
    let mut out = Vec::new();
    for i in 0..side {
        for j in 0..side {
            let x = (i as f64 + rng.f64()) / side as f64;
            let y = (j as f64 + rng.f64()) / side as f64;
            out.push(DVec3::new(x, y, z + (rng.f64() - 0.5) * 1e-4));
        }
    }
    out
}
