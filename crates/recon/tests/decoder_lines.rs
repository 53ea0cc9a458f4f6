//! Normal-mesh geometry by construction (`ReconOptions::decoder_lines`): every level lies on the
//! MRQ grid, the vertices on their decoder lines cost one number each, and the file decodes to the
//! levels reconstructed, bit for bit.

use octowrap_format::{DecodeOptions, EncodeOptions, decode_bytes, encode};
use octowrap_geom::DVec3;
use octowrap_mesh::Hierarchy;
use octowrap_recon::{DecoderGrid, MaxLevel, ReconOptions, Reconstruction, reconstruct_with_progress};

/// A bumpy sphere, sampled evenly.
fn sphere(n: u32) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let phi = f64::from(i) * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            let bump = 1.0 + 0.05 * (5.0 * phi).sin() * (4.0 * z).cos();
            DVec3::new(r * phi.cos(), r * phi.sin(), z) * bump
        })
        .collect()
}

fn run(points: &[DVec3], lines: Option<DecoderGrid>, reach: f64) -> Reconstruction {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(5);
    o.decoder_lines = lines;
    o.line_reach = reach;
    reconstruct_with_progress(points, &o, &mut |_| {}).unwrap()
}

fn bit_keys(h: &Hierarchy, k: usize) -> Vec<[u64; 3]> {
    let mut keys: Vec<[u64; 3]> =
        h.levels[k].mesh.vertices.positions.iter().map(|p| p.to_array().map(f64::to_bits)).collect();
    keys.sort_unstable();
    keys
}

/// With lines, whatever the reach: every vertex is a grid point, refined levels have vertices on
/// lines (all of them, by construction, at least as many as near lines), and the encoded file
/// decodes to exactly the reconstructed positions; by construction the file is smaller than
/// the free levels' on the same grid.
#[test]
fn levels_lie_on_the_grid_and_decode_exactly() {
    let points = sphere(30_000);
    let free = run(&points, None, 0.1);
    assert!(free.line_grid.is_none());
    assert!(free.levels.iter().all(|l| l.on_lines == 0));
    let mut sizes = Vec::new();
    let mut on = Vec::new();
    for reach in [0.1, f64::INFINITY] {
        let r = run(&points, Some(DecoderGrid::Finest), reach);
        let grid = r.line_grid.expect("a grid");
        assert_eq!(grid.bits(), octowrap_format::reconstruction_grid_bits(5));
        for level in &r.hierarchy.levels {
            for &p in &level.mesh.vertices.positions {
                assert_eq!(grid.snap(p), p, "reach {reach}: {p} is off the grid");
            }
        }
        let placed: usize = r.levels.iter().map(|l| l.on_lines).sum();
        assert!(r.levels[..2].iter().all(|l| l.on_lines == 0), "levels 0 and 1 have no lines");
        on.push(placed);
        let bytes = encode(&r.hierarchy, &EncodeOptions::with_quantization(grid.quantization())).unwrap();
        let decoded = decode_bytes(&bytes, &DecodeOptions::default()).unwrap().hierarchy;
        for k in 0..r.hierarchy.levels.len() {
            assert_eq!(bit_keys(&decoded, k), bit_keys(&r.hierarchy, k), "reach {reach}, level {k}");
        }
        let free_bytes = encode(&free.hierarchy, &EncodeOptions::with_quantization(grid.quantization())).unwrap();
        sizes.push((bytes.len(), free_bytes.len()));
    }
    let all: usize = run(&points, None, 0.1).levels[2..].iter().map(|l| l.vertices).sum();
    assert!(on[0] > 0 && on[1] >= on[0], "on lines: {on:?}");
    assert!(on[1] * 10 > all * 7, "by construction {} of {all} refined vertices on lines", on[1]);
    let (lines, free) = sizes[1];
    assert!(lines * 10 < free * 9, "by construction {lines} bytes, free {free}");
}

/// A grid the format cannot hold is an error naming the decoder lines, not a panic.
#[test]
fn a_bad_grid_is_an_error() {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(3);
    o.decoder_lines = Some(DecoderGrid::Bits(40));
    let e = reconstruct_with_progress(&sphere(5_000), &o, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("decoder lines"), "{e}");
}

/// Levels past the density-supported one are subdivided, and a subdivided level's quads start at
/// any corner of their voxel: a level subdivided from a subdivided parent still finds lines for
/// most of its vertices (the finest level is most of the file).
#[test]
fn subdivided_levels_keep_their_lines() {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(6);
    o.decoder_lines = Some(DecoderGrid::Finest);
    let r = reconstruct_with_progress(&sphere(3_000), &o, &mut |_| {}).unwrap();
    let trusted = r.trusted_level as usize;
    assert!(trusted + 2 <= 6, "the sphere is dense enough for level {trusted}: no subdivided parent");
    for (k, l) in r.levels.iter().enumerate().skip(trusted + 2) {
        assert!(
            l.on_lines * 2 > l.vertices,
            "level {k} (trusted {trusted}): {} of {} vertices on lines",
            l.on_lines,
            l.vertices
        );
    }
}
