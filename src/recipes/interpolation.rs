//! Interpolation error: a table as a renderer reads it, against the exact integral at random
//! points of its domain.
//!
//! The two error estimates of a build (the replicate spread and the per-cell references) are
//! taken at the nodes, where interpolation is exact: they say nothing of a table whose integrand
//! turns faster between nodes than linear interpolation follows (a step of total internal
//! reflection at low roughness, the grazing fall-off of a smooth interface). This check draws
//! points uniformly over a domain of lookup parameters, integrates each on its own by plain Monte
//! Carlo ([`super::Kernel::exact_value`]: the integrand at every sample, on the f32 kernel where the
//! table has one) on points independent of the table's,
//! and the pipeline compares every written file, read back and sampled as a renderer samples it,
//! with those values ([`compare`]).
//!
//! The scene build measures its slices the same way, over the ranges their lookups reach.

use serde::{Deserialize, Serialize};

use super::TableRecipe;
use crate::error::{Error, Result};
use crate::integrate::{Estimate, Progress, estimate_cells};
use crate::physics::henyey_greenstein::MIN_ROUGHNESS;
use crate::sampling::sequence::{PointSet, SamplePlan, scramble_seed};
use crate::stats::ErrorSummary;
pub use crate::stats::InterpolationError;

/// How many random points an interpolation check takes per domain, and how many samples the
/// exact integral gets at each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterpolationConfig {
    /// Random points per domain (0 skips the check).
    pub points: usize,
    /// Samples of each point's exact integral: a power of two, in 4 independent scrambles (their
    /// spread is the exact values' own standard error, reported beside the figures).
    pub samples: u64,
}

impl Default for InterpolationConfig {
    fn default() -> Self {
        InterpolationConfig { points: 2048, samples: 1 << 14 }
    }
}

/// Scrambles of the exact values: their spread is the standard error the manifest reports.
const EXACT_REPLICATES: u32 = 4;

impl InterpolationConfig {
    pub fn validate(&self, key: &str) -> Result<()> {
        if self.points > 0 {
            SamplePlan::new(self.samples, EXACT_REPLICATES).map_err(|e| {
                Error::invalid(format!("{key}.samples"), format!("{}; allowed: a power of two from 4 to 2^32", e))
            })?;
            if self.samples < EXACT_REPLICATES as u64 {
                return Err(Error::invalid(
                    format!("{key}.samples"),
                    format!("{}; allowed: a power of two from {EXACT_REPLICATES} to 2^32", self.samples),
                ));
            }
        }
        if self.points > MAX_POINTS {
            return Err(Error::invalid(
                format!("{key}.points"),
                format!("{}; allowed: 0 to {MAX_POINTS}", self.points),
            ));
        }
        Ok(())
    }
}

/// More points than this would make the check cost more than the table.
pub const MAX_POINTS: usize = 1 << 20;

/// The largest roughness of the low-roughness domain: smooth coats and metals, where the tables
/// turn fastest between nodes.
pub const SMOOTH_ALPHA_LIMIT: f64 = 0.05;

/// A box of lookup parameters, one range per parameter, that random points are drawn from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// What the box is, in words, for the manifest.
    pub name: String,
    /// The lookup parameters, in the order the recipe takes them.
    pub parameters: Vec<String>,
    pub ranges: Vec<[f64; 2]>,
}

impl Domain {
    /// The box in words: `uniform over mu [0, 1], alpha [0.0001, 0.05], ...`.
    pub fn describe(&self) -> String {
        let ranges: Vec<String> =
            self.parameters.iter().zip(&self.ranges).map(|(p, [lo, hi])| format!("{p} [{lo}, {hi}]")).collect();
        format!("uniform over {}", ranges.join(", "))
    }
}

/// The domains a full table is checked over: the whole box of its lookup parameters, and the same
/// box cut to `alpha <= 0.05` (from the model's smallest lobe roughness, 1e-4) where the table has
/// an `alpha` parameter reaching there.
pub fn standard_domains(parameters: &[&str], ranges: &[[f64; 2]]) -> Vec<Domain> {
    let parameters: Vec<String> = parameters.iter().map(|p| p.to_string()).collect();
    let mut domains =
        vec![Domain { name: "whole domain".into(), parameters: parameters.clone(), ranges: ranges.to_vec() }];
    if let Some(a) = parameters.iter().position(|p| p == "alpha") {
        let [lo, hi] = ranges[a];
        let smooth = [lo.max(MIN_ROUGHNESS), hi.min(SMOOTH_ALPHA_LIMIT)];
        if smooth[0] < smooth[1] {
            let mut cut = ranges.to_vec();
            cut[a] = smooth;
            domains.push(Domain { name: "low roughness".into(), parameters, ranges: cut });
        }
    }
    domains
}

