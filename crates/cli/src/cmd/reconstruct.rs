//! `octowrap reconstruct`: a point cloud to a multiresolution quad mesh.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use octowrap_format::Quantization;
use octowrap_io::{Format, WriteOptions};
use octowrap_recon::{
    AUTO_CAP, AutoChoice, AutoStop, DEEPEST_LEVEL, DecoderGrid, LevelKind, MaxLevel, ReconOptions, Reconstruction,
    SparseMode, Stage,
};

use super::input::{InputArgs, OutputFormatArgs};
use super::mrq;
use crate::out::ClobberArgs;
use crate::progress;

/// Reconstruct a surface from a point cloud: a two-manifold quad mesh at every octree level.
///
/// The points' bounding cube is split level by level (an octree); at every level a quad mesh is
/// wrapped around the occupied cells, refined from the level above (each face has a parent face
/// and quadrant, or was created), and its vertices are moved onto planes fitted to the nearby
/// points. Open scans stay open (holes become boundary loops); closed objects come out closed.
/// Then the vertices of every level up to --fit-max-faces faces are fitted to the points by
/// least squares (--fit-passes, 3 by default; 0 keeps the paper's planes alone): the faces, not
/// only their corners, come close to the points (on the Stanford bunny the coarse levels' error
/// falls 1.5-3x).
///
/// The finest level by default (--max-level auto) starts from the deepest level the sampling
/// density supports, the last where the median cell holds at least 8 points, and goes on past
/// it by subdivision, mapping the new vertices onto the points and fitting them, while each
/// level brings the mesh at least 1.5x closer to the points (RMS distance; a level that does
/// not is dropped) and before the mesh outgrows the data: no level with more than 3 faces per
/// input point or 400,000 faces, at most 3 levels past the supported one (--auto-min-gain,
/// --auto-faces-per-point, --auto-max-faces).
/// The chosen level and the reason are printed on standard error. A number (--level N or
/// --max-level N) builds exactly that many levels, subdividing past the supported one.
/// --region-levels N goes up to N levels past that limit where some region is still dense: the
/// dense regions are wrapped, the sparse ones subdivided inside the same mesh (crack-free), so
/// unevenly sampled scans get finer where their points allow (slower: the wrapped levels cost
/// several times a subdivided one).
///
/// Output: PLY or OBJ (or OFF, STL) get one level, the finest or --level K; an .mrq file gets the
/// whole hierarchy with its parent links. An .mrq file quantizes positions on a grid tied to the
/// octree cube whose step is a 64th of the finest level's voxel (2^(K+6) steps across the cube
/// for finest level K), so that quantization adds at most about 1 % to any level's distance to
/// the points; --bits or --step set another grid. For .mrq output the reconstruction computes
/// every level as the MRQ decoder will see it: each refined vertex that lies within 0.3 voxel of
/// the line the decoder predicts it on (from the decoded level above) goes onto that line and
/// costs one number (the fit's last passes move it along the line only, the free vertices
/// around it in space), and every vertex lies on the grid, so the file decodes to exactly
/// the levels reconstructed (and --all-levels writes the same positions). With --step (a grid
/// not tied to the cube) the vertices slide onto their lines after the reconstruction instead.
/// --keep-positions leaves every vertex free (each decoded within half a grid step).
/// --all-levels DIR also writes DIR/level-K.ply for every level K from 0 (the root cube), with the
/// positions the .mrq output holds.
///
/// Examples:
///   octowrap reconstruct bunny.ply -o bunny-mesh.ply
///   octowrap reconstruct dragon.ply.gz -o dragon-mesh.ply --level 7 --timings
///   octowrap reconstruct scan.laz -o scan.mrq --max-level auto
///   octowrap reconstruct kitten.xyz -o kitten.obj --relax-passes 0 --all-levels kitten-levels/
///   octowrap reconstruct cloud.ply -o cloud.ply --threads 1
///   octowrap reconstruct rabbit.ply -o rabbit.ply --region-levels 2 --region-density 2.75
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Input point cloud (any readable format; a mesh's vertices are used as points; `-` for
    /// standard input with --from).
    pub input: PathBuf,
    /// Output file: .ply, .obj, .off, .stl for one level, .mrq for the hierarchy; a name ending in
    /// .gz (x.mrq.gz, x.ply.gz) is gzip-compressed.
    #[arg(long, short = 'o', value_name = "OUT")]
    pub output: PathBuf,
    /// Finest level to build, 1 to 20. Levels past the density limit are subdivided (or wrapped
    /// with --wrap-sparse).
    #[arg(long, short = 'l', value_name = "N", conflicts_with = "max_level",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(DEEPEST_LEVEL)))]
    pub level: Option<u32>,
    /// Finest level: `auto` (past the deepest level the sampling density supports while the
    /// error keeps falling, see above) or a number, 1 to 20.
    #[arg(long, value_name = "auto|N", default_value = "auto", value_parser = parse_max_level)]
    pub max_level: MaxLevel,
    /// --max-level auto keeps a subdivided level only when it is at least this many times closer
    /// to the points than its parent (RMS; 1 or more).
    #[arg(long, value_name = "X", default_value_t = ReconOptions::default().auto_min_gain, value_parser = parse_gain)]
    pub auto_min_gain: f64,
    /// --max-level auto builds no level with more faces than this many per input point.
    #[arg(long, value_name = "X", default_value_t = ReconOptions::default().auto_faces_per_point, value_parser = parse_density)]
    pub auto_faces_per_point: f64,
    /// --max-level auto builds no level with more faces than this.
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().auto_max_faces)]
    pub auto_max_faces: usize,
    /// Repair intersecting faces on every level with at most N faces: the corners of each
    /// intersecting pair move towards their neighbours' centroid until no pair is left, keeping
    /// the connectivity. Off (0) by default: it clears the bunny's levels but smooths detail
    /// away on some scans (Lucy's finest level: 3x the points-to-mesh RMS). Try 250000.
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().untangle_max_faces)]
    pub untangle_max_faces: usize,
    /// Write this level to a PLY/OBJ/OFF/STL output instead of the finest (0 = the root cube; at
    /// most the finest level asked for). An .mrq output holds every level.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=i64::from(DEEPEST_LEVEL)))]
    pub write_level: Option<u32>,
    /// Relaxation passes per level (Laplacian smoothing, then re-projection onto the points).
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().relax_passes)]
    pub relax_passes: u32,
    /// The coarsest level relaxed (relaxation shrinks coarse meshes).
    #[arg(long, value_name = "K", default_value_t = ReconOptions::default().relax_from_level)]
    pub relax_from_level: u32,
    /// Passes of the least-squares fit of the vertices to the points (0: off, the paper's
    /// tangent-plane mapping alone).
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().fit_passes)]
    pub fit_passes: u32,
    /// The fit runs on levels with at most this many faces (it costs about as much as wrapping a
    /// level; finer levels already lie close to the points).
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().fit_max_faces)]
    pub fit_max_faces: usize,
    /// Median points per cell below which a level's topology is not trusted (a positive number).
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().min_median_points, value_parser = parse_min_points)]
    pub min_points: f64,
    /// Wrap levels past the density limit instead of subdividing (they fragment where sparse).
    #[arg(long)]
    pub wrap_sparse: bool,
    /// Levels past the density limit wrapped where some region is dense, the sparse regions
    /// subdivided inside the same mesh (0: off).
    #[arg(long, value_name = "N", default_value_t = ReconOptions::default().region_levels, conflicts_with = "wrap_sparse")]
    pub region_levels: u32,
    /// With --region-levels: a cell is sparse when its 3x3x3 block holds fewer than this many
    /// points per occupied child cell.
    #[arg(long, value_name = "TAU", default_value_t = ReconOptions::default().region_density, value_parser = parse_density)]
    pub region_density: f64,
    /// Worker threads, 1 or more (default: all cores). The output is the same for any number.
    #[arg(long, short = 'j', value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub threads: Option<u16>,
    /// Also write DIR/level-K.ply for every level K (DIR is created when missing).
    #[arg(long, value_name = "DIR")]
    pub all_levels: Option<PathBuf>,
    /// Print the per-level, per-stage time table (like the paper's Table 2) on standard error; with
    /// .mrq output also what the line placement did (vertices placed, kept, moves refused).
    #[arg(long)]
    pub timings: bool,
    #[command(flatten)]
    pub output_format: OutputFormatArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    #[command(flatten)]
    pub mrq: mrq::MrqWriteArgs,
    /// MRQ output: keep the reconstructed positions (each decoded vertex within half a grid
    /// step) instead of placing vertices on their prediction lines.
    #[arg(long)]
    pub keep_positions: bool,
    /// Reconstruct one tile of a tiled run (`octowrap tile`): INPUT is the tile's points
    /// (`tile split --merge`), the lattice and finest level are the plan's, and the finest level
    /// keeps the faces the tile owns. Implies --keep-positions.
    #[arg(long, value_name = "PLAN", requires = "tile")]
    pub plan: Option<PathBuf>,
    /// With --plan: the tile's id.
    #[arg(long, value_name = "ID", requires = "plan")]
    pub tile: Option<u32>,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

