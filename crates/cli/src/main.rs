//! The `octowrap` command line. One file per subcommand under `cmd/`; arguments in `args.rs`.
//!
//! Exit codes: 0 success, 1 a check failed (for example `validate` found a required property
//! missing), 2 the command could not run (unreadable input, bad arguments).
#![allow(clippy::print_stderr, clippy::print_stdout)]

mod args;
mod cmd;
mod progress;

use std::process::ExitCode;

use clap::Parser;

/// jemalloc, built with transparent huge pages on (`.cargo/config.toml`): the reconstruction of
/// millions of points allocates and frees arrays of tens of megabytes per level, which the system
/// allocator maps afresh each time (a page fault per 4 KiB); see tools/bench/RESULTS.md.
#[cfg(all(unix, not(target_env = "msvc")))]
#[global_allocator]
static ALLOC: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    match cmd::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::from(2)
        }
    }
}
