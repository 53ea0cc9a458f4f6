//! `octowrap validate`: two-manifold checks for CI.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::ValueEnum;
use octowrap_io::Format as MeshFormat;
use octowrap_validate::{
    FileResult, Format, Outcome, Requirement, ValidateOptions, validate_hierarchy, validate_mesh, write_report,
};
use rayon::prelude::*;

use super::input::InputArgs;

/// Check meshes for two-manifoldness, orientation, holes and defects.
///
/// Every file (or every mesh file under a directory) is read as a raw indexed face list, so broken
/// meshes are described rather than rejected. An MRQ file is decoded whole (every checksum, and
/// every level's derivation from its parent, is checked on the way), then every level gets the
/// mesh checks and the parent links are checked. A human summary goes to standard error; `--format`
/// writes a machine report (JSON, JUnit XML or SARIF 2.1.0) to standard output.
///
/// Definitions (they differ between tools; these are octowrap's):
///   edge           two vertices that follow each other in a face; its sides are the faces using it
///   boundary edge  an edge with one side; a boundary loop is a connected set of them (a hole)
///   manifold       every index valid, faces of 3+ vertices, every edge 1 or 2 sides, and the faces
///                  around every vertex form one fan (boundaries allowed)
///   oriented       manifold, and no directed edge a->b used by two faces
///   closed         no boundary edges
///   watertight     manifold and closed (ask for `oriented` too if winding matters)
///   clean          finite coordinates; no repeated-index, zero-area or duplicate faces
///   intersection-free  no two faces share a point beyond their common edge or vertex
///                  (checked with --self-intersections; exact predicates)
///
/// Issue codes are stable: E-INDEX-RANGE, E-FACE-SIZE, E-NONFINITE-VERTEX, E-NONMANIFOLD-EDGE,
/// E-NONMANIFOLD-VERTEX, E-ORIENTATION, W-DEGENERATE-FACE, W-ZERO-AREA-FACE, W-DUPLICATE-FACE,
/// W-DUPLICATE-VERTEX, W-UNUSED-VERTEX, I-BOUNDARY-EDGE, E-SELF-INTERSECTION.
///
/// A file holding no faces (an empty mesh, a point cloud, bytes no reader recognises as faces)
/// meets no required property: there is nothing to check.
///
/// Exit codes: 0 every file meets every required property; 1 a required property fails;
/// 2 a file could not be read.
///
/// Examples:
///   octowrap validate part.stl
///   octowrap validate --require watertight,oriented meshes/
///   octowrap validate --format junit models/ > validate.xml
///   octowrap validate --format sarif scan.ply > validate.sarif
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Mesh files (PLY, OBJ, OFF, STL, MRQ) or directories to search for them.
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    /// Properties that must hold, comma-separated: manifold, oriented, closed, watertight, clean,
    /// intersection-free.
    #[arg(long, value_delimiter = ',', default_value = "manifold", value_name = "PROPERTY,...", value_parser = requirement_parser())]
    pub require: Vec<Requirement>,
    /// Machine-readable report on standard output.
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<ReportFormat>,
    /// Merge vertices with exactly equal positions before checking: `auto` does it for STL only
    /// (STL stores every triangle corner separately).
    #[arg(long, default_value = "auto", value_name = "WHEN")]
    pub weld: Weld,
    /// Also look for faces that cross or overlap each other (exact predicates: coplanar and
    /// touching faces give no false positives; slower than the other checks).
    #[arg(long)]
    pub self_intersections: bool,
    /// Most offending elements listed per finding (counts are always complete).
    #[arg(long, default_value_t = 100, value_name = "N")]
    pub max_elements: usize,
    /// Print only the summary line on standard error.
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub input_args: InputArgs,
}

/// Parses `--require` values by the library's own names (manifold, oriented, ...).
fn requirement_parser() -> impl clap::builder::TypedValueParser<Value = Requirement> {
    use clap::builder::TypedValueParser;
    let names: Vec<&'static str> = Requirement::ALL.iter().map(|r| r.name()).collect();
    clap::builder::PossibleValuesParser::new(names)
        .map(|s| Requirement::from_name(&s).expect("the parser only accepts known names"))
}

/// `--format` values.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ReportFormat {
    /// JSON document with every count and finding.
    Json,
    /// JUnit XML (one test case per file).
    Junit,
    /// SARIF 2.1.0 (one result per finding).
    Sarif,
    /// The human summary, on standard output.
    Text,
}

