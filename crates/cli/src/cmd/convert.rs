//! `octowrap convert`: read any supported input, write any writable format.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use octowrap_io::{Format, WriteOptions};

use super::input::{InputArgs, OutputFormatArgs, check_sound};
use super::mrq;
use crate::out::ClobberArgs;

/// Convert a point cloud or mesh between formats.
///
/// The input format is detected from the content (signature) and the extension; the output
/// format comes from OUTPUT's extension or `--to`. Use `-` for standard input or output.
/// An output ending in .gz is gzip-compressed. The output is written to a temporary file and
/// renamed into place, so a failed run leaves nothing half-written (a FIFO or device is written
/// into directly; a symbolic link keeps pointing at the file it names). The output may not be the
/// input.
///
/// Examples:
///   octowrap convert scan.laz scan.ply
///   octowrap convert dragon_vrip.ply.gz dragon.obj
///   octowrap convert --weld part.stl part.ply
///   gunzip -c cloud.xyz.gz | octowrap convert - --from xyz cloud.ply
///   octowrap convert depth.exr --camera 525,525,319.5,239.5 depth.ply
///   octowrap convert bunny.ply bunny.mrq                 (lossless one-level MRQ)
///   octowrap convert bunny.ply bunny.mrq --bits 14       (vertices within half a 2^-14 step)
///   octowrap convert bunny.mrq --level 4 bunny-l4.obj
///
/// MRQ (octowrap's multiresolution format, spec/FORMAT.md): a mesh written to OUTPUT.mrq becomes a
/// one-level file, stored exactly unless --bits or --step ask for quantization; an .mrq input
/// converts to a mesh as its finest level, or level --level K (see also `octowrap extract`).
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
#[allow(clippy::doc_markdown)] // the examples are shell lines shown by --help, not Rust names
pub struct Args {
    /// Input file (`-` for standard input).
    pub input: PathBuf,
    /// Output file (`-` for standard output, with `--to`).
    pub output: PathBuf,
    #[command(flatten)]
    pub output_format: OutputFormatArgs,
    /// Merge vertices whose positions are exactly equal before writing. STL stores every triangle
    /// corner on its own; welding turns such a triangle soup into an indexed mesh.
    #[arg(long)]
    pub weld: bool,
    /// MRQ input: the level to convert, 0 = coarsest (default: the finest).
    #[arg(long, value_name = "K")]
    pub level: Option<u32>,
    #[command(flatten)]
    pub mrq: mrq::MrqWriteArgs,
    #[command(flatten)]
    pub clobber: ClobberArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    let mrq_in = mrq::is_mrq(&args.input);
    if args.level.is_some() && !mrq_in {
        bail!("--level picks a level of an MRQ input; '{}' is a single mesh", args.input.display());
    }
    if args.output_format.to.is_none() && mrq::has_mrq_extension(&args.output) {
        if args.output_format.ascii {
            bail!("--ascii applies to PLY and STL output; MRQ is binary");
        }
        let h = if mrq_in {
            mrq::read(&args.input, None)?.hierarchy
        } else {
            octowrap_mesh::Hierarchy::single(args.input_args.read_sound(&args.input)?)
        };
        mrq::write(&args.output, &h, &args.mrq.options(true, &args.input), args.clobber)?;
        return Ok(ExitCode::SUCCESS);
    }
    args.mrq.refuse_unless_mrq(&args.output)?;
    let to = args.output_format.to.or_else(|| Format::from_path(&args.output));
    let Some(to) = to else {
        bail!("cannot tell the output format of '{}': give it an extension or --to", args.output.display());
    };
    if !to.writable() {
        bail!("octowrap reads {to} files but does not write them; writable: ply, obj, off, stl, xyz");
    }
    let mut mesh =
        if mrq_in { mrq::read_level(&args.input, args.level)? } else { args.input_args.read_sound(&args.input)? };
    check_sound(&args.input, &mesh)?;
    if args.weld {
        let merged = mesh.weld_exact();
        say!("welded {merged} vertices with equal positions; {} remain", mesh.vertex_count());
    }
    if !mesh.faces.is_empty() && !to.holds_faces() {
        say!(
            "note: {to} holds points only: writing the {} vertices, dropping the {} faces",
            mesh.vertex_count(),
            mesh.faces.len()
        );
    }
    let mut opts = WriteOptions::default();
    opts.format = Some(to);
    opts.ascii = args.output_format.ascii;
    opts.no_clobber = args.clobber.no_clobber;
    octowrap_io::write_path(&args.output, &mesh, &opts)?;
    Ok(ExitCode::SUCCESS)
}
