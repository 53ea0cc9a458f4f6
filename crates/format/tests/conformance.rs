//! Conformance vectors in `fixtures/format/` (spec §9): `valid/` files must decode to their golden
//! dump (`NAME.mrq` beside `NAME.json`), `invalid/` files must fail with the error class of spec
//! §7.3 listed in `invalid/README.md`, `regress/` files must decode to their dump too.
//!
//! To rewrite the vectors after an intended format change:
//! `OCTOWRAP_REGEN_FIXTURES=1 cargo test --release -p octowrap-format --test conformance`
//! (then review the diff and add a change-log line to spec/FORMAT.md).

use std::path::{Path, PathBuf};

use octowrap_format::DecodeError as Error;
use octowrap_format::fuzzing::{payloads, reseal};
use octowrap_format::synthetic::{Edits, Rng, cube_hierarchy, polygon_mesh, without_lattice};
use octowrap_format::tamper::fix_preamble_checksum;
use octowrap_format::{
    DecodeOptions, EncodeOptions, Limits, Metadata, Quantization, decode, encode, place_on_prediction_lines,
};
use octowrap_mesh::{DVec3, FaceList, FaceOrigin, Hierarchy, Level, Mesh, Quadrant};
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
        // The spec's worked example (Appendix B): one quad and its canonical subdivision.
        ("two_level_quad_q4", encode(&subdivided(one_quad(), 0.0, 1), &v3(q(4))).unwrap()),
        // Mode 1 under a parent whose faces repeat vertices (edges `{a, a}`, edges met twice).
        ("generic_repeated_parent_vertices_q12", encode(&subdivided(repeating_soup(), 0.3, 2), &v3(q(12))).unwrap()),
        // Mode 3 with lattice predictor 0 and line geometry (the encoder's choice for this seed).
        (
            "v3_cube3_lattice_lines_predictor0_q12",
            encode(&placed_with(cube_hierarchy(3, Edits::default(), 12), &v3(q(12))), &v3(q(12))).unwrap(),
        ),
        // Predictions beyond the grid range, which `clamp` (spec §1.7) limits: a 28-bit grid with
        // every vertex below level 0 pressed onto the cube's face x = 1 (grid x = 2^28).
        ("clamped_predictions_q28", encode(&pressed(cube_hierarchy(3, Edits::default(), 3)), &q(28)).unwrap()),
        ("v3_clamped_predictions_q28", encode(&pressed(cube_hierarchy(3, Edits::default(), 3)), &v3(q(28))).unwrap()),
        // Format version 5 (spec §11): levels in chunks; a chunk shift of 1 splits levels 2 and 3
        // into cells of depth 1 and 2.
        ("v5_cube4_chunks_q12", encode(&cube_hierarchy(4, Edits::default(), 3), &v5(q(12), 1)).unwrap()),
        (
            "v5_cube4_chunks_lines_q12",
            encode(&placed_with(cube_hierarchy(4, Edits::default(), 3), &v5(q(12), 1)), &v5(q(12), 1)).unwrap(),
        ),
        ("v5_cube4_chunks_exact", encode(&cube_hierarchy(4, Edits::default(), 4), &v5(exact.clone(), 1)).unwrap()),
        // Without lattice coordinates: one chunk per level.
        (
            "v5_cube3_generic_q12",
            encode(&without_lattice(cube_hierarchy(3, Edits::default(), 5)), &v5(q(12), 1)).unwrap(),
        ),
        // Format version 4 (spec §6.9): mode 3 geometry in value blocks, range coded or byte planes.
        ("v4_cube3_lattice_q12", encode(&cube_hierarchy(4, Edits::default(), 3), &v4(q(12))).unwrap()),
        (
            "v4_cube3_lattice_lines_q12",
            encode(&placed_with(cube_hierarchy(4, Edits::default(), 3), &v4(q(12))), &v4(q(12))).unwrap(),
        ),
    ]
}

/// The unit square as one quad.
fn one_quad() -> Mesh {
    let mut quad = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    quad.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
    quad
}

/// A small polygon soup some of whose faces repeat a vertex.
fn repeating_soup() -> Mesh {
    let mesh = polygon_mesh(8, 6, 7);
    let repeats = mesh.faces.iter().filter(|f| (1..f.len()).any(|i| f[..i].contains(&f[i]))).count();
    assert!(repeats >= 2, "the soup must repeat vertices within faces");
    mesh
}

