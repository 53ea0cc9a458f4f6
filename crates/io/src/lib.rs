//! Readers and writers for every point and mesh format octowrap's users bring.
//!
//! | format | read | write | notes |
//! |---|---|---|---|
//! | PLY | ascii, binary LE/BE | binary LE (default), ascii | extra vertex properties skipped; any integer list type |
//! | OBJ | yes | yes | quads and n-gons kept; negative indices |
//! | OFF | yes | yes | `OFF`, `COFF`, `NOFF`, `CNOFF` headers |
//! | STL | ascii, binary | binary (ascii on request) | read as stored (3 vertices per triangle: [`Mesh::weld_exact`] indexes them); quads split along the shorter diagonal on write |
//! | XYZ / PTS / PWN | yes | yes (XYZ) | whitespace columns: `x y z [nx ny nz]` |
//! | PCD | ascii, binary, binary_compressed | – | |
//! | LAS / LAZ | yes (COPC as plain LAZ) | – | scaled coordinates kept in `f64` |
//! | E57 | yes | – | Cartesian and spherical; several scans merged with their poses |
//! | OpenEXR | yes | – | depth `Z` plus a [`PinholeCamera`], or RGB = XYZ positions |
//! | Stanford `.conf` | yes | – | range scans merged with their poses |
//!
//! Any input may be gzip-compressed (`.ply.gz`); it is decompressed transparently. The format is
//! chosen from the content when it has a signature (magic bytes), else from the extension, else
//! from a look at the text ([`Format::detect`]).
//!
//! # Hostile input
//! Every reader parses the whole (decompressed) input in memory, but the input is loaded as a
//! stream, gzip inflated chunk by chunk, and refused as soon as it cannot belong to its format: a
//! text format stops at the first NUL byte, a binary body whose size the header bounds (PLY, STL,
//! PCD) stops one byte past that bound (trailing data is an error naming its offset). The memory
//! ceiling ([`Limits::max_memory`], 8 GiB unless set) caps what one input may make a reader hold,
//! its bytes and everything read from them; each reader checks it before allocating for a
//! declared count, and as its vectors grow. Every declared count is also checked against the bytes
//! that remain ([`Limits`]), so a header that declares 10^12 vertices in a 1 kB file fails at once
//! with [`ErrorKind::LimitExceeded`]. A `.conf` set lists at most [`Limits::max_scans`] scans. A
//! result whose extent is not finite (a point at 1e308 beside the unit cube) is refused
//! ([`check_extent`]), and an OBJ with nothing but unknown statements is not an empty mesh. Errors
//! name the file, the byte offset or line (for a gzip stream, the compressed offset as well), and
//! what was expected. No reader panics on any input; `tools/fuzz` holds a target for each.
//!
//! # Writing
//! [`write_path`] writes to a temporary file beside the target and renames it into place, so a
//! failed or interrupted run never leaves a half-written file.
//!
//! ```no_run
//! use octowrap_io::{read_path, write_path, ReadOptions, WriteOptions};
//! let mesh = read_path("bunny.ply".as_ref(), &ReadOptions::default())?;
//! write_path("bunny.obj".as_ref(), &mesh, &WriteOptions::default())?;
//! # Ok::<(), octowrap_io::Error>(())
//! ```

mod budget;
mod error;
mod source;
mod text;

mod conf;
mod crs;
mod e57;
mod exr;
mod las;
mod obj;
mod off;
mod pcd;
mod ply;
mod stl;
mod xyz;

use std::io::{Read, Write};
use std::path::Path;

pub use crs::{Crs, read_crs};
pub use error::{Error, ErrorKind, Location, Result};
pub use octowrap_mesh::Mesh;

/// The file formats octowrap reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Format {
    /// Stanford polygon format.
    Ply,
    /// Wavefront OBJ.
    Obj,
    /// Object File Format.
    Off,
    /// Stereolithography (triangles).
    Stl,
    /// Whitespace-separated point columns (`.xyz`, `.pts`, `.pwn`, `.txt`).
    Xyz,
    /// Point Cloud Library's format.
    Pcd,
    /// ASPRS LAS, or LAZ (its compressed form, COPC included).
    Las,
    /// ASTM E57 3D imaging data.
    E57,
    /// OpenEXR image (depth or XYZ positions).
    Exr,
    /// A Stanford `.conf` scan set: range scans with poses.
    Conf,
}

