//! `tmlut fit`: least-squares fits of analytic forms to a table, error against cost.

use std::path::PathBuf;

use clap::Args;

use tmlut::fit::{ALL_FORMS, Form};

use super::{Context, check_count};

/// Fit analytic approximations to a table by least squares (NLopt) and report error against
/// cost: `tmlut fit tir`. Writes fit.json, HLSL/WGSL per fitted form and error_vs_cost.png.
#[derive(Args)]
pub struct FitArgs {
    /// The table to fit; only `tir` today.
    target: String,
    /// Comma-separated forms (default: all).
    #[arg(long, value_delimiter = ',', help = format!("Comma-separated forms (default: all). Known: {}", form_names().join(", ")))]
    forms: Option<Vec<String>>,
    /// The TIR table: a `.dds` or `.exr` written by `tmlut build` (a DDS reads its axes from the
    /// manifest.json beside it), or the original `.bin` layout.
    #[arg(long, default_value = "luts/tir.dds")]
    table: PathBuf,
    #[arg(long, default_value = "fit")]
    out: PathBuf,
    /// Seed of the multi-start points (same table and seed: same coefficients).
    #[arg(long, default_value_t = 2021)]
    seed: u64,
    /// Starts per fitted form.
    #[arg(long, default_value_t = 6)]
    starts: usize,
    /// Timed runs per form (the median is reported).
    #[arg(long, default_value_t = 21)]
    timing_runs: usize,
}

fn form_names() -> Vec<&'static str> {
    ALL_FORMS.iter().map(|f| f.name()).collect()
}

pub fn exec(args: FitArgs, _: &Context) -> tmlut::Result<()> {
    if args.target != "tir" {
        return Err(tmlut::Error::invalid("fit target", format!("{}; allowed: tir", args.target)));
    }
    // Each start is a whole minimisation and each timing run a pass over 2^14 queries per form.
    check_count("--starts", args.starts, 1..=1000)?;
    check_count("--timing-runs", args.timing_runs, 1..=1000)?;
    let forms = match &args.forms {
        None => ALL_FORMS.to_vec(),
        Some(names) => names
            .iter()
            .map(|n| {
                Form::from_name(n).ok_or_else(|| {
                    tmlut::Error::invalid("--forms", format!("{n}; allowed: {}", form_names().join(", ")))
                })
            })
            .collect::<tmlut::Result<Vec<_>>>()?,
    };
    // A `.bin` file names no axes; the original layout's are (mu, alpha, eta).
    let loaded = match tmlut::loader::format_of(&args.table)? {
        tmlut::formats::FileFormat::Bin => tmlut::formats::bin::read_bin(&args.table, Some(&["mu", "alpha", "eta"]))?,
        _ => tmlut::loader::load_table(&args.table)?,
    };
    let settings =
        tmlut::fit::FitSettings { starts: args.starts, seed: args.seed, ..tmlut::fit::FitSettings::default() };
    let request = tmlut::fit::FitRequest {
        table_path: args.table,
        forms,
        out: args.out,
        settings,
        timing_runs: args.timing_runs,
        timing_queries: 1 << 14,
    };
    let manifest = tmlut::fit::fit_tir(&loaded, &request)?;
    print!("{}", tmlut::fit::summary::markdown(&manifest, &request.out.join("fit.json")));
    Ok(())
}
