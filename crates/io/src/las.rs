//! LAS and LAZ reading: ASPRS LAS 1.0-1.4 point clouds, their LASzip-compressed form, and
//! Cloud-Optimized Point Clouds (COPC, which are valid LAZ 1.4 files and are read as such).
//!
//! Follows the ASPRS "LAS Specification 1.4 - R15" (2019) for the public header block, and
//! decodes points with the [`las`] crate (`LASzip` through the `laz` crate).
//!
//! # What is read
//! * Positions: the stored 32-bit integers times the header's scale plus its offset, computed in
//!   `f64` (`X * x_scale + x_offset`), which is exact to the file's own precision: georeferenced
//!   coordinates (UTM eastings near 600,000 m at a 0.01 m scale) keep every digit.
//! * Intensities: always, the 16-bit values as stored (0-65535).
//! * Colours, for point formats that have RGB (2, 3, 5, 7, 8, 10). The specification says the
//!   16-bit channels are scaled to the full 0-65535 range, but many writers store 8-bit values
//!   unscaled. **Decision**: if every channel of every point is at most 255, the values are kept
//!   as they are; otherwise each channel's high byte is taken (`v >> 8`).
//! * Every other attribute (returns, classification, GPS time, extra bytes, waveforms) is skipped.
//!
//! # Hostile input
//! The [`las`] crate trusts some header fields (it allocates the first extended VLR's declared
//! length, and the LAZ chunk table's declared entry count), so the public header block is checked
//! here first ([`precheck`]): the declared point count against the bytes after the point-data
//! offset (uncompressed: `count × record length` must fit; compressed: the count must be within
//! [`Limits::max_points`](crate::Limits)), the first EVLR's length against the file size, and the
//! LAZ chunk count against the file size. Points are then decoded in batches of at most 16 MiB, so
//! memory grows only with points actually decoded. The crate needs an owned, `'static` reader, so
//! the input is copied once into it.

use std::io::Cursor;

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, PointCloud};

use crate::budget::{Budget, point_bytes};
use crate::{Error, Location, Mesh, ReadOptions, Result, justify};

/// Size of the LAS 1.0-1.2 public header block; 1.3 adds 8 bytes, 1.4 another 140.
const HEADER_1_2: usize = 227;
const HEADER_1_4: usize = 375;
/// Bytes of an extended VLR's header before its payload.
const EVLR_HEADER: u64 = 60;
/// Most bytes of raw point records decoded at once.
const BATCH_BYTES: usize = 16 << 20;

/// Reads a whole LAS or LAZ input.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    let pre = precheck(data, opts)?;
    let mut budget = Budget::new(&opts.limits, data.len());
    // The `las` crate reads from an owned copy of the input.
    budget.charge(data.len() as u64, &|| "a copy of the input for the LAS decoder".to_owned(), Location::Unknown)?;
    let has_color = data.get(104).is_some_and(|&f| matches!(f & 0x3f, 2 | 3 | 5 | 7 | 8 | 10));
    // Positions, intensities, 16-bit colours and the 8-bit colours made from them.
    let each = point_bytes(false, has_color, true) + if has_color { 6 } else { 0 };
    budget.charge_n(usize::try_from(pre.count).unwrap_or(usize::MAX), each, "points", Location::Byte(107))?;
    let mut reader = las::Reader::new(Cursor::new(data.to_vec())).map_err(|e| {
        Error::invalid(
            Location::Unknown,
            "cannot read the LAS header, its VLRs or the LAZ chunk table (file cut short?)",
        )
        .with_source(e)
    })?;
    let header = reader.header();
    let declared = header.number_of_points();
    if declared != pre.count {
        return Err(Error::invalid(
            Location::Byte(107),
            format!("point count {declared} differs from the checked header's {}", pre.count),
        ));
    }
    let format = *header.point_format();
    let record_len = usize::from(format.len()).max(1);
    let batch = (BATCH_BYTES / record_len).max(1) as u64;
    // Reserve only what the input itself can hold: uncompressed records are checked, LAZ grows.
    let reserve = if pre.compressed { pre.count.min(data.len() as u64) } else { pre.count } as usize;
    let mut positions = Vec::with_capacity(reserve);
    let mut intensities = Vec::with_capacity(reserve);
    let mut rgb16: Option<Vec<[u16; 3]>> = format.has_color.then(|| Vec::with_capacity(reserve));
    let mut pd = las::PointDataBuilder::new().for_header(header).build();
    let mut done = 0u64;
    while done < pre.count {
        let n = reader.fill_points(batch.min(pre.count - done), &mut pd).map_err(|e| {
            // Uncompressed records sit at fixed offsets; compressed ones have none to give.
            let at = if pre.compressed {
                Location::Unknown
            } else {
                Location::Byte(pre.offset.saturating_add(done.saturating_mul(record_len as u64)))
            };
            let what = if pre.compressed { "LAZ-compressed " } else { "" };
            Error::invalid(
                at,
                format!("cannot decode {what}points {done}.. of {} (file cut short or corrupt?)", pre.count),
            )
            .with_source(e)
        })?;
        if n == 0 {
            break;
        }
        positions.extend(pd.x().zip(pd.y()).zip(pd.z()).map(|((x, y), z)| DVec3::new(x, y, z)));
        intensities.extend(pd.intensity().map(f32::from));
        if let (Some(c), Some(it)) = (rgb16.as_mut(), pd.rgb()) {
            c.extend(it.map(|(r, g, b)| [r, g, b]));
        }
        done += n;
    }
    if done != pre.count {
        return Err(Error::invalid(
            Location::Unknown,
            format!("the header declares {} points, but the data holds {done}", pre.count),
        ));
    }
    let colors = rgb16.map(|c| {
        let wide = c.iter().flatten().any(|&v| v > 255);
        c.into_iter()
            .map(|[r, g, b]| if wide { [r >> 8, g >> 8, b >> 8] } else { [r, g, b] }.map(|v| v as u8))
            .collect()
    });
    let cloud = PointCloud { positions, normals: None, colors, intensities: Some(intensities) };
    Ok(Mesh { vertices: cloud, faces: FaceList::default() })
}

