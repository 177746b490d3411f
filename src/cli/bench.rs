//! `tmlut bench`: the measurements of `docs/benchmark.md`, one suite at a time, each printed as
//! Markdown: the tables (the default), the random walk, the furnace's walk workload, the exact
//! integrals against Monte Carlo; and materials baked, against their model.

use clap::{Args, Subcommand};

use std::path::PathBuf;

use tmlut::bake::BakeSettings;
use tmlut::exact::MONTE_CARLO_REPLICATES;
use tmlut::pipeline;
use tmlut::random_walk::{BATCH_PATHS, MAX_PATHS, WalkSettings};
use tmlut::report::bench::bake::{self, BakeBenchSettings};
use tmlut::report::bench::furnace::{self, FurnaceBenchSettings};
use tmlut::report::bench::peak_memory_bytes;
use tmlut::report::bench::quadrature::{self, QuadratureBenchSettings};
use tmlut::report::bench::tables::{self, BenchSettings};
use tmlut::report::bench::walk::{self, WalkBenchSettings};

use super::{ConfigArg, Context, ThreadsArg, check_count, check_sample_count};

/// Measure and print a Markdown section for docs/benchmark.md. Without a suite, `tables`: time
/// each table's build and measure its error against the exact integral at random nodes, beside
/// the per-cell method on the same nodes.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_value_name = "SUITE", subcommand_help_heading = "Suites")]
pub struct BenchArgs {
    #[command(subcommand)]
    suite: Option<Suite>,
    #[command(flatten)]
    tables: TablesArgs,
}

#[derive(Subcommand)]
enum Suite {
    /// Each table's build time and error beside the per-cell method (the default).
    Tables(TablesArgs),
    /// The random walk's wall time per path on two stacks at three views, on one thread and on
    /// --threads.
    Walk(WalkArgs),
    /// The furnace test's random walk over six materials at --views view cosines, timed.
    Furnace(FurnaceWorkloadArgs),
    /// The furnace's exact integrals against Monte Carlo on the hardest lookups; exits non-zero
    /// when any disagrees.
    Quadrature(QuadratureArgs),
    /// Each material of some scenes baked from exact integrals, timed, with its baked values
    /// against its model.
    Bake(BakeArgs),
}

#[derive(Args)]
struct TablesArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Comma-separated tables (default: all).
    #[arg(long, value_delimiter = ',')]
    only: Option<Vec<String>>,
    /// Builds per table; the median is reported.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Random nodes compared with references.
    #[arg(long, default_value_t = 300)]
    nodes: usize,
    /// Gauss–Legendre nodes per panel of each reference node's exact integral (2 to 64).
    #[arg(long, default_value_t = 64)]
    reference_nodes: usize,
    /// Nodes the per-cell method runs on (the first of the compared nodes).
    #[arg(long, default_value_t = 300)]
    per_cell_nodes: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

