//! Conformance vectors in `fixtures/format/`: `valid/` files must decode to their golden dump
//! (`NAME.mrq` beside `NAME.json`), `invalid/` files must fail with the error kind listed in
//! `invalid/README.md`, `regress/` files must decode to their dump too.
//!
//! To rewrite the vectors after an intended format change:
//! `OCTOWRAP_REGEN_FIXTURES=1 cargo test --release -p octowrap-format --test conformance`
//! (then review the diff and add a change-log line to spec/FORMAT.md).

use std::path::{Path, PathBuf};

use octowrap_format::DecodeError as Error;
use octowrap_format::fuzzing::{payloads, reseal};
use octowrap_format::synthetic::{Edits, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::tamper::fix_preamble_checksum;
use octowrap_format::{
    DecodeOptions, EncodeOptions, Limits, Metadata, Quantization, decode, encode, place_on_prediction_lines,
};
use octowrap_mesh::{DVec3, FaceList, FaceOrigin, Hierarchy, Mesh};
use serde_json::json;

fn dir(sub: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format").join(sub)
}

fn regen() -> bool {
    std::env::var_os("OCTOWRAP_REGEN_FIXTURES").is_some()
}

/// The golden dump of a decoded hierarchy: JSON, one level per entry.
fn dump(h: &Hierarchy) -> String {
    let levels: Vec<_> = h
        .levels
        .iter()
        .map(|l| {
            json!({
                "vertices": l.mesh.vertices.positions.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
                "faces": l.mesh.faces.iter().collect::<Vec<_>>(),
                "origins": l.origins.iter().map(|o| match o {
                    FaceOrigin::Subface { parent, quadrant } => json!([parent, quadrant.0]),
                    FaceOrigin::Created => json!(null),
                }).collect::<Vec<_>>(),
                "lattice": l.lattice.as_ref().map(|x| json!({
                    "face_slots": x.face_slots.iter().map(|(v, d)| [v[0], v[1], v[2], u32::from(*d)]).collect::<Vec<_>>(),
                    "vertex_corners": x.vertex_corners,
                })),
            })
        })
        .collect();
    let cube = h.cube.map(|c| [c.min.to_array(), c.max.to_array()]);
    serde_json::to_string_pretty(&json!({ "cube": cube, "levels": levels })).expect("json") + "\n"
}

/// Version 2 options (the files written before version 3 stay as they were).
fn q(bits: u32) -> EncodeOptions {
    v2(EncodeOptions::with_quantization(Quantization::Bits(bits)))
}

fn v2(mut opts: EncodeOptions) -> EncodeOptions {
    opts.version = 2;
    opts
}

fn valid_set() -> Vec<(&'static str, Vec<u8>)> {
    let mut quad = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    quad.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
    let mut meta = v2(EncodeOptions::with_quantization(Quantization::Step(0.25)));
    meta.metadata = Metadata {
        units: "m".into(),
        source: "conformance".into(),
        generator: "octowrap-format tests".into(),
        entries: vec![("crs".into(), "EPSG:25832".into())],
    };
    let exact = v2(EncodeOptions::with_quantization(Quantization::Exact));
    vec![
        ("one_quad_exact", encode(&Hierarchy::single(quad.clone()), &exact).unwrap()),
        ("one_quad_metadata_step", encode(&Hierarchy::single(quad), &meta).unwrap()),
        ("empty_mesh", encode(&Hierarchy::single(Mesh::default()), &q(12)).unwrap()),
        ("polygon_soup_q16", encode(&Hierarchy::single(polygon_mesh(30, 20, 5)), &q(16)).unwrap()),
        ("cube3_lattice_q12", encode(&cube_hierarchy(3, Edits::default(), 3), &q(12)).unwrap()),
        ("cube3_lattice_exact", encode(&cube_hierarchy(3, Edits::default(), 4), &exact).unwrap()),
        ("cube3_generic_q12", encode(&without_lattice(cube_hierarchy(3, Edits::default(), 5)), &q(12)).unwrap()),
        ("cube3_subdivision_q10", encode(&cube_hierarchy(3, Edits::none(), 6), &q(10)).unwrap()),
        ("cube3_lattice_lines_q12", encode(&placed(cube_hierarchy(3, Edits::default(), 3)), &q(12)).unwrap()),
        (
            "cube3_generic_lines_q12",
            encode(&placed(without_lattice(cube_hierarchy(3, Edits::default(), 5))), &q(12)).unwrap(),
        ),
        // Format version 3 (spec §5.9, §6.8): lattice refinements in mode 3.
        ("v3_cube3_lattice_q12", encode(&cube_hierarchy(3, Edits::default(), 3), &v3(q(12))).unwrap()),
        ("v3_cube3_lattice_exact", encode(&cube_hierarchy(3, Edits::default(), 4), &v3(exact.clone())).unwrap()),
        (
            "v3_cube3_lattice_lines_q12",
            encode(&placed_with(cube_hierarchy(3, Edits::default(), 3), &v3(q(12))), &v3(q(12))).unwrap(),
        ),
        ("v3_cube3_subdivision_q10", encode(&cube_hierarchy(3, Edits::none(), 6), &v3(q(10))).unwrap()),
        ("v3_cube3_generic_q12", encode(&without_lattice(cube_hierarchy(3, Edits::default(), 5)), &v3(q(12))).unwrap()),
    ]
}

/// `opts` writing format version 3.
fn v3(mut opts: EncodeOptions) -> EncodeOptions {
    opts.version = 3;
    opts
}

/// `h` with its vertices on their prediction lines under `opts`.
fn placed_with(mut h: Hierarchy, opts: &EncodeOptions) -> Hierarchy {
    place_on_prediction_lines(&mut h, opts).unwrap();
    h
}

/// `h` with its vertices on their prediction lines of a 12-bit grid (spec §6.6).
fn placed(mut h: Hierarchy) -> Hierarchy {
    place_on_prediction_lines(&mut h, &q(12)).unwrap();
    h
}

fn regress_set() -> Vec<(&'static str, Vec<u8>)> {
    let joins = Edits { join: 0.3, split: 0.1, ..Edits::default() };
    vec![
        // A predicted name whose every corner is an exception has no vertex (a split entry of 0);
        // the first decoder miscounted such levels.
        ("names_without_vertices_lattice", encode(&cube_hierarchy(3, joins, 8), &q(12)).unwrap()),
        ("names_without_vertices_generic", encode(&without_lattice(cube_hierarchy(3, joins, 9)), &q(12)).unwrap()),
        // Version 3: keys whose every corner is an exception, split keys, exceptions numbering
        // new vertices.
        ("v3_splits_and_exceptions", encode(&cube_hierarchy(3, joins, 8), &v3(q(12))).unwrap()),
    ]
}

/// (file, expected error kind, what is wrong, bytes).
fn invalid_set() -> Vec<(&'static str, &'static str, &'static str, Vec<u8>)> {
    let base = encode(&cube_hierarchy(3, Edits::default(), 3), &q(12)).unwrap();
    let good_payloads = payloads(&base).unwrap();
    let level1 = |b: &[u8]| {
        let info = octowrap_format::read_info(b, &Limits::default()).unwrap();
        info.levels[1].clone()
    };
    let mut out = Vec::new();
    let mut b = base.clone();
    b[1] = b'X';
    out.push(("bad_magic.mrq", "BadMagic", "the second magic byte is `X`", b));
    let mut b = base.clone();
    b[8] = 4;
    out.push(("version_4.mrq", "UnsupportedVersion", "version 4", b));
    out.push(("truncated_header.mrq", "Truncated", "the file ends inside the header", base[..60].to_vec()));
    let l1 = level1(&base);
    let cut = (l1.offset + l1.stored_size / 2) as usize;
    out.push(("truncated_level1.mrq", "Truncated", "the file ends inside level 1", base[..cut].to_vec()));
    let mut b = base.clone();
    let meta_byte = 112 + 48 * 3 + 2;
    b[meta_byte] ^= 1;
    out.push(("preamble_checksum.mrq", "ChecksumMismatch", "a metadata byte changed", b));
    let mut b = base.clone();
    b[(l1.offset + 5) as usize] ^= 0x10;
    out.push(("level1_checksum.mrq", "ChecksumMismatch", "a byte of level 1's stored bytes changed", b));
    let mut b = base.clone();
    b[12] |= 8;
    out.push(("reserved_flag.mrq", "Invalid", "reserved header flag bit 3 set", b));
    let mut b = base.clone();
    b[16..20].copy_from_slice(&1000u32.to_le_bytes());
    out.push(("too_many_levels.mrq", "LimitExceeded", "level_count 1000", b));
    let mut b = base.clone();
    let off = 112 + 48; // level 1's offset field
    let v = u64::from_le_bytes(b[off..off + 8].try_into().unwrap()) + 1;
    b[off..off + 8].copy_from_slice(&v.to_le_bytes());
    fix_preamble_checksum(&mut b);
    out.push(("level_gap.mrq", "Invalid", "level 1 does not start where level 0 ends", b));
    let mut b = base.clone();
    let off = 112 + 48 + 32; // level 1's vertex_count
    let v = u32::from_le_bytes(b[off..off + 4].try_into().unwrap()) + 1;
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
    fix_preamble_checksum(&mut b);
    out.push(("count_mismatch.mrq", "Invalid", "level 1's vertex_count differs from its block header", b));
    let mut p = good_payloads.clone();
    p[1][0] = 7;
    out.push(("unknown_mode.mrq", "Invalid", "level 1 block mode 7", reseal(&base, &p, None).unwrap()));
    let mut p = good_payloads.clone();
    p[0][0] = 2;
    out.push(("lattice_mode_at_level0.mrq", "Invalid", "level 0 in mode 2", reseal(&base, &p, None).unwrap()));
    let mut p = good_payloads.clone();
    p[2].push(0);
    out.push((
        "trailing_byte.mrq",
        "Invalid",
        "level 2's payload has one byte more than its streams",
        reseal(&base, &p, None).unwrap(),
    ));
    let mut p = good_payloads.clone();
    // Rotation stream of level 1: after child_masks and depths.
    let sizes: Vec<usize> =
        (0..12).map(|i| u32::from_le_bytes(p[1][16 + 4 * i..20 + 4 * i].try_into().unwrap()) as usize).collect();
    let rot_at = 64 + sizes[0] + sizes[1];
    p[1][rot_at] |= 0x80;
    out.push((
        "reserved_rotation_bits.mrq",
        "Invalid",
        "a rotation byte of level 1 with bit 7 set",
        reseal(&base, &p, None).unwrap(),
    ));
    out.extend(invalid_lines_set());
    out.extend(invalid_v3_set());
    let mut p = good_payloads;
    p[1][64] |= 0xf0;
    out.push((
        "child_mask_high_bits.mrq",
        "Invalid",
        "a lattice child mask with bits 4-7 set",
        reseal(&base, &p, None).unwrap(),
    ));
    out
}

/// Invalid files about line geometry (spec §6.6), from a placed hierarchy.
fn invalid_lines_set() -> Vec<(&'static str, &'static str, &'static str, Vec<u8>)> {
    let mut out = Vec::new();
    let lines = encode(&placed(cube_hierarchy(3, Edits::default(), 3)), &q(12)).unwrap();
    let mut b = lines.clone();
    b[8] = 1;
    fix_preamble_checksum(&mut b);
    out.push(("lines_in_version_1.mrq", "Invalid", "line geometry (spec §6.6) in a version 1 file", b));
    let mut p = payloads(&lines).unwrap();
    p[0][2] |= 2;
    out.push((
        "lines_at_level_0.mrq",
        "Invalid",
        "level 0's block header sets the line bit",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[0][3] = 1;
    out.push((
        "line_shift_without_lines.mrq",
        "Invalid",
        "level 0's block header has line_shift 1 without the line bit",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[2][3] = 17;
    out.push((
        "line_shift_17.mrq",
        "Invalid",
        "level 2's line_shift is 17 (at most 16)",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[1][2] |= 4;
    out.push((
        "reserved_predictor_bits.mrq",
        "Invalid",
        "level 1's predictor byte has bit 2 set",
        reseal(&lines, &p, None).unwrap(),
    ));
    out
}

/// Invalid files of format version 3 (spec §5.9, §6.8).
fn invalid_v3_set() -> Vec<(&'static str, &'static str, &'static str, Vec<u8>)> {
    let mut out = Vec::new();
    let joins = Edits { join: 0.3, split: 0.1, ..Edits::default() };
    let base = encode(&cube_hierarchy(3, joins, 8), &v3(q(12))).unwrap();
    let mut b = base.clone();
    b[8] = 2;
    fix_preamble_checksum(&mut b);
    out.push(("v3_mode_3_in_version_2.mrq", "Invalid", "a version 2 file with mode 3 levels", b));
    let good = payloads(&base).unwrap();
    let stream = |p: &[u8], i: usize| {
        let sizes: Vec<usize> =
            (0..12).map(|j| u32::from_le_bytes(p[16 + 4 * j..20 + 4 * j].try_into().unwrap()) as usize).collect();
        64 + sizes[..i].iter().sum::<usize>()..64 + sizes[..=i].iter().sum::<usize>()
    };
    // Level 2's extra_names stream (6) says one vertex more than it holds.
    let mut p = good.clone();
    let r = stream(&p[2], 6);
    p[2][r.start] += 1;
    out.push((
        "v3_extra_count.mrq",
        "Invalid",
        "level 2's extra_names count disagrees with vertex_count",
        reseal(&base, &p, None).unwrap(),
    ));
    // Level 1's predictor byte sets a reserved bit.
    let mut p = good.clone();
    p[1][2] |= 4;
    out.push((
        "v3_reserved_predictor_bits.mrq",
        "Invalid",
        "level 1 (mode 3) sets predictor bit 2",
        reseal(&base, &p, None).unwrap(),
    ));
    // Level 2's vertex count one higher in both the table and the block: corners number fewer.
    let mut p = good;
    let nv = u32::from_le_bytes(p[2][4..8].try_into().unwrap());
    p[2][4..8].copy_from_slice(&(nv + 1).to_le_bytes());
    let info = octowrap_format::read_info(&base[..], &Limits::default()).unwrap();
    let mut counts: Vec<(u32, u32, u32)> =
        info.levels.iter().map(|l| (l.vertex_count, l.face_count, l.corner_count)).collect();
    counts[2].0 += 1;
    out.push((
        "v3_vertex_count_high.mrq",
        "Invalid",
        "level 2 claims one vertex more than its corners and extras number",
        reseal(&base, &p, Some(&counts)).unwrap(),
    ));
    out
}

fn kind(e: &Error) -> &'static str {
    match e {
        Error::BadMagic { .. } => "BadMagic",
        Error::UnsupportedVersion { .. } => "UnsupportedVersion",
        Error::Truncated { .. } => "Truncated",
        Error::ChecksumMismatch { .. } => "ChecksumMismatch",
        Error::LimitExceeded { .. } => "LimitExceeded",
        Error::Invalid { .. } => "Invalid",
        Error::Zstd { .. } => "Zstd",
        Error::NoSuchLevel { .. } => "NoSuchLevel",
        _ => "Io",
    }
}

fn write_valid(sub: &str, set: Vec<(&str, Vec<u8>)>) {
    for (name, bytes) in set {
        let h = decode(&bytes[..], &DecodeOptions::default()).unwrap().hierarchy;
        std::fs::write(dir(sub).join(format!("{name}.mrq")), &bytes).unwrap();
        std::fs::write(dir(sub).join(format!("{name}.json")), dump(&h)).unwrap();
    }
}

fn check_valid(sub: &str) -> usize {
    let mut n = 0;
    for e in std::fs::read_dir(dir(sub)).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_none_or(|x| x != "mrq") {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        let file = decode(&bytes[..], &DecodeOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let want = std::fs::read_to_string(path.with_extension("json")).unwrap();
        assert_eq!(dump(&file.hierarchy), want, "{}: decoded levels differ from the golden dump", path.display());
        // Re-encoding the decoded hierarchy exactly and decoding again changes nothing.
        // (In the file's own version: versions 2 and 3 order vertices differently.)
        let mut exact = EncodeOptions::with_quantization(Quantization::Exact);
        exact.version = file.info.version.max(2);
        let again = encode(&file.hierarchy, &exact).unwrap();
        let back = decode(&again[..], &DecodeOptions::default()).unwrap();
        assert_eq!(back.hierarchy, file.hierarchy, "{}", path.display());
        n += 1;
    }
    n
}

#[test]
fn valid_files_match_their_dumps() {
    if regen() {
        write_valid("valid", valid_set());
    }
    assert!(check_valid("valid") >= 8);
}

#[test]
fn regress_files_match_their_dumps() {
    if regen() {
        write_valid("regress", regress_set());
    }
    assert!(check_valid("regress") >= 2);
}

#[test]
fn the_encoder_still_writes_the_valid_files() {
    if regen() {
        return; // the other tests are rewriting the files
    }
    for (name, bytes) in valid_set().into_iter().chain(regress_set()) {
        let sub = if name.starts_with("names_without") || name.starts_with("v3_splits") { "regress" } else { "valid" };
        assert!(!name.starts_with("version1_"), "version 1 files are kept, not regenerated");
        let on_disk = std::fs::read(dir(sub).join(format!("{name}.mrq"))).unwrap();
        assert_eq!(bytes, on_disk, "{name}: the encoder's output changed; regenerate on purpose (see module docs)");
    }
}

#[test]
fn invalid_files_fail_as_stated() {
    let readme = dir("invalid").join("README.md");
    if regen() {
        let mut text = String::from(
            "# Invalid MRQ files\n\nRule: every file here MUST be rejected by a decoder, with the error named below \
             (the reference decoder's `Error` variant), and never crash it. Generated by \
             `crates/format/tests/conformance.rs` (`OCTOWRAP_REGEN_FIXTURES=1`) from `valid/cube3_lattice_q12.mrq`'s \
             hierarchy.\n\n| file | expected error | what is wrong |\n|---|---|---|\n",
        );
        for (name, kind, what, bytes) in invalid_set() {
            std::fs::write(dir("invalid").join(name), bytes).unwrap();
            text += "| ";
            text += &[name, kind, what].join(" | ");
            text += " |\n";
        }
        std::fs::write(&readme, text).unwrap();
    }
    let text = std::fs::read_to_string(&readme).unwrap();
    let mut n = 0;
    for line in text.lines().filter(|l| l.starts_with("| ") && l.contains(".mrq")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let (name, want) = (cells[1], cells[2]);
        let bytes = std::fs::read(dir("invalid").join(name)).unwrap();
        let mut opts = DecodeOptions::default();
        opts.limits = Limits::strict();
        match decode(&bytes[..], &opts) {
            Ok(_) => panic!("{name} decoded, expected {want}"),
            Err(e) => assert_eq!(kind(&e), want, "{name}: {e}"),
        }
        n += 1;
    }
    assert!(n >= 15, "{n} invalid files listed");
}
