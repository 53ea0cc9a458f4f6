//! Exports checked from outside: the Khronos glTF-Validator passes every file with 0 errors and 0
//! warnings, counts read back (with the `gltf` crate, or by decoding the buffers ourselves where
//! it cannot read an extension) match the source, and the options do what they say.

mod support;

use std::path::Path;

use octowrap_export::{Error, ExportOptions, Levels, Summary, to_glb, write_path};
use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_mesh::{DVec3, FaceList, Hierarchy, Mesh};
use serde_json::Value;

fn opts(levels: Levels, quantize: bool, meshopt: bool) -> ExportOptions {
    let mut o = ExportOptions::default();
    o.levels = levels;
    o.quantize = quantize;
    o.meshopt = meshopt;
    o
}

/// The GLB's JSON chunk and binary chunk.
fn split(glb: &[u8]) -> (Value, Vec<u8>) {
    let g = gltf::binary::Glb::from_slice(glb).expect("a well-formed GLB");
    (serde_json::from_slice(&g.json).expect("JSON"), g.bin.map(std::borrow::Cow::into_owned).unwrap_or_default())
}

/// Writes `bytes` to the artefact folder and validates it there.
fn save_and_validate(name: &str, bytes: &[u8]) -> Option<Value> {
    let path = support::artefacts().join(name);
    std::fs::write(&path, bytes).expect("write");
    support::validate(&path)
}

/// The bytes of accessor `a` (no meshopt), element by element.
fn accessor_bytes(doc: &Value, bin: &[u8], a: usize) -> (Vec<u8>, usize, usize) {
    let acc = &doc["accessors"][a];
    let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let offset = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    let count = acc["count"].as_u64().unwrap() as usize;
    let stride = view["byteStride"].as_u64().map_or(len / count, |s| s as usize);
    (bin[offset..offset + len].to_vec(), count, stride)
}

/// The validator's vertex, triangle and draw-call counts agree with what the exporter wrote, and
/// the extensions used and required are the ones the summary names.
fn assert_counts(report: &Value, summary: &Summary) {
    let info = &report["info"];
    let vertices: usize = summary.levels.iter().map(|l| l.vertices).sum();
    let triangles: usize = summary.levels.iter().map(|l| l.triangles).sum();
    assert_eq!(info["totalVertexCount"].as_u64(), Some(vertices as u64), "{info}");
    assert_eq!(info["totalTriangleCount"].as_u64(), Some(triangles as u64), "{info}");
    assert_eq!(info["drawCallCount"].as_u64(), Some(summary.levels.len() as u64), "{info}");
    let used = info.get("extensionsUsed").cloned().unwrap_or(serde_json::json!([]));
    assert_eq!(used, serde_json::json!(summary.extensions_used));
    let required = info.get("extensionsRequired").cloned().unwrap_or(serde_json::json!([]));
    assert_eq!(required, serde_json::json!(summary.extensions_required));
}

fn hierarchy() -> Hierarchy {
    cube_hierarchy(5, Edits::default(), 11)
}

