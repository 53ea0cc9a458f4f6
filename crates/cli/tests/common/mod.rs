//! Helpers shared by the command-line tests: run the binary, find the fixtures.
#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `octowrap` with `args` (no standard input) from the current directory.
pub fn octowrap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octowrap")).args(args).stdin(Stdio::null()).output().expect("runs")
}

/// Runs `octowrap` from the repository root, so that file names in reports are relative and stable.
pub fn octowrap_in_root(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octowrap"))
        .args(args)
        .current_dir(root())
        .stdin(Stdio::null())
        .output()
        .expect("runs")
}

/// The shipped kitten point cloud.
pub fn kitten() -> PathBuf {
    root().join("fixtures/points/kitten.xyz")
}

/// Output bytes as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}
