//! The model's lookups answered by the integrals themselves, in f64, with no table: FGD, TIR's
//! ratio `∫ G1 [..] / ∫ G1` and GD's `E[G2 / G1(wi)]` at exactly the parameters of each lookup, by
//! the deterministic visible-normal quadrature ([`VisibleNormalQuadrature`]: product
//! Gauss–Legendre with every jump and kink of the integrand a panel edge). `A(tables) - A(exact)`
//! is then the error the tables themselves cost a material.
//!
//! Each distinct lookup is integrated once and remembered: an answer depends only on the lookup
//! and the rule's node count, never on the order the lookups are asked in, the other lookups of a
//! batch or the thread asking. Albedos integrated together that differ only in their indices (a
//! conductor's channels) share one pass over the quadrature's nodes, each answer with the bits of
//! its integral alone ([`ExactTables::integrate_all`]).
//!
//! [`compare_with_monte_carlo`] checks the quadrature against the tables' per-cell Monte Carlo
//! estimator on the lookups where it is hardest ([`hard_lookups`]): a test at 2^16 samples, and
//! `tmlut bench quadrature` at 2^20 for the figures `docs/furnace.md` quotes.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::RwLock;

use rayon::prelude::*;

use crate::config::Config;
use crate::error::Result;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cosine_functions};
use crate::model::{Lookup, Quantity, Site, Tables};
use crate::physics::MaskingShadowing;
use crate::recipes::fgd::{fgd_by_quadrature, fgd_cell, fgd_kink, fgd_pairs_by_quadrature};
use crate::recipes::tir::{tir_by_quadrature, tir_cell};
use crate::sampling::sequence::{PointSet, SamplePlan};

pub use crate::integrate::quadrature::DEFAULT_NODES;

/// Exact integrals for the model, remembered per lookup.
pub struct ExactTables {
    quadrature: VisibleNormalQuadrature,
    fgd_masking: MaskingShadowing,
    gd_masking: MaskingShadowing,
    known: RwLock<HashMap<[u64; 5], f64>>,
}

impl ExactTables {
    /// Integrals by the quadrature of `nodes` Gauss–Legendre nodes per panel, with the masking
    /// models of `config`'s FGD and GD tables (TIR's integrand fixes separable Smith).
    pub fn new(config: &Config, nodes: usize) -> Result<Self> {
        Ok(ExactTables {
            quadrature: VisibleNormalQuadrature::new(nodes)?,
            fgd_masking: config.fgd.masking,
            gd_masking: config.gd.masking,
            known: RwLock::new(HashMap::new()),
        })
    }

    /// Gauss–Legendre nodes per panel.
    pub fn nodes(&self) -> usize {
        self.quadrature.nodes()
    }

    /// Whether `lookup` has been integrated.
    pub fn knows(&self, lookup: &Lookup) -> bool {
        self.known.read().unwrap_or_else(|p| p.into_inner()).contains_key(&key(lookup))
    }

    /// Integrate every lookup of `lookups` not yet known, in parallel; albedos that share `mu`,
    /// `alpha` and their kink (a conductor's channels) three at a time in one pass over the
    /// quadrature ([`fgd_pairs_by_quadrature`]), each answer still the bits of its integral alone.
    pub fn integrate_all(&self, lookups: &[Lookup]) {
        // Sorted, so that the work is split the same way on every run (the answers would not
        // change otherwise; the order of the work would).
        let missing: BTreeSet<[u64; 5]> = {
            let known = self.known.read().unwrap_or_else(|p| p.into_inner());
            lookups.iter().map(key).filter(|k| !known.contains_key(k)).collect()
        };
        let mut albedos: BTreeMap<[u64; 3], Vec<[u64; 5]>> = BTreeMap::new();
        let mut work: Vec<Vec<[u64; 5]>> = Vec::new();
        for k in missing {
            if k[0] == ALBEDO {
                let kink = fgd_kink((f64::from_bits(k[3]), f64::from_bits(k[4])));
                albedos.entry([k[1], k[2], kink.map_or(u64::MAX, f64::to_bits)]).or_default().push(k);
            } else {
                work.push(vec![k]);
            }
        }
        work.extend(albedos.into_values().flat_map(|group| group.chunks(3).map(<[_]>::to_vec).collect::<Vec<_>>()));
        let answers: Vec<([u64; 5], f64)> =
            work.par_iter().flat_map_iter(|keys| self.integrate_together(keys)).collect();
        self.known.write().unwrap_or_else(|p| p.into_inner()).extend(answers);
    }