#[test]
fn every_level_is_its_own_mesh_and_node_in_a_lod_chain() {
    let h = hierarchy();
    let (glb, summary) = to_glb(&h, &opts(Levels::All, false, false)).unwrap();
    let report = save_and_validate("cube5_all.glb", &glb);
    // The gltf crate reads the plain file (MSFT_lod is only used, not required).
    let gltf = gltf::Gltf::from_slice(&glb).expect("the gltf crate reads it");
    let blob = gltf.blob.clone().expect("binary chunk");
    assert_eq!(gltf.meshes().len(), 5);
    assert_eq!(gltf.nodes().len(), 5);
    assert_eq!(gltf.scenes().next().unwrap().nodes().count(), 1, "only the finest node is in the scene");
    for (node, level) in gltf.nodes().zip((0..5).rev()) {
        let src = &h.levels[level].mesh;
        assert!(node.name().unwrap().starts_with(&format!("level {level}")), "{:?}", node.name());
        let prim = node.mesh().unwrap().primitives().next().unwrap();
        assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
        let reader = prim.reader(|_| Some(&blob));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        let tris = src.triangles();
        assert_eq!(indices.len(), tris.len() * 3, "level {level}: one triangle per source triangle");
        // Same triangles, in order, on the same positions.
        for (t, src_t) in indices.chunks(3).zip(&tris) {
            for (&i, &s) in t.iter().zip(src_t) {
                let p = DVec3::from(positions[i as usize].map(f64::from));
                assert!((p - src.vertices.positions[s as usize]).length() < 1e-6, "level {level}");
            }
        }
        let used: std::collections::BTreeSet<u32> = tris.iter().flatten().copied().collect();
        assert_eq!(positions.len(), used.len(), "level {level}: every used vertex once (no crease)");
        let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
        assert!(normals.iter().all(|n| (n.iter().map(|c| c * c).sum::<f32>() - 1.0).abs() < 1e-5));
    }
    let (doc, _) = split(&glb);
    assert_eq!(doc["nodes"][0]["extensions"]["MSFT_lod"]["ids"], serde_json::json!([1, 2, 3, 4]));
    let cov: Vec<f64> = doc["nodes"][0]["extras"]["MSFT_screencoverage"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(cov.len(), 5);
    assert!(cov.windows(2).all(|w| w[0] > w[1]), "coverage falls with coarseness: {cov:?}");
    assert!(cov[4].abs() < f64::EPSILON && cov[0] <= 1.0, "{cov:?}");
    assert!(summary.screen_coverage.iter().zip(&cov).all(|(a, b)| (a - b).abs() < 1e-15 * a.max(1e-300)));
    assert_eq!(doc["extensionsUsed"], serde_json::json!(["MSFT_lod"]));
    assert!(doc.get("extensionsRequired").is_none());
    assert_eq!(doc["meshes"][2]["extras"]["octowrap"]["level"], 2);
    if let Some(r) = report {
        assert_counts(&r, &summary);
        let tris: usize = (0..5).map(|k| h.levels[k].mesh.triangles().len()).sum();
        assert_eq!(r["info"]["totalTriangleCount"].as_u64(), Some(tris as u64));
    }
}

#[test]
fn quantized_positions_stay_within_half_a_step() {
    let h = hierarchy();
    let (glb, summary) = to_glb(&h, &opts(Levels::All, true, false)).unwrap();
    // The gltf crate cannot read i16 positions: the validator's report gives the counts.
    if let Some(r) = save_and_validate("cube5_all_quantized.glb", &glb) {
        assert_counts(&r, &summary);
    }
    let (doc, bin) = split(&glb);
    assert_eq!(doc["extensionsRequired"], serde_json::json!(["KHR_mesh_quantization"]));
    for (n, level) in (0..5).rev().enumerate() {
        let node = &doc["nodes"][n];
        let tr: Vec<f64> = node["translation"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let s = node["scale"][0].as_f64().unwrap();
        let prim = &doc["meshes"][n]["primitives"][0];
        let pos = prim["attributes"]["POSITION"].as_u64().unwrap() as usize;
        assert_eq!(doc["accessors"][pos]["componentType"], 5122, "i16");
        let nrm = prim["attributes"]["NORMAL"].as_u64().unwrap() as usize;
        assert_eq!(
            (doc["accessors"][nrm]["componentType"].as_u64(), doc["accessors"][nrm]["normalized"].as_bool()),
            (Some(5120), Some(true))
        );
        let (bytes, count, stride) = accessor_bytes(&doc, &bin, pos);
        assert_eq!(stride, 8);
        let idx = prim["indices"].as_u64().unwrap() as usize;
        let (ib, icount, _) = accessor_bytes(&doc, &bin, idx);
        let indices: Vec<u16> = ib.chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
        let src = &h.levels[level].mesh;
        let tris = src.triangles();
        assert_eq!(icount, tris.len() * 3);
        for (t, st) in indices.chunks(3).zip(&tris) {
            for (&i, &si) in t.iter().zip(st) {
                assert!((i as usize) < count);
                let e = &bytes[i as usize * stride..];
                let q = [0, 2, 4].map(|o| f64::from(i16::from_le_bytes([e[o], e[o + 1]])));
                let p = DVec3::new(tr[0] + s * q[0], tr[1] + s * q[1], tr[2] + s * q[2]);
                let d = (p - src.vertices.positions[si as usize]).abs().max_element();
                assert!(d <= 0.5 * s + 1e-6, "level {level}: off by {d}, step {s}");
            }
        }
    }
}

#[test]
fn meshopt_views_decode_to_the_plain_buffers() {
    // The hierarchy has u16 indices; the 255 x 255 grid u32 indices and colours.
    let inputs = [("cube5_all", hierarchy()), ("grid255", Hierarchy::single(grid(255)))];
    for ((name, h), quantize) in inputs.iter().flat_map(|i| [(i, false), (i, true)]) {
        let plain = to_glb(h, &opts(Levels::All, quantize, false)).unwrap().0;
        let (packed, summary) = to_glb(h, &opts(Levels::All, quantize, true)).unwrap();
        if let Some(r) = save_and_validate(&format!("{name}_meshopt_q{}.glb", u8::from(quantize)), &packed) {
            assert_counts(&r, &summary);
        }
        assert!(packed.len() < plain.len(), "meshopt makes the file smaller: {} vs {}", packed.len(), plain.len());
        let (pdoc, pbin) = split(&plain);
        let (mdoc, mbin) = split(&packed);
        assert!(mdoc["extensionsRequired"].as_array().unwrap().iter().any(|e| e == "EXT_meshopt_compression"));
        assert_eq!(mdoc["buffers"][1]["extensions"]["EXT_meshopt_compression"]["fallback"], true);
        assert!(mdoc["buffers"][1].get("uri").is_none());
        let views = mdoc["bufferViews"].as_array().unwrap();
        assert_eq!(views.len(), pdoc["bufferViews"].as_array().unwrap().len());
        // Every view decoded, laid out as the fallback buffer says.
        let mut fallback = vec![0u8; mdoc["buffers"][1]["byteLength"].as_u64().unwrap() as usize];
        for v in views {
            let ext = &v["extensions"]["EXT_meshopt_compression"];
            let (off, len) =
                (ext["byteOffset"].as_u64().unwrap() as usize, ext["byteLength"].as_u64().unwrap() as usize);
            let (count, stride) =
                (ext["count"].as_u64().unwrap() as usize, ext["byteStride"].as_u64().unwrap() as usize);
            let data = &mbin[off..off + len];
            assert_eq!(data[0], if ext["mode"] == "ATTRIBUTES" { 0xa0 } else { 0xe1 }, "codec version header");
            let decoded: Vec<u8> = match (ext["mode"].as_str().unwrap(), stride) {
                ("ATTRIBUTES", 4) => {
                    bytemuck::cast_slice(&meshopt::decode_vertex_buffer::<[u8; 4]>(data, count).unwrap()).to_vec()
                }
                ("ATTRIBUTES", 8) => {
                    bytemuck::cast_slice(&meshopt::decode_vertex_buffer::<[u8; 8]>(data, count).unwrap()).to_vec()
                }
                ("ATTRIBUTES", 12) => {
                    bytemuck::cast_slice(&meshopt::decode_vertex_buffer::<[u8; 12]>(data, count).unwrap()).to_vec()
                }
                ("TRIANGLES", 2) => {
                    bytemuck::cast_slice(&meshopt::decode_index_buffer::<u16>(data, count).unwrap()).to_vec()
                }
                ("TRIANGLES", 4) => {
                    bytemuck::cast_slice(&meshopt::decode_index_buffer::<u32>(data, count).unwrap()).to_vec()
                }
                other => panic!("unexpected meshopt view {other:?}"),
            };
            assert_eq!(v["buffer"], 1);
            let at = v["byteOffset"].as_u64().unwrap() as usize;
            assert_eq!(v["byteLength"].as_u64(), Some(decoded.len() as u64));
            fallback[at..at + decoded.len()].copy_from_slice(&decoded);
        }
        // Vertices and triangles are reordered for the codecs; each level keeps the same triangles
        // (same winding) with the same corner attributes.
        for m in 0..pdoc["meshes"].as_array().unwrap().len() {
            let a = triangle_corners(&pdoc, &pbin, m);
            let b = triangle_corners(&mdoc, &fallback, m);
            assert_eq!(a.len(), summary.levels[m].triangles);
            assert!(a == b, "{name}: mesh {m} has other triangles after meshopt");
        }
    }
}

/// Mesh `m`'s triangles, each corner as the bytes of all its attributes, each triangle rotated to
/// start at its smallest corner (winding kept), sorted.
fn triangle_corners(doc: &Value, bin: &[u8], m: usize) -> Vec<[Vec<u8>; 3]> {
    let prim = &doc["meshes"][m]["primitives"][0];
    let element = |a: usize, i: usize| -> Vec<u8> {
        let acc = &doc["accessors"][a];
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let size = match (acc["componentType"].as_u64().unwrap(), acc["type"].as_str().unwrap()) {
            (5126, "VEC3") => 12,
            (5122 | 5123, "VEC3") => 6,
            (5120, "VEC3") => 3,
            (5123, "SCALAR") => 2,
            (5125, "SCALAR") => 4,
            other => panic!("unexpected accessor {other:?}"),
        };
        let stride = view["byteStride"].as_u64().map_or(size, |s| s as usize);
        let at = view["byteOffset"].as_u64().unwrap() as usize + i * stride;
        bin[at..at + size].to_vec()
    };
    let ia = prim["indices"].as_u64().unwrap() as usize;
    let attrs: Vec<usize> =
        prim["attributes"].as_object().unwrap().values().map(|v| v.as_u64().unwrap() as usize).collect();
    let count = doc["accessors"][ia]["count"].as_u64().unwrap() as usize;
    let index = |k: usize| -> usize {
        let b = element(ia, k);
        if b.len() == 2 {
            usize::from(u16::from_le_bytes([b[0], b[1]]))
        } else {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize
        }
    };
    let mut tris: Vec<[Vec<u8>; 3]> = (0..count / 3)
        .map(|t| {
            let c: [Vec<u8>; 3] =
                std::array::from_fn(|k| attrs.iter().flat_map(|&a| element(a, index(3 * t + k))).collect());
            let r = (0..3).min_by_key(|&k| c[k].clone()).unwrap();
            [c[r].clone(), c[(r + 1) % 3].clone(), c[(r + 2) % 3].clone()]
        })
        .collect();
    tris.sort();
    tris
}

/// An `n` x `n` grid of quads in the z = 0 plane, with a colour per vertex.
fn grid(n: u32) -> Mesh {
    let mut m = Mesh::from_positions(
        (0..=n).flat_map(|y| (0..=n).map(move |x| DVec3::new(f64::from(x), f64::from(y), 0.0))).collect(),
    );
    let quads: Vec<[u32; 4]> = (0..n)
        .flat_map(|y| {
            (0..n)
                .map(move |x| [y * (n + 1) + x, y * (n + 1) + x + 1, (y + 1) * (n + 1) + x + 1, (y + 1) * (n + 1) + x])
        })
        .collect();
    m.faces = FaceList::from_quads(&quads);
    m.vertices.colors = Some((0..m.vertex_count()).map(|i| [(i % 256) as u8, 128, 255]).collect());
    m
}

#[test]
fn indices_are_u16_while_they_fit_and_u32_beyond() {
    for (n, want) in [(254u32, 5123u64), (255, 5125)] {
        // 255 x 255 quads have 256^2 = 65536 vertices: one too many for u16 (65535 is restart).
        let glb = to_glb(&Hierarchy::single(grid(n)), &ExportOptions::default()).unwrap().0;
        save_and_validate(&format!("grid{n}.glb"), &glb);
        let (doc, _) = split(&glb);
        let idx = doc["meshes"][0]["primitives"][0]["indices"].as_u64().unwrap() as usize;
        assert_eq!(doc["accessors"][idx]["componentType"].as_u64(), Some(want), "grid {n}");
        assert_eq!(doc["accessors"][idx]["count"].as_u64(), Some(u64::from(n * n * 6)));
    }
}

#[test]
fn colours_are_written_linear_and_can_be_left_out() {
    let m = grid(3);
    let glb = to_glb(&Hierarchy::single(m.clone()), &ExportOptions::default()).unwrap().0;
    save_and_validate("grid3_colors.glb", &glb);
    let gltf = gltf::Gltf::from_slice(&glb).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let prim = gltf.meshes().next().unwrap().primitives().next().unwrap();
    let colors: Vec<[u16; 3]> = match prim.reader(|_| Some(&blob)).read_colors(0).unwrap() {
        gltf::mesh::util::ReadColors::RgbU16(it) => it.collect(),
        other => panic!("expected u16 RGB colours, found {other:?}"),
    };
    assert_eq!(colors.len(), m.vertex_count());
    assert_eq!(colors[0], [0, 14_146, 65_535], "sRGB (0, 128, 255) in linear 16-bit");
    let mut no = ExportOptions::default();
    no.colors = false;
    let (doc, _) = split(&to_glb(&Hierarchy::single(m), &no).unwrap().0);
    assert!(doc["meshes"][0]["primitives"][0]["attributes"].get("COLOR_0").is_none());
}

#[test]
fn a_crease_angle_splits_the_cube_corners() {
    let path = support::root().join("fixtures/meshes/valid/cube_quads.obj");
    let cube = octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()).unwrap();
    assert_eq!(cube.vertex_count(), 8);
    let count = |crease: Option<f64>| {
        let mut o = ExportOptions::default();
        o.crease_angle_deg = crease;
        let (glb, s) = to_glb(&Hierarchy::single(cube.clone()), &o).unwrap();
        save_and_validate(&format!("cube_crease_{crease:?}.glb"), &glb);
        s.levels[0].vertices
    };
    assert_eq!(count(None), 8, "smooth: one normal per corner vertex");
    assert_eq!(count(Some(30.0)), 24, "creased: each corner splits into its three faces");
    assert_eq!(count(Some(120.0)), 8, "a crease wider than 90 degrees keeps the cube smooth");
}

#[test]
fn gltf_with_bin_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube levels.gltf");
    let s: Summary = write_path(&path, &hierarchy(), &opts(Levels::One(2), false, false)).unwrap();
    assert_eq!(s.levels.len(), 1);
    assert_eq!(s.levels[0].level, 2);
    assert!(dir.path().join("cube levels.bin").is_file());
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("\"uri\": \"cube%20levels.bin\""), "{text}");
    support::validate(&path);
    let doc = gltf::Gltf::from_slice(text.as_bytes()).expect("the gltf crate reads the JSON");
    let bin = std::fs::read(dir.path().join("cube levels.bin")).unwrap();
    assert_eq!(doc.buffers().next().unwrap().length(), bin.len());
    assert_eq!(doc.nodes().next().unwrap().name(), Some("level 2"));
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    let n = prim.reader(|_| Some(&bin)).read_indices().unwrap().into_u32().count();
    assert_eq!(n, hierarchy().levels[2].mesh.triangles().len() * 3);
    // Nothing else is left in the folder (the temporary files were renamed).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn the_same_input_gives_the_same_bytes() {
    for (q, m) in [(false, false), (true, false), (false, true), (true, true)] {
        let mut o = opts(Levels::All, q, m);
        o.crease_angle_deg = Some(40.0);
        o.metadata = vec![("units".into(), "m".into()), ("source".into(), "synthetic".into())];
        let a = to_glb(&hierarchy(), &o).unwrap().0;
        let b = to_glb(&hierarchy(), &o).unwrap().0;
        assert!(a == b, "quantize {q}, meshopt {m}");
        let (doc, _) = split(&a);
        assert_eq!(doc["asset"]["extras"]["octowrap"]["units"], "m");
    }
}

