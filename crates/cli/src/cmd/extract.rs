//! `octowrap extract`: one level of an MRQ file as a mesh file.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use octowrap_io::{Format, WriteOptions};
use octowrap_mesh::{Aabb, DVec3};

use super::input::OutputFormatArgs;
use super::mrq;
use crate::out::ClobberArgs;

/// Write one level of an MRQ hierarchy as a mesh (PLY, OBJ, OFF, STL or XYZ).
///
/// Only the bytes up to the requested level are read, so extracting a coarse level of a large
/// file is fast. Every vertex lies within half a quantization step of the mesh that was encoded
/// (see `octowrap info FILE.mrq` for the step).
///
/// With --region, only the faces of the level with a vertex inside a box are extracted, and of a
/// chunked file (format version 5, the default) only the chunks whose boxes meet it are read,
/// with the chunks of coarser levels they refine. --stats prints how many bytes and range
/// requests that took.
///
/// Examples:
///   octowrap extract bunny.mrq --level 3 -o bunny-l3.ply
///   octowrap extract bunny.mrq -o finest.obj
///   octowrap extract dragon.mrq --level 5 --to off -o - | less
///   octowrap extract city.mrq --region 0,0,0,100,100,50 --stats -o block.ply
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
    /// Extract only the chunks meeting this box: XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX in the file's
    /// units (see `octowrap info FILE.mrq` for its extent).
    #[arg(long, value_name = "BOX", value_parser = parse_box, allow_hyphen_values = true)]
    pub region: Option<Aabb>,
    /// Print the bytes and range requests read, and the chunks decoded, on standard error.
    #[arg(long)]
    pub stats: bool,
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
    let mesh = if args.region.is_some() || args.stats {
        mrq::read_region(&args.input, args.level, args.region, args.stats)?
    } else {
        mrq::read_level(&args.input, args.level)?
    };
    let mut opts = WriteOptions::default();
    opts.format = Some(to);
    opts.ascii = args.output_format.ascii;
    opts.no_clobber = args.clobber.no_clobber;
    octowrap_io::write_path(&args.output, &mesh, &opts)?;
    Ok(ExitCode::SUCCESS)
}

/// Parses `XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX`.
fn parse_box(s: &str) -> anyhow::Result<Aabb> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().with_context(|| format!("'{x}' is not a number")))
        .collect::<anyhow::Result<_>>()?;
    let [x0, y0, z0, x1, y1, z1] = v[..] else {
        bail!("a region is six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX, not {}", v.len());
    };
    if !v.iter().all(|x| x.is_finite()) || x0 > x1 || y0 > y1 || z0 > z1 {
        bail!("the region's numbers must be finite, each minimum at most its maximum: {s}");
    }
    Ok(Aabb { min: DVec3::new(x0, y0, z0), max: DVec3::new(x1, y1, z1) })
}
