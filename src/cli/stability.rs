//! `tmlut stability`: the stiff-case matrix over physics, tables and the model.

use clap::Args;

use super::Context;

/// Evaluate every physics function and table at the stiff cases of its domain (alpha, mu, eta,
/// kappa at and next to their edges, the critical angle, the horizon) and check finiteness,
/// range, limits, continuity, f32 against f64 and half-float storage. Exits non-zero on any
/// failure.
#[derive(Args)]
pub struct StabilityArgs {
    /// One part of the matrix (default: all).
    #[arg(long, help = format!("One part of the matrix: {} (default: all)", tmlut::stability::sections().join(", ")))]
    table: Option<String>,
}

pub fn exec(args: StabilityArgs, context: &Context) -> tmlut::Result<()> {
    let report = tmlut::stability::run(args.table.as_deref())?;
    // --quiet lists only failures and stated limitations; otherwise every case.
    print!("{}", report.render(!context.quiet));
    if report.passed() {
        Ok(())
    } else {
        Err(tmlut::Error::invalid(
            "stability",
            format!("{} checks failed", report.count(tmlut::stability::Outcome::Fail)),
        ))
    }
}
