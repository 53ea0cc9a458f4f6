//! The `octowrap` binary as a user runs it: outputs, messages and exit codes.

mod common;

use common::{kitten, octowrap, text};

#[test]
fn info_reports_counts_as_json() {
    let out = octowrap(&["info", "--json", kitten().to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["points"], 5210);
    assert_eq!(v["faces"], 0);
    assert_eq!(v["format"], "xyz");
    assert_eq!(v["attributes"][0], "normal");
}

#[test]
fn convert_writes_a_readable_file_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("kitten.ply");
    let out = octowrap(&["convert", kitten().to_str().unwrap(), out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let info = octowrap(&["info", "--json", out_path.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["points"], 5210);
    assert_eq!(v["format"], "ply");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn convert_to_standard_output() {
    let out = octowrap(&["convert", kitten().to_str().unwrap(), "-", "--to", "xyz"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(text(&out.stdout).lines().count(), 5210);
}

#[test]
fn unreadable_input_exits_2_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.ply");
    std::fs::write(&bad, "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nend_header\n1\n")
        .unwrap();
    let target = dir.path().join("out.obj");
    let out = octowrap(&["convert", bad.to_str().unwrap(), target.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(err.contains("broken.ply"), "{err}");
    assert!(!target.exists(), "a failed run left an output file");

    let out = octowrap(&["info", dir.path().join("missing.ply").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("missing.ply"));
}

#[test]
fn unknown_output_format_is_refused_before_reading() {
    let out = octowrap(&["convert", kitten().to_str().unwrap(), "out.docx"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--to"), "{}", text(&out.stderr));
    let out = octowrap(&["convert", kitten().to_str().unwrap(), "out.laz"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("does not write"), "{}", text(&out.stderr));
}

#[test]
fn help_teaches_with_examples() {
    let out = octowrap(&["convert", "--help"]);
    assert!(out.status.success());
    let h = text(&out.stdout);
    assert!(h.contains("Examples:") && h.contains("octowrap convert scan.laz scan.ply"), "{h}");
}

/// A missing input is reported once per command, naming the file and the system's reason, with
/// the reason said once (not repeated by the error chain).
#[test]
fn a_missing_input_names_the_file_and_its_cause_once() {
    for args in [
        vec!["convert", "/nonexistent/in.ply", "/tmp/octowrap-never-written.ply"],
        vec!["info", "/nonexistent/in.ply"],
        vec!["export", "/nonexistent/in.ply", "-o", "/tmp/octowrap-never-written.glb"],
        vec!["decimate", "/nonexistent/in.ply", "-o", "/tmp/octowrap-never-written.ply", "--ratio", "0.5"],
    ] {
        let out = common::octowrap(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = common::text(&out.stderr);
        assert!(err.contains("/nonexistent/in.ply"), "{args:?}: {err}");
        assert_eq!(err.matches("os error 2").count(), 1, "{args:?}: the cause once: {err}");
    }
}