fn parse_min_points(s: &str) -> anyhow::Result<f64> {
    let v: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number"))?;
    if !(v.is_finite() && v > 0.0) {
        bail!("the median points per cell must be a positive number, not {s}");
    }
    Ok(v)
}

fn parse_density(s: &str) -> anyhow::Result<f64> {
    let tau: f64 = s.parse().with_context(|| format!("'{s}' is not a number"))?;
    if !(tau.is_finite() && tau > 0.0) {
        bail!("the region density must be a positive number of points per cell, not {s}");
    }
    Ok(tau)
}

fn parse_gain(s: &str) -> anyhow::Result<f64> {
    let v: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number"))?;
    if !(v.is_finite() && v >= 1.0) {
        bail!("the least gain per level must be a number of at least 1, not {s}");
    }
    Ok(v)
}

fn parse_max_level(s: &str) -> anyhow::Result<MaxLevel> {
    if s.eq_ignore_ascii_case("auto") {
        return Ok(MaxLevel::Auto);
    }
    let n: u32 = s.parse().with_context(|| format!("'{s}' is neither `auto` nor a level number"))?;
    if n == 0 || n > DEEPEST_LEVEL {
        bail!("the finest level must be 1 to {DEEPEST_LEVEL}, not {n}");
    }
    Ok(MaxLevel::Level(n))
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    let is_mrq = args.output_format.to.is_none() && mrq::has_mrq_extension(&args.output);
    let to = if is_mrq { None } else { args.output_format.to.or_else(|| Format::from_path(&args.output)) };
    check_options(args, is_mrq, to)?;
    let mut opts = recon_options(args);
    if let (Some(plan), Some(tile)) = (&args.plan, args.tile) {
        let h = super::tile::reconstruct(&args.input, plan, tile, &opts)?;
        return write_tile(args, &h, is_mrq, to);
    }
    // MRQ output on a grid tied to the cube: every refined vertex computed on its decoder line.
    let on_lines = is_mrq && !args.keep_positions && args.mrq.step.is_none() && !args.mrq.exact;
    if on_lines {
        opts.decoder_lines = Some(args.mrq.bits.map_or(DecoderGrid::Finest, DecoderGrid::Bits));
    }
    let (format, mesh) = args.input_args.read_detected(&args.input)?;
    let crs = InputArgs::crs(&args.input, format)?;
    let points = mesh.vertices.positions;
    let mut r = reconstruct_in_pool(&points, &opts, args.threads)
        .with_context(|| format!("reconstructing {}", args.input.display()))?;
    if let Some(a) = &r.auto {
        say!("{}", auto_message(a, points.len(), &opts));
    }
    let mut mrq_opts = args.mrq.options(false, &args.input);
    if let Some(crs) = &crs {
        mrq_opts.metadata.entries.push((octowrap_format::CRS_KEY.to_owned(), crs.to_text()));
    }
    if let Some(grid) = r.line_grid {
        mrq_opts.quantization = grid.quantization();
    } else if args.mrq.bits.is_none() && args.mrq.step.is_none() && !args.mrq.exact {
        mrq_opts.quantization =
            Quantization::Bits(octowrap_format::reconstruction_grid_bits(r.hierarchy.levels.len() - 1));
    }
    let placement = if is_mrq && !args.keep_positions && !on_lines {
        let t = std::time::Instant::now();
        let p = octowrap_format::place_on_prediction_lines(&mut r.hierarchy, &mrq_opts)
            .context("placing vertices on their prediction lines")?;
        Some((p, t.elapsed().as_secs_f64()))
    } else {
        None
    };
    if args.timings {
        print_timings(&r, on_lines, placement);
    }
    write_outputs(args, &r.hierarchy, &mrq_opts, is_mrq, to)?;
    Ok(ExitCode::SUCCESS)
}

