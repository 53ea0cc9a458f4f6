//! The reconstruction's promises (the crate docs' guarantees), on synthetic shapes.
#![allow(clippy::print_stderr, clippy::needless_range_loop)]

mod support;

use octowrap_geom::DVec3;
use octowrap_mesh::Hierarchy;
use octowrap_recon::{MaxLevel, ReconOptions, reconstruct};
use support::{Topology, check_manifold, face_frames};

fn opts(level: u32) -> ReconOptions {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(level);
    o
}

/// Reconstructs to `level`, checks every level is manifold and the links are valid, and returns
/// the hierarchy and each level's topology.
fn build(name: &str, points: &[DVec3], o: &ReconOptions) -> (Hierarchy, Vec<Topology>) {
    let h = reconstruct(points, o).unwrap_or_else(|e| panic!("{name}: {e}"));
    h.check_links().unwrap_or_else(|e| panic!("{name}: {e}"));
    let tops: Vec<Topology> = h
        .levels
        .iter()
        .enumerate()
        .map(|(j, l)| {
            let lat = l.lattice.as_ref().expect("lattice");
            assert_eq!(lat.face_slots.len(), l.mesh.faces.len());
            check_manifold(&l.mesh).unwrap_or_else(|e| panic!("{name} level {j}: {e}"))
        })
        .collect();
    for (j, t) in tops.iter().enumerate() {
        eprintln!(
            "{name} level {j}: {} faces, {} boundary loops, {} components, euler {}",
            t.faces, t.boundary_loops, t.components, t.euler
        );
    }
    (h, tops)
}

#[test]
fn sphere_is_closed_genus_zero_and_outward() {
    let pts = support::sphere(60_000);
    let (h, tops) = build("sphere", &pts, &opts(6));
    for (j, t) in tops.iter().enumerate().skip(1) {
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 2), "level {j}");
    }
    // Faces grow about 4x per level.
    for j in 3..6 {
        let r = tops[j + 1].faces as f64 / tops[j].faces as f64;
        assert!((3.0..5.0).contains(&r), "level {j}: ratio {r}");
    }
    for j in 1..=6 {
        // Every face's lattice side looks outwards, and the mapped faces nearly all do too.
        let frames = face_frames(&h.levels[j].mesh);
        let lat = h.levels[j].lattice.as_ref().unwrap();
        for ((_, c), &(_, side)) in frames.iter().zip(&lat.face_slots) {
            let a = usize::from(side / 2);
            let s = if side % 2 == 0 { 1.0 } else { -1.0 };
            assert!(c[a] * s > -0.05, "level {j}: a face looks inwards at {c}");
        }
        let inward = frames.iter().filter(|(n, c)| n.dot(*c) <= 0.0).count();
        eprintln!("level {j}: {inward} of {} mapped faces fold inwards", frames.len());
        assert!(inward * 200 <= frames.len(), "level {j}: {inward} folded faces");
        // Vertices lie near the sphere.
        let h_j = 2.04 / f64::from(1u32 << j);
        for p in &h.levels[j].mesh.vertices.positions {
            assert!((p.length() - 1.0).abs() < 0.5 * h_j, "level {j}: vertex at radius {}", p.length());
        }
    }
}

#[test]
fn torus_has_genus_one() {
    let pts = support::torus(80_000, 1.0, 0.4);
    let (_, tops) = build("torus", &pts, &opts(6));
    for (j, t) in tops.iter().enumerate().skip(3) {
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 0), "level {j}");
    }
}

fn wrap_opts(level: u32) -> ReconOptions {
    let mut o = opts(level);
    o.sparse = octowrap_recon::SparseMode::Wrap;
    o
}

#[test]
fn bowl_stays_open_with_one_rim() {
    let pts = support::bowl(40_000, 0.1);
    let (_, tops) = build("bowl", &pts, &wrap_opts(6));
    for (j, t) in tops.iter().enumerate().skip(2) {
        assert_eq!((t.boundary_loops, t.components), (1, 1), "level {j}");
    }
}

#[test]
fn disc_with_a_hole_has_two_boundary_loops() {
    let pts = support::annulus(40_000, 0.35);
    let (_, tops) = build("annulus", &pts, &wrap_opts(6));
    for (j, t) in tops.iter().enumerate().skip(4) {
        assert_eq!((t.boundary_loops, t.components), (2, 1), "level {j}");
    }
}

