//! `octowrap decimate`: error-bounded decimation of any mesh, and adaptive cuts through MRQ
//! hierarchies.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use octowrap_decimate::metrics::{Sampling, distance};
use octowrap_decimate::{Camera, CutCriterion, DecimateOptions, ErrorBound, QuadMode};
use octowrap_io::{Format, WriteOptions};
use octowrap_mesh::{Hierarchy, Mesh};
use serde::Serialize;

use super::input::{InputArgs, OutputFormatArgs};
use super::mrq;
use crate::out::ClobberArgs;
use crate::progress;

/// Decimate a mesh to a face budget or an error budget, or cut an MRQ hierarchy adaptively.
///
/// Any mesh (PLY, OBJ, OFF, STL, MRQ; triangles, quads or polygons) is decimated by quadric-error
/// edge collapse. The output is never less manifold than the input: no new non-manifold edges or
/// vertices, no flipped faces; non-manifold spots of the input are left exactly as they are.
/// Boundaries are preserved (--lock-border keeps boundary vertices fixed). Quad-dominant input is
/// decimated on its triangulation and re-paired into quads where two triangles make a convex,
/// nearly flat quad (--quads).
///
/// The error printed, and what each figure costs:
///   by default         the quadric error of the costliest collapse: an area-weighted RMS
///                      distance to the input planes a vertex stands for, an estimate 2 to 5
///                      times below the Hausdorff distance; free (the collapse computes it)
///   --measure          also the symmetric Hausdorff distance between input and output,
///                      certified: an upper bound that no point of either surface exceeds,
///                      between sample points included, within 1 % of the largest distance
///                      found (both printed, in the input's units and as a percentage of the
///                      bounding-box diagonal); and the sampled RMS and Hausdorff distances.
///                      On a scanned mesh the certified search (a subdivision of every triangle
///                      not settled at once) takes about twice as long as the decimation, the
///                      sampling about as long as the decimation: the Stanford dragon to 10 %
///                      takes about 3x as long end to end with --measure as without
///   --max-error E      always measures the certified distance (it is what enforces the bound),
///                      once per collapse run
///
/// Targets (at least one; with several, decimation stops at whichever comes first):
///   --target-faces N   at most N output faces, counted as written: a quad is one face, and so
///                      is each triangle (quad output re-runs until the count is met)
///   --ratio R          at most R times the input's faces (0 < R <= 1)
///   --max-error E      the output's Hausdorff distance to the input (the certified figure
///                      above) is at most E: a length in the input's units, or a percentage of
///                      the bounding-box diagonal (`0.1%`). Regions found over E keep their input
///                      resolution and decimation runs again (a few runs); E = 0 returns the
///                      input unchanged
///
/// MRQ input with --max-error or --view: a hierarchy cut instead. Each region of the surface uses
/// the coarsest level whose distance to the finest level (the certified Hausdorff distance between
/// the region's finest faces and the face standing for them) is at most E (or, with --view, the
/// screen-space error in pixels allowed by the camera); the regions are stitched through the finest
/// level's vertices, so the result is crack-free and two-manifold wherever the finest level is.
/// The largest such region distance is reported; the cut's distance to the finest level is at
/// most that. On a chunked file (format version 5) the cut is made of whole chunks instead: the
/// index's geometric errors choose them (with --view, every chunk is kept, those out of view at
/// the level where they leave it, viewport taken as 16:9), only they and their ancestors are read,
/// and the crack rule of spec §11.5 stitches them (it refines a chunk where two levels do not fit);
/// the bytes read are reported. --cut faces asks for the face-level cut, which reads the whole
/// file and is finer-grained.
///
/// Camera JSON for --view (the schema):
///   { "position": [x, y, z],          eye, world units
///     "target": [x, y, z],            point looked at
///     "up": [0, 0, 1],                up direction (optional, default +Z)
///     "fov_y_degrees": 60,            vertical field of view, (0, 180)
///     "viewport_height_px": 1080,     viewport height in pixels
///     "pixel_error": 1.0 }            largest screen-space error, pixels
/// A region at distance d from the eye may be coarse when its error is at most
/// pixel_error * 2 d tan(fov_y / 2) / viewport_height_px.
///
/// The output is written to a temporary file and renamed into place. A summary goes to standard
/// error; --json prints the report on standard output (so not with `-o -`, which puts the mesh
/// there).
///
/// Exit codes: 0 done; 2 the command could not run (unreadable input, bad arguments).
///
/// Examples:
///   octowrap decimate dragon_vrip.ply.gz -o dragon-1pc.ply --ratio 0.01
///   octowrap decimate scan.obj -o scan-small.obj --target-faces 20000 --lock-border
///   octowrap decimate part.stl -o part.ply --max-error 0.05%
///   octowrap decimate bunny.mrq -o bunny-cut.ply --max-error 0.0005
///   octowrap decimate bunny.mrq -o bunny-view.obj --view camera.json
///   octowrap decimate mesh.ply -o out.off --ratio 0.1 --measure --json > report.json
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
#[allow(clippy::doc_markdown)] // the examples are shell lines shown by --help, not Rust names
#[command(group(clap::ArgGroup::new("target").required(true).multiple(true)
    .args(["target_faces", "ratio", "max_error", "view"])))]
