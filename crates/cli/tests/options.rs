//! Options are checked before any work, and messages say what is wrong with which file.
#![allow(clippy::print_stdout)] // a test that cannot run here prints a SKIPPED line

mod common;

use std::path::{Path, PathBuf};

use common::{kitten, octowrap, root, text};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn cube() -> PathBuf {
    root().join("fixtures/meshes/valid/cube_quads.obj")
}

/// Runs `args`, expecting exit 2 with every one of `needles` in standard error and no output file.
fn refused(args: &[&str], needles: &[&str], output: &Path) {
    let out = octowrap(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: '{n}' not in: {err}");
    }
    assert!(!output.exists(), "{args:?}: nothing written");
}

#[test]
fn out_of_range_values_are_refused_by_the_parser() {
    let dir = tempfile::tempdir().unwrap();
    let mrq = dir.path().join("o.mrq");
    let ply = dir.path().join("o.ply");
    let (k, c) = (kitten(), cube());
    let (k, c) = (s(&k), s(&c));
    refused(&["convert", c, s(&mrq), "--bits", "0"], &["--bits", "1..=28"], &mrq);
    refused(&["convert", c, s(&mrq), "--bits", "29"], &["--bits"], &mrq);
    refused(&["convert", c, s(&mrq), "--zstd-level", "0"], &["--zstd-level", "1..=22"], &mrq);
    refused(&["convert", c, s(&mrq), "--zstd-level", "23"], &["--zstd-level"], &mrq);
    refused(&["convert", c, s(&mrq), "--step", "0"], &["--step"], &mrq);
    refused(&["decimate", c, "-o", s(&ply), "--target-faces", "0"], &["--target-faces"], &ply);
    refused(&["reconstruct", k, "-o", s(&mrq), "--bits", "0"], &["--bits"], &mrq);
    refused(&["reconstruct", k, "-o", s(&ply), "--level", "0"], &["--level"], &ply);
    refused(&["reconstruct", k, "-o", s(&ply), "--max-level", "21"], &["--max-level"], &ply);
    refused(&["reconstruct", k, "-o", s(&ply), "--threads", "0"], &["--threads"], &ply);
    refused(&["export", c, "-o", s(&dir.path().join("e.glb")), "--crease-angle", "181"], &["crease"], &ply);
    refused(&["export", c, "-o", s(&dir.path().join("e.glb")), "--screen-error", "0"], &["screen"], &ply);
    refused(&["info", c, "--max-memory", "lots"], &["--max-memory"], &ply);
}

#[test]
fn combinations_are_refused_before_reading_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("o.ply");
    let mrq = dir.path().join("o.mrq");
    // An input that does not exist: a combination error must come first, not "cannot read".
    let missing = dir.path().join("missing.xyz");
    let m = s(&missing);
    refused(&["reconstruct", m, "-o", s(&ply), "--level", "3", "--write-level", "9"], &["--write-level 9", "3"], &ply);
    refused(&["reconstruct", m, "-o", s(&mrq), "--write-level", "2"], &["--write-level", ".mrq"], &mrq);
    refused(&["reconstruct", m, "-o", s(&ply), "--bits", "12"], &["--bits", "not MRQ"], &ply);
    refused(&["reconstruct", m, "-o", s(&ply), "--keep-positions"], &["--keep-positions"], &ply);
    refused(&["convert", m, s(&ply), "--zstd-level", "5"], &["--zstd-level", "not MRQ"], &ply);
    refused(&["convert", m, s(&ply), "--level", "2"], &["--level", "single mesh"], &ply);
    let hierarchy = root().join("fixtures/format/valid/cube3_lattice_exact.mrq");
    let cut = ["decimate", s(&hierarchy), "-o", s(&ply), "--max-error", "0.1"];
    refused(&[&cut[..], &["--lock-border"]].concat(), &["--lock-border", "cut"], &ply);
    refused(&[&cut[..], &["--quads", "triangles"]].concat(), &["--quads", "cut"], &ply);
    for args in [
        vec!["reconstruct", m, "-o", s(&ply), "--level", "3", "--write-level", "9"],
        vec!["convert", m, s(&ply), "--zstd-level", "5"],
    ] {
        let err = text(&octowrap(&args).stderr);
        assert!(!err.contains("No such file"), "{args:?}: refused before reading: {err}");
    }
}

