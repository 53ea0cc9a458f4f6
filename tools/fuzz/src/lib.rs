//! What every reader target shares: the entry point the CLI uses, under a 256 MiB memory ceiling.
#![forbid(unsafe_code)]

use std::path::Path;

use octowrap_io::{Format, Mesh, ReadOptions, check_extent, read_from};

/// The memory ceiling inside the targets (libFuzzer's `-rss_limit_mb=512` catches a reader that
/// allocates past it).
pub const CEILING: u64 = 256 << 20;

/// Read options for a target: the format forced, the ceiling set, NaN records kept (they reach
/// more code).
pub fn options(format: Option<Format>) -> ReadOptions {
    let mut o = ReadOptions::default();
    o.format = format;
    o.limits.max_memory = Some(CEILING);
    o.keep_invalid = true;
    o
}

/// Reads `data` as `format` through [`read_from`] (gzip is taken when the bytes start with its
/// signature) and checks what every successful read promises.
pub fn read_as(data: &[u8], format: Format, name: &str) -> Option<Mesh> {
    let (got, mesh) = read_from(data, Path::new(name), &options(Some(format))).ok()?;
    assert_eq!(got, format);
    holds(&mesh);
    Some(mesh)
}

/// The properties of a mesh a reader returns: parallel attribute arrays, a finite extent.
pub fn holds(mesh: &Mesh) {
    assert!(mesh.vertices.attributes_consistent(), "attribute arrays of unequal length");
    check_extent(mesh).expect("a read mesh has a finite extent");
}
