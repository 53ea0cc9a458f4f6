//! `octowrap validate` as CI uses it: exit codes and report snapshots.
//!
//! Snapshots live in `tests/snapshots/`; a missing or different snapshot fails. Run with
//! `UPDATE_SNAPSHOTS=1` to write them after an intended change, and review the diff.

use std::path::Path;
use std::process::Output;

mod common;

use common::octowrap_in_root as octowrap;

fn snapshot(name: &str, out: &Output, stream: &[u8]) {
    let text = format!("exit code: {:?}\n{}", out.status.code(), String::from_utf8_lossy(stream));
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots").join(name);
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some_and(|v| v == "1") {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("snapshot {} is missing ({e}); UPDATE_SNAPSHOTS=1 writes it", path.display()));
    assert_eq!(text, want, "snapshot {name} differs (UPDATE_SNAPSHOTS=1 rewrites it)");
}

#[test]
fn valid_fixtures_pass_with_exit_0() {
    let out = octowrap(&["validate", "--require", "manifold,oriented", "fixtures/meshes/valid"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    snapshot("valid_text.txt", &out, &out.stderr);
}

#[test]
fn defects_fail_with_exit_1_and_a_json_report() {
    let out = octowrap(&["validate", "--format", "json", "fixtures/meshes/defects"]);
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 8);
    let nm = files.iter().find(|f| f["file"].as_str().unwrap().ends_with("three_faces_one_edge.obj")).unwrap();
    assert_eq!(nm["outcome"]["counts"]["non_manifold_edges"], 1);
    assert_eq!(nm["outcome"]["findings"][0]["code"], "E-NONMANIFOLD-EDGE");
    assert_eq!(nm["outcome"]["findings"][0]["elements"][0]["edge"], serde_json::json!([0, 1]));
    assert_eq!(nm["failed_requirements"], serde_json::json!(["manifold"]));
    snapshot("defects_text.txt", &out, &out.stderr);
}

#[test]
fn junit_and_sarif_reports() {
    let out = octowrap(&[
        "validate",
        "--format",
        "junit",
        "-q",
        "fixtures/meshes/defects/hourglass_vertex.obj",
        "fixtures/meshes/valid/cube_quads.obj",
    ]);
    assert_eq!(out.status.code(), Some(1));
    snapshot("junit.xml", &out, &out.stdout);
    let out = octowrap(&[
        "validate",
        "--format",
        "sarif",
        "-q",
        "--require",
        "oriented",
        "fixtures/meshes/defects/flipped_face.obj",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["version"], "2.1.0");
    let results = v["runs"][0]["results"].as_array().unwrap();
    assert_eq!(results[0]["ruleId"], "E-ORIENTATION");
    assert_eq!(results[0]["properties"]["count"], 4);
    snapshot("sarif.json", &out, &out.stdout);
}

#[test]
fn unreadable_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.off");
    std::fs::write(&bad, "OFF\n3 1 0\n0 0 0\n").unwrap();
    let out = octowrap(&["validate", bad.to_str().unwrap(), "fixtures/meshes/valid/cube_quads.obj"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("UNREADABLE"));
}

#[test]
fn watertight_requirement_fails_on_an_open_box() {
    let out = octowrap(&["validate", "--require", "watertight", "fixtures/meshes/valid/open_box.obj"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("required but not met: watertight"));
}

#[test]
fn mrq_files_are_checked_level_by_level() {
    let out = octowrap(&["validate", "--format", "json", "fixtures/format/valid/cube3_subdivision_q10.mrq"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let outcome = &v["files"][0]["outcome"];
    assert_eq!(outcome["kind"], "hierarchy");
    let levels = outcome["levels"].as_array().unwrap();
    assert!(levels.len() >= 2);
    assert!(levels.iter().all(|l| l["properties"]["manifold"] == true));
    assert_eq!(outcome["links"], serde_json::json!([]));

    // A corrupted level is unreadable (exit 2), and the report says which level and byte.
    let out = octowrap(&["validate", "fixtures/format/invalid/level1_checksum.mrq"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("checksum mismatch in level 1"), "{err}");
}