/// The reconstruction's options from the command line's.
fn recon_options(args: &Args) -> ReconOptions {
    let mut opts = ReconOptions::default();
    opts.max_level = args.level.map_or(args.max_level, MaxLevel::Level);
    opts.relax_passes = args.relax_passes;
    opts.relax_from_level = args.relax_from_level;
    opts.min_median_points = args.min_points;
    opts.fit_passes = args.fit_passes;
    opts.fit_max_faces = args.fit_max_faces;
    opts.region_levels = args.region_levels;
    opts.region_density = args.region_density;
    opts.auto_min_gain = args.auto_min_gain;
    opts.auto_faces_per_point = args.auto_faces_per_point;
    opts.auto_max_faces = args.auto_max_faces;
    opts.untangle_max_faces = args.untangle_max_faces;
    if args.wrap_sparse {
        opts.sparse = SparseMode::Wrap;
    }
    opts
}

/// Reconstructs `points` on `threads` threads (all cores when `None`), with a progress bar.
fn reconstruct_in_pool(
    points: &[octowrap_geom::DVec3],
    opts: &ReconOptions,
    threads: Option<u16>,
) -> anyhow::Result<octowrap_recon::Reconstruction> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads.map_or(0, usize::from)).build()?;
    let bar = progress::bar(1, "partitioning");
    let result = pool.install(|| {
        octowrap_recon::reconstruct_with_progress(points, opts, &mut |p| {
            let stage = match p.stage {
                Stage::Partitioning => "partitioning",
                Stage::Regular => "regular refinement",
                Stage::Irregular => "irregular refinement",
                Stage::Mapping => "vertex mapping",
                Stage::Relaxation => "relaxation",
            };
            bar.set_length(u64::from(p.levels.max(1)) * 4);
            let step = match p.stage {
                Stage::Partitioning => 0,
                Stage::Regular | Stage::Irregular => 1,
                Stage::Mapping => 2,
                Stage::Relaxation => 3,
            };
            bar.set_position(u64::from(p.level.saturating_sub(1)) * 4 + step);
            bar.set_message(format!("level {}: {stage}", p.level));
        })
    });
    bar.finish_and_clear();
    Ok(result?)
}

