//! Reconstruction accuracy and speed.
//!
//! Per model and level: faces, the RMS and maximum distance from the input points to the mesh
//! (quads split into two triangles) and from the mesh vertices to the points, as fractions of the
//! points' bounding-box diagonal, and the wall time to build the hierarchy to that level. Then the
//! timing targets, and the effect of relaxation on accuracy.

use std::time::Instant;

use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::Mesh;
use octowrap_recon::{MaxLevel, ReconOptions, Reconstruction, reconstruct_with_progress};
use rayon::prelude::*;

use crate::stages::stage_table;
use crate::util::{best_of, headline, shared_data};

/// A uniform grid over items with bounding boxes, for nearest-item queries.
struct Grid {
    origin: DVec3,
    cell: f64,
    dims: [i64; 3],
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    fn new(bounds: Aabb, cell: f64, boxes: &[(DVec3, DVec3)]) -> Self {
        let origin = bounds.min;
        let size = bounds.size();
        let dims = [0, 1, 2].map(|a| ((size[a] / cell).ceil() as i64).max(1));
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut counts = vec![0u32; n + 1];
        let range = |b: &(DVec3, DVec3)| -> ([i64; 3], [i64; 3]) {
            let lo = [0, 1, 2].map(|a| (((b.0[a] - origin[a]) / cell).floor() as i64).clamp(0, dims[a] - 1));
            let hi = [0, 1, 2].map(|a| (((b.1[a] - origin[a]) / cell).floor() as i64).clamp(0, dims[a] - 1));
            (lo, hi)
        };
        let index = |c: [i64; 3]| (c[0] + dims[0] * (c[1] + dims[1] * c[2])) as usize;
        for b in boxes {
            let (lo, hi) = range(b);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        counts[index([x, y, z]) + 1] += 1;
                    }
                }
            }
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[n] as usize];
        for (i, b) in boxes.iter().enumerate() {
            let (lo, hi) = range(b);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let c = index([x, y, z]);
                        items[fill[c] as usize] = i as u32;
                        fill[c] += 1;
                    }
                }
            }
        }
        Self { origin, cell, dims, starts: counts, items }
    }

    /// The smallest `dist2(p, item)` over all items (ring search).
    fn nearest(&self, p: DVec3, dist2: impl Fn(u32) -> f64) -> f64 {
        let c = [0, 1, 2].map(|a| (((p[a] - self.origin[a]) / self.cell).floor() as i64).clamp(0, self.dims[a] - 1));
        let mut best = f64::INFINITY;
        let max_r = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_r {
            for z in (c[2] - r).max(0)..=(c[2] + r).min(self.dims[2] - 1) {
                for y in (c[1] - r).max(0)..=(c[1] + r).min(self.dims[1] - 1) {
                    for x in (c[0] - r).max(0)..=(c[0] + r).min(self.dims[0] - 1) {
                        if (x - c[0]).abs() != r && (y - c[1]).abs() != r && (z - c[2]).abs() != r {
                            continue;
                        }
                        let i = (x + self.dims[0] * (y + self.dims[1] * z)) as usize;
                        for &it in &self.items[self.starts[i] as usize..self.starts[i + 1] as usize] {
                            best = best.min(dist2(it));
                        }
                    }
                }
            }
            // Anything in rings beyond r is at least r cells away (p's own offset in its cell
            // can be up to a cell; be conservative).
            let reach = (r as f64) * self.cell;
            if best <= reach * reach {
                break;
            }
        }
        best
    }
}

/// RMS and maximum of distances.
fn rms_max(d2: &[f64]) -> (f64, f64) {
    let n = d2.len().max(1) as f64;
    let rms = (d2.iter().sum::<f64>() / n).sqrt();
    let max = d2.iter().copied().fold(0.0, f64::max).sqrt();
    (rms, max)
}

