//! E57 reading: ASTM E2807 "Standard Specification for 3D Imaging Data Exchange" (E57) files,
//! as written by terrestrial laser scanners.
//!
//! Decoding (the paged CRC-32C layer, the XML tree, compressed vector sections with their
//! bit-packed and scaled-integer codecs) is done by the [`e57`] crate; this module picks what
//! octowrap keeps and merges the scans.
//!
//! # What is read
//! * **Every point cloud** (`/data3D/*`) in the file, each brought into the file's common frame by
//!   its `pose` (rotation quaternion, then translation), then merged into one cloud in file order.
//! * Cartesian coordinates, or spherical ones (range, azimuth, elevation) converted to Cartesian;
//!   integer, scaled-integer and float encodings alike, as `f64`.
//! * Points whose coordinates are invalid are skipped: `cartesianInvalidState` 1 (direction
//!   only) or 2 (no data), `sphericalInvalidState` 1 (direction only, no range) or 2. With
//!   [`ReadOptions::keep_invalid`](crate::ReadOptions) they are kept as NaN points instead, so the
//!   count equals the file's record count.
//! * Colours, when a scan has them: normalised by the scan's `colorLimits` and scaled to 0-255;
//!   a point whose colour is marked invalid gets black.
//! * Intensities, when a scan has them: the values as stored (not normalised); an invalid one is 0.
//!
//! When scans differ in what they carry, an attribute survives the merge only if every scan has
//! it ([`PointCloud::append`]).
//!
//! # Hostile input
//! The file header is checked first: its physical length and the XML section must lie within the
//! input (the crate would otherwise allocate the declared XML length). Each scan's declared
//! record count is checked against [`Limits::max_points`](crate::Limits), and the points it
//! declares are charged to the memory ceiling before any is decoded (bit-packed records of a
//! constant value take no bits, so the file size cannot bound them). Two scans naming the same
//! binary section are refused: that is one scan read many times over. A page whose CRC does not
//! match fails with [`ErrorKind::Invalid`](crate::ErrorKind).

use std::io::Cursor;

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{FaceList, PointCloud};

use crate::budget::{Budget, point_bytes};
use crate::{Error, Location, Mesh, ReadOptions, Result, justify};

/// Bytes of the E57 file header.
const HEADER: usize = 48;

/// Reads a whole E57 input.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    precheck(data)?;
    let mut reader =
        e57::E57Reader::new(Cursor::new(data)).map_err(|e| convert("cannot read the E57 header and XML", &e))?;
    let mut merged = PointCloud::default();
    let mut total = 0u64;
    let mut budget = Budget::new(&opts.limits, data.len());
    let clouds = reader.pointclouds();
    // Each point cloud owns its binary section: several naming the same one would read its bytes
    // again and again (an amplification, not a scan set).
    let mut offsets: Vec<(u64, usize)> = clouds.iter().enumerate().map(|(k, pc)| (pc.file_offset, k)).collect();
    offsets.sort_unstable();
    if let Some(w) = offsets.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(Error::invalid(
            Location::Byte(w[0].0),
            format!("point clouds {} and {} name the same binary section at byte {}", w[0].1, w[1].1, w[0].0),
        ));
    }
    for (k, pc) in clouds.into_iter().enumerate() {
        let max = opts.limits.max_points.saturating_sub(total);
        let records = justify(pc.records, 0, usize::MAX, max, "points", Location::Unknown)?;
        let has_color = pc.has_color();
        let has_intensity = pc.has_intensity();
        let each = point_bytes(false, has_color, has_intensity);
        budget.charge_n(records, each, &format!("points in point cloud {k}"), Location::Byte(pc.file_offset))?;
        let reserve = records.min(data.len());
        let mut cloud = PointCloud {
            positions: Vec::with_capacity(reserve),
            normals: None,
            colors: has_color.then(|| Vec::with_capacity(reserve)),
            intensities: has_intensity.then(|| Vec::with_capacity(reserve)),
        };
        let mut points =
            reader.pointcloud_simple(&pc).map_err(|e| convert(&format!("cannot open point cloud {k}"), &e))?;
        points.apply_pose(true);
        points.spherical_to_cartesian(true);
        points.intensity_to_color(false);
        points.normalize_intensity(false);
        points.normalize_color(true);
        for (i, p) in points.enumerate() {
            let p = p.map_err(|e| convert(&format!("cannot read point {i} of point cloud {k}"), &e))?;
            let position = match p.cartesian {
                e57::CartesianCoordinate::Valid { x, y, z } => DVec3::new(x, y, z),
                _ if opts.keep_invalid => DVec3::NAN,
                _ => continue,
            };
            cloud.positions.push(position);
            if let Some(colors) = &mut cloud.colors {
                let c = p.color.map_or([0.0; 3], |c| [c.red, c.green, c.blue]);
                colors.push(c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
            }
            if let Some(intensities) = &mut cloud.intensities {
                intensities.push(p.intensity.unwrap_or(0.0));
            }
        }
        total += cloud.len() as u64;
        append(&mut merged, cloud, k == 0);
    }
    Ok(Mesh { vertices: merged, faces: FaceList::default() })
}

