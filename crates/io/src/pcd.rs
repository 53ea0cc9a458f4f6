//! PCD reading: the Point Cloud Library's point cloud format, versions 0.7 and older (`.5`).
//!
//! Follows the PCL file-format documentation ("The PCD (Point Cloud Data) file format",
//! pointclouds.org) and PCL's reader (`io/src/pcd_io.cpp`) where the documentation is silent.
//!
//! A text header of `KEY values` lines (`VERSION`, `FIELDS`, `SIZE`, `TYPE`, `COUNT`, `WIDTH`,
//! `HEIGHT`, `VIEWPOINT`, `POINTS`, `DATA`; `#` comments) ends with the `DATA` line, after which
//! the body is one of:
//!
//! * `ascii`: one point per line, `COUNT` values per field, fields in header order;
//! * `binary`: the points one after the other ("array of structures"), each field's `SIZE × COUNT`
//!   little-endian bytes in header order;
//! * `binary_compressed`: `u32` compressed size, `u32` uncompressed size, then an LZF stream
//!   (liblzf's format, see [`lzf_decompress`]) that expands to the fields one after the other
//!   ("structure of arrays": every point's `x`, then every point's `y`, ...).
//!
//! # What is read
//! * `x y z` (required, any numeric type) become positions in `f64`.
//! * `normal_x normal_y normal_z` become normals when all three are present.
//! * `rgb` or `rgba` (`SIZE 4`, `TYPE F` or `U`: a packed `0xAARRGGBB` word, stored in a float's
//!   bits when `TYPE F`) become colours.
//! * `intensity` (any numeric type) becomes intensities.
//! * Every other field is skipped (any `COUNT`); of a field with `COUNT > 1` that we read, the
//!   first value is taken. Missing `COUNT` means 1 for every field; missing `WIDTH` means `POINTS`,
//!   missing `HEIGHT` means 1; missing `POINTS` means `WIDTH × HEIGHT`.
//!
//! # Decisions
//! * **NaN points are dropped** unless [`ReadOptions::keep_invalid`](crate::ReadOptions) is set.
//!   Organised clouds (`HEIGHT > 1`, a depth camera's pixel grid) mark pixels without a measurement
//!   by `x = y = z = NaN`. They carry no geometry, so by default every point whose `x`, `y` or `z`
//!   is NaN is left out and the image grid is not kept; with `keep_invalid` every record becomes a
//!   point, in file order, and the grid is `WIDTH x HEIGHT` again.
//! * **`VIEWPOINT tx ty tz qw qx qy qz` is applied**: it is the sensor pose (PCL's
//!   `sensor_origin_` and `sensor_orientation_`), and each point `p` (and normal `n`) is brought
//!   into the common frame as `R(q) p + t` (`R(q) n`). The default `0 0 0 1 0 0 0` changes
//!   nothing. A non-unit quaternion is normalised; a zero quaternion is an error.

use octowrap_geom::DVec3;
use octowrap_geom::glam::DQuat;
use octowrap_mesh::{FaceList, PointCloud};

mod lzf;

use lzf::{LZF_MAX_RATIO, lzf_decompress};

use crate::budget::{Budget, point_bytes};
use crate::source::Rule;
use crate::text::{Lines, parse_f64, tokens};
use crate::{Error, Location, Mesh, ReadOptions, Result, justify};

/// Reads a whole PCD input. A binary body must end where its points do: anything after is
/// trailing data and refused, but for the zeros PCL pads a `binary_compressed` file with (never
/// more than the expanded body's size).
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let header = Header::parse(data)?;
    let max = opts.limits.max_points;
    let mut budget = Budget::new(&opts.limits, data.len());
    if header.point_step == 0 {
        return Err(Error::invalid(header.data_line, "the point records are 0 bytes long (every COUNT is 0)"));
    }
    let at = Location::Byte(header.data_start as u64);
    let n = justify(header.points, 0, usize::MAX, max, "points", at)?;
    let r = &header.roles;
    let each = point_bytes(r.normal.is_some(), r.rgb.is_some(), r.intensity.is_some());
    let mut cloud = match header.data {
        DataKind::Ascii => {
            budget.charge_n(n.min(data.len()), each, "points", header.data_line)?;
            read_ascii(data, &header, max, opts.keep_invalid)?
        }
        DataKind::Binary => {
            let body = data.get(header.data_start..).unwrap_or_default();
            justify(header.points, header.point_step as u64, body.len(), max, "points", at)?;
            trailing(data, header.data_start as u64 + n as u64 * header.point_step as u64)?;
            budget.charge_n(n, each, "points", at)?;
            read_binary(body, &header, Layout::Interleaved, header.data_start as u64, opts.keep_invalid)?
        }
        DataKind::Compressed => {
            let body = decompress_body(data, &header, &mut budget)?;
            budget.charge_n(n, each, "points", at)?;
            read_binary(&body, &header, Layout::FieldMajor, header.data_start as u64, opts.keep_invalid)?
        }
    };
    if let Some((t, q)) = header.viewpoint {
        if t != DVec3::ZERO || q != DQuat::IDENTITY {
            for p in &mut cloud.positions {
                *p = q * *p + t;
            }
            if let Some(normals) = &mut cloud.normals {
                let qf = q.as_quat();
                for n in normals {
                    *n = qf * *n;
                }
            }
        }
    }
    Ok(Mesh { vertices: cloud, faces: FaceList::default() })
}

