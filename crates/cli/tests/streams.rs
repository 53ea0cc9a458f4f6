//! Standard output: a closed pipe ends a command quietly, and reports never share standard output
//! with data.

mod common;

use std::process::{Command, Stdio};

use common::{kitten, octowrap, root, text};

#[test]
fn a_closed_pipe_is_a_quiet_success() {
    let cube = root().join("fixtures/meshes/valid/cube_quads.obj");
    let mrq = root().join("fixtures/format/valid/cube3_lattice_exact.mrq");
    let (k, c, m) = (kitten(), cube, mrq);
    let (k, c, m) = (k.to_str().unwrap(), c.to_str().unwrap(), m.to_str().unwrap());
    let commands: [Vec<&str>; 6] = [
        vec!["info", k, c, m, k, c, m],
        vec!["info", "--json", k, c, m],
        vec!["validate", c, "--format", "json"],
        vec!["convert", k, "-", "--to", "xyz"],
        vec!["extract", m, "-o", "-", "--to", "obj"],
        vec!["decimate", c, "-o", "out.ply", "--target-faces", "4", "--json"],
    ];
    let dir = tempfile::tempdir().unwrap();
    for args in commands {
        // The reading end is closed before the command writes: every write meets a closed pipe.
        let mut child = Command::new(env!("CARGO_BIN_EXE_octowrap"))
            .args(&args)
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
    }
}

#[test]
fn a_report_never_shares_standard_output_with_the_mesh() {
    let cube = root().join("fixtures/meshes/valid/cube_quads.obj");
    let out =
        octowrap(&["decimate", cube.to_str().unwrap(), "-o", "-", "--to", "ply", "--target-faces", "4", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty(), "nothing written");
    let err = text(&out.stderr);
    assert!(err.contains("--json") && err.contains("-o -"), "{err}");
    // Without --json, the mesh alone is on standard output and the summary on standard error.
    let out = octowrap(&["decimate", cube.to_str().unwrap(), "-o", "-", "--to", "ply", "--target-faces", "4"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stdout.starts_with(b"ply\n"));
    assert!(text(&out.stderr).contains("faces"));
}