impl Format {
    /// Every format, in the order of the table above.
    pub const ALL: [Self; 10] =
        [Self::Ply, Self::Obj, Self::Off, Self::Stl, Self::Xyz, Self::Pcd, Self::Las, Self::E57, Self::Exr, Self::Conf];

    /// A short lowercase name (`ply`, `obj`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::Ply => "ply",
            Self::Obj => "obj",
            Self::Off => "off",
            Self::Stl => "stl",
            Self::Xyz => "xyz",
            Self::Pcd => "pcd",
            Self::Las => "las",
            Self::E57 => "e57",
            Self::Exr => "exr",
            Self::Conf => "conf",
        }
    }

    /// Whether octowrap can write this format.
    pub fn writable(self) -> bool {
        matches!(self, Self::Ply | Self::Obj | Self::Off | Self::Stl | Self::Xyz)
    }

    /// Whether the format can hold faces.
    pub fn holds_faces(self) -> bool {
        matches!(self, Self::Ply | Self::Obj | Self::Off | Self::Stl)
    }

    /// The format an extension names (case-insensitive, without the dot; `gz` is not a format).
    pub fn from_extension(ext: &str) -> Option<Self> {
        Some(match ext.to_ascii_lowercase().as_str() {
            "ply" => Self::Ply,
            "obj" => Self::Obj,
            "off" | "coff" | "noff" => Self::Off,
            "stl" => Self::Stl,
            "xyz" | "pts" | "pwn" | "txt" | "asc" => Self::Xyz,
            "pcd" => Self::Pcd,
            "las" | "laz" => Self::Las,
            "e57" => Self::E57,
            "exr" => Self::Exr,
            "conf" => Self::Conf,
            _ => return None,
        })
    }

    /// The format a path's extension names, looking through a trailing `.gz`.
    pub fn from_path(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_str()?;
        let name = strip_gz(name);
        let ext = Path::new(name).extension()?.to_str()?;
        Self::from_extension(ext)
    }

    /// The format whose signature starts `data`, for formats that have one.
    pub fn sniff(data: &[u8]) -> Option<Self> {
        let starts = |m: &[u8]| data.starts_with(m);
        if starts(b"ply\n") || starts(b"ply\r\n") {
            Some(Self::Ply)
        } else if starts(b"LASF") {
            Some(Self::Las)
        } else if starts(b"ASTM-E57") {
            Some(Self::E57)
        } else if starts(&[0x76, 0x2f, 0x31, 0x01]) {
            Some(Self::Exr)
        } else if stl::looks_binary(data) {
            Some(Self::Stl)
        } else {
            None
        }
    }

    /// Guesses a text format from its first lines, for inputs with neither a signature nor a
    /// known extension (standard input, say).
    pub fn guess_text(data: &[u8]) -> Option<Self> {
        let head = &data[..data.len().min(4096)];
        let text = String::from_utf8_lossy(head);
        let first = text.lines().map(str::trim).find(|l| !l.is_empty())?;
        let word = first.split_whitespace().next().unwrap_or("");
        if word.ends_with("OFF") && word.len() <= 5 {
            return Some(Self::Off);
        }
        if word == "solid" {
            return Some(Self::Stl);
        }
        if first.starts_with("# .PCD") || word == "VERSION" {
            return Some(Self::Pcd);
        }
        if word == "camera" || word == "bmesh" || word == "mesh" {
            return Some(Self::Conf);
        }
        let obj_words = ["v", "vn", "vt", "f", "o", "g", "s", "usemtl", "mtllib", "l"];
        if text.lines().map(str::trim).any(|l| obj_words.contains(&l.split_whitespace().next().unwrap_or(""))) {
            return Some(Self::Obj);
        }
        if first.split_whitespace().all(|t| t.parse::<f64>().is_ok()) {
            return Some(Self::Xyz);
        }
        None
    }

    /// Picks the format of an input: its signature first (content beats a wrong extension), then
    /// `path`'s extension, then a look at the text.
    pub fn detect(path: Option<&Path>, data: &[u8]) -> Option<Self> {
        Self::sniff(data).or_else(|| path.and_then(Self::from_path)).or_else(|| Self::guess_text(data))
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `name` without a trailing `.gz` (any case). Compared as bytes: a name ending in a multibyte
/// character has no character boundary three bytes from its end.
fn strip_gz(name: &str) -> &str {
    let n = name.len();
    if n > 3 && name.as_bytes()[n - 3..].eq_ignore_ascii_case(b".gz") { &name[..n - 3] } else { name }
}

/// Caps on what a reader will allocate, checked before allocating. Every reader also refuses any
/// count its remaining input cannot hold, whatever the limits say.
///
/// The fields are public; start from [`Limits::default`] (or [`Limits::unlimited`]) and change
/// the ones you need:
///
/// ```
/// let mut opts = octowrap_io::ReadOptions::default();
/// opts.limits.max_memory = Some(256 << 20); // 256 MiB
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Limits {
    /// Most points (vertices) one input may hold. Default: `u32::MAX`, since faces index with `u32`.
    pub max_points: u64,
    /// Most faces one input may hold. Default: `u32::MAX`.
    pub max_faces: u64,
    /// The memory ceiling: the most bytes one input may make a reader hold at once, its
    /// (decompressed) content and everything read from it together. A reader checks it before
    /// each allocation whose size the input declares or drives, and refuses with
    /// [`ErrorKind::LimitExceeded`] once it would be passed. `None` is unlimited (on request
    /// only). Default: [`Limits::DEFAULT_MAX_MEMORY`] (8 GiB).
    pub max_memory: Option<u64>,
    /// Most scans a Stanford `.conf` set may list. Default: [`Limits::DEFAULT_MAX_SCANS`].
    pub max_scans: u64,
}

impl Limits {
    /// The default memory ceiling: 8 GiB.
    pub const DEFAULT_MAX_MEMORY: u64 = 8 << 30;
    /// The default cap on the scans of a `.conf` set: 1,000 (Stanford's largest sets list a few
    /// dozen).
    pub const DEFAULT_MAX_SCANS: u64 = 1000;

    /// No caps but those that the input's own size and 32-bit indices impose.
    pub fn unlimited() -> Self {
        Self { max_memory: None, max_scans: u64::MAX, ..Self::default() }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_points: u64::from(u32::MAX),
            max_faces: u64::from(u32::MAX),
            max_memory: Some(Self::DEFAULT_MAX_MEMORY),
            max_scans: Self::DEFAULT_MAX_SCANS,
        }
    }
}

