//! `OpenEXR` reading: depth images and position images as point clouds.
//!
//! Follows the `OpenEXR` file layout ("`OpenEXR` File Layout" and "Interpreting Deep Pixels",
//! openexr.com; multi-view naming from "Storing Multi-View Images in `OpenEXR` Files"), decoded by
//! the [`exr`] crate. Flat (scanline or tiled) images are read; the first part (layer) of a
//! multi-part file, at its largest resolution level.
//!
//! # Which channels
//! 1. `X`, `Y`, `Z` all present: a **position image**; each pixel whose three values are finite
//!    is one point `(X, Y, Z)`.
//! 2. Otherwise a **depth image** if there is a depth channel: `Z`; else `<view>.Z` for the
//!    first (default) view named by the `multiView` attribute; else the first channel ending in
//!    `.Z`; else `depth`. It needs a [`PinholeCamera`]
//!    ([`ReadOptions::camera`], `--camera fx,fy,cx,cy` on the command line); without one the read
//!    fails with [`ErrorKind::Unsupported`](crate::ErrorKind). Pixel `(u, v)` (absolute pixel
//!    coordinates: the data window may start away from the origin) with depth `z` becomes
//!    `((u + 0.5 - cx) z / fx, (v + 0.5 - cy) z / fy, z)`; pixels whose depth is not finite or not
//!    positive (background, often `inf` or `0`) are skipped. `R`, `G`, `B`, when present, become
//!    colours: linear values clamped to `[0, 1]` and scaled to 0-255 (no transfer curve).
//! 3. Otherwise `R`, `G`, `B` present: a **position image** as in 1.
//!
//! Deep images (several samples per pixel) are not read: they fail with
//! [`ErrorKind::Unsupported`](crate::ErrorKind). Subsampled channels are not read either.
//!
//! # Hostile input
//! The headers are read first (the [`exr`] crate reads them without allocating for pixels);
//! before any pixel is decoded, each part's data window must hold at most
//! [`Limits::max_points`](crate::Limits) pixels, and its pixel bytes must be within what the input
//! can expand to: the input size for uncompressed parts, 1100 times it otherwise (deflate, the
//! most expansive codec, expands at most 1032:1).

use std::io::Cursor;

use crate::budget::Budget;

use octowrap_geom::DVec3;
use octowrap_mesh::{FaceList, PointCloud};

use crate::{Error, ErrorKind, Location, Mesh, PinholeCamera, ReadOptions, Result};

/// The most a compressed EXR can expand (deflate's limit is 1032:1; PIZ, RLE and B44 expand less).
const MAX_EXPANSION: u64 = 1100;

/// Reads a whole `OpenEXR` input.
pub(crate) fn read(data: &[u8], opts: &ReadOptions) -> Result<Mesh> {
    precheck(data, opts)?;
    let image = {
        use exr::prelude::{ReadChannels, ReadLayers};
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(data))
            .map_err(|e| convert("cannot decode the EXR pixels", &e))?
    };
    let layer = &image.layer_data;
    let (w, h) = (layer.size.x(), layer.size.y());
    let pixels = w.checked_mul(h).ok_or_else(|| Error::limit(Location::Unknown, "EXR data window overflows"))?;
    let origin = (f64::from(layer.attributes.layer_position.x()), f64::from(layer.attributes.layer_position.y()));
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    let channel = |name: &str| -> Result<Option<Vec<f32>>> {
        let Some(c) = layer.channel_data.list.iter().find(|c| c.name.to_string() == name) else { return Ok(None) };
        let v: Vec<f32> = match &c.sample_data {
            exr::prelude::FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            exr::prelude::FlatSamples::F32(v) => v.clone(),
            exr::prelude::FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        };
        if v.len() != pixels {
            return Err(Error::unsupported(
                Location::Unknown,
                format!("EXR channel '{name}' is subsampled ({} samples for {w}×{h} pixels)", v.len()),
            ));
        }
        Ok(Some(v))
    };
    let xyz = |a: &str, b: &str, c: &str| -> Result<Option<[Vec<f32>; 3]>> {
        Ok(match (channel(a)?, channel(b)?, channel(c)?) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        })
    };
    if let Some(p) = xyz("X", "Y", "Z")? {
        return Ok(positions_image(&p));
    }
    let first_view = layer
        .attributes
        .multi_view_names
        .as_ref()
        .and_then(|v| v.first())
        .or(layer.attributes.layer_name.as_ref())
        .map(ToString::to_string);
    let depth_name = ["Z".to_owned()]
        .into_iter()
        .chain(first_view.map(|v| format!("{v}.Z")))
        .chain(names.iter().filter(|n| n.rsplit_once('.').is_some_and(|(_, c)| c == "Z")).cloned())
        .chain(["depth".to_owned()])
        .find(|n| names.contains(n));
    if let Some(depth_name) = depth_name {
        let Some(camera) = opts.camera else {
            return Err(Error::unsupported(
                Location::Unknown,
                format!(
                    "this EXR is a depth image (channel '{depth_name}'): a pinhole camera is needed to turn it \
                     into points; give it as --camera fx,fy,cx,cy (pixels)"
                ),
            ));
        };
        let depth = channel(&depth_name)?.unwrap_or_default();
        let rgb = xyz("R", "G", "B")?;
        return Ok(depth_image(&depth, rgb.as_ref(), w, origin, &camera));
    }
    if let Some(p) = xyz("R", "G", "B")? {
        return Ok(positions_image(&p));
    }
    Err(Error::unsupported(
        Location::Unknown,
        format!("EXR has no depth channel (Z) and no X,Y,Z or R,G,B positions; channels: {}", names.join(", ")),
    ))
}

