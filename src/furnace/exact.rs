//! The model's lookups answered by the integrals themselves, in f64, with no table: the per-cell
//! estimators the tables' reference checks use ([`crate::recipes::fgd::fgd_cell`],
//! [`crate::recipes::tir`]'s ratio estimator, GD's `E[G2 / G1(wi)]`), at exactly the parameters of
//! each lookup. `A(tables) - A(exact)` is then the error the tables themselves cost a material.
//!
//! Each distinct lookup is integrated once and remembered; the answers depend only on the lookup,
//! the sample count and the seed, never on the order they are asked in or the thread asking.
//!
//! [`ExactTables::integrate_all`] answers many lookups at once, sharing what the method allows: the
//! visible-normal samples, warp and weight of an integral depend on `(mu, alpha)` alone, so every
//! FGD lookup at one `(mu, alpha)` is one pass over the samples with a Fresnel term per
//! `(eta, kappa)` ([`fgd_cells_at_mu_alpha`]), and every TIR lookup one pass with an indicator per
//! `eta` ([`tir_cells_at_mu_alpha`]). Each answer has the bits of the lookup integrated alone (both
//! functions guarantee it), so sharing changes the run time and nothing else.

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, RwLock};

use rayon::prelude::*;

use crate::config::Config;
use crate::error::Result;
use crate::integrate::{Method, estimate_cosine_functions};
use crate::model::{Lookup, Quantity, Tables};
use crate::physics::MaskingShadowing;
use crate::recipes::fgd::{fgd_cell, fgd_cells_at_mu_alpha};
use crate::recipes::reference_points;
use crate::recipes::tir::{tir_cell, tir_cells_at_mu_alpha};
use crate::sampling::sequence::PointSet;

/// Exact integrals for the model, remembered per lookup.
pub struct ExactTables {
    points: Arc<PointSet>,
    fgd_masking: MaskingShadowing,
    gd_masking: MaskingShadowing,
    known: RwLock<HashMap<[u64; 5], f64>>,
}

impl ExactTables {
    /// Integrals with `samples` points each (a power of two), drawn from `seed`, with the masking
    /// models of `config`'s FGD and GD tables (TIR's integrand fixes separable Smith).
    pub fn new(config: &Config, samples: u64, seed: u64) -> Result<Self> {
        Ok(ExactTables {
            points: reference_points(samples, seed)?,
            fgd_masking: config.fgd.masking,
            gd_masking: config.gd.masking,
            known: RwLock::new(HashMap::new()),
        })
    }

    /// Samples per integral.
    pub fn samples(&self) -> u64 {
        self.points.plan().total()
    }

    /// Whether `lookup` has been integrated.
    pub fn knows(&self, lookup: &Lookup) -> bool {
        self.known.read().unwrap_or_else(|p| p.into_inner()).contains_key(&key(lookup))
    }

    /// Integrate every lookup of `lookups` not yet known, in parallel, the lookups of one
    /// `(quantity, mu, alpha)` in one pass over the samples.
    pub fn integrate_all(&self, lookups: &[Lookup]) {
        // Grouped in a sorted map, so that the work is split the same way on every run (the
        // answers would not change otherwise; the order of the work would).
        let mut groups: BTreeMap<[u64; 3], Vec<[u64; 2]>> = BTreeMap::new();
        {
            let known = self.known.read().unwrap_or_else(|p| p.into_inner());
            for lookup in lookups {
                let k = key(lookup);
                if !known.contains_key(&k) {
                    groups.entry([k[0], k[1], k[2]]).or_default().push([k[3], k[4]]);
                }
            }
        }
        let groups: Vec<([u64; 3], Vec<[u64; 2]>)> = groups
            .into_iter()
            .map(|(g, mut rest)| {
                rest.sort_unstable();
                rest.dedup();
                (g, rest)
            })
            .collect();
        let answers: Vec<Vec<([u64; 5], f64)>> = groups
            .par_iter()
            .map(|([quantity, mu, alpha], rest)| {
                let (mu_f, alpha_f) = (f64::from_bits(*mu), f64::from_bits(*alpha));
                let values: Vec<f64> = match *quantity {
                    ALBEDO => {
                        let pairs: Vec<(f64, f64)> =
                            rest.iter().map(|[e, k]| (f64::from_bits(*e), f64::from_bits(*k))).collect();
                        fgd_cells_at_mu_alpha(self.fgd_masking, &self.points, mu_f, alpha_f, &pairs)
                            .into_iter()
                            .map(|e| e.mean[0])
                            .collect()
                    }
                    TIR => {
                        let etas: Vec<f64> = rest.iter().map(|[e, _]| f64::from_bits(*e)).collect();
                        tir_cells_at_mu_alpha(mu_f, alpha_f, &etas, &self.points)
                            .into_iter()
                            .map(|e| e.mean[0])
                            .collect()
                    }
                    // GD has no further parameter: one integral per (mu, alpha), integrated alone.
                    _ => rest.iter().map(|_| self.gd(mu_f, alpha_f)).collect(),
                };
                rest.iter().zip(values).map(|([e, k], v)| ([*quantity, *mu, *alpha, *e, *k], v)).collect()
            })
            .collect();
        let mut known = self.known.write().unwrap_or_else(|p| p.into_inner());
        known.extend(answers.into_iter().flatten());
    }

