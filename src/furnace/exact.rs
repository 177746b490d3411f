//! The model's lookups answered by the integrals themselves, in f64, with no table: the per-cell
//! estimators the tables' reference checks use ([`crate::recipes::fgd::fgd_cell`],
//! [`crate::recipes::tir`]'s ratio estimator, GD's `E[G2 / G1(wi)]`), at exactly the parameters of
//! each lookup. `A(tables) - A(exact)` is then the error the tables themselves cost a material.
//!
//! Each distinct lookup is integrated once and remembered; the answers depend only on the lookup,
//! the sample count and the seed, never on the order they are asked in or the thread asking.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use crate::config::Config;
use crate::error::Result;
use crate::integrate::{Method, estimate_cosine_functions};
use crate::model::{Lookup, Quantity, Tables};
use crate::physics::MaskingShadowing;
use crate::recipes::{fgd::fgd_cell, reference_points, tir::tir_cell};
use crate::sampling::sequence::PointSet;

/// Exact integrals for the model, remembered per lookup.
pub struct ExactTables {
    points: Arc<PointSet>,
    fgd_masking: MaskingShadowing,
    gd_masking: MaskingShadowing,
    known: Mutex<HashMap<[u64; 5], f64>>,
}

impl ExactTables {
    /// Integrals with `samples` points each (a power of two), drawn from `seed`, with the masking
    /// models of `config`'s FGD and GD tables (TIR's integrand fixes separable Smith).
    pub fn new(config: &Config, samples: u64, seed: u64) -> Result<Self> {
        Ok(ExactTables {
            points: reference_points(samples, seed)?,
            fgd_masking: config.fgd.masking,
            gd_masking: config.gd.masking,
            known: Mutex::new(HashMap::new()),
        })
    }

    /// Samples per integral.
    pub fn samples(&self) -> u64 {
        self.points.plan().total()
    }

    fn integrate(&self, lookup: &Lookup) -> f64 {
        let (mu, alpha) = (lookup.mu, lookup.alpha);
        match lookup.quantity {
            Quantity::Albedo => {
                fgd_cell(self.fgd_masking, &self.points, &[mu, alpha, lookup.eta, lookup.kappa]).mean[0]
            }
            Quantity::Tir => tir_cell(mu, alpha, lookup.eta, &self.points).mean[0],
            Quantity::Gd => {
                estimate_cosine_functions(mu, alpha, self.gd_masking, Method::PerCell, &self.points, |_| [1.0]).mean[0]
            }
        }
    }
}

impl Tables for ExactTables {
    fn value(&self, lookup: &Lookup) -> f64 {
        let quantity = match lookup.quantity {
            Quantity::Albedo => 0,
            Quantity::Tir => 1,
            Quantity::Gd => 2,
        };
        let key = [quantity, lookup.mu.to_bits(), lookup.alpha.to_bits(), lookup.eta.to_bits(), lookup.kappa.to_bits()];
        if let Some(&value) = self.known.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return value;
        }
        // Integrated outside the lock: another thread may integrate the same lookup meanwhile and
        // get the same bits.
        let value = self.integrate(lookup);
        self.known.lock().unwrap_or_else(|p| p.into_inner()).insert(key, value);
        value
    }
}