#[test]
fn two_parallel_sheets_are_not_joined_across_the_gap() {
    let mut pts = support::sheet(150, 0.0, 1);
    pts.extend(support::sheet(150, 0.12, 2));
    let (h, tops) = build("sheets", &pts, &wrap_opts(6));
    for j in 5..=6 {
        let frames = face_frames(&h.levels[j].mesh);
        for (n, c) in &frames {
            assert!(!(c.z > 0.03 && c.z < 0.09), "level {j}: a face between the sheets at {c}");
            // No face looks into the gap.
            assert!(
                !(c.z > 0.06 && n.z < -0.7 || c.z < 0.06 && n.z > 0.7),
                "level {j}: face at {c} looks into the gap"
            );
        }
        assert_eq!(tops[j].components, 2, "level {j}");
    }
}

#[test]
fn thin_plate_stays_closed() {
    let pts = support::box_surface(80_000, DVec3::ZERO, DVec3::new(1.0, 1.0, 0.06), 3);
    let (h, tops) = build("plate", &pts, &wrap_opts(6));
    for (j, t) in tops.iter().enumerate().skip(1) {
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 2), "level {j}");
    }
    // Once the plate is several voxels thick, the two sides face away from each other.
    for (n, c) in face_frames(&h.levels[6].mesh) {
        if n.z.abs() > 0.7 {
            assert!(n.z * (c.z - 0.03) > 0.0, "a face at {c} looks into the plate");
        }
    }
}

#[test]
fn plate_with_a_pillar_wraps_the_pillar() {
    let mut pts = support::box_surface(60_000, DVec3::ZERO, DVec3::new(1.0, 1.0, 0.06), 5);
    // A pillar one level-5 voxel across (1.02 / 32 = 0.032) and 0.3 tall.
    pts.extend(support::box_surface(6_000, DVec3::new(0.5, 0.5, 0.06), DVec3::new(0.53, 0.53, 0.36), 6));
    let (h, tops) = build("pillar", &pts, &wrap_opts(5));
    // Level 1 sees the pillar's foot and the plate in one voxel; from level 2 on the whole
    // object is closed.
    for (j, t) in tops.iter().enumerate().skip(2) {
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 2), "level {j}");
    }
    for j in 3..=5 {
        let top = h.levels[j].mesh.vertices.positions.iter().map(|p| p.z).fold(f64::MIN, f64::max);
        assert!(top > 0.3, "level {j}: the pillar is not wrapped (top {top})");
    }
}

/// A unit sphere sampled densely above the equator and eight times more thinly below it.
fn half_sparse_sphere() -> Vec<DVec3> {
    support::sphere(120_000).into_iter().enumerate().filter(|(i, p)| p.z > 0.0 || i % 8 == 0).map(|(_, p)| p).collect()
}

#[test]
fn sparse_regions_are_subdivided_inside_closed_crack_free_levels() {
    let pts = half_sparse_sphere();
    let mut o = opts(6);
    o.region_density = 10.0;
    o.region_levels = 2;
    let r = octowrap_recon::reconstruct_with_progress(&pts, &o, &mut |_| {}).expect("reconstructs");
    let (h, tops) = build("half-sparse sphere", &pts, &o);
    assert_eq!(h.levels.len(), r.hierarchy.levels.len());
    let mut mixed = 0;
    for (j, (t, rep)) in tops.iter().zip(&r.levels).enumerate().skip(1) {
        eprintln!("level {j}: {:?}, {} sparse voxels of {} + filled", rep.kind, rep.sparse_voxels, rep.voxels);
        // Closed, one piece, genus 0: the border between the regions has no crack.
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 2), "level {j}");
        if rep.kind == octowrap_recon::LevelKind::Wrapped && rep.sparse_voxels > 0 {
            mixed += 1;
        }
    }
    assert!(mixed >= 1, "no level mixed dense and sparse regions");
    // The sparse half is subdivided: below the equator the faces of a mixed level are their
    // parents' split 1:4.
    for (j, rep) in r.levels.iter().enumerate().skip(1) {
        if rep.kind != octowrap_recon::LevelKind::Wrapped || rep.sparse_voxels == 0 {
            continue;
        }
        let low: Vec<bool> = face_frames(&h.levels[j - 1].mesh).iter().map(|(_, c)| c.z < -0.3).collect();
        let mut children = vec![0; low.len()];
        for o in &h.levels[j].origins {
            if let octowrap_mesh::FaceOrigin::Subface { parent, .. } = o {
                children[*parent as usize] += 1;
            }
        }
        let parents = low.iter().filter(|&&l| l).count();
        let split = low.iter().zip(&children).filter(|&(&l, &n)| l && n == 4).count();
        eprintln!("level {j}: {split} of {parents} parents below z = -0.3 split into four");
        assert!(parents > 100 && split == parents, "level {j}: the sparse half is not a 1:4 split");
    }
}