#[derive(Args)]
struct WalkArgs {
    /// Paths per run (rounded up to whole batches of 1024).
    #[arg(long, default_value_t = WalkBenchSettings::default().paths)]
    paths: u64,
    /// Runs per stack, view and thread count; the median is reported.
    #[arg(long, default_value_t = WalkBenchSettings::default().repeats)]
    repeats: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

#[derive(Args)]
struct FurnaceWorkloadArgs {
    /// View cosines per material, uniform in mu from 0 to 1.
    #[arg(long, default_value_t = FurnaceBenchSettings::default().views)]
    views: usize,
    /// The most paths a view traces (it stops earlier at the furnace's standard error, after at
    /// least 2^14 paths or this many if fewer).
    #[arg(long, default_value_t = WalkSettings::default().max_paths)]
    max_paths: u64,
    /// Runs of the whole workload; the medians are reported.
    #[arg(long, default_value_t = FurnaceBenchSettings::default().repeats)]
    repeats: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

#[derive(Args)]
struct QuadratureArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Monte Carlo samples per lookup: a power of two from 2^4 to 2^24.
    #[arg(long, default_value_t = QuadratureBenchSettings::default().samples)]
    samples: u64,
    #[command(flatten)]
    threads: ThreadsArg,
}

#[derive(Args)]
struct BakeArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Scene files, or folders of them (every `*.toml`, sorted).
    #[arg(long = "scene", default_value = "luts/scenes")]
    scenes: Vec<PathBuf>,
    /// Nodes of mu per material.
    #[arg(long, default_value_t = BakeSettings::default().nodes)]
    nodes: usize,
    /// Views per node interval the errors are measured at (1 to 64).
    #[arg(long, default_value_t = 4)]
    error_views: usize,
    /// Gauss–Legendre nodes per panel of the exact integrals (2 to 64).
    #[arg(long, default_value_t = tmlut::exact::DEFAULT_NODES)]
    exact_nodes: usize,
    /// Materials also baked alone, each with exact integrals of its own, and timed: the first
    /// this many (0 to all).
    #[arg(long, default_value_t = 32)]
    alone: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

/// A suite's runs: beyond this a bench runs for days.
const REPEATS: std::ops::RangeInclusive<usize> = 1..=100;

pub fn exec(args: BenchArgs, context: &Context) -> tmlut::Result<()> {
    match args.suite {
        None => exec_tables(args.tables, context),
        Some(Suite::Tables(tables)) => exec_tables(tables, context),
        Some(Suite::Walk(walk)) => exec_walk(walk),
        Some(Suite::Furnace(furnace)) => exec_furnace(furnace, context),
        Some(Suite::Quadrature(quadrature)) => exec_quadrature(quadrature, context),
        Some(Suite::Bake(bake)) => exec_bake(bake, context),
    }
}

fn exec_tables(args: TablesArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    check_count("--reference-nodes", args.reference_nodes, tmlut::integrate::quadrature::NODES)?;
    // Each repeat is a whole build, and each node a reference integral: beyond these the nodes'
    // arithmetic overflows.
    check_count("--repeats", args.repeats, REPEATS)?;
    check_count("--nodes", args.nodes, 1..=100_000)?;
    check_count("--per-cell-nodes", args.per_cell_nodes, 0..=100_000)?;
    let tables = pipeline::resolve_tables(&config, args.only.as_deref())?;
    let settings = BenchSettings {
        repeats: args.repeats,
        nodes: args.nodes,
        reference_nodes: args.reference_nodes,
        per_cell_nodes: args.per_cell_nodes,
        ..BenchSettings::default()
    };
    let rows = tables::bench(&config, &tables, &settings, &context.progress())?;
    print!("{}", tables::markdown(&rows, &settings, rayon::current_num_threads()));
    if let Some(bytes) = peak_memory_bytes() {
        println!("Peak resident memory of the run: {:.0} MiB.", bytes as f64 / (1 << 20) as f64);
    }
    Ok(())
}

fn exec_walk(args: WalkArgs) -> tmlut::Result<()> {
    args.threads.apply()?;
    check_count("--paths", args.paths, BATCH_PATHS..=MAX_PATHS)?;
    check_count("--repeats", args.repeats, REPEATS)?;
    let mut thread_counts = vec![1, rayon::current_num_threads()];
    thread_counts.dedup();
    let settings = WalkBenchSettings { paths: args.paths, repeats: args.repeats, thread_counts };
    let timings = walk::bench_walk(&settings)?;
    print!("{}", walk::markdown(&timings, &settings));
    Ok(())
}

fn exec_furnace(args: FurnaceWorkloadArgs, context: &Context) -> tmlut::Result<()> {
    args.threads.apply()?;
    check_count("--views", args.views, tmlut::furnace::VIEWS)?;
    check_count("--max-paths", args.max_paths, 1..=MAX_PATHS)?;
    check_count("--repeats", args.repeats, REPEATS)?;
    let defaults = WalkSettings::default();
    let walk =
        WalkSettings { min_paths: defaults.min_paths.min(args.max_paths), max_paths: args.max_paths, ..defaults };
    let settings = FurnaceBenchSettings { views: args.views, repeats: args.repeats, walk };
    let bench = furnace::bench_furnace(&settings, &context.progress())?;
    print!("{}", furnace::markdown(&bench, &settings, rayon::current_num_threads()));
    Ok(())
}

fn exec_quadrature(args: QuadratureArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    // The standard errors come from the spread of the replicates, which need a point each.
    if args.samples < u64::from(MONTE_CARLO_REPLICATES) {
        return Err(tmlut::Error::invalid(
            "--samples",
            format!(
                "{}; allowed: a power of two from {MONTE_CARLO_REPLICATES} (one point per replicate) to 2^24",
                args.samples
            ),
        ));
    }
    check_sample_count("--samples", args.samples)?;
    let settings = QuadratureBenchSettings { samples: args.samples, ..QuadratureBenchSettings::default() };
    let bench = quadrature::bench_quadrature(&config, &settings, &context.progress())?;
    print!("{}", quadrature::markdown(&bench, &settings));
    bench.verdict()
}

fn exec_bake(args: BakeArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    check_count("--nodes", args.nodes, tmlut::bake::NODES)?;
    check_count("--error-views", args.error_views, 1..=64)?;
    check_count("--exact-nodes", args.exact_nodes, tmlut::integrate::quadrature::NODES)?;
    let settings = BakeBenchSettings {
        scenes: args.scenes,
        bake: BakeSettings { nodes: args.nodes, ..BakeSettings::default() },
        error_views_per_interval: args.error_views,
        exact_nodes: args.exact_nodes,
        alone: args.alone,
    };
    let bench = bake::bench_bake(&config, &settings, &context.progress())?;
    print!("{}", bake::markdown(&bench, &settings, rayon::current_num_threads()));
    Ok(())
}