/// One point per pixel whose three channel values are finite.
fn positions_image(p: &[Vec<f32>; 3]) -> Mesh {
    let positions: Vec<DVec3> = p[0]
        .iter()
        .zip(&p[1])
        .zip(&p[2])
        .map(|((&x, &y), &z)| DVec3::new(f64::from(x), f64::from(y), f64::from(z)))
        .filter(|q| q.is_finite())
        .collect();
    Mesh::from_positions(positions)
}

/// Back-projects every pixel with a finite positive depth through the pinhole `camera`.
fn depth_image(
    depth: &[f32],
    rgb: Option<&[Vec<f32>; 3]>,
    w: usize,
    origin: (f64, f64),
    camera: &PinholeCamera,
) -> Mesh {
    let mut positions = Vec::new();
    let mut colors = rgb.map(|_| Vec::new());
    for (i, &z) in depth.iter().enumerate() {
        let z = f64::from(z);
        if !(z.is_finite() && z > 0.0) {
            continue;
        }
        let (col, row) = (i % w.max(1), i / w.max(1));
        let u = origin.0 + col as f64;
        let v = origin.1 + row as f64;
        let p = DVec3::new((u + 0.5 - camera.cx) * z / camera.fx, (v + 0.5 - camera.cy) * z / camera.fy, z);
        if !p.is_finite() {
            continue;
        }
        positions.push(p);
        if let (Some(colors), Some(rgb)) = (&mut colors, rgb) {
            colors.push([0, 1, 2].map(|k| (rgb[k][i].clamp(0.0, 1.0) * 255.0).round() as u8));
        }
    }
    let cloud = PointCloud { positions, normals: None, colors, intensities: None };
    Mesh { vertices: cloud, faces: FaceList::default() }
}

/// An `exr` crate error as ours.
fn convert(what: &str, e: &exr::error::Error) -> Error {
    let kind = match e {
        exr::error::Error::NotSupported(_) => ErrorKind::Unsupported,
        _ => ErrorKind::Invalid,
    };
    Error::new(kind, Location::Unknown, format!("{what}: {e}"))
}

