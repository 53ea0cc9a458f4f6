//! Test helpers: the Khronos glTF-Validator and the headless three.js page, run through node
//! scripts in `tools/viewer`. Without node, the npm modules or Chromium, the checks print SKIPPED
//! with the reason and pass (`.ci/run` installs all three, so CI runs them).
#![allow(dead_code, clippy::print_stderr)] // each test file uses its own subset; SKIPPED goes to stderr

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The viewer and validator scripts' folder.
pub fn viewer() -> PathBuf {
    root().join("tools/viewer")
}

/// A folder under `target/` for artefacts the tests keep (screenshots, exported files).
pub fn artefacts() -> PathBuf {
    let dir = root().join("target/export-artefacts");
    std::fs::create_dir_all(&dir).expect("target/ is writable");
    dir.canonicalize().unwrap_or(dir)
}

fn node_works() -> bool {
    Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success())
}

/// Why the validator cannot run here, if it cannot.
pub fn validator_missing() -> Option<String> {
    if !node_works() {
        return Some("node is not installed".into());
    }
    if !viewer().join("node_modules/gltf-validator").is_dir() {
        return Some("tools/viewer/node_modules is missing (run `npm ci` in tools/viewer)".into());
    }
    None
}

/// Why the headless page cannot run here, if it cannot.
pub fn page_missing() -> Option<String> {
    if let Some(why) = validator_missing() {
        return Some(why);
    }
    if !viewer().join("node_modules/three").is_dir() || !viewer().join("node_modules/playwright-core").is_dir() {
        return Some("three or playwright-core is missing from tools/viewer/node_modules".into());
    }
    if !Path::new("/usr/bin/chromium").exists() {
        return Some("/usr/bin/chromium is not installed (apt-get install chromium)".into());
    }
    None
}

/// Prints SKIPPED with `why`, or fails when `OCTOWRAP_EXPORT_CHECKS=required` (set by `.ci/run`
/// once it has installed the tools), so that CI cannot pass by skipping.
fn skip(what: &str, why: &str) {
    assert!(
        std::env::var("OCTOWRAP_EXPORT_CHECKS").as_deref() != Ok("required"),
        "{what} is required here (OCTOWRAP_EXPORT_CHECKS=required) but cannot run: {why}"
    );
    eprintln!("SKIPPED {what}: {why}");
}

/// Runs the Khronos validator on `file`; `None` (after printing SKIPPED) when it cannot run.
/// Panics, printing the issues, unless the report has 0 errors and 0 warnings.
pub fn validate(file: &Path) -> Option<serde_json::Value> {
    if let Some(why) = validator_missing() {
        skip(&format!("glTF-Validator on {}", file.display()), &why);
        return None;
    }
    let out = Command::new("node").arg(viewer().join("validate.mjs")).arg(file).output().expect("node runs");
    assert!(out.status.success(), "validate.mjs failed: {}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the validator prints JSON");
    let issues = &report["issues"];
    assert_eq!(
        (issues["numErrors"].as_u64(), issues["numWarnings"].as_u64()),
        (Some(0), Some(0)),
        "{}: {}",
        file.display(),
        serde_json::to_string_pretty(&issues["messages"]).unwrap_or_default()
    );
    Some(report)
}

/// Opens `glb` in the three.js page in headless Chromium and returns its JSON result (see
/// `tools/viewer/check-page.mjs`); `None` (after printing SKIPPED) when it cannot run.
pub fn open_in_page(glb: &Path, screenshot: &Path) -> Option<serde_json::Value> {
    if let Some(why) = page_missing() {
        skip(&format!("three.js page on {}", glb.display()), &why);
        return None;
    }
    let out =
        Command::new("node").arg(viewer().join("check-page.mjs")).arg(glb).arg(screenshot).output().expect("node runs");
    assert!(
        out.status.success(),
        "check-page.mjs failed ({:?}): {}\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Some(serde_json::from_slice(&out.stdout).expect("the page check prints JSON"))
}