/// A pinhole camera for turning a depth image into points: pixel `(u, v)` with depth `z` (along
/// the optical axis) becomes `((u + 0.5 - cx) z / fx, (v + 0.5 - cy) z / fy, z)` in camera space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    /// Focal length in pixels, horizontal.
    pub fx: f64,
    /// Focal length in pixels, vertical.
    pub fy: f64,
    /// Principal point, pixels from the left edge.
    pub cx: f64,
    /// Principal point, pixels from the top edge.
    pub cy: f64,
}

/// How to read an input.
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct ReadOptions {
    /// Caps checked before allocating.
    pub limits: Limits,
    /// Force a format instead of detecting it.
    pub format: Option<Format>,
    /// Camera for depth images (OpenEXR `Z`). Without it, an EXR must hold XYZ positions in RGB.
    pub camera: Option<PinholeCamera>,
    /// Keep the records that hold no position as NaN points instead of dropping them: the pixels
    /// without a measurement of an organised PCD cloud, and E57 records marked invalid or
    /// direction-only. The point count then equals the file's record count (and an organised
    /// cloud keeps its `width x height` grid). Default false: such records carry no geometry.
    pub keep_invalid: bool,
}

/// How to write an output.
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct WriteOptions {
    /// Force a format instead of taking it from the extension.
    pub format: Option<Format>,
    /// Text instead of binary where the format has both (PLY, STL).
    pub ascii: bool,
    /// Refuse to replace an existing file ([`octowrap_fsutil::WriteOptions::no_clobber`]).
    pub no_clobber: bool,
}