/// Appends `cloud` to `merged`; the first scan's attributes are taken as they are, even if it
/// is empty (so that an empty first scan does not hide a later scan's missing attribute).
fn append(merged: &mut PointCloud, cloud: PointCloud, first: bool) {
    if first {
        *merged = cloud;
        return;
    }
    join(&mut merged.colors, cloud.colors);
    join(&mut merged.intensities, cloud.intensities);
    join::<Vec3>(&mut merged.normals, cloud.normals);
    merged.positions.extend(cloud.positions);
}

/// Extends `a` by `b` if both are present, else drops `a`.
fn join<T>(a: &mut Option<Vec<T>>, b: Option<Vec<T>>) {
    match (a.as_mut(), b) {
        (Some(x), Some(y)) => x.extend(y),
        _ => *a = None,
    }
}

/// An `e57` crate error as ours, with its chain of causes in the message (each said once), and
/// a page checksum failure called what it is.
fn convert(what: &str, e: &e57::Error) -> Error {
    use std::fmt::Write;
    let mut msg = format!("{what}: {e}");
    let mut src = std::error::Error::source(e);
    while let Some(s) = src {
        let s_text = s.to_string();
        if !msg.ends_with(&s_text) {
            let _ = write!(msg, ": {s_text}");
        }
        src = s.source();
    }
    if msg.contains("checksum") {
        msg = format!("corrupt E57 file: a page fails its CRC-32C check ({msg})");
    }
    Error::invalid(Location::Unknown, msg)
}

fn u64_at(d: &[u8], at: usize) -> u64 {
    d.get(at..at + 8).and_then(|b| b.try_into().ok()).map_or(0, u64::from_le_bytes)
}

