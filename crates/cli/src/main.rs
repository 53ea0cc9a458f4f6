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
