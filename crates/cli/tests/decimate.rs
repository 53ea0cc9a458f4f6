//! `octowrap decimate` on the command line: meshes in and out of every writable format, MRQ cuts
//! with a fixed error and with a camera, the JSON report, and exit code 2 for what cannot run.

mod common;

use std::path::Path;

use common::{octowrap, root, text};
use octowrap_io::{ReadOptions, read_path};
use octowrap_validate::{ValidateOptions, validate_mesh};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn decimates_a_quad_torus_into_every_format() {
    let input = root().join("fixtures/meshes/valid/torus_quads.obj");
    let dir = tempfile::tempdir().unwrap();
    for ext in ["ply", "obj", "off", "stl"] {
        let out_path = dir.path().join(format!("t.{ext}"));
        let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--ratio", "0.5", "--json"]);
        assert!(out.status.success(), "{ext}: {}", text(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(report["mode"], "decimate");
        assert_eq!(report["input_faces"], 48);
        let mut o = ValidateOptions::default();
        o.weld = ext == "stl";
        let mesh = read_path(&out_path, &ReadOptions::default()).unwrap();
        let r = validate_mesh(&mesh, &o);
        assert!(r.properties.watertight && r.properties.oriented, "{ext}: {:?}", r.findings);
        assert_eq!(r.components[0].genus, Some(1), "{ext}");
    }
}

#[test]
fn error_bounds_in_units_and_percent_and_measurement() {
    let input = root().join("fixtures/meshes/valid/open_box.obj");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("box.ply");
    for bound in ["0.5%", "0.001"] {
        let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--max-error", bound, "--measure", "--json"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(report["measured"]["hausdorff"].as_f64().unwrap() < 1e-9, "a flat box decimates exactly");
        assert!(report["decimate"]["error"].as_f64().unwrap() < 1e-6);
        assert!(text(&out.stderr).contains("sampled: Hausdorff"));
        assert!(text(&out.stderr).contains("certified"));
    }
    let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--target-faces", "3", "--lock-border"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mesh = read_path(&out_path, &ReadOptions::default()).unwrap();
    assert_eq!(validate_mesh(&mesh, &ValidateOptions::default()).counts.boundary_loops, 1);
}

#[test]
fn the_certified_distance_is_measured_on_request() {
    // By default only the free quadric estimate: no certified figure in the report or the summary.
    let input = root().join("fixtures/meshes/valid/torus_quads.obj");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("t.ply");
    let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--ratio", "0.5", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report["decimate"]["error"].is_null(), "{report}");
    assert!(report["measured"].is_null(), "{report}");
    assert!(report["decimate"]["quadric_error"].as_f64().unwrap() > 0.0, "{report}");
    let summary = text(&out.stderr);
    assert!(summary.contains("error estimate (quadric") && !summary.contains("certified;"), "{summary}");
    // --measure: the certified bound, at least the sampled distance, and both printed.
    let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--ratio", "0.5", "--measure", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let certified = report["decimate"]["error"].as_f64().unwrap();
    let sampled = report["measured"]["hausdorff"].as_f64().unwrap();
    assert!(certified > 0.0 && sampled <= certified * (1.0 + 1e-9), "{report}");
    let summary = text(&out.stderr);
    assert!(summary.contains("certified;") && summary.contains("sampled: Hausdorff"), "{summary}");
    assert!(!summary.contains("error estimate"), "{summary}");
}

#[test]
fn max_error_bounds_the_written_output_and_quad_targets_are_met() {
    let input = root().join("fixtures/meshes/valid/torus_quads.obj");
    let mesh = read_path(&input, &ReadOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("t.ply");
    for bound in ["1", "10%", "25%"] {
        let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--max-error", bound, "--json"]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let d = &report["decimate"];
        let e = if let Some(p) = bound.strip_suffix('%') {
            p.parse::<f64>().unwrap() / 100.0 * d["diagonal"].as_f64().unwrap()
        } else {
            bound.parse().unwrap()
        };
        let reported = d["error"].as_f64().unwrap();
        assert!(reported <= e && d["collapses"].as_u64().unwrap() > 0, "{bound}: {d}");
        // The written output, measured independently: within the bound, and below the certified
        // figure.
        let written = read_path(&out_path, &ReadOptions::default()).unwrap();
        let sampled = octowrap_decimate::metrics::distance(
            &mesh,
            &written,
            &octowrap_decimate::metrics::Sampling::with_samples(200_000),
        );
        assert!(
            sampled.hausdorff <= reported * (1.0 + 1e-9) && sampled.hausdorff >= 0.9 * reported - 1e-9,
            "{bound}: {d}"
        );
        assert!(text(&out.stderr).contains("Hausdorff distance to the input: at most"));
    }
    // A face target on quad input counts the faces as written (16 is about as low as this
    // torus goes: 15 faces, 8 vertices).
    for n in ["30", "20", "16"] {
        let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--target-faces", n]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let written = read_path(&out_path, &ReadOptions::default()).unwrap();
        assert!(written.faces.len() <= n.parse().unwrap(), "{n}: {}", written.faces.len());
    }
}

#[test]
fn mrq_cuts_with_an_error_and_with_a_camera() {
    let input = root().join("fixtures/format/valid/cube3_subdivision_q10.mrq");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("cut.off");
    let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--max-error", "1", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["mode"], "cut");
    assert_eq!(report["output_faces"], 6, "the coarsest level everywhere");
    let camera = dir.path().join("camera.json");
    std::fs::write(
        &camera,
        r#"{"position": [3, 3, 3], "target": [0.5, 0.5, 0.5], "fov_y_degrees": 45,
            "viewport_height_px": 1080, "pixel_error": 1}"#,
    )
    .unwrap();
    let out = octowrap(&["decimate", s(&input), "-o", s(&out_path), "--view", s(&camera), "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mesh = read_path(&out_path, &ReadOptions::default()).unwrap();
    let r = validate_mesh(&mesh, &ValidateOptions::default());
    assert!(r.properties.watertight && r.properties.oriented, "{:?}", r.findings);
    // An MRQ output is a one-level file.
    let mrq_out = dir.path().join("cut.mrq");
    let out = octowrap(&["decimate", s(&input), "-o", s(&mrq_out), "--max-error", "0.05"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let back = octowrap_format::read_path(&mrq_out, &octowrap_format::DecodeOptions::default()).unwrap();
    assert_eq!(back.hierarchy.levels.len(), 1);
}

#[test]
fn what_cannot_run_exits_with_2() {
    let input = root().join("fixtures/meshes/valid/cube_quads.obj");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("x.ply");
    let cases: Vec<Vec<&str>> = vec![
        vec!["decimate", s(&input), "-o", s(&out_path)],
        vec!["decimate", s(&input), "-o", s(&out_path), "--ratio", "1.5"],
        vec!["decimate", s(&input), "-o", s(&out_path), "--max-error", "-1"],
        vec!["decimate", s(&input), "-o", s(&out_path), "--max-error", "abc%"],
        vec!["decimate", s(&input), "-o", s(&out_path), "--view", "camera.json"],
        vec!["decimate", "/nonexistent/mesh.ply", "-o", s(&out_path), "--ratio", "0.5"],
    ];
    for args in &cases {
        let out = octowrap(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out.stderr));
    }
    let xyz = dir.path().join("x.xyz");
    let out = octowrap(&["decimate", s(&input), "-o", s(&xyz), "--ratio", "0.5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!xyz.exists());
    let cloud = root().join("fixtures/points/kitten.xyz");
    let out = octowrap(&["decimate", s(&cloud), "-o", s(&out_path), "--ratio", "0.5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("no faces"));
    assert!(!out_path.exists(), "nothing written when the command fails");
}

#[test]
fn help_documents_targets_and_the_camera_schema() {
    let out = octowrap(&["decimate", "--help"]);
    assert!(out.status.success());
    let help = text(&out.stdout);
    for needle in [
        "--target-faces",
        "--ratio",
        "--max-error",
        "--view",
        "fov_y_degrees",
        "viewport_height_px",
        "pixel_error",
        "Examples:",
        "certified",
        "a quad is one face",
    ] {
        assert!(help.contains(needle), "{needle}");
    }
}
