//! `write_file` against what an output path may name: nothing, a file with its own mode, a
//! symbolic link, a FIFO, a folder; and `same_file` through links.
#![allow(clippy::print_stdout)] // a test that cannot run here prints a SKIPPED line
#![cfg(unix)]

use std::io::Read;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::Path;
use std::process::Command;

use octowrap_fsutil::{WriteError, WriteOptions, check_output, same_file, write_file};

fn put(path: &Path, bytes: &[u8], opts: &WriteOptions) -> Result<(), WriteError<std::io::Error>> {
    write_file(path, opts, |w| w.write_all(bytes))
}

fn mode(path: &Path) -> u32 {
    std::fs::metadata(path).unwrap().mode() & 0o7777
}

/// The process's umask, as the kernel reports it.
fn umask() -> Option<u32> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("Umask:"))?;
    u32::from_str_radix(line.split_whitespace().nth(1)?, 8).ok()
}

/// The folder holds only the names given: no temporary left behind.
fn assert_only(dir: &Path, names: &[&str]) {
    let mut found: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    found.sort();
    let mut want: Vec<String> = names.iter().map(|s| (*s).to_owned()).collect();
    want.sort();
    assert_eq!(found, want);
}

#[test]
fn a_new_file_gets_the_umask_mode_and_a_replaced_file_keeps_its_mode() {
    let dir = tempfile::tempdir().unwrap();
    let new = dir.path().join("new.ply");
    put(&new, b"one", &WriteOptions::default()).unwrap();
    assert_eq!(std::fs::read(&new).unwrap(), b"one");
    match umask() {
        Some(u) => assert_eq!(mode(&new), 0o666 & !u, "a new file is created like any program's"),
        None => println!("SKIPPED the umask comparison: /proc/self/status has no Umask line"),
    }
    for m in [0o644, 0o755, 0o640, 0o600] {
        std::fs::set_permissions(&new, std::fs::Permissions::from_mode(m)).unwrap();
        put(&new, b"two", &WriteOptions::default()).unwrap();
        assert_eq!(mode(&new), m, "the replaced file's mode {m:o} is kept");
        assert_eq!(std::fs::read(&new).unwrap(), b"two");
    }
    assert_only(dir.path(), &["new.ply"]);
}

#[test]
fn a_symbolic_link_stays_a_link_and_its_target_is_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("real");
    std::fs::create_dir(&sub).unwrap();
    let target = sub.join("mesh.ply");
    std::fs::write(&target, b"old").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o644)).unwrap();
    let link = dir.path().join("link.ply");
    std::os::unix::fs::symlink("real/mesh.ply", &link).unwrap();
    // A link to a link.
    let link2 = dir.path().join("link2.ply");
    std::os::unix::fs::symlink("link.ply", &link2).unwrap();
    put(&link2, b"new", &WriteOptions::default()).unwrap();
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(std::fs::symlink_metadata(&link2).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), b"new");
    assert_eq!(mode(&target), 0o644);
    assert_only(dir.path(), &["link.ply", "link2.ply", "real"]);
    assert_only(&sub, &["mesh.ply"]);
    // A dangling link: its target is created.
    std::fs::remove_file(&target).unwrap();
    put(&link, b"again", &WriteOptions::default()).unwrap();
    assert_eq!(std::fs::read(&target).unwrap(), b"again");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
}

#[test]
fn a_fifo_is_written_into_and_stays_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.ply");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        println!("SKIPPED: mkfifo is not available");
        return;
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut v = Vec::new();
            std::fs::File::open(&fifo).unwrap().read_to_end(&mut v).unwrap();
            v
        })
    };
    let payload: Vec<u8> = (0..3_000_000u32).map(|i| (i % 251) as u8).collect();
    put(&fifo, &payload, &WriteOptions::no_clobber(true)).unwrap();
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(reader.join().unwrap(), payload);
    assert_only(dir.path(), &["pipe.ply"]);
}