/// Refuses anything but blanks after byte `end`.
fn trailing(data: &[u8], end: u64) -> Result<()> {
    let rest = usize::try_from(end).ok().and_then(|e| data.get(e..)).unwrap_or_default();
    if rest.trim_ascii().is_empty() {
        return Ok(());
    }
    Err(Error::invalid(
        Location::Byte(end),
        format!("trailing data: {} bytes follow the body the header declares, which ends at byte {end}", rest.len()),
    ))
}

/// What the header says about the bytes to come, once its `DATA` line is in `data`: an ascii body
/// is text; a binary body ends where its points do.
pub(crate) fn stream_rule(data: &[u8]) -> Option<Rule> {
    let window = data.get(..data.len().min(1 << 20)).unwrap_or(data);
    let has_data_line = window.split(|&c| c == b'\n').rev().skip(1).any(|l| l.trim_ascii_start().starts_with(b"DATA"));
    if !has_data_line {
        return None;
    }
    let Ok(h) = Header::parse(data) else { return Some(Rule::Free) };
    let start = h.data_start as u64;
    match h.data {
        DataKind::Ascii => Some(Rule::Text { from: h.data_start }),
        DataKind::Binary => {
            let end = start.saturating_add(h.points.saturating_mul(h.point_step as u64));
            Some(Rule::EndsBy { end, least: end })
        }
        DataKind::Compressed => {
            let sizes = data.get(h.data_start..h.data_start.checked_add(4)?)?;
            let compressed = u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]);
            // PCL pads the file with zeros, never beyond the expanded size.
            let pad = h.points.saturating_mul(h.point_step as u64);
            let least = start + 8 + u64::from(compressed);
            Some(Rule::EndsBy { end: least.saturating_add(pad), least })
        }
    }
}

/// How the body is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum DataKind {
    Ascii,
    Binary,
    Compressed,
}

/// One `FIELDS` entry.
#[derive(Clone, Debug)]
struct Field {
    name: String,
    /// Bytes per value: 1, 2, 4 or 8.
    size: usize,
    /// `F`, `I` or `U`.
    ty: u8,
    /// Values per point.
    count: usize,
    /// Byte offset of the field within one point record (`SIZE × COUNT` of the fields before).
    offset: usize,
}

/// The fields we read, as indices into [`Header::fields`].
#[derive(Clone, Copy, Debug, Default)]
struct Roles {
    xyz: [usize; 3],
    normal: Option<[usize; 3]>,
    rgb: Option<usize>,
    intensity: Option<usize>,
}

#[derive(Clone, Debug)]
struct Header {
    fields: Vec<Field>,
    roles: Roles,
    /// Bytes per point record (sum of `SIZE × COUNT`).
    point_step: usize,
    /// Values per point (sum of `COUNT`), the tokens of an ascii line.
    values_per_point: usize,
    points: u64,
    viewpoint: Option<(DVec3, DQuat)>,
    data: DataKind,
    /// Byte offset of the first body byte.
    data_start: usize,
    /// The `DATA` line.
    data_line: Location,
}