/// Distances points -> mesh and mesh vertices -> points, as (rms, max) pairs, in world units.
fn errors(points: &[DVec3], mesh: &Mesh) -> ((f64, f64), (f64, f64)) {
    let pos = &mesh.vertices.positions;
    let tris: Vec<[DVec3; 3]> = mesh
        .faces
        .iter()
        .flat_map(|f| {
            let q: Vec<DVec3> = f.iter().map(|&v| pos[v as usize]).collect();
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        })
        .collect();
    let boxes: Vec<(DVec3, DVec3)> =
        tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
    let bounds = Aabb::from_points(points).union(&Aabb::from_points(pos));
    let mean_edge = if tris.is_empty() {
        bounds.diagonal()
    } else {
        boxes.iter().map(|b| (b.1 - b.0).max_element()).sum::<f64>() / boxes.len() as f64
    };
    let cell = mean_edge.max(bounds.diagonal() / 512.0);
    let grid = Grid::new(bounds, cell, &boxes);
    let to_mesh: Vec<f64> = points
        .par_iter()
        .map(|&p| {
            grid.nearest(p, |t| {
                let t = &tris[t as usize];
                octowrap_geom::point_triangle_squared(p, &[t[0], t[1], t[2]])
            })
        })
        .collect();
    let pboxes: Vec<(DVec3, DVec3)> = points.iter().map(|&p| (p, p)).collect();
    let pcell = (bounds.diagonal() / (points.len() as f64).cbrt() / 4.0).max(bounds.diagonal() / 1024.0);
    let pgrid = Grid::new(bounds, pcell, &pboxes);
    let to_points: Vec<f64> =
        pos.par_iter().map(|&v| pgrid.nearest(v, |i| (points[i as usize] - v).length_squared())).collect();
    (rms_max(&to_mesh), rms_max(&to_points))
}

/// Boundary loops of a mesh, as the validator counts them.
fn boundary_loops(mesh: &Mesh) -> usize {
    octowrap_validate::validate_mesh(mesh, &octowrap_validate::ValidateOptions::default()).counts.boundary_loops
}

/// User plus system CPU seconds of this process so far (`/proc/self/stat`, 100 ticks a second).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the line: 11 and 12 after the name (state is 0).
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn load(relative: &str) -> Option<Vec<DVec3>> {
    let path = shared_data()?.join(relative);
    match octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()) {
        Ok(m) => Some(m.vertices.positions),
        Err(e) => {
            outln!("(skipped {relative}: {e})");
            None
        }
    }
}

/// Options to `level`; `relax`: `None` for the default relaxation, or that many passes on
/// every level.
pub fn opts(level: u32, relax: Option<u32>) -> ReconOptions {
    let mut o = ReconOptions::default();
    o.max_level = MaxLevel::Level(level);
    if let Some(passes) = relax {
        o.relax_passes = passes;
        o.relax_from_level = 1;
    }
    o
}

pub fn run(points: &[DVec3], o: &ReconOptions) -> Reconstruction {
    reconstruct_with_progress(points, o, &mut |_| {}).expect("reconstructs")
}

/// The accuracy table of one model.
fn accuracy(name: &str, points: &[DVec3], max_level: u32) {
    let diag = Aabb::from_points(points).diagonal();
    let r = run(points, &opts(max_level, None));
    outln!();
    outln!("### {name}: {} points, topology trusted to level {}", points.len(), r.trusted_level);
    outln!();
    outln!(
        "| level | kind | faces | loops | pts→mesh RMS | pts→mesh max | verts→pts RMS | verts→pts max | time to level (s) |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|");
    for (j, (level, rep)) in r.hierarchy.levels.iter().zip(&r.levels).enumerate().skip(1) {
        let ((a_rms, a_max), (b_rms, b_max)) = errors(points, &level.mesh);
        let (t, _) = best_of(3, || run(points, &opts(j as u32, None)));
        outln!(
            "| {j} | {:?} | {} | {} | {:.5} | {:.4} | {:.5} | {:.4} | {t:.3} |",
            rep.kind,
            rep.faces,
            boundary_loops(&level.mesh),
            a_rms / diag,
            a_max / diag,
            b_rms / diag,
            b_max / diag
        );
    }
}