/// `--weld` values.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Weld {
    /// STL files only.
    Auto,
    /// Every file.
    Always,
    /// No file.
    Never,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    let files = collect(&args.paths)?;
    let required = &args.require;
    let results: Vec<FileResult> = files
        .par_iter()
        .map(|path| {
            let name = path.display().to_string();
            let mut o = ValidateOptions::default();
            o.max_elements = args.max_elements;
            o.self_intersections = args.self_intersections || required.contains(&Requirement::IntersectionFree);
            if super::mrq::is_mrq(path) {
                // Decoding checks every level's checksum and that each level derives from its
                // parent as the spec says; then every level gets the mesh checks.
                let read = crate::limits::check_input_size(path)
                    .and_then(|()| Ok(super::mrq::decode_file(path, &crate::limits::decode_options(None))?));
                let outcome = match read {
                    Ok(file) => Outcome::Hierarchy(validate_hierarchy(&file.hierarchy, &o)),
                    Err(e) => Outcome::Unreadable { error: format!("{name}: {e:#}") },
                };
                return judge(name, outcome, required);
            }
            // A name that is not UTF-8 gives no extension to the readers: say it.
            let mut input_args = args.input_args.clone();
            if path.to_str().is_none() && input_args.from.is_none() {
                input_args.from = MeshFormat::from_path(Path::new(&*path.to_string_lossy()));
            }
            let outcome = match input_args.read_detected(path) {
                Err(e) => Outcome::Unreadable { error: format!("{e:#}") },
                Ok((format, mesh)) => {
                    o.weld = match args.weld {
                        Weld::Always => true,
                        Weld::Never => false,
                        Weld::Auto => format == MeshFormat::Stl,
                    };
                    Outcome::Mesh(validate_mesh(&mesh, &o))
                }
            };
            judge(name, outcome, required)
        })
        .collect();
    for r in &results {
        if faceless(&r.outcome) {
            say!("note: {} holds no faces: it meets no required property", r.file);
        }
    }

    let stderr = std::io::stderr();
    let mut err = stderr.lock();
    if args.quiet {
        let passed = results.iter().filter(|r| r.passed()).count();
        writeln!(err, "{} files, {passed} passed", results.len())?;
    } else if !matches!(args.format, Some(ReportFormat::Text)) {
        write_report(&mut err, Format::Text, &results)?;
    }
    if let Some(f) = args.format {
        let format = match f {
            ReportFormat::Json => Format::Json,
            ReportFormat::Junit => Format::Junit,
            ReportFormat::Sarif => Format::Sarif,
            ReportFormat::Text => Format::Text,
        };
        crate::out::stdout(|w| write_report(w, format, &results))?;
    }
    Ok(if results.iter().any(|r| matches!(r.outcome, Outcome::Unreadable { .. })) {
        ExitCode::from(2)
    } else if results.iter().all(FileResult::passed) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Whether a readable file holds no faces (in some level, for a hierarchy).
fn faceless(outcome: &Outcome) -> bool {
    match outcome {
        Outcome::Mesh(r) => r.faces == 0,
        Outcome::Hierarchy(h) => h.levels.is_empty() || h.levels.iter().any(|l| l.faces == 0),
        Outcome::Unreadable { .. } => false,
    }
}

/// Judges `outcome` against `required`; a file without faces fails every requirement.
fn judge(name: String, outcome: Outcome, required: &[Requirement]) -> FileResult {
    let mut r = FileResult::new(name, outcome, required);
    if faceless(&r.outcome) {
        r.failed_requirements = required.to_vec();
    }
    r
}

/// The files named, with directories searched (recursively, sorted) for mesh files.
fn collect(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found = Vec::new();
            walk(p, &mut found).with_context(|| format!("cannot list {}", p.display()))?;
            found.sort();
            if found.is_empty() {
                anyhow::bail!("{} holds no mesh files (ply, obj, off, stl, mrq)", p.display());
            }
            out.extend(found);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Adds the mesh files under `dir`, recognised by extension. A name that is not valid UTF-8 is
/// judged by its extension all the same (and shown with replacement characters).
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            walk(&path, out)?;
            continue;
        }
        let shown = PathBuf::from(path.to_string_lossy().into_owned());
        if MeshFormat::from_path(&shown).is_some_and(MeshFormat::holds_faces) || super::mrq::has_mrq_extension(&shown) {
            out.push(path);
        }
    }
    Ok(())
}