impl Header {
    fn parse(data: &[u8]) -> Result<Self> {
        let mut lines = Lines::new(data);
        let mut names: Option<Vec<String>> = None;
        let mut sizes: Option<Vec<usize>> = None;
        let mut types: Option<Vec<u8>> = None;
        let mut counts: Option<Vec<usize>> = None;
        let (mut width, mut height, mut points) = (None, None, None);
        let mut viewpoint = None;
        let kind = loop {
            let Some(line) = lines.next_content_line(b'#') else {
                return Err(Error::invalid(
                    lines.location(),
                    "PCD header ends before its DATA line (expected FIELDS, SIZE, TYPE, ..., DATA)",
                ));
            };
            let mut it = tokens(line);
            let Some(key) = it.next() else { continue };
            let values: Vec<&[u8]> = it.collect();
            let key = String::from_utf8_lossy(key).to_ascii_uppercase();
            let loc = lines.location();
            match key.as_str() {
                "VERSION" => {}
                "FIELDS" | "COLUMNS" => {
                    names = Some(values.iter().map(|v| String::from_utf8_lossy(v).into_owned()).collect());
                }
                "SIZE" => sizes = Some(parse_list(&values, loc, "SIZE", |v| matches!(v, 1 | 2 | 4 | 8))?),
                "COUNT" => counts = Some(parse_list(&values, loc, "COUNT", |v| v <= 1 << 20)?),
                "TYPE" => {
                    let mut t = Vec::with_capacity(values.len());
                    for v in &values {
                        match v {
                            [c @ (b'F' | b'I' | b'U')] => t.push(*c),
                            [c @ (b'f' | b'i' | b'u')] => t.push(c.to_ascii_uppercase()),
                            _ => {
                                return Err(Error::invalid(
                                    loc,
                                    format!("expected a TYPE of F, I or U, found '{}'", String::from_utf8_lossy(v)),
                                ));
                            }
                        }
                    }
                    types = Some(t);
                }
                "WIDTH" => width = Some(parse_one(&values, loc, "WIDTH")?),
                "HEIGHT" => height = Some(parse_one(&values, loc, "HEIGHT")?),
                "POINTS" => points = Some(parse_one(&values, loc, "POINTS")?),
                "VIEWPOINT" => viewpoint = Some(parse_viewpoint(&values, loc)?),
                "DATA" => {
                    break match values.first().map(|v| v.to_ascii_lowercase()).as_deref() {
                        Some(b"ascii") => DataKind::Ascii,
                        Some(b"binary") => DataKind::Binary,
                        Some(b"binary_compressed") => DataKind::Compressed,
                        other => {
                            return Err(Error::unsupported(
                                loc,
                                format!(
                                    "expected DATA ascii, binary or binary_compressed, found '{}'",
                                    String::from_utf8_lossy(other.unwrap_or_default())
                                ),
                            ));
                        }
                    };
                }
                _ => {
                    return Err(Error::invalid(
                        loc,
                        format!("expected a PCD header keyword (FIELDS, SIZE, TYPE, ..., DATA), found '{key}'"),
                    ));
                }
            }
        };
        let data_loc = lines.location();
        let data_start = lines.offset();
        let names = names.ok_or_else(|| Error::invalid(data_loc, "PCD header has no FIELDS line"))?;
        let sizes = sizes.ok_or_else(|| Error::invalid(data_loc, "PCD header has no SIZE line"))?;
        let types = types.ok_or_else(|| Error::invalid(data_loc, "PCD header has no TYPE line"))?;
        let counts = counts.unwrap_or_else(|| vec![1; names.len()]);
        let (fields, point_step, values_per_point) = build_fields(names, sizes, types, counts, data_loc)?;
        let roles = Roles::find(&fields, data_loc)?;
        let points = point_count(points, width, height, data_loc)?;
        Ok(Self {
            fields,
            roles,
            point_step,
            values_per_point,
            points,
            viewpoint,
            data: kind,
            data_start,
            data_line: data_loc,
        })
    }
}

/// The point count: `POINTS`, checked against `WIDTH × HEIGHT` when both are given (`HEIGHT`
/// defaults to 1).
fn point_count(points: Option<u64>, width: Option<u64>, height: Option<u64>, at: Location) -> Result<u64> {
    Ok(match (points, width, height) {
        (Some(p), Some(w), h) => {
            let wh = w.checked_mul(h.unwrap_or(1));
            if wh != Some(p) {
                return Err(Error::invalid(
                    at,
                    format!("POINTS {p} differs from WIDTH {w} × HEIGHT {}", h.unwrap_or(1)),
                ));
            }
            p
        }
        (Some(p), None, _) => p,
        (None, Some(w), h) => {
            w.checked_mul(h.unwrap_or(1)).ok_or_else(|| Error::limit(at, "WIDTH × HEIGHT overflows"))?
        }
        (None, None, _) => return Err(Error::invalid(at, "PCD header gives neither POINTS nor WIDTH")),
    })
}