/// `count` points drawn uniformly from the box `ranges`, reproducibly from `seed` and `stream`
/// (each coordinate from its own SplitMix64 hash, independent of the Sobol points of estimates).
pub fn random_points(ranges: &[[f64; 2]], count: usize, seed: u64, stream: u64) -> Vec<Vec<f64>> {
    (0..count)
        .map(|k| {
            ranges
                .iter()
                .enumerate()
                .map(|(d, &[lo, hi])| {
                    let u = scramble_seed(seed, stream.wrapping_mul(16).wrapping_add(d as u64), k as u32) as f64
                        / 4_294_967_296.0;
                    lo + u * (hi - lo)
                })
                .collect()
        })
        .collect()
}

/// Seeds of the exact values are offset from the table's, so that their scrambles are independent
/// of the points the table was integrated with (and of the reference cells').
const EXACT_SEED_OFFSET: u64 = 0x1_7E2F_0A7E;

/// The points of exact values for a run seeded with `seed`.
pub fn exact_points(samples: u64, seed: u64) -> Result<PointSet> {
    Ok(PointSet::new(SamplePlan::new(samples, EXACT_REPLICATES)?, seed.wrapping_add(EXACT_SEED_OFFSET)))
}

/// Random points of one domain with the exact integral at each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExactValues {
    pub domain: Domain,
    /// Each point's lookup parameters, in the domain's order.
    pub lookups: Vec<Vec<f64>>,
    /// Each point in the table's axes' quantities (what `Table::interpolate` takes).
    pub positions: Vec<Vec<f64>>,
    pub exact: Vec<Estimate>,
    pub samples_per_point: u64,
}

/// Draw `config.points` random points in each of `domains`, map each to the table's axes with
/// `position_of`, and integrate each with `estimate` (one estimate per stored channel) on points
/// independent of the table's.
pub fn exact_values(
    label: &str,
    domains: Vec<Domain>,
    config: &InterpolationConfig,
    seed: u64,
    progress: &dyn Progress,
    position_of: impl Fn(&[f64]) -> Vec<f64>,
    estimate: impl Fn(&PointSet, &[f64]) -> Estimate + Sync,
) -> Result<Vec<ExactValues>> {
    if config.points == 0 {
        return Ok(Vec::new());
    }
    let points = exact_points(config.samples, seed)?;
    domains
        .into_iter()
        .enumerate()
        .map(|(d, domain)| {
            let lookups = random_points(&domain.ranges, config.points, seed, 0xD0_0000 + d as u64);
            let positions: Vec<Vec<f64>> = lookups.iter().map(|l| position_of(l)).collect();
            let cells: Vec<u64> = (0..positions.len() as u64).collect();
            let exact = estimate_cells(&cells, &format!("{label} interpolation check"), progress, |k| {
                estimate(&points, &positions[k as usize])
            });
            Ok(ExactValues { domain, lookups, positions, exact, samples_per_point: points.plan().total() })
        })
        .collect()
}

/// [`exact_values`] for a full table over its recipe's domains.
pub fn exact_values_of(recipe: &dyn TableRecipe, seed: u64, progress: &dyn Progress) -> Result<Vec<ExactValues>> {
    exact_values(
        recipe.name(),
        recipe.interpolation_domains()?,
        &recipe.interpolation(),
        seed,
        progress,
        |lookup| recipe.position_of(lookup),
        |points, position| recipe.exact_value(points, position),
    )
}

