//! Writers never harm what they replace: FIFOs, devices and symbolic links stay what they are,
//! modes are kept, the input is never the output, `--no-clobber` is honoured, `.gz` compresses,
//! and a signal leaves no temporary behind.
#![allow(clippy::print_stdout)] // a test that cannot run here prints a SKIPPED line
#![cfg(unix)]

mod common;

use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{kitten, octowrap, root, text};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn cube() -> PathBuf {
    root().join("fixtures/meshes/valid/cube_quads.obj")
}

fn mrq() -> PathBuf {
    root().join("fixtures/format/valid/cube3_lattice_exact.mrq")
}

/// The names in `dir`, sorted (no `.octowrap-*.tmp` may be among them).
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

fn umask() -> Option<u32> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("Umask:"))?;
    u32::from_str_radix(line.split_whitespace().nth(1)?, 8).ok()
}

#[test]
fn an_output_fifo_is_written_into_and_stays_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("out.ply");
    if !Command::new("mkfifo").arg(&fifo).status().is_ok_and(|st| st.success()) {
        println!("SKIPPED: mkfifo is not available");
        return;
    }
    let reader = Command::new("cat").arg(&fifo).stdout(Stdio::piped()).spawn().unwrap();
    let out = octowrap(&["convert", s(&cube()), s(&fifo)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // Checked first: a FIFO replaced by a file would leave the reader waiting forever.
    let fifo_kept = std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo();
    if !fifo_kept {
        let mut reader = reader;
        let _ = reader.kill();
        panic!("the FIFO was replaced by a regular file");
    }
    let bytes = reader.wait_with_output().unwrap().stdout;
    assert!(bytes.starts_with(b"ply\n"), "the reader got the PLY");
    assert_eq!(names(dir.path()), ["out.ply"]);
}

/// A test never writes to the machine's own `/dev/null` or `/dev/stdout`: a regression would
/// replace them with regular files. It writes to a null device made for it in a temporary folder
/// (`mknod NAME c 1 3`, which needs root) and to a link to its own standard output.
#[test]
fn writing_to_a_character_device_or_stdout_leaves_them_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let null = dir.path().join("null");
    let made = Command::new("mknod").arg(&null).args(["c", "1", "3"]).stderr(Stdio::null()).status();
    if !made.is_ok_and(|st| st.success()) {
        println!("SKIPPED: mknod cannot make a character device here (it needs root)");
        return;
    }
    let device = std::fs::symlink_metadata(&null).unwrap();
    assert!(device.file_type().is_char_device());
    for format in ["ply", "obj", "off", "stl"] {
        let out = octowrap(&["convert", s(&cube()), s(&null), "--to", format]);
        assert!(out.status.success(), "{format}: {}", text(&out.stderr));
        let after = std::fs::symlink_metadata(&null).unwrap();
        assert!(after.file_type().is_char_device(), "{format}: the device was replaced");
        assert_eq!(after.rdev(), device.rdev(), "{format}: the same device");
        assert_eq!(after.ino(), device.ino(), "{format}: the same node");
    }
    // Standard output (a pipe here) through a link in the temporary folder, as `/dev/stdout` is.
    if !Path::new("/proc/self/fd/1").exists() {
        println!("SKIPPED: no /proc/self/fd");
        return;
    }
    let stdout = dir.path().join("stdout");
    std::os::unix::fs::symlink("/proc/self/fd/1", &stdout).unwrap();
    let out = octowrap(&["convert", s(&cube()), s(&stdout), "--to", "obj"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).lines().any(|l| l.starts_with("f ")), "the OBJ went through the pipe");
    assert!(std::fs::symlink_metadata(&stdout).unwrap().file_type().is_symlink(), "the link is kept");
    assert_eq!(names(dir.path()), ["null", "stdout"], "no temporary is left");
}

