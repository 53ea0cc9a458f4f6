//! `octowrap export X.mrq -o DIR/tileset.json` as a user runs it on reconstructed hierarchies:
//! the spec checks, the Khronos glTF-Validator on every tile, both browser clients
//! (`3DTilesRendererJS` and `CesiumJS` in headless Chromium: far tiles coarse, near tiles finest, no
//! console errors, no cracks in pixels), and the autzen LiDAR tile set on the globe where pyproj
//! puts it. Artefacts (tilesets, screenshots) stay under `target/tiles-artefacts/`.
#![allow(clippy::print_stdout)]

#[path = "../../tiles/tests/support/clients.rs"]
mod clients;
mod common;

use std::path::Path;
use std::process::Command;

use common::{kitten, octowrap, text};
use serde_json::Value;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn run(args: &[&str]) -> String {
    let o = octowrap(args);
    assert!(o.status.success(), "octowrap {args:?}: {}", text(&o.stderr));
    text(&o.stdout) + &text(&o.stderr)
}

fn validate_tiles(tileset: &Path) {
    if clients::clients_missing().is_some() || !clients::tools().join("node_modules/gltf-validator").is_dir() {
        return clients::skip_or_fail("glTF-Validator on every tile", "tools/tiles-check is not installed");
    }
    let out = Command::new("node").arg(clients::tools().join("validate-tiles.mjs")).arg(tileset).output().unwrap();
    let t = text(&out.stdout);
    assert!(out.status.success() && t.contains(" 0 errors, 0 warnings"), "{t}{}", text(&out.stderr));
}

fn read_json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The kitten reconstructed and exported as tiles: valid, and both clients refine it as the camera
/// comes in, without cracks.
#[test]
fn kitten_tileset_refines_in_both_clients_without_cracks() {
    let dir = clients::artefacts("kitten");
    let mrq = dir.join("kitten.mrq");
    run(&["reconstruct", s(&kitten()), "-o", s(&mrq)]);
    let info = run(&["info", s(&mrq)]);
    assert!(info.contains("frame       local (no CRS)"), "{info}");
    let tileset = dir.join("tiles/tileset.json");
    // 500 faces a tile: the kitten's 12,000 finest faces become tiles of three levels.
    let said = run(&["export", s(&mrq), "-o", s(&tileset), "--tile-faces", "500"]);
    assert!(said.contains("frame local (no CRS)"), "{said}");
    let report = octowrap_tiles::check::check_tileset(&tileset).unwrap();
    assert!(report.findings.is_empty(), "{:#?}", report.findings);
    validate_tiles(&tileset);
    let Some(r) = clients::check_clients(&tileset, &dir, &[]) else { return };
    for client in ["three", "cesium"] {
        clients::assert_refines(&r, client);
    }
    let c = &r["three"]["cracks"];
    let (holes, fraction) = (c["holeFraction"].as_f64().unwrap(), c["fraction"].as_f64().unwrap());
    assert!(c["modelPixels"].as_u64().unwrap() > 10_000, "the model fills the near view: {c}");
    // Cracks are holes in the tiled view's surface; at its silhouette the coarser tiles of the
    // view's far side may cover a little less than the finest level does, by design.
    assert!(holes <= 0.0005, "{:.4} % of the model's pixels are cracks: {c}", holes * 100.0);
    assert!(fraction <= 0.005, "{:.4} % of the model's pixels missing, silhouettes included: {c}", fraction * 100.0);
    println!(
        "kitten: three {:.1} s, cesium {:.1} s; near view draws {} tiles; cracks {} of {} pixels ({} missing with the silhouettes); screenshots in {}",
        r["three"]["seconds"].as_f64().unwrap(),
        r["cesium"]["seconds"].as_f64().unwrap(),
        clients::drawn(&r, "three", "near").len(),
        c["holePixels"],
        c["modelPixels"],
        c["missingPixels"],
        dir.display()
    );
}