/// What [`precheck`] learned from the public header block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Precheck {
    /// Number of point records.
    count: u64,
    /// Whether the points are LAZ-compressed.
    compressed: bool,
    /// Byte offset of the point data.
    offset: u64,
}

fn u16_at(d: &[u8], at: usize) -> u16 {
    d.get(at..at + 2).map_or(0, |b| u16::from_le_bytes([b[0], b[1]]))
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    d.get(at..at + 4).map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn u64_at(d: &[u8], at: usize) -> u64 {
    d.get(at..at + 8).and_then(|b| b.try_into().ok()).map_or(0, u64::from_le_bytes)
}

/// Checks the public header block's counts and offsets against the input before the [`las`]
/// crate sees them.
fn precheck(data: &[u8], opts: &ReadOptions) -> Result<Precheck> {
    if !data.starts_with(b"LASF") {
        return Err(Error::invalid(Location::Byte(0), "expected the LAS signature 'LASF'"));
    }
    let minor = data.get(25).copied().unwrap_or(0);
    let need = if minor >= 4 { HEADER_1_4 } else { HEADER_1_2 };
    if data.len() < need {
        return Err(Error::invalid(
            Location::Byte(data.len() as u64),
            format!("LAS 1.{minor} header needs {need} bytes, the input ends after {}", data.len()),
        ));
    }
    let len = data.len() as u64;
    let header_size = u64::from(u16_at(data, 94));
    let offset = u64::from(u32_at(data, 96));
    let format_id = data[104];
    let record_len = u64::from(u16_at(data, 105));
    let legacy = u64::from(u32_at(data, 107));
    let count = if minor >= 4 && legacy == 0 { u64_at(data, 247) } else { legacy };
    let compressed = format_id & 0x80 != 0;
    if header_size > len || offset > len {
        return Err(Error::invalid(
            Location::Byte(94),
            format!("header size {header_size} / point data offset {offset} lie beyond the input's {len} bytes"),
        ));
    }
    let remaining = (len - offset) as usize;
    if compressed {
        justify(count, 0, remaining, opts.limits.max_points, "points", Location::Byte(107))?;
        check_laz_items(data, header_size, offset, u32_at(data, 100), record_len)?;
        check_chunk_table(data, offset, count)?;
    } else {
        justify(count, record_len, remaining, opts.limits.max_points, "points", Location::Byte(107))?;
    }
    // The crate computes offset + count × record length; make sure that cannot overflow.
    if count.checked_mul(record_len).and_then(|b| b.checked_add(offset)).is_none() {
        return Err(Error::limit(Location::Byte(107), format!("{count} points of {record_len} bytes overflow")));
    }
    if minor >= 4 {
        let start = u64_at(data, 235);
        let n = u32_at(data, 243);
        if start > 0 && n > 0 {
            let at = Location::Byte(start);
            let body = start.checked_add(EVLR_HEADER).filter(|&e| e <= len).ok_or_else(|| {
                Error::invalid(at, format!("first extended VLR at byte {start} lies beyond the input"))
            })?;
            let evlr_len = u64_at(data, (start + 20) as usize);
            if evlr_len > len - body {
                return Err(Error::limit(
                    at,
                    format!("extended VLR declares {evlr_len} bytes, but only {} remain", len - body),
                ));
            }
        }
    }
    Ok(Precheck { count, compressed, offset })
}

/// The `LASzip` VLR (user `laszip encoded`, record 22204) lists the items a point record is made of;
/// the `laz` crate trusts that list (it panics on an empty one), so check it: at least one item,
/// each of a known type with its fixed size, all of one compressor generation (item versions 1-2
/// with the LAS 1.0-1.3 items, 3-4 with the LAS 1.4 ones), sizes adding up to the record length.
fn check_laz_items(data: &[u8], header_size: u64, offset: u64, vlrs: u32, record_len: u64) -> Result<()> {
    let mut pos = header_size;
    for _ in 0..vlrs {
        if pos.saturating_add(54) > offset {
            break; // The crate reports VLRs that overrun the point data.
        }
        let p = pos as usize;
        let len = u64::from(u16_at(data, p + 20));
        if data.get(p + 2..p + 18).is_some_and(|u| u.starts_with(b"laszip encoded")) && u16_at(data, p + 18) == 22204 {
            let payload = data.get(p + 54..).unwrap_or_default();
            let payload = payload.get(..len as usize).unwrap_or(payload);
            let at = Location::Byte(pos + 54);
            let n = usize::from(u16_at(payload, 32));
            if payload.len() < 34 + 6 * n || n == 0 {
                return Err(Error::invalid(at, format!("LASzip VLR lists {n} items in {} bytes", payload.len())));
            }
            let mut sum = 0u64;
            let mut family = None;
            for k in 0..n {
                let (ty, size, version) =
                    (u16_at(payload, 34 + 6 * k), u16_at(payload, 36 + 6 * k), u16_at(payload, 38 + 6 * k));
                let (fixed, fam) = match ty {
                    0 => (None, 1),
                    6 => (Some(20), 1),
                    7 => (Some(8), 1),
                    8 => (Some(6), 1),
                    9 => (Some(29), 1),
                    10 => (Some(30), 3),
                    11 => (Some(6), 3),
                    12 => (Some(8), 3),
                    13 => (Some(29), 3),
                    14 => (None, 3),
                    _ => return Err(Error::invalid(at, format!("LASzip item {k} has unknown type {ty}"))),
                };
                let version_fam = match version {
                    1 | 2 => 1,
                    3 | 4 => 3,
                    _ => return Err(Error::unsupported(at, format!("LASzip item {k} has version {version}"))),
                };
                if fixed.is_some_and(|f| f != size)
                    || size == 0
                    || fam != version_fam
                    || *family.get_or_insert(fam) != fam
                {
                    return Err(Error::invalid(
                        at,
                        format!("LASzip item {k} (type {ty}, {size} bytes, version {version}) does not fit the others"),
                    ));
                }
                sum += u64::from(size);
            }
            if sum != record_len {
                return Err(Error::invalid(
                    at,
                    format!("LASzip items add up to {sum} bytes, but points are {record_len} bytes long"),
                ));
            }
        }
        pos = pos.saturating_add(54 + len);
    }
    Ok(())
}

/// `LASzip` stores a chunk table whose entry count the `laz` crate allocates for; each chunk holds
/// at least one point and at least one byte, so the count must be within both.
fn check_chunk_table(data: &[u8], offset: u64, count: u64) -> Result<()> {
    let len = data.len() as u64;
    let mut table = u64_at(data, offset as usize) as i64;
    if table <= offset as i64 && len >= 8 {
        table = u64_at(data, (len - 8) as usize) as i64;
    }
    let Ok(table) = u64::try_from(table) else { return Ok(()) };
    if table <= offset || table.saturating_add(8) > len {
        return Ok(()); // The crate fails on its own when it cannot read the table.
    }
    let chunks = u64::from(u32_at(data, (table + 4) as usize));
    if chunks > count.max(1) || chunks > len {
        return Err(Error::invalid(
            Location::Byte(table + 4),
            format!("LAZ chunk table declares {chunks} chunks for {count} points in {len} bytes"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;

    fn opts() -> ReadOptions {
        ReadOptions::default()
    }

    /// A LAS file written by the `las` crate: 3 points of format 2 (RGB) at scale 0.001 around a
    /// UTM-like offset.
    fn tiny(colors: [[u16; 3]; 3], compress: bool) -> Vec<u8> {
        let mut b = las::Builder::from((1, 2));
        b.point_format = las::point::Format::new(2).unwrap();
        b.point_format.is_compressed = compress;
        b.transforms = las::Vector {
            x: las::Transform { scale: 0.001, offset: 600_000.0 },
            y: las::Transform { scale: 0.001, offset: 5_000_000.0 },
            z: las::Transform { scale: 0.001, offset: 0.0 },
        };
        let header = b.into_header().unwrap();
        let mut w = las::Writer::new(Cursor::new(Vec::new()), header).unwrap();
        {
            for (k, c) in colors.iter().enumerate() {
                let p = las::Point {
                    x: 600_123.456 + k as f64,
                    y: 5_000_987.654,
                    z: 12.345,
                    intensity: 100 * k as u16,
                    color: Some(las::Color { red: c[0], green: c[1], blue: c[2] }),
                    ..Default::default()
                };
                w.write_point(p).unwrap();
            }
        }
        w.into_inner().unwrap().into_inner()
    }

    #[test]
    fn scaled_coordinates_are_exact_and_colours_scaled() {
        for compress in [false, true] {
            let m = read(&tiny([[65535, 256, 0], [0, 0, 0], [1, 2, 3]], compress), &opts()).unwrap();
            let c = &m.vertices;
            assert_eq!(c.len(), 3);
            assert_eq!(c.positions[1], DVec3::new(600_124.456, 5_000_987.654, 12.345));
            assert_eq!(c.intensities.as_deref(), Some(&[0.0, 100.0, 200.0][..]));
            assert_eq!(c.colors.as_deref(), Some(&[[255, 1, 0], [0, 0, 0], [0, 0, 0]][..]));
            let m = read(&tiny([[255, 128, 0], [0, 0, 0], [1, 2, 3]], compress), &opts()).unwrap();
            assert_eq!(m.vertices.colors.as_deref(), Some(&[[255, 128, 0], [0, 0, 0], [1, 2, 3]][..]));
        }
    }

    #[test]
    fn hostile_counts_fail_at_once() {
        let mut d = tiny([[0; 3]; 3], false);
        d[107..111].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(read(&d, &opts()).unwrap_err().kind, ErrorKind::LimitExceeded);
        let mut d = tiny([[0; 3]; 3], true);
        d[107..111].copy_from_slice(&u32::MAX.to_le_bytes());
        let limits = crate::Limits { max_points: 1000, ..crate::Limits::default() };
        let e = read(&d, &ReadOptions { limits, ..opts() }).unwrap_err();
        assert_eq!(e.kind, ErrorKind::LimitExceeded);
        // Within the limit, the LAZ data runs out long before 2^32 points.
        assert!(read(&d, &opts()).is_err());
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        for compress in [false, true] {
            let d = tiny([[1, 2, 3]; 3], compress);
            for n in 0..d.len() {
                assert!(read(&d[..n], &opts()).is_err(), "prefix {n} of {} (laz {compress})", d.len());
            }
        }
    }

    #[test]
    fn mutated_headers_never_panic() {
        for compress in [false, true] {
            let d = tiny([[1, 2, 3]; 3], compress);
            for at in 0..d.len() {
                for v in [0u8, 1, 0x7f, 0x80, 0xff] {
                    let mut m = d.clone();
                    m[at] = v;
                    let _ = read(&m, &opts());
                }
            }
        }
    }

    #[test]
    fn real_las_and_laz_files() {
        let Some(dir) = octowrap_testdata::dir("lidar-las") else { return };
        let mut autzen = Vec::new();
        for (name, count, colors) in [
            ("autzen_trim.las", 110_000, true),
            ("autzen_trim.laz", 110_000, true),
            ("lone-star.copc.laz", 518_862, false), // point format 6: no RGB
            ("Megaplot.laz", 81_590, false),
            ("MixedConifer.laz", 37_657, false),
            ("Topography.laz", 73_403, false),
        ] {
            let data = std::fs::read(dir.join(name)).unwrap();
            let m = read(&data, &opts()).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(m.vertices.len(), count, "{name}");
            assert_eq!(m.vertices.colors.is_some(), colors, "{name}");
            assert_eq!(m.vertices.non_finite_count(), 0, "{name}");
            if name.starts_with("autzen") {
                autzen.push(m);
            }
        }
        assert_eq!(autzen[0], autzen[1], "autzen LAS and LAZ hold the same points");
        // Georeferenced: eastings in the hundreds of thousands (feet, Oregon State Plane), kept exactly.
        assert!(autzen[0].vertices.positions[0].x > 600_000.0);
    }

    #[test]
    fn cgal_oni() {
        let Some(dir) = octowrap_testdata::dir("cgal-data/points_3") else { return };
        let m = read(&std::fs::read(dir.join("oni.las")).unwrap(), &opts()).unwrap();
        assert_eq!(m.vertices.len(), 1435);
    }
}
