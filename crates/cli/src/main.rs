//! The `octowrap` command line. One file per subcommand under `cmd/`; arguments in `args.rs`.
//!
//! Exit codes: 0 success, 1 a check failed (for example `validate` found a required property
//! missing), 2 the command could not run (unreadable input, bad arguments), 130 and 143 stopped by
//! SIGINT and SIGTERM (after removing the temporary files of writes in progress).
//!
//! Standard output is written through `out::stdout` only, so that a reader closing the pipe
//! (`octowrap info FILE | head -1`) ends the command quietly with success; messages go to
//! standard error through `say!`, which never panics.

#[macro_use]
mod out;
mod args;
mod cmd;
mod limits;
mod progress;

use std::process::ExitCode;

use clap::Parser;

/// jemalloc, built with transparent huge pages on (`.cargo/config.toml`): the reconstruction of
/// millions of points allocates and frees arrays of tens of megabytes per level, which the system
/// allocator maps afresh each time (a page fault per 4 KiB); see `docs/decisions.md`,
/// Benchmarks, "The binaries allocate with jemalloc".
#[cfg(all(unix, not(target_env = "msvc")))]
#[global_allocator]
static ALLOC: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() -> ExitCode {
    out::remove_temporaries_on_signals();
    let cli = args::Cli::parse();
    limits::set_max_memory(cli.max_memory);
    limits::set_max_scans(cli.max_scans);
    match cmd::run(cli) {
        Ok(code) => code,
        Err(err) if out::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            say!("error: {err:#}");
            ExitCode::from(2)
        }
    }
}
