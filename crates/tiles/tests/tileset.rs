//! Tilesets written from synthetic hierarchies: structure (the spec checks), determinism, measured
//! errors, the Khronos glTF-Validator on every tile, and the crack check by software rendering.

mod support;

use std::path::Path;

use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_geom::DVec3;
use octowrap_mesh::{Hierarchy, Mesh};
use octowrap_tiles::check::check_tileset;
use octowrap_tiles::tileset::{Tile, Tileset};
use octowrap_tiles::{Frame, OctreePartition, TilesOptions, write_tileset};
use support::{Raster, glb_triangles};

fn options(target_faces: usize) -> TilesOptions {
    let mut o = TilesOptions::default();
    let mut p = OctreePartition::default();
    p.target_faces = target_faces;
    o.partition = p;
    o
}

fn read_tileset(path: &Path) -> Tileset {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn all_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.strip_prefix(dir).unwrap().display().to_string(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
#[allow(clippy::items_after_statements)]
fn synthetic_tileset_passes_the_spec_checks_and_is_deterministic() {
    let h = cube_hierarchy(6, Edits::default(), 7);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tileset.json");
    let summary = write_tileset(&path, h.clone(), &Frame::Local, &options(96)).unwrap();
    let report = check_tileset(&path).unwrap();
    assert!(report.findings.is_empty(), "{:#?}", report.findings);
    assert_eq!(report.tiles, summary.tiles);
    assert_eq!(report.contents.len(), summary.content_tiles);
    assert!(summary.content_tiles > 8, "the levels below the target are cut into cells: {summary:?}");
    // Measured errors: finest tiles 0, the root positive and at least the coarsest level's
    // distance to the finest (a lower bound of it).
    let ts = read_tileset(&path);
    assert_eq!(ts.root.refine.as_deref(), Some("REPLACE"));
    let d = octowrap_decimate::metrics::certified_hausdorff(&h.levels[0].mesh, &h.levels[5].mesh);
    assert!(ts.root.geometric_error >= d.lower * 0.999, "{} < {}", ts.root.geometric_error, d.lower);
    fn leaves(t: &Tile, out: &mut Vec<f64>) {
        if t.children.is_empty() {
            out.push(t.geometric_error);
        }
        t.children.iter().for_each(|c| leaves(c, out));
    }
    let mut leaf_errors = Vec::new();
    leaves(&ts.root, &mut leaf_errors);
    assert!(leaf_errors.iter().all(|&e| e == 0.0), "{leaf_errors:?}");
    // Same input, same bytes, whatever the thread count.
    let again = tempfile::tempdir().unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| write_tileset(&again.path().join("tileset.json"), h, &Frame::Local, &options(96)).unwrap());
    assert_eq!(all_files(dir.path()), all_files(again.path()));
    support::validate_gltf(&path);
}

#[test]
fn a_broken_tileset_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tileset.json");
    write_tileset(&path, cube_hierarchy(4, Edits::none(), 1), &Frame::Local, &options(20)).unwrap();
    let mut ts = read_tileset(&path);
    ts.root.children[0].geometric_error = ts.root.geometric_error * 2.0;
    let uri = ts.root.content.as_ref().unwrap().uri.clone();
    std::fs::remove_file(dir.path().join(&uri)).unwrap();
    ts.root.refine = None;
    std::fs::write(&path, serde_json::to_vec(&ts).unwrap()).unwrap();
    let f = check_tileset(&path).unwrap().findings;
    assert!(f.iter().any(|m| m.contains("exceeds its parent")), "{f:#?}");
    assert!(f.iter().any(|m| m.contains("does not resolve")), "{f:#?}");
    assert!(f.iter().any(|m| m.contains("refine is required")), "{f:#?}");
}

#[test]
fn a_single_mesh_is_one_tile() {
    let h = cube_hierarchy(3, Edits::none(), 3);
    let mesh = h.levels[2].mesh.clone();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.json");
    let s = write_tileset(&path, Hierarchy::single(mesh), &Frame::Local, &TilesOptions::default()).unwrap();
    assert_eq!((s.tiles, s.content_tiles, s.root_error), (1, 1, 0.0));
    assert!(check_tileset(&path).unwrap().findings.is_empty());
}

/// The tiles a client would draw: refine while the projected error exceeds `pixels`.
fn cut<'a>(t: &'a Tile, eye: DVec3, focal_px: f64, pixels: f64, out: &mut Vec<&'a Tile>) {
    let b = t.bounding_volume.bbox.as_ref().unwrap();
    let (c, h) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[7], b[11]));
    let d = ((eye - c).abs() - h).max(DVec3::ZERO).length().max(1e-9);
    if t.children.is_empty() || t.geometric_error * focal_px / d <= pixels {
        out.push(t);
    } else {
        t.children.iter().for_each(|c| cut(c, eye, focal_px, pixels, out));
    }
}

/// Pixels the finest level covers that the mixed-level tiled view leaves empty, with and without
/// the flange, as fractions of the model's pixels.
fn crack_fraction(h: &Hierarchy, target: usize, eye: DVec3, pixels: f64, flange: bool) -> (f64, usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tileset.json");
    let mut opts = options(target);
    opts.flange = flange;
    write_tileset(&path, h.clone(), &Frame::Local, &opts).unwrap();
    let ts = read_tileset(&path);
    let m = ts.root.transform.clone().unwrap();
    let origin = DVec3::new(m[12], m[13], m[14]);
    let size = 400;
    let center = DVec3::splat(0.5);
    let raster = Raster::new(eye, center, 40f64.to_radians(), size);
    let focal = raster.focal_px();
    let mut tiles = Vec::new();
    cut(&ts.root, eye - origin, focal, pixels, &mut tiles);
    let levels: std::collections::BTreeSet<String> =
        tiles.iter().filter_map(|t| t.content.as_ref()).map(|c| c.uri.split('/').nth(1).unwrap().to_owned()).collect();
    let finest: &Mesh = &h.levels.last().unwrap().mesh;
    let mut reference = raster.blank();
    let p = &finest.vertices.positions;
    for t in finest.triangles() {
        raster.fill(&mut reference, [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]]);
    }
    let mut tiled = raster.blank();
    for t in &tiles {
        if let Some(c) = &t.content {
            for tri in glb_triangles(&dir.path().join(&c.uri)) {
                raster.fill(&mut tiled, tri.map(|q| q + origin));
            }
        }
    }
    let model = reference.iter().filter(|&&c| c).count();
    let missing = reference.iter().zip(&tiled).filter(|(r, t)| **r && !**t).count();
    (missing as f64 / model as f64, levels.len())
}