/// Compare values read at the points of `exact` with the exact integral: `read(position)` returns
/// one value per channel of `channels` (which name them).
pub fn compare(
    exact: &ExactValues,
    read_as: &str,
    channels: &[String],
    read: impl Fn(&[f64]) -> Vec<f64>,
) -> InterpolationError {
    let mut differences = Vec::with_capacity(exact.positions.len() * channels.len());
    let mut worst = (-1.0f64, String::new());
    let mut standard_error_max = 0.0f64;
    for ((lookup, position), estimate) in exact.lookups.iter().zip(&exact.positions).zip(&exact.exact) {
        let values = read(position);
        for (c, name) in channels.iter().enumerate() {
            let difference = values[c] - estimate.mean[c];
            standard_error_max = standard_error_max.max(estimate.standard_error[c]);
            if difference.abs() > worst.0 {
                let at: Vec<String> =
                    exact.domain.parameters.iter().zip(lookup).map(|(p, v)| format!("{p} {v:.6}")).collect();
                worst = (
                    difference.abs(),
                    format!("{}, channel {name}: read {:.6}, exact {:.6}", at.join(", "), values[c], estimate.mean[c]),
                );
            }
            differences.push(difference);
        }
    }
    let magnitudes: Vec<f64> = differences.iter().map(|d| d.abs()).collect();
    InterpolationError {
        p99: crate::stats::quantile(&magnitudes, 0.99),
        domain: exact.domain.name.clone(),
        points: format!("{} points {}", exact.positions.len(), exact.domain.describe()),
        read_as: read_as.into(),
        exact_samples: exact.samples_per_point,
        exact_standard_error_max: standard_error_max,
        error: ErrorSummary::of_differences(differences),
        worst_at: worst.1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_points_fill_their_box_reproducibly() {
        let ranges = [[0.0, 1.0], [0.25, 0.5]];
        let points = random_points(&ranges, 4096, 7, 1);
        assert_eq!(points, random_points(&ranges, 4096, 7, 1));
        assert_ne!(points, random_points(&ranges, 4096, 7, 2));
        for (d, &[lo, hi]) in ranges.iter().enumerate() {
            let values: Vec<f64> = points.iter().map(|p| p[d]).collect();
            assert!(values.iter().all(|&v| v >= lo && v < hi));
            // Uniform: a quarter of the points in each quarter of the range, within 4 sigma.
            for q in 0..4 {
                let (a, b) = (lo + q as f64 * (hi - lo) / 4.0, lo + (q + 1) as f64 * (hi - lo) / 4.0);
                let n = values.iter().filter(|&&v| v >= a && v < b).count() as f64;
                assert!((n - 1024.0).abs() < 4.0 * (4096.0f64 * 0.25 * 0.75).sqrt(), "axis {d}, quarter {q}: {n}");
            }
        }
    }

    #[test]
    fn the_low_roughness_domain_cuts_alpha_only() {
        let domains = standard_domains(&["mu", "alpha", "eta"], &[[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]]);
        assert_eq!(domains.len(), 2);
        assert_eq!(domains[1].ranges, vec![[0.0, 1.0], [MIN_ROUGHNESS, SMOOTH_ALPHA_LIMIT], [0.0, 1.0]]);
        // A table whose alpha range lies above the cut has no low-roughness domain.
        assert_eq!(standard_domains(&["mu", "alpha"], &[[0.0, 1.0], [0.2, 0.4]]).len(), 1);
        assert_eq!(standard_domains(&["x"], &[[0.0, 1.0]]).len(), 1);
    }

    #[test]
    fn compare_finds_the_worst_point_and_channel() {
        let domain = Domain { name: "box".into(), parameters: vec!["x".into()], ranges: vec![[0.0, 1.0]] };
        let exact = ExactValues {
            domain,
            lookups: vec![vec![0.1], vec![0.7]],
            positions: vec![vec![0.1], vec![0.7]],
            exact: vec![
                Estimate { mean: vec![1.0, 2.0], standard_error: vec![1e-4, 2e-4] },
                Estimate { mean: vec![3.0, 4.0], standard_error: vec![3e-4, 1e-4] },
            ],
            samples_per_point: 16,
        };
        let names = vec!["a".to_string(), "b".to_string()];
        let error = compare(&exact, "test", &names, |p| if p[0] < 0.5 { vec![1.0, 2.5] } else { vec![3.0, 4.0] });
        assert_eq!(error.error.count, 4);
        assert_eq!(error.error.max, 0.5);
        assert!((error.error.rms - 0.25).abs() < 1e-15);
        assert_eq!(error.exact_standard_error_max, 3e-4);
        assert!(error.worst_at.starts_with("x 0.100000, channel b"), "{}", error.worst_at);
    }
}