pub struct Args {
    /// Input mesh or MRQ file (`-` for standard input).
    pub input: PathBuf,
    /// Output file: ply, obj, off, stl, or mrq (a one-level file), gzip-compressed when the name
    /// ends in .gz; `-` for standard output with --to.
    #[arg(long, short = 'o', value_name = "OUT")]
    pub output: PathBuf,
    /// Target face count, 1 or more: faces as written (a quad is one face, a triangle another).
    #[arg(long, value_name = "N", value_parser = parse_faces)]
    pub target_faces: Option<usize>,
    /// Target face count as a fraction of the input's, in (0, 1].
    #[arg(long, value_name = "R", conflicts_with = "target_faces", value_parser = parse_ratio)]
    pub ratio: Option<f64>,
    /// Error bound on the output's certified Hausdorff distance to the input (cut: on each
    /// region's distance to the finest level): a length in the input's units, or a percentage of
    /// the bounding-box diagonal (`0.1%`).
    #[arg(long, value_name = "E", value_parser = parse_error)]
    pub max_error: Option<ErrorBound>,
    /// MRQ input: cut for this camera (JSON file; schema above) instead of a fixed error.
    #[arg(long, value_name = "CAMERA.json", conflicts_with_all = ["max_error", "target_faces", "ratio"])]
    pub view: Option<PathBuf>,
    /// MRQ input with --max-error or --view: how to cut. `chunks` selects whole chunks from a
    /// version 5 file's index by their geometric errors, reads only those and their ancestors,
    /// and stitches them crack-free (spec §11.5); `faces` decodes the whole hierarchy and cuts it
    /// face by face (finer-grained, so fewer faces for the same error, but it reads the whole
    /// file); `auto` is `chunks` for version 5 files, `faces` otherwise.
    #[arg(long, value_name = "HOW", default_value = "auto", value_parser = ["auto", "chunks", "faces"])]
    pub cut: String,
    /// Keep boundary vertices fixed (interior vertices may still collapse into them).
    #[arg(long)]
    pub lock_border: bool,
    /// Quad-dominant input: auto (re-pair into quads when half or more of the faces are quads),
    /// quads (always re-pair), triangles (never).
    #[arg(long, value_name = "MODE", default_value = "auto", value_parser = ["auto", "quads", "triangles"])]
    pub quads: String,
    /// Measure the error reached: the certified Hausdorff distance (about twice the decimation's
    /// time) and the sampled RMS and Hausdorff distances (200,000 area samples per mesh plus the
    /// vertices; about the decimation's time). Without it only the free quadric estimate is
    /// printed (and, with --max-error, the certified distance that enforces the bound).
    #[arg(long)]
    pub measure: bool,
    /// Print the report as JSON on standard output.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub output_format: OutputFormatArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    #[command(flatten)]
    pub clobber: ClobberArgs,
}

fn parse_faces(s: &str) -> anyhow::Result<usize> {
    let n: usize = s.trim().parse().with_context(|| format!("'{s}' is not a face count"))?;
    if n == 0 {
        bail!("the target must be 1 face or more (a mesh of 0 faces is no mesh)");
    }
    Ok(n)
}

fn parse_ratio(s: &str) -> anyhow::Result<f64> {
    let r: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number"))?;
    if !(r > 0.0 && r <= 1.0) {
        bail!("the ratio must be in (0, 1]");
    }
    Ok(r)
}

fn parse_error(s: &str) -> anyhow::Result<ErrorBound> {
    let s = s.trim();
    let (num, relative) = match s.strip_suffix('%') {
        Some(n) => (n, true),
        None => (s, false),
    };
    let v: f64 = num.trim().parse().with_context(|| format!("'{s}' is not a number (or a percentage like 0.1%)"))?;
    if !(v >= 0.0 && v.is_finite()) {
        bail!("the error bound must be zero or positive");
    }
    Ok(if relative { ErrorBound::Relative(v / 100.0) } else { ErrorBound::Absolute(v) })
}

