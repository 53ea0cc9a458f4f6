//! Hierarchy cuts are crack-free and two-manifold wherever the finest level is (the validator
//! proves it), stay within their error bound of the finest level, refine towards the camera, and
//! do not depend on the thread count.

#![allow(clippy::print_stderr)]

use std::path::Path;

use octowrap_decimate::metrics::{Sampling, certified_hausdorff, distance};
use octowrap_decimate::{Camera, CutCriterion, cut};
use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_mesh::{FaceOrigin, Hierarchy, Mesh};
use octowrap_validate::{MeshReport, ValidateOptions, validate_mesh};

fn report(m: &Mesh) -> MeshReport {
    validate_mesh(m, &ValidateOptions::default())
}

/// Levels that are pure subdivisions, each with its own noise: closed, and differing level to
/// level, so that cuts mix levels.
fn noisy(levels: usize, seed: u64) -> Hierarchy {
    cube_hierarchy(levels, Edits { noise: 0.3, shuffle: true, ..Edits::none() }, seed)
}

/// The cut is no less manifold than the finest level, and has boundary edges only where it does.
fn assert_no_worse(name: &str, finest: &Mesh, out: &Mesh) {
    let (a, b) = (report(finest), report(out));
    let (ca, cb) = (&a.counts, &b.counts);
    assert!(cb.non_manifold_edges <= ca.non_manifold_edges, "{name}: {ca:?} -> {cb:?}");
    assert!(cb.non_manifold_vertices <= ca.non_manifold_vertices, "{name}: {ca:?} -> {cb:?}");
    assert!(cb.orientation_conflicts <= ca.orientation_conflicts, "{name}: {ca:?} -> {cb:?}");
    assert!(cb.boundary_edges <= ca.boundary_edges, "{name}: {ca:?} -> {cb:?}");
    if a.properties.watertight {
        assert!(b.properties.watertight, "{name}: crack: {:?}", b.findings);
    }
    if a.properties.oriented {
        assert!(b.properties.oriented, "{name}");
    }
}

#[test]
fn fixed_error_cuts_are_watertight_and_within_the_bound() {
    let h = noisy(6, 11);
    let finest = &h.levels.last().unwrap().mesh;
    assert!(report(finest).properties.watertight);
    let mut last_faces = usize::MAX;
    let mut mixed = false;
    for e in [0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.2] {
        let out = cut(&h, &CutCriterion::MaxError(e)).unwrap();
        let r = &out.report;
        assert_eq!(r.faces, out.mesh.faces.len());
        assert!(r.faces <= last_faces, "coarser with a larger bound");
        last_faces = r.faces;
        assert!(r.max_error <= e);
        mixed |= r.faces_per_level.iter().filter(|&&n| n > 0).count() >= 2;
        assert_no_worse(&format!("E = {e}"), finest, &out.mesh);
        let d = distance(finest, &out.mesh, &Sampling::with_samples(200_000));
        eprintln!("E = {e}: {} faces per level {:?}, Hausdorff {:.4}", r.faces, r.faces_per_level, d.hausdorff);
        // Each region's distance is certified (an upper bound), so an independent dense
        // measurement of the whole cut, which is at most the largest region's, stays within it.
        assert!(d.hausdorff <= r.max_error + 1e-12 && d.hausdorff <= e + 1e-12, "E = {e}: measured {}", d.hausdorff);
        let c = certified_hausdorff(finest, &out.mesh);
        assert!(c.lower <= e + 1e-12 && c.lower <= r.max_error + 1e-12, "E = {e}: {c:?}");
    }
    assert!(mixed, "some bound mixes levels");
    let exact = cut(&h, &CutCriterion::MaxError(0.0)).unwrap();
    assert_eq!(exact.mesh.faces.len(), finest.faces.len());
    assert!(distance(finest, &exact.mesh, &Sampling::with_samples(10_000)).hausdorff < 1e-12);
}

