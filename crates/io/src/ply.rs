//! PLY, the Stanford polygon file format: reading (ascii, binary little and big endian) and
//! writing (binary little endian by default, ascii on request).
//!
//! Follows Greg Turk's *The PLY Polygon File Format* as given in Paul Bourke's description
//! (<https://paulbourke.net/dataformats/ply/>): a text header (`ply`, `format`, `element`,
//! `property`, `comment`, `obj_info`, `end_header`; `\n` or `\r\n` line ends) and a body holding
//! each element's records in header order.
//!
//! # Reading
//! * Scalar types by their old names (`char uchar short ushort int uint float double`) and their
//!   sized names (`int8 uint8 int16 uint16 int32 uint32 float32 float64`); `int64`/`uint64` too.
//! * The `vertex` element gives positions from `x y z` of any scalar type (kept in `f64`), normals
//!   from `nx ny nz`, colours from `red green blue` (8-bit as they are, 16-bit scaled down, floats
//!   taken as 0.0-1.0), intensities from `intensity` or `scalar_intensity`. Every other vertex
//!   property (`confidence`, `alpha`, `flags`, lists...) is skipped.
//! * The `face` element gives polygons from its list property `vertex_indices` (or
//!   `vertex_index`), with any integer count and index types; faces keep their size (quads and
//!   n-gons are not triangulated), and faces of fewer than 3 corners are kept for the validator
//!   to describe. Other face properties are skipped.
//! * Every other element (`camera`, `range_grid`, `edge`, `material`, ...) is skipped, list
//!   properties included.
//! * A float property is parsed straight to `f32` in ascii bodies, so a file's values come back
//!   as the `float`s it holds.
//!
//! Binary vertex records of fixed size are read attribute by attribute with a dedicated loop for
//! the common `float x, y, z` little-endian layout; the benchmark target is ≥ 1 GB/s on one core.
//!
//! # Writing
//! `x y z` as `float` when every coordinate is exactly an `f32`, else as `double` (georeferenced
//! coordinates); `nx ny nz` as `float`, `red green blue` as `uchar`, `intensity` as `float` when
//! present; faces as `list uchar int vertex_indices` (`list int int` when a face has more than
//! 255 corners). A mesh without faces is written without a `face` element. Ascii output writes
//! each value in its shortest round-trip form, so text round trips are exact too.

mod body;
mod header;

use std::io::Write;

use crate::budget::Budget;
use crate::source::Rule;
use crate::text::LineWriter;
use crate::{Error, Mesh, ReadOptions, Result, WriteOptions};

/// Reads a whole PLY file held in memory.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let header = header::parse(data)?;
    let mut budget = Budget::new(&opts.limits, data.len());
    let (vertices, faces) = body::read(data, &header, &opts.limits, &mut budget)?;
    Ok(Mesh { vertices, faces })
}

/// What the header says about the bytes to come, once it is complete in `data`: an ascii file is
/// text throughout; a binary body is at most as long as its records can be (each list as long as
/// its count type allows).
pub(crate) fn stream_rule(data: &[u8]) -> Option<Rule> {
    let window = data.get(..data.len().min(1 << 20)).unwrap_or(data);
    let complete = window.windows(12).any(|w| w.starts_with(b"end_header") && matches!(w[10], b'\n' | b'\r'));
    if !complete {
        return None;
    }
    let Ok(h) = header::parse(data) else { return Some(Rule::Free) };
    if h.encoding == header::Encoding::Ascii {
        return Some(Rule::Text { from: 0 });
    }
    let body = |size: &dyn Fn(&header::Element) -> u64| {
        h.elements.iter().fold(h.body_start as u64, |sum, el| sum.saturating_add(el.count.saturating_mul(size(el))))
    };
    let (end, least) = (body(&header::Element::max_binary_size), body(&|el| el.min_binary_size() as u64));
    Some(Rule::EndsBy { end, least })
}

/// Whether every coordinate is exactly an `f32` (then `float` loses nothing).
fn positions_fit_f32(mesh: &Mesh) -> bool {
    mesh.vertices.positions.iter().all(|p| p.to_array().iter().all(|&c| f64::from(c as f32).to_bits() == c.to_bits()))
}