/// Reads a point cloud or mesh from a file (`-` for standard input).
pub fn read_path(path: &Path, opts: &ReadOptions) -> Result<Mesh> {
    read_path_detected(path, opts).map(|(_, mesh)| mesh)
}

/// Like [`read_path`], also telling which format was read.
pub fn read_path_detected(path: &Path, opts: &ReadOptions) -> Result<(Format, Mesh)> {
    let name = display_name(path, "<stdin>");
    if path == Path::new("-") {
        return read_from(std::io::stdin().lock(), path, opts).map_err(|e| e.in_file(&name));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(e).in_file(&name))?;
    if let (Ok(meta), Some(ceiling)) = (file.metadata(), opts.limits.max_memory) {
        if meta.len() > ceiling {
            let e = budget::exceeded(ceiling, meta.len(), "the file's bytes", Location::Unknown);
            return Err(e.in_file(&name));
        }
    }
    read_from(file, path, opts).map_err(|e| e.in_file(&name))
}

/// Reads a point cloud or mesh from any byte stream, as [`read_path`] reads a file: gzip is
/// decompressed as it streams in, the format is `opts.format` or else detected from the content
/// and `path`'s extension (`path` also locates the scans of a `.conf` set), and the bytes held
/// stay within the memory ceiling. The error names no file: callers add it with
/// [`Error::in_file`].
pub fn read_from(input: impl Read, path: &Path, opts: &ReadOptions) -> Result<(Format, Mesh)> {
    let loaded = source::load(input, Some(path), opts)?;
    let mesh = if loaded.format == Format::Conf {
        let mesh = conf::read(path, &loaded.data, opts)?;
        check_extent(&mesh)?;
        mesh
    } else {
        read_bytes(&loaded.data, loaded.format, opts)?
    };
    Ok((loaded.format, mesh))
}

/// Reads an in-memory input (already decompressed) of a known format. The error names no file:
/// callers add it with [`Error::in_file`]. Stanford `.conf` sets refer to other files and need
/// [`read_path`].
///
/// The result has a finite extent ([`check_extent`]).
pub fn read_bytes(data: &[u8], format: Format, opts: &ReadOptions) -> Result<Mesh> {
    let mesh = match format {
        Format::Ply => ply::read(data, opts),
        Format::Obj => obj::read(data, opts),
        Format::Off => off::read(data, opts),
        Format::Stl => stl::read(data, opts),
        Format::Xyz => xyz::read(data, opts),
        Format::Pcd => pcd::read(data, opts),
        Format::Las => las::read(data, opts),
        Format::E57 => e57::read(data, opts),
        Format::Exr => exr::read(data, opts),
        Format::Conf => {
            Err(Error::unsupported(Location::Unknown, "a .conf scan set refers to other files: read it by path"))
        }
    }?;
    debug_assert!(mesh.vertices.attributes_consistent());
    check_extent(&mesh)?;
    Ok(mesh)
}

