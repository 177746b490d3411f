//! `tmlut fit`: least-squares fits of analytic forms to a table, error against cost.

use std::path::{Path, PathBuf};

use clap::Args;

use tmlut::fit::{ALL_FORMS, Form};

use super::{Context, check_count};

/// Fit analytic approximations to a table by least squares (NLopt). `tmlut fit tir`: the built-in
/// TIR forms, error against cost (fit.json, HLSL/WGSL per form, error_vs_cost.png). `tmlut fit
/// --form FILE --table TABLE_FILE`: a form written as text (docs/fit.md, "Forms as text"), fitted
/// to any table tmlut writes (fit.json, report.md, error_map.png, residuals.png, WGSL, HLSL, GLSL,
/// MSL). `tmlut fit --scene SCENE --form A --form B ...`: TIR forms judged in the material (each
/// form file fitted to --table first, or a `tmlut fit --form` output folder used as fitted),
/// ranked by the furnace's largest error with each, the TIR table's beside them (ranking.json).
#[derive(Args)]
pub struct FitArgs {
    /// The built-in forms' table: `tir`. Not with --form.
    target: Option<String>,
    /// A form file (TOML): the table it approximates, its parameters, `let` bindings and one
    /// expression per channel. With --scene, repeated: form files (fitted to --table), folders
    /// written by `tmlut fit --form` (or their fit.json), or folders of form files.
    #[arg(long, conflicts_with_all = ["target", "forms"])]
    form: Vec<PathBuf>,
    /// Rank the --form candidates (TIR forms) by their error in this scene's materials: a
    /// furnace run with the TIR table, then one per form (tables built once, no random walk).
    #[arg(long, requires = "form")]
    scene: Option<PathBuf>,
    /// With --scene: view cosines per material.
    #[arg(long, default_value_t = tmlut::furnace::FurnaceSettings::default().views, requires = "scene")]
    views: usize,
    /// With --scene: Gauss–Legendre nodes per panel of each exact integral (docs/furnace.md).
    #[arg(long, default_value_t = tmlut::furnace::FurnaceSettings::default().exact_nodes, requires = "scene")]
    exact_nodes: usize,
    /// With --form: the most objective evaluations per start; 0 evaluates the form at its start
    /// values (the figures of published coefficients).
    #[arg(long, default_value_t = 2000, requires = "form")]
    max_evaluations: u32,
    /// With --form: certify the fitted form against exact integrals at the random points of the
    /// table's interpolation check (its points and samples from the configuration), beside the
    /// table's own error there.
    #[arg(long, requires = "form", conflicts_with = "scene")]
    certify: bool,
    /// With --form, repeatable: keep only the points with LO <= VAR <= HI, for the fit, its
    /// figures, pictures and certification; VAR a variable of the table (mu, alpha, eta, kappa)
    /// or roughness (sqrt(alpha)).
    #[arg(long, value_name = "VAR=LO:HI", requires = "form", conflicts_with = "scene")]
    range: Vec<String>,
    /// With --form: each point's weight in the objective and the weighted figures: uniform,
    /// cosine (mu, the view's cosine), or SCENE.toml (how many of the scene's materials look the
    /// table up there; docs/fit.md).
    #[arg(
        long,
        default_value = "uniform",
        value_name = "uniform|cosine|SCENE.toml",
        requires = "form",
        conflicts_with = "scene"
    )]
    weights: String,
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
    /// Timed runs per form (the median is reported); with --form, of the form and of the table's
    /// lookup over up to 4096 of the points, 0 for none.
    #[arg(long, default_value_t = 21)]
    timing_runs: usize,
}

fn form_names() -> Vec<&'static str> {
    ALL_FORMS.iter().map(|f| f.name()).collect()
}

