//! `octowrap export`: an MRQ hierarchy or any mesh as glTF 2.0 (GLB, or .gltf + .bin).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::ValueEnum;
use octowrap_export::{ExportOptions, Levels};
use octowrap_mesh::Hierarchy;

use super::input::InputArgs;
use super::mrq;
use crate::out::ClobberArgs;
use crate::progress;

/// Export a hierarchy or mesh as glTF 2.0: one .glb file, or a .gltf file with a .bin beside it.
///
/// Quads are split along their shorter diagonal; normals are smooth (area-weighted) unless
/// --crease-angle splits them where faces meet at a sharper angle; vertex colours are kept. Each
/// level becomes its own mesh and node, named `level K`; the level's numbers (faces, quads,
/// geometric error) are in the mesh's extras, the input's metadata in the asset's extras.
///
/// --levels all writes every level of an MRQ file as a level-of-detail chain (MSFT_lod, finest
/// first, with MSFT_screencoverage switching hints derived from each level's mean edge length);
/// loaders without MSFT_lod show the finest level. Without it, the finest level (or --level K) is
/// written. Mesh inputs (PLY, OBJ, OFF, STL, ...) have one level.
///
/// --quantize stores positions as 16-bit integers with a node transform and normals as 8-bit
/// (KHR_mesh_quantization, then required); --meshopt compresses every buffer with meshoptimizer
/// (EXT_meshopt_compression, then required). The same input and options give the same bytes.
///
/// An output ending in .json writes an OGC 3D Tiles 1.1 tileset instead: that tileset.json and
/// one .glb per tile under tiles/ beside it (a tile is one level's faces in one octree cell;
/// refine REPLACE; each tile's geometric error the certified Hausdorff distance to the finest
/// level over its region; a flange of neighbouring faces against cracks). An MRQ file that
/// records a CRS (reconstruct keeps the one a LAS/LAZ/E57 input declares) is placed on the globe
/// (EPSG:4978); otherwise the tileset is in a local frame. --quantize and --meshopt apply to the
/// tiles. A mesh input becomes one tile. --implicit writes the octree levels as implicit tiling
/// (subtrees/ beside tileset.json; their geometric error halves per level from a root error chosen
/// to stay at or above every tile's measured one).
///
/// Exit codes: 0 written; 2 the input could not be read or exported (nothing is written then).
///
/// Examples:
///   octowrap export dragon.mrq -o dragon.glb --levels all --quantize
///   octowrap export dragon.mrq -o dragon-l6.glb --level 6 --meshopt --quantize
///   octowrap export part.stl -o part.gltf --crease-angle 30
///   octowrap export bunny.ply -o bunny.glb --no-colors
///   octowrap export autzen.mrq -o tiles/tileset.json --meshopt --quantize
///   octowrap export kitten.mrq -o kitten/tileset.json --tile-faces 1000 --implicit
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
#[allow(clippy::doc_markdown)] // the help text names glTF extensions, not Rust items
pub struct Args {
    /// Input: an MRQ file or any mesh (PLY, OBJ, OFF, STL, ...; `-` for standard input with --from).
    pub input: PathBuf,
    /// Output file: .glb (binary glTF; .glb.gz gzip-compressed), .gltf (JSON, with OUT's stem
    /// .bin beside it), or .json (a 3D Tiles tileset, its tiles in a tiles/ folder beside it).
    #[arg(long, short = 'o', value_name = "OUT")]
    pub output: PathBuf,
    /// Which levels of an MRQ file: `all` writes every level as an MSFT_lod chain; `finest` (the
    /// default) the finest only.
    #[arg(long, value_name = "WHICH", conflicts_with = "level")]
    pub levels: Option<WhichLevels>,
    /// Write level K of an MRQ file only (0 = coarsest).
    #[arg(long, short = 'l', value_name = "K")]
    pub level: Option<u32>,
    /// Store positions as i16 with a node transform and normals as i8 (KHR_mesh_quantization).
    #[arg(long)]
    pub quantize: bool,
    /// Compress the buffers with meshoptimizer (EXT_meshopt_compression).
    #[arg(long)]
    pub meshopt: bool,
    /// Split normals where faces meet at more than this angle, in degrees (0 to 180; default:
    /// smooth everywhere).
    #[arg(long, value_name = "DEGREES", value_parser = parse_crease)]
    pub crease_angle: Option<f64>,
    /// Leave vertex colours out.
    #[arg(long)]
    pub no_colors: bool,
    /// The projected error, in pixels of a 1080-pixel-high view, the level-switching hints allow
    /// (a positive number).
    #[arg(long, value_name = "PIXELS", default_value_t = 1.0, value_parser = parse_pixels)]
    pub screen_error: f64,
    /// Tilesets only: a level with more faces than N is cut into octree cells, one tile each
    /// (default 16384; a positive number).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub tile_faces: Option<u32>,
    /// Tilesets only: the tiles below the coarsest cut level as 3D Tiles 1.1 implicit tiling (an
    /// octree described by subtree files with availability bitstreams) instead of explicit JSON.
    #[arg(long)]
    pub implicit: bool,
    #[command(flatten)]
    pub input_args: InputArgs,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

fn parse_crease(s: &str) -> anyhow::Result<f64> {
    let v: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number of degrees"))?;
    if !(0.0..=180.0).contains(&v) {
        bail!("the crease angle must be 0 to 180 degrees, not {s}");
    }
    Ok(v)
}

fn parse_pixels(s: &str) -> anyhow::Result<f64> {
    let v: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number of pixels"))?;
    if !(v.is_finite() && v > 0.0) {
        bail!("the screen error must be a positive number of pixels, not {s}");
    }
    Ok(v)
}

/// `--levels` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
#[allow(clippy::doc_markdown)] // shown by --help
pub enum WhichLevels {
    /// Every level, chained with MSFT_lod.
    All,
    /// The finest level.
    Finest,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    if super::tileset::is_tileset(args) {
        return super::tileset::run(args);
    }
    if args.tile_faces.is_some() || args.implicit {
        bail!("--tile-faces and --implicit are tileset options: give an output ending in .json");
    }
    let gz = octowrap_fsutil::is_gz(&args.output);
    let container = octowrap_export::Container::from_path(&octowrap_fsutil::without_gz(&args.output));
    let Some(container) = container else {
        bail!(
            "cannot tell the glTF form of '{}': the output must end in .glb or .gltf (or .glb.gz, compressed)",
            args.output.display()
        );
    };
    if gz && container == octowrap_export::Container::Gltf {
        bail!(
            "'{}': a .gltf file names its .bin beside it, so it is not compressed: write a .glb.gz instead",
            args.output.display()
        );
    }
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    if container == octowrap_export::Container::Gltf {
        crate::out::check_output(&args.output.with_extension("bin"), &[&args.input], args.clobber)?;
    }
    let mut opts = ExportOptions::default();
    opts.levels = match (args.levels, args.level) {
        (Some(WhichLevels::All), _) => Levels::All,
        (_, Some(k)) => Levels::One(k as usize),
        _ => Levels::Finest,
    };
    opts.quantize = args.quantize;
    opts.meshopt = args.meshopt;
    opts.crease_angle_deg = args.crease_angle;
    opts.colors = !args.no_colors;
    opts.max_screen_error = args.screen_error / 1080.0;
    opts.no_clobber = args.clobber.no_clobber;
    let input_name = args.input.display().to_string();
    let source = args.input.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let h = if mrq::is_mrq(&args.input) {
        // Levels beyond the one asked for are not read.
        let file = mrq::read(&args.input, args.level)?;
        let m = &file.info.metadata;
        for (k, v) in [("units", &m.units), ("source", &m.source), ("generator", &m.generator)] {
            if !v.is_empty() {
                opts.metadata.push((k.to_owned(), v.clone()));
            }
        }
        opts.metadata.extend(m.entries.iter().cloned());
        opts.metadata.push(("levels".to_owned(), file.info.levels.len().to_string()));
        if let Levels::One(k) = opts.levels {
            if k < file.hierarchy.levels.len() {
                opts.levels = Levels::Finest; // the decoded prefix ends at level k
            }
        }
        file.hierarchy
    } else {
        if args.level.is_some_and(|k| k > 0) || args.levels == Some(WhichLevels::All) {
            say!("note: {input_name} is a single mesh: exporting it as one level");
        }
        if matches!(opts.levels, Levels::One(_)) {
            opts.levels = Levels::Finest;
        }
        let mesh = args.input_args.read_sound(&args.input)?;
        Hierarchy::single(mesh)
    };
    if !opts.metadata.iter().any(|(k, _)| k == "source") && !source.is_empty() {
        opts.metadata.push(("source".to_owned(), source));
    }
    let pb = progress::spinner(format!("exporting {}", args.output.display()));
    let written = if gz {
        write_glb_gz(&args.output, &h, &opts, args.clobber)
    } else {
        octowrap_export::write_path(&args.output, &h, &opts).map_err(anyhow::Error::from)
    };
    pb.finish_and_clear();
    let summary = written.with_context(|| format!("exporting {input_name}"))?;
    let triangles: usize = summary.levels.iter().map(|l| l.triangles).sum();
    let names: Vec<String> = summary.levels.iter().map(|l| l.level.to_string()).collect();
    say!(
        "wrote {}: level{} {}, {triangles} triangles, {} bytes{}",
        args.output.display(),
        if names.len() == 1 { "" } else { "s" },
        names.join(", "),
        summary.bytes,
        if summary.extensions_used.is_empty() {
            String::new()
        } else {
            format!(", extensions {}", summary.extensions_used.join(", "))
        }
    );
    Ok(ExitCode::SUCCESS)
}

/// Writes `h` as one gzip-compressed .glb file.
fn write_glb_gz(
    path: &Path,
    h: &Hierarchy,
    opts: &ExportOptions,
    clobber: crate::out::ClobberArgs,
) -> anyhow::Result<octowrap_export::Summary> {
    let (bytes, summary) = octowrap_export::to_glb(h, opts)?;
    octowrap_fsutil::write_file_gz(path, &clobber.write_options(), |w| w.write_all(&bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| e)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(summary)
}