    /// The integrals of `keys`: one lookup, or up to three albedos of one `mu`, `alpha` and kink.
    fn integrate_together(&self, keys: &[[u64; 5]]) -> Vec<([u64; 5], f64)> {
        let pair = |k: &[u64; 5]| (f64::from_bits(k[3]), f64::from_bits(k[4]));
        let [mu, alpha] = [keys[0][1], keys[0][2]].map(f64::from_bits);
        let (masking, quadrature) = (self.fgd_masking, &self.quadrature);
        let answers = match keys {
            [a, b] => fgd_pairs_by_quadrature(masking, quadrature, mu, alpha, [pair(a), pair(b)]).to_vec(),
            [a, b, c] => fgd_pairs_by_quadrature(masking, quadrature, mu, alpha, [pair(a), pair(b), pair(c)]).to_vec(),
            _ => keys.iter().map(|&k| self.integrate(k)).collect(),
        };
        keys.iter().copied().zip(answers).collect()
    }

    /// The integral of the lookup with key `k`.
    fn integrate(&self, [quantity, mu, alpha, eta, kappa]: [u64; 5]) -> f64 {
        let [mu, alpha, eta, kappa] = [mu, alpha, eta, kappa].map(f64::from_bits);
        match quantity {
            ALBEDO => fgd_by_quadrature(self.fgd_masking, &self.quadrature, mu, alpha, (eta, kappa)),
            TIR => tir_by_quadrature(&self.quadrature, mu, alpha, eta),
            _ => {
                let [gd] = self.quadrature.cosine_functions(mu, alpha, self.gd_masking, &[], |_| [1.0]);
                gd
            }
        }
    }
}

const ALBEDO: u64 = 0;
const TIR: u64 = 1;
const GD: u64 = 2;

/// What determines a lookup's integral: its quantity, `mu`, `alpha`, `eta`, `kappa`, to the bit
/// (the site, layer and channel that asked do not).
fn key(lookup: &Lookup) -> [u64; 5] {
    let quantity = match lookup.quantity {
        Quantity::Albedo => ALBEDO,
        Quantity::Tir => TIR,
        Quantity::Gd => GD,
    };
    [quantity, lookup.mu.to_bits(), lookup.alpha.to_bits(), lookup.eta.to_bits(), lookup.kappa.to_bits()]
}

impl Tables for ExactTables {
    fn knows(&self, lookup: &Lookup) -> bool {
        ExactTables::knows(self, lookup)
    }

    fn prepare(&self, lookups: &[Lookup]) {
        self.integrate_all(lookups);
    }

    fn value(&self, lookup: &Lookup) -> f64 {
        let key = key(lookup);
        if let Some(&value) = self.known.read().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return value;
        }
        // Integrated outside the lock: another thread may integrate the same lookup meanwhile and
        // get the same bits.
        let value = self.integrate(key);
        self.known.write().unwrap_or_else(|p| p.into_inner()).insert(key, value);
        value
    }
}