pub fn exec(args: FitArgs, context: &Context) -> tmlut::Result<()> {
    // Each start is a whole minimisation and each timing run a pass over 2^14 queries per form.
    check_count("--starts", args.starts, 1..=1000)?;
    let settings = tmlut::fit::FitSettings {
        starts: args.starts,
        seed: args.seed,
        max_evaluations: args.max_evaluations,
        ..tmlut::fit::FitSettings::default()
    };
    if let Some(scene) = &args.scene {
        return rank(&args, scene, settings, context);
    }
    if args.form.len() > 1 {
        return Err(tmlut::Error::invalid(
            "--form",
            format!("given {} times; one form is fitted at a time, several only with --scene", args.form.len()),
        ));
    }
    if let Some(form) = args.form.first().cloned() {
        let table = tmlut::loader::load_table(&args.table)?;
        check_count("--timing-runs", args.timing_runs, 0..=1000)?;
        let ranges = args.range.iter().map(|r| tmlut::fit::text::Range::parse(r)).collect::<tmlut::Result<Vec<_>>>()?;
        let weights = tmlut::fit::text::WeightsSpec::parse(&args.weights)?;
        let certify = if args.certify { Some(args.config.load()?) } else { None };
        let request = tmlut::fit::text::FormFitRequest {
            form,
            table: args.table,
            out: args.out,
            settings,
            certify,
            ranges,
            weights,
            timing_runs: args.timing_runs,
        };
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

/// `tmlut fit --scene`: every candidate fitted (or read as fitted), then ranked in the material.
fn rank(args: &FitArgs, scene: &Path, settings: tmlut::fit::FitSettings, context: &Context) -> tmlut::Result<()> {
    use tmlut::fit::text::FittedForm;
    use tmlut::fit::text::fitting::FIT_FILE;
    check_count("--views", args.views, tmlut::furnace::VIEWS)?;
    check_count("--exact-nodes", args.exact_nodes, tmlut::integrate::quadrature::NODES)?;
    let config = args.config.load()?;
    let (scene_read, text) = tmlut::scene::Scene::read(scene)?;
    // Form files first found, then fitted in order (the table read once, where one is needed).
    let mut candidates: Vec<PathBuf> = Vec::new();
    for path in &args.form {
        if path.is_dir() && !path.join(FIT_FILE).is_file() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|source| tmlut::Error::io(path, source))?
                .filter_map(|entry| entry.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .collect();
            files.sort();
            // A folder of forms may hold forms of other tables (luts/forms/ does): those are skipped.
            files.retain(|file| {
                let table = std::fs::read_to_string(file)
                    .ok()
                    .and_then(|text| text.parse::<toml::Table>().ok())
                    .and_then(|t| t.get("table").and_then(|v| v.as_str().map(str::to_string)));
                match table.as_deref() {
                    Some("tir") | None => true,
                    Some(other) => {
                        eprintln!("skipped {}: a form for table `{other}`, not `tir`", file.display());
                        false
                    }
                }
            });
            if files.is_empty() {
                return Err(tmlut::Error::invalid(
                    format!("--form {}", path.display()),
                    format!("a folder with no {FIT_FILE} and no TIR form file (.toml)"),
                ));
            }
            candidates.extend(files);
        } else {
            candidates.push(path.clone());
        }
    }
    let mut table = None;
    let mut forms = Vec::with_capacity(candidates.len());
    for path in candidates {
        let fitted = if path.extension().is_some_and(|e| e == "toml") {
            if table.is_none() {
                table = Some(tmlut::loader::load_table(&args.table)?);
            }
            let name = tmlut::fit::text::form::form_name(&path);
            let out = args.out.join("fits").join(&name);
            let request = tmlut::fit::text::FormFitRequest {
                form: path.clone(),
                table: args.table.clone(),
                out,
                settings,
                certify: None,
                ranges: Vec::new(),
                weights: tmlut::fit::text::WeightsSpec::Uniform,
                timing_runs: 0,
            };
            let report = tmlut::fit::text::fit_form_file(table.as_ref().expect("read above"), &request)?;
            eprintln!(
                "fitted {} to {}: RMS {:.3e}, max {:.3e} over the table's points",
                path.display(),
                args.table.display(),
                report.figures.together.rms,
                report.figures.together.max
            );
            FittedForm::read(&request.out, &request.out.display().to_string())?
        } else {
            FittedForm::read(&path, &path.display().to_string())?
        };
        forms.push(fitted);
    }
    let request = tmlut::furnace::forms::FormRankRequest {
        scene: scene_read,
        source: scene.display().to_string(),
        text,
        forms,
        out: args.out.clone(),
        config,
        settings: tmlut::furnace::FurnaceSettings {
            views: args.views,
            exact_nodes: args.exact_nodes,
            ..tmlut::furnace::FurnaceSettings::default()
        },
    };
    let started = std::time::Instant::now();
    let ranking = tmlut::furnace::forms::rank_forms(&request, &context.progress())?;
    print!("{}", tmlut::furnace::forms::markdown(&ranking));
    eprintln!(
        "wrote {} ({:.1} s)",
        args.out.join(tmlut::furnace::forms::RANKING_FILE).display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