/// A table of the points-to-mesh RMS / diagonal per level (levels 1 to `max_level`), one row per
/// labelled set of options.
fn effect_table(title: &str, column: &str, points: &[DVec3], max_level: u32, rows: Vec<(String, ReconOptions)>) {
    let diag = Aabb::from_points(points).diagonal();
    outln!();
    outln!("### {title}");
    outln!();
    let header: Vec<String> = (1..=max_level).map(|j| format!("L{j}")).collect();
    outln!("| {column} | {} |", header.join(" | "));
    outln!("|---|{}", "---|".repeat(max_level as usize));
    for (label, o) in rows {
        let r = run(points, &o);
        let cells: Vec<String> =
            r.hierarchy.levels.iter().skip(1).map(|l| format!("{:.5}", errors(points, &l.mesh).0.0 / diag)).collect();
        outln!("| {label} | {} |", cells.join(" | "));
    }
}

/// Points-to-mesh RMS per level for several relaxation pass counts.
fn relaxation_effect(name: &str, points: &[DVec3], max_level: u32) {
    let rows = [0, 1, 4].map(|passes| (passes.to_string(), opts(max_level, Some(passes))));
    let title = format!("Relaxation on {name}: points→mesh RMS / diagonal per level, passes on every level");
    effect_table(&title, "passes", points, max_level, rows.into());
}

/// Points-to-mesh RMS per level with the paper's plane and with the weighted quadric.
fn mapping_effect(name: &str, points: &[DVec3], max_level: u32) {
    let rows = [false, true].map(|quadric| {
        let mut o = opts(max_level, None);
        o.quadric_mapping = quadric;
        (if quadric { "quadric" } else { "plane (paper)" }.to_string(), o)
    });
    let title = format!("Vertex mapping on {name}: points→mesh RMS / diagonal per level (default relaxation)");
    effect_table(&title, "mapping", points, max_level, rows.into());
}

/// Points-to-mesh RMS per level with the least-squares fit off (the paper's mapping and
/// relaxation alone) and with 1, 3 (the default) and 5 passes.
fn fit_effect(name: &str, points: &[DVec3], max_level: u32) {
    let rows = [0, 1, 3, 5].map(|passes| {
        let mut o = opts(max_level, None);
        o.fit_passes = passes;
        (if passes == 0 { "0 (paper)".to_string() } else { passes.to_string() }, o)
    });
    let title = format!("The fit on {name}: points→mesh RMS / diagonal per level, by fit passes");
    effect_table(&title, "fit passes", points, max_level, rows.into());
}

/// Points-to-mesh RMS per level with the per-region trusted level off and on (`region_levels`
/// levels past the global density limit, several `region_density` values), with the faces and
/// boundary loops of the finest level.
fn regions_effect(name: &str, points: &[DVec3], max_level: u32, region_levels: u32) {
    let diag = Aabb::from_points(points).diagonal();
    outln!();
    outln!(
        "### Trusted level per region on {name}: points→mesh RMS / diagonal per level (`region_levels` = {region_levels})"
    );
    outln!();
    let header: Vec<String> = (1..=max_level).map(|j| format!("L{j}")).collect();
    outln!("| region_density | {} | wrapped to | finest faces | finest loops |", header.join(" | "));
    outln!("|---|{}---|---|---|", "---|".repeat(max_level as usize));
    for tau in [None, Some(2.75), Some(3.0), Some(4.0), Some(10.0)] {
        let mut o = opts(max_level, None);
        if let Some(t) = tau {
            o.region_density = t;
            o.region_levels = region_levels;
        }
        let r = run(points, &o);
        let cells: Vec<String> =
            r.hierarchy.levels.iter().skip(1).map(|l| format!("{:.5}", errors(points, &l.mesh).0.0 / diag)).collect();
        let finest = r.hierarchy.finest().map(|l| &l.mesh);
        outln!(
            "| {} | {} | {} | {} | {} |",
            tau.map_or_else(|| "off (default)".to_owned(), |t| format!("{t}")),
            cells.join(" | "),
            r.trusted_level,
            finest.map_or(0, |m| m.faces.len()),
            finest.map_or(0, boundary_loops)
        );
    }
}

/// Area-uniform samples of a triangle mesh with Gaussian noise of `sigma`.
pub fn resample(mesh: &Mesh, n: usize, sigma: f64) -> Vec<DVec3> {
    let sampler = octowrap_mesh::shapes::SurfaceSampler::new(mesh);
    (0..n as u64).into_par_iter().map(|i| sampler.point(i, sigma)).collect()
}

