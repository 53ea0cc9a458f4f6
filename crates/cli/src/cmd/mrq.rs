//! MRQ helpers shared by `convert`, `info` and `extract`: recognising `.mrq` files, reading a
//! level, writing a hierarchy with the quantization options, and the `info` report.

use std::io::Read;
use std::path::Path;

use anyhow::{Context, bail};
use octowrap_format::{DecodeOptions, EncodeOptions, FileInfo, Quantization};
use octowrap_mesh::{Hierarchy, Mesh};
use serde::Serialize;

/// Whether `path` has the `.mrq` extension.
pub fn has_mrq_extension(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mrq"))
}

/// Whether `path` names an MRQ file: by the `.mrq` extension, or by its magic number.
pub fn is_mrq(path: &Path) -> bool {
    if has_mrq_extension(path) {
        return true;
    }
    if path == Path::new("-") {
        return false;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut head)).is_ok() && octowrap_format::is_mrq(&head)
}

/// How to write an MRQ file.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct MrqWriteArgs {
    /// MRQ output: quantize positions on a grid of 2^BITS steps across the octree cube (or the
    /// bounding box). Every decoded vertex then lies within half a step of the input.
    #[arg(long, value_name = "BITS", conflicts_with_all = ["step", "exact"])]
    pub bits: Option<u32>,
    /// MRQ output: quantize positions on a grid with this step, in the input's units.
    #[arg(long, value_name = "STEP", conflicts_with = "exact")]
    pub step: Option<f64>,
    /// MRQ output: store positions exactly (lossless; the default when converting a mesh).
    #[arg(long)]
    pub exact: bool,
    /// MRQ output: zstd level, 1 (fast) to 22 (small).
    #[arg(long, value_name = "N", default_value_t = 19)]
    pub zstd_level: i32,
    /// MRQ output: the length unit to record (for example m or mm).
    #[arg(long, value_name = "UNIT")]
    pub units: Option<String>,
}

impl MrqWriteArgs {
    /// Encoder options; `lossless_default` picks exact storage when no quantization is given.
    pub fn options(&self, lossless_default: bool, source: &Path) -> EncodeOptions {
        let quantization = match (self.bits, self.step) {
            (Some(b), _) => Quantization::Bits(b),
            (_, Some(s)) => Quantization::Step(s),
            _ if self.exact || lossless_default => Quantization::Exact,
            _ => Quantization::Bits(16),
        };
        let mut o = EncodeOptions::with_quantization(quantization);
        o.zstd_level = self.zstd_level;
        o.metadata.units = self.units.clone().unwrap_or_default();
        o.metadata.source = source.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        o.metadata.generator = format!("octowrap {}", env!("CARGO_PKG_VERSION"));
        o
    }
}

/// Writes `h` to `path` as MRQ.
pub fn write(path: &Path, h: &Hierarchy, opts: &EncodeOptions) -> anyhow::Result<()> {
    let dropped: Vec<&str> = h.levels.iter().flat_map(|l| l.mesh.vertices.attribute_names()).collect();
    if !dropped.is_empty() {
        let mut names = dropped;
        names.sort_unstable();
        names.dedup();
        eprintln!("note: MRQ stores positions and connectivity only: dropping {}", names.join(", "));
    }
    if path == Path::new("-") {
        let mut out = std::io::stdout().lock();
        octowrap_format::encode_to(&mut out, h, opts).with_context(|| "writing MRQ to standard output")?;
        return Ok(());
    }
    octowrap_format::write_path(path, h, opts).with_context(|| format!("writing {}", path.display()))
}

/// Reads levels `0..=level` (all when `None`) of an MRQ file (`-` for standard input).
pub fn read(path: &Path, level: Option<u32>) -> anyhow::Result<octowrap_format::MrqFile> {
    let mut opts = DecodeOptions::default();
    opts.max_level = level;
    let file = if path == Path::new("-") {
        octowrap_format::decode(std::io::stdin().lock(), &opts)
    } else {
        octowrap_format::read_path(path, &opts)
    };
    file.with_context(|| format!("reading {}", path.display()))
}

/// The mesh of level `level` (the finest when `None`).
pub fn read_level(path: &Path, level: Option<u32>) -> anyhow::Result<Mesh> {
    let file = read(path, level)?;
    let n = file.info.levels.len();
    let Some(l) = file.hierarchy.levels.into_iter().last() else { bail!("{} holds no levels", path.display()) };
    if let Some(k) = level {
        eprintln!("note: level {k} of {n} ({} faces, {} vertices)", l.mesh.faces.len(), l.mesh.vertex_count());
    }
    Ok(l.mesh)
}

/// What `info` reports about an MRQ file.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The file as given.
    pub file: String,
    /// Always `mrq`.
    pub format: &'static str,
    /// File size in bytes.
    pub bytes: u64,
    /// Everything the preamble says (levels with offsets, sizes and counts; quantization; metadata).
    #[serde(flatten)]
    pub info: FileInfo,
}

impl Report {
    /// Reads the preamble of `path` only.
    pub fn new(path: &Path) -> anyhow::Result<Self> {
        let f = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
        let bytes = f.metadata().map_or(0, |m| m.len());
        let info = octowrap_format::read_info(std::io::BufReader::new(f), &octowrap_format::Limits::default())
            .with_context(|| format!("reading {}", path.display()))?;
        Ok(Self { file: path.display().to_string(), format: "mrq", bytes, info })
    }

    /// Prints the text form.
    #[allow(clippy::print_stdout)]
    pub fn print_text(&self) {
        let i = &self.info;
        println!("{}", self.file);
        println!("  format      MRQ version {}, {} bytes, {} levels", i.version, self.bytes, i.levels.len());
        match &i.grid {
            None => println!("  positions   exact (binary64)"),
            Some(g) => println!(
                "  positions   grid step {:.6e}{}, origin {:.6} {:.6} {:.6}",
                g.step,
                if g.tied_to_cube { format!(" ({} bits across the cube)", g.bits) } else { String::new() },
                g.origin[0],
                g.origin[1],
                g.origin[2]
            ),
        }
        if let Some(([x0, y0, z0], [x1, y1, z1])) = i.cube {
            println!("  cube        {x0:.6} {y0:.6} {z0:.6} .. {x1:.6} {y1:.6} {z1:.6}");
        }
        let m = &i.metadata;
        for (k, v) in [("units", &m.units), ("source", &m.source), ("generator", &m.generator)] {
            if !v.is_empty() {
                println!("  {k:<11} {v}");
            }
        }
        for (k, v) in &m.entries {
            println!("  {k:<11} {v}");
        }
        println!("  level     vertices        faces        bytes   bits/vertex");
        for (k, l) in i.levels.iter().enumerate() {
            let bpv = if l.vertex_count > 0 { l.stored_size as f64 * 8.0 / f64::from(l.vertex_count) } else { 0.0 };
            println!("  {k:>5} {:>12} {:>12} {:>12} {:>13.2}", l.vertex_count, l.face_count, l.stored_size, bpv);
        }
    }
}
