//! `octowrap tile`: tiled reconstruction of scenes larger than one machine (plan, split, merge;
//! the per-tile reconstruction is `octowrap reconstruct --plan --tile`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Subcommand;
use octowrap_io::WriteOptions;
use octowrap_recon::ReconOptions;
use octowrap_tile::{Plan, PlanOptions, merge, own, split};

use crate::out::ClobberArgs;

/// Tiled reconstruction for scenes larger than one machine: plan tiles over one global cube,
/// split the points into tiles with halos, reconstruct each tile on its own (`octowrap
/// reconstruct TILE-POINTS --plan plan.json --tile ID -o tiles/ID.mrq`), merge one level of the
/// whole scene.
///
/// Every tile uses the same global octree lattice (the cube the untiled run would use), and a
/// face of the finest level belongs to the one tile whose cell contains its voxel, so the tiles'
/// faces never overlap; the merge welds vertices that two tiles computed at the same lattice
/// corner and position.
///
/// Example (4 tiles of about 30,000 points):
///   octowrap tile plan scan.laz -o plan.json --points-per-tile 30000
///   octowrap tile split plan.json scan.laz -o parts/
///   octowrap tile split plan.json --merge --tile 0 -o parts/
///   octowrap reconstruct parts/tile-0.pts --plan plan.json --tile 0 -o tiles/0.mrq
///   octowrap tile merge plan.json tiles/ -o merged.ply
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The step.
    #[command(subcommand)]
    pub step: Step,
}

/// The steps of a tiled run.
#[derive(Debug, Subcommand)]
pub enum Step {
    /// Plan the tiles: reads LAS/LAZ headers for the bounds (other formats are read in full),
    /// then every input once to count points per cell; writes the plan as JSON.
    Plan(PlanArgs),
    /// Bin one input's points into per-tile parts (own cell plus halo), or with --merge join a
    /// tile's parts into DIR/tile-ID.pts.
    Split(SplitArgs),
    /// Merge one level of every tile's DIR/ID.mrq into one mesh.
    Merge(MergeArgs),
}

/// `tile plan`.
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// The point clouds of the scene.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The plan file to write.
    #[arg(long, short = 'o')]
    pub output: PathBuf,
    /// Most points a tile's cell holds before it splits into its eight children.
    #[arg(long, value_name = "N", default_value_t = PlanOptions::default().points_per_tile,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub points_per_tile: u64,
    /// The finest level (default: the deepest the density of all inputs supports).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=i64::from(octowrap_recon::DEEPEST_LEVEL)))]
    pub level: Option<u32>,
    /// Halo width in voxels of the finest level.
    #[arg(long, value_name = "N", default_value_t = octowrap_tile::DEFAULT_HALO_VOXELS)]
    pub halo_voxels: u32,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

/// `tile split`.
#[derive(Debug, clap::Args)]
pub struct SplitArgs {
    /// The plan.
    pub plan: PathBuf,
    /// The input to split (one of the plan's inputs); not with --merge.
    #[arg(required_unless_present = "merge", conflicts_with = "merge")]
    pub input: Option<PathBuf>,
    /// Join the parts of --tile in the output folder into DIR/tile-ID.pts.
    #[arg(long, requires = "tile")]
    pub merge: bool,
    /// The tile to merge.
    #[arg(long, value_name = "ID")]
    pub tile: Option<u32>,
    /// The parts folder (created when missing).
    #[arg(long, short = 'o', value_name = "DIR")]
    pub output: PathBuf,
}

/// `tile merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The plan.
    pub plan: PathBuf,
    /// The folder of the tiles' ID.mrq files.
    pub tiles: PathBuf,
    /// The level to merge (default: the plan's finest). Coarser levels are cut by the same
    /// ownership rule, but each tile computed them from its own points only.
    #[arg(long, value_name = "K")]
    pub level: Option<u32>,
    /// The mesh to write (.ply, .obj, .off, .stl).
    #[arg(long, short = 'o')]
    pub output: PathBuf,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    match &args.step {
        Step::Plan(a) => plan(a),
        Step::Split(a) => split(a),
        Step::Merge(a) => merge(a),
    }
}