    fn gd(&self, mu: f64, alpha: f64) -> f64 {
        estimate_cosine_functions(mu, alpha, self.gd_masking, Method::PerCell, &self.points, |_| [1.0]).mean[0]
    }

    fn integrate(&self, lookup: &Lookup) -> f64 {
        let (mu, alpha) = (lookup.mu, lookup.alpha);
        match lookup.quantity {
            Quantity::Albedo => {
                fgd_cell(self.fgd_masking, &self.points, &[mu, alpha, lookup.eta, lookup.kappa]).mean[0]
            }
            Quantity::Tir => tir_cell(mu, alpha, lookup.eta, &self.points).mean[0],
            Quantity::Gd => self.gd(mu, alpha),
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
    fn value(&self, lookup: &Lookup) -> f64 {
        let key = key(lookup);
        if let Some(&value) = self.known.read().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return value;
        }
        // Integrated outside the lock: another thread may integrate the same lookup meanwhile and
        // get the same bits.
        let value = self.integrate(lookup);
        self.known.write().unwrap_or_else(|p| p.into_inner()).insert(key, value);
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Site;

    fn lookup(quantity: Quantity, mu: f64, alpha: f64, eta: f64, kappa: f64) -> Lookup {
        Lookup { quantity, site: Site::FromAbove, layer: 1, channel: None, mu, alpha, eta, kappa }
    }

    #[test]
    fn integrated_together_each_lookup_has_the_bits_of_its_integral_alone() {
        // Lookups that share (mu, alpha) share one pass over the samples; every answer must still
        // be the one integral of that lookup, to the bit, or a library's table error would depend
        // on which other materials were measured beside it.
        let config = Config::default();
        let lookups = [
            lookup(Quantity::Albedo, 0.7, 0.1, 1.5, 0.0),
            lookup(Quantity::Albedo, 0.7, 0.1, 0.27, 3.61),
            lookup(Quantity::Albedo, 0.7, 0.1, 0.68, 2.63),
            lookup(Quantity::Albedo, 0.3, 0.1, 1.5, 0.0),
            lookup(Quantity::Tir, 0.7, 0.1, 0.66, 0.0),
            lookup(Quantity::Tir, 0.7, 0.1, 0.8, 0.0),
            lookup(Quantity::Gd, 0.7, 0.1, 1.0, 0.0),
            lookup(Quantity::Gd, 0.2, 0.3, 1.0, 0.0),
        ];
        let together = ExactTables::new(&config, 1024, 3).unwrap();
        together.integrate_all(&lookups);
        for l in &lookups {
            assert!(together.knows(l), "{l:?}");
            let alone = ExactTables::new(&config, 1024, 3).unwrap();
            assert_eq!(together.value(l).to_bits(), alone.value(l).to_bits(), "{l:?}");
        }
        // The site, layer and channel that ask do not change the integral.
        let mut other = lookups[1];
        other.channel = Some(2);
        other.layer = 2;
        assert!(together.knows(&other));
    }
}
