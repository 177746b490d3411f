//! `tmlut pack-report`: the error of FGD's GPU packings, through the GPU emulator.

use std::path::PathBuf;

use clap::Args;

use tmlut::formats::Precision;
use tmlut::packing::Packing;
use tmlut::packing::report::ReportSettings;

use super::{ConfigArg, Context, ThreadsArg, check_count, check_sample_count, one_of};

/// Measure FGD packings: the emulated shader lookup at random points against 4D multilinear
/// interpolation of the table and against the integral. Prints a Markdown table.
#[derive(Args)]
pub struct PackReportArgs {
    /// The 4D FGD table (`tmlut build --only fgd` writes it as fgd.exr; the original layout as fgd.bin).
    #[arg(long, default_value = "out/luts/fgd.exr")]
    table: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// Comma-separated packings (default: all).
    #[arg(long, value_delimiter = ',', help = format!("Comma-separated packings (default: all). Known: {}", Packing::names()))]
    packing: Option<Vec<String>>,
    /// Storage precision of the packed textures: f32 or f16.
    #[arg(long, default_value = "f32", value_parser = parse_precision)]
    precision: Precision,
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
    #[command(flatten)]
    threads: ThreadsArg,
}

fn parse_precision(text: &str) -> Result<Precision, String> {
    one_of(text, &[("f32", Precision::F32), ("f16", Precision::F16)])
}

pub fn exec(args: PackReportArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    // The query points are held in memory at once (a few tens of bytes each, per packing), and
    // each reference point is an integral.
    check_count("--points", args.points, 1..=10_000_000)?;
    check_count("--reference-points", args.reference_points, 0..=100_000)?;
    if args.reference_points > 0 {
        check_sample_count("--reference-samples", args.reference_samples)?;
    }
    check_count("--weight-bits", args.weight_bits, 1..=23)?;
    let packings = match &args.packing {
        Some(names) => names.iter().map(|n| Packing::parse(n)).collect::<tmlut::Result<Vec<_>>>()?,
        None => Packing::ALL.to_vec(),
    };
    // A `.bin` file names no axes; the FGD table's are (mu, alpha, eta, kappa).
    let fgd = if args.table.extension().is_some_and(|e| e == "bin") {
        tmlut::formats::bin::read_bin(&args.table, Some(&tmlut::packing::FGD_INPUTS))?
    } else {
        tmlut::loader::load_table(&args.table)?
    };
    let settings = ReportSettings {
        points: args.points,
        reference_points: args.reference_points,
        reference_samples: args.reference_samples,
        seed: args.seed,
        weight_bits: args.weight_bits,
    };
    let report = tmlut::packing::report::report(
        &fgd,
        &config.fgd,
        &packings,
        args.precision,
        true,
        &settings,
        &context.progress(),
    )?;
    print!("{}", tmlut::packing::report::markdown(&report));
    Ok(())
}
