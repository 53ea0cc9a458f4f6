//! `octowrap export IN -o DIR/tileset.json`: a hierarchy or mesh as an OGC 3D Tiles 1.1 tileset.

use std::process::ExitCode;

use anyhow::{Context, bail};
use octowrap_mesh::Hierarchy;
use octowrap_tiles::{Frame, TilesOptions};

use super::export::Args;
use super::mrq;
use crate::progress;

/// Whether `export` writes a tileset: the output ends in `.json`.
pub fn is_tileset(args: &Args) -> bool {
    args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Runs the tileset export.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    if args.levels.is_some() || args.level.is_some() || args.crease_angle.is_some() {
        bail!("--levels, --level and --crease-angle are glTF options: a tileset holds every level, smooth");
    }
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    let mut opts = TilesOptions::default();
    opts.quantize = args.quantize;
    opts.meshopt = args.meshopt;
    opts.colors = !args.no_colors;
    opts.no_clobber = args.clobber.no_clobber;
    opts.implicit = args.implicit;
    if let Some(n) = args.tile_faces {
        let mut p = octowrap_tiles::OctreePartition::default();
        p.target_faces = n as usize;
        opts.partition = p;
    }
    let input_name = args.input.display().to_string();
    let (h, frame) = if mrq::is_mrq(&args.input) {
        let file = mrq::read(&args.input, None)?;
        let m = &file.info.metadata;
        for (k, v) in [("units", &m.units), ("source", &m.source), ("generator", &m.generator)] {
            if !v.is_empty() {
                opts.metadata.push((k.to_owned(), v.clone()));
            }
        }
        let crs = m.entries.iter().find(|(k, _)| k == octowrap_format::CRS_KEY).map(|(_, v)| v.clone());
        (file.hierarchy, crs.map_or(Frame::Local, Frame::Crs))
    } else {
        (Hierarchy::single(args.input_args.read_sound(&args.input)?), Frame::Local)
    };
    let pb = progress::spinner(format!("writing tiles of {}", args.output.display()));
    let written = octowrap_tiles::write_tileset(&args.output, h, &frame, &opts);
    pb.finish_and_clear();
    let s = written.with_context(|| format!("exporting {input_name} as 3D Tiles"))?;
    say!(
        "wrote {}: {} tiles ({} with content) over {} levels, {} bytes, root error {:.6}; frame {}",
        args.output.display(),
        s.tiles,
        s.content_tiles,
        s.levels,
        s.bytes,
        s.root_error,
        s.frame
    );
    Ok(ExitCode::SUCCESS)
}