#[test]
fn decimate_without_a_target_names_every_alternative() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("o.ply");
    refused(&["decimate", s(&cube()), "-o", s(&ply)], &["--target-faces", "--ratio", "--max-error", "--view"], &ply);
}

#[test]
fn a_broken_input_is_blamed_not_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("broken.obj");
    std::fs::write(&broken, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    for (output, args) in [
        ("o.ply", vec!["convert", "IN", "OUT"]),
        ("o.mrq", vec!["convert", "IN", "OUT"]),
        ("o.glb", vec!["export", "IN", "-o", "OUT"]),
        ("d.ply", vec!["decimate", "IN", "-o", "OUT", "--ratio", "0.5"]),
    ] {
        let out_path = dir.path().join(output);
        let args: Vec<&str> = args
            .iter()
            .map(|a| {
                if *a == "IN" {
                    s(&broken)
                } else if *a == "OUT" {
                    s(&out_path)
                } else {
                    a
                }
            })
            .collect();
        let out = octowrap(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("broken.obj"), "{args:?}: names the input: {err}");
        assert!(!err.contains(output), "{args:?}: does not blame the output: {err}");
        assert!(!out_path.exists());
    }
}

#[test]
fn an_input_export_cannot_draw_is_blamed_not_the_output() {
    // Readable, but every triangle names a vertex twice: the export refuses the content.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("degenerate.obj");
    std::fs::write(&input, "v 0 0 0\nv 1 0 0\nv 0 1 0\n".to_owned() + &"f 1 1 1\n".repeat(100)).unwrap();
    for output in ["o.glb", "o.gltf"] {
        let out_path = dir.path().join(output);
        let out = octowrap(&["export", s(&input), "-o", s(&out_path), "--meshopt"]);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{output}: {err}");
        assert!(
            err.contains("degenerate.obj") && err.contains("names a vertex twice"),
            "{output}: names the input: {err}"
        );
        assert!(!err.contains(output), "{output}: does not blame the output: {err}");
        assert!(!out_path.exists());
    }
}

#[test]
fn info_reports_every_file_and_exits_2_if_any_failed() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ply");
    std::fs::write(&bad, b"ply\nformat ascii 1.0\nelement vertex 99\nend_header\n1 2\n").unwrap();
    let missing = dir.path().join("missing.obj");
    let out = octowrap(&["info", "--json", s(&cube()), s(&bad), s(&missing), s(&kitten())]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let files = v.as_array().unwrap();
    assert_eq!(files.len(), 4, "every file reported");
    assert_eq!(files[0]["faces"], 6);
    assert!(files[1]["error"].as_str().unwrap().contains("bad.ply"));
    assert!(files[2]["error"].as_str().unwrap().contains("missing.obj"));
    assert_eq!(files[3]["points"], 5210);
    let err = text(&out.stderr);
    assert!(err.contains("bad.ply") && err.contains("missing.obj"), "{err}");
    // Text form: the readable files are described, the others named on standard error.
    let out = octowrap(&["info", s(&bad), s(&cube())]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stdout).contains("cube_quads.obj"));
}