/// Writes `mesh` as PLY: binary little endian, or ascii with `opts.ascii`.
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, opts: &WriteOptions) -> Result<()> {
    use std::fmt::Write as _;
    let v = &mesh.vertices;
    let double = !positions_fit_f32(mesh);
    let long_faces = mesh.faces.iter().any(|f| f.len() > 255);
    let index_ty = if v.len() > i32::MAX as usize { "uint" } else { "int" };
    let mut h = String::new();
    h.push_str("ply\n");
    h.push_str(if opts.ascii { "format ascii 1.0\n" } else { "format binary_little_endian 1.0\n" });
    h.push_str("comment written by octowrap\n");
    let _ = writeln!(h, "element vertex {}", v.len());
    let coord = if double { "double" } else { "float" };
    for c in ["x", "y", "z"] {
        let _ = writeln!(h, "property {coord} {c}");
    }
    if v.normals.is_some() {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if v.colors.is_some() {
        h.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    if v.intensities.is_some() {
        h.push_str("property float intensity\n");
    }
    if !mesh.faces.is_empty() {
        let _ = writeln!(h, "element face {}", mesh.faces.len());
        let count_ty = if long_faces { "int" } else { "uchar" };
        let _ = writeln!(h, "property list {count_ty} {index_ty} vertex_indices");
    }
    h.push_str("end_header\n");
    let io = |e| Error::io(e);
    w.write_all(h.as_bytes()).map_err(io)?;
    if opts.ascii { write_ascii(w, mesh, double) } else { write_binary(w, mesh, double, long_faces) }
}

fn write_ascii(w: &mut dyn Write, mesh: &Mesh, double: bool) -> Result<()> {
    use std::fmt::Write as _;
    let v = &mesh.vertices;
    let mut s = LineWriter::new(w);
    for (i, p) in v.positions.iter().enumerate() {
        // Writing to a String cannot fail.
        if double {
            let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
        } else {
            let _ = write!(s, "{} {} {}", p.x as f32, p.y as f32, p.z as f32);
        }
        if let Some(n) = v.normals.as_ref().and_then(|n| n.get(i)) {
            let _ = write!(s, " {} {} {}", n.x, n.y, n.z);
        }
        if let Some([r, g, b]) = v.colors.as_ref().and_then(|c| c.get(i)) {
            let _ = write!(s, " {r} {g} {b}");
        }
        if let Some(t) = v.intensities.as_ref().and_then(|t| t.get(i)) {
            let _ = write!(s, " {t}");
        }
        s.end_line()?;
    }
    s.counted_faces(&mesh.faces)?;
    s.finish()
}

fn write_binary(w: &mut dyn Write, mesh: &Mesh, double: bool, long_faces: bool) -> Result<()> {
    let v = &mesh.vertices;
    let mut b: Vec<u8> = Vec::with_capacity(1 << 20);
    for (i, p) in v.positions.iter().enumerate() {
        if double {
            for c in p.to_array() {
                b.extend_from_slice(&c.to_le_bytes());
            }
        } else {
            for c in p.to_array() {
                b.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        if let Some(n) = v.normals.as_ref().and_then(|n| n.get(i)) {
            for c in n.to_array() {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(c) = v.colors.as_ref().and_then(|c| c.get(i)) {
            b.extend_from_slice(c);
        }
        if let Some(t) = v.intensities.as_ref().and_then(|t| t.get(i)) {
            b.extend_from_slice(&t.to_le_bytes());
        }
        if b.len() >= (1 << 20) - 64 {
            w.write_all(&b).map_err(Error::io)?;
            b.clear();
        }
    }
    for f in mesh.faces.iter() {
        if long_faces {
            b.extend_from_slice(&(f.len() as u32).to_le_bytes());
        } else {
            b.push(f.len() as u8);
        }
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
        if b.len() >= 1 << 20 {
            w.write_all(&b).map_err(Error::io)?;
            b.clear();
        }
    }
    w.write_all(&b).map_err(Error::io)
}

#[cfg(test)]
mod tests;
