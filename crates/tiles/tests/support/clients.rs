//! The two browser clients as a test runs them: `tools/tiles-check/check-clients.mjs` opens a
//! tileset in `3DTilesRendererJS` and `CesiumJS` in headless Chromium and reports the tiles each
//! drew at a far and a near view, the pixel crack measure, console errors and screenshots.
//! Without node, the npm modules or Chromium the check prints SKIPPED (a failure under
//! `OCTOWRAP_TILES_CHECKS=required`, as `.ci/run` sets it once they are installed).
#![allow(dead_code, clippy::print_stdout)] // each test file uses its own subset; SKIPPED goes to stdout

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// `tools/tiles-check`.
pub fn tools() -> PathBuf {
    octowrap_testdata::workspace_root().join("tools/tiles-check")
}

/// A folder under `target/tiles-artefacts/` that the tests keep (tilesets, screenshots).
pub fn artefacts(name: &str) -> PathBuf {
    let dir = octowrap_testdata::workspace_root().join("target/tiles-artefacts").join(name);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).expect("target/ is writable");
    }
    std::fs::create_dir_all(&dir).expect("target/ is writable");
    dir.canonicalize().unwrap_or(dir)
}

/// Prints SKIPPED with `why`, or fails when `OCTOWRAP_TILES_CHECKS=required`.
pub fn skip_or_fail(what: &str, why: &str) {
    assert!(
        std::env::var("OCTOWRAP_TILES_CHECKS").as_deref() != Ok("required"),
        "{what} is required here (OCTOWRAP_TILES_CHECKS=required) but cannot run: {why}"
    );
    println!("SKIPPED {what}: {why}");
}

/// Why the browser clients cannot run here, if they cannot.
pub fn clients_missing() -> Option<String> {
    if !Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success()) {
        return Some("node is not installed".into());
    }
    for m in ["3d-tiles-renderer", "cesium", "three", "playwright-core"] {
        if !tools().join("node_modules").join(m).is_dir() {
            return Some(format!("tools/tiles-check/node_modules/{m} is missing (npm ci in tools/tiles-check)"));
        }
    }
    if !Path::new("/usr/bin/chromium").exists() {
        return Some("/usr/bin/chromium is not installed (apt-get install chromium)".into());
    }
    None
}

/// Runs both clients (or those `args` name with `--clients`) on `tileset`, screenshots into
/// `shots`; `None` after SKIPPED. Panics with the script's output when a page failed to run.
pub fn check_clients(tileset: &Path, shots: &Path, args: &[&str]) -> Option<Value> {
    if let Some(why) = clients_missing() {
        skip_or_fail("3D Tiles clients in headless Chromium", &why);
        return None;
    }
    let out = Command::new("node")
        .arg(tools().join("check-clients.mjs"))
        .arg(tileset)
        .arg(shots)
        .args(args)
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "check-clients.mjs failed: {stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    Some(serde_json::from_str(&stdout).expect("check-clients.mjs prints JSON"))
}

/// The drawn tiles of one client at one view.
pub fn drawn<'a>(report: &'a Value, client: &str, view: &str) -> &'a [Value] {
    report[client]["views"][view]["tiles"].as_array().map_or(&[], Vec::as_slice)
}

/// Asserts what a client drew: far, every tile coarse (a positive geometric error); near, the
/// tile nearest the camera from the finest level (error 0) and the farthest still coarse; no
/// console errors; a screenshot per view.
pub fn assert_refines(report: &Value, client: &str) {
    let r = &report[client];
    assert_eq!(r["errors"].as_array().map(Vec::len), Some(0), "{client}: console errors: {}", r["errors"]);
    let far = drawn(report, client, "far");
    assert!(!far.is_empty(), "{client}: nothing drawn at the far view: {r}");
    assert!(
        far.iter().all(|t| t["geometricError"].as_f64().unwrap() > 0.0),
        "{client}: the far view draws only coarse tiles: {}",
        r["views"]["far"]
    );
    let near = drawn(report, client, "near");
    let (first, last) = (near.first().expect("tiles drawn near"), near.last().unwrap());
    assert_eq!(
        first["geometricError"].as_f64(),
        Some(0.0),
        "{client}: the nearest tile is finest: {}",
        r["views"]["near"]
    );
    assert!(
        last["geometricError"].as_f64().unwrap() > 0.0,
        "{client}: the farthest tile stays coarse: {}",
        r["views"]["near"]
    );
    assert!(
        near.len() > far.len(),
        "{client}: coming closer draws more tiles ({} near, {} far)",
        near.len(),
        far.len()
    );
    for shot in r["screenshots"].as_array().unwrap() {
        let p = Path::new(shot.as_str().unwrap());
        assert!(std::fs::metadata(p).is_ok_and(|m| m.len() > 1000), "{client}: screenshot {}", p.display());
    }
}