/// The lookups where the exact integrals are hardest: `eta < 1` near the critical angle, `alpha`
/// near 0, grazing and normal views, large `kappa`, TIR's indicator.
pub fn hard_lookups() -> Vec<Lookup> {
    let mut lookups = Vec::new();
    for (mu, alpha, eta, kappa) in [
        (0.3, 0.05, 0.66, 0.0),
        (0.75, 0.02, 0.66, 0.0),
        (0.75, 0.3, 0.66, 0.0),
        (0.5, 0.1, 0.8, 0.05),
        (0.6, 0.001, 1.5, 0.0),
        (0.6, 1e-4, 0.7, 0.0),
        (0.0, 0.2, 1.5, 0.0),
        (0.01, 0.5, 0.27, 3.61),
        (0.0, 0.02, 0.66, 0.0),
        (0.4, 0.3, 0.2, 4.0),
        (0.9, 0.8, 2.5, 3.0),
        (1.0, 0.4, 0.66, 0.0),
    ] {
        lookups.push(lookup(Quantity::Albedo, mu, alpha, eta, kappa));
    }
    for (mu, alpha, eta) in [
        (0.3, 0.05, 0.66),
        (0.75, 0.02, 0.66),
        (0.1, 0.5, 0.9),
        (0.0, 0.3, 0.66),
        (0.9, 0.001, 0.5),
        (0.5, 1.0, 0.3),
        (1.0, 0.2, 0.95),
        (0.2, 0.0, 0.7),
    ] {
        lookups.push(lookup(Quantity::Tir, mu, alpha, eta, 0.0));
    }
    for (mu, alpha) in [(0.5, 0.3), (0.0, 0.8), (0.9, 0.01), (0.05, 1.0)] {
        lookups.push(lookup(Quantity::Gd, mu, alpha, 1.0, 0.0));
    }
    lookups
}

/// A lookup of the top layer from above (what determines its integral: [`key`]).
fn lookup(quantity: Quantity, mu: f64, alpha: f64, eta: f64, kappa: f64) -> Lookup {
    Lookup { quantity, site: Site::FromAbove, layer: 1, channel: None, mu, alpha, eta, kappa }
}

/// Monte Carlo replicates of a comparison's estimates: its standard errors come from their spread.
pub const MONTE_CARLO_REPLICATES: u32 = 16;
/// Seed of the Monte Carlo points of a comparison.
pub const MONTE_CARLO_SEED: u64 = 11;
/// The quadrature agrees with Monte Carlo within this many of its standard errors ...
pub const AGREEMENT_STANDARD_ERRORS: f64 = 5.0;
/// ... plus this, for lookups whose Monte Carlo standard error is (nearly) 0.
pub const AGREEMENT_SLACK: f64 = 1e-6;
/// The default rule agrees with the finer one within this.
pub const FINER_RULE_TOLERANCE: f64 = 1e-5;

/// One lookup by the quadrature, by a rule of four times its nodes, and by per-cell Monte Carlo
/// (the estimator the exact integrals used before the quadrature, independent of it).
#[derive(Debug, Clone)]
pub struct MonteCarloComparison {
    pub lookup: Lookup,
    pub quadrature: f64,
    /// The same integral with four times the Gauss–Legendre nodes per panel.
    pub finer: f64,
    pub monte_carlo: f64,
    pub standard_error: f64,
}

impl MonteCarloComparison {
    /// Whether the quadrature lies within [`AGREEMENT_STANDARD_ERRORS`] standard errors (plus
    /// [`AGREEMENT_SLACK`]) of Monte Carlo.
    pub fn agrees_with_monte_carlo(&self) -> bool {
        self.quadrature.is_finite()
            && (self.quadrature - self.monte_carlo).abs()
                <= AGREEMENT_STANDARD_ERRORS * self.standard_error + AGREEMENT_SLACK
    }

    /// Whether the finer rule moves the value by at most [`FINER_RULE_TOLERANCE`].
    pub fn agrees_with_finer_rule(&self) -> bool {
        (self.quadrature - self.finer).abs() <= FINER_RULE_TOLERANCE
    }
}