#[test]
fn no_cracks_between_tiles_at_different_levels() {
    // Every level on a sphere, the even ones 1 % outside it and the odd ones 1 % inside: tile
    // borders at different levels part along every tile edge.
    let mut h = cube_hierarchy(6, Edits::none(), 11);
    for (k, l) in h.levels.iter_mut().enumerate() {
        let s = if k % 2 == 0 { 1.01 } else { 0.99 };
        for p in &mut l.mesh.vertices.positions {
            *p = DVec3::splat(0.5) + (*p - DVec3::splat(0.5)) * s;
        }
    }
    // A client's cut at 10 pixels of error: three levels in view.
    let eye = DVec3::new(0.5, -0.6, 0.9);
    let (fraction, levels) = crack_fraction(&h, 24, eye, 10.0, true);
    let (without, _) = crack_fraction(&h, 24, eye, 10.0, false);
    assert!(levels >= 3, "the view mixes {levels} levels");
    assert!(without > 0.0005, "without the flange the view must crack ({:.4} %)", without * 100.0);
    assert!(fraction <= 0.0005, "{:.4} % of the model's pixels are cracks", fraction * 100.0);
}

#[test]
#[allow(clippy::items_after_statements)]
fn implicit_tiling_passes_the_spec_checks_and_a_broken_subtree_is_reported() {
    let h = cube_hierarchy(6, Edits::default(), 7);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tileset.json");
    let mut opts = options(96);
    opts.implicit = true;
    let explicit = write_tileset(&dir.path().join("explicit.json"), h.clone(), &Frame::Local, &options(96)).unwrap();
    let summary = write_tileset(&path, h.clone(), &Frame::Local, &opts).unwrap();
    let report = check_tileset(&path).unwrap();
    assert!(report.findings.is_empty(), "{:#?}", report.findings);
    // The same tiles, listed by the subtrees instead of the JSON.
    assert_eq!(report.tiles, explicit.tiles);
    assert_eq!(report.contents.len(), explicit.content_tiles);
    assert_eq!(summary.content_tiles, explicit.content_tiles);
    let ts = read_tileset(&path);
    fn implicit_root(t: &Tile) -> Option<&Tile> {
        if t.implicit_tiling.is_some() { Some(t) } else { t.children.iter().find_map(implicit_root) }
    }
    let root = implicit_root(&ts.root).expect("an implicit root");
    let imp = root.implicit_tiling.as_ref().unwrap();
    assert_eq!((imp.subdivision_scheme.as_str(), imp.subtree_levels), ("OCTREE", 3));
    assert!(imp.available_levels > 3, "more than one subtree level: {imp:?}");
    // Every implicit tile's error (the root's halved per level) is at least its measured one,
    // which the explicit tileset records per tile.
    let ex = read_tileset(&dir.path().join("explicit.json"));
    fn walk<'a>(t: &'a Tile, out: &mut Vec<&'a Tile>) {
        out.push(t);
        t.children.iter().for_each(|c| walk(c, out));
    }
    let mut all = Vec::new();
    walk(&ex.root, &mut all);
    for t in all {
        // tiles/LEVEL/DEPTH-X-Y-Z.glb: the tiles below the implicit root have a positive depth.
        if let Some(c) = &t.content {
            let depth: i32 = c.uri.rsplit('/').next().unwrap().split('-').next().unwrap().parse().unwrap();
            let implicit_error = root.geometric_error / 2f64.powi(depth);
            assert!(
                depth == 0 || implicit_error >= t.geometric_error,
                "{}: {implicit_error} < {}",
                c.uri,
                t.geometric_error
            );
        }
    }
    support::validate_gltf(&path);
    // Same bytes whatever the thread count (the explicit tileset beside it included).
    let again = tempfile::tempdir().unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| {
        write_tileset(&again.path().join("explicit.json"), h.clone(), &Frame::Local, &options(96)).unwrap();
        write_tileset(&again.path().join("tileset.json"), h, &Frame::Local, &opts).unwrap();
    });
    assert_eq!(all_files(dir.path()), all_files(again.path()));
    // A truncated subtree and a missing content are found.
    let sub = dir.path().join("subtrees/0/0-0-0.subtree");
    let bytes = std::fs::read(&sub).unwrap();
    std::fs::write(&sub, &bytes[..bytes.len() - 1]).unwrap();
    let f = check_tileset(&path).unwrap().findings;
    assert!(f.iter().any(|m| m.contains("subtree subtrees/0/0-0-0.subtree") && m.contains("do not fill")), "{f:#?}");
    std::fs::write(&sub, &bytes).unwrap();
    std::fs::remove_file(dir.path().join("implicit/1/0-0-0.glb")).unwrap();
    let f = check_tileset(&path).unwrap().findings;
    assert!(f.iter().any(|m| m.contains("implicit/1/0-0-0.glb") && m.contains("does not resolve")), "{f:#?}");
}
