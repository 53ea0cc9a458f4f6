//! Loading an input: the bytes of a file or stream, gunzipped as they stream in, read chunk by
//! chunk and refused as soon as they cannot belong to the format.
//!
//! The readers parse a whole input held in memory, but nothing is inflated blindly first: the
//! decompressed stream is read in 64 KiB chunks and checked as it grows.
//! * The memory ceiling ([`Limits::max_memory`](crate::Limits)) caps the bytes held.
//! * Once the format and enough of its header are in, the format gives a [`Rule`]: a binary body
//!   whose size the header bounds (binary PLY, binary STL, binary PCD) is read up to that bound and
//!   one byte more, which is trailing data and refused (and a header whose body needs more bytes
//!   than the ceiling, every list empty, is refused at once); a text format refuses the first NUL byte,
//!   which no text holds (a bomb of zeros behind a text header stops in its first chunk).
//! * A broken gzip stream is reported at the compressed byte where the inflater stopped, with the
//!   decompressed bytes produced before it.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use crate::budget::{bytes, exceeded};
use crate::{Error, Format, Location, ReadOptions, Result};

/// How much is read at a time.
const CHUNK: usize = 64 << 10;

/// How far the early checks look for a header before giving up on a rule (the reader then
/// reports what is wrong with the header).
const HEADER_WINDOW: usize = 1 << 20;

/// What the format says about the bytes still to come.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rule {
    /// Text from byte `from` on: a NUL byte there is refused.
    Text { from: usize },
    /// The header bounds the input: nothing may follow byte `end` (exclusive), and the input
    /// takes at least `least` bytes (the body with every list empty), which must fit under the
    /// memory ceiling: a header declaring more is refused before its body is read.
    EndsBy { end: u64, least: u64 },
    /// Nothing to check early (formats read whole by their libraries).
    Free,
}

/// An input read into memory.
pub(crate) struct Loaded {
    /// Its format.
    pub format: Format,
    /// Its (decompressed) bytes.
    pub data: Vec<u8>,
}

/// A `BufRead` that counts the bytes its consumer takes (the compressed offset of a gzip stream).
struct Counted<R> {
    inner: R,
    consumed: u64,
}

impl<R: BufRead> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.consumed += n as u64;
        Ok(n)
    }
}

impl<R: BufRead> BufRead for Counted<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        self.consumed += amt as u64;
        self.inner.consume(amt);
    }
}

/// The decompressed stream.
enum Stream<R: BufRead> {
    Plain(R),
    Gzip(Box<flate2::bufread::MultiGzDecoder<Counted<R>>>),
}

impl<R: BufRead> Stream<R> {
    /// The compressed bytes consumed so far, for a gzip stream.
    fn compressed_offset(&self) -> Option<u64> {
        match self {
            Self::Plain(_) => None,
            Self::Gzip(d) => Some(d.get_ref().consumed),
        }
    }

    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Self::Plain(r) => r.read(buf),
            Self::Gzip(d) => d.read(buf),
        }
    }

    /// One [`Self::read`], retried while it is interrupted.
    fn read_retrying(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        loop {
            match self.read(buf) {
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                other => return other,
            }
        }
    }
}

/// Whether `data` starts with the gzip signature.
pub(crate) fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// Reads `input` (gzipped or not) into memory under `opts`' limits, and tells its format
/// (`opts.format`, else detected from the content and `path`'s extension).
pub(crate) fn load(input: impl Read, path: Option<&Path>, opts: &ReadOptions) -> Result<Loaded> {
    let mut input = BufReader::with_capacity(CHUNK, input);
    let head = loop {
        match input.fill_buf() {
            Ok(b) => break b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(Error::io(e)),
        }
    };
    let mut stream = if is_gzip(head) {
        Stream::Gzip(Box::new(flate2::bufread::MultiGzDecoder::new(Counted { inner: input, consumed: 0 })))
    } else {
        Stream::Plain(input)
    };
    let ceiling = opts.limits.max_memory.unwrap_or(u64::MAX);
    let mut data: Vec<u8> = Vec::new();
    let mut format = opts.format;
    let mut rule: Option<Rule> = None;
    let mut checked = 0usize;
    loop {
        let n = read_more(&mut stream, &mut data, ceiling, rule)?;
        let eof = n == 0;
        if format.is_none() && (eof || data.len() >= 4096) {
            format = detect_early(path, &data, eof);
        }
        if let (Some(f), None) = (format, rule) {
            rule = rule_for(f, &data, eof);
            let least = match rule {
                Some(Rule::EndsBy { least, .. }) => least,
                _ => 0,
            };
            if least > ceiling {
                return Err(exceeded(ceiling, least, "the body its header declares", Location::Unknown));
            }
        }
        match rule {
            Some(Rule::Text { from }) => {
                let from = from.max(checked);
                if let Some(k) = data.get(from..).and_then(|t| t.iter().position(|&c| c == 0)) {
                    let at = from + k;
                    return Err(Error::invalid(
                        Location::Byte(at as u64),
                        format!(
                            "a NUL byte in what must be {} text{}: the input is not text from here on",
                            format.map_or("", Format::name),
                            compressed_note(&stream)
                        ),
                    ));
                }
                checked = data.len();
            }
            Some(Rule::EndsBy { end, .. }) if data.len() as u64 > end => {
                return Err(Error::invalid(
                    Location::Byte(end),
                    format!(
                        "trailing data: the header's counts end the body at byte {end} at most, but the input goes \
                         on{}",
                        compressed_note(&stream)
                    ),
                ));
            }
            _ => {}
        }
        if eof {
            break;
        }
    }
    let format = format.or_else(|| Format::detect(path, &data)).ok_or_else(|| {
        Error::unsupported(Location::Unknown, "cannot tell the format from the extension or the content")
    })?;
    data.shrink_to_fit();
    Ok(Loaded { format, data })
}