/// Zips the `FIELDS`, `SIZE`, `TYPE` and `COUNT` lists into fields with their record offsets;
/// returns them with the record size and the number of values per point.
fn build_fields(
    names: Vec<String>,
    sizes: Vec<usize>,
    types: Vec<u8>,
    counts: Vec<usize>,
    at: Location,
) -> Result<(Vec<Field>, usize, usize)> {
    for (what, n) in [("SIZE", sizes.len()), ("TYPE", types.len()), ("COUNT", counts.len())] {
        if n != names.len() {
            return Err(Error::invalid(
                at,
                format!("FIELDS names {} fields but {what} gives {n} entries", names.len()),
            ));
        }
    }
    let mut fields = Vec::with_capacity(names.len());
    let (mut offset, mut values_per_point) = (0usize, 0usize);
    for (((name, size), ty), count) in names.into_iter().zip(sizes).zip(types).zip(counts) {
        if ty == b'F' && !matches!(size, 4 | 8) {
            return Err(Error::unsupported(
                at,
                format!("field '{name}' is a float of {size} bytes; only 4 and 8 are read"),
            ));
        }
        fields.push(Field { name, size, ty, count, offset });
        // SIZE ≤ 8 and COUNT ≤ 2^20 per field, and the field count is bounded by the header's
        // length, so these sums cannot overflow in practice; check anyway.
        offset = offset.checked_add(size * count).ok_or_else(|| Error::limit(at, "PCD point record size overflows"))?;
        values_per_point = values_per_point.saturating_add(count);
    }
    Ok((fields, offset, values_per_point))
}

impl Roles {
    fn find(fields: &[Field], at: Location) -> Result<Self> {
        let find = |name: &str| fields.iter().position(|f| f.name == name && f.count >= 1);
        let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
            let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
            return Err(Error::unsupported(
                at,
                format!("PCD fields x, y and z are required, found only '{}'", names.join(" ")),
            ));
        };
        let xyz = [x, y, z];
        let normal = match (find("normal_x"), find("normal_y"), find("normal_z")) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        let rgb = find("rgb").or_else(|| find("rgba")).filter(|&i| fields[i].size == 4);
        Ok(Self { xyz, normal, rgb, intensity: find("intensity") })
    }
}

fn parse_list(values: &[&[u8]], at: Location, what: &str, ok: impl Fn(usize) -> bool) -> Result<Vec<usize>> {
    values
        .iter()
        .map(|v| {
            std::str::from_utf8(v).ok().and_then(|s| s.parse::<usize>().ok()).filter(|&n| ok(n)).ok_or_else(|| {
                Error::invalid(at, format!("expected a valid {what} value, found '{}'", String::from_utf8_lossy(v)))
            })
        })
        .collect()
}

fn parse_one(values: &[&[u8]], at: Location, what: &str) -> Result<u64> {
    match values {
        [v] => std::str::from_utf8(v).ok().and_then(|s| s.parse::<u64>().ok()).ok_or_else(|| {
            Error::invalid(at, format!("expected a count after {what}, found '{}'", String::from_utf8_lossy(v)))
        }),
        _ => Err(Error::invalid(at, format!("expected one count after {what}, found {} values", values.len()))),
    }
}

fn parse_viewpoint(values: &[&[u8]], at: Location) -> Result<(DVec3, DQuat)> {
    let v: Option<Vec<f64>> = values.iter().map(|t| parse_f64(t).filter(|x| x.is_finite())).collect();
    match v.as_deref() {
        Some(&[tx, ty, tz, qw, qx, qy, qz]) => {
            let q = DQuat::from_xyzw(qx, qy, qz, qw);
            let len = q.length();
            if !(len > 1e-12 && len.is_finite()) {
                return Err(Error::invalid(at, "VIEWPOINT quaternion has zero length"));
            }
            Ok((DVec3::new(tx, ty, tz), q / len))
        }
        _ => Err(Error::invalid(at, "expected VIEWPOINT tx ty tz qw qx qy qz (7 finite numbers)")),
    }
}

/// Where a field value of point `i` sits in a binary body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layout {
    /// `binary`: point records one after the other.
    Interleaved,
    /// `binary_compressed` once expanded: each field's values for all points, field after field.
    FieldMajor,
}

/// Reads points from a binary body whose size the caller has checked to hold `header.points`
/// records (every access is still bounds-checked). `base` is the body's offset in the file.
fn read_binary(body: &[u8], h: &Header, layout: Layout, base: u64, keep_invalid: bool) -> Result<PointCloud> {
    let n = usize::try_from(h.points).map_err(|_| Error::limit(Location::Byte(base), "too many points"))?;
    let raw = |i: usize, f: usize| -> Result<&[u8]> {
        let field = &h.fields[f];
        let start = match layout {
            Layout::Interleaved => i.checked_mul(h.point_step).and_then(|s| s.checked_add(field.offset)),
            Layout::FieldMajor => n
                .checked_mul(field.offset)
                .and_then(|s| s.checked_add(i.checked_mul(field.size.checked_mul(field.count)?)?)),
        };
        start
            .and_then(|s| body.get(s..s.checked_add(field.size)?))
            .ok_or_else(|| Error::invalid(Location::Byte(base), format!("PCD body too short for point {i}")))
    };
    let mut b = Builder::new(h, n, keep_invalid);
    for i in 0..n {
        b.push(
            h,
            |f| raw(i, f).map(|r| decode(r, h.fields[f].ty)),
            |f| raw(i, f).map(|r| u32::from_le_bytes([r[0], r[1], r[2], r[3]])),
        )?;
    }
    Ok(b.finish())
}

