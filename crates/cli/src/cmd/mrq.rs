//! MRQ helpers shared by `convert`, `info` and `extract`: recognising `.mrq` files, reading a
//! level, writing a hierarchy with the quantization options, and the `info` report.

use std::io::{Read, Write};
use std::path::Path;

use anyhow::{Context, bail};
use octowrap_format::{EncodeOptions, FileInfo, Quantization};
use octowrap_mesh::{Hierarchy, Mesh};
use serde::Serialize;

use crate::out::ClobberArgs;

/// Whether `path` has the `.mrq` extension, or `.mrq.gz` (a gzip-compressed MRQ file).
pub fn has_mrq_extension(path: &Path) -> bool {
    octowrap_fsutil::without_gz(path).extension().is_some_and(|e| e.eq_ignore_ascii_case("mrq"))
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
    /// bounding box), 1 to 28. Every decoded vertex then lies within half a step of the input.
    #[arg(long, value_name = "BITS", conflicts_with_all = ["step", "exact"],
          value_parser = clap::value_parser!(u32).range(1..=i64::from(octowrap_format::MAX_GRID_BITS)))]
    pub bits: Option<u32>,
    /// MRQ output: quantize positions on a grid with this step, in the input's units (> 0).
    #[arg(long, value_name = "STEP", conflicts_with = "exact", value_parser = parse_step)]
    pub step: Option<f64>,
    /// MRQ output: store positions exactly (lossless; the default when converting a mesh).
    #[arg(long)]
    pub exact: bool,
    /// MRQ output: zstd level, 1 (fast) to 22 (small) [default: 19].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd_level: Option<i32>,
    /// MRQ output: the length unit to record (for example m or mm).
    #[arg(long, value_name = "UNIT")]
    pub units: Option<String>,
    /// MRQ output: the format version to write, 2 to 5 [default: 5]. Version 5 splits every level
    /// into chunks by octree cell, so that readers can fetch one part of a level (`extract
    /// --region`, view-dependent clients); version 4 stores each level whole.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(2..=i64::from(octowrap_format::FORMAT_VERSION)))]
    pub format_version: Option<u16>,
    /// MRQ output, version 5: level K's chunk cells are 2^S voxels of the level wide, so a chunk
    /// holds up to about 4^S faces [default: 7]. Smaller chunks let a reader fetch less of a large
    /// level, and cost more bytes (their shared border vertices are stored in each chunk).
    #[arg(long, value_name = "S", value_parser = clap::value_parser!(u32).range(1..=20))]
    pub chunk_shift: Option<u32>,
}

fn parse_step(s: &str) -> anyhow::Result<f64> {
    let v: f64 = s.trim().parse().with_context(|| format!("'{s}' is not a number"))?;
    if !(v.is_finite() && v > 0.0) {
        bail!("the grid step must be a positive length, not {s}");
    }
    Ok(v)
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
        if let Some(level) = self.zstd_level {
            o.zstd_level = level;
        }
        if let Some(v) = self.format_version {
            o.version = v;
        }
        if let Some(shift) = self.chunk_shift {
            o.chunk_shift = shift;
        }
        o.metadata.units = self.units.clone().unwrap_or_default();
        o.metadata.source = source.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        o.metadata.generator = format!("octowrap {}", env!("CARGO_PKG_VERSION"));
        o
    }

    /// Refuses these options when the output is not MRQ (they would be ignored), naming the first
    /// one given.
    pub fn refuse_unless_mrq(&self, output: &Path) -> anyhow::Result<()> {
        let given = [
            ("--bits", self.bits.is_some()),
            ("--step", self.step.is_some()),
            ("--exact", self.exact),
            ("--zstd-level", self.zstd_level.is_some()),
            ("--units", self.units.is_some()),
            ("--format-version", self.format_version.is_some()),
            ("--chunk-shift", self.chunk_shift.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|g| g.1) {
            bail!(
                "{flag} sets how an MRQ file stores positions, but the output '{}' is not MRQ: \
                 drop {flag}, or write an .mrq file",
                output.display()
            );
        }
        Ok(())
    }
}