/// Reads the next piece of `stream` onto `data`, growing it without passing `ceiling`; returns
/// the bytes read (0 at the end). Under a body-end `rule`, reads no further than one byte past it.
fn read_more<R: BufRead>(
    stream: &mut Stream<R>,
    data: &mut Vec<u8>,
    ceiling: u64,
    rule: Option<Rule>,
) -> Result<usize> {
    let start = data.len();
    if start as u64 >= ceiling {
        // The buffer holds the ceiling: one byte more, read aside, tells whether the input
        // goes on (growing the buffer for that byte would copy it whole: twice the ceiling).
        let mut one = [0u8; 1];
        let n = stream.read_retrying(&mut one).map_err(|e| stream_error(e, stream, start))?;
        if n > 0 {
            return Err(exceeded(ceiling, start as u64 + 1, "the input's bytes", Location::Byte(ceiling)));
        }
        return Ok(0);
    }
    let mut want = CHUNK as u64;
    if let Some(Rule::EndsBy { end, .. }) = rule {
        // One byte past the bound is enough to know there is trailing data.
        want = want.min((end + 1).saturating_sub(start as u64)).max(1);
    }
    want = want.min(ceiling - start as u64).max(1);
    if data.capacity() - start < want as usize {
        // Double, but never past the ceiling; and when the doubling after this one would
        // stop at the ceiling, take all the room now: a last small step would copy a
        // buffer of nearly the ceiling into one of the ceiling, holding both at once.
        let room = ceiling - start as u64;
        let mut more = (start.max(CHUNK) as u64).min(room).max(want);
        if room - more < start as u64 + more {
            more = room;
        }
        data.reserve_exact(more as usize);
    }
    data.resize(start + want as usize, 0);
    let n = match stream.read_retrying(&mut data[start..]) {
        Ok(n) => n,
        Err(e) => {
            data.truncate(start);
            return Err(stream_error(e, stream, start));
        }
    };
    data.truncate(start + n);
    Ok(n)
}

/// The format, once the first bytes are in: a signature, else the extension, else (only with the
/// whole input, since a binary STL's signature is its size) a look at the content.
fn detect_early(path: Option<&Path>, data: &[u8], eof: bool) -> Option<Format> {
    if eof {
        return Format::detect(path, data);
    }
    let starts = |m: &[u8]| data.starts_with(m);
    if starts(b"ply\n") || starts(b"ply\r\n") {
        return Some(Format::Ply);
    }
    let sniffed = Format::sniff(data).filter(|&f| f != Format::Stl);
    sniffed.or_else(|| path.and_then(Format::from_path))
}

/// The rule `format` sets for `data`, once enough of its header is in (`None`: not yet).
fn rule_for(format: Format, data: &[u8], eof: bool) -> Option<Rule> {
    let rule = match format {
        Format::Obj | Format::Off | Format::Xyz | Format::Conf => Some(Rule::Text { from: 0 }),
        Format::Ply => crate::ply::stream_rule(data),
        Format::Stl => crate::stl::stream_rule(data),
        Format::Pcd => crate::pcd::stream_rule(data),
        Format::Las | Format::E57 | Format::Exr => Some(Rule::Free),
    };
    if rule.is_none() && (eof || data.len() >= HEADER_WINDOW) { Some(Rule::Free) } else { rule }
}