/// Reads the headers and checks every part against the limits and the input size before any
/// pixel storage is allocated; refuses deep data.
fn precheck(data: &[u8], opts: &ReadOptions) -> Result<()> {
    if !data.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Err(Error::invalid(Location::Byte(0), "expected the OpenEXR magic number 76 2f 31 01"));
    }
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(data), false)
        .map_err(|e| convert("cannot read the EXR header", &e))?;
    if meta.headers.is_empty() {
        return Err(Error::invalid(Location::Unknown, "EXR file has no header"));
    }
    let len = data.len() as u64;
    let mut budget = Budget::new(&opts.limits, data.len());
    for (k, header) in meta.headers.iter().enumerate() {
        if header.deep {
            return Err(Error::unsupported(
                Location::Unknown,
                format!(
                    "EXR part {k} holds deep data (several samples per pixel), which octowrap does not read; \
                     flatten it to a regular image first"
                ),
            ));
        }
        let (w, h) = (header.layer_size.x() as u64, header.layer_size.y() as u64);
        let pixels = w.saturating_mul(h);
        if pixels > opts.limits.max_points {
            return Err(Error::limit(
                Location::Unknown,
                format!("EXR part {k} is {w}×{h} pixels, more than the limit of {} points", opts.limits.max_points),
            ));
        }
        let bytes_per_pixel: u64 = header.channels.list.iter().map(|c| c.sample_type.bytes_per_sample() as u64).sum();
        let need = pixels.saturating_mul(bytes_per_pixel);
        // The decoder's samples, their `f32` copies, and the points made from them.
        let channels = header.channels.list.len() as u64;
        let held = need.saturating_add(pixels.saturating_mul(4 * channels + 24 + 4));
        budget.charge(held, &|| format!("EXR part {k} of {w}×{h} pixels"), Location::Unknown)?;
        let uncompressed = header.compression == exr::compression::Compression::Uncompressed;
        let can = if uncompressed { len } else { len.saturating_mul(MAX_EXPANSION) };
        if need > can {
            return Err(Error::limit(
                Location::Unknown,
                format!(
                    "EXR part {k} declares {w}×{h} pixels of {bytes_per_pixel} bytes ({need} bytes), \
                     more than the {len}-byte input can hold"
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, Vec2};

    fn opts() -> ReadOptions {
        ReadOptions::default()
    }

    fn cam() -> ReadOptions {
        ReadOptions { camera: Some(PinholeCamera { fx: 2.0, fy: 4.0, cx: 1.0, cy: 1.0 }), ..opts() }
    }

    /// A 2×2 flat image with the given f32 channels.
    fn image(channels: &[(&str, [f32; 4])], compressed: bool) -> Vec<u8> {
        image_with_views(channels, compressed, None)
    }

    /// Like [`image`], with a `multiView` attribute.
    fn image_with_views(channels: &[(&str, [f32; 4])], compressed: bool, views: Option<&[&str]>) -> Vec<u8> {
        use exr::prelude::WritableImage;
        let list = channels
            .iter()
            .map(|(name, v)| AnyChannel::new(*name, FlatSamples::F32(v.to_vec())))
            .collect::<exr::prelude::SmallVec<_>>();
        let encoding = if compressed { Encoding::SMALL_LOSSLESS } else { Encoding::UNCOMPRESSED };
        let attributes = LayerAttributes {
            multi_view_names: views.map(|v| v.iter().map(|n| exr::prelude::Text::from(*n)).collect()),
            ..LayerAttributes::default()
        };
        let layer = Layer::new(Vec2(2, 2), attributes, encoding, AnyChannels::sort(list));
        let mut out = Cursor::new(Vec::new());
        Image::from_layer(layer).write().to_buffered(&mut out).unwrap();
        out.into_inner()
    }

    #[test]
    fn depth_image_back_projects_and_skips_background() {
        let d = image(&[("Z", [1.0, f32::INFINITY, 0.0, 2.0]), ("R", [1.0, 0.5, 0.0, 2.0])], true);
        assert_eq!(read(&d, &opts()).unwrap_err().kind, ErrorKind::Unsupported);
        let e = read(&d, &opts()).unwrap_err().to_string();
        assert!(e.contains("--camera fx,fy,cx,cy"), "{e}");
        let m = read(&d, &cam()).unwrap();
        // Pixel (0,0), z 1: ((0.5 - 1) / 2, (0.5 - 1) / 4, 1); pixel (1,1), z 2: (0.5 * 2 / 2, 0.5 * 2 / 4, 2).
        assert_eq!(m.vertices.positions, vec![DVec3::new(-0.25, -0.125, 1.0), DVec3::new(0.5, 0.25, 2.0)]);
        assert!(m.vertices.colors.is_none(), "no G and B channels");
    }

    #[test]
    #[allow(clippy::float_cmp)] // depths are small integers, exact in f32 and f64
    fn multi_view_depth_takes_the_default_view() {
        let channels = [("left.Z", [1.0; 4]), ("right.Z", [2.0; 4])];
        let z = |d: &[u8]| read(d, &cam()).unwrap().vertices.positions[0].z;
        assert_eq!(z(&image_with_views(&channels, true, Some(&["right", "left"]))), 2.0);
        assert_eq!(z(&image(&channels, true)), 1.0, "without multiView: the first '.Z' channel");
        let mut with_plain = channels.to_vec();
        with_plain.push(("Z", [3.0; 4]));
        assert_eq!(z(&image_with_views(&with_plain, true, Some(&["right", "left"]))), 3.0);
    }

    #[test]
    fn position_images_from_xyz_or_rgb() {
        let d = image(&[("X", [1.0, 2.0, f32::NAN, 4.0]), ("Y", [0.0; 4]), ("Z", [5.0; 4])], false);
        let m = read(&d, &opts()).unwrap();
        assert_eq!(
            m.vertices.positions,
            vec![DVec3::new(1.0, 0.0, 5.0), DVec3::new(2.0, 0.0, 5.0), DVec3::new(4.0, 0.0, 5.0)]
        );
        let d = image(&[("R", [1.0; 4]), ("G", [2.0; 4]), ("B", [3.0; 4])], true);
        assert_eq!(read(&d, &opts()).unwrap().vertices.positions, vec![DVec3::new(1.0, 2.0, 3.0); 4]);
        let d = image(&[("Y", [1.0; 4])], true);
        assert_eq!(read(&d, &opts()).unwrap_err().kind, ErrorKind::Unsupported);
    }

    #[test]
    fn every_prefix_fails_cleanly() {
        for compressed in [false, true] {
            let d = image(&[("Z", [1.0, 2.0, 3.0, 4.0])], compressed);
            for n in 0..d.len() {
                assert!(read(&d[..n], &cam()).is_err(), "prefix {n} of {}", d.len());
            }
        }
    }

    #[test]
    fn hostile_data_window_fails_before_allocating() {
        let mut d = image(&[("Z", [1.0, 2.0, 3.0, 4.0])], false);
        // The dataWindow attribute's box2i: xMin yMin xMax yMax after its name, type and size.
        let at = d.windows(10).position(|w| w == b"dataWindow").unwrap() + 10 + 1 + 6 + 4;
        d[at + 8..at + 12].copy_from_slice(&60_000i32.to_le_bytes());
        d[at + 12..at + 16].copy_from_slice(&60_000i32.to_le_bytes());
        let e = read(&d, &cam()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::LimitExceeded, "{e}");
    }

    #[test]
    fn mutations_never_panic() {
        let d = image(&[("Z", [1.0, 2.0, 3.0, 4.0]), ("R", [0.0; 4])], true);
        for at in 0..d.len() {
            for v in [0u8, 0x7f, 0xff] {
                let mut m = d.clone();
                m[at] = v;
                let _ = read(&m, &cam());
            }
        }
    }

    #[test]
    fn real_exr_files() {
        let Some(dir) = octowrap_testdata::dir("openexr-depth") else { return };
        let deep = std::fs::read(dir.join("LowResLeftView_Trunks.exr")).unwrap();
        let e = read(&deep, &cam()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported, "{e}");
        assert!(e.to_string().contains("deep"), "{e}");
        let beach = std::fs::read(dir.join("Beachball_singlepart.0001.exr")).unwrap();
        assert_eq!(read(&beach, &opts()).unwrap_err().kind, ErrorKind::Unsupported);
        let camera = PinholeCamera { fx: 1000.0, fy: 1000.0, cx: 1024.0, cy: 778.0 };
        let m = read(&beach, &ReadOptions { camera: Some(camera), ..opts() }).unwrap();
        let c = &m.vertices;
        // Data window (654,245)-(1564,1120): 911 × 876 = 798,036 pixels, of which 596,983 have a
        // finite positive depth in `Z` (the default view; `left.Z` is the other one).
        assert_eq!(c.len(), 596_983);
        assert_eq!(c.non_finite_count(), 0);
        assert!(c.positions.iter().all(|p| p.z > 0.0));
        assert_eq!(c.colors.as_ref().map(Vec::len), Some(c.len()));
    }
}