/// Writes the hierarchy: every level with `--all-levels`, then the MRQ file or the chosen level.
fn write_outputs(
    args: &Args,
    h: &octowrap_mesh::Hierarchy,
    mrq_opts: &octowrap_format::EncodeOptions,
    is_mrq: bool,
    to: Option<Format>,
) -> anyhow::Result<()> {
    if let Some(dir) = &args.all_levels {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for (k, level) in h.levels.iter().enumerate() {
            let path = dir.join(format!("level-{k}.ply"));
            let mut w = WriteOptions::default();
            w.no_clobber = args.clobber.no_clobber;
            octowrap_io::write_path(&path, &level.mesh, &w)?;
        }
    }
    if is_mrq {
        mrq::write(&args.output, h, mrq_opts, args.clobber)?;
    } else {
        let k = args.write_level.map_or(h.levels.len() - 1, |k| k as usize);
        let Some(level) = h.levels.get(k) else {
            bail!("--write-level {k}: the hierarchy has levels 0 to {}", h.levels.len() - 1);
        };
        let mut w = WriteOptions::default();
        w.format = to;
        w.ascii = args.output_format.ascii;
        w.no_clobber = args.clobber.no_clobber;
        octowrap_io::write_path(&args.output, &level.mesh, &w)?;
    }
    Ok(())
}

