//! Shared bench helpers: timing, data paths, machine description, and the capture of a
//! section's output (its full text for the raw-run file, its headline figures for the results
//! page, `results.rs`), and the points-to-mesh distance the format and accuracy areas measure.

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

use octowrap_geom::{Aabb, DVec3};
use octowrap_mesh::Mesh;
use rayon::prelude::*;

/// The shared data folder ([`octowrap_testdata::data_root`]), if present. Silent when absent: each
/// bench area says what it skips.
pub fn shared_data() -> Option<PathBuf> {
    let dir = octowrap_testdata::data_root();
    dir.is_dir().then_some(dir)
}

/// The `octowrap` binary the areas run: `OCTOWRAP_BIN`, else the workspace's
/// `target/release/octowrap` (`cargo build --release -p octowrap-cli` first); `None` when it is
/// not there.
pub fn octowrap_binary() -> Option<std::path::PathBuf> {
    let p = std::env::var_os("OCTOWRAP_BIN")
        .map_or_else(|| octowrap_testdata::workspace_root().join("target/release/octowrap"), std::path::PathBuf::from);
    p.is_file().then_some(p)
}

/// Best wall time in seconds of `runs` runs of `f` (the result of the last run is returned).
pub fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("at least one run"))
}

/// [`best_of`], also giving the least CPU time the calling thread spent in one run (for
/// single-threaded work: on a busy machine the wall time includes waits for the core, the CPU
/// time does not).
pub fn best_of_cpu<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, f64, T) {
    let mut cpu = f64::INFINITY;
    let (wall, out) = best_of(runs, || {
        let t = cpu_time::ThreadTime::now();
        let r = f();
        cpu = cpu.min(t.elapsed().as_secs_f64());
        r
    });
    (wall, cpu, out)
}

/// One line naming the machine: cores and CPU model (`/proc/cpuinfo`).
pub fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".to_owned());
    format!("machine: {} cores, {cpu}", cores())
}

/// The cores this process may use.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// The one-minute load average (`/proc/loadavg`), if known.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// The output of the section running now, and its headline figures.
static CAPTURE: Mutex<Capture> = Mutex::new(Capture { text: String::new(), headlines: Vec::new() });

/// What a section printed and the figures it reported for the results page.
#[derive(Debug, Default)]
pub struct Capture {
    /// Everything the section printed on standard output.
    pub text: String,
    /// Its headline figures, in the order reported.
    pub headlines: Vec<Headline>,
}

/// One row of an area's table on the results page.
#[derive(Clone, Debug)]
pub struct Headline {
    /// What was measured.
    pub case: String,
    /// The figure, with its unit.
    pub figure: String,
    /// The target, or `–`.
    pub target: String,
    /// Whether the target is met (`None`: no target, or no verdict possible).
    pub met: Option<bool>,
}

/// Prints `text` on standard output and keeps it for the raw-run file.
pub fn emit(text: &str) {
    print!("{text}");
    CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).text.push_str(text);
}

/// Records a headline figure of the running section.
pub fn headline(case: impl Into<String>, figure: impl Into<String>, target: impl Into<String>, met: Option<bool>) {
    let h = Headline { case: case.into(), figure: figure.into(), target: target.into(), met };
    CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).headlines.push(h);
}

/// Takes what was captured since the last call.
pub fn take_capture() -> Capture {
    std::mem::take(&mut *CAPTURE.lock().unwrap_or_else(std::sync::PoisonError::into_inner))
}

/// RMS distance from `points` to `mesh` (quads split along one diagonal), the measure of the
/// format and accuracy areas: a uniform grid over the triangles' boxes, searched in growing
/// rings of cells.
pub fn points_to_mesh_rms(points: &[DVec3], mesh: &Mesh) -> f64 {
    let pos = &mesh.vertices.positions;
    let tris: Vec<[DVec3; 3]> = mesh
        .faces
        .iter()
        .flat_map(|f| (1..f.len() - 1).map(move |i| [pos[f[0] as usize], pos[f[i] as usize], pos[f[i + 1] as usize]]))
        .collect();
    if tris.is_empty() || points.is_empty() {
        return f64::NAN;
    }
    let boxes: Vec<(DVec3, DVec3)> =
        tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
    let bounds = Aabb::from_points(points).union(&Aabb::from_points(pos));
    let mean_edge = boxes.iter().map(|b| (b.1 - b.0).max_element()).sum::<f64>() / boxes.len() as f64;
    let cell = mean_edge.max(bounds.diagonal() / 512.0);
    let dims = [0, 1, 2].map(|a| ((bounds.size()[a] / cell).ceil() as i64).max(1));
    let cell_of = |p: DVec3| [0, 1, 2].map(|a| (((p[a] - bounds.min[a]) / cell).floor() as i64).clamp(0, dims[a] - 1));
    let index = |c: [i64; 3]| (c[0] + dims[0] * (c[1] + dims[1] * c[2])) as usize;
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); (dims[0] * dims[1] * dims[2]) as usize];
    for (i, b) in boxes.iter().enumerate() {
        let (lo, hi) = (cell_of(b.0), cell_of(b.1));
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    cells[index([x, y, z])].push(i as u32);
                }
            }
        }
    }
    let d2: Vec<f64> = points
        .par_iter()
        .map(|&p| {
            let c = cell_of(p);
            let mut best = f64::INFINITY;
            for r in 0..=dims.iter().copied().max().unwrap_or(1) {
                for z in (c[2] - r).max(0)..=(c[2] + r).min(dims[2] - 1) {
                    for y in (c[1] - r).max(0)..=(c[1] + r).min(dims[1] - 1) {
                        for x in (c[0] - r).max(0)..=(c[0] + r).min(dims[0] - 1) {
                            if (x - c[0]).abs() != r && (y - c[1]).abs() != r && (z - c[2]).abs() != r {
                                continue;
                            }
                            for &t in &cells[index([x, y, z])] {
                                let t = &tris[t as usize];
                                best = best.min(octowrap_geom::point_triangle_squared(p, &[t[0], t[1], t[2]]));
                            }
                        }
                    }
                }
                let reach = r as f64 * cell;
                if best <= reach * reach {
                    break;
                }
            }
            best
        })
        .collect();
    (d2.iter().sum::<f64>() / d2.len() as f64).sqrt()
}