/// The positions of a GLB written without quantization, in the tileset's z-up frame (glTF's y-up
/// turned as 3D Tiles clients turn it), the node's translation and scale applied.
fn glb_positions(file: &Path) -> Vec<[f64; 3]> {
    let bytes = std::fs::read(file).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len + 8..];
    let node = doc["nodes"].as_array().unwrap().iter().find(|n| n.get("mesh").is_some()).unwrap();
    assert!(node.get("rotation").is_none() && node.get("matrix").is_none(), "{node}");
    let v3 =
        |key: &str, d: f64| -> [f64; 3] { node.get(key).map_or([d; 3], |a| [0, 1, 2].map(|k| a[k].as_f64().unwrap())) };
    let (t, sc) = (v3("translation", 0.0), v3("scale", 1.0));
    let mesh = &doc["meshes"][node["mesh"].as_u64().unwrap() as usize];
    let acc = &doc["accessors"][mesh["primitives"][0]["attributes"]["POSITION"].as_u64().unwrap() as usize];
    assert_eq!(acc["componentType"].as_u64(), Some(5126), "float positions: {acc}");
    let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
    let stride = view["byteStride"].as_u64().unwrap_or(12) as usize;
    (0..acc["count"].as_u64().unwrap() as usize)
        .map(|i| {
            let at = start + i * stride;
            let f = |k: usize| f64::from(f32::from_le_bytes(bin[at + 4 * k..at + 4 * k + 4].try_into().unwrap()));
            let p = [0, 1, 2].map(|k| f(k) * sc[k] + t[k]);
            [p[0], -p[2], p[1]]
        })
        .collect()
}

fn apply(m: &[f64], p: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r])
}

const PYPROJ: &str = r#"
import sys, json, pyproj
data = json.load(sys.stdin)
crs = pyproj.CRS.from_wkt(data["wkt"])
unit = crs.axis_info[0].unit_conversion_factor
geo = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
cart = pyproj.Transformer.from_pipeline("+proj=cart +ellps=GRS80")
x, y, z = data["origin"]
lon, lat = geo.transform(x, y)
out = {"origin_ecef": list(cart.transform(lon, lat, z * unit)), "origin_lonlat": [lon, lat], "unit": unit}
pts = []
for X, Y, Z in data["ecef"]:
    lon, lat, h = cart.transform(X, Y, Z, direction="INVERSE")
    x, y = geo.transform(lon, lat, direction="INVERSE")
    pts.append([x, y, h / unit])
out["crs"] = pts
print(json.dumps(out))
"#;