/// Checks that `mesh`'s points have a usable extent: every coordinate finite (NaN marks a point
/// without a position and is passed over), the bounding box's squared diagonal representable in
/// `f64` (so distances and squared distances between any two points are finite), and a non-zero
/// extent at least `f64::MIN_POSITIVE` (a subnormal one has no finite reciprocal to normalise
/// by). The error names the point farthest out.
pub fn check_extent(mesh: &Mesh) -> Result<()> {
    let positions = &mesh.vertices.positions;
    let mut lo = octowrap_geom::DVec3::INFINITY;
    let mut hi = octowrap_geom::DVec3::NEG_INFINITY;
    let mut far = (0usize, 0.0f64);
    for (k, p) in positions.iter().enumerate() {
        if p.is_nan() {
            continue;
        }
        let m = p.abs().max_element();
        if m > far.1 {
            far = (k, m);
        }
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if positions.iter().all(|p| p.is_nan()) {
        return Ok(());
    }
    let span = (hi - lo).max_element();
    if span > 0.0 && span < f64::MIN_POSITIVE {
        return Err(Error::invalid(
            Location::Unknown,
            format!(
                "the points span only {span:e} (a subnormal extent, below {:e}): positions so close cannot be \
                 told apart in f64 arithmetic; scale them first",
                f64::MIN_POSITIVE
            ),
        ));
    }
    if far.1.is_finite() && (hi - lo).length_squared().is_finite() {
        return Ok(());
    }
    let p = positions[far.0];
    Err(Error::invalid(
        Location::Unknown,
        format!(
            "point {} at ({:e}, {:e}, {:e}) lies so far out that the points' extent is not finite in f64 \
             (bounding box from ({:e}, {:e}, {:e}) to ({:e}, {:e}, {:e}))",
            far.0, p.x, p.y, p.z, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        ),
    ))
}

/// Decompresses `data` if it starts with the gzip signature, streaming, within
/// `limits.max_memory` (the bytes held at once, the compressed input included).
pub fn decompress_if_gzip(data: Vec<u8>, limits: &Limits) -> Result<Vec<u8>> {
    if !source::is_gzip(&data) {
        return Ok(data);
    }
    let mut opts = ReadOptions { limits: *limits, ..ReadOptions::default() };
    opts.limits.max_memory = limits.max_memory.map(|m| m.saturating_sub(data.len() as u64));
    // The format is irrelevant to plain decompression: LAS sets no early rule.
    opts.format = Some(Format::Las);
    source::load(&data[..], None, &opts).map(|l| l.data)
}

/// Writes `mesh` to `path` (`-` for standard output) in the format its extension names; a path
/// ending in `.gz` is gzip-compressed. Files are written with [`octowrap_fsutil::write_file`]:
/// atomically through a temporary beside the target, keeping a replaced file's mode and owner and
/// a symbolic link's link, or straight into a FIFO or device.
pub fn write_path(path: &Path, mesh: &Mesh, opts: &WriteOptions) -> Result<()> {
    let name = display_name(path, "<stdout>");
    let format = opts
        .format
        .or_else(|| Format::from_path(path))
        .ok_or_else(|| Error::unsupported(Location::Unknown, "cannot tell the output format from the extension"))
        .map_err(|e| e.in_file(&name))?;
    let gzip = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    let write = |w: &mut dyn Write| -> Result<()> {
        if gzip {
            let mut z = flate2::write::GzEncoder::new(w, flate2::Compression::default());
            write_to(&mut z, mesh, format, opts)?;
            z.finish().map_err(Error::io)?;
            Ok(())
        } else {
            write_to(w, mesh, format, opts)
        }
    };
    if path == Path::new("-") {
        let stdout = std::io::stdout();
        let mut w = std::io::BufWriter::new(stdout.lock());
        write(&mut w).map_err(|e| e.in_file(&name))?;
        return w.flush().map_err(|e| Error::io(e).in_file(&name));
    }
    let file_opts = octowrap_fsutil::WriteOptions::no_clobber(opts.no_clobber);
    octowrap_fsutil::write_file(path, &file_opts, write).map_err(|e| match e {
        octowrap_fsutil::WriteError::Io(e) => Error::io(e).in_file(&name),
        octowrap_fsutil::WriteError::Write(e) => e.in_file(&name),
    })
}

/// Writes `mesh` in `format` to any writer.
pub fn write_to(w: &mut dyn Write, mesh: &Mesh, format: Format, opts: &WriteOptions) -> Result<()> {
    if let Err(e) = mesh.check_indices() {
        return Err(Error::invalid(Location::Unknown, format!("cannot write a broken mesh: {e}")));
    }
    match format {
        Format::Ply => ply::write(w, mesh, opts),
        Format::Obj => obj::write(w, mesh, opts),
        Format::Off => off::write(w, mesh, opts),
        Format::Stl => stl::write(w, mesh, opts),
        Format::Xyz => xyz::write(w, mesh, opts),
        other => Err(Error::unsupported(Location::Unknown, format!("octowrap does not write {other} files"))),
    }
}

fn display_name(path: &Path, stdio: &str) -> String {
    if path == Path::new("-") { stdio.to_owned() } else { path.display().to_string() }
}

/// Checks a count declared by a header before allocating for it: at least `min_bytes_each` bytes
/// per element must remain in the input, and the count must be within `max`.
///
/// Returns the count as `usize`.
pub(crate) fn justify(
    count: u64,
    min_bytes_each: u64,
    remaining: usize,
    max: u64,
    what: &str,
    at: Location,
) -> Result<usize> {
    if count > max {
        return Err(Error::limit(at, format!("{count} {what} declared, more than the limit of {max}")));
    }
    let need = count.saturating_mul(min_bytes_each);
    if need > remaining as u64 {
        return Err(Error::limit(
            at,
            format!("{count} {what} declared, but only {remaining} bytes remain (at least {need} needed)"),
        ));
    }
    usize::try_from(count).map_err(|_| Error::limit(at, format!("{count} {what} do not fit in memory")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extension_and_gz() {
        assert_eq!(Format::from_path(Path::new("a/b/dragon.PLY.gz")), Some(Format::Ply));
        assert_eq!(Format::from_path(Path::new("x.laz")), Some(Format::Las));
        assert_eq!(Format::from_path(Path::new("x.gz")), None);
        assert_eq!(Format::from_path(Path::new("noext")), None);
        // Names ending in a multibyte character (no char boundary three bytes from the end).
        assert_eq!(Format::from_path(Path::new("scan\u{e9}")), None);
        assert_eq!(Format::from_path(Path::new("\u{1F600}")), None);
        assert_eq!(Format::from_path(Path::new("caf\u{e9}.ply")), Some(Format::Ply));
        assert_eq!(strip_gz("\u{e9}\u{e9}"), "\u{e9}\u{e9}");
        assert_eq!(strip_gz("a.GZ"), "a");
    }

    #[test]
    fn content_beats_extension() {
        assert_eq!(Format::detect(Some(Path::new("a.obj")), b"ply\nformat ascii 1.0\n"), Some(Format::Ply));
        assert_eq!(Format::detect(None, b"OFF\n3 1 0\n"), Some(Format::Off));
        assert_eq!(Format::detect(None, b"# comment\nv 1 2 3\nf 1 2 3\n"), Some(Format::Obj));
        assert_eq!(Format::detect(None, b"1 2 3\n4 5 6\n"), Some(Format::Xyz));
        assert_eq!(Format::detect(None, b"\x00\x01garbage"), None);
    }

    #[test]
    fn justify_refuses_counts_the_bytes_cannot_hold() {
        let e = justify(1_000_000_000_000, 12, 1000, u64::MAX, "vertices", Location::Byte(40)).unwrap_err();
        assert_eq!(e.kind, ErrorKind::LimitExceeded);
        assert!(e.to_string().contains("10000000000"), "{e}");
        assert_eq!(justify(10, 12, 120, u64::MAX, "vertices", Location::Byte(0)).unwrap(), 10);
        assert!(justify(10, 0, 0, 5, "faces", Location::Byte(0)).is_err());
    }

    #[test]
    fn gzip_bomb_is_capped() {
        use flate2::{Compression, write::GzEncoder};
        let mut enc = GzEncoder::new(Vec::new(), Compression::fast());
        enc.write_all(&vec![b'a'; 100_000]).unwrap();
        let gz = enc.finish().unwrap();
        let limits = Limits { max_memory: Some(1000), ..Limits::default() };
        assert_eq!(decompress_if_gzip(gz.clone(), &limits).unwrap_err().kind, ErrorKind::LimitExceeded);
        assert_eq!(decompress_if_gzip(gz, &Limits::default()).unwrap().len(), 100_000);
        assert!(decompress_if_gzip(vec![0x1f, 0x8b, 0, 0], &Limits::default()).is_err());
    }
}
