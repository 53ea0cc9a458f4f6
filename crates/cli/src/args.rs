//! Command-line arguments (clap derive). Each subcommand's arguments live beside its code in
//! `cmd/`; this file only lists the subcommands.

use clap::{Parser, Subcommand};

use crate::cmd;

/// octowrap turns unorganized point clouds (laser scans, LiDAR) into multiresolution quad meshes,
/// and converts, inspects and validates point clouds and meshes.
///
/// Formats read: PLY, OBJ, OFF, STL, XYZ/PTS/PWN, PCD, LAS/LAZ (COPC), E57, OpenEXR, Stanford .conf
/// scan sets; any of them gzip-compressed. Formats written: PLY, OBJ, OFF, STL, XYZ. MRQ, octowrap's
/// multiresolution file (spec/FORMAT.md), is read and written by every command that takes meshes.
#[derive(Debug, Parser)]
#[command(name = "octowrap", version, about, long_about, propagate_version = true, max_term_width = 100)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
    /// Most memory one input may make the command allocate, as bytes or with a suffix (512M, 8G,
    /// 1T). Inputs larger than this, or declaring more than this, are refused before they are
    /// read: the readers and the MRQ decoder check it before allocating. The resident memory can
    /// pass it for a moment, up to about twice it, while a growing buffer is copied (the old copy,
    /// and pages the allocator has not yet returned).
    #[arg(long, global = true, value_name = "SIZE", default_value = crate::limits::DEFAULT_MAX_MEMORY,
          value_parser = crate::limits::parse_size)]
    pub max_memory: u64,
    /// Most scans one Stanford `.conf` set may list (each `bmesh` line is a scan read in full, so
    /// a short file naming one scan thousands of times would read it thousands of times).
    #[arg(long, global = true, value_name = "N", default_value_t = octowrap_io::Limits::DEFAULT_MAX_SCANS,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_scans: u64,
}

/// The subcommands. Each one's help is the doc comment of its `Args` in `cmd/` (a doc comment
/// here would replace it).
#[derive(Debug, Subcommand)]
pub enum Command {
    Reconstruct(cmd::reconstruct::Args),
    Convert(cmd::convert::Args),
    Info(cmd::info::Args),
    Extract(cmd::extract::Args),
    Validate(cmd::validate::Args),
    Decimate(cmd::decimate::Args),
    Export(cmd::export::Args),
    View(cmd::view::Args),
    Tile(cmd::tile::Args),
}