fn pyproj(input: &Value) -> Option<Value> {
    use std::io::Write;
    let child = Command::new("python3")
        .args(["-c", PYPROJ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => {
            clients::skip_or_fail("pyproj comparison", &format!("python3 cannot run: {e}"));
            return None;
        }
    };
    child.stdin.take().unwrap().write_all(input.to_string().as_bytes()).unwrap();
    let o = child.wait_with_output().unwrap();
    if !o.status.success() {
        clients::skip_or_fail("pyproj comparison", &text(&o.stderr));
        return None;
    }
    Some(serde_json::from_slice(&o.stdout).unwrap())
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The writer's origin: the centre of every level's bounding box, in the CRS.
fn box_centre(h: &octowrap_mesh::Hierarchy) -> [f64; 3] {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for l in &h.levels {
        for p in &l.mesh.vertices.positions {
            for (k, v) in p.to_array().into_iter().enumerate() {
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
    }
    [0, 1, 2].map(|k| (lo[k] + hi[k]) * 0.5)
}

/// The content of a finest tile (geometric error 0).
fn finest_uri(t: &Value) -> Option<String> {
    if t["geometricError"].as_f64() == Some(0.0) {
        if let Some(u) = t["content"]["uri"].as_str() {
            return Some(u.to_owned());
        }
    }
    t["children"].as_array()?.iter().find_map(finest_uri)
}

/// The issue's done-means: `reconstruct autzen_trim.laz -o a.mrq && export a.mrq -o
/// tiles/tileset.json`. The MRQ keeps the CRS; the root transform's origin and the finest tiles'
/// vertices land within 0.05 m of where pyproj puts the same points in Earth-centred coordinates;
/// `CesiumJS` draws the tileset on the globe there, and both clients refine it.
#[test]
fn autzen_tiles_land_where_pyproj_puts_them() {
    let Some(laz) = octowrap_testdata::file("lidar-las/autzen_trim.laz") else {
        return octowrap_testdata::skip("lidar-las/autzen_trim.laz");
    };
    let dir = clients::artefacts("autzen");
    let mrq = dir.join("a.mrq");
    run(&["reconstruct", s(&laz), "-o", s(&mrq)]);
    let f = octowrap_format::read_path(&mrq, &octowrap_format::DecodeOptions::default()).unwrap();
    let wkt = f.info.metadata.entries.iter().find(|(k, _)| k == octowrap_format::CRS_KEY);
    let wkt = wkt.map(|(_, v)| v.clone()).expect("the MRQ keeps the CRS autzen declares");
    let info = run(&["info", s(&mrq)]);
    assert!(!info.contains("local (no CRS)"), "{info}");
    let tileset = dir.join("tiles/tileset.json");
    let said = run(&["export", s(&mrq), "-o", s(&tileset), "--tile-faces", "2000"]);
    assert!(said.contains("frame EPSG:4978"), "{said}");
    let report = octowrap_tiles::check::check_tileset(&tileset).unwrap();
    assert!(report.findings.is_empty(), "{:#?}", report.findings);
    let origin = box_centre(&f.hierarchy);
    let ts = read_json(&tileset);
    let m: Vec<f64> = ts["root"]["transform"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    // Vertices of one finest tile, in ECEF through the root transform.
    let uri = finest_uri(&ts["root"]).expect("a finest tile");
    let local = glb_positions(&tileset.parent().unwrap().join(&uri));
    let picked: Vec<[f64; 3]> = local.iter().step_by((local.len() / 40).max(1)).map(|&p| apply(&m, p)).collect();
    let input = serde_json::json!({ "wkt": wkt, "origin": origin, "ecef": picked });
    let Some(theirs) = pyproj(&input) else { return };
    let at = |v: &Value| [0, 1, 2].map(|k| v[k].as_f64().unwrap());
    let d = distance([m[12], m[13], m[14]], at(&theirs["origin_ecef"]));
    assert!(d <= 0.05, "the root origin is {d} m from pyproj's");
    // pyproj takes each tile vertex back to the CRS: it must be a vertex of the finest level.
    let unit = theirs["unit"].as_f64().unwrap();
    let finest = &f.hierarchy.levels.last().unwrap().mesh.vertices.positions;
    let mut worst = 0.0f64;
    for q in theirs["crs"].as_array().unwrap().iter().map(at) {
        let near = finest.iter().map(|p| distance(p.to_array(), q)).fold(f64::INFINITY, f64::min) * unit;
        worst = worst.max(near);
    }
    assert!(worst <= 0.05, "a tile vertex lands {worst} m from the finest level's vertex pyproj puts there");
    validate_tiles(&tileset);
    let Some(r) = clients::check_clients(&tileset, &dir, &[]) else { return };
    let p = &r["cesium"]["placement"];
    assert_eq!(p["onGlobe"], true, "{p}");
    let d = distance(at(&p["ecef"]), at(&theirs["origin_ecef"]));
    assert!(d <= 0.05, "CesiumJS puts the root origin {d} m from pyproj's: {p}");
    let (lon, lat) = (theirs["origin_lonlat"][0].as_f64().unwrap(), theirs["origin_lonlat"][1].as_f64().unwrap());
    assert!(
        (p["longitude"].as_f64().unwrap() - lon).abs() < 1e-6 && (p["latitude"].as_f64().unwrap() - lat).abs() < 1e-6,
        "{p} vs {lon} {lat}"
    );
    for client in ["three", "cesium"] {
        clients::assert_refines(&r, client);
    }
    println!(
        "autzen: origin {lon:.6} {lat:.6}; worst vertex {worst:.4} m from pyproj; three {:.1} s, cesium {:.1} s; screenshots in {}",
        r["three"]["seconds"].as_f64().unwrap(),
        r["cesium"]["seconds"].as_f64().unwrap(),
        dir.display()
    );
}

/// The implicit level of a drawn tile (`implicit/LEVEL/X-Y-Z.glb`); explicit tiles above the
/// implicit root count as level 0.
fn implicit_level(t: &Value) -> u64 {
    let uri = t["uri"].as_str().unwrap_or("");
    uri.strip_prefix("implicit/").and_then(|r| r.split('/').next()).and_then(|l| l.parse().ok()).unwrap_or(0)
}

/// `--implicit`: the same kitten as implicit tiling passes the spec checks (subtrees walked) and
/// the validator, and both clients expand the subtrees and refine by distance.
#[test]
#[allow(clippy::items_after_statements)]
fn kitten_implicit_tileset_refines_in_both_clients() {
    let dir = clients::artefacts("kitten-implicit");
    let mrq = dir.join("kitten.mrq");
    run(&["reconstruct", s(&kitten()), "-o", s(&mrq)]);
    let tileset = dir.join("tiles/tileset.json");
    run(&["export", s(&mrq), "-o", s(&tileset), "--tile-faces", "500", "--implicit"]);
    let report = octowrap_tiles::check::check_tileset(&tileset).unwrap();
    assert!(report.findings.is_empty(), "{:#?}", report.findings);
    let ts = read_json(&tileset);
    fn implicit_root(t: &Value) -> Option<&Value> {
        if t.get("implicitTiling").is_some() {
            Some(t)
        } else {
            t["children"].as_array()?.iter().find_map(implicit_root)
        }
    }
    let imp = &implicit_root(&ts["root"]).expect("an implicit root")["implicitTiling"];
    let deepest = imp["availableLevels"].as_u64().unwrap() - 1;
    assert!(deepest >= 3, "{imp}");
    validate_tiles(&tileset);
    // Implicit errors halve per level from a root error at or above every measured one, so they
    // overstate the finer tiles' errors: a client at 32 pixels refines as one at 16 does the
    // explicit tileset.
    let Some(r) = clients::check_clients(&tileset, &dir, &["--no-cracks", "--error-target", "32"]) else { return };
    for client in ["three", "cesium"] {
        let c = &r[client];
        assert_eq!(c["errors"].as_array().map(Vec::len), Some(0), "{client}: console errors: {}", c["errors"]);
        let far = clients::drawn(&r, client, "far");
        let near = clients::drawn(&r, client, "near");
        assert!(
            !far.is_empty() && far.iter().all(|t| implicit_level(t) < deepest),
            "{client} far: {}",
            c["views"]["far"]
        );
        let (first, last) = (near.first().expect("tiles drawn near"), near.last().unwrap());
        assert_eq!(implicit_level(first), deepest, "{client}: the nearest tile is finest: {}", c["views"]["near"]);
        assert!(implicit_level(last) < deepest, "{client}: the farthest tile stays coarse: {}", c["views"]["near"]);
    }
    println!(
        "kitten --implicit: {} tiles; near view draws {} tiles; three {:.1} s, cesium {:.1} s",
        report.tiles,
        clients::drawn(&r, "three", "near").len(),
        r["three"]["seconds"].as_f64().unwrap(),
        r["cesium"]["seconds"].as_f64().unwrap()
    );
}

/// Tileset options on a glTF output, and a zero face target, exit 2 naming the option; nothing
/// is written.
#[test]
fn tileset_options_elsewhere_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let mrq = common::root().join("fixtures/format/valid/cube3_lattice_q12.mrq");
    let glb = dir.path().join("a.glb");
    for extra in [&["--implicit"][..], &["--tile-faces", "100"][..]] {
        let mut args = vec!["export", s(&mrq), "-o", s(&glb)];
        args.extend_from_slice(extra);
        let o = octowrap(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", text(&o.stderr));
        assert!(text(&o.stderr).contains("tileset options"), "{}", text(&o.stderr));
        assert!(!glb.exists());
    }
    let json = dir.path().join("t/tileset.json");
    let o = octowrap(&["export", s(&mrq), "-o", s(&json), "--tile-faces", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("--tile-faces"), "{}", text(&o.stderr));
    assert!(!json.exists());
}