/// Writes `h` to `path` (`-` for standard output) as MRQ, gzip-compressed when `path` ends in
/// `.gz`.
pub fn write(path: &Path, h: &Hierarchy, opts: &EncodeOptions, clobber: ClobberArgs) -> anyhow::Result<()> {
    let dropped: Vec<&str> = h.levels.iter().flat_map(|l| l.mesh.vertices.attribute_names()).collect();
    if !dropped.is_empty() {
        let mut names = dropped;
        names.sort_unstable();
        names.dedup();
        say!("note: MRQ stores positions and connectivity only: dropping {}", names.join(", "));
    }
    let bytes = octowrap_decimate::chunks::encode_measured(h, opts).context("encoding the mesh as MRQ")?;
    if path == Path::new("-") {
        return Ok(crate::out::stdout(|w| w.write_all(&bytes))?);
    }
    octowrap_fsutil::write_file_gz(path, &clobber.write_options(), |w| w.write_all(&bytes))
        .map_err(|(octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e))| e)
        .with_context(|| format!("writing {}", path.display()))
}

/// Reads levels `0..=level` (all when `None`) of an MRQ file (`-` for standard input; a name
/// ending in `.gz` is decompressed as it is read).
pub fn read(path: &Path, level: Option<u32>) -> anyhow::Result<octowrap_format::MrqFile> {
    crate::limits::check_input_size(path)?;
    let opts = crate::limits::decode_options(level);
    let file = if path == Path::new("-") {
        octowrap_format::decode(std::io::stdin().lock(), &opts)
    } else {
        decode_file(path, &opts)
    };
    file.with_context(|| format!("reading {}", path.display()))
}

/// The bytes of the MRQ file `path`, decompressed as they are read when its name ends in `.gz`.
/// (The decoder reads levels in order and checks each level's declared sizes against its limits
/// before allocating, so the decompressed stream needs no ceiling of its own.)
fn open(path: &Path) -> std::io::Result<Box<dyn Read>> {
    let file = std::io::BufReader::with_capacity(1 << 20, std::fs::File::open(path)?);
    Ok(if octowrap_fsutil::is_gz(path) { Box::new(flate2::read::MultiGzDecoder::new(file)) } else { Box::new(file) })
}

/// Decodes the MRQ file `path` (gzip-compressed when its name ends in `.gz`).
pub fn decode_file(
    path: &Path,
    opts: &octowrap_format::DecodeOptions,
) -> Result<octowrap_format::MrqFile, octowrap_format::DecodeError> {
    octowrap_format::decode(open(path)?, opts)
}

/// The mesh of level `level` (the finest when `None`).
pub fn read_level(path: &Path, level: Option<u32>) -> anyhow::Result<Mesh> {
    let file = read(path, level)?;
    let n = file.info.levels.len();
    let Some(l) = file.hierarchy.levels.into_iter().last() else { bail!("{} holds no levels", path.display()) };
    if let Some(k) = level {
        say!("note: level {k} of {n} ({} faces, {} vertices)", l.mesh.faces.len(), l.mesh.vertex_count());
    }
    Ok(l.mesh)
}

/// The part of level `level` (the finest when `None`) inside `region` (all of it for `None`),
/// reading only the chunks it needs through range reads of the file (`.gz` files and standard
/// input are read whole first); `stats` prints what was read.
pub fn read_region(
    path: &Path,
    level: Option<u32>,
    region: Option<octowrap_mesh::Aabb>,
    stats: bool,
) -> anyhow::Result<Mesh> {
    let limits = crate::limits::format_limits();
    let ctx = || format!("reading {}", path.display());
    let (mesh, st, chunks, k, n) = if path == Path::new("-") || octowrap_fsutil::is_gz(path) {
        let mut bytes = Vec::new();
        if path == Path::new("-") {
            std::io::stdin().lock().read_to_end(&mut bytes)?;
        } else {
            open(path)?.read_to_end(&mut bytes)?;
        }
        region_of(&bytes[..], level, region, &limits).with_context(ctx)?
    } else {
        crate::limits::check_input_size(path)?;
        let f = std::fs::File::open(path).with_context(ctx)?;
        region_of(octowrap_format::SeekSource(std::io::BufReader::new(f)), level, region, &limits).with_context(ctx)?
    };
    if stats {
        say!(
            "read {} bytes in {} range requests; level {k} of {n}: {} chunks, {} faces, {} vertices",
            st.bytes,
            st.requests,
            chunks,
            mesh.faces.len(),
            mesh.vertex_count()
        );
    }
    Ok(mesh)
}

