//! `tmlut audit`: a table an engine ships, measured against exact integrals.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::Context;
use super::check::{COULD_NOT_RUN, EXCEEDED};

/// Measure a table an engine ships against exact integrals, with the engine's conventions (a preset).
///
/// At the texels of the engine's layout: per channel the RMS, 99th percentile and largest |error|
/// and where, NaN or infinity in the file as a finding, and the cause where one is
/// recognisable (half-float rounding, the sample noise of N samples, a line or the table shifted
/// by one texel, swapped axes, a flipped axis, the other masking model). Reads the preset's engine
/// file (threejs: DFGLUTData.js) or a DDS, KTX2 or OpenEXR table of its shape in tmlut's layout.
/// Exit status as `check`: 0 measured, 1 the largest |error| over --budget, 2 the file could not
/// be read or audited.
#[derive(Args)]
pub struct AuditArgs {
    /// The table file to audit.
    file: PathBuf,
    /// The engine's conventions: a preset of luts/presets/ by name (`tmlut list`), or the path of
    /// a preset file (`.toml`).
    #[arg(long)]
    preset: String,
    /// Print the report as JSON (numbers as numbers; also when the file cannot be read).
    #[arg(long)]
    json: bool,
    /// Also write audit.json and a heat map of |error| per channel (audit_<channel>.png) into this
    /// folder, and nowhere else.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// The largest |error| allowed in any channel; exit status 1 beyond it (a non-finite value
    /// exceeds every budget).
    #[arg(long, value_name = "X")]
    budget: Option<f64>,
}

pub fn exec(args: AuditArgs, context: &Context) -> ExitCode {
    let progress = context.progress();
    let result = (|| {
        if let Some(budget) = args.budget
            && !(budget.is_finite() && budget >= 0.0)
        {
            return Err(tmlut::Error::invalid("--budget", format!("{budget}: a finite |error| of 0 or more")));
        }
        let preset = tmlut::presets::Preset::load(&args.preset)?;
        let audit = tmlut::report::audit::audit(&args.file, &preset, &progress)?;
        if let Some(dir) = &args.out {
            audit.write(dir, args.budget)?;
        }
        Ok(audit)
    })();
    let audit = match result {
        Ok(audit) => audit,
        Err(e) => {
            if args.json {
                let report = serde_json::json!({ "status": "error", "error": e.to_string() });
                println!("{}", serde_json::to_string_pretty(&report).expect("a string prints"));
            }
            eprintln!("error: {e}");
            return ExitCode::from(COULD_NOT_RUN);
        }
    };
    if args.json {
        print!("{}", audit.to_json(args.budget));
    } else {
        print!("{}", audit.render());
    }
    match args.budget {
        Some(budget) if audit.largest_error() > budget => {
            eprintln!(
                "error: {}: the largest |error| {:.3e} is over the budget {budget:.3e}",
                args.file.display(),
                audit.largest_error()
            );
            ExitCode::from(EXCEEDED)
        }
        _ => ExitCode::SUCCESS,
    }
}
