//! Bad input never panics: each case gets the error or the mesh it states. Same output for 1 and
//! 2 threads.

mod support;

use octowrap_geom::DVec3;
use octowrap_recon::{Error, MaxLevel, ReconOptions, reconstruct};
use support::check_manifold;

fn level(n: u32) -> ReconOptions {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(n);
    o
}

/// What a degenerate cloud must give: a mesh of one closed component per level, a mesh of one
/// open sheet (one boundary loop) per level below the root, or this error.
#[derive(Debug)]
enum Expect {
    Closed,
    OpenSheet,
    Fails(Error),
}

/// Reconstructs `pts` with the default options and at level 5, and asserts `expect`. A mesh must
/// also have valid links, manifold quad levels, and finite vertices near the root cube.
fn expect(name: &str, pts: &[DVec3], expect: &Expect) {
    for o in [ReconOptions::default(), level(5)] {
        let h = match (reconstruct(pts, &o), expect) {
            (Err(e), Expect::Fails(want)) => {
                assert_eq!(&e, want, "{name}");
                continue;
            }
            (Ok(h), Expect::Closed | Expect::OpenSheet) => h,
            (got, _) => panic!("{name}: expected {expect:?}, got {:?}", got.map(|h| h.levels.len())),
        };
        h.check_links().unwrap_or_else(|e| panic!("{name}: {e}"));
        let cube = h.cube.expect("a reconstruction has its root cube");
        for (j, l) in h.levels.iter().enumerate() {
            let t = check_manifold(&l.mesh).unwrap_or_else(|e| panic!("{name} level {j}: {e}"));
            let loops = match expect {
                Expect::OpenSheet if j > 0 => 1,
                _ => 0,
            };
            assert_eq!((t.boundary_loops, t.components), (loops, 1), "{name} level {j}");
            let p = &l.mesh.vertices.positions;
            // The fit may carry vertices a little past the cube (up to 6 % of its edge on these
            // clouds), never far.
            let near =
                |p: &DVec3| ((*p - cube.center()).abs() - cube.size() * 0.5).max_element() < 0.25 * cube.size().x;
            assert!(p.iter().all(|p| p.is_finite() && near(p)), "{name} level {j}");
        }
    }
}

#[test]
fn empty_single_and_equal_points_are_errors() {
    assert_eq!(reconstruct(&[], &ReconOptions::default()), Err(Error::Empty));
    assert_eq!(
        reconstruct(&[DVec3::ONE], &ReconOptions::default()),
        Err(Error::TooFewDistinct { distinct: 1, needed: 3 })
    );
    let same = vec![DVec3::new(1.0, 2.0, 3.0); 1000];
    assert!(matches!(reconstruct(&same, &ReconOptions::default()), Err(Error::TooFewDistinct { distinct: 1, .. })));
    let two = [DVec3::ZERO, DVec3::ONE, DVec3::ZERO];
    assert!(matches!(reconstruct(&two, &ReconOptions::default()), Err(Error::TooFewDistinct { distinct: 2, .. })));
}

#[test]
fn non_finite_points_are_rejected_with_their_count() {
    let mut pts = support::sphere(500);
    pts[3].x = f64::NAN;
    pts[10].z = f64::INFINITY;
    pts[11].y = f64::NEG_INFINITY;
    let e = reconstruct(&pts, &ReconOptions::default()).unwrap_err();
    assert_eq!(e, Error::NonFinite { count: 3, total: 500 });
    assert!(e.to_string().contains("3 of 500"));
}

#[test]
fn bad_levels_are_rejected() {
    let pts = support::sphere(500);
    // Subdividing 15 levels past the density limit would need billions of faces.
    assert!(matches!(reconstruct(&pts, &level(20)), Err(Error::TooManyFaces { .. })));
    assert!(matches!(reconstruct(&pts, &level(0)), Err(Error::BadLevel { requested: 0, .. })));
    assert!(matches!(reconstruct(&pts, &level(99)), Err(Error::BadLevel { requested: 99, .. })));
}

