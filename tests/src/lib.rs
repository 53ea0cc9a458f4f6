//! Helpers shared by octowrap's cross-crate tests: where the shared data and fixtures are, and
//! how to skip a case (saying so) when the shared data is absent.
#![allow(clippy::print_stderr)]

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ has a parent").to_path_buf()
}

/// `fixtures/` in the repository.
pub fn fixtures() -> PathBuf {
    repo_root().join("fixtures")
}

/// The shared real-data folder (`../shared/data` beside the checkout, or `$OCTOWRAP_DATA`),
/// if present.
pub fn shared_data() -> Option<PathBuf> {
    let dir = std::env::var_os("OCTOWRAP_DATA")
        .map_or_else(|| repo_root().join("..").join("shared").join("data"), PathBuf::from);
    dir.is_dir().then_some(dir)
}

/// A file under the shared data folder, or `None` (printing that the case is skipped and why)
/// when the shared data or the file is absent.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let Some(dir) = shared_data() else {
        eprintln!("SKIPPED: ../shared/data is absent, so the case needing {relative} did not run");
        return None;
    };
    let p = dir.join(relative);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("SKIPPED: {} is absent", p.display());
        None
    }
}
