//! `tmlut bench quadrature`: the exact integrals of the furnace test (the visible-normal
//! quadrature) against per-cell Monte Carlo on the lookups where they are hardest, and against a
//! rule of four times the nodes: the validation `docs/furnace.md` quotes. A check as much as a
//! measurement: [`QuadratureBench::verdict`] fails when any lookup disagrees.

use std::fmt::Write;

use crate::config::Config;
use crate::error::{Error, Result};
use crate::exact::{
    AGREEMENT_SLACK, AGREEMENT_STANDARD_ERRORS, FINER_RULE_TOLERANCE, MONTE_CARLO_REPLICATES, MONTE_CARLO_SEED,
    MonteCarloComparison, compare_with_monte_carlo,
};
use crate::integrate::Progress;
use crate::model::Lookup;

/// What to measure.
#[derive(Debug, Clone)]
pub struct QuadratureBenchSettings {
    /// Gauss–Legendre nodes per panel of the rule checked (the finer one has four times as many).
    pub nodes: usize,
    /// Monte Carlo samples per lookup (a power of two).
    pub samples: u64,
}

impl Default for QuadratureBenchSettings {
    fn default() -> Self {
        QuadratureBenchSettings { nodes: crate::exact::DEFAULT_NODES, samples: 1 << 20 }
    }
}

/// The comparisons of every hard lookup.
#[derive(Debug, Clone)]
pub struct QuadratureBench {
    pub comparisons: Vec<MonteCarloComparison>,
}

impl QuadratureBench {
    /// The comparison with the largest `|quadrature - Monte Carlo|`.
    pub fn furthest_from_monte_carlo(&self) -> Option<&MonteCarloComparison> {
        self.comparisons
            .iter()
            .max_by(|a, b| (a.quadrature - a.monte_carlo).abs().total_cmp(&(b.quadrature - b.monte_carlo).abs()))
    }

    /// The comparison the finer rule moves most.
    pub fn furthest_from_finer_rule(&self) -> Option<&MonteCarloComparison> {
        self.comparisons.iter().max_by(|a, b| (a.quadrature - a.finer).abs().total_cmp(&(b.quadrature - b.finer).abs()))
    }

    /// The smallest and largest Monte Carlo standard error.
    pub fn standard_error_range(&self) -> (f64, f64) {
        self.comparisons
            .iter()
            .map(|c| c.standard_error)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), se| (low.min(se), high.max(se)))
    }

    /// Ok when every lookup agrees with Monte Carlo and with the finer rule; otherwise an error
    /// naming each one that does not.
    pub fn verdict(&self) -> Result<()> {
        let failures: Vec<String> = self
            .comparisons
            .iter()
            .filter(|c| !(c.agrees_with_monte_carlo() && c.agrees_with_finer_rule()))
            .map(|c| {
                format!(
                    "{}: quadrature {:.9}, Monte Carlo {:.9} ± {:.1e}, finer rule {:+.1e}",
                    describe(&c.lookup),
                    c.quadrature,
                    c.monte_carlo,
                    c.standard_error,
                    c.finer - c.quadrature
                )
            })
            .collect();
        if failures.is_empty() {
            return Ok(());
        }
        Err(Error::invalid(
            "quadrature against Monte Carlo",
            format!(
                "{} of {} lookups disagree (allowed: within {AGREEMENT_STANDARD_ERRORS} standard errors + \
                 {AGREEMENT_SLACK:e} of Monte Carlo, and within {FINER_RULE_TOLERANCE:e} of the finer rule): {}",
                failures.len(),
                self.comparisons.len(),
                failures.join("; ")
            ),
        ))
    }
}

/// Compare every hard lookup under `settings`, with the masking models of `config`'s tables.
pub fn bench_quadrature(
    config: &Config,
    settings: &QuadratureBenchSettings,
    progress: &dyn Progress,
) -> Result<QuadratureBench> {
    Ok(QuadratureBench { comparisons: compare_with_monte_carlo(config, settings.nodes, settings.samples, progress)? })
}

fn describe(l: &Lookup) -> String {
    format!("{:?} mu {} alpha {} eta {} kappa {}", l.quantity, l.mu, l.alpha, l.eta, l.kappa)
}

