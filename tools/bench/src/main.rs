//! octowrap's benchmark report. `cargo run --release -p octowrap-bench` prints one table per
//! area (I/O, reconstruction, format, chunks, validator, decimation, 3D Tiles, the browser viewer, fuzzing, the Python package, hostile input); `-- io` (or other area names) runs
//! those areas. `--write-results` also puts each area's headline figures on the results page,
//! `tools/bench/RESULTS.md`, and its full output in `tools/bench/runs/` (`results.rs`).
//!
//! `-- meshopt-simplify IN OUT RATIO` is the meshoptimizer driver the decimation area times
//! beside `octowrap decimate` (`decimate.rs`).
#![allow(clippy::print_stdout, clippy::print_stderr)]

/// `print!` that also keeps the text for the raw-run file.
macro_rules! out {
    ($($t:tt)*) => { $crate::util::emit(&format!($($t)*)) };
}

/// `println!` that also keeps the text for the raw-run file.
macro_rules! outln {
    () => { $crate::util::emit("\n") };
    ($($t:tt)*) => { $crate::util::emit(&format!("{}\n", format_args!($($t)*))) };
}

mod accuracy;
mod browser;
mod chunks;
mod decimate;
mod format;
mod fuzz;
#[cfg(unix)]
mod hostile;
mod io;
mod python;
mod recon;
mod results;
mod stages;
mod tiles;
mod util;
mod validate;

/// jemalloc, built with transparent huge pages on (`.cargo/config.toml`): the reconstruction of
/// millions of points allocates and frees arrays of tens of megabytes per level, which the system
/// allocator maps afresh each time (a page fault per 4 KiB); see `docs/decisions.md`.
#[cfg(all(unix, not(target_env = "msvc")))]
#[global_allocator]
static ALLOC: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

/// The hostile-input probe (`hostile.rs`), on Unix only (FIFOs, device nodes, modes, signals).
fn hostile_report() {
    #[cfg(unix)]
    hostile::report();
    #[cfg(not(unix))]
    outln!("## Hostile input (issue 17)\n\nnot measured: the probe needs a Unix system\n");
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("meshopt-simplify") {
        return decimate::meshopt_driver(&args[1..]);
    }
    let write_results = args.iter().any(|a| a == "--write-results");
    let wanted: Vec<&String> = args.iter().filter(|a| *a != "--write-results").collect();
    if let Some(bad) = wanted.iter().find(|w| !results::AREAS.iter().any(|a| a.0 == w.as_str())) {
        let names: Vec<&str> = results::AREAS.iter().map(|a| a.0).collect();
        eprintln!("unknown area '{bad}': the areas are {}", names.join(", "));
        return std::process::ExitCode::from(2);
    }
    println!("# octowrap benchmark report");
    println!();
    println!("{}", util::machine_line());
    println!();
    let sections: &[(&str, fn())] = &[
        ("io", io::report),
        ("recon", recon::report),
        ("format", format::report),
        ("chunks", chunks::report),
        ("accuracy", accuracy::report),
        ("validate", validate::report),
        ("decimate", decimate::report),
        ("tiles", tiles::report),
        ("browser", browser::report),
        ("fuzz", fuzz::report),
        ("python", python::report),
        ("hostile", hostile_report),
    ];
    for &(name, report) in sections {
        if !(wanted.is_empty() || wanted.iter().any(|w| *w == name)) {
            continue;
        }
        let mut info = results::RunInfo::start(name);
        let _ = util::take_capture();
        report();
        let capture = util::take_capture();
        info.load.1 = util::load_average();
        if write_results {
            match results::write(name, &info, &capture) {
                Ok(raw) => eprintln!("{name}: RESULTS.md updated, full output in {}", raw.display()),
                Err(e) => {
                    eprintln!("{name}: cannot write the results: {e}");
                    return std::process::ExitCode::from(2);
                }
            }
        }
    }
    std::process::ExitCode::SUCCESS
}
