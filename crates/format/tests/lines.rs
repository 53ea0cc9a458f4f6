//! One-number line geometry (spec §6.6) and the placement that puts vertices on their lines:
//! placed hierarchies decode to exactly what was placed, most of their vertices cost one number,
//! the surface barely moves, and hierarchies not placed still round-trip within half a step.

use octowrap_format::synthetic::{Edits, cube_hierarchy, without_lattice};
use octowrap_format::{
    DecodeOptions, EncodeOptions, Quantization, canonical, decode, encode, encode_with_stats, place_on_prediction_lines,
};
use octowrap_mesh::Hierarchy;

fn q12() -> EncodeOptions {
    EncodeOptions::with_quantization(Quantization::Bits(12))
}

/// Encodes `h`, checks that the decoded positions equal `canonical(h)`'s (to binary64 rounding;
/// without an octree cube, the vertices on the bounding box, which placement leaves in place,
/// within half a step) and that re-encoding the decoded file gives the same
/// bytes; returns the bytes.
fn exact_round_trip(h: &Hierarchy, opts: &EncodeOptions) -> Vec<u8> {
    let bytes = encode(h, opts).unwrap();
    let file = decode(&bytes[..], &DecodeOptions::default()).unwrap();
    let step = file.info.grid.unwrap().step;
    let got = file.hierarchy;
    let want = canonical(h, opts).unwrap();
    let mut inexact = 0;
    for (k, (g, w)) in got.levels.iter().zip(&want.levels).enumerate() {
        assert_eq!(g.mesh.faces, w.mesh.faces, "level {k}");
        for (v, (a, b)) in g.mesh.vertices.positions.iter().zip(&w.mesh.vertices.positions).enumerate() {
            let err = (*a - *b).abs().max_element();
            assert!(err <= 0.5 * step * (1.0 + 1e-9), "level {k} vertex {v}: {a} against {b}");
            if err > 1e-12 {
                inexact += 1;
            }
        }
    }
    let mut bounds = octowrap_mesh::Aabb::EMPTY;
    let all = || h.levels.iter().flat_map(|l| l.mesh.vertices.positions.iter());
    for p in all() {
        bounds.grow(*p);
    }
    let on_box = all().filter(|p| (0..3).any(|a| p[a] <= bounds.min[a] || p[a] >= bounds.max[a])).count();
    assert!(
        inexact <= if h.cube.is_some() { 0 } else { on_box },
        "{inexact} vertices not placed on grid points ({on_box} on the box)"
    );
    assert_eq!(encode(&got, opts).unwrap(), bytes, "re-encoding the decoded hierarchy changes the bytes");
    bytes
}

#[test]
fn placed_lattice_hierarchies_decode_exactly_and_shrink() {
    for seed in 1..4 {
        let h = cube_hierarchy(6, Edits::default(), seed);
        let mut placed = h.clone();
        let stats = place_on_prediction_lines(&mut placed, &q12()).unwrap();
        assert!(stats.placed > 2 * stats.kept, "{stats:?}");
        let before = encode(&h, &q12()).unwrap();
        let after = exact_round_trip(&placed, &q12());
        assert!(after.len() * 10 < before.len() * 8, "seed {seed}: {} bytes placed, {} not", after.len(), before.len());
        // Vertices slide along the surface: no move beyond the limit.
        // 1.5 voxels of level 2 (the first level placed) in the unit cube.
        let limit = 1.5 / 4.0;
        assert!(stats.max_move <= limit, "{stats:?}");
        // Same topology, level by level.
        for (a, b) in placed.levels.iter().zip(&h.levels) {
            assert_eq!(a.mesh.faces, b.mesh.faces);
            assert_eq!(a.origins, b.origins);
        }
        let (_, levels) = encode_with_stats(&placed, &q12()).unwrap();
        let first = octowrap_format::LinePlacement::first_placed_level();
        assert!(levels[first..].iter().all(|l| l.predictor & 2 != 0), "every placed level codes lines: {levels:?}");
    }
}

#[test]
fn placed_generic_hierarchies_decode_exactly_and_shrink() {
    let h = without_lattice(cube_hierarchy(5, Edits::default(), 7));
    let mut placed = h.clone();
    let stats = place_on_prediction_lines(&mut placed, &q12()).unwrap();
    assert!(stats.placed > 2 * stats.kept, "{stats:?}");
    let before = encode(&h, &q12()).unwrap();
    let after = exact_round_trip(&placed, &q12());
    assert!(after.len() < before.len(), "{} bytes placed, {} not", after.len(), before.len());
}

#[test]
fn placement_is_deterministic_and_keeps_untied_grids() {
    // Without a cube the grid follows the bounding box: placement must not change it.
    let mut h = cube_hierarchy(5, Edits::default(), 11);
    h.cube = None;
    for opts in [q12(), EncodeOptions::with_quantization(Quantization::Step(1.0 / 3000.0))] {
        let mut a = h.clone();
        let mut b = h.clone();
        let sa = place_on_prediction_lines(&mut a, &opts).unwrap();
        let sb = place_on_prediction_lines(&mut b, &opts).unwrap();
        assert_eq!(sa, sb);
        assert_eq!(a, b);
        assert!(sa.placed > 0, "{sa:?}");
        let bytes = exact_round_trip(&a, &opts);
        let info = decode(&bytes[..], &DecodeOptions::default()).unwrap().info;
        let plain = decode(&encode(&h, &opts).unwrap()[..], &DecodeOptions::default()).unwrap().info;
        assert_eq!(info.grid, plain.grid, "placement changed the grid");
    }
}

#[test]
fn exact_files_have_no_lines() {
    let h = cube_hierarchy(4, Edits::default(), 3);
    let mut placed = h.clone();
    let stats = place_on_prediction_lines(&mut placed, &EncodeOptions::with_quantization(Quantization::Exact)).unwrap();
    assert_eq!(placed, h);
    assert_eq!(stats.placed, 0);
}

#[test]
fn hierarchies_off_their_lines_still_round_trip() {
    // Place, then push some vertices off their lines: those take three residuals.
    let mut h = cube_hierarchy(5, Edits::default(), 5);
    place_on_prediction_lines(&mut h, &q12()).unwrap();
    for l in &mut h.levels[1..] {
        for (i, p) in l.mesh.vertices.positions.iter_mut().enumerate() {
            if i % 7 == 0 {
                p.x += 0.37 / 4096.0 * (i % 5) as f64;
                p.y -= 1.1 / 4096.0;
            }
        }
    }
    let bytes = encode(&h, &q12()).unwrap();
    let got = decode(&bytes[..], &DecodeOptions::default()).unwrap();
    let step = got.info.grid.unwrap().step;
    let want = canonical(&h, &q12()).unwrap();
    for (g, w) in got.hierarchy.levels.iter().zip(&want.levels) {
        for (a, b) in g.mesh.vertices.positions.iter().zip(&w.mesh.vertices.positions) {
            assert!((*a - *b).abs().max_element() <= 0.5 * step * (1.0 + 1e-9));
        }
    }
}
