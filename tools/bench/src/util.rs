//! Shared bench helpers: timing, data paths, machine description, and the capture of a
//! section's output (its full text for the raw-run file, its headline figures for the results
//! page, `results.rs`).

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

/// The shared data folder ([`octowrap_testdata::data_root`]), if present. Silent when absent: each
/// bench area says what it skips.
pub fn shared_data() -> Option<PathBuf> {
    let dir = octowrap_testdata::data_root();
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
