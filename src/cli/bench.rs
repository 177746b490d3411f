//! `tmlut bench`: build time and error of each table beside the per-cell method.

use clap::Args;

use tmlut::pipeline;
use tmlut::report::bench::{self, BenchSettings};

use super::{ConfigArg, Context, ThreadsArg, check_count};

/// Time each table's build and measure its error against the exact integral at random nodes,
/// beside the per-cell method on the same nodes. Prints a Markdown table.
#[derive(Args)]
pub struct BenchArgs {
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

pub fn exec(args: BenchArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    check_count("--reference-nodes", args.reference_nodes, tmlut::integrate::quadrature::NODES)?;
    // Each repeat is a whole build, and each node a reference integral: beyond these a bench runs
    // for days, and the nodes' arithmetic overflows.
    check_count("--repeats", args.repeats, 1..=100)?;
    check_count("--nodes", args.nodes, 1..=100_000)?;
    check_count("--per-cell-nodes", args.per_cell_nodes, 0..=100_000)?;
    let tables = pipeline::resolve_tables(args.only.as_deref())?;
    let settings = BenchSettings {
        repeats: args.repeats,
        nodes: args.nodes,
        reference_nodes: args.reference_nodes,
        per_cell_nodes: args.per_cell_nodes,
        ..BenchSettings::default()
    };
    let rows = bench::bench(&config, &tables, &settings, &context.progress())?;
    print!("{}", bench::markdown(&rows, &settings, rayon::current_num_threads()));
    if let Some(bytes) = bench::peak_memory_bytes() {
        println!("Peak resident memory of the run: {:.0} MiB.", bytes as f64 / (1 << 20) as f64);
    }
    Ok(())
}