/// The JSON report.
#[derive(Debug, Serialize)]
struct Report {
    input: String,
    output: String,
    mode: &'static str,
    input_faces: usize,
    output_faces: usize,
    output_vertices: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    decimate: Option<octowrap_decimate::DecimateReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cut: Option<octowrap_decimate::CutReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    chunk_cut: Option<octowrap_decimate::chunks::ChunkCutReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    measured: Option<octowrap_decimate::metrics::Distance>,
    seconds: f64,
}

/// Runs the command.
pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    crate::out::check_output(&args.output, &[&args.input], args.clobber)?;
    if args.json && args.output == Path::new("-") {
        bail!(
            "--json prints the report on standard output, where `-o -` writes the mesh: write the mesh to a file, or drop --json (the summary goes to standard error)"
        );
    }
    let mrq_out = args.output_format.to.is_none() && mrq::has_mrq_extension(&args.output);
    let to = args.output_format.to.or_else(|| Format::from_path(&args.output));
    if !mrq_out {
        let Some(to) = to else {
            bail!("cannot tell the output format of '{}': give it an extension or --to", args.output.display());
        };
        if !to.writable() || !to.holds_faces() {
            bail!("{to} cannot hold a decimated mesh; write ply, obj, off, stl or mrq");
        }
    }
    let mrq_in = mrq::is_mrq(&args.input);
    let cut = mrq_in
        && (args.view.is_some() || (args.max_error.is_some() && args.target_faces.is_none() && args.ratio.is_none()));
    if cut && (args.lock_border || args.quads != "auto") {
        let flag = if args.lock_border { "--lock-border" } else { "--quads" };
        bail!(
            "{flag} steers edge collapse, but '{}' with {} is cut through its levels, which keeps every \
             boundary and face kind of the hierarchy: drop {flag}, or add --target-faces or --ratio to decimate",
            args.input.display(),
            if args.view.is_some() { "--view" } else { "--max-error alone" }
        );
    }
    if args.view.is_some() && !mrq_in {
        bail!(
            "--view cuts an MRQ hierarchy; '{}' is not an MRQ file (use --ratio or --max-error)",
            args.input.display()
        );
    }
    let camera = match &args.view {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            Some(Camera::from_json(&text).with_context(|| format!("reading {}", path.display()))?)
        }
        None => None,
    };
    if cut && args.cut != "faces" {
        // A chunked cut seeks: not through standard input or gzip.
        let seekable = args.input != Path::new("-") && !octowrap_fsutil::is_gz(&args.input);
        let version = if seekable {
            let file = std::fs::File::open(&args.input).with_context(|| format!("opening {}", args.input.display()))?;
            octowrap_format::read_info(std::io::BufReader::new(file), &octowrap_format::Limits::default())
                .with_context(|| format!("reading {}", args.input.display()))?
                .version
        } else {
            0
        };
        if version >= 5 {
            return run_chunk_cut(args, camera.as_ref(), mrq_out, to);
        }
        if args.cut == "chunks" {
            let why = if seekable {
                format!("it is version {version}: rewrite it with `octowrap convert IN.mrq -o out.mrq`")
            } else {
                "a chunked cut reads parts of the file, which standard input and gzip cannot give".into()
            };
            bail!(
                "--cut chunks needs a plain chunked MRQ file (format version 5), and '{}' is not: {why}; or use --cut faces",
                args.input.display()
            );
        }
    } else if args.cut != "auto" && !cut {
        bail!("--cut chooses how an MRQ hierarchy is cut (with --max-error alone or --view); drop it");
    }
    let (input, hierarchy) = if mrq_in {
        let h = mrq::read(&args.input, None)?.hierarchy;
        let Some(finest) = h.levels.last() else { bail!("{} holds no levels", args.input.display()) };
        (finest.mesh.clone(), Some(h))
    } else {
        (args.input_args.read_sound(&args.input)?, None)
    };
    if input.faces.is_empty() {
        bail!("{} has no faces: decimation needs a mesh, not a point cloud", args.input.display());
    }
    let start = std::time::Instant::now();
    let (mesh, mut report) = if cut {
        let h = hierarchy.as_ref().context("hierarchy")?;
        run_cut(args, camera, h, &input)?
    } else {
        run_decimate(args, &input)?
    };
    report.seconds = start.elapsed().as_secs_f64();
    if args.measure {
        let pb = progress::spinner("measuring the distance to the input");
        let d = distance(&input, &mesh, &Sampling::default());
        pb.finish_and_clear();
        report.measured = Some(d);
    }
    write(args, mrq_out, to, &mesh)?;
    print_summary(&report, input.vertices.bounds().diagonal());
    if args.json {
        let json = serde_json::to_string_pretty(&report)?;
        crate::out::stdout(|w| writeln!(w, "{json}"))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn run_decimate(args: &Args, input: &Mesh) -> anyhow::Result<(Mesh, Report)> {
    let mut opts = DecimateOptions::default();
    opts.target_faces =
        args.target_faces.or_else(|| args.ratio.map(|r| ((input.faces.len() as f64 * r).round() as usize).max(1)));
    opts.max_error = args.max_error;
    opts.lock_border = args.lock_border;
    // The certified measurement costs about twice the decimation: on request only (--max-error
    // measures whatever this says).
    opts.measure = args.measure;
    opts.quads = match args.quads.as_str() {
        "quads" => QuadMode::Quads,
        "triangles" => QuadMode::Triangles,
        _ => QuadMode::Auto,
    };
    let pb = progress::spinner(format!("decimating {} faces", input.faces.len()));
    let out = octowrap_decimate::decimate_with_progress(input, &opts, &mut |live| {
        pb.set_message(format!("decimating: {live} triangles left"));
    });
    pb.finish_and_clear();
    let out = out.with_context(|| format!("decimating {}", args.input.display()))?;
    let report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        mode: "decimate",
        input_faces: input.faces.len(),
        output_faces: out.mesh.faces.len(),
        output_vertices: out.mesh.vertex_count(),
        decimate: Some(out.report),
        cut: None,
        chunk_cut: None,
        measured: None,
        seconds: 0.0,
    };
    Ok((out.mesh, report))
}

