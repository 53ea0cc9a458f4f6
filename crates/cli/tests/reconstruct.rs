//! `octowrap reconstruct` as a user runs it: outputs, the timing table, levels, errors.

mod common;

use common::{kitten, octowrap, text};

#[test]
fn writes_the_finest_level_all_levels_and_timings() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("kitten.ply");
    let levels = dir.path().join("levels");
    let out = octowrap(&[
        "reconstruct",
        kitten().to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
        "--level",
        "5",
        "--timings",
        "--all-levels",
        levels.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    for column in ["level", "partitioning", "regular", "irregular", "mapping", "relaxation"] {
        assert!(err.contains(column), "timing table lacks {column}: {err}");
    }
    assert_eq!(err.lines().filter(|l| l.trim_start().starts_with(char::is_numeric)).count(), 6, "{err}");
    let finest = octowrap_io::read_path(&out_path, &octowrap_io::ReadOptions::default()).unwrap();
    assert!(finest.faces.all_quads() && finest.faces.len() > 1000);
    for k in 0..=5 {
        let m = octowrap_io::read_path(&levels.join(format!("level-{k}.ply")), &octowrap_io::ReadOptions::default())
            .unwrap_or_else(|e| panic!("level {k}: {e}"));
        assert!(m.faces.all_quads());
        if k == 0 {
            assert_eq!(m.faces.len(), 6);
        }
        if k == 5 {
            assert_eq!(m.faces, finest.faces);
        }
    }
}

#[test]
fn same_bytes_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one.ply");
    let two = dir.path().join("two.ply");
    for (p, n) in [(&one, "1"), (&two, "2")] {
        let out = octowrap(&["reconstruct", kitten().to_str().unwrap(), "-o", p.to_str().unwrap(), "-j", n]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    assert_eq!(std::fs::read(one).unwrap(), std::fs::read(two).unwrap());
}

#[test]
fn bad_input_and_bad_output_fail_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.xyz");
    std::fs::write(&empty, "").unwrap();
    let out = octowrap(&["reconstruct", empty.to_str().unwrap(), "-o", dir.path().join("x.ply").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("empty"), "{}", text(&out.stderr));
    let nan = dir.path().join("nan.xyz");
    std::fs::write(&nan, "0 0 0\n1 0 0\nnan 1 0\n0 0 1\n").unwrap();
    let out = octowrap(&["reconstruct", nan.to_str().unwrap(), "-o", dir.path().join("x.ply").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let out = octowrap(&["reconstruct", kitten().to_str().unwrap(), "-o", dir.path().join("x.xyz").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("cannot hold a mesh"), "{}", text(&out.stderr));
}

#[test]
fn region_levels_refine_dense_regions_past_the_limit_and_stay_manifold() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.ply");
    let regions = dir.path().join("regions.ply");
    let input = kitten();
    let run = |p: &std::path::Path, extra: &[&str]| {
        let mut a = vec!["reconstruct", input.to_str().unwrap(), "-o", p.to_str().unwrap(), "--timings"];
        a.extend_from_slice(extra);
        let out = octowrap(&a);
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stderr)
    };
    // Pinned levels: --max-level auto would go on past the density-supported level.
    let plain_table = run(&plain, &["--level", "4"]);
    let region_table = run(&regions, &["--level", "5", "--region-levels", "2", "--region-density", "2"]);
    // The kitten's topology is trusted to level 4; with regions, level 5 is wrapped where dense.
    assert!(plain_table.contains("trusted to level 4"), "{plain_table}");
    assert!(region_table.contains("trusted to level 5"), "{region_table}");
    let read = |p: &std::path::Path| octowrap_io::read_path(p, &octowrap_io::ReadOptions::default()).unwrap();
    let (a, b) = (read(&plain), read(&regions));
    assert!(b.faces.all_quads() && b.faces.len() > a.faces.len(), "{} vs {}", b.faces.len(), a.faces.len());
    let check = octowrap(&["validate", regions.to_str().unwrap(), "--require", "manifold,oriented"]);
    assert_eq!(check.status.code(), Some(0), "{}", text(&check.stderr));

    for bad in ["0", "nan", "-1", "many"] {
        let out = octowrap(&[
            "reconstruct",
            kitten().to_str().unwrap(),
            "-o",
            regions.to_str().unwrap(),
            "--region-levels",
            "1",
            &format!("--region-density={bad}"),
        ]);
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", text(&out.stderr));
        assert!(text(&out.stderr).contains("region-density"), "{bad}: {}", text(&out.stderr));
    }
}

#[test]
fn fit_passes_zero_keeps_the_papers_mapping_and_the_same_faces() {
    let dir = tempfile::tempdir().unwrap();
    let input = kitten();
    let run = |name: &str, extra: &[&str]| {
        let p = dir.path().join(name);
        let mut a = vec!["reconstruct", input.to_str().unwrap(), "-o", p.to_str().unwrap()];
        a.extend_from_slice(extra);
        let out = octowrap(&a);
        assert!(out.status.success(), "{}", text(&out.stderr));
        octowrap_io::read_path(&p, &octowrap_io::ReadOptions::default()).unwrap()
    };
    // A pinned level: --max-level auto measures each level after the fit, so its choice could
    // differ between the runs.
    let fitted = run("fit.ply", &["--level", "4"]);
    let plain = run("plain.ply", &["--level", "4", "--fit-passes", "0"]);
    let capped = run("capped.ply", &["--level", "4", "--fit-max-faces", "10"]);
    // The fit moves vertices only: the same faces, other positions; a face limit below the
    // finest level's faces leaves it as the paper's mapping puts it.
    assert_eq!(fitted.faces, plain.faces);
    assert_ne!(fitted.vertices.positions, plain.vertices.positions);
    assert_eq!(capped.vertices.positions, plain.vertices.positions);
    let out = octowrap(&["reconstruct", input.to_str().unwrap(), "-o", "x.ply", "--fit-passes", "many"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
}