/// Writes a tile's hierarchy (see `tile::reconstruct`): positions as reconstructed.
fn write_tile(args: &Args, h: &octowrap_mesh::Hierarchy, is_mrq: bool, to: Option<Format>) -> anyhow::Result<ExitCode> {
    if is_mrq {
        let mut o = args.mrq.options(false, &args.input);
        if args.mrq.bits.is_none() && args.mrq.step.is_none() && !args.mrq.exact {
            o.quantization = Quantization::Bits(octowrap_format::reconstruction_grid_bits(h.levels.len() - 1));
        }
        mrq::write(&args.output, h, &o, args.clobber)?;
    } else {
        let k = args.write_level.map_or(h.levels.len() - 1, |k| k as usize);
        let Some(level) = h.levels.get(k) else { bail!("--write-level {k}: no such level") };
        let mut w = WriteOptions::default();
        w.format = to;
        w.no_clobber = args.clobber.no_clobber;
        octowrap_io::write_path(&args.output, &level.mesh, &w)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The --timings report: the stage table, then what the MRQ lines or the placement did.
fn print_timings(r: &Reconstruction, on_lines: bool, placement: Option<(octowrap_format::LinePlacement, f64)>) {
    say!("{}", timing_table(r).trim_end());
    if on_lines {
        let on: usize = r.levels.iter().map(|l| l.on_lines).sum();
        let all: usize = r.levels.iter().map(|l| l.vertices).sum();
        let per: Vec<String> = r.levels.iter().map(|l| format!("{}/{}", l.on_lines, l.vertices)).collect();
        say!(
            "MRQ decoder lines: {on} of {all} vertices computed as one scalar on their line (per level {})",
            per.join(" ")
        );
    }
    if let Some((p, secs)) = placement {
        say!(
            "MRQ line placement {secs:.4} s: {} vertices on their prediction lines, {} kept where they were \
             ({} of them because the move would fold a face or meet another vertex), {} without a line; \
             largest move {:.3e}, RMS {:.3e}",
            p.placed,
            p.kept,
            p.reverted,
            p.without_line,
            p.max_move,
            p.rms_move
        );
    }
}

/// Refuses, before any work, options that cannot be honoured or would be ignored.
fn check_options(args: &Args, is_mrq: bool, to: Option<Format>) -> anyhow::Result<()> {
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    if is_mrq {
        if let Some(k) = args.write_level {
            bail!("--write-level {k} picks the level of a single-mesh output; an .mrq output holds every level");
        }
        if args.output_format.ascii {
            bail!("--ascii applies to PLY and STL output; MRQ is binary");
        }
    } else {
        let Some(to) = to else {
            bail!("cannot tell the output format of '{}': give it an extension or --to", args.output.display());
        };
        if !to.writable() || !to.holds_faces() {
            bail!("{to} cannot hold a mesh; write .ply, .obj, .off, .stl or .mrq");
        }
        args.mrq.refuse_unless_mrq(&args.output)?;
        if args.keep_positions {
            bail!("--keep-positions applies to .mrq output; '{}' is not MRQ", args.output.display());
        }
    }
    let finest = match args.level.map_or(args.max_level, MaxLevel::Level) {
        MaxLevel::Level(n) => n,
        MaxLevel::Auto => AUTO_CAP.saturating_add(args.region_levels).min(DEEPEST_LEVEL),
    };
    if let Some(k) = args.write_level.filter(|&k| k > finest) {
        bail!(
            "--write-level {k} is past the finest level built ({finest}): ask for --level {k} or a lower --write-level"
        );
    }
    if let Some(dir) = &args.all_levels {
        if dir.exists() && !dir.is_dir() {
            bail!("--all-levels {}: not a folder", dir.display());
        }
    }
    Ok(())
}

/// The line saying which level --max-level auto chose and why.
fn auto_message(a: &AutoChoice, points: usize, opts: &ReconOptions) -> String {
    let why = match a.stop {
        AutoStop::SmallGain { level, gain } => format!(
            "level {level} was only {gain:.2}x closer to the points than level {} (at least {}x is worth its 4x faces)",
            level - 1,
            opts.auto_min_gain
        ),
        AutoStop::TooManyFaces { next_faces, limit } => format!(
            "level {} would have {next_faces} faces, more than {limit} ({} per input point, {points} points; \
             at most {})",
            a.level + 1,
            opts.auto_faces_per_point,
            opts.auto_max_faces
        ),
        AutoStop::Deepest => "it is the deepest level auto builds".to_owned(),
    };
    let steps: Vec<String> = a.errors.iter().map(|(j, e)| format!("L{j} {e:.3e}")).collect();
    format!(
        "finest level {} (auto: the density supports level {}; points-to-mesh RMS {}): {why}",
        a.level,
        a.trusted,
        steps.join(", ")
    )
}

/// The per-level, per-stage table (seconds), like the paper's Table 2.
fn timing_table(r: &Reconstruction) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>5} {:>10} {:>9} {:>9} {:>13} {:>8} {:>10} {:>10} {:>10} {:>9} {:>9}",
        "level",
        "kind",
        "faces",
        "vertices",
        "partitioning",
        "regular",
        "irregular",
        "mapping",
        "relaxation",
        "total",
        "median"
    );
    for l in &r.levels {
        let t = &l.timings;
        let kind = match l.kind {
            LevelKind::Root => "root",
            LevelKind::Wrapped => "wrapped",
            LevelKind::Subdivided => "subdivided",
        };
        let _ = writeln!(
            s,
            "{:>5} {:>10} {:>9} {:>9} {:>13.4} {:>8.4} {:>10.4} {:>10.4} {:>10.4} {:>9.4} {:>9}",
            l.level,
            kind,
            l.faces,
            l.vertices,
            t.partitioning.as_secs_f64(),
            t.regular.as_secs_f64(),
            t.irregular.as_secs_f64(),
            t.mapping.as_secs_f64(),
            t.relaxation.as_secs_f64(),
            t.total().as_secs_f64(),
            l.median_points
        );
    }
    let total: f64 = r.levels.iter().map(|l| l.timings.total().as_secs_f64()).sum();
    let _ = writeln!(s, "total {total:.4} s; topology trusted to level {}", r.trusted_level);
    s
}
