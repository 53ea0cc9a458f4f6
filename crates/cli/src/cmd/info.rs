//! `octowrap info`: what a file holds.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use octowrap_mesh::Mesh;
use serde::Serialize;

use super::input::InputArgs;

/// Print counts, bounding box, attributes and face sizes of point clouds and meshes.
///
/// For an MRQ file, print its levels (vertices, faces, bytes and bits per vertex of each),
/// quantization, cube and metadata, read from the file's preamble alone.
///
/// Every file is described; one that cannot be read is named on standard error with the reason.
///
/// Exit codes: 0 every file described; 2 some file could not be read.
///
/// Examples:
///   octowrap info bunny.ply
///   octowrap info --json scans/*.laz
///   octowrap info bunny.mrq
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Files to describe (`-` for standard input).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Print one JSON object per file (a JSON array for several files) instead of text. A file
    /// that cannot be read is listed as `{"file": ..., "error": ...}`.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub input_args: InputArgs,
}

/// What `info` reports about one file.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The file as given.
    pub file: String,
    /// The detected or forced format.
    pub format: String,
    /// Number of points (vertices).
    pub points: usize,
    /// Number of faces.
    pub faces: usize,
    /// Sum of face sizes.
    pub corners: usize,
    /// Per-point attributes besides position.
    pub attributes: Vec<&'static str>,
    /// Smallest corner of the bounding box of the finite points (absent when there are none).
    pub bbox_min: Option<[f64; 3]>,
    /// Largest corner.
    pub bbox_max: Option<[f64; 3]>,
    /// Bounding-box diagonal.
    pub diagonal: f64,
    /// Points with a NaN or infinite coordinate.
    pub non_finite_points: usize,
    /// `[face size, count]` pairs.
    pub face_sizes: Vec<[usize; 2]>,
}

impl Report {
    /// Describes `mesh`, read from `file` as `format`.
    pub fn new(file: &Path, format: &str, mesh: &Mesh) -> Self {
        let b = mesh.vertices.bounds();
        let (bbox_min, bbox_max) =
            if b.is_empty() { (None, None) } else { (Some(b.min.to_array()), Some(b.max.to_array())) };
        Self {
            file: file.display().to_string(),
            format: format.to_owned(),
            points: mesh.vertex_count(),
            faces: mesh.faces.len(),
            corners: mesh.faces.corner_count(),
            attributes: mesh.vertices.attribute_names(),
            bbox_min,
            bbox_max,
            diagonal: b.diagonal(),
            non_finite_points: mesh.vertices.non_finite_count(),
            face_sizes: mesh.faces.size_histogram().into_iter().map(|(s, c)| [s, c]).collect(),
        }
    }

    fn write_text(&self, w: &mut dyn Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.file)?;
        writeln!(w, "  format      {}", self.format)?;
        writeln!(w, "  points      {}", self.points)?;
        writeln!(w, "  faces       {}", self.faces)?;
        if !self.attributes.is_empty() {
            writeln!(w, "  attributes  {}", self.attributes.join(", "))?;
        }
        if let (Some(lo), Some(hi)) = (self.bbox_min, self.bbox_max) {
            let ([x0, y0, z0], [x1, y1, z1]) = (lo, hi);
            writeln!(w, "  bbox min    {x0:.6} {y0:.6} {z0:.6}")?;
            writeln!(w, "  bbox max    {x1:.6} {y1:.6} {z1:.6}")?;
            writeln!(w, "  diagonal    {:.6}", self.diagonal)?;
        }
        if self.non_finite_points > 0 {
            writeln!(w, "  non-finite  {} points", self.non_finite_points)?;
        }
        if !self.face_sizes.is_empty() {
            let h: Vec<String> = self.face_sizes.iter().map(|[s, c]| format!("{s}-gons: {c}")).collect();
            writeln!(w, "  face sizes  {}", h.join(", "))?;
        }
        Ok(())
    }
}

/// What `info` says about a file it could not read (JSON form).
#[derive(Debug, Serialize)]
struct Failure {
    file: String,
    error: String,
}

/// Describes one file: its report as JSON, and its text form.
fn describe(args: &Args, file: &Path) -> anyhow::Result<(serde_json::Value, String)> {
    let mut text = Vec::new();
    let value = if super::mrq::is_mrq(file) {
        let r = super::mrq::Report::new(file)?;
        r.write_text(&mut text)?;
        serde_json::to_value(r)?
    } else {
        let (format, mesh) = args.input_args.read_detected(file)?;
        let r = Report::new(file, format.name(), &mesh);
        r.write_text(&mut text)?;
        serde_json::to_value(r)?
    };
    Ok((value, String::from_utf8_lossy(&text).into_owned()))
}

/// Runs the command: every file is described, those that cannot be read are named on standard
/// error (and, with `--json`, listed with their error); the exit code is 2 when any failed.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    let mut reports = Vec::new();
    let mut failed = 0usize;
    for file in &args.files {
        match describe(args, file) {
            Ok((value, text)) => {
                if !args.json {
                    crate::out::stdout(|w| w.write_all(text.as_bytes()))?;
                }
                reports.push(value);
            }
            Err(e) => {
                failed += 1;
                let error = format!("{e:#}");
                let named = if error.contains(&*file.to_string_lossy()) {
                    error.clone()
                } else {
                    format!("{}: {error}", file.display())
                };
                say!("error: {named}");
                reports.push(serde_json::to_value(Failure { file: file.display().to_string(), error: named })?);
            }
        }
    }
    if args.json {
        let out = if reports.len() == 1 {
            serde_json::to_string_pretty(&reports[0])?
        } else {
            serde_json::to_string_pretty(&reports)?
        };
        crate::out::stdout(|w| writeln!(w, "{out}"))?;
    }
    if failed > 0 {
        if args.files.len() > 1 {
            say!("{failed} of {} files could not be read", args.files.len());
        }
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}