/// Every lookup of [`hard_lookups`] by the quadrature of `nodes` Gauss–Legendre nodes per panel,
/// by one of four times as many, and by per-cell Monte Carlo with `samples` Sobol points in
/// [`MONTE_CARLO_REPLICATES`] replicates; lookups in parallel, one step of `progress` each.
pub fn compare_with_monte_carlo(
    config: &Config,
    nodes: usize,
    samples: u64,
    progress: &dyn Progress,
) -> Result<Vec<MonteCarloComparison>> {
    let points = PointSet::new(SamplePlan::new(samples, MONTE_CARLO_REPLICATES)?, MONTE_CARLO_SEED);
    let exact = ExactTables::new(config, nodes)?;
    let finer = ExactTables::new(config, 4 * nodes)?;
    let lookups = hard_lookups();
    progress.start("quadrature vs MC", lookups.len() as u64);
    let comparisons = lookups
        .into_par_iter()
        .map(|lookup| {
            let reference = monte_carlo(config, &points, &lookup);
            let comparison = MonteCarloComparison {
                lookup,
                quadrature: exact.value(&lookup),
                finer: finer.value(&lookup),
                monte_carlo: reference.mean[0],
                standard_error: reference.standard_error[0],
            };
            progress.advance(1);
            comparison
        })
        .collect();
    progress.finish();
    Ok(comparisons)
}

/// The per-cell Monte Carlo estimate of a lookup with the table recipes' own estimators.
fn monte_carlo(config: &Config, points: &PointSet, l: &Lookup) -> Estimate {
    match l.quantity {
        Quantity::Albedo => fgd_cell(config.fgd.masking, points, &[l.mu, l.alpha, l.eta, l.kappa]),
        Quantity::Tir => tir_cell(l.mu, l.alpha, l.eta, points),
        Quantity::Gd => estimate_cosine_functions(l.mu, l.alpha, config.gd.masking, Method::PerCell, points, |_| [1.0]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrated_together_each_lookup_has_the_bits_of_its_integral_alone() {
        // Integrated as a batch, in parallel, every answer must be the one integral of that lookup
        // alone, to the bit, or a library's table error would depend on which other materials were
        // measured beside it.
        let config = Config::default();
        let lookups = [
            lookup(Quantity::Albedo, 0.7, 0.1, 1.5, 0.0),
            lookup(Quantity::Albedo, 0.7, 0.1, 0.27, 3.61),
            lookup(Quantity::Albedo, 0.7, 0.1, 0.68, 2.63),
            lookup(Quantity::Albedo, 0.7, 0.1, 0.2, 4.0),
            // Below eta = 1 Fresnel kinks: a pass of its own.
            lookup(Quantity::Albedo, 0.7, 0.1, 0.66, 0.0),
            lookup(Quantity::Albedo, 0.3, 0.1, 1.5, 0.0),
            lookup(Quantity::Tir, 0.7, 0.1, 0.66, 0.0),
            lookup(Quantity::Tir, 0.7, 0.1, 0.8, 0.0),
            lookup(Quantity::Gd, 0.7, 0.1, 1.0, 0.0),
            lookup(Quantity::Gd, 0.2, 0.3, 1.0, 0.0),
        ];
        let together = ExactTables::new(&config, 8).unwrap();
        together.integrate_all(&lookups);
        for l in &lookups {
            assert!(together.knows(l), "{l:?}");
            let alone = ExactTables::new(&config, 8).unwrap();
            assert_eq!(together.value(l).to_bits(), alone.value(l).to_bits(), "{l:?}");
        }
        // The site, layer and channel that ask do not change the integral.
        let mut other = lookups[1];
        other.channel = Some(2);
        other.layer = 2;
        assert!(together.knows(&other));
    }

    #[test]
    fn the_quadrature_agrees_with_monte_carlo_on_the_hard_lookups() {
        let comparisons =
            compare_with_monte_carlo(&Config::default(), crate::exact::DEFAULT_NODES, 1 << 16, &()).unwrap();
        assert_eq!(comparisons.len(), hard_lookups().len());
        for c in &comparisons {
            assert!(c.agrees_with_monte_carlo() && c.agrees_with_finer_rule(), "{c:?}");
        }
    }
}
