//! One module per subcommand.

pub mod convert;
pub mod decimate;
pub mod export;
pub mod extract;
pub mod info;
pub mod input;
pub mod mrq;
pub mod reconstruct;
pub mod tile;
pub mod tileset;
pub mod validate;
pub mod view;

use std::process::ExitCode;

use crate::args::{Cli, Command};

/// Runs the chosen subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Reconstruct(a) => reconstruct::run(&a),
        Command::Convert(a) => convert::run(&a),
        Command::Extract(a) => extract::run(&a),
        Command::Info(a) => info::run(&a),
        Command::Validate(a) => validate::run(&a),
        Command::Decimate(a) => decimate::run(&a),
        Command::Export(a) => export::run(&a),
        Command::View(a) => view::run(&a),
        Command::Tile(a) => tile::run(&a),
    }
}