/// Collects points, dropping NaN ones unless asked to keep them.
struct Builder {
    cloud: PointCloud,
    keep_invalid: bool,
}

impl Builder {
    fn new(h: &Header, n: usize, keep_invalid: bool) -> Self {
        let r = &h.roles;
        Self {
            keep_invalid,
            cloud: PointCloud {
                positions: Vec::with_capacity(n),
                normals: r.normal.map(|_| Vec::with_capacity(n)),
                colors: r.rgb.map(|_| Vec::with_capacity(n)),
                intensities: r.intensity.map(|_| Vec::with_capacity(n)),
            },
        }
    }

    /// Adds one point whose field values `value(field index)` gives (the first of each field);
    /// `bits(field index)` gives a packed colour word.
    fn push(
        &mut self,
        h: &Header,
        mut value: impl FnMut(usize) -> Result<f64>,
        bits: impl FnOnce(usize) -> Result<u32>,
    ) -> Result<()> {
        let r = &h.roles;
        let p = DVec3::new(value(r.xyz[0])?, value(r.xyz[1])?, value(r.xyz[2])?);
        if p.is_nan() && !self.keep_invalid {
            return Ok(());
        }
        self.cloud.positions.push(p);
        if let (Some(nf), Some(normals)) = (r.normal, &mut self.cloud.normals) {
            let n = DVec3::new(value(nf[0])?, value(nf[1])?, value(nf[2])?);
            normals.push(n.as_vec3());
        }
        if let (Some(f), Some(colors)) = (r.rgb, &mut self.cloud.colors) {
            let bits = bits(f)?;
            colors.push([(bits >> 16) as u8, (bits >> 8) as u8, bits as u8]);
        }
        if let (Some(f), Some(intensities)) = (r.intensity, &mut self.cloud.intensities) {
            intensities.push(value(f)? as f32);
        }
        Ok(())
    }

    fn finish(self) -> PointCloud {
        self.cloud
    }
}

/// Decodes one little-endian value of `bytes.len()` (1, 2, 4 or 8) bytes and type `ty`.
fn decode(bytes: &[u8], ty: u8) -> f64 {
    let mut b = [0u8; 8];
    let n = bytes.len().min(8);
    b[..n].copy_from_slice(&bytes[..n]);
    match (ty, n) {
        (b'F', 4) => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        (b'F', _) => f64::from_le_bytes(b),
        (b'I', 1) => f64::from(b[0] as i8),
        (b'I', 2) => f64::from(i16::from_le_bytes([b[0], b[1]])),
        (b'I', 4) => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        (b'I', _) => i64::from_le_bytes(b) as f64,
        // `U` of any size: the zero-padded little-endian word.
        _ => u64::from_le_bytes(b) as f64,
    }
}

