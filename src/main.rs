//! The `tmlut` command: a thin layer over the library ([`cli`]: one file per command).

use std::process::ExitCode;

use clap::Parser;

mod cli;

fn main() -> ExitCode {
    cli::run(cli::Cli::parse())
}
