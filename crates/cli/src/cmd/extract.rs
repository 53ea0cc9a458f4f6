//! `octowrap extract`: one level of an MRQ file as a mesh file.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use octowrap_io::{Format, WriteOptions};

use super::input::OutputFormatArgs;
use super::mrq;
use crate::out::ClobberArgs;

/// Write one level of an MRQ hierarchy as a mesh (PLY, OBJ, OFF, STL or XYZ).
///
/// Only the bytes up to the requested level are read, so extracting a coarse level of a large
/// file is fast. Every vertex lies within half a quantization step of the mesh that was encoded
/// (see `octowrap info FILE.mrq` for the step).
///
/// Examples:
///   octowrap extract bunny.mrq --level 3 -o bunny-l3.ply
///   octowrap extract bunny.mrq -o finest.obj
///   octowrap extract dragon.mrq --level 5 --to off -o - | less
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The MRQ file (`-` for standard input).
    pub input: PathBuf,
    /// Level to extract, 0 = coarsest (default: the finest).
    #[arg(long, short = 'l', value_name = "K")]
    pub level: Option<u32>,
    /// Output mesh file (`-` for standard output, with `--to`).
    #[arg(long, short = 'o', value_name = "OUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub output_format: OutputFormatArgs,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    let Some(to) = args.output_format.to.or_else(|| Format::from_path(&args.output)) else {
        bail!("cannot tell the output format of '{}': give it an extension or --to", args.output.display());
    };
    if !to.writable() {
        bail!("octowrap reads {to} files but does not write them; writable: ply, obj, off, stl, xyz");
    }
    let mesh = mrq::read_level(&args.input, args.level)?;
    let mut opts = WriteOptions::default();
    opts.format = Some(to);
    opts.ascii = args.output_format.ascii;
    opts.no_clobber = args.clobber.no_clobber;
    octowrap_io::write_path(&args.output, &mesh, &opts)?;
    Ok(ExitCode::SUCCESS)
}