fn read_ascii(data: &[u8], h: &Header, max: u64, keep_invalid: bool) -> Result<PointCloud> {
    let body = data.get(h.data_start..).unwrap_or_default();
    // Each value takes at least one character and one separator; the last point's line may
    // lack its newline, hence the one extra byte granted.
    let min_each = (h.values_per_point as u64).saturating_mul(2).max(1);
    let line0 = match h.data_line {
        Location::Line(l) => l,
        _ => 0,
    };
    let n = justify(h.points, min_each, body.len().saturating_add(1), max, "points", h.data_line)?;
    let mut lines = Lines::new(body);
    let at = |l: &Lines<'_>| match l.location() {
        Location::Line(k) => Location::Line(k + line0),
        other => other,
    };
    let mut b = Builder::new(h, n, keep_invalid);
    let mut vals = vec![0f64; h.fields.len()];
    let mut read = 0usize;
    while read < n {
        let Some(line) = lines.next_line() else {
            return Err(Error::invalid(
                at(&lines),
                format!("expected {n} points in the ascii body, found the end of the input after {read}"),
            ));
        };
        if line.trim_ascii().is_empty() {
            continue;
        }
        let mut it = tokens(line);
        let mut seen = 0usize;
        let mut rgb_bits = 0u32;
        for (f, field) in h.fields.iter().enumerate() {
            for k in 0..field.count {
                let Some(tok) = it.next() else {
                    return Err(Error::invalid(
                        at(&lines),
                        format!("expected {} values per point, found {seen}", h.values_per_point),
                    ));
                };
                seen += 1;
                if k == 0 && Some(f) == h.roles.rgb {
                    rgb_bits = parse_packed_rgb(tok, field.ty).ok_or_else(|| {
                        Error::invalid(
                            at(&lines),
                            format!(
                                "expected a packed colour for '{}', found '{}'",
                                field.name,
                                String::from_utf8_lossy(tok)
                            ),
                        )
                    })?;
                } else if k == 0 {
                    vals[f] = parse_ascii_value(tok, field).ok_or_else(|| {
                        Error::invalid(
                            at(&lines),
                            format!(
                                "expected a number for field '{}', found '{}'",
                                field.name,
                                String::from_utf8_lossy(tok)
                            ),
                        )
                    })?;
                }
            }
        }
        if it.next().is_some() {
            let found = seen + 1 + it.count();
            return Err(Error::invalid(
                at(&lines),
                format!("expected {} values per point, found {found}", h.values_per_point),
            ));
        }
        b.push(h, |f| Ok(vals[f]), |_| Ok(rgb_bits))?;
        read += 1;
    }
    Ok(b.finish())
}

/// Parses a packed `0xAARRGGBB` colour word: a `TYPE F` value carries it in its `f32` bits.
fn parse_packed_rgb(tok: &[u8], ty: u8) -> Option<u32> {
    let s = std::str::from_utf8(tok).ok()?;
    if ty == b'F' { s.parse::<f32>().ok().map(f32::to_bits) } else { s.parse::<u32>().ok() }
}

/// Parses one ascii value: integers as integers (exact beyond 2^53), falling back to a float parse.
fn parse_ascii_value(tok: &[u8], field: &Field) -> Option<f64> {
    let s = std::str::from_utf8(tok).ok()?;
    match field.ty {
        b'F' if field.size == 4 => s.parse::<f32>().ok().map(f64::from),
        b'F' => s.parse::<f64>().ok(),
        b'U' => s.parse::<u64>().ok().map(|v| v as f64).or_else(|| s.parse::<f64>().ok()),
        _ => s.parse::<i64>().ok().map(|v| v as f64).or_else(|| s.parse::<f64>().ok()),
    }
}