/// ", at compressed byte N" for a gzip stream.
fn compressed_note<R: BufRead>(stream: &Stream<R>) -> String {
    stream.compressed_offset().map_or_else(String::new, |c| format!(" (gzip input near compressed byte {c})"))
}

/// A read error: a broken gzip stream at its compressed offset, or an operating-system error.
fn stream_error<R: BufRead>(e: std::io::Error, stream: &Stream<R>, decompressed: usize) -> Error {
    match stream.compressed_offset() {
        Some(c) if e.kind() != std::io::ErrorKind::Interrupted && !is_os_error(&e) => Error::invalid(
            Location::Byte(c),
            format!("broken gzip stream at compressed byte {c}, after {} decompressed", bytes(decompressed as u64)),
        )
        .with_source(e),
        _ => Error::io(e),
    }
}

/// Whether `e` comes from the operating system rather than from the gzip decoder.
fn is_os_error(e: &std::io::Error) -> bool {
    e.raw_os_error().is_some()
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;
    use crate::{ErrorKind, Limits};

    fn gzip(data: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn gzip_errors_name_the_compressed_offset() {
        let gz = gzip(&b"1 2 3\n".repeat(20_000));
        let mut broken = gz.clone();
        let mid = broken.len() / 2;
        for b in &mut broken[mid..mid + 16] {
            *b ^= 0x5a;
        }
        let e = load(&broken[..], Some(Path::new("a.xyz.gz")), &ReadOptions::default()).err().unwrap();
        assert_eq!(e.kind, ErrorKind::Invalid, "{e}");
        let Location::Byte(at) = e.location else { panic!("{e}") };
        assert!(at > 0 && at <= broken.len() as u64, "{e}");
        assert!(e.message.contains("compressed byte"), "{e}");
        let e = load(&gz[..gz.len() - 30], None, &ReadOptions::default()).err().unwrap();
        assert!(matches!(e.location, Location::Byte(b) if b > 0), "a truncated stream: {e}");
    }

    #[test]
    fn the_ceiling_caps_what_is_held() {
        let gz = gzip(&b"1 2 3\n".repeat(100_000));
        let opts =
            ReadOptions { limits: Limits { max_memory: Some(100_000), ..Limits::default() }, ..Default::default() };
        let e = load(&gz[..], Some(Path::new("a.xyz.gz")), &opts).err().unwrap();
        assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
        assert!(e.message.contains("--max-memory"), "{e}");
        let l = load(&gz[..], Some(Path::new("a.xyz.gz")), &ReadOptions::default()).unwrap();
        assert_eq!((l.format, l.data.len()), (Format::Xyz, 600_000));
    }

    /// A binary PLY header over a body of `len` bytes (zeros, or noise that gzip cannot shrink):
    /// `vertices` float points, then `faces` faces with an int-counted list.
    fn ply_over(vertices: u64, faces: u64, len: usize, noise: bool) -> Vec<u8> {
        let mut ply = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\n\
             property float z\nelement face {faces}\nproperty list int int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        ply.extend((0..len).map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            if noise { (x >> 24) as u8 } else { 0 }
        }));
        ply
    }

    #[test]
    fn a_header_declaring_more_than_the_ceiling_is_refused_before_its_body() {
        // 2^31 vertices (24 GiB of body at least) over 4 MiB of noise, gzipped: refused at once,
        // with the input read no further than its first chunks.
        let gz = gzip(&ply_over(1 << 31, 0, 4 << 20, true));
        let opts =
            ReadOptions { limits: Limits { max_memory: Some(1 << 30), ..Limits::default() }, ..Default::default() };
        let mut counted = Counted { inner: &gz[..], consumed: 0 };
        let e = load(&mut counted, Some(Path::new("a.ply.gz")), &opts).err().unwrap();
        assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
        assert!(e.message.contains("header declares") && e.message.contains("--max-memory"), "{e}");
        assert!(counted.consumed < gz.len() as u64 / 2, "read {} of {} bytes", counted.consumed, gz.len());
        // Lists count at their fewest bytes: faces whose lists could hold 2^31 corners each do not
        // refuse a file whose lists are empty.
        let small = ply_over(2, 3, 2 * 12 + 3 * 4, false);
        let l = load(&small[..], Some(Path::new("a.ply")), &opts).unwrap();
        assert_eq!((l.format, l.data.len()), (Format::Ply, small.len()));
    }
}
