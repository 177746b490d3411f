//! The `tmlut` command: a thin layer over the library. Parsing arguments, progress bars and exit
//! codes live here; everything else is in `tmlut::*`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use tmlut::config::Config;
use tmlut::integrate::{Method, Progress};
use tmlut::packing::Packing;
use tmlut::packing::report::ReportSettings;
use tmlut::pipeline::{self, BuildRequest};
use tmlut::recipes::TABLES;
use tmlut::report::bench::{self, BenchSettings};
use tmlut::report::{check, converge};
use tmlut::scene::Scene;
use tmlut::scene::build::{SceneBuildRequest, build_scene};
use tmlut::scene::plan::{human_bytes, plan};

#[derive(Parser)]
#[command(
    name = "tmlut",
    version,
    about = "Integrate, write, check and inspect the lookup tables of transfer-matrix layered materials"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print no progress bars, only results and errors.
    #[arg(long, short, global = true)]
    quiet: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Integrate tables and write them, with a manifest.json, into a folder.
    Build {
        /// TOML configuration (every key optional; see luts/default.toml).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Comma-separated tables to build (default: all). See `tmlut list`.
        #[arg(long, value_delimiter = ',')]
        only: Option<Vec<String>>,
        /// Output folder.
        #[arg(long, default_value = "luts")]
        out: PathBuf,
        /// Worker threads (default: one per core). Results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of the Monte Carlo estimates, overriding the configuration's.
        #[arg(long)]
        seed: Option<u64>,
        /// Integration method of every table, overriding the configuration's: `fast` (one
        /// measure per (mu, alpha)) or `per-cell` (every cell on its own; slow, for cross-checks).
        #[arg(long, value_parser = parse_method)]
        method: Option<Method>,
        /// Also write each table's error map: maps/<table>_error.exr (every node's replicate
        /// standard error) and maps/<table>_error.png (heatmaps with a colour bar).
        #[arg(long)]
        error_maps: bool,
        /// Build only what this scene's materials need (see `tmlut plan`); the configuration
        /// still sets samples, masking and precision. Records the scene and plan in the manifest.
        #[arg(long, conflicts_with = "only")]
        scene: Option<PathBuf>,
    },
    /// Print the build plan of a scene: the lookups its materials make, each table built with its
    /// size and reason, each table or range left out with its reason, and the total bytes against
    /// the default set. Integrates nothing.
    Plan {
        /// Scene file (TOML; see luts/scenes/ and docs/scenes.md).
        scene: PathBuf,
        /// TOML configuration of the tables (default: the built-in defaults).
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Time each table's build and measure its error against per-cell references, beside the
    /// per-cell method on the same nodes. Prints a Markdown table.
    Bench {
        /// TOML configuration of the tables (default: the built-in defaults).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Comma-separated tables (default: all).
        #[arg(long, value_delimiter = ',')]
        only: Option<Vec<String>>,
        /// Builds per table; the median is reported.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Random nodes compared with references.
        #[arg(long, default_value_t = 300)]
        nodes: usize,
        /// Samples per reference node (a power of two).
        #[arg(long, default_value_t = 1 << 22)]
        reference_samples: u64,
        /// Nodes the per-cell method runs on (the first of the compared nodes).
        #[arg(long, default_value_t = 300)]
        per_cell_nodes: usize,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Check an output folder against error budgets: SHA-256 of every file, NaN count, value
    /// range, error and build time. Exits non-zero naming every budget exceeded.
    Check {
        /// The output folder (with its manifest.json).
        dir: PathBuf,
        /// Budgets file (default: the committed budgets.toml, for the default LUT set).
        #[arg(long)]
        budgets: Option<PathBuf>,
        /// Print the findings as JSON instead of lines.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate every physics function and table at the stiff cases of its domain (alpha, mu, eta,
    /// kappa at and next to their edges, the critical angle, the horizon) and check finiteness,
    /// range, limits, continuity, f32 against f64 and half-float storage. Exits non-zero on any
    /// failure.
    Stability {
        /// One part of the matrix: physics, fgd, gd, tir, belcour, karis, f16 or model (default: all).
        #[arg(long)]
        table: Option<String>,
    },
    /// Measure FGD packings: the emulated shader lookup at random points against 4D multilinear
    /// interpolation of the table and against the integral. Prints a Markdown table.
    PackReport {
        /// The 4D FGD table (`tmlut build --only fgd` writes it as fgd.exr; the original layout as fgd.bin).
        #[arg(long, default_value = "luts/fgd.exr")]
        table: PathBuf,
        /// TOML configuration whose [fgd] masking the integral is computed with (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Comma-separated packings (default: all). Known: thesis, lossless-filtered, lossless.
        #[arg(long, value_delimiter = ',')]
        packing: Option<Vec<String>>,
        /// Storage precision of the packed textures: f32 or f16.
        #[arg(long, default_value = "f32", value_parser = parse_precision)]
        precision: tmlut::formats::Precision,
        /// Random query points.
        #[arg(long, default_value_t = 100_000)]
        points: usize,
        /// Query points also compared with the integral (per-cell f64 estimates).
        #[arg(long, default_value_t = 1000)]
        reference_points: usize,
        /// Samples per integral estimate (a power of two).
        #[arg(long, default_value_t = 1 << 16)]
        reference_samples: u64,
        #[arg(long, default_value_t = 2021)]
        seed: u64,
        /// Fractional bits of the hardware filter weights for the quantised column.
        #[arg(long, default_value_t = 8)]
        weight_bits: u32,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Error against run time: sweep the samples per cell (powers of two) for the fast build and
    /// the per-cell method, measure error on a fixed random subset against high-sample references,
    /// and write converge_TABLE.csv and converge_TABLE.png (log-log, one line per method).
    Converge {
        /// The table to sweep.
        table: String,
        /// TOML configuration (default: the built-in defaults).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Output folder of the CSV and the plot.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
        /// Smallest and largest samples per cell (powers of two).
        #[arg(long, default_value_t = 256)]
        samples_from: u64,
        #[arg(long, default_value_t = 65536)]
        samples_to: u64,
        /// Cells of the fixed random subset the error is measured on.
        #[arg(long, default_value_t = 64)]
        cells: usize,
        /// Samples per reference cell (a power of two).
        #[arg(long, default_value_t = 1 << 20)]
        reference_samples: u64,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Fit analytic approximations to a table by least squares (NLopt) and report error against
    /// cost: `tmlut fit tir`. Writes fit.json, HLSL/WGSL per fitted form and error_vs_cost.png.
    Fit {
        /// The table to fit; only `tir` today.
        target: String,
        /// Comma-separated forms (default: all). Known: eq56, eq56-corrected, logistic, smoothstep,
        /// algebraic, rational.
        #[arg(long, value_delimiter = ',')]
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
    },
    /// The furnace test of a scene's materials: the directional albedo A(mu) of the transfer-matrix
    /// model with the scene's tables, with exact integrals, and from a random walk through the
    /// explicit stack, so that the tables' error and the model's are measured apart. Writes
    /// <out>/<scene>/furnace.json and per material a furnace sphere (.exr, .png) and an A(mu)
    /// plot; prints a Markdown summary.
    Furnace {
        /// Scene files (default: every scene of luts/scenes/).
        scenes: Vec<PathBuf>,
        /// A folder built for the scene (tmlut build --scene), or the default set; default: build
        /// the scene's plan into <out>/<scene>/luts first.
        #[arg(long)]
        luts: Option<PathBuf>,
        /// Output folder; each scene writes into a subfolder named after it.
        #[arg(long, default_value = "furnace")]
        out: PathBuf,
        /// TOML configuration the scene's tables are built with (default: the built-in defaults).
        #[arg(long)]
        config: Option<PathBuf>,
        /// View cosines per material, uniform in angle, grazing included.
        #[arg(long, default_value_t = 64)]
        views: usize,
        /// Samples of each exact integral (a power of two).
        #[arg(long, default_value_t = 1 << 16)]
        exact_samples: u64,
        /// The random walk stops at this standard error of A in every channel ...
        #[arg(long, default_value_t = tmlut::random_walk::WalkSettings::default().target_standard_error)]
        walk_standard_error: f64,
        /// ... after at least this many paths per view ...
        #[arg(long, default_value_t = tmlut::random_walk::WalkSettings::default().min_paths)]
        walk_min_paths: u64,
        /// ... and at most this many.
        #[arg(long, default_value_t = tmlut::random_walk::WalkSettings::default().max_paths)]
        walk_max_paths: u64,
        /// Masking of the random walk's interfaces: smith-separable (as the tables) or
        /// smith-height-correlated.
        #[arg(long, default_value = "smith-separable", value_parser = parse_walk_masking)]
        walk_masking: tmlut::random_walk::Masking,
        /// The full FGD table read where a folder has both: packing (fgd_lossless.dds through its
        /// shader) or table (fgd.bin, 4D CPU interpolation).
        #[arg(long, default_value = "packing", value_parser = parse_fgd_source)]
        fgd_source: tmlut::model::folder::FgdSource,
        /// Seed of the random walk (the exact integrals use the configuration's seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Sphere size of the pictures, in pixels.
        #[arg(long, default_value_t = 256)]
        picture_size: usize,
        /// Worker threads (default: one per core). Results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Write a scene's transfer-matrix shader (WGSL and HLSL) over a built folder: one function
    /// per material returning its lobes and directional albedo, reading the folder's tables with
    /// the manifest's coordinates (docs/shaders.md).
    Shader {
        /// Scene file (TOML; see luts/scenes/).
        scene: PathBuf,
        /// The folder built for the scene (tmlut build --scene), or one holding the tables it reads.
        #[arg(long)]
        luts: PathBuf,
        /// Output folder for <scene>.wgsl, <scene>.hlsl, <scene>.shader.json.
        #[arg(long)]
        out: PathBuf,
        /// Also write <scene>.reference.json: the CPU evaluator at this many views per material.
        #[arg(long, default_value_t = 0)]
        reference_views: usize,
    },
    /// List the tables tmlut knows.
    List,
    /// Describe a table file: axes, channels, value range, NaN count, conventions.
    Inspect { file: PathBuf },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> tmlut::Result<()> {
    match cli.command {
        Command::Build { config, only, out, threads, seed, method, error_maps, scene } => {
            let mut config = Config::load(config.as_deref())?;
            if let Some(seed) = seed {
                config.seed = seed;
            }
            if let Some(method) = method {
                config.set_method(method);
            }
            set_threads(threads)?;
            let progress = ProgressBars::new(cli.quiet);
            let written = match scene {
                Some(path) => {
                    let (scene, text) = Scene::read(&path)?;
                    let request = SceneBuildRequest {
                        scene,
                        source: path.clone(),
                        text,
                        config,
                        out,
                        error_maps,
                        accuracy_reports: true,
                    };
                    let (plan, written) = build_scene(&request, &progress)?;
                    println!(
                        "scene `{}`: {} table(s), {} of texels against {} for the default set",
                        plan.scene,
                        plan.tables.len(),
                        human_bytes(plan.bytes),
                        human_bytes(plan.default_set_bytes)
                    );
                    for warning in &plan.warnings {
                        eprintln!("warning: {warning}");
                    }
                    write_shader(&path, &request.out, &request.out)?;
                    written
                }
                None => pipeline::build(&BuildRequest { config, only, out, error_maps }, &progress)?,
            };
            for file in written {
                let e = &file.entry;
                let reference = e.error.integration.reference.as_ref().map_or(String::new(), |r| {
                    format!(", reference max |diff| {:.2e} ({} values)", r.difference.max, r.difference.count)
                });
                println!(
                    "{}  {} bytes  built in {:.2} s, replicate s.e. max {:.2e}{reference}",
                    file.path.display(),
                    e.bytes,
                    e.wall_time_s,
                    e.error.integration.replicate_standard_error.max,
                );
                for interpolation in &e.error.interpolation {
                    println!(
                        "    interpolated vs the exact integral, {}: RMS {:.2e}, max {:.2e}",
                        interpolation.domain, interpolation.error.rms, interpolation.error.max
                    );
                }
                for accuracy in &e.accuracy {
                    let what = accuracy.what.split(['(', ';']).next().unwrap_or_default().trim_end();
                    println!("    {what}: RMS {:.2e}, max {:.2e}", accuracy.error.rms, accuracy.error.max);
                }
            }
            Ok(())
        }
        Command::Shader { scene, luts, out, reference_views } => {
            let (scene, _) = Scene::read(&scene)?;
            for path in tmlut::scene::shader::write_scene_shader(&scene, &luts, &out, reference_views)? {
                println!("{}", path.display());
            }
            Ok(())
        }
        Command::Plan { scene, config } => {
            let config = Config::load(config.as_deref())?;
            let (scene, _) = Scene::read(&scene)?;
            print!("{}", plan(&scene, &config)?);
            Ok(())
        }
        Command::Fit { target, forms, table, out, seed, starts, timing_runs } => {
            if target != "tir" {
                return Err(tmlut::Error::invalid("fit target", format!("{target}; allowed: tir")));
            }
            let forms = match forms {
                None => tmlut::fit::ALL_FORMS.to_vec(),
                Some(names) => names
                    .iter()
                    .map(|n| {
                        tmlut::fit::Form::from_name(n).ok_or_else(|| {
                            let known: Vec<&str> = tmlut::fit::ALL_FORMS.iter().map(|f| f.name()).collect();
                            tmlut::Error::invalid("--forms", format!("{n}; allowed: {}", known.join(", ")))
                        })
                    })
                    .collect::<tmlut::Result<Vec<_>>>()?,
            };
            // A `.bin` file names no axes; the original layout's are (mu, alpha, eta).
            let loaded = match tmlut::loader::format_of(&table)? {
                tmlut::formats::FileFormat::Bin => {
                    tmlut::formats::bin::read_bin(&table, Some(&["mu", "alpha", "eta"]))?
                }
                _ => tmlut::loader::load_table(&table)?,
            };
            let settings = tmlut::fit::FitSettings { starts, seed, ..tmlut::fit::FitSettings::default() };
            let request = tmlut::fit::FitRequest {
                table_path: table,
                forms,
                out,
                settings,
                timing_runs,
                timing_queries: 1 << 14,
            };
            let manifest = tmlut::fit::fit_tir(&loaded, &request)?;
            println!(
                "| form | parameters | RMSE | MSE | max error | at (mu, alpha, eta) | ns/eval (f32) | status (best start) |"
            );
            println!("|---|---|---|---|---|---|---|---|");
            for f in &manifest.forms {
                let at = f.figures.max_at;
                let status = f.search.as_ref().map_or("-".to_string(), |s| {
                    format!(
                        "{} ({}/{} starts succeeded)",
                        s.starts[s.best_start].status,
                        s.starts.iter().filter(|x| x.succeeded).count(),
                        s.starts.len()
                    )
                });
                println!(
                    "| {} | {} | {:.4} | {:.5} | {:.3} | ({:.3}, {:.3}, {:.3}) | {:.2} | {status} |",
                    f.name,
                    f.parameters.len(),
                    f.figures.rmse,
                    f.figures.mse,
                    f.figures.max_abs_error,
                    at[0],
                    at[1],
                    at[2],
                    f.cost_ns_per_evaluation_f32,
                );
            }
            println!(
                "| table fetch (GPU emulator, trilinear) | - | 0 at nodes | - | - | - | {:.2} | - |",
                manifest.table_fetch_cost_ns_f32
            );
            println!(
                "best form costing no more than eq56: {}",
                manifest.best_under_eq56_cost.as_deref().unwrap_or("none (eq56 not requested, or none cheaper)")
            );
            println!("wrote {}", request.out.join("fit.json").display());
            Ok(())
        }
        Command::Bench { config, only, repeats, nodes, reference_samples, per_cell_nodes, threads } => {
            let config = Config::load(config.as_deref())?;
            set_threads(threads)?;
            tmlut::sampling::sequence::SamplePlan::new(reference_samples, 1)
                .map_err(|e| tmlut::Error::invalid("--reference-samples", e.to_string()))?;
            let tables = pipeline::resolve_tables(only.as_deref())?;
            let settings =
                BenchSettings { repeats, nodes, reference_samples, per_cell_nodes, ..BenchSettings::default() };
            let progress = ProgressBars::new(cli.quiet);
            let rows = bench::bench(&config, &tables, &settings, &progress)?;
            print!("{}", bench::markdown(&rows, &settings, rayon::current_num_threads()));
            if let Some(bytes) = bench::peak_memory_bytes() {
                println!("Peak resident memory of the run: {:.0} MiB.", bytes as f64 / (1 << 20) as f64);
            }
            Ok(())
        }
        Command::Check { dir, budgets, json } => {
            let budgets = match &budgets {
                Some(path) => check::Budgets::from_file(path)?,
                None => check::Budgets::from_toml(check::DEFAULT_BUDGETS, "budgets.toml (built in)")?,
            };
            let findings = check::check_folder(&dir, &budgets)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&findings).expect("findings are plain data"));
            } else {
                print!("{}", check::render(&findings));
            }
            let failed = findings.iter().filter(|f| !f.pass).count();
            if failed > 0 {
                return Err(tmlut::Error::invalid(
                    dir.display().to_string(),
                    format!("{failed} budget(s) exceeded (see above)"),
                ));
            }
            Ok(())
        }
        Command::Stability { table } => {
            let report = tmlut::stability::run(table.as_deref())?;
            // --quiet lists only failures and stated limitations; otherwise every case.
            print!("{}", report.render(!cli.quiet));
            if report.passed() {
                Ok(())
            } else {
                Err(tmlut::Error::invalid(
                    "stability",
                    format!("{} checks failed", report.count(tmlut::stability::Outcome::Fail)),
                ))
            }
        }
        Command::PackReport {
            table,
            config,
            packing,
            precision,
            points,
            reference_points,
            reference_samples,
            seed,
            weight_bits,
            threads,
        } => {
            let config = Config::load(config.as_deref())?;
            set_threads(threads)?;
            if reference_points > 0 {
                tmlut::sampling::sequence::SamplePlan::new(reference_samples, 1)
                    .map_err(|e| tmlut::Error::invalid("--reference-samples", e.to_string()))?;
            }
            if !(1..=23).contains(&weight_bits) {
                return Err(tmlut::Error::invalid("--weight-bits", format!("{weight_bits}; allowed: 1 to 23")));
            }
            let packings = match packing {
                Some(names) => names.iter().map(|n| Packing::parse(n)).collect::<tmlut::Result<Vec<_>>>()?,
                None => Packing::ALL.to_vec(),
            };
            // A `.bin` file names no axes; the FGD table's are (mu, alpha, eta, kappa).
            let fgd = if table.extension().is_some_and(|e| e == "bin") {
                tmlut::formats::bin::read_bin(&table, Some(&tmlut::packing::FGD_INPUTS))?
            } else {
                tmlut::loader::load_table(&table)?
            };
            let settings = ReportSettings { points, reference_points, reference_samples, seed, weight_bits };
            let progress = ProgressBars::new(cli.quiet);
            let report =
                tmlut::packing::report::report(&fgd, &config.fgd, &packings, precision, true, &settings, &progress)?;
            print!("{}", tmlut::packing::report::markdown(&report));
            Ok(())
        }
        Command::Converge { table, config, out, samples_from, samples_to, cells, reference_samples, threads } => {
            let config = Config::load(config.as_deref())?;
            set_threads(threads)?;
            for (key, n) in [
                ("--samples-from", samples_from),
                ("--samples-to", samples_to),
                ("--reference-samples", reference_samples),
            ] {
                tmlut::sampling::sequence::SamplePlan::new(n, 1)
                    .map_err(|e| tmlut::Error::invalid(key, e.to_string()))?;
            }
            if samples_from > samples_to || cells == 0 {
                return Err(tmlut::Error::invalid(
                    "--samples-from/--samples-to/--cells",
                    "allowed: samples-from <= samples-to, at least one cell",
                ));
            }
            let samples = (samples_from.trailing_zeros()..=samples_to.trailing_zeros()).map(|k| 1u64 << k).collect();
            let settings = converge::ConvergeSettings { samples, cells, reference_samples };
            let progress = ProgressBars::new(cli.quiet);
            let points = converge::converge(&config, &table, &settings, &progress)?;
            print!("{}", converge::csv(&points));
            for path in converge::write(&out, &table, &points, &settings)? {
                println!("wrote {}", path.display());
            }
            Ok(())
        }
        Command::Furnace {
            scenes,
            luts,
            out,
            config,
            views,
            exact_samples,
            walk_standard_error,
            walk_min_paths,
            walk_max_paths,
            walk_masking,
            fgd_source,
            seed,
            picture_size,
            threads,
        } => {
            let config = Config::load(config.as_deref())?;
            set_threads(threads)?;
            let scenes = if scenes.is_empty() {
                let examples = std::path::Path::new("luts/scenes");
                if !examples.is_dir() {
                    return Err(tmlut::Error::invalid(
                        "furnace",
                        "no scene given, and no luts/scenes/ here to take the example scenes from; give scene files, or run from the repository's root",
                    ));
                }
                tmlut::furnace::scene_files(examples)?
            } else {
                scenes
            };
            if luts.is_some() && scenes.len() > 1 {
                return Err(tmlut::Error::invalid(
                    "--luts",
                    format!("given with {} scenes; a folder of tables serves one scene", scenes.len()),
                ));
            }
            let settings = tmlut::furnace::FurnaceSettings {
                views,
                exact_samples,
                walk: tmlut::random_walk::WalkSettings {
                    seed,
                    target_standard_error: walk_standard_error,
                    min_paths: walk_min_paths,
                    max_paths: walk_max_paths,
                    masking: walk_masking,
                    ..Default::default()
                },
                fgd_source,
                picture_size,
                ..Default::default()
            };
            settings.validate()?;
            let progress = ProgressBars::new(cli.quiet);
            let mut summary = String::from(tmlut::furnace::report::MARKDOWN_HEADER);
            for path in scenes {
                let (scene, text) = Scene::read(&path)?;
                for warning in &scene.warnings {
                    eprintln!("warning: {warning}");
                }
                let request = tmlut::furnace::FurnaceRequest {
                    out: out.join(tmlut::furnace::report::file_stem(&scene.name)),
                    scene,
                    source: path.display().to_string(),
                    text,
                    luts: luts.clone(),
                    config: config.clone(),
                    settings: settings.clone(),
                };
                let report = tmlut::furnace::run(&request, &progress)?;
                summary.push_str(&tmlut::furnace::report::markdown_rows(&report));
                eprintln!("wrote {}", request.out.join(tmlut::furnace::report::FURNACE_FILE).display());
            }
            print!("{summary}");
            Ok(())
        }
        Command::List => {
            for (name, description) in TABLES {
                println!("{name:<8} {description}");
            }
            Ok(())
        }
        Command::Inspect { file } => {
            let inspection = tmlut::report::inspect(&file)?;
            print!("{}", inspection.text);
            if inspection.disagreements.is_empty() {
                Ok(())
            } else {
                Err(tmlut::Error::format(
                    &file,
                    format!(
                        "differs from its entry in manifest.json in {} way(s) (see DIFFERS above)",
                        inspection.disagreements.len()
                    ),
                ))
            }
        }
    }
}

fn parse_method(text: &str) -> Result<Method, String> {
    match text {
        "fast" => Ok(Method::Fast),
        "per-cell" => Ok(Method::PerCell),
        other => Err(format!("`{other}`; allowed: fast, per-cell")),
    }
}

fn parse_precision(text: &str) -> Result<tmlut::formats::Precision, String> {
    match text {
        "f32" => Ok(tmlut::formats::Precision::F32),
        "f16" => Ok(tmlut::formats::Precision::F16),
        other => Err(format!("`{other}`; allowed: f32, f16")),
    }
}

fn parse_walk_masking(text: &str) -> Result<tmlut::random_walk::Masking, String> {
    use tmlut::random_walk::Masking;
    [Masking::Separable, Masking::HeightCorrelated]
        .into_iter()
        .find(|m| m.name() == text)
        .ok_or_else(|| format!("`{text}`; allowed: smith-separable, smith-height-correlated"))
}

fn parse_fgd_source(text: &str) -> Result<tmlut::model::folder::FgdSource, String> {
    use tmlut::model::folder::FgdSource;
    match text {
        "packing" => Ok(FgdSource::Packing),
        "table" => Ok(FgdSource::Table),
        other => Err(format!("`{other}`; allowed: packing, table")),
    }
}

/// The most worker threads `--threads` starts: results do not depend on the count, and far more
/// threads than cores only cost (each is started at once, with its own stack).
const MAX_THREADS: usize = 1024;

fn set_threads(threads: Option<usize>) -> tmlut::Result<()> {
    let Some(threads) = threads else { return Ok(()) };
    if !(1..=MAX_THREADS).contains(&threads) {
        return Err(tmlut::Error::invalid("--threads", format!("{threads}; allowed: 1 to {MAX_THREADS}")));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|e| tmlut::Error::invalid("--threads", e.to_string()))
}

/// One progress bar per long step, on standard error; nothing with `--quiet` or when standard
/// error is not a terminal (indicatif hides itself there).
struct ProgressBars {
    quiet: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl ProgressBars {
    fn new(quiet: bool) -> Self {
        ProgressBars { quiet, bar: Mutex::new(None) }
    }
}

impl Progress for ProgressBars {
    fn start(&self, label: &str, total: u64) {
        if self.quiet {
            return;
        }
        let bar = ProgressBar::new(total).with_message(label.to_string());
        bar.set_style(
            ProgressStyle::with_template("{msg:>16} [{bar:40}] {pos}/{len} cells, {elapsed} (eta {eta})")
                .expect("the template is valid")
                .progress_chars("=> "),
        );
        *self.bar.lock().expect("progress lock") = Some(bar);
    }

    fn advance(&self, done: u64) {
        if let Some(bar) = &*self.bar.lock().expect("progress lock") {
            bar.inc(done);
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }

    fn note(&self, message: &str) {
        eprintln!("note: {message}");
    }
}

/// `build --scene` writes the scene's shader beside its tables, where the shader covers the scene.
fn write_shader(scene: &std::path::Path, luts: &std::path::Path, out: &std::path::Path) -> tmlut::Result<()> {
    let (scene, _) = Scene::read(scene)?;
    match tmlut::scene::shader::write_scene_shader(&scene, luts, out, 0) {
        Ok(paths) => {
            for path in paths {
                println!("{}", path.display());
            }
        }
        Err(e) => eprintln!("note: no shader written for scene `{}`: {e}", scene.name),
    }
    Ok(())
}
