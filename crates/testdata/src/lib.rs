//! Where octowrap's tests find the shared real-data scans, and what a test does without them.
//!
//! The scans (the Stanford bunny and dragon, LAS, E57, PCD, EXR and defect meshes) are too large
//! for the repository; they live in a folder beside the checkout:
//!
//! * `OCTOWRAP_DATA`, if set, names the folder;
//! * otherwise it is `../shared/data` relative to the workspace root.
//!
//! A test asks for a file or folder under it with [`file`] or [`dir`]. When it is absent the
//! answer is `None` after a line starting with `SKIPPED` on stderr, so the test returns and
//! passes, saying so; with `OCTOWRAP_REQUIRE_DATA=1` (set by `.ci/run` when the data is present)
//! the same call panics naming the missing path, so a case cannot pass by not running.
//!
//! ```no_run
//! let Some(bunny) = octowrap_testdata::file("stanford-bunny/reconstruction/bun_zipper.ply") else {
//!     return;
//! };
//! assert!(bunny.is_file());
//! ```
#![deny(missing_docs)]
#![allow(clippy::print_stderr)] // the SKIPPED lines are this crate's purpose

use std::path::{Path, PathBuf};

/// The environment variable naming the data folder.
pub const DATA_VAR: &str = "OCTOWRAP_DATA";

/// The environment variable that turns every skip into a failure when set to `1`.
pub const REQUIRE_VAR: &str = "OCTOWRAP_REQUIRE_DATA";

/// The workspace root (the folder holding `crates/`, `fixtures/` and `spec/`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `fixtures/` in the repository (always present: it is part of the checkout).
pub fn fixtures() -> PathBuf {
    workspace_root().join("fixtures")
}

/// Whether a missing file is a failure (`OCTOWRAP_REQUIRE_DATA=1`).
pub fn required() -> bool {
    std::env::var_os(REQUIRE_VAR).is_some_and(|v| v == "1")
}

/// The data folder, `$OCTOWRAP_DATA` or `../shared/data` beside the workspace root, whether or
/// not it exists.
pub fn data_root() -> PathBuf {
    std::env::var_os(DATA_VAR).map_or_else(|| workspace_root().join("../shared/data"), PathBuf::from)
}

/// The file `relative` (a `/`-separated path under the data folder), or `None` after printing a
/// `SKIPPED` line naming it. Panics instead when [`required`].
pub fn file(relative: &str) -> Option<PathBuf> {
    present(relative, Path::is_file)
}

/// The folder `relative` under the data folder (`""` for the data folder itself), or `None` after
/// printing a `SKIPPED` line naming it. Panics instead when [`required`].
pub fn dir(relative: &str) -> Option<PathBuf> {
    present(relative, Path::is_dir)
}

/// Prints the `SKIPPED` line for a case that cannot run for want of `what` (a file, a tool), or
/// panics when [`required`]. For tests whose data is found some other way than [`file`] or [`dir`].
pub fn skip(what: &str) {
    assert!(!required(), "{REQUIRE_VAR}=1 but the case needs {what}, which is absent");
    eprintln!("SKIPPED: {what} is absent");
}

fn present(relative: &str, exists: fn(&Path) -> bool) -> Option<PathBuf> {
    let root = data_root();
    let path = if relative.is_empty() { root } else { root.join(relative) };
    if exists(&path) {
        Some(path)
    } else {
        skip(&path.display().to_string());
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workspace_root_holds_the_fixtures() {
        assert!(fixtures().join("points").is_dir());
        assert!(workspace_root().join("Cargo.toml").is_file());
    }

    #[test]
    fn a_missing_file_is_none_or_a_failure() {
        let missing = "no-such-folder/no-such-file.ply";
        if required() {
            assert!(std::panic::catch_unwind(|| file(missing)).is_err());
        } else {
            assert_eq!(file(missing), None);
        }
    }
}