/// Expands a `binary_compressed` body after checking its sizes against the header and limits.
fn decompress_body(data: &[u8], h: &Header, budget: &mut Budget) -> Result<Vec<u8>> {
    let start = h.data_start;
    let at = Location::Byte(start as u64);
    let word = |k: usize| -> Result<u32> {
        data.get(start + k..start + k + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).ok_or_else(|| {
            Error::invalid(
                Location::Byte((start + k) as u64),
                "expected the binary_compressed sizes (two u32), found the end of the input",
            )
        })
    };
    let compressed = word(0)? as usize;
    let uncompressed = u64::from(word(4)?);
    let expect = h.points.saturating_mul(h.point_step as u64);
    if uncompressed != expect {
        return Err(Error::invalid(
            Location::Byte(start as u64 + 4),
            format!(
                "binary_compressed expands to {uncompressed} bytes, but {} points of {} bytes need {expect}",
                h.points, h.point_step
            ),
        ));
    }
    let payload = data.get(start + 8..).and_then(|rest| rest.get(..compressed)).ok_or_else(|| {
        Error::invalid(
            Location::Byte(start as u64 + 8),
            format!(
                "binary_compressed declares {compressed} compressed bytes, but only {} remain",
                data.len().saturating_sub(start + 8)
            ),
        )
    })?;
    let end = start + 8 + compressed;
    let pad = data.get(end..).unwrap_or_default();
    if pad.len() as u64 > uncompressed || pad.iter().any(|&c| c != 0) {
        trailing(data, end as u64)?;
    }
    budget.charge(uncompressed, &|| "the binary_compressed body".to_owned(), at)?;
    if uncompressed > (compressed as u64).saturating_mul(LZF_MAX_RATIO) {
        return Err(Error::invalid(
            at,
            format!("{compressed} LZF bytes cannot expand to {uncompressed} (LZF expands at most {LZF_MAX_RATIO}×)"),
        ));
    }
    lzf_decompress(payload, uncompressed as usize).map_err(|e| {
        Error::invalid(Location::Byte(start as u64 + 8 + e.input_offset as u64), format!("broken LZF data: {}", e.what))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;
    use proptest::prelude::*;

    fn opts() -> ReadOptions {
        ReadOptions::default()
    }

    const HEAD: &str = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";

    fn ascii_xyz_rgb() -> Vec<u8> {
        // rgb 0x00FF8001 packed in a float's bits: its decimal form.
        let rgb = f32::from_bits(0x00FF_8001);
        format!(
            "{HEAD}FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\n\
             VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n1 2 3 {rgb:e}\nnan nan nan {rgb:e}\n4.5 5 6 {rgb:e}\n"
        )
        .into_bytes()
    }

    /// x y z (f32), a skipped 2-value u8 field, normals, intensity (u16): 12 + 2 + 12 + 2 = 28 bytes.
    fn records() -> Vec<(DVec3, [f32; 3], u16)> {
        vec![
            (DVec3::new(1.0, 2.0, 3.0), [0.0, 0.0, 1.0], 7),
            (DVec3::splat(f64::NAN), [0.0, 1.0, 0.0], 8),
            (DVec3::new(-1.5, 0.25, 8.0), [1.0, 0.0, 0.0], 65535),
        ]
    }

    const RICH_FIELDS: &str = "FIELDS x y z pad normal_x normal_y normal_z intensity\nSIZE 4 4 4 1 4 4 4 2\n\
         TYPE F F F U F F F U\nCOUNT 1 1 1 2 1 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\n";

    fn binary_rich() -> Vec<u8> {
        let mut v = format!("{HEAD}{RICH_FIELDS}DATA binary\n").into_bytes();
        for (p, n, i) in records() {
            for c in p.to_array() {
                v.extend_from_slice(&(c as f32).to_le_bytes());
            }
            v.extend_from_slice(&[9, 9]);
            for c in n {
                v.extend_from_slice(&c.to_le_bytes());
            }
            v.extend_from_slice(&i.to_le_bytes());
        }
        v
    }

    fn compressed_rich() -> Vec<u8> {
        let recs = records();
        let mut soa = Vec::new();
        for axis in 0..3 {
            for (p, _, _) in &recs {
                soa.extend_from_slice(&(p[axis] as f32).to_le_bytes());
            }
        }
        for _ in &recs {
            soa.extend_from_slice(&[9, 9]);
        }
        for axis in 0..3 {
            for (_, n, _) in &recs {
                soa.extend_from_slice(&n[axis].to_le_bytes());
            }
        }
        for (_, _, i) in &recs {
            soa.extend_from_slice(&i.to_le_bytes());
        }
        let z = lzf::tests::literal_runs(&soa);
        let mut v = format!("{HEAD}{RICH_FIELDS}DATA binary_compressed\n").into_bytes();
        v.extend_from_slice(&(z.len() as u32).to_le_bytes());
        v.extend_from_slice(&(soa.len() as u32).to_le_bytes());
        v.extend_from_slice(&z);
        v
    }

    fn check_rich(m: &Mesh) {
        let c = &m.vertices;
        assert_eq!(c.positions, vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-1.5, 0.25, 8.0)]);
        assert_eq!(c.normals.as_deref(), Some(&[octowrap_geom::Vec3::Z, octowrap_geom::Vec3::X][..]));
        assert_eq!(c.intensities.as_deref(), Some(&[7.0, 65535.0][..]));
        assert!(c.colors.is_none());
    }

    #[test]
    fn ascii_with_packed_rgb_drops_nan_points() {
        let m = read(&ascii_xyz_rgb(), &opts()).unwrap();
        assert_eq!(m.vertices.positions, vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.5, 5.0, 6.0)]);
        assert_eq!(m.vertices.colors.as_deref(), Some(&[[255, 128, 1], [255, 128, 1]][..]));
    }

    #[test]
    fn binary_and_compressed_agree() {
        check_rich(&read(&binary_rich(), &opts()).unwrap());
        check_rich(&read(&compressed_rich(), &opts()).unwrap());
    }

    #[test]
    fn old_header_without_count_and_viewpoint() {
        let d = b"VERSION .5\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3";
        assert_eq!(read(d, &opts()).unwrap().vertices.positions, vec![DVec3::new(1.0, 2.0, 3.0)]);
    }

    #[test]
    fn viewpoint_rotates_then_translates() {
        // 180° about x (qw 0, qx 1), then +10 in x.
        let d = format!(
            "{HEAD}FIELDS x y z rgba\nSIZE 4 4 4 4\nTYPE F F F U\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 10 0 0 0 1 0 0\n\
             POINTS 1\nDATA ascii\n1 2 3 4278255360\n"
        );
        let m = read(d.as_bytes(), &opts()).unwrap();
        assert!((m.vertices.positions[0] - DVec3::new(11.0, -2.0, -3.0)).length() < 1e-12);
        assert_eq!(m.vertices.colors.as_deref(), Some(&[[0, 255, 0]][..]));
    }

    #[test]
    fn hostile_headers_fail_cleanly() {
        let huge = format!(
            "{HEAD}FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000000000\nPOINTS 1000000000000\nDATA binary\n"
        );
        assert_eq!(read(huge.as_bytes(), &opts()).unwrap_err().kind, ErrorKind::LimitExceeded);
        let asc = huge.replace("DATA binary", "DATA ascii");
        assert_eq!(read(asc.as_bytes(), &opts()).unwrap_err().kind, ErrorKind::LimitExceeded);
        let mut z = huge.replace("DATA binary", "DATA binary_compressed").into_bytes();
        z.extend_from_slice(&[4, 0, 0, 0, 0, 0, 0, 0xff, 0, 1, 2, 3]);
        assert!(read(&z, &opts()).is_err());
        let no_xyz = format!("{HEAD}FIELDS a b\nSIZE 4 4\nTYPE F F\nPOINTS 0\nDATA ascii\n");
        assert_eq!(read(no_xyz.as_bytes(), &opts()).unwrap_err().kind, ErrorKind::Unsupported);
        let mismatch = format!("{HEAD}FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 0\nDATA ascii\n");
        let e = read(mismatch.as_bytes(), &opts()).unwrap_err();
        assert!(e.to_string().contains("SIZE gives 2"), "{e}");
        let bad_line = format!("{HEAD}FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA ascii\n1 2 3\n1.5 2.5\n");
        let e = read(bad_line.as_bytes(), &opts()).unwrap_err();
        assert_eq!(e.location, Location::Line(9), "{e}");
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        for input in [ascii_xyz_rgb(), binary_rich(), compressed_rich()] {
            let full = read(&input, &opts());
            assert!(full.is_ok());
            for n in 0..input.len() {
                // Truncating the ascii body's last line can still leave a valid, shorter number.
                let _ = read(&input[..n], &opts());
            }
            // Strict truncations of binary bodies always fail.
            if !input.ends_with(b"\n") {
                for n in 0..input.len() {
                    assert!(read(&input[..n], &opts()).is_err(), "prefix {n} of {} read", input.len());
                }
            }
        }
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(input in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = read(&input, &opts());
        }

        #[test]
        fn random_bodies_never_panic(body in proptest::collection::vec(any::<u8>(), 0..400), kind in 0usize..3) {
            let data = ["ascii", "binary", "binary_compressed"][kind];
            let mut v = format!("{HEAD}{RICH_FIELDS}DATA {data}\n").into_bytes();
            v.extend_from_slice(&body);
            let _ = read(&v, &opts());
        }

        #[test]
        fn mutated_files_never_panic(pos in 0usize..2000, byte in any::<u8>(), which in 0usize..3) {
            let mut v = [ascii_xyz_rgb(), binary_rich(), compressed_rich()][which].clone();
            let k = pos % v.len();
            v[k] = byte;
            let _ = read(&v, &opts());
        }
    }

    #[test]
    fn real_pcl_files() {
        let Some(dir) = octowrap_testdata::dir("pcl-pcd") else { return };
        for (name, count, normals, colors) in
            [("bunny.pcd", 397, false, false), ("bun0.pcd", 397, true, false), ("milk.pcd", 13_704, false, false)]
        {
            let data = std::fs::read(dir.join(name)).unwrap();
            let h = Header::parse(&data).unwrap();
            assert_eq!(h.points, count, "{name}");
            let m = read(&data, &opts()).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(m.vertices.len(), count as usize, "{name}");
            assert_eq!(m.vertices.normals.is_some(), normals, "{name}");
            assert_eq!(m.vertices.colors.is_some(), colors, "{name}");
            assert_eq!(m.vertices.non_finite_count(), 0, "{name}");
        }
        // The organised 640×480 capture: 307,200 points declared; NaN pixels dropped.
        let data = std::fs::read(dir.join("table_scene_mug_stereo_textured.pcd")).unwrap();
        let h = Header::parse(&data).unwrap();
        assert_eq!(h.points, 307_200);
        let m = read(&data, &opts()).unwrap();
        let c = &m.vertices;
        assert_eq!(c.len(), 209_280, "non-NaN points of the 640×480 grid");
        assert_eq!(c.non_finite_count(), 0);
        assert_eq!(c.colors.as_ref().map(Vec::len), Some(c.len()));
    }
}
