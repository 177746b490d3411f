//! `tmlut check`: hold an output folder to its budgets.

use std::path::PathBuf;

use clap::Args;

use tmlut::report::check;

use super::Context;

/// Check an output folder against error budgets: SHA-256 of every file, NaN count, value
/// range, error and build time. Exits non-zero naming every budget exceeded.
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

pub fn exec(args: CheckArgs, _: &Context) -> tmlut::Result<()> {
    let budgets = match &args.budgets {
        Some(path) => check::Budgets::from_file(path)?,
        None => check::Budgets::from_toml(check::DEFAULT_BUDGETS, "budgets.toml (built in)")?,
    };
    let findings = check::check_folder(&args.dir, &budgets)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&findings).expect("findings are plain data"));
    } else {
        print!("{}", check::render(&findings));
    }
    let failed = findings.iter().filter(|f| !f.pass).count();
    if failed > 0 {
        return Err(tmlut::Error::invalid(
            args.dir.display().to_string(),
            format!("{failed} budget(s) exceeded (see above)"),
        ));
    }
    Ok(())
}