/// `mesh` and its canonical subdivision (spec §5.4: a vertex per parent vertex, edge and face;
/// edges numbered by first appearance; a child per parent corner), the new vertices moved by up
/// to `noise` (deterministic).
fn subdivided(mesh: Mesh, noise: f64, seed: u64) -> Hierarchy {
    let p = &mesh.vertices.positions;
    let mut edges: Vec<(u32, u32)> = Vec::new();
    let mut edge_points = Vec::new();
    let mut edge_of = |a: u32, b: u32| {
        let key = (a.min(b), a.max(b));
        if let Some(e) = edges.iter().position(|&x| x == key) {
            return e;
        }
        edges.push(key);
        edge_points.push((p[a as usize] + p[b as usize]) / 2.0);
        edges.len() - 1
    };
    let mut corner_edges = Vec::new();
    for f in mesh.faces.iter() {
        let n = f.len();
        corner_edges.push((0..n).map(|i| edge_of(f[i], f[(i + 1) % n])).collect::<Vec<_>>());
    }
    let (nv, ne) = (p.len() as u32, edge_points.len() as u32);
    let mut positions = p.clone();
    positions.extend(edge_points);
    positions.extend(mesh.faces.iter().map(|f| f.iter().map(|&v| p[v as usize]).sum::<DVec3>() / f.len() as f64));
    let mut rng = Rng::new(seed);
    for x in &mut positions[nv as usize..] {
        *x += DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5) * noise;
    }
    let mut quads = Vec::new();
    let mut origins = Vec::new();
    for (pf, f) in mesh.faces.iter().enumerate() {
        let n = f.len();
        let e = &corner_edges[pf];
        for q in 0..n {
            quads.push([f[q], nv + e[q] as u32, nv + ne + pf as u32, nv + e[(q + n - 1) % n] as u32]);
            // (The hierarchy model links quadrants 0-3 only; the other children are created faces.)
            origins.push(if q < 4 {
                FaceOrigin::Subface { parent: pf as u32, quadrant: Quadrant(q as u8) }
            } else {
                FaceOrigin::Created
            });
        }
    }
    let mut fine = Mesh::from_positions(positions);
    fine.faces = FaceList::from_quads(&quads);
    let mut h = Hierarchy::single(mesh);
    h.levels.push(Level { mesh: fine, origins, lattice: None });
    h
}

/// `h` with every vertex inside the unit cube, and every vertex below level 0 moved onto its face
/// x = 1.
fn pressed(mut h: Hierarchy) -> Hierarchy {
    for (k, level) in h.levels.iter_mut().enumerate() {
        for x in &mut level.mesh.vertices.positions {
            *x = x.clamp(DVec3::ZERO, DVec3::ONE);
            if k > 0 {
                x.x = 1.0;
            }
        }
    }
    h
}

/// `opts` writing format version 5 with chunk shift `shift`.
fn v5(mut opts: EncodeOptions, shift: u32) -> EncodeOptions {
    opts.version = 5;
    opts.chunk_shift = shift;
    opts
}

