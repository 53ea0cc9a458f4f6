//! Shared bench helpers: timing, data paths, machine description.

use std::path::PathBuf;
use std::time::Instant;

/// The shared data folder, if present.
pub fn shared_data() -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::var_os("OCTOWRAP_DATA").map_or_else(|| root.join("../shared/data"), PathBuf::from);
    dir.is_dir().then_some(dir)
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

/// One line naming the machine: cores and CPU model.
pub fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".to_owned());
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    format!("machine: {cores} cores, {cpu}")
}