#[test]
fn an_empty_mesh_fails_every_requirement() {
    let dir = tempfile::tempdir().unwrap();
    // 100 KB of pseudo-random bytes named .obj: no reader finds faces in them.
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let junk: Vec<u8> = (0..100_000)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect();
    let noise = dir.path().join("noise.obj");
    std::fs::write(&noise, junk).unwrap();
    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, b"# nothing\n").unwrap();
    for file in [&noise, &empty] {
        for req in ["watertight", "manifold", "clean", "closed,oriented"] {
            let out = octowrap(&["validate", s(file), "--require", req]);
            assert_ne!(out.status.code(), Some(0), "{} --require {req}: {}", file.display(), text(&out.stderr));
        }
    }
    let out = octowrap(&["validate", s(&empty), "--require", "watertight"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("no faces"), "{}", text(&out.stderr));
}

#[cfg(target_os = "linux")]
#[test]
fn validate_reports_a_file_whose_name_is_not_utf8() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(cube(), dir.path().join("good.obj")).unwrap();
    let odd = dir.path().join(std::ffi::OsStr::from_bytes(b"caf\xe9.obj"));
    if std::fs::copy(cube(), &odd).is_err() {
        println!("SKIPPED: the file system refuses non-UTF-8 names");
        return;
    }
    let out = octowrap(&["validate", s(dir.path()), "--format", "json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let listed = v.to_string();
    assert!(listed.contains("caf\u{fffd}.obj"), "the odd name is reported: {listed}");
    assert!(listed.contains("good.obj"));
}

#[test]
fn max_memory_is_documented_and_refuses_a_larger_input() {
    let help = text(&octowrap(&["convert", "--help"]).stdout);
    assert!(help.contains("--max-memory"), "{help}");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("k.ply");
    refused(&["convert", s(&kitten()), s(&out_path), "--max-memory", "1K"], &["--max-memory", "kitten.xyz"], &out_path);
    let out = octowrap(&["info", s(&kitten()), "--max-memory", "1G"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

/// Runs `octowrap args` with `input` on standard input.
fn with_stdin(args: &[&str], input: &[u8]) -> std::process::Output {
    use std::io::Write as _;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_octowrap"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    // The command may stop reading early (that is the point): a closed pipe is fine here.
    let feeder = std::thread::spawn(move || drop(stdin.write_all(&input)));
    let out = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    out
}

#[test]
fn standard_input_counts_against_max_memory_like_a_file() {
    let mut xyz = String::new();
    for i in 0..100_000 {
        xyz += &(i.to_string() + " " + &(i % 7).to_string() + " 0.5\n");
    }
    assert!(xyz.len() > 1 << 20);
    let out = with_stdin(&["info", "-", "--from", "xyz", "--max-memory", "1M"], xyz.as_bytes());
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("<stdin>") && err.contains("--max-memory") && err.contains("1048576 bytes"), "{err}");
    // Compressed, the same points fit in a few kilobytes, but what they decompress to counts.
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut z, xyz.as_bytes()).unwrap();
    let gz = z.finish().unwrap();
    assert!(gz.len() < 1 << 20);
    let out = with_stdin(&["info", "-", "--from", "xyz", "--max-memory", "1M"], &gz);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("--max-memory"), "{}", text(&out.stderr));
    let out = with_stdin(&["info", "-", "--from", "xyz", "--max-memory", "64M"], xyz.as_bytes());
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("100000"), "{}", text(&out.stdout));
}

#[test]
fn max_scans_caps_a_conf_set_and_raising_it_reads_the_set() {
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("a.xyz");
    std::fs::write(&scan, "0 0 0\n1 0 0\n0 1 0\n0 0 1\n").unwrap();
    let conf = dir.path().join("set.conf");
    std::fs::write(&conf, "bmesh a.xyz 0 0 0 0 0 0 1\n".repeat(3)).unwrap();
    let out = dir.path().join("o.xyz");
    refused(&["convert", s(&conf), s(&out), "--max-scans", "2"], &["set.conf", "--max-scans"], &out);
    let ok = octowrap(&["convert", s(&conf), s(&out), "--max-scans", "3"]);
    assert_eq!(ok.status.code(), Some(0), "{}", text(&ok.stderr));
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 12, "three scans of four points");
}
