//! The crack measure as a client draws it: the sphere hierarchy whose levels part along every tile
//! border (odd levels 1 % inside, even ones 1 % outside) in 3DTilesRendererJS in headless Chromium.
//! At a camera that mixes levels, the pixels a render of the finest level covers and the tiled
//! view leaves empty stay at most 0.05 % of the model's pixels with the flange, and exceed it
//! without (the measure can fail). Screenshots and the picture of the measure (`three-cracks.png`:
//! red where only the finest level covers) under `target/tiles-artefacts/sphere-*`.

#[path = "support/clients.rs"]
mod clients;

use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_geom::DVec3;
use octowrap_tiles::{Frame, OctreePartition, TilesOptions, write_tileset};
use serde_json::Value;

fn parted_sphere() -> octowrap_mesh::Hierarchy {
    let mut h = cube_hierarchy(6, Edits::none(), 11);
    for (k, l) in h.levels.iter_mut().enumerate() {
        let s = if k % 2 == 0 { 1.01 } else { 0.99 };
        for p in &mut l.mesh.vertices.positions {
            *p = DVec3::splat(0.5) + (*p - DVec3::splat(0.5)) * s;
        }
    }
    h
}

/// The crack report and the levels drawn, for a tileset written with or without the flange.
fn cracks(flange: bool) -> Option<(Value, usize)> {
    let name = if flange { "sphere-flange" } else { "sphere-no-flange" };
    let dir = clients::artefacts(name);
    std::fs::create_dir_all(dir.join("tiles")).unwrap();
    let path = dir.join("tiles/tileset.json");
    let mut opts = TilesOptions::default();
    let mut p = OctreePartition::default();
    p.target_faces = 96;
    opts.partition = p;
    opts.flange = flange;
    write_tileset(&path, parted_sphere(), &Frame::Local, &opts).unwrap();
    let ts: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let m = &ts["root"]["transform"];
    let o = [12, 13, 14].map(|k| m[k].as_f64().unwrap());
    // A camera on the -y side, above the centre and looking at it; at 10 pixels of error the client
    // draws three levels, their borders facing the camera (96 faces a tile: few tiles to load).
    let (eye, target) = ([0.5, -0.45, 0.85], [0.5, 0.5, 0.5]);
    let view: Vec<String> = eye.iter().chain(&target).enumerate().map(|(k, v)| (v - o[k % 3]).to_string()).collect();
    let r = clients::check_clients(
        &path,
        &dir,
        &["--clients", "three", "--views", "given", "--view", &view.join(","), "--error-target", "10"],
    )?;
    assert_eq!(r["three"]["errors"].as_array().map(Vec::len), Some(0), "console errors: {}", r["three"]["errors"]);
    let levels: std::collections::BTreeSet<String> = clients::drawn(&r, "three", "given")
        .iter()
        .filter_map(|t| t["uri"].as_str()?.split('/').nth(1).map(str::to_owned))
        .collect();
    Some((r["three"]["cracks"].clone(), levels.len()))
}

#[test]
fn no_cracks_in_pixels_in_3d_tiles_renderer() {
    let Some((with, levels)) = cracks(true) else { return };
    let Some((without, _)) = cracks(false) else { return };
    let f = |c: &Value| c["fraction"].as_f64().unwrap();
    assert!(levels >= 3, "the view mixes {levels} levels");
    assert_eq!(with["modelPixels"], without["modelPixels"], "the same finest level from the same camera");
    assert!(with["modelPixels"].as_u64().unwrap() > 10_000, "{with}");
    let holes = |c: &Value| c["holeFraction"].as_f64().unwrap();
    assert!(f(&without) > 0.0005, "without the flange the view must crack: {without}");
    assert!(holes(&without) > 0.0005, "the cracks without the flange are holes in the surface: {without}");
    assert!(holes(&with) <= f(&with), "holes are some of the missing pixels: {with}");
    assert!(f(&with) <= 0.0005, "{:.4} % of the model's pixels are cracks: {with}", f(&with) * 100.0);
    #[allow(clippy::print_stdout)]
    {
        println!(
            "3DTilesRendererJS, {levels} levels in view: cracks {:.4} % with the flange, {:.4} % without",
            f(&with) * 100.0,
            f(&without) * 100.0
        );
    }
}