#[test]
fn view_dependent_cuts_refine_towards_the_camera() {
    let h = noisy(6, 5);
    let finest = &h.levels.last().unwrap().mesh;
    let camera = Camera::from_json(
        r#"{"position": [1.3, 1.3, 1.3], "target": [0.5, 0.5, 0.5], "up": [0, 0, 1],
            "fov_y_degrees": 60, "viewport_height_px": 720, "pixel_error": 3}"#,
    )
    .unwrap();
    let out = cut(&h, &CutCriterion::View(camera)).unwrap();
    assert_no_worse("view", finest, &out.mesh);
    let used = out.report.faces_per_level.iter().filter(|&&n| n > 0).count();
    assert!(used >= 2, "{:?}", out.report.faces_per_level);
    // Faces near the camera are smaller than faces far from it.
    let eye = octowrap_geom::DVec3::splat(1.3);
    let (mut near, mut far) = (Vec::new(), Vec::new());
    for f in out.mesh.faces.iter() {
        let p: Vec<_> = f.iter().map(|&v| out.mesh.vertices.positions[v as usize]).collect();
        let c = p.iter().copied().sum::<octowrap_geom::DVec3>() / p.len() as f64;
        let size = p.iter().map(|q| q.distance(c)).fold(0.0, f64::max);
        if c.distance(eye) < 0.9 {
            near.push(size);
        } else if c.distance(eye) > 1.6 {
            far.push(size);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    assert!(!near.is_empty() && !far.is_empty());
    assert!(mean(&near) < mean(&far), "near {} far {}", mean(&near), mean(&far));
}

#[test]
fn edited_hierarchies_and_conformance_files() {
    // Removed children, pushed-in children, created faces, split and joined vertices.
    for seed in 1..=8 {
        let h = cube_hierarchy(5, Edits::default(), seed);
        let finest = &h.levels.last().unwrap().mesh;
        for e in [0.005, 0.01, 0.02, 0.05, 1.0] {
            let out = cut(&h, &CutCriterion::MaxError(e)).unwrap();
            assert_no_worse(&format!("seed {seed}, E = {e}"), finest, &out.mesh);
        }
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format/valid");
    for name in ["cube3_subdivision_q10.mrq", "cube3_lattice_q12.mrq", "cube3_generic_q12.mrq", "one_quad_exact.mrq"] {
        let h =
            octowrap_format::read_path(&dir.join(name), &octowrap_format::DecodeOptions::default()).unwrap().hierarchy;
        let finest = &h.levels.last().unwrap().mesh;
        for e in [0.0, 0.02, 1.0] {
            let out = cut(&h, &CutCriterion::MaxError(e)).unwrap();
            assert_no_worse(&format!("{name}, E = {e}"), finest, &out.mesh);
        }
    }
}

#[test]
fn same_output_whatever_the_thread_count() {
    let h = noisy(5, 3);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| cut(&h, &CutCriterion::MaxError(0.01)).unwrap())
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a.mesh, b.mesh);
    assert_eq!(a.report, b.report);
}

#[test]
fn hostile_hierarchies_fail_cleanly() {
    assert!(matches!(
        cut(&Hierarchy::default(), &CutCriterion::MaxError(1.0)),
        Err(octowrap_decimate::Error::EmptyHierarchy)
    ));
    let mut h = noisy(3, 1);
    assert!(cut(&h, &CutCriterion::MaxError(-1.0)).is_err());
    assert!(cut(&h, &CutCriterion::MaxError(f64::NAN)).is_err());
    h.levels[1].origins[0] = FaceOrigin::Subface { parent: 99, quadrant: octowrap_mesh::Quadrant(0) };
    assert!(matches!(cut(&h, &CutCriterion::MaxError(1.0)), Err(octowrap_decimate::Error::InvalidHierarchy(_))));
    let mut h = noisy(3, 1);
    h.levels[2].mesh.vertices.positions[0] = octowrap_geom::DVec3::NAN;
    assert!(matches!(cut(&h, &CutCriterion::MaxError(1.0)), Err(octowrap_decimate::Error::NonFinite { .. })));
    let mut h = octowrap_format::synthetic::without_lattice(noisy(3, 1));
    h.levels[1].mesh.faces.push(&[0, 1, 999]);
    h.levels[1].origins.push(FaceOrigin::Created);
    assert!(matches!(cut(&h, &CutCriterion::MaxError(1.0)), Err(octowrap_decimate::Error::InvalidMesh(_))));
}
