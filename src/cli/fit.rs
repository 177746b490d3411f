//! `tmlut fit`: least-squares fits of forms written as text to a table.

use std::path::{Path, PathBuf};

use clap::Args;

use super::{Context, check_count};

/// Fit forms written as text to a table by least squares (NLopt). `tmlut fit --form FILE --table
/// TABLE_FILE`: a form file (docs/fit.md, "Forms as text") fitted to any table tmlut writes
/// (fit.json, report.md, error_map.png, residuals.png, WGSL, HLSL, GLSL, MSL). `--form DIR`: every
/// form file of the folder for that table, each into its own folder of --out, ranked by max error
/// then RMS (forms.json; `--form luts/forms --table tir.dds` fits every TIR form). For a file
/// or a folder, --range keeps a box of the table, --weights weighs its points, and each report
/// states the form's operations and, with --timing-runs, its CPU time beside the table's lookup.
/// `tmlut fit --scene SCENE --form A --form B ...`: TIR forms judged in the material (each form file fitted
/// to --table first, or a `tmlut fit --form` output folder used as fitted), ranked by the
/// furnace's largest error with each, the TIR table's beside them (ranking.json).
#[derive(Args)]
pub struct FitArgs {
    /// A form file (TOML): the table it approximates, its parameters, `let` bindings and one
    /// expression per channel; or a folder of form files. With --scene, repeated: form files
    /// (fitted to --table), folders written by `tmlut fit --form` (or their fit.json), or folders
    /// of form files.
    #[arg(long, required = true)]
    form: Vec<PathBuf>,
    /// Rank the --form candidates (TIR forms) by their error in this scene's materials: a
    /// furnace run with the TIR table, then one per form (tables built once, no random walk).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// With --scene: view cosines per material.
    #[arg(long, default_value_t = tmlut::furnace::FurnaceSettings::default().views, requires = "scene")]
    views: usize,
    /// With --scene: Gauss–Legendre nodes per panel of each exact integral (docs/furnace.md).
    #[arg(long, default_value_t = tmlut::furnace::FurnaceSettings::default().exact_nodes, requires = "scene")]
    exact_nodes: usize,
    /// The most objective evaluations per start; 0 evaluates the form at its start values (the
    /// figures of published coefficients).
    #[arg(long, default_value_t = 2000)]
    max_evaluations: u32,
    /// Certify the fitted form against exact integrals at the random points of the table's
    /// interpolation check (its points and samples from the configuration), beside the table's
    /// own error there. A scene's slice is certified where the scene's lookups of it are made, the
    /// slice planned again from the scene its folder's manifest records.
    #[arg(long, conflicts_with = "scene")]
    certify: bool,
    /// Repeatable: keep only the points with LO <= VAR <= HI, for the fit, its figures, pictures
    /// and certification (of every form, with a folder); VAR a variable of the table (mu, alpha,
    /// eta, kappa) or roughness (sqrt(alpha)).
    #[arg(long, value_name = "VAR=LO:HI", conflicts_with = "scene")]
    range: Vec<String>,
    /// Each point's weight in the objective and the weighted figures (with a folder, the
    /// ranking's): uniform, cosine (mu, the view's cosine), or SCENE.toml (how many of the
    /// scene's materials look the table up there; docs/fit.md).
    #[arg(long, default_value = "uniform", value_name = "uniform|cosine|SCENE.toml", conflicts_with = "scene")]
    weights: String,
    #[command(flatten)]
    config: super::ConfigArg,
    /// The table: a `.dds` or `.exr` written by `tmlut build` (a DDS reads its axes from the
    /// manifest.json beside it).
    #[arg(long, default_value = "out/luts/tir.dds")]
    table: PathBuf,
    #[arg(long, default_value = "fit")]
    out: PathBuf,
    /// Seed of the multi-start points (same table and seed: same coefficients).
    #[arg(long, default_value_t = 2021)]
    seed: u64,
    /// Starts per fitted form.
    #[arg(long, default_value_t = 6)]
    starts: usize,
    /// Timed runs per form of the form and of the table's lookup, each over up to 4096 of the
    /// points (the median is reported); 0 for none. Not with --scene.
    #[arg(long, default_value_t = 21, conflicts_with = "scene")]
    timing_runs: usize,
}

pub fn exec(args: FitArgs, context: &Context) -> tmlut::Result<()> {
    // Each start is a whole minimisation.
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
            format!(
                "given {} times; one form file or folder is fitted at a time, several only with --scene",
                args.form.len()
            ),
        ));
    }
    let form = args.form[0].clone();
    let table = tmlut::loader::load_table(&args.table)?;
    // Each timing run is a pass over up to 4096 points per form and of the table's lookup.
    check_count("--timing-runs", args.timing_runs, 0..=1000)?;
    let ranges = args.range.iter().map(|r| tmlut::fit::forms::Range::parse(r)).collect::<tmlut::Result<Vec<_>>>()?;
    let weights = tmlut::fit::forms::WeightsSpec::parse(&args.weights)?;
    // The scene's lookups of the table, read once for every form.
    let scene = match &weights {
        tmlut::fit::forms::WeightsSpec::Scene(path) => Some(tmlut::scene::lookups::table_lookups(path, &table.name)?),
        _ => None,
    };
    // The exact integrals every form is certified against, computed once.
    let certify = match args.certify {
        true => Some(std::sync::Arc::new(tmlut::scene::certify::exact_values_for(
            &args.table,
            &table.name,
            &args.config.load()?,
            settings.seed,
            &context.progress(),
        )?)),
        false => None,
    };
    let options = tmlut::fit::forms::FitOptions {
        table: args.table,
        settings,
        certify,
        ranges,
        weights,
        scene,
        timing_runs: args.timing_runs,
    };
    if form.is_dir() {
        let (files, skipped) = tmlut::fit::forms::form::form_files_for(&form, &table.name)?;
        skipped.iter().for_each(|note| eprintln!("{note}"));
        let request = tmlut::fit::forms::FolderFitRequest { files, out: args.out, options };
        let fits = tmlut::fit::forms::fit_form_files(&table, &request)?;
        print!("{}", tmlut::fit::forms::markdown::ranking_markdown(&fits));
        println!("Wrote {}", request.out.join(tmlut::fit::forms::fitting::FORMS_FILE).display());
        return Ok(());
    }
    let request = tmlut::fit::forms::FormFitRequest { form, out: args.out, options };
    let report = tmlut::fit::forms::fit_form_file(&table, &request)?;
    print!("{}", tmlut::fit::forms::markdown::markdown(&report));
    println!("Wrote {}", request.out.join(tmlut::fit::forms::fitting::FIT_FILE).display());
    Ok(())
}

/// `tmlut fit --scene`: every candidate fitted (or read as fitted), then ranked in the material.
fn rank(args: &FitArgs, scene: &Path, settings: tmlut::fit::FitSettings, context: &Context) -> tmlut::Result<()> {
    check_count("--views", args.views, tmlut::furnace::VIEWS)?;
    check_count("--exact-nodes", args.exact_nodes, tmlut::integrate::quadrature::NODES)?;
    let config = args.config.load()?;
    let (scene_read, text) = tmlut::scene::Scene::read(scene)?;
    let forms = tmlut::furnace::forms::fitted_candidates(
        &args.form,
        &args.table,
        &args.out,
        settings,
        &mut |path, report| {
            eprintln!(
                "fitted {} to {}: RMS {:.3e}, max {:.3e} over the table's points",
                path.display(),
                args.table.display(),
                report.figures.together.rms,
                report.figures.together.max
            )
        },
        &mut |note| eprintln!("{note}"),
    )?;
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