/// [`read_region`] over a byte-range source: the mesh, what was read, the chunks of the level
/// decoded, the level and the number of levels.
fn region_of<S: octowrap_format::RangeSource>(
    source: S,
    level: Option<u32>,
    region: Option<octowrap_mesh::Aabb>,
    limits: &octowrap_format::Limits,
) -> Result<(Mesh, octowrap_format::ReadStats, usize, u32, u32), octowrap_format::DecodeError> {
    let mut r = octowrap_format::ChunkedMrq::open(source, limits)?;
    let n = r.info().levels.len() as u32;
    let k = level.unwrap_or(n.saturating_sub(1));
    let chunks = r.chunks_in(k, region).len();
    let mesh = r.extract(k, region)?;
    let mesh = match region {
        Some(b) => clip(&mesh, b),
        None => mesh,
    };
    Ok((mesh, r.stats(), chunks, k, n))
}

/// The faces of `mesh` with a vertex inside `b`, and the vertices they use (in their order).
fn clip(mesh: &Mesh, b: octowrap_mesh::Aabb) -> Mesh {
    let p = &mesh.vertices.positions;
    let inside = |v: u32| (0..3).all(|a| p[v as usize][a] >= b.min[a] && p[v as usize][a] <= b.max[a]);
    let mut new = vec![u32::MAX; p.len()];
    let mut out = Mesh::default();
    let mut corners = Vec::new();
    for f in mesh.faces.iter().filter(|f| f.iter().any(|&v| inside(v))) {
        corners.clear();
        for &v in f {
            if new[v as usize] == u32::MAX {
                new[v as usize] = out.vertices.positions.len() as u32;
                out.vertices.positions.push(p[v as usize]);
            }
            corners.push(new[v as usize]);
        }
        out.faces.push(&corners);
    }
    out
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
        let bytes = std::fs::metadata(path).with_context(|| format!("opening {}", path.display()))?.len();
        let f = open(path).with_context(|| format!("opening {}", path.display()))?;
        let info = octowrap_format::read_info(f, &crate::limits::format_limits())
            .with_context(|| format!("reading {}", path.display()))?;
        Ok(Self { file: path.display().to_string(), format: "mrq", bytes, info })
    }

    /// Writes the text form.
    pub fn write_text(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let i = &self.info;
        writeln!(w, "{}", self.file)?;
        writeln!(w, "  format      MRQ version {}, {} bytes, {} levels", i.version, self.bytes, i.levels.len())?;
        match &i.grid {
            None => writeln!(w, "  positions   exact (binary64)")?,
            Some(g) => writeln!(
                w,
                "  positions   grid step {:.6e}{}, origin {:.6} {:.6} {:.6}",
                g.step,
                if g.tied_to_cube { format!(" ({} bits across the cube)", g.bits) } else { String::new() },
                g.origin[0],
                g.origin[1],
                g.origin[2]
            )?,
        }
        if let Some(([x0, y0, z0], [x1, y1, z1])) = i.cube {
            writeln!(w, "  cube        {x0:.6} {y0:.6} {z0:.6} .. {x1:.6} {y1:.6} {z1:.6}")?;
        }
        let m = &i.metadata;
        for (k, v) in [("units", &m.units), ("source", &m.source), ("generator", &m.generator)] {
            if !v.is_empty() {
                writeln!(w, "  {k:<11} {v}")?;
            }
        }
        for (k, v) in &m.entries {
            writeln!(w, "  {k:<11} {v}")?;
        }
        if !m.entries.iter().any(|(k, _)| k == octowrap_format::CRS_KEY) {
            writeln!(w, "  frame       local (no CRS): a tileset of it is not placed on the globe")?;
        }
        let chunked = i.version >= 5;
        if chunked {
            let n: u32 = i.levels.iter().map(|l| l.chunk_count).sum();
            writeln!(
                w,
                "  chunks      {n} (a level's chunks are the cells of its cell depth; `extract --region` reads only those it needs)"
            )?;
            writeln!(w, "  level     vertices        faces        bytes   bits/vertex   chunks  cell depth")?;
        } else {
            writeln!(w, "  level     vertices        faces        bytes   bits/vertex")?;
        }
        for (k, l) in i.levels.iter().enumerate() {
            let bpv = if l.vertex_count > 0 { l.stored_size as f64 * 8.0 / f64::from(l.vertex_count) } else { 0.0 };
            write!(w, "  {k:>5} {:>12} {:>12} {:>12} {:>13.2}", l.vertex_count, l.face_count, l.stored_size, bpv)?;
            if chunked {
                write!(w, " {:>8} {:>11}", l.chunk_count, l.cell_depth)?;
            }
            writeln!(w)?;
        }
        Ok(())
    }
}
