//! Property: for random hierarchies (random edits, lattice or not) and random quantization, the
//! decoded file equals the canonical form of the input: topology exactly, every position within
//! half a grid step on every axis; and encoding is deterministic. Also after placing the vertices
//! on their prediction lines.

use octowrap_format::synthetic::{Edits, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::{DecodeOptions, EncodeOptions, Quantization, canonical, decode, encode};
use octowrap_mesh::Hierarchy;
use proptest::prelude::*;

fn check(h: &Hierarchy, opts: &EncodeOptions) -> Result<(), TestCaseError> {
    let bytes = encode(h, opts).map_err(|e| TestCaseError::fail(e.to_string()))?;
    prop_assert_eq!(&bytes, &encode(h, opts).unwrap());
    let want = canonical(h, opts).unwrap();
    let file = decode(&bytes[..], &DecodeOptions::default()).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let step = file.info.grid.map_or(0.0, |g| g.step);
    for (g, w) in file.hierarchy.levels.iter().zip(&want.levels) {
        prop_assert_eq!(&g.mesh.faces, &w.mesh.faces);
        prop_assert_eq!(&g.origins, &w.origins);
        prop_assert_eq!(&g.lattice, &w.lattice);
        for (a, b) in g.mesh.vertices.positions.iter().zip(&w.mesh.vertices.positions) {
            let err = (*a - *b).abs().max_element();
            prop_assert!(err <= step * 0.5 * (1.0 + 1e-9) + 1e-12 * b.abs().max_element().max(1.0));
        }
    }
    Ok(())
}

fn quantization() -> impl Strategy<Value = Quantization> {
    prop_oneof![
        Just(Quantization::Exact),
        (1u32..=24).prop_map(Quantization::Bits),
        (1e-4f64..0.5).prop_map(Quantization::Step),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn hierarchies_round_trip(
        seed in any::<u64>(),
        levels in 1usize..5,
        remove in 0.0f64..0.5,
        inner in 0.0f64..0.5,
        create in 0.0f64..0.3,
        split in 0.0f64..0.2,
        join in 0.0f64..0.1,
        lattice in any::<bool>(),
        lines in any::<bool>(),
        v3 in any::<bool>(),
        q in quantization(),
    ) {
        let edits = Edits { remove, inner, create, split, join, noise: 0.3, shuffle: true };
        let h = cube_hierarchy(levels, edits, seed);
        let mut h = if lattice { h } else { without_lattice(h) };
        let mut opts = EncodeOptions::with_quantization(q);
        // Format version 3 (spec §5.9, §6.8): lattice levels in mode 3.
        opts.version = if v3 { 3 } else { 2 };
        if lines {
            // Vertices on their prediction lines (spec §6.6): still within half a step.
            octowrap_format::place_on_prediction_lines(&mut h, &opts).map_err(|e| TestCaseError::fail(e.to_string()))?;
        }
        check(&h, &opts)?;
    }

    #[test]
    fn version_3_lattice_hierarchies_round_trip(
        seed in any::<u64>(),
        levels in 2usize..5,
        remove in 0.0f64..0.5,
        inner in 0.0f64..0.5,
        create in 0.0f64..0.3,
        split in 0.0f64..0.2,
        join in prop_oneof![Just(0.0f64), 0.0f64..0.1],
        lines in any::<bool>(),
        bits in 4u32..=20,
    ) {
        let edits = Edits { remove, inner, create, split, join, noise: 0.3, shuffle: true };
        let mut h = cube_hierarchy(levels, edits, seed);
        let mut opts = EncodeOptions::with_quantization(Quantization::Bits(bits));
        opts.version = 3;
        if lines {
            octowrap_format::place_on_prediction_lines(&mut h, &opts).map_err(|e| TestCaseError::fail(e.to_string()))?;
        }
        check(&h, &opts)?;
        // Every level that version 2 codes in mode 2 is in mode 3, the others as in version 2.
        let (bytes, stats) = octowrap_format::encode_with_stats(&h, &opts).unwrap();
        prop_assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 3);
        opts.version = 2;
        let (_, stats2) = octowrap_format::encode_with_stats(&h, &opts).unwrap();
        let modes: Vec<u8> = stats.iter().map(|s| s.mode).collect();
        let want: Vec<u8> = stats2.iter().map(|s| if s.mode == 2 { 3 } else { s.mode }).collect();
        prop_assert_eq!(&modes, &want);
        if join == 0.0 {
            // Without joins every refinement is a lattice one.
            prop_assert!(modes.iter().skip(1).all(|&m| m == 3), "{:?}", modes);
        }
    }

    #[test]
    fn polygon_meshes_round_trip(seed in any::<u64>(), n in 0usize..200, f in 0usize..150, q in quantization()) {
        check(&Hierarchy::single(polygon_mesh(n, f, seed)), &EncodeOptions::with_quantization(q))?;
    }
}
