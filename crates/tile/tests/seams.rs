//! A sampled sphere cut into the eight octants of its cube: every face of the finest level has
//! exactly one owner, the merged slots are the untiled run's, and the border vertices weld.

use octowrap_geom::DVec3;
use octowrap_recon::{MaxLevel, ReconOptions};
use octowrap_tile::{PlanOptions, merge, own, plan, split};

fn sphere(n: u32) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let phi = f64::from(i) * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos() + 0.1, r * phi.sin() - 0.2, z + 0.05)
        })
        .collect()
}

#[test]
fn octant_tiles_own_every_face_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sphere.ply");
    let pts = sphere(20_000);
    octowrap_io::write_path(
        &input,
        &octowrap_mesh::Mesh::from_positions(pts.clone()),
        &octowrap_io::WriteOptions::default(),
    )
    .unwrap();
    let mut po = PlanOptions::default();
    po.points_per_tile = 5_000;
    po.level = Some(4);
    po.max_tile_depth = Some(1);
    po.padding = 0.1;
    let plan = plan::build(&[input], &po).unwrap();
    assert_eq!(plan.tiles.len(), 8, "{:?}", plan.tiles);
    assert_eq!(plan.tiles.iter().map(|t| t.points).sum::<u64>(), 20_000);

    let mut opts = ReconOptions::default();
    opts.max_level = MaxLevel::Level(4);
    opts.padding = 0.1;
    let untiled = octowrap_recon::reconstruct(&pts, &opts).unwrap();
    assert_eq!(untiled.cube, Some(plan.cube()));

    let bins = split::bin(&plan, &pts);
    let mut levels = Vec::new();
    for (t, b) in plan.tiles.iter().zip(&bins) {
        assert!(b.len() as u64 > t.points, "the halo adds points");
        let h = own::reconstruct_tile(&plan, t.id, b, &ReconOptions::default()).unwrap();
        levels.push(h.levels.last().unwrap().clone());
    }
    let (merged, rep) = merge::merge(&levels).unwrap();
    assert_eq!(rep.duplicate_slots, 0);
    let fine = untiled.levels.last().unwrap();
    let mut a = merged.lattice.unwrap().face_slots;
    let mut b = fine.lattice.clone().unwrap().face_slots;
    a.sort_unstable();
    b.sort_unstable();
    assert_eq!(a, b, "the tiles' slots are the untiled run's");
    assert!(rep.welded > 0);
}