fn plan(a: &PlanArgs) -> anyhow::Result<ExitCode> {
    let inputs: Vec<&Path> = a.inputs.iter().map(PathBuf::as_path).collect();
    crate::out::check_output(&a.output, &inputs, a.clobber)?;
    let mut opts = PlanOptions::default();
    opts.points_per_tile = a.points_per_tile;
    opts.level = a.level;
    opts.halo_voxels = a.halo_voxels;
    let plan = octowrap_tile::plan::build(&a.inputs, &opts)?;
    plan.save(&a.output, &a.clobber.write_options())?;
    let points: u64 = plan.inputs.iter().map(|i| i.points).sum();
    say!(
        "{} tiles over {points} points, level {}, voxel {:.4}, halo {:.4} ({} voxels)",
        plan.tiles.len(),
        plan.level,
        plan.voxel_edge(),
        plan.halo(),
        plan.halo_voxels
    );
    Ok(ExitCode::SUCCESS)
}

fn split(a: &SplitArgs) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(&a.plan)?;
    let opts = octowrap_fsutil::WriteOptions::default();
    if a.merge {
        let id = a.tile.context("--merge needs --tile")?;
        let n = split::merge_parts(&plan, id, &a.output, &opts)?;
        say!("tile {id}: {n} points in {}", split::tile_path(&a.output, id).display());
        return Ok(ExitCode::SUCCESS);
    }
    let input = a.input.as_ref().context("an input to split")?;
    let Some(i) = plan.inputs.iter().position(|p| p.path == *input || octowrap_fsutil::same_file(&p.path, input))
    else {
        bail!("{} is not one of the plan's inputs", input.display());
    };
    let counts = split::split_input(&plan, i, &a.output, &opts)?;
    say!("{}: {} points into {} tiles (halos included)", input.display(), counts.iter().sum::<usize>(), counts.len());
    Ok(ExitCode::SUCCESS)
}

fn merge(a: &MergeArgs) -> anyhow::Result<ExitCode> {
    crate::out::check_output(&a.output, &[], a.clobber)?;
    let plan = Plan::load(&a.plan)?;
    let k = a.level.unwrap_or(plan.level);
    if let Some(t) = plan.tiles.iter().find(|t| t.depth > k) {
        bail!("--level {k} is coarser than tile {} (depth {}): a face of level {k} has no single owner", t.id, t.depth);
    }
    if k > plan.level {
        bail!("--level {k} is past the plan's finest level {}", plan.level);
    }
    let mut levels = Vec::with_capacity(plan.tiles.len());
    for t in &plan.tiles {
        let path = a.tiles.join(format!("{}.mrq", t.id));
        let file = super::mrq::read(&path, Some(k))?;
        let Some(level) = file.hierarchy.levels.get(k as usize) else {
            bail!("{} has no level {k}", path.display());
        };
        levels.push(own::keep_owned(&plan, t, k, level).with_context(|| format!("tile {}", t.id))?);
    }
    let (level, rep) = merge::merge(&levels)?;
    say!(
        "level {k}: {} faces, {} vertices; {} welded across tiles, {} border vertices apart (positions differ), {} faces on a slot of another tile",
        rep.faces,
        rep.vertices,
        rep.welded,
        rep.unwelded,
        rep.duplicate_slots
    );
    let mut w = WriteOptions::default();
    w.no_clobber = a.clobber.no_clobber;
    octowrap_io::write_path(&a.output, &level.mesh, &w)?;
    Ok(ExitCode::SUCCESS)
}

/// `octowrap reconstruct INPUT --plan --tile`: the tile's points (INPUT, a `tile split --merge`
/// output) reconstructed on the plan's lattice, the finest level cut to the faces the tile owns.
/// Vertices keep their reconstructed positions (no line placement: it depends on the tile's
/// coarse levels, which differ between tiles, and would move border vertices apart).
pub fn reconstruct(
    input: &Path,
    plan: &Path,
    tile: u32,
    opts: &ReconOptions,
) -> anyhow::Result<octowrap_mesh::Hierarchy> {
    let plan = Plan::load(plan)?;
    let points = octowrap_tile::points::read(input)?;
    Ok(own::reconstruct_tile(&plan, tile, &points, opts)?)
}