fn invalid(h: &Hierarchy, o: &ExportOptions) -> String {
    match to_glb(h, o) {
        Err(e @ Error::Invalid { .. }) => e.to_string(),
        other => panic!("expected an Invalid error, got {other:?}"),
    }
}

#[test]
fn hostile_input_gets_named_errors() {
    let quad = || {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y]);
        m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
        m
    };
    let d = ExportOptions::default();
    assert!(invalid(&Hierarchy::default(), &d).contains("no levels"));
    assert!(invalid(&Hierarchy::single(Mesh::from_positions(vec![DVec3::ONE])), &d).contains("level 0 has no faces"));
    let mut m = quad();
    m.vertices.positions[2] = DVec3::new(f64::NAN, 0.0, 0.0);
    assert!(invalid(&Hierarchy::single(m), &d).contains("non-finite"));
    let mut m = quad();
    m.faces.push(&[0, 1, 9]);
    assert!(invalid(&Hierarchy::single(m), &d).contains("level 0: face 1 refers to vertex 9"));
    let mut m = quad();
    m.faces.push(&[0, 1]);
    assert!(invalid(&Hierarchy::single(m), &d).contains("face 1 has 2 vertices"));
    assert!(
        invalid(&hierarchy(), &opts(Levels::One(5), false, false))
            .contains("level 5 does not exist: the input has 5 levels (0 to 4)")
    );
    let mut o = ExportOptions::default();
    o.crease_angle_deg = Some(200.0);
    assert!(invalid(&Hierarchy::single(quad()), &o).contains("crease angle"));
    o.crease_angle_deg = Some(f64::NAN);
    assert!(invalid(&Hierarchy::single(quad()), &o).contains("crease angle"));
    let mut o = ExportOptions::default();
    o.max_screen_error = 0.0;
    assert!(invalid(&Hierarchy::single(quad()), &o).contains("screen error"));
    let mut m = quad();
    m.vertices.positions[0] = DVec3::splat(1e300);
    assert!(matches!(to_glb(&Hierarchy::single(m), &d), Err(Error::LimitExceeded { .. })));
    // A failed write leaves no file behind; what is wrong with the input names no file (the
    // caller names the input), what the system refuses names the output.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.glb");
    let e = write_path(&out, &Hierarchy::default(), &d).unwrap_err();
    assert!(e.to_string().starts_with("invalid: "), "{e}");
    assert!(!out.exists());
    let e = write_path(Path::new("/nonexistent-dir/x.glb"), &Hierarchy::single(quad()), &d).unwrap_err();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("/nonexistent-dir/x.glb"), "{e}");
}

