//! `tmlut check`: hold an output folder to its budgets.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use tmlut::report::check;
use tmlut::report::ci::{CheckReport, Status};

use super::Context;

/// Exit status of `check` when every check ran and some budget was exceeded.
pub const EXCEEDED: u8 = 1;
/// Exit status of `check` when it could not check at all: a missing folder, a manifest it cannot
/// read, a budgets file it refuses. CI tells this broken job from a table that got worse.
pub const COULD_NOT_RUN: u8 = 2;

/// Check an output folder against error budgets: SHA-256 of every file, NaN count, value
/// range and error. Exit status: 0 every budget held, 1 a budget exceeded (each one named),
/// 2 the folder could not be checked (missing folder, unreadable manifest, bad budgets file).
#[derive(Args)]
pub struct CheckArgs {
    /// The output folder (with its manifest.json).
    dir: PathBuf,
    /// Budgets file (default: the budgets of the preset the folder was built with, `tmlut build
    /// --preset`, else the committed budgets.toml, for the default LUT set).
    #[arg(long)]
    budgets: Option<PathBuf>,
    /// Hold the folder to this preset's budgets: a name (`tmlut list`) or a preset file.
    #[arg(long, value_name = "NAME|FILE", conflicts_with = "budgets")]
    preset: Option<String>,
    /// How findings are printed: lines; json (one report: status, summary, findings with numbers
    /// as numbers, printed even when the folder cannot be checked); github (workflow commands: an
    /// error annotation per exceeded budget and a notice with the counts).
    #[arg(long, value_enum, default_value_t = Format::Lines)]
    format: Format,
    /// The same as --format json.
    #[arg(long, conflicts_with = "format")]
    json: bool,
    /// Fail every file, and every furnace scene, that no budget holds (by its table, its slice
    /// kind such as `[fgd_slice]`, its scene or `[furnace_every_material]`), instead of reporting
    /// its figures unchecked.
    #[arg(long)]
    strict: bool,
    /// Also write a JUnit XML report to this file (one test case per check; written whole or
    /// not at all, also when the folder cannot be checked).
    #[arg(long, value_name = "FILE")]
    junit: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    Lines,
    Json,
    Github,
}

pub fn exec(args: CheckArgs, _: &Context) -> ExitCode {
    let format = if args.json { Format::Json } else { args.format };
    let report = match findings(&args) {
        Ok(findings) => CheckReport::of(findings),
        Err(e) => CheckReport::could_not_run(e.to_string()),
    };
    let folder = args.dir.display().to_string();
    match format {
        Format::Json => print!("{}", report.to_json()),
        Format::Github => print!("{}", report.to_github(&folder)),
        Format::Lines => {
            if report.status != Status::Error {
                print!("{}", check::render(&report.findings));
            }
        }
    }
    let mut status = match report.status {
        Status::Passed => ExitCode::SUCCESS,
        Status::Failed => ExitCode::from(EXCEEDED),
        Status::Error => ExitCode::from(COULD_NOT_RUN),
    };
    match &report.error {
        Some(error) => eprintln!("error: {error}"),
        None if report.status == Status::Failed => {
            eprintln!("error: {folder}: {} budget(s) exceeded (see above)", report.summary.failed)
        }
        None => {}
    }
    if let Some(path) = &args.junit
        && let Err(e) = tmlut::formats::write_bytes_atomically(path, report.to_junit(&folder).as_bytes())
    {
        eprintln!("error: --junit {}: {e}", path.display());
        status = ExitCode::from(COULD_NOT_RUN);
    }
    status
}

/// Every finding, or why the folder could not be checked.
fn findings(args: &CheckArgs) -> tmlut::Result<Vec<check::Finding>> {
    let mut budgets = match (&args.budgets, &args.preset) {
        (Some(path), _) => check::Budgets::from_file(path)?,
        (None, Some(preset)) => check::Budgets::of_preset(&tmlut::presets::Preset::load(preset)?)?,
        (None, None) => check::Budgets::for_folder(&args.dir)?,
    };
    budgets.strict = args.strict;
    check::check_folder(&args.dir, &budgets)
}
