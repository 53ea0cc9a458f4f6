//! Command-line arguments (clap derive). Each subcommand's arguments live beside its code in
//! `cmd/`; this file only lists the subcommands.

use clap::{Parser, Subcommand};

use crate::cmd;

/// octowrap turns unorganized point clouds (laser scans, LiDAR) into multiresolution quad meshes,
/// and converts, inspects and validates point clouds and meshes.
///
/// Formats read: PLY, OBJ, OFF, STL, XYZ/PTS/PWN, PCD, LAS/LAZ (COPC), E57, OpenEXR, Stanford .conf
/// scan sets; any of them gzip-compressed. Formats written: PLY, OBJ, OFF, STL, XYZ.
#[derive(Debug, Parser)]
#[command(name = "octowrap", version, about, long_about, propagate_version = true, max_term_width = 100)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Convert a point cloud or mesh between formats.
    Convert(cmd::convert::Args),
    /// Print counts, bounds, properties and face sizes of point clouds and meshes.
    Info(cmd::info::Args),
    /// Write one level of an MRQ hierarchy as a mesh file.
    Extract(cmd::extract::Args),
    /// Check meshes for two-manifoldness, orientation, holes and defects (for CI pipelines).
    Validate(cmd::validate::Args),
}