/// Polygon soups (triangles, quads, n-gons, not manifold) under every option set: the validator
/// passes each export.
#[test]
fn polygon_soups_validate_under_every_option_set() {
    for seed in 0..4u64 {
        let mut m = octowrap_format::synthetic::polygon_mesh(300, 200, seed);
        m.vertices.colors = Some((0..m.vertex_count()).map(|i| [(i * 7) as u8, (i * 13) as u8, 200]).collect());
        let mut o = opts(Levels::All, seed & 1 == 1, seed & 2 == 2);
        o.crease_angle_deg = Some(35.0);
        let (glb, summary) = to_glb(&Hierarchy::single(m.clone()), &o).unwrap();
        let drawn = m.triangles().iter().filter(|[a, b, c]| a != b && b != c && a != c).count();
        assert_eq!(summary.levels[0].triangles, drawn, "every triangle with three distinct corners");
        if let Some(r) = save_and_validate(&format!("soup{seed}.glb"), &glb) {
            assert_counts(&r, &summary);
        }
    }
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Any face soup, broken or not, gives an error or a GLB the gltf crate parses, never a panic.
        #[test]
        fn arbitrary_meshes_never_panic(
            positions in prop::collection::vec(prop::array::uniform3(prop_oneof![-1e3f64..1e3, Just(f64::NAN), Just(0.0)]), 0..12),
            faces in prop::collection::vec(prop::collection::vec(0u32..14, 0..6), 0..10),
            quantize: bool, meshopt: bool, crease in prop::option::of(0.0f64..180.0),
        ) {
            let mut m = Mesh::from_positions(positions.into_iter().map(DVec3::from).collect());
            for f in &faces { m.faces.push(f); }
            let mut o = opts(Levels::All, quantize, meshopt);
            o.crease_angle_deg = crease;
            if let Ok((glb, _)) = to_glb(&Hierarchy::single(m), &o) {
                let g = gltf::binary::Glb::from_slice(&glb).unwrap();
                let doc: Value = serde_json::from_slice(&g.json).unwrap();
                prop_assert_eq!(doc["asset"]["version"].as_str(), Some("2.0"));
            }
        }
    }
}