fn status_kb(field: &str) -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse::<f64>().ok()
}

fn verdict(ok: bool) -> &'static str {
    if ok { "met" } else { "NOT met" }
}

/// The large case: the dragon resampled to 4.3 M points with noise, to level 10, run
/// three times like the other timing targets: the best wall time (the target's verdict), the
/// median and every run's, the largest peak memory and the best run's CPU time and stage table.
fn large_case(m: Mesh, threads: usize) {
    let diag = m.vertices.bounds().diagonal();
    let pts = resample(&m, 4_300_000, 2e-4 * diag);
    drop(m);
    let before = status_kb("VmRSS:").unwrap_or(0.0);
    let mut runs: Vec<(f64, f64, f64, usize, String)> = Vec::new();
    let mut reset = true;
    for _ in 0..3 {
        // Reset the peak (Linux >= 4.0), so the peak below is this run's.
        reset &= std::fs::write("/proc/self/clear_refs", "5").is_ok();
        let t = Instant::now();
        let cpu = cpu_seconds();
        let r = run(&pts, &opts(10, None));
        let secs = t.elapsed().as_secs_f64();
        let cpu = cpu_seconds() - cpu;
        let peak = status_kb("VmHWM:").unwrap_or(0.0);
        let faces = r.hierarchy.finest().map_or(0, |l| l.mesh.faces.len());
        let table = stage_table(&r);
        drop(r);
        runs.push((secs, cpu, peak, faces, table));
    }
    let mut walls: Vec<f64> = runs.iter().map(|r| r.0).collect();
    walls.sort_by(f64::total_cmp);
    let best = runs.iter().min_by(|a, b| a.0.total_cmp(&b.0)).expect("three runs");
    let (secs, cpu, _, faces, table) = best;
    let peak = runs.iter().map(|r| r.2).fold(0.0, f64::max);
    let per_point = peak * 1024.0 / pts.len() as f64;
    outln!(
        "| 4.3 M points (dragon resampled, noise 2e-4 diag) to level 10 | {} | {faces} | {secs:.3} | 3 | {} (median {:.3}; runs {}) |",
        pts.len(),
        verdict(*secs <= 3.0),
        walls[1],
        runs.iter().map(|r| format!("{:.3}", r.0)).collect::<Vec<_>>().join(", ")
    );
    headline(
        format!(
            "{:.1} M points (dragon resampled, noise 2e-4 diag) to level 10, best of 3, {threads} threads",
            pts.len() as f64 / 1e6
        ),
        format!("{secs:.3} s (median {:.3})", walls[1]),
        "≤ 3 s",
        Some(*secs <= 3.0),
    );
    headline(
        "peak memory of that case per input point (input included)",
        format!("{per_point:.0} bytes ({:.0} MB)", peak / 1024.0),
        "≤ 150 bytes",
        Some(per_point <= 150.0),
    );
    outln!();
    outln!(
        "Peak memory of those runs: {:.0} MB resident = {per_point:.0} bytes per input point including the input itself \
         (target 150: {}); {:.0} bytes per point above the {:.0} MB resident before them{}.",
        peak / 1024.0,
        verdict(per_point <= 150.0),
        (peak - before) * 1024.0 / pts.len() as f64,
        before / 1024.0,
        if reset { "" } else { " (peak reset unavailable: the peak includes earlier sections)" }
    );
    outln!();
    outln!(
        "CPU time of the best run: {cpu:.2} s on {threads} threads; load average at the end: {}.",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    outln!();
    outln!("Stages of the best run (seconds, like the paper's Table 2):");
    outln!();
    out!("{table}");
}

/// Prints the reconstruction section.
pub fn report() {
    outln!("## Reconstruction");
    outln!();
    let threads = rayon::current_num_threads();
    outln!(
        "Default options (4 relaxation passes from level 4) unless stated. Distances are fractions of the points' \
         bounding-box diagonal; times are wall seconds on {threads} threads, best of 3."
    );
    let Some(_) = shared_data() else {
        outln!("(skipped: ../shared/data is absent)");
        return;
    };
    let rabbit = load("stanford-bunny/reconstruction/bun_zipper_res2.ply");
    let bunny = load("stanford-bunny/reconstruction/bun_zipper.ply");
    let dragon_mesh = shared_data().and_then(|d| {
        octowrap_io::read_path(&d.join("stanford-dragon/dragon_vrip.ply.gz"), &octowrap_io::ReadOptions::default()).ok()
    });
    let dragon: Option<Vec<DVec3>> = dragon_mesh.as_ref().map(|m| m.vertices.positions.clone());
    // OCTOWRAP_RECON_QUICK=1 skips the accuracy tables (timing targets only).
    let quick = std::env::var_os("OCTOWRAP_RECON_QUICK").is_some();
    // OCTOWRAP_RECON_ACCURACY=1 prints the three accuracy tables only.
    let accuracy_only = std::env::var_os("OCTOWRAP_RECON_ACCURACY").is_some();
    if let Some(p) = rabbit.as_ref().filter(|_| !quick) {
        accuracy("Rabbit (bun_zipper_res2)", p, 6);
    }
    if let Some(p) = bunny.as_ref().filter(|_| !quick) {
        accuracy("Bunny (bun_zipper)", p, 7);
    }
    if let Some(p) = dragon.as_ref().filter(|_| !quick) {
        accuracy("Dragon (dragon_vrip)", p, 7);
    }
    if accuracy_only {
        return;
    }
    if let Some(p) = rabbit.as_ref().filter(|_| !quick) {
        regions_effect("the Rabbit", p, 6, 2);
    }
    if let Some(p) = bunny.as_ref().filter(|_| !quick) {
        regions_effect("the bunny", p, 7, 2);
    }
    if let Some(p) = dragon.as_ref().filter(|_| !quick) {
        regions_effect("the dragon", p, 8, 1);
    }
    if let Some(p) = rabbit.as_ref().filter(|_| !quick) {
        fit_effect("the Rabbit", p, 6);
    }
    if let Some(p) = bunny.as_ref().filter(|_| !quick) {
        fit_effect("the bunny", p, 7);
    }
    if let Some(p) = dragon.as_ref().filter(|_| !quick) {
        fit_effect("the dragon", p, 7);
    }
    if let Some(p) = bunny.as_ref().filter(|_| !quick) {
        mapping_effect("the bunny", p, 7);
    }
    if let Some(p) = dragon.as_ref().filter(|_| !quick) {
        mapping_effect("the dragon", p, 7);
    }
    if let Some(p) = bunny.as_ref().filter(|_| !quick) {
        relaxation_effect("the bunny", p, 7);
    }
    if let Some(p) = dragon.as_ref().filter(|_| !quick) {
        relaxation_effect("the dragon", p, 7);
    }
    outln!();
    outln!("### Timing targets");
    outln!();
    outln!("| case | points | faces | wall s | target | |");
    outln!("|---|---|---|---|---|---|");
    if let Some(p) = &dragon {
        let (t, r) = best_of(3, || run(p, &opts(7, Some(4))));
        let faces = r.hierarchy.finest().map_or(0, |l| l.mesh.faces.len());
        outln!(
            "| dragon to level 7, 4 relaxation passes | {} | {faces} | {t:.3} | 0.5 | {} |",
            p.len(),
            verdict(t <= 0.5)
        );
        headline(
            format!("dragon ({} points) to level 7, 4 relaxation passes, best of 3, {threads} threads", p.len()),
            format!("{t:.3} s"),
            "≤ 0.5 s",
            Some(t <= 0.5),
        );
    }
    if let Some(p) = &bunny {
        let (t, r) = best_of(3, || run(p, &opts(6, None)));
        let faces = r.hierarchy.finest().map_or(0, |l| l.mesh.faces.len());
        outln!("| bunny to level 6 | {} | {faces} | {t:.3} | 0.1 | {} |", p.len(), verdict(t <= 0.1));
        headline(
            format!("bunny ({} points) to level 6, best of 3, {threads} threads", p.len()),
            format!("{t:.3} s"),
            "≤ 0.1 s",
            Some(t <= 0.1),
        );
    }
    if let Some(m) = dragon_mesh {
        drop(dragon);
        large_case(m, threads);
    }
    outln!();
}
