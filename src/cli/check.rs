//! `tmlut check`: hold an output folder to its budgets.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use tmlut::report::check;

use super::{Context, exit_status};

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
    /// Budgets file (default: the committed budgets.toml, for the default LUT set).
    #[arg(long)]
    budgets: Option<PathBuf>,
    /// Print the findings as JSON instead of lines.
    #[arg(long)]
    json: bool,
}

pub fn exec(args: CheckArgs, _: &Context) -> ExitCode {
    let findings = match findings(&args) {
        Ok(findings) => findings,
        Err(e) => return exit_status(Err(e), ExitCode::from(COULD_NOT_RUN)),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&findings).expect("findings are plain data"));
    } else {
        print!("{}", check::render(&findings));
    }
    let failed = findings.iter().filter(|f| !f.pass).count();
    let result = if failed > 0 {
        Err(tmlut::Error::invalid(args.dir.display().to_string(), format!("{failed} budget(s) exceeded (see above)")))
    } else {
        Ok(())
    };
    exit_status(result, ExitCode::from(EXCEEDED))
}

/// Every finding, or why the folder could not be checked.
fn findings(args: &CheckArgs) -> tmlut::Result<Vec<check::Finding>> {
    let budgets = match &args.budgets {
        Some(path) => check::Budgets::from_file(path)?,
        None => check::Budgets::from_toml(check::DEFAULT_BUDGETS, "budgets.toml (built in)")?,
    };
    check::check_folder(&args.dir, &budgets)
}
