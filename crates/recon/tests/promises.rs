//! The reconstruction's promises (see `../shared/docs/reconstruction.md`), on synthetic shapes.
#![allow(clippy::print_stderr)]

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