#[test]
fn degenerate_clouds_give_valid_meshes_or_errors() {
    let line: Vec<DVec3> = (0..2000).map(|i| DVec3::new(f64::from(i) * 0.01, 0.0, 0.0)).collect();
    expect("collinear", &line, &Expect::Closed);
    let plane: Vec<DVec3> = (0..4000).map(|i| DVec3::new(f64::from(i % 64), f64::from(i / 64), 5.0)).collect();
    expect("flat plane", &plane, &Expect::OpenSheet);
    let three = [DVec3::ZERO, DVec3::X, DVec3::Y];
    expect("three points", &three, &Expect::Closed);
    let mut dups = support::sphere(300);
    for i in 0..30_000 {
        dups.push(dups[i % 7]);
    }
    expect("heavy duplicates", &dups, &Expect::Closed);
    let far: Vec<DVec3> =
        support::sphere(3000).into_iter().map(|p| p * 0.01 + DVec3::new(6.0e5, 5.0e6, 120.0)).collect();
    expect("georeferenced", &far, &Expect::Closed);
    let huge: Vec<DVec3> = support::sphere(3000).into_iter().map(|p| p * 1e300).collect();
    expect("huge", &huge, &Expect::Closed);
    let tiny: Vec<DVec3> = support::sphere(3000).into_iter().map(|p| p * 1e-300).collect();
    expect("tiny", &tiny, &Expect::Closed);
    let mut rng = octowrap_geom::SplitMix64::from_state(5);
    let noise: Vec<DVec3> = (0..5000).map(|_| DVec3::new(rng.f64(), rng.f64(), rng.f64())).collect();
    expect("uniform noise", &noise, &Expect::Closed);
    // Each cluster spans less than 2^-21 of the root cube: two distinct positions.
    let clusters: Vec<DVec3> = (0..3000)
        .map(|i| {
            let base = if i % 2 == 0 { DVec3::ZERO } else { DVec3::splat(1e6) };
            base + DVec3::new(f64::from(i % 13) * 1e-3, f64::from(i % 7) * 1e-3, 0.0)
        })
        .collect();
    expect("two far clusters", &clusters, &Expect::Fails(Error::TooFewDistinct { distinct: 2, needed: 3 }));
}

#[test]
fn same_output_for_one_and_two_threads() {
    let mut pts = support::torus(30_000, 1.0, 0.35);
    pts.extend(support::bowl(20_000, 0.2).into_iter().map(|p| p * 0.5 + DVec3::new(0.0, 0.0, 1.0)));
    let mut o = level(7);
    o.relax_passes = 2;
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("pool").install(|| reconstruct(&pts, &o))
    };
    let one = run(1).expect("reconstructs");
    let two = run(2).expect("reconstructs");
    assert_eq!(one.levels.len(), 8);
    for (a, b) in one.levels.iter().zip(&two.levels) {
        assert_eq!(a.mesh.faces, b.mesh.faces);
        let bits = |l: &octowrap_mesh::Level| -> Vec<[u64; 3]> {
            l.mesh.vertices.positions.iter().map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).collect()
        };
        assert_eq!(bits(a), bits(b));
        assert_eq!(a.origins, b.origins);
        assert_eq!(a.lattice, b.lattice);
    }
}

#[test]
fn sparse_regions_give_the_same_output_for_one_and_two_threads() {
    let pts: Vec<DVec3> = support::sphere(60_000)
        .into_iter()
        .enumerate()
        .filter(|(i, p)| p.z > 0.2 || i % 6 == 0)
        .map(|(_, p)| p)
        .collect();
    let mut o = level(7);
    o.region_density = 10.0;
    o.region_levels = 2;
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("pool")
            .install(|| octowrap_recon::reconstruct_with_progress(&pts, &o, &mut |_| {}).expect("reconstructs"))
    };
    let (one, two) = (run(1), run(2));
    assert!(one.levels.iter().any(|l| l.sparse_voxels > 0), "no sparse region");
    for (a, b) in one.hierarchy.levels.iter().zip(&two.hierarchy.levels) {
        assert_eq!(a.mesh.faces, b.mesh.faces);
        let bits = |l: &octowrap_mesh::Level| -> Vec<[u64; 3]> {
            l.mesh.vertices.positions.iter().map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).collect()
        };
        assert_eq!(bits(a), bits(b));
        assert_eq!(a.origins, b.origins);
        assert_eq!(a.lattice, b.lattice);
    }
}