#[test]
fn sparse_regions_keep_an_open_bowl_open() {
    // A bowl sampled thinly on one side: the rim stays one loop at every level.
    let pts: Vec<DVec3> = support::bowl(80_000, 0.1)
        .into_iter()
        .enumerate()
        .filter(|(i, p)| p.x > 0.0 || i % 8 == 0)
        .map(|(_, p)| p)
        .collect();
    let mut o = opts(6);
    o.region_density = 10.0;
    o.region_levels = 2;
    let r = octowrap_recon::reconstruct_with_progress(&pts, &o, &mut |_| {}).expect("reconstructs");
    assert!(r.levels.iter().any(|l| l.sparse_voxels > 0), "no sparse region");
    let (_, tops) = build("half-sparse bowl", &pts, &o);
    for (j, t) in tops.iter().enumerate().skip(2) {
        assert_eq!((t.boundary_loops, t.components), (1, 1), "level {j}");
    }
}

#[test]
fn auto_goes_as_deep_as_dense_regions_are_wrapped() {
    let pts = half_sparse_sphere();
    let plain =
        octowrap_recon::reconstruct_with_progress(&pts, &ReconOptions::default(), &mut |_| {}).expect("reconstructs");
    let mut o = ReconOptions::default();
    o.region_levels = 2;
    // At 3 points per child the thin half counts as dense at level 5 and breaks into holes.
    o.region_density = 10.0;
    let r = octowrap_recon::reconstruct_with_progress(&pts, &o, &mut |_| {}).expect("reconstructs");
    let finest = r.hierarchy.levels.len() as u32 - 1;
    eprintln!("auto: {} levels without regions, {finest} with", plain.hierarchy.levels.len() - 1);
    assert_eq!(r.trusted_level, finest);
    assert!(finest > plain.trusted_level && finest <= plain.trusted_level + 2);
    // The levels past the global limit are mixed: wrapped, with sparse regions filled.
    let last = &r.levels[finest as usize];
    assert!(last.kind == octowrap_recon::LevelKind::Wrapped && last.sparse_voxels > 0);
    r.hierarchy.check_links().expect("links");
    for (j, l) in r.hierarchy.levels.iter().enumerate().skip(1) {
        let t = check_manifold(&l.mesh).unwrap_or_else(|e| panic!("level {j}: {e}"));
        assert_eq!((t.boundary_edges, t.components, t.euler), (0, 1, 2), "level {j}");
    }
}

/// RMS distance from `points` to the mesh (quads split along their shorter diagonal), brute force.
fn points_to_mesh_rms(points: &[DVec3], mesh: &octowrap_mesh::Mesh) -> f64 {
    let pos = &mesh.vertices.positions;
    let tris: Vec<[DVec3; 3]> = mesh.triangles().iter().map(|t| t.map(|v| pos[v as usize])).collect();
    let sum: f64 = points
        .iter()
        .map(|&p| tris.iter().map(|t| octowrap_geom::point_triangle_squared(p, t)).fold(f64::INFINITY, f64::min))
        .sum();
    (sum / points.len() as f64).sqrt()
}

#[test]
fn the_fit_brings_every_level_closer_to_the_points_and_keeps_the_topology() {
    // A torus (curved both ways, so a coarse mesh between its mapped vertices cuts inside and
    // outside), to level 4.
    // The repair of intersecting faces is off in both: it moves the vertices of folds, fitted
    // or not, and this compares the fit alone.
    let pts = support::torus(30_000, 1.0, 0.35);
    let mut on = opts(4);
    on.untangle_max_faces = 0;
    let mut off = on.clone();
    off.fit_passes = 0;
    let (plain, plain_tops) = build("torus, no fit", &pts, &off);
    let (fitted, fitted_tops) = build("torus, fit", &pts, &on);
    let sample: Vec<DVec3> = pts.iter().step_by(10).copied().collect();
    let mut last = f64::INFINITY;
    for j in 1..=4 {
        // The same faces and connectivity: only the positions moved.
        assert_eq!(plain.levels[j].mesh.faces, fitted.levels[j].mesh.faces, "level {j}");
        assert_eq!(plain_tops[j].euler, fitted_tops[j].euler);
        let a = points_to_mesh_rms(&sample, &plain.levels[j].mesh);
        let b = points_to_mesh_rms(&sample, &fitted.levels[j].mesh);
        eprintln!("level {j}: points-to-mesh RMS {a:.5} without the fit, {b:.5} with it");
        assert!(b < 0.8 * a, "level {j}: {b} is not well below {a}");
        assert!(b < last, "level {j}: the fitted error {b} did not fall (level above: {last})");
        last = b;
    }
}