fn run_cut(args: &Args, camera: Option<Camera>, h: &Hierarchy, input: &Mesh) -> anyhow::Result<(Mesh, Report)> {
    let criterion = if let Some(camera) = camera {
        CutCriterion::View(camera)
    } else {
        let e = match args.max_error {
            Some(ErrorBound::Absolute(e)) => e,
            Some(ErrorBound::Relative(r)) => r * input.vertices.bounds().diagonal(),
            None => bail!("a hierarchy cut needs --max-error or --view"),
        };
        CutCriterion::MaxError(e)
    };
    let pb = progress::spinner(format!("cutting {} levels", h.levels.len()));
    let out = octowrap_decimate::cut(h, &criterion);
    pb.finish_and_clear();
    let out = out.with_context(|| format!("cutting {}", args.input.display()))?;
    let report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        mode: "cut",
        input_faces: input.faces.len(),
        output_faces: out.mesh.faces.len(),
        output_vertices: out.mesh.vertex_count(),
        decimate: None,
        cut: Some(out.report),
        chunk_cut: None,
        measured: None,
        seconds: 0.0,
    };
    Ok((out.mesh, report))
}

/// The chunked cut of a version 5 file: the index picks the chunks, only they and their
/// ancestors are read, and the crack rule stitches them ([`octowrap_decimate::chunks::cut_chunks`]).
fn run_chunk_cut(args: &Args, camera: Option<&Camera>, mrq_out: bool, to: Option<Format>) -> anyhow::Result<ExitCode> {
    use octowrap_decimate::chunks::{ChunkCriterion, cut_chunks};
    let file = std::fs::File::open(&args.input).with_context(|| format!("opening {}", args.input.display()))?;
    let file_bytes = file.metadata().map_or(0, |m| m.len());
    let source = octowrap_format::SeekSource(std::io::BufReader::new(file));
    let start = std::time::Instant::now();
    let mut reader = octowrap_format::ChunkedMrq::open(source, &octowrap_format::Limits::default())
        .with_context(|| format!("reading {}", args.input.display()))?;
    let criterion = match (camera, args.max_error) {
        (Some(c), _) => ChunkCriterion::View(*c),
        (None, Some(e)) => ChunkCriterion::MaxError(e),
        (None, None) => bail!("a hierarchy cut needs --max-error or --view"),
    };
    let pb = progress::spinner(format!("cutting through the chunks of {}", args.input.display()));
    let cut = cut_chunks(&mut reader, &criterion, file_bytes);
    pb.finish_and_clear();
    let cut = cut.with_context(|| format!("cutting {}", args.input.display()))?;
    let mut report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        mode: "chunk cut",
        input_faces: cut.finest_faces,
        output_faces: cut.mesh.faces.len(),
        output_vertices: cut.mesh.vertex_count(),
        decimate: None,
        cut: None,
        chunk_cut: Some(cut.report.clone()),
        measured: None,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.measure {
        let pb = progress::spinner("reading the finest level and measuring the distance to it");
        let input = mrq::read(&args.input, None)?.hierarchy.levels.pop().context("levels")?.mesh;
        report.measured = Some(distance(&input, &cut.mesh, &Sampling::default()));
        pb.finish_and_clear();
    }
    write(args, mrq_out, to, &cut.mesh)?;
    print_summary(&report, cut.diagonal);
    if args.json {
        let json = serde_json::to_string_pretty(&report)?;
        crate::out::stdout(|w| writeln!(w, "{json}"))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn write(args: &Args, mrq_out: bool, to: Option<Format>, mesh: &Mesh) -> anyhow::Result<()> {
    if mrq_out {
        let h = Hierarchy::single(mesh.clone());
        let opts = octowrap_format::EncodeOptions::with_quantization(octowrap_format::Quantization::Exact);
        return mrq::write(&args.output, &h, &opts, args.clobber);
    }
    let mut opts = WriteOptions::default();
    opts.format = to;
    opts.ascii = args.output_format.ascii;
    opts.no_clobber = args.clobber.no_clobber;
    octowrap_io::write_path(&args.output, mesh, &opts).with_context(|| format!("writing {}", args.output.display()))
}

fn print_summary(r: &Report, diagonal: f64) {
    let pct = |x: f64| if diagonal > 0.0 { 100.0 * x / diagonal } else { 0.0 };
    say!(
        "{}: {} -> {} faces, {} vertices, {:.3} s",
        Path::new(&r.output).display(),
        r.input_faces,
        r.output_faces,
        r.output_vertices,
        r.seconds
    );
    if let Some(d) = &r.decimate {
        if let (Some(e), Some(found)) = (d.error, d.error_found) {
            say!(
                "  Hausdorff distance to the input: at most {e:.6e} ({:.4}% of the diagonal), certified; {found:.6e} ({:.4}%) found at a sample",
                pct(e),
                pct(found)
            );
        }
        if d.error.is_none() {
            say!(
                "  error estimate (quadric, 2 to 5 times below the Hausdorff distance): {:.6e} ({:.4}% of the diagonal); --measure certifies the distance",
                d.quadric_error,
                pct(d.quadric_error)
            );
        }
        say!(
            "  quadric error {:.6e}; stopped: {}; {} collapses in {} passes, {} run(s){}",
            d.quadric_error,
            serde_json::to_value(d.stop).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default(),
            d.collapses,
            d.passes,
            d.runs,
            if d.frozen_vertices > 0 {
                format!("; {} non-manifold vertices left untouched", d.frozen_vertices)
            } else {
                String::new()
            }
        );
    }
    if let Some(c) = &r.cut {
        let levels: Vec<String> = c.faces_per_level.iter().map(ToString::to_string).collect();
        say!(
            "  faces per level (coarsest first): {}; largest region distance to the finest level {:.6e} ({:.4}% of the diagonal), certified",
            levels.join(" "),
            c.max_error,
            pct(c.max_error)
        );
    }
    if let Some(c) = &r.chunk_cut {
        let levels: Vec<String> = c.faces_per_level.iter().map(ToString::to_string).collect();
        say!(
            "  faces per level (coarsest first): {}; {} chunks drawn ({} refined by the crack rule{}); largest chunk error {:.6e} ({:.4}% of the diagonal), certified for the chunks as stored (seam vertices moved to a finer chunk's are not measured again: --measure does)",
            levels.join(" "),
            c.chunks_drawn,
            c.chunks_refined,
            if c.unresolved_seams > 0 { format!(", {} seams left open", c.unresolved_seams) } else { String::new() },
            c.max_error,
            pct(c.max_error)
        );
        say!(
            "  read {} of {} bytes ({:.1} %) in {} requests",
            c.bytes_read,
            c.file_bytes,
            if c.file_bytes > 0 { 100.0 * c.bytes_read as f64 / c.file_bytes as f64 } else { 0.0 },
            c.requests
        );
    }
    if let Some(m) = &r.measured {
        say!(
            "  sampled: Hausdorff {:.6e} ({:.4}%), RMS {:.6e} ({:.4}%)",
            m.hausdorff,
            pct(m.hausdorff),
            m.rms,
            pct(m.rms)
        );
    }
}
