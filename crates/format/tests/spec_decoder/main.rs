//! An MRQ decoder written from `spec/FORMAT.md` alone, section by section, as proof that the spec
//! is complete: plain and slow (maps and vectors, 128-bit integers where in doubt), using only std,
//! `zstd` and `xxhash-rust`, and nothing of `octowrap-format` but its decoder, called here to
//! compare results.
//!
//! The tests decode every conformance file (spec §9): each file of `fixtures/format/valid/` and
//! `regress/` must decode to what the reference decoder returns (every level's positions bit for
//! bit, faces, origins, lattice coordinates; the cube and the metadata) and to the golden dump
//! beside it; each file of `invalid/` must be rejected with the error class its README names.

mod block;
mod chunks;
mod compare;
mod container;
mod file;
mod geometry;
mod geometry3;
mod primitives;
mod topology;
mod values;

use std::path::{Path, PathBuf};

use serde_json::json;

use compare::compare_with_reference;
use file::{File, decode};
use primitives::SpecError;

fn dir(sub: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format").join(sub)
}

fn files(sub: &str) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir(sub))
        .expect("fixture folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "mrq"))
        .collect();
    out.sort();
    out
}

/// The golden dump of spec §9, written the way the conformance test writes it.
fn dump(f: &File) -> String {
    let levels: Vec<_> = f
        .levels
        .iter()
        .zip(&f.positions)
        .map(|(l, p)| {
            json!({
                "vertices": p,
                "faces": l.faces,
                "origins": l.origins.iter().map(|o| o.map(|(p, q)| json!([p, q]))).collect::<Vec<_>>(),
                "lattice": l.slots.as_ref().zip(l.vertex_corners.as_ref()).map(|(s, c)| json!({
                    "face_slots": s.iter().map(|(v, d)| [v[0], v[1], v[2], u32::from(*d)]).collect::<Vec<_>>(),
                    "vertex_corners": c,
                })),
            })
        })
        .collect();
    let cube = f.cube.map(|(a, b)| [a, b]);
    serde_json::to_string_pretty(&json!({ "cube": cube, "levels": levels })).expect("json") + "\n"
}

fn check_decodes(sub: &str) -> usize {
    let mut n = 0;
    for path in files(sub) {
        let bytes = std::fs::read(&path).expect("fixture");
        let ours = decode(&bytes).unwrap_or_else(|e: SpecError| panic!("{}: {e}", path.display()));
        compare_with_reference(&path, &bytes, &ours);
        let golden = std::fs::read_to_string(path.with_extension("json")).expect("golden dump");
        assert!(dump(&ours) == golden, "{}: differs from its golden dump", path.display());
        n += 1;
    }
    n
}

#[test]
fn valid_files_decode_as_the_reference_decoder_does() {
    let n = check_decodes("valid");
    assert!(n >= 21, "{n} valid files");
}

#[test]
fn regress_files_decode_as_the_reference_decoder_does() {
    let n = check_decodes("regress");
    assert!(n >= 3, "{n} regress files");
}

#[test]
fn invalid_files_fail_with_their_class() {
    let readme = std::fs::read_to_string(dir("invalid").join("README.md")).expect("README");
    let mut n = 0;
    for line in readme.lines().filter(|l| l.starts_with("| ") && l.contains(".mrq")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let (name, class) = (cells[1], cells[3]);
        let bytes = std::fs::read(dir("invalid").join(name)).expect("fixture");
        match decode(&bytes) {
            Ok(_) => panic!("{name} decoded, expected {class}"),
            Err(e) => assert_eq!(e.class.name(), class, "{name}: {e}"),
        }
        n += 1;
    }
    assert_eq!(n, files("invalid").len(), "every invalid file is listed in the README");
    assert!(n >= 32, "{n} invalid files");
}

#[test]
fn every_prefix_of_a_small_valid_file_is_truncated() {
    // Spec §7.1: a file that ends early is `truncated` (after a correct magic).
    for path in files("valid").into_iter().filter(|p| std::fs::metadata(p).is_ok_and(|m| m.len() < 700)) {
        let bytes = std::fs::read(&path).expect("fixture");
        for len in 1..bytes.len() {
            match decode(&bytes[..len]) {
                Ok(_) => panic!("{} cut at {len} decodes", path.display()),
                Err(e) => assert_eq!(e.class.name(), "truncated", "{} cut at {len}: {e}", path.display()),
            }
        }
    }
}