#[test]
fn dev_null_is_written_into_not_replaced() {
    let null = Path::new("/dev/null");
    if !std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
        println!("SKIPPED: no /dev/null character device");
        return;
    }
    put(null, b"discarded", &WriteOptions::default()).unwrap();
    assert!(std::fs::metadata(null).unwrap().file_type().is_char_device());
}

#[test]
fn no_clobber_refuses_an_existing_file_and_a_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("a.obj");
    std::fs::write(&f, b"keep me").unwrap();
    let opts = WriteOptions::no_clobber(true);
    assert!(check_output(&f, &opts).is_err());
    let Err(WriteError::Io(e)) = put(&f, b"x", &opts) else { panic!("no-clobber must refuse") };
    assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
    assert_eq!(std::fs::read(&f).unwrap(), b"keep me");
    assert!(check_output(&dir.path().join("b.obj"), &opts).is_ok());
    assert!(check_output(&dir.path().join("missing/b.obj"), &WriteOptions::default()).is_err());
    let Err(WriteError::Io(e)) = put(dir.path(), b"x", &WriteOptions::default()) else { panic!("a folder") };
    assert!(e.to_string().contains("folder"), "{e}");
    assert_only(dir.path(), &["a.obj"]);
}

#[test]
fn a_failing_writer_leaves_the_target_and_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("a.obj");
    std::fs::write(&f, b"before").unwrap();
    let r = write_file(&f, &WriteOptions::default(), |w| {
        w.write_all(b"half")?;
        Err::<(), _>(std::io::Error::other("the encoder failed"))
    });
    assert!(matches!(r, Err(WriteError::Write(_))));
    assert_eq!(std::fs::read(&f).unwrap(), b"before");
    assert_only(dir.path(), &["a.obj"]);
}

#[test]
fn same_file_sees_through_symbolic_and_hard_links() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.ply");
    std::fs::write(&a, b"x").unwrap();
    let hard = dir.path().join("hard.ply");
    std::fs::hard_link(&a, &hard).unwrap();
    let soft = dir.path().join("soft.ply");
    std::os::unix::fs::symlink(&a, &soft).unwrap();
    let other = dir.path().join("b.ply");
    std::fs::write(&other, b"x").unwrap();
    assert!(same_file(&a, &hard));
    assert!(same_file(&soft, &a));
    assert!(same_file(&a, &dir.path().join(".").join("a.ply")));
    assert!(!same_file(&a, &other));
    assert!(!same_file(&a, &dir.path().join("missing.ply")));
}

#[test]
fn a_gz_path_is_written_compressed_and_any_other_as_is() {
    let dir = tempfile::tempdir().unwrap();
    let text = b"solid nothing\n".repeat(1000);
    let gz = dir.path().join("a.mrq.gz");
    octowrap_fsutil::write_file_gz(&gz, &WriteOptions::default(), |w| w.write_all(&text)).unwrap();
    let stored = std::fs::read(&gz).unwrap();
    assert_eq!(stored[..2], [0x1f, 0x8b], "a gzip member");
    assert!(stored.len() < text.len() / 10, "{} bytes", stored.len());
    let mut back = Vec::new();
    flate2::read::GzDecoder::new(&stored[..]).read_to_end(&mut back).unwrap();
    assert_eq!(back, text);
    let plain = dir.path().join("a.mrq");
    octowrap_fsutil::write_file_gz(&plain, &WriteOptions::default(), |w| w.write_all(&text)).unwrap();
    assert_eq!(std::fs::read(&plain).unwrap(), text);
    assert_eq!(octowrap_fsutil::without_gz(&gz), plain);
    assert_eq!(octowrap_fsutil::without_gz(&plain), plain);
    // A failing writer leaves nothing behind, compressed or not.
    let failed = octowrap_fsutil::write_file_gz(&dir.path().join("b.glb.gz"), &WriteOptions::default(), |w| {
        w.write_all(b"partial")?;
        Err(std::io::Error::other("stopped"))
    });
    assert!(matches!(failed, Err(WriteError::Write(_))));
    assert_only(dir.path(), &["a.mrq", "a.mrq.gz"]);
}