/// The comparisons as a Markdown section: every lookup, then the largest differences.
pub fn markdown(bench: &QuadratureBench, settings: &QuadratureBenchSettings) -> String {
    let finer_nodes = 4 * settings.nodes;
    let mut out = String::new();
    let _ = writeln!(out, "## Exact integrals against Monte Carlo\n");
    let _ = writeln!(
        out,
        "The furnace's exact integrals (the visible-normal quadrature, {} Gauss–Legendre nodes per panel) on {} \
         lookups where they are hardest, against the per-cell Monte Carlo estimator with {} Sobol samples in {} \
         replicates (seed {}), and against the quadrature with {finer_nodes} nodes. Agreement: within \
         {AGREEMENT_STANDARD_ERRORS} standard errors + {AGREEMENT_SLACK:e} of Monte Carlo, and within \
         {FINER_RULE_TOLERANCE:e} of {finer_nodes} nodes.\n",
        settings.nodes,
        bench.comparisons.len(),
        settings.samples,
        MONTE_CARLO_REPLICATES,
        MONTE_CARLO_SEED,
    );
    let _ = writeln!(
        out,
        "| quantity | mu | alpha | eta | kappa | quadrature | {finer_nodes} nodes − {} | Monte Carlo | s.e. | \\|quadrature − MC\\| | agrees |",
        settings.nodes
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for c in &bench.comparisons {
        let l = &c.lookup;
        let agrees = if c.agrees_with_monte_carlo() && c.agrees_with_finer_rule() { "yes" } else { "NO" };
        let _ = writeln!(
            out,
            "| {:?} | {} | {} | {} | {} | {:.9} | {:+.1e} | {:.9} | {:.1e} | {:.1e} | {agrees} |",
            l.quantity,
            l.mu,
            l.alpha,
            l.eta,
            l.kappa,
            c.quadrature,
            c.finer - c.quadrature,
            c.monte_carlo,
            c.standard_error,
            (c.quadrature - c.monte_carlo).abs(),
        );
    }
    if let (Some(far), Some(moved)) = (bench.furthest_from_monte_carlo(), bench.furthest_from_finer_rule()) {
        let (low, high) = bench.standard_error_range();
        let _ = writeln!(
            out,
            "\nMax |quadrature − MC|: {:.2e} ({}, where Monte Carlo's standard error is {:.1e}); Monte Carlo's \
             standard errors: {low:.1e} to {high:.1e}. Max |{} − {finer_nodes} nodes|: {:.2e} ({}).",
            (far.quadrature - far.monte_carlo).abs(),
            describe(&far.lookup),
            far.standard_error,
            settings.nodes,
            (moved.quadrature - moved.finer).abs(),
            describe(&moved.lookup),
        );
    }
    let agreeing =
        bench.comparisons.iter().filter(|c| c.agrees_with_monte_carlo() && c.agrees_with_finer_rule()).count();
    let _ = writeln!(out, "{agreeing} of {} lookups agree.", bench.comparisons.len());
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::hard_lookups;

    #[test]
    fn a_lookup_off_monte_carlo_fails_the_verdict_by_name() {
        let agreeing = |lookup: Lookup| MonteCarloComparison {
            lookup,
            quadrature: 0.5,
            finer: 0.5,
            monte_carlo: 0.5 + 1e-6,
            standard_error: 1e-5,
        };
        let lookups = hard_lookups();
        let mut bench = QuadratureBench { comparisons: lookups.iter().copied().map(agreeing).collect() };
        assert!(bench.verdict().is_ok());
        assert!(
            markdown(&bench, &QuadratureBenchSettings::default())
                .contains(&format!("{0} of {0} lookups agree", lookups.len()))
        );

        // Six standard errors off, and a finer rule 2e-5 away: each named.
        bench.comparisons[3].monte_carlo = 0.5 + 6e-5;
        bench.comparisons[7].finer = 0.5 + 2e-5;
        let err = bench.verdict().unwrap_err().to_string();
        assert!(err.contains(&format!("2 of {} lookups disagree", lookups.len())), "{err}");
        assert!(err.contains(&describe(&lookups[3])) && err.contains(&describe(&lookups[7])), "{err}");
        let text = markdown(&bench, &QuadratureBenchSettings::default());
        assert!(
            text.contains("| NO |")
                && text.contains(&format!("{} of {} lookups agree", lookups.len() - 2, lookups.len())),
            "{text}"
        );
        assert!(text.contains("Max |quadrature − MC|: 6.00e-5"), "{text}");
    }
}
