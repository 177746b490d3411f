//! `tmlut fit`: least-squares fits of analytic forms to a table, error against cost.

use std::path::PathBuf;

use clap::Args;

use tmlut::fit::{ALL_FORMS, Form};

use super::{Context, check_count};

/// Fit analytic approximations to a table by least squares (NLopt). `tmlut fit tir`: the built-in
/// TIR forms, error against cost (fit.json, HLSL/WGSL per form, error_vs_cost.png). `tmlut fit
/// --form FILE --table TABLE_FILE`: a form written as text (docs/fit.md, "Forms as text"), fitted
/// to any table tmlut writes (fit.json, report.md, WGSL, HLSL, GLSL, MSL).
#[derive(Args)]
pub struct FitArgs {
    /// The built-in forms' table: `tir`. Not with --form.
    target: Option<String>,
    /// A form file (TOML): the table it approximates, its parameters, `let` bindings and one
    /// expression per channel.
    #[arg(long, conflicts_with_all = ["target", "forms", "timing_runs"])]
    form: Option<PathBuf>,
    /// With --form: the most objective evaluations per start; 0 evaluates the form at its start
    /// values (the figures of published coefficients).
    #[arg(long, default_value_t = 2000, requires = "form")]
    max_evaluations: u32,
    /// With --form: certify the fitted form against exact integrals at the random points of the
    /// table's interpolation check (its points and samples from the configuration), beside the
    /// table's own error there.
    #[arg(long, requires = "form")]
    certify: bool,
    #[command(flatten)]
    config: super::ConfigArg,
    /// Comma-separated forms (default: all).
    #[arg(long, value_delimiter = ',', help = format!("Comma-separated forms (default: all). Known: {}", form_names().join(", ")))]
    forms: Option<Vec<String>>,
    /// The table: a `.dds` or `.exr` written by `tmlut build` (a DDS reads its axes from the
    /// manifest.json beside it), or, for TIR, the original `.bin` layout.
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
    // Each start is a whole minimisation and each timing run a pass over 2^14 queries per form.
    check_count("--starts", args.starts, 1..=1000)?;
    if let Some(form) = args.form {
        let table = tmlut::loader::load_table(&args.table)?;
        let settings = tmlut::fit::FitSettings {
            starts: args.starts,
            seed: args.seed,
            max_evaluations: args.max_evaluations,
            ..tmlut::fit::FitSettings::default()
        };
        let certify = if args.certify { Some(args.config.load()?) } else { None };
        let request = tmlut::fit::text::FormFitRequest { form, table: args.table, out: args.out, settings, certify };
        let report = tmlut::fit::text::fit_form_file(&table, &request)?;
        print!("{}", tmlut::fit::text::fitting::markdown(&report));
        println!("Wrote {}", request.out.join(tmlut::fit::text::fitting::FIT_FILE).display());
        return Ok(());
    }
    match args.target.as_deref() {
        Some("tir") => {}
        other => {
            return Err(tmlut::Error::invalid(
                "fit target",
                format!("{}; allowed: tir, or --form FILE --table TABLE_FILE", other.unwrap_or("none given")),
            ));
        }
    }
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