#[test]
fn a_symbolic_link_output_stays_a_link_and_modes_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.ply");
    std::fs::write(&target, b"old").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o644)).unwrap();
    let link = dir.path().join("link.ply");
    std::os::unix::fs::symlink("real.ply", &link).unwrap();
    let out = octowrap(&["convert", s(&cube()), s(&link)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link is kept");
    assert!(std::fs::read(&target).unwrap().starts_with(b"ply\n"), "its target is replaced");
    assert_eq!(std::fs::metadata(&target).unwrap().mode() & 0o777, 0o644, "and keeps its mode");
    // Every writer: a new file gets 0666 less the umask, a replaced one keeps its mode.
    let (c, m, k) = (cube(), mrq(), kitten());
    let (c, m, k) = (s(&c), s(&m), s(&k));
    let outputs = [
        ("a.obj", vec!["convert", c, "OUT"]),
        ("b.mrq", vec!["convert", c, "OUT"]),
        ("c.off", vec!["extract", m, "-o", "OUT"]),
        ("d.ply", vec!["decimate", c, "-o", "OUT", "--target-faces", "4"]),
        ("e.glb", vec!["export", c, "-o", "OUT"]),
        ("f.ply", vec!["reconstruct", k, "-o", "OUT", "--level", "3"]),
    ];
    for (name, args) in outputs {
        let path = dir.path().join(name);
        let args: Vec<&str> = args.iter().map(|a| if *a == "OUT" { s(&path) } else { a }).collect();
        let out = octowrap(&args);
        assert!(out.status.success(), "{name}: {}", text(&out.stderr));
        if let Some(u) = umask() {
            assert_eq!(std::fs::metadata(&path).unwrap().mode() & 0o777, 0o666 & !u, "{name}: new file");
        }
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        let out = octowrap(&args);
        assert!(out.status.success(), "{name}: {}", text(&out.stderr));
        assert_eq!(std::fs::metadata(&path).unwrap().mode() & 0o777, 0o640, "{name}: replaced file");
    }
    assert!(names(dir.path()).iter().all(|n| !n.starts_with(".octowrap-")), "{:?}", names(dir.path()));
}

#[test]
fn the_output_may_not_be_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    std::fs::copy(cube(), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    let soft = dir.path().join("soft.obj");
    std::os::unix::fs::symlink(&input, &soft).unwrap();
    let hard = dir.path().join("hard.obj");
    std::fs::hard_link(&input, &hard).unwrap();
    let kitten_copy = dir.path().join("k.ply");
    let out = octowrap(&["convert", s(&kitten()), s(&kitten_copy)]);
    assert!(out.status.success());
    for output in [&input, &soft, &hard] {
        for args in
            [vec!["convert", s(&input), s(output)], vec!["decimate", s(&input), "-o", s(output), "--ratio", "0.5"]]
        {
            let out = octowrap(&args);
            assert_eq!(out.status.code(), Some(2), "{args:?}");
            let err = text(&out.stderr);
            assert!(err.contains("the output is the input"), "{args:?}: {err}");
        }
    }
    let out = octowrap(&["reconstruct", s(&kitten_copy), "-o", s(&kitten_copy)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("the output is the input"), "{}", text(&out.stderr));
    assert_eq!(std::fs::read(&input).unwrap(), before, "the input is untouched");
}

#[test]
fn no_clobber_refuses_before_any_work_on_every_writing_command() {
    let dir = tempfile::tempdir().unwrap();
    let (c, m, k) = (cube(), mrq(), kitten());
    let (c, m, k) = (s(&c), s(&m), s(&k));
    let cases = [
        ("a.obj", vec!["convert", c, "OUT", "--no-clobber"]),
        ("b.mrq", vec!["convert", c, "OUT", "--no-clobber"]),
        ("c.off", vec!["extract", m, "-o", "OUT", "--no-clobber"]),
        ("d.ply", vec!["decimate", c, "-o", "OUT", "--target-faces", "4", "--no-clobber"]),
        ("e.glb", vec!["export", c, "-o", "OUT", "--no-clobber"]),
        ("f.ply", vec!["reconstruct", k, "-o", "OUT", "--level", "3", "--no-clobber"]),
    ];
    for (name, args) in cases {
        let path = dir.path().join(name);
        let args: Vec<&str> = args.iter().map(|a| if *a == "OUT" { s(&path) } else { a }).collect();
        let out = octowrap(&args);
        assert!(out.status.success(), "{name}: a new file is written: {}", text(&out.stderr));
        std::fs::write(&path, b"precious").unwrap();
        let out = octowrap(&args);
        assert_eq!(out.status.code(), Some(2), "{name}");
        assert!(text(&out.stderr).contains("--no-clobber"), "{name}: {}", text(&out.stderr));
        assert_eq!(std::fs::read(&path).unwrap(), b"precious", "{name}: kept");
    }
    // A .gltf output checks its .bin too.
    std::fs::write(dir.path().join("g.bin"), b"precious").unwrap();
    let gltf = dir.path().join("g.gltf");
    let out = octowrap(&["export", s(&cube()), "-o", s(&gltf), "--no-clobber"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!gltf.exists());
}

#[test]
fn a_gz_output_is_gzip_compressed() {
    let dir = tempfile::tempdir().unwrap();
    let gz = dir.path().join("cube.ply.gz");
    let out = octowrap(&["convert", s(&cube()), s(&gz)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let bytes = std::fs::read(&gz).unwrap();
    assert_eq!(bytes[..2], [0x1f, 0x8b], "gzip signature");
    let info = octowrap(&["info", "--json", s(&gz)]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["format"], "ply");
    assert_eq!(v["faces"], 6);
}

/// The bytes of a gzip file, decompressed.
fn gunzip(path: &Path) -> Vec<u8> {
    use std::io::Read as _;
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(bytes[..2], [0x1f, 0x8b], "{}: gzip signature", path.display());
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(&bytes[..]).read_to_end(&mut out).unwrap();
    out
}

#[test]
fn mrq_and_glb_gz_outputs_are_gzip_compressed_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, gz) = (dir.path().join("c.mrq"), dir.path().join("c.mrq.gz"));
    for o in [&plain, &gz] {
        let out = octowrap(&["convert", s(&mrq()), s(o)]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    // The encoder records the output's name nowhere, so the two hold the same MRQ bytes.
    assert!(gunzip(&gz) == std::fs::read(&plain).unwrap(), "the .mrq.gz holds the .mrq's bytes");
    // Read back by every command that takes an MRQ input: info, validate, convert, export.
    let info = octowrap(&["info", "--json", s(&gz)]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["format"], "mrq", "{v}");
    // validate decodes every level of the .gz as of the plain file: the same report.
    let (valid, valid_plain) = (octowrap(&["validate", s(&gz)]), octowrap(&["validate", s(&plain)]));
    assert_eq!(valid.status.code(), valid_plain.status.code(), "{}", text(&valid.stderr));
    let report = |o: &std::process::Output| text(&o.stdout) + &text(&o.stderr);
    assert_eq!(report(&valid).replace("c.mrq.gz", "c.mrq"), report(&valid_plain));
    assert!(report(&valid).contains("level 0:"), "{}", report(&valid));
    // convert reads the levels of the .gz as of the plain file.
    let (back, back_plain) = (dir.path().join("back.obj"), dir.path().join("back-plain.obj"));
    for (from, to) in [(&gz, &back), (&plain, &back_plain)] {
        let out = octowrap(&["convert", s(from), s(to)]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    assert!(std::fs::read(&back).unwrap() == std::fs::read(&back_plain).unwrap(), "the same finest level");
    // reconstruct writes .mrq.gz too.
    let rec = dir.path().join("k.mrq.gz");
    let out = octowrap(&["reconstruct", s(&kitten()), "-o", s(&rec), "--level", "3"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(gunzip(&rec).starts_with(b"\x89MRQ"), "an MRQ file inside");
    // export: .glb.gz holds the .glb's bytes; .gltf.gz is refused before any work.
    let (glb, glb_gz) = (dir.path().join("c.glb"), dir.path().join("c.glb.gz"));
    for o in [&glb, &glb_gz] {
        let out = octowrap(&["export", s(&mrq()), "-o", s(o)]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    assert!(gunzip(&glb_gz) == std::fs::read(&glb).unwrap(), "the .glb.gz holds the .glb's bytes");
    let gltf_gz = dir.path().join("c.gltf.gz");
    let out = octowrap(&["export", s(&mrq()), "-o", s(&gltf_gz)]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains(".glb.gz"), "{}", text(&out.stderr));
    assert!(!gltf_gz.exists());
}

#[test]
fn a_signal_during_a_write_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    // A cloud large enough that writing it gzip-compressed takes a while.
    let big = dir.path().join("big.ply");
    let n = 1_500_000u32;
    let mut ply = format!("ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n").into_bytes();
    for i in 0..n {
        for c in [i as f32, (i % 977) as f32 * 0.37, (i % 1013) as f32 * 0.11] {
            ply.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(&big, ply).unwrap();
    let outdir = dir.path().join("out");
    std::fs::create_dir(&outdir).unwrap();
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let output = outdir.join("big.xyz.gz");
        let mut child = Command::new(env!("CARGO_BIN_EXE_octowrap"))
            .args(["convert", s(&big), s(&output)])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        let mut signalled = false;
        while start.elapsed() < Duration::from_secs(120) {
            if names(&outdir).iter().any(|n| n.starts_with(".octowrap-")) {
                let kill = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status();
                signalled = kill.is_ok_and(|st| st.success());
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let status = child.wait().unwrap();
        assert!(signalled, "the temporary was seen and SIG{signal} sent (status {status:?})");
        assert_eq!(status.code(), Some(code), "SIG{signal}");
        assert!(names(&outdir).is_empty(), "SIG{signal}: left {:?}", names(&outdir));
    }
}
