//! octowrap's benchmark report. `cargo run --release -p octowrap-bench` prints one table per
//! issue (I/O, reconstruction, format, ...); `-- io` (or another section name) runs one section.
//! Figures go to `tools/bench/RESULTS.md` with their date.
#![allow(clippy::print_stdout, clippy::print_stderr)]

mod decimate;
mod format;
mod io;
mod recon;
mod util;
mod validate;

/// jemalloc, built with transparent huge pages on (`.cargo/config.toml`): the reconstruction of
/// millions of points allocates and frees arrays of tens of megabytes per level, which the system
/// allocator maps afresh each time (a page fault per 4 KiB); see tools/bench/RESULTS.md.
#[cfg(all(unix, not(target_env = "msvc")))]
#[global_allocator]
static ALLOC: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() {
    let wanted: Vec<String> = std::env::args().skip(1).collect();
    let run = |name: &str| wanted.is_empty() || wanted.iter().any(|w| w == name);
    println!("# octowrap benchmark report");
    println!();
    println!("{}", util::machine_line());
    println!();
    if run("io") {
        io::report();
    }
    if run("recon") {
        recon::report();
    }
    if run("format") {
        format::report();
    }
    if run("validate") {
        validate::report();
    }
    if run("decimate") {
        decimate::report();
    }
}