/// Checks the file header's lengths and offsets against the input size.
fn precheck(data: &[u8]) -> Result<()> {
    if !data.starts_with(b"ASTM-E57") {
        return Err(Error::invalid(Location::Byte(0), "expected the E57 signature 'ASTM-E57'"));
    }
    if data.len() < HEADER {
        return Err(Error::invalid(
            Location::Byte(data.len() as u64),
            format!("E57 header needs {HEADER} bytes, the input ends after {}", data.len()),
        ));
    }
    let len = data.len() as u64;
    let phys_length = u64_at(data, 16);
    let xml_offset = u64_at(data, 24);
    let xml_length = u64_at(data, 32);
    if phys_length > len {
        return Err(Error::invalid(
            Location::Byte(16),
            format!("E57 header declares {phys_length} bytes, but the input has {len} (file cut short?)"),
        ));
    }
    if xml_offset > len || xml_length > len - xml_offset {
        return Err(Error::invalid(
            Location::Byte(24),
            format!("XML section of {xml_length} bytes at {xml_offset} lies beyond the input's {len} bytes"),
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

    /// CRC-32C (Castagnoli), as E57 pages store it.
    fn crc32c(data: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 { (c >> 1) ^ 0x82F6_3B78 } else { c >> 1 };
            }
        }
        !c
    }

    #[test]
    fn scans_sharing_a_binary_section_are_refused() {
        let mut d = tiny();
        let offsets: Vec<u64> =
            e57::E57Reader::new(Cursor::new(&d[..])).unwrap().pointclouds().iter().map(|pc| pc.file_offset).collect();
        // Point the second scan at the first one's section (zero-padded to the same length) and
        // reseal the page.
        let from = format!("fileOffset=\"{}\"", offsets[1]);
        let digits = offsets[1].to_string().len();
        let to = format!("fileOffset=\"{:0digits$}\"", offsets[0]);
        let at = d.windows(from.len()).position(|w| w == from.as_bytes()).expect("the attribute in one page");
        d[at..at + to.len()].copy_from_slice(to.as_bytes());
        let page = at / 1024 * 1024;
        let crc = crc32c(&d[page..page + 1020]);
        d[page + 1020..page + 1024].copy_from_slice(&crc.to_be_bytes());
        let e = read(&d, &opts()).unwrap_err();
        assert_eq!((e.kind, e.location), (ErrorKind::Invalid, Location::Byte(offsets[0])), "{e}");
        assert!(e.message.contains("same binary section"), "{e}");
    }

    /// Points in the spherical scan of [`tiny`].
    const SPHERICAL: usize = 64;

    /// Two scans written with the `e57` crate: Cartesian with a pose, spherical with an invalid point.
    fn tiny() -> Vec<u8> {
        use e57::{Quaternion, Record, RecordValue, Transform, Translation};
        let mut cur = Cursor::new(Vec::new());
        {
            let mut w = e57::E57Writer::new(&mut cur, "guid-file").unwrap();
            let proto = vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
                Record { name: e57::RecordName::Intensity, data_type: e57::RecordDataType::F32 },
            ];
            let mut pc = w.add_pointcloud("guid-a", proto).unwrap();
            // 90° about z, then +10 in x.
            let h = std::f64::consts::FRAC_1_SQRT_2;
            pc.set_transform(Some(Transform {
                rotation: Quaternion { w: h, x: 0.0, y: 0.0, z: h },
                translation: Translation { x: 10.0, y: 0.0, z: 0.0 },
            }));
            for (x, i) in [(1.0, 0.5), (2.0, 0.25)] {
                pc.add_point(vec![
                    RecordValue::Double(x),
                    RecordValue::Double(0.0),
                    RecordValue::Double(0.0),
                    RecordValue::Single(i),
                ])
                .unwrap();
            }
            pc.finalize().unwrap();
            let proto = vec![
                Record::SPHERICAL_RANGE_F64,
                Record::SPHERICAL_AZIMUTH_F64,
                Record::SPHERICAL_ELEVATION_F64,
                Record::SPHERICAL_INVALID_STATE,
            ];
            let mut pc = w.add_pointcloud("guid-b", proto).unwrap();
            // Ranges 2, 3, 4, 5, ... with invalid states 0, 2, 1, 0, 2, 1, ...: one point in three kept.
            for k in 0..SPHERICAL {
                pc.add_point(vec![
                    RecordValue::Double(2.0 + k as f64),
                    RecordValue::Double(0.0),
                    RecordValue::Double(0.0),
                    RecordValue::Integer([0, 2, 1][k % 3]),
                ])
                .unwrap();
            }
            pc.finalize().unwrap();
            w.finalize().unwrap();
        }
        cur.into_inner()
    }

    #[test]
    fn scans_merged_with_poses_invalid_skipped() {
        let m = read(&tiny(), &opts()).unwrap();
        let c = &m.vertices;
        let mut want = vec![DVec3::new(10.0, 1.0, 0.0), DVec3::new(10.0, 2.0, 0.0)];
        want.extend((0..SPHERICAL).step_by(3).map(|k| DVec3::new(2.0 + k as f64, 0.0, 0.0)));
        assert_eq!(c.len(), want.len(), "{:?}", c.positions);
        for (p, w) in c.positions.iter().zip(want) {
            assert!((*p - w).length() < 1e-12, "{p} vs {w}");
        }
        assert!(c.intensities.is_none(), "second scan has no intensity");
        assert!(c.colors.is_none());
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        let d = tiny();
        for n in (0..d.len()).step_by(7).chain([d.len() - 1]) {
            assert!(read(&d[..n], &opts()).is_err(), "prefix {n} of {}", d.len());
        }
    }

    #[test]
    fn mutations_never_panic() {
        let d = tiny();
        for at in (0..d.len()).step_by(3) {
            let mut m = d.clone();
            m[at] ^= 0x5a;
            let _ = read(&m, &opts());
        }
        let mut m = d.clone();
        m[32..40].copy_from_slice(&u64::MAX.to_le_bytes());
        assert_eq!(read(&m, &opts()).unwrap_err().kind, ErrorKind::Invalid);
    }

    #[test]
    fn real_e57_files() {
        let Some(dir) = octowrap_testdata::dir("e57") else { return };
        let mut bunny = None;
        for (name, count, colors) in [
            ("bunnyDouble.e57", 30_571, false),
            ("bunnyFloat.e57", 30_571, false),
            ("bunnyInt19.e57", 30_571, false),
            ("bunnyInt21.e57", 30_571, false),
            ("bunnyInt24.e57", 30_571, false),
            ("bunnyInt32.e57", 30_571, false),
            ("tinyCartesianFloatRgb.e57", 2_090, true),
            // 360 records, every other one direction-only (sphericalInvalidState 1): 180 points.
            ("tiny_spherical.e57", 180, false),
        ] {
            let data = std::fs::read(dir.join(name)).unwrap();
            let declared: u64 =
                e57::E57Reader::new(Cursor::new(&data[..])).unwrap().pointclouds().iter().map(|pc| pc.records).sum();
            let want = if name == "tiny_spherical.e57" { 360 } else { count as u64 };
            assert_eq!(declared, want, "{name}: PROVENANCE.md's record count");
            let m = read(&data, &opts()).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(m.vertices.len(), count, "{name}");
            assert_eq!(m.vertices.colors.is_some(), colors, "{name}");
            assert_eq!(m.vertices.non_finite_count(), 0, "{name}");
            if name == "bunnyDouble.e57" {
                bunny = Some(m.vertices.bounds());
            } else if name.starts_with("bunny") {
                // Scaled-integer encodings agree with the doubles to their quantum.
                let b = m.vertices.bounds();
                let d = bunny.unwrap();
                assert!((b.min - d.min).abs().max_element() < 1e-3, "{name}");
            }
        }
        let e = read(&std::fs::read(dir.join("corrupt_crc.e57")).unwrap(), &opts()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Invalid);
        assert!(e.to_string().contains("CRC"), "{e}");
    }
}