/// `opts` writing format version 4.
fn v4(mut opts: EncodeOptions) -> EncodeOptions {
    opts.version = 4;
    opts
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

/// (file, violated section, error class of spec §7.3, what is wrong, bytes).
type Invalid = (&'static str, &'static str, &'static str, &'static str, Vec<u8>);

fn invalid_set() -> Vec<Invalid> {
    let base = encode(&cube_hierarchy(3, Edits::default(), 3), &q(12)).unwrap();
    let good_payloads = payloads(&base).unwrap();
    let level1 = |b: &[u8]| {
        let info = octowrap_format::read_info(b, &Limits::default()).unwrap();
        info.levels[1].clone()
    };
    let mut out = Vec::new();
    let mut b = base.clone();
    b[1] = b'X';
    out.push(("bad_magic.mrq", "§3.1", "not-mrq", "the second magic byte is `X`", b));
    let mut b = base.clone();
    b[8] = 6;
    out.push(("version_6.mrq", "§3.1", "unsupported-version", "version 6", b));
    out.push(("truncated_header.mrq", "§3.1", "truncated", "the file ends inside the header", base[..60].to_vec()));
    let l1 = level1(&base);
    let cut = (l1.offset + l1.stored_size / 2) as usize;
    out.push(("truncated_level1.mrq", "§3.5", "truncated", "the file ends inside level 1", base[..cut].to_vec()));
    let mut b = base.clone();
    let meta_byte = 112 + 48 * 3 + 2;
    b[meta_byte] ^= 1;
    out.push(("preamble_checksum.mrq", "§3.4", "checksum", "a metadata byte changed", b));
    let mut b = base.clone();
    b[(l1.offset + 5) as usize] ^= 0x10;
    out.push(("level1_checksum.mrq", "§3.5", "checksum", "a byte of level 1's stored bytes changed", b));
    let mut b = base.clone();
    b[12] |= 8;
    out.push(("reserved_flag.mrq", "§3.1", "invalid", "reserved header flag bit 3 set", b));
    let mut b = base.clone();
    b[16..20].copy_from_slice(&1000u32.to_le_bytes());
    out.push(("too_many_levels.mrq", "§7.2", "limit", "level_count 1000", b));
    let mut b = base.clone();
    let off = 112 + 48; // level 1's offset field
    let v = u64::from_le_bytes(b[off..off + 8].try_into().unwrap()) + 1;
    b[off..off + 8].copy_from_slice(&v.to_le_bytes());
    fix_preamble_checksum(&mut b);
    out.push(("level_gap.mrq", "§3.2", "invalid", "level 1 does not start where level 0 ends", b));
    let mut b = base.clone();
    b.push(0);
    out.push(("bytes_after_last_level.mrq", "§3.5", "invalid", "one zero byte follows the last level", b));
    let mut b = base.clone();
    let off = 112 + 48 + 32; // level 1's vertex_count
    let v = u32::from_le_bytes(b[off..off + 4].try_into().unwrap()) + 1;
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
    fix_preamble_checksum(&mut b);
    out.push(("count_mismatch.mrq", "§4.1", "invalid", "level 1's vertex_count differs from its block header", b));
    let mut p = good_payloads.clone();
    p[1][0] = 7;
    out.push(("unknown_mode.mrq", "§4.1", "invalid", "level 1 block mode 7", reseal(&base, &p, None).unwrap()));
    let mut p = good_payloads.clone();
    p[0][0] = 2;
    out.push(("lattice_mode_at_level0.mrq", "§4.1", "invalid", "level 0 in mode 2", reseal(&base, &p, None).unwrap()));
    let mut p = good_payloads.clone();
    p[2].push(0);
    out.push((
        "trailing_byte.mrq",
        "§4.1",
        "invalid",
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
        "§5.2",
        "invalid",
        "a rotation byte of level 1 with bit 7 set",
        reseal(&base, &p, None).unwrap(),
    ));
    out.extend(invalid_lines_set());
    out.extend(invalid_v3_set());
    out.extend(invalid_v5_set());
    out.extend(invalid_mode3_set());
    let mut p = good_payloads;
    p[1][64] |= 0xf0;
    out.push((
        "child_mask_high_bits.mrq",
        "§5.3",
        "invalid",
        "a lattice child mask with bits 4-7 set",
        reseal(&base, &p, None).unwrap(),
    ));
    out
}

/// Invalid files about line geometry (spec §6.6), from a placed hierarchy.
/// Version 5 files that break the chunk rules of spec §11, from `valid/v5_cube4_chunks_q12.mrq`'s
/// hierarchy.
fn invalid_v5_set() -> Vec<Invalid> {
    let base = encode(&cube_hierarchy(4, Edits::default(), 3), &v5(q(12), 1)).unwrap();
    let levels = 4usize;
    let chunks = u32::from_le_bytes(base[108..112].try_into().unwrap()) as usize;
    let entry = |i: usize| 112 + 48 * levels + 88 * i;
    let level_of = |b: &[u8], i: usize| u16::from_le_bytes(b[entry(i) + 28..entry(i) + 30].try_into().unwrap());
    let first_of = |k: u16| (0..chunks).find(|&i| level_of(&base, i) == k).unwrap();
    let sealed = |mut b: Vec<u8>| {
        assert!(fix_preamble_checksum(&mut b));
        b
    };
    let put32 = |b: &mut Vec<u8>, at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let get32 = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let mut out: Vec<Invalid> = Vec::new();
    // A stored byte of a level 3 chunk changed: the level's checksum fails first.
    let c3 = first_of(3);
    let mut b = base.clone();
    let off = u64::from_le_bytes(b[entry(c3)..entry(c3) + 8].try_into().unwrap()) as usize;
    b[off + 3] ^= 0x40;
    out.push(("v5_chunk_stored_byte.mrq", "§11.3", "checksum", "a stored byte of a level 3 chunk changed", b));
    // The second level 3 chunk names the first level 3 chunk's parent's sibling as its parent.
    let c2 = first_of(2);
    let mut b = base.clone();
    let p = get32(&b, entry(c3 + 1) + 24);
    put32(&mut b, entry(c3 + 1) + 24, if p as usize == c2 { p + 1 } else { c2 as u32 });
    out.push((
        "v5_chunk_parent_cell.mrq",
        "§11.2",
        "invalid",
        "a chunk's parent chunk's cell does not hold its cell",
        sealed(b),
    ));
    // Two level 3 chunks' cells swapped: the cells are not in increasing Morton order.
    let mut b = base.clone();
    let (x, y) = (entry(c3) + 32, entry(c3 + 1) + 32);
    let (cx, cy) = (b[x..x + 12].to_vec(), b[y..y + 12].to_vec());
    b[x..x + 12].copy_from_slice(&cy);
    b[y..y + 12].copy_from_slice(&cx);
    out.push((
        "v5_chunk_morton_order.mrq",
        "§11.2",
        "invalid",
        "two chunks of level 3 listed out of Morton order",
        sealed(b),
    ));
    // A chunk's offset one byte on.
    let mut b = base.clone();
    let o = u64::from_le_bytes(b[entry(c3 + 1)..entry(c3 + 1) + 8].try_into().unwrap());
    b[entry(c3 + 1)..entry(c3 + 1) + 8].copy_from_slice(&(o + 1).to_le_bytes());
    out.push((
        "v5_chunk_offset_gap.mrq",
        "§11.2",
        "invalid",
        "a chunk does not start where the one before ends",
        sealed(b),
    ));
    // Level 2's cell depth 2 (at most 1 at level 2).
    let mut b = base.clone();
    put32(&mut b, 112 + 48 * 2 + 44, 2);
    out.push(("v5_cell_depth_too_deep.mrq", "§11.1", "invalid", "level 2 has cell depth 2", sealed(b)));
    // Level 3's vertex count one short of what its chunks merge into.
    let mut b = base.clone();
    let nv = get32(&b, 112 + 48 * 3 + 32);
    put32(&mut b, 112 + 48 * 3 + 32, nv - 1);
    out.push((
        "v5_merged_vertex_count.mrq",
        "§11.4",
        "invalid",
        "level 3's chunks merge into one vertex more than the level table says",
        sealed(b),
    ));
    // A chunk's face count one more than its block holds (the level's sum no longer matches).
    let mut b = base.clone();
    let nf = get32(&b, entry(c3) + 48);
    put32(&mut b, entry(c3) + 48, nf + 1);
    out.push((
        "v5_chunk_face_count.mrq",
        "§11.2",
        "invalid",
        "a chunk's face count does not add up to its level's",
        sealed(b),
    ));
    // More chunks than the strict limits allow.
    let mut b = base.clone();
    put32(&mut b, 108, 1 << 21);
    out.push(("v5_too_many_chunks.mrq", "§7.2", "limit", "chunk_count 2^21 (the default limit is 2^20)", b));
    // A version 4 file that declares chunks.
    let mut b = encode(&cube_hierarchy(3, Edits::default(), 3), &v4(q(12))).unwrap();
    put32(&mut b, 108, 1);
    out.push(("v5_chunks_in_version_4.mrq", "§3.1", "invalid", "a version 4 header with chunk_count 1", sealed(b)));
    out
}

fn invalid_lines_set() -> Vec<Invalid> {
    let mut out = Vec::new();
    let lines = encode(&placed(cube_hierarchy(3, Edits::default(), 3)), &q(12)).unwrap();
    let mut b = lines.clone();
    b[8] = 1;
    fix_preamble_checksum(&mut b);
    out.push(("lines_in_version_1.mrq", "§4.1", "invalid", "line geometry (spec §6.6) in a version 1 file", b));
    let mut p = payloads(&lines).unwrap();
    p[0][2] |= 2;
    out.push((
        "lines_at_level_0.mrq",
        "§4.1",
        "invalid",
        "level 0's block header sets the line bit",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[0][3] = 1;
    out.push((
        "line_shift_without_lines.mrq",
        "§4.1",
        "invalid",
        "level 0's block header has line_shift 1 without the line bit",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[2][3] = 17;
    out.push((
        "line_shift_17.mrq",
        "§4.1",
        "invalid",
        "level 2's line_shift is 17 (at most 16)",
        reseal(&lines, &p, None).unwrap(),
    ));
    let mut p = payloads(&lines).unwrap();
    p[1][2] |= 4;
    out.push((
        "reserved_predictor_bits.mrq",
        "§4.1",
        "invalid",
        "level 1's predictor byte has bit 2 set",
        reseal(&lines, &p, None).unwrap(),
    ));
    out
}

/// Invalid files of format version 3 (spec §5.9, §6.8).
fn invalid_v3_set() -> Vec<Invalid> {
    let mut out = Vec::new();
    let joins = Edits { join: 0.3, split: 0.1, ..Edits::default() };
    let base = encode(&cube_hierarchy(3, joins, 8), &v3(q(12))).unwrap();
    let mut b = base.clone();
    b[8] = 2;
    fix_preamble_checksum(&mut b);
    out.push(("v3_mode_3_in_version_2.mrq", "§4.1", "invalid", "a version 2 file with mode 3 levels", b));
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
        "§5.5",
        "invalid",
        "level 2 (mode 1): its extra_names count is one higher than the names that follow",
        reseal(&base, &p, None).unwrap(),
    ));
    // Level 1's predictor byte sets a reserved bit.
    let mut p = good.clone();
    p[1][2] |= 4;
    out.push((
        "v3_reserved_predictor_bits.mrq",
        "§4.1",
        "invalid",
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
        "§5.5",
        "invalid",
        "level 2 (mode 1) claims one vertex more than its names and splits number",
        reseal(&base, &p, Some(&counts)).unwrap(),
    ));
    out
}

/// The bytes of stream `i` (spec §4.2) of payload `p`.
fn stream_bytes(p: &[u8], i: usize) -> Vec<u8> {
    let size = |j: usize| u32::from_le_bytes(p[16 + 4 * j..20 + 4 * j].try_into().unwrap()) as usize;
    let at = 64 + (0..i).map(size).sum::<usize>();
    p[at..at + size(i)].to_vec()
}

/// Payload `p` with stream `i` (spec §4.2) rewritten by `edit`, the block header's sizes updated.
fn with_stream(p: &[u8], i: usize, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let sizes: Vec<usize> =
        (0..12).map(|j| u32::from_le_bytes(p[16 + 4 * j..20 + 4 * j].try_into().unwrap()) as usize).collect();
    let mut streams: Vec<Vec<u8>> = Vec::new();
    let mut at = 64;
    for &s in &sizes {
        streams.push(p[at..at + s].to_vec());
        at += s;
    }
    edit(&mut streams[i]);
    let mut out = p[..16].to_vec();
    for s in &streams {
        out.extend(u32::try_from(s.len()).unwrap().to_le_bytes());
    }
    for s in streams {
        out.extend(s);
    }
    out
}

/// `v` as a varint (spec §1.3).
fn varint(mut v: u64) -> Vec<u8> {
    let mut out = Vec::new();
    while v >= 0x80 {
        out.push((v & 0x7f) as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
    out
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// The streams of a mode-3 level block that the `v3_` files edit (spec §5.9).
const EXTRA_KEYS: usize = 6;
const SPLIT_KEYS: usize = 7;
const EXCEPTIONS: usize = 8;
const CHOICES: usize = 9;

/// `regress/v3_splits_and_exceptions.mrq`'s hierarchy, encoded, with its level payloads: the
/// starting point of every `v3_` invalid file.
struct Mode3Base {
    file: Vec<u8>,
    payloads: Vec<Vec<u8>>,
}

impl Mode3Base {
    fn new() -> Self {
        let joins = Edits { join: 0.3, split: 0.1, ..Edits::default() };
        let file = encode(&cube_hierarchy(3, joins, 8), &v3(q(12))).unwrap();
        let payloads = payloads(&file).unwrap();
        assert_eq!(payloads[1][0], 3, "level 1 is in mode 3");
        Self { file, payloads }
    }

    /// Level 1's stream `i`, as encoded.
    fn stream(&self, i: usize) -> Vec<u8> {
        stream_bytes(&self.payloads[1], i)
    }

    /// The file with level 1's stream `i` edited, resealed (sizes and checksums fixed).
    fn with(&self, i: usize, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
        let mut p = self.payloads.clone();
        p[1] = with_stream(&self.payloads[1], i, edit);
        reseal(&self.file, &p, None).unwrap()
    }
}

/// Invalid files that break the rules of mode 3's corner resolution (spec §5.9), all in level 1
/// (mode 3, depth 1: corner keys below 27) of `regress/v3_splits_and_exceptions.mrq`'s hierarchy,
/// whose first exception is at corner 0 and numbers vertex 0. One file per rule, in the spec's order.
fn invalid_mode3_set() -> Vec<Invalid> {
    let base = Mode3Base::new();
    let mut out = mode3_exception_files(&base);
    out.extend(mode3_split_files(&base));
    out.extend(mode3_extra_files(&base));
    out
}

/// Level 1's exceptions, which start with: count, corner 0, vertex 0 (= next: a new vertex), its
/// key delta.
fn mode3_exception_files(base: &Mode3Base) -> Vec<Invalid> {
    let exc = base.stream(EXCEPTIONS);
    assert!(exc[0] > 1 && exc[1] == 0 && exc[2] == 0 && exc[3] < 0x80 && exc[4] < 0x80, "{:?}", &exc[..6]);
    let mut out = vec![
        (
            "v3_exception_vertex_beyond_next.mrq",
            "§5.9",
            "invalid",
            "level 1's first exception (corner 0) names vertex 1 while only 0 may be numbered",
            base.with(EXCEPTIONS, |s| s[2] = 1),
        ),
        (
            "v3_exception_key_not_lattice.mrq",
            "§5.9",
            "invalid",
            "level 1's first exception numbers a vertex whose key is no corner key of depth 1",
            base.with(EXCEPTIONS, |s| drop(s.splice(3..4, varint(zigzag(1_000_000))))),
        ),
    ];
    // An exception inserted at corner 1 that numbers vertex 1 with the key of vertex 0 (numbered
    // at corner 0), which is no split key.
    let decoded = decode(&base.file[..], &DecodeOptions::default()).unwrap().hierarchy;
    let l1 = &decoded.levels[1];
    let corners = &l1.lattice.as_ref().unwrap().vertex_corners;
    let key_of = |c: [u32; 3]| u64::from(c[0]) + 3 * u64::from(c[1]) + 9 * u64::from(c[2]);
    let k0 = key_of(corners[0]);
    let pk1 = key_of(corners[l1.mesh.faces.face(0)[1] as usize]);
    assert!(!split_keys(base).contains(&k0) && exc[4] >= 1, "vertex 0's key {k0} is a split key");
    out.push((
        "v3_key_numbered_twice.mrq",
        "§5.9",
        "invalid",
        "level 1: an exception at corner 1 numbers a second vertex under vertex 0's key, which is no split key",
        base.with(EXCEPTIONS, |s| {
            let mut head = vec![exc[0] + 1, 0, 0, exc[3], 0, 1];
            head.extend(varint(zigzag(k0 as i64 - pk1 as i64)));
            head.push(exc[4] - 1);
            s.splice(0..5, head);
        }),
    ));
    out
}

/// Level 1's split keys, decoded from their stream (a count, then the first key and gaps less one,
/// all single bytes here).
fn split_keys(base: &Mode3Base) -> Vec<u64> {
    let splits = base.stream(SPLIT_KEYS);
    let mut keys = Vec::new();
    let mut key = 0u64;
    for i in 0..usize::from(splits[0]) {
        key = if i == 0 { u64::from(splits[1]) } else { key + 1 + u64::from(splits[1 + i]) };
        keys.push(key);
    }
    keys
}

/// Level 1's choices and split keys.
fn mode3_split_files(base: &Mode3Base) -> Vec<Invalid> {
    assert_eq!(split_keys(base).last(), Some(&26), "the last split key is the last key of depth 1");
    vec![
        (
            "v3_choice_beyond_list.mrq",
            "§5.9",
            "invalid",
            "level 1's first choice is 100, beyond the split key's list",
            base.with(CHOICES, |s| s[0] = 100),
        ),
        (
            "v3_split_key_not_lattice.mrq",
            "§5.9",
            "invalid",
            "level 1's last split key is 27, no corner key of depth 1",
            base.with(SPLIT_KEYS, |s| *s.last_mut().unwrap() += 1),
        ),
    ]
}

/// Level 1's extra vertices, and a vertex count below what its corners number.
fn mode3_extra_files(base: &Mode3Base) -> Vec<Invalid> {
    let extras = base.stream(EXTRA_KEYS);
    assert!(extras[0] >= 1 && extras[1] < 0x80, "{extras:?}");
    let mut out = vec![
        (
            "v3_extra_key_not_lattice.mrq",
            "§5.9",
            "invalid",
            "level 1's first extra vertex has a key that is no corner key of depth 1",
            base.with(EXTRA_KEYS, |s| drop(s.splice(1..2, varint(zigzag(1_000_000))))),
        ),
        (
            "v3_extra_keys_count.mrq",
            "§5.9",
            "invalid",
            "level 1's extra_keys count is one more than vertex_count minus the vertices its corners number",
            base.with(EXTRA_KEYS, |s| s[0] += 1),
        ),
    ];
    // vertex_count lowered below what the corners alone number (table and block agree).
    let mut p = base.payloads.clone();
    let nv = u32::from_le_bytes(p[1][4..8].try_into().unwrap()) - u32::from(extras[0]) - 1;
    p[1][4..8].copy_from_slice(&nv.to_le_bytes());
    let info = octowrap_format::read_info(&base.file[..], &Limits::default()).unwrap();
    let mut counts: Vec<(u32, u32, u32)> =
        info.levels.iter().map(|l| (l.vertex_count, l.face_count, l.corner_count)).collect();
    counts[1].0 = nv;
    out.push((
        "v3_corners_number_too_many.mrq",
        "§5.9",
        "invalid",
        "level 1's corners number one vertex more than its vertex_count",
        reseal(&base.file, &p, Some(&counts)).unwrap(),
    ));
    out
}

/// The error class of spec §7.3 that the reference decoder's error belongs to.
fn class(e: &Error) -> &'static str {
    match e {
        Error::BadMagic { .. } => "not-mrq",
        Error::UnsupportedVersion { .. } => "unsupported-version",
        Error::Truncated { .. } => "truncated",
        Error::ChecksumMismatch { .. } => "checksum",
        Error::LimitExceeded { .. } => "limit",
        Error::Invalid { .. } | Error::Zstd { .. } => "invalid",
        _ => "other",
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
        // Version 5: the chunk shift the file was written with.
        let levels = file.info.levels.iter().enumerate();
        if let Some(shift) = levels.filter(|(_, l)| l.cell_depth > 0).map(|(k, l)| k as u32 - l.cell_depth).min() {
            exact.chunk_shift = shift;
        }
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
            "# Invalid MRQ files\n\nRule: every file here MUST be rejected by a decoder, and never crash it. Per \
             file, the table names the section of `spec/FORMAT.md` the file violates and the error class of spec \
             §7.3 that a decoder checking in the order of spec §7.1 reports. Generated by \
             `crates/format/tests/conformance.rs` (`OCTOWRAP_REGEN_FIXTURES=1`), most from \
             `valid/cube3_lattice_q12.mrq`'s hierarchy, the files about line \
             geometry (`lines_*`, `line_shift_*`, `reserved_predictor_bits`) from \
             `valid/cube3_lattice_lines_q12.mrq`'s, the `v3_` files from \
             `regress/v3_splits_and_exceptions.mrq`'s, the `v5_` files from `valid/v5_cube4_chunks_q12.mrq`'s.\n\n| file | violates | error class | what is wrong \
             |\n|---|---|---|---|\n",
        );
        for (name, section, class, what, bytes) in invalid_set() {
            std::fs::write(dir("invalid").join(name), bytes).unwrap();
            text += "| ";
            text += &[name, section, class, what].join(" | ");
            text += " |\n";
        }
        std::fs::write(&readme, text).unwrap();
    }
    let text = std::fs::read_to_string(&readme).unwrap();
    let mut n = 0;
    for line in text.lines().filter(|l| l.starts_with("| ") && l.contains(".mrq")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let (name, want) = (cells[1], cells[3]);
        let bytes = std::fs::read(dir("invalid").join(name)).unwrap();
        let mut opts = DecodeOptions::default();
        opts.limits = Limits::strict();
        match decode(&bytes[..], &opts) {
            Ok(_) => panic!("{name} decoded, expected {want}"),
            Err(e) => assert_eq!(class(&e), want, "{name}: {e}"),
        }
        n += 1;
    }
    assert!(n >= 15, "{n} invalid files listed");
}
