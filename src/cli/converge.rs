//! `tmlut converge`: error against run time for one table.

use std::path::PathBuf;

use clap::Args;

use tmlut::report::converge;

use super::{ConfigArg, Context, ThreadsArg, check_count, check_sample_count};

/// Error against run time: sweep the samples per cell (powers of two) for the fast build and the
/// per-cell Monte Carlo method, and the Gauss–Legendre nodes per panel of the per-cell quadrature;
/// measure error on a fixed random subset of cells against the exact integral, and write
/// converge_TABLE.csv and converge_TABLE.png (log-log, one line per method, every point labelled).
#[derive(Args)]
pub struct ConvergeArgs {
    /// The table to sweep.
    #[arg(help = format!("The table to sweep: {}", tmlut::config::TableKind::names().join(", ")))]
    table: String,
    #[command(flatten)]
    config: ConfigArg,
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
    /// Smallest and largest Gauss–Legendre nodes per panel of the per-cell quadrature (2 to 63,
    /// below --reference-nodes): both, and the counts 3, 4, 6, 8, 12, 16, 24, 32, 48 between them.
    #[arg(long, default_value_t = 2)]
    nodes_from: usize,
    #[arg(long, default_value_t = 32)]
    nodes_to: usize,
    /// Gauss–Legendre nodes per panel of each reference cell: the exact integral, by the
    /// deterministic quadrature (2 to 64).
    #[arg(long, default_value_t = 64)]
    reference_nodes: usize,
    /// After the sweep, answer for each method how many samples per cell (or, for the quadrature,
    /// nodes per panel) give this RMS error (a positive number, e.g. 1e-4): the smallest swept
    /// count that reaches it, or for Monte Carlo one extrapolated from the last points' log-log
    /// slope (said so). Also writes converge_TABLE.json.
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    target_error: Option<String>,
    #[command(flatten)]
    threads: ThreadsArg,
}

pub fn exec(args: ConvergeArgs, context: &Context) -> tmlut::Result<()> {
    let target = args.target_error.as_deref().map(converge::parse_target_error).transpose()?;
    let config = args.config.load()?;
    args.threads.apply()?;
    for (key, n) in [("--samples-from", args.samples_from), ("--samples-to", args.samples_to)] {
        check_sample_count(key, n)?;
    }
    // Every cell is a reference integral and one per-cell run per sample count.
    check_count("--cells", args.cells, 1..=100_000)?;
    if args.samples_from > args.samples_to {
        return Err(tmlut::Error::invalid(
            "--samples-from/--samples-to",
            format!("{} > {}; allowed: samples-from <= samples-to", args.samples_from, args.samples_to),
        ));
    }
    let samples = (args.samples_from.trailing_zeros()..=args.samples_to.trailing_zeros()).map(|k| 1u64 << k).collect();
    for (key, n) in [("--nodes-from", args.nodes_from), ("--nodes-to", args.nodes_to)] {
        check_count(key, n, tmlut::integrate::quadrature::NODES)?;
    }
    if args.nodes_from > args.nodes_to {
        return Err(tmlut::Error::invalid(
            "--nodes-from/--nodes-to",
            format!("{} > {}; allowed: nodes-from <= nodes-to", args.nodes_from, args.nodes_to),
        ));
    }
    let settings = converge::ConvergeSettings {
        samples,
        nodes: converge::node_counts(args.nodes_from, args.nodes_to),
        cells: args.cells,
        reference_nodes: args.reference_nodes,
    };
    settings.validate()?;
    let points = converge::converge(&config, &args.table, &settings, &context.progress())?;
    print!("{}", converge::csv(&points));
    let answers = target.map(|e| converge::target_answers(&points, e)).unwrap_or_default();
    for answer in &answers {
        println!("{}", answer.line());
    }
    for path in converge::write(&args.out, &args.table, &points, &settings, &answers)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
