//! Input options shared by every subcommand that reads point clouds or meshes.

use std::path::Path;

use anyhow::{Context, bail};
use octowrap_io::{Format, PinholeCamera, ReadOptions};
use octowrap_mesh::Mesh;

use crate::progress;

/// How to read the input.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct InputArgs {
    /// Input format, when neither the content nor the extension tells it (for example on
    /// standard input): ply, obj, off, stl, xyz, pcd, las, e57, exr, conf.
    #[arg(long, value_name = "FORMAT", value_parser = parse_format)]
    pub from: Option<Format>,

    /// Pinhole camera for OpenEXR depth images, as `fx,fy,cx,cy` in pixels. Each pixel (u, v) with
    /// depth z becomes ((u + 0.5 - cx) z / fx, (v + 0.5 - cy) z / fy, z). Without it an EXR must
    /// hold XYZ positions in its R, G, B channels.
    #[arg(long, value_name = "FX,FY,CX,CY", value_parser = parse_camera)]
    pub camera: Option<PinholeCamera>,

    /// Keep records that hold no position (NaN pixels of organised PCD clouds, invalid E57
    /// records) as NaN points, so the point count equals the file's record count. By default they
    /// are dropped; `reconstruct` refuses NaN points.
    #[arg(long)]
    pub keep_invalid: bool,
}

impl InputArgs {
    /// The library options these arguments stand for, with `--max-memory` applied.
    pub fn read_options(&self) -> ReadOptions {
        let mut o = ReadOptions::default();
        o.format = self.from;
        o.camera = self.camera;
        o.keep_invalid = self.keep_invalid;
        crate::limits::read_options(o)
    }

    /// Reads `path` (`-` for standard input), with a spinner on a terminal.
    pub fn read(&self, path: &Path) -> anyhow::Result<Mesh> {
        Ok(self.read_detected(path)?.1)
    }

    /// Like [`InputArgs::read`], also telling which format was read.
    pub fn read_detected(&self, path: &Path) -> anyhow::Result<(Format, Mesh)> {
        crate::limits::check_input_size(path)?;
        let pb = progress::spinner(format!("reading {}", path.display()));
        let read = octowrap_io::read_path_detected(path, &self.read_options());
        pb.finish_and_clear();
        Ok(read?)
    }

    /// The CRS `path` declares (LAS/LAZ/COPC or E57 read as `format`); `None` for standard
    /// input and for formats without one.
    pub fn crs(path: &Path, format: Format) -> anyhow::Result<Option<octowrap_io::Crs>> {
        if path == Path::new("-") || !matches!(format, Format::Las | Format::E57) {
            return Ok(None);
        }
        let data = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        octowrap_io::read_crs(&data, format).with_context(|| format!("reading the CRS of {}", path.display()))
    }

    /// Reads `path` as a mesh that can be processed and written: every face index in range and
    /// every face of 3 or more corners. (The readers keep broken faces, so that `validate` can
    /// describe them; every other command refuses them here, naming the input.)
    pub fn read_sound(&self, path: &Path) -> anyhow::Result<Mesh> {
        let mesh = self.read(path)?;
        check_sound(path, &mesh)?;
        Ok(mesh)
    }
}

/// Refuses a mesh read from `path` whose faces are broken, naming the input file.
pub fn check_sound(path: &Path, mesh: &Mesh) -> anyhow::Result<()> {
    if let Err(e) = mesh.check_indices() {
        bail!("{}: broken input: {e} (`octowrap validate` describes every defect)", path.display());
    }
    Ok(())
}

/// How to write a mesh output: shared by every subcommand that writes one.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct OutputFormatArgs {
    /// Output format, when the output's extension does not say: ply, obj, off, stl, xyz.
    #[arg(long, value_name = "FORMAT", value_parser = parse_format)]
    pub to: Option<Format>,
    /// Write text instead of binary (PLY, STL).
    #[arg(long)]
    pub ascii: bool,
}

/// Parses a format name.
pub fn parse_format(s: &str) -> anyhow::Result<Format> {
    Format::from_extension(s).with_context(|| {
        let names: Vec<_> = Format::ALL.iter().map(|f| f.name()).collect();
        format!("unknown format '{s}'; known: {}", names.join(", "))
    })
}

fn parse_camera(s: &str) -> anyhow::Result<PinholeCamera> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>().with_context(|| format!("'{t}' is not a number")))
        .collect::<anyhow::Result<_>>()?;
    let [fx, fy, cx, cy] = v[..] else { bail!("expected four numbers fx,fy,cx,cy, found {}", v.len()) };
    if !(fx > 0.0 && fy > 0.0 && cx.is_finite() && cy.is_finite() && fx.is_finite() && fy.is_finite()) {
        bail!("focal lengths must be positive and all values finite");
    }
    Ok(PinholeCamera { fx, fy, cx, cy })
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn camera_parsing() {
        let c = parse_camera("500, 500,320,240").unwrap();
        assert_eq!(c.cx, 320.0);
        assert!(parse_camera("1,2,3").is_err());
        assert!(parse_camera("0,1,2,3").is_err());
        assert!(parse_format("PLY").is_ok());
        assert!(parse_format("docx").unwrap_err().to_string().contains("known: ply"));
    }
}
