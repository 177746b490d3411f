//! Table recipes: one file per table, each readable as the integral it computes.
//!
//! A recipe turns its settings into a [`TableBuild`]: the table itself and the record of how it
//! was made (integrand, masking-shadowing model, sampler, samples, seed, wall time, error
//! estimates) that the manifest publishes beside every file.

/// The part of a [`TableRecipe`] impl that every table's settings share: the name constant, the
/// inherent `axes`, the `sampling` and `output` fields, and the module's `CHANNEL_COUNT` and `build`. Used
/// inside `impl TableRecipe for ...Settings`, so that each impl states only what differs
/// (`estimate_node`).
macro_rules! table_recipe_accessors {
    () => {
        fn name(&self) -> &'static str {
            NAME
        }

        fn axes(&self) -> Result<Vec<Axis>> {
            Self::axes(self)
        }

        fn sampling(&self) -> SamplingConfig {
            self.sampling
        }

        fn output(&self) -> &OutputConfig {
            &self.output
        }

        fn channel_count(&self) -> usize {
            CHANNEL_COUNT
        }

        fn build(&self, seed: u64, progress: &dyn Progress) -> Result<TableBuild> {
            build(self, seed, progress)
        }
    };
}

pub mod belcour;
pub mod fgd;
pub mod gd;
pub mod karis;
pub mod slices;
pub mod split_sum;
pub mod tir;

use serde::{Deserialize, Serialize};

pub use crate::integrate::Method;
use crate::integrate::{Estimate, Progress};
use crate::physics::{FresnelBasis, MaskingShadowing};
use crate::sampling::sequence::{PointSet, SamplePlan};
pub use crate::stats::{AccuracyReport, ErrorRecord, ErrorSummary, ReferenceComparison};
use crate::table::Table;

/// Every table tmlut knows, with a one-line description, in build order.
pub const TABLES: &[(&str, &str)] = &[
    (fgd::NAME, "directional albedo with exact Fresnel, 4D (mu, alpha, eta, kappa)"),
    (gd::NAME, "microfacet albedo without Fresnel (separable Smith), 2D (mu, alpha)"),
    (tir::NAME, "share of a lobe lost to total internal reflection, 3D (mu, alpha, eta < 1)"),
    (belcour::NAME, "Belcour-Bati-Barla 2020 split-sum with a Fresnel basis, 2D (n.v, roughness), 4 channels"),
    (
        karis::NAME,
        "Karis split-sum environment BRDF (UE4): scale and bias of F0 under Schlick Fresnel, 2D (n.v, roughness)",
    ),
];

/// What the pipeline, the benchmark and the checks need of every table. Each table's settings
/// implement it.
pub trait TableRecipe: Sync {
    fn name(&self) -> &'static str;
    /// The axes of the table these settings describe.
    fn axes(&self) -> crate::error::Result<Vec<crate::table::Axis>>;
    fn sampling(&self) -> crate::config::SamplingConfig;
    fn output(&self) -> &crate::config::OutputConfig;
    /// Channels of the table.
    fn channel_count(&self) -> usize;
    /// Integrate the whole table.
    fn build(&self, seed: u64, progress: &dyn Progress) -> crate::error::Result<TableBuild>;
    /// One node on its own, by the per-cell method (scalar f64), at a position given in the
    /// axes' quantities: the independent cross-check of whatever [`TableRecipe::build`] did.
    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate;
}

/// How a table was integrated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SamplingRecord {
    /// The estimator, e.g. "visible-normal Monte Carlo, per cell".
    pub method: String,
    /// The point set, e.g. "Owen-scrambled Sobol (sobol_burley), 4 replicates x 256 points".
    pub sampler: String,
    pub samples_per_cell: u64,
    pub replicates: u32,
    pub seed: u64,
}

/// A table and the record of how it was made.
#[derive(Debug, Clone)]
pub struct TableBuild {
    pub table: Table,
    /// The integral, in words and symbols, as the manifest states it.
    pub integrand: String,
    pub masking: Option<MaskingShadowing>,
    /// Conventions a user must know to read the table right.
    pub notes: Vec<String>,
    pub sampling: SamplingRecord,
    pub error: ErrorRecord,
    pub wall_time_s: f64,
    /// The tabulated Fresnel basis a shader needs to use the table (Belcour only).
    pub fresnel_basis: Option<FresnelBasis>,
    /// Further measured accuracy figures (for instance, how well a split-sum reproduces FGD).
    pub accuracy: Vec<AccuracyReport>,
    /// The replicate standard error of every stored value, in the table's layout, where it was
    /// computed for every node (the error maps draw it).
    pub standard_error: Option<Vec<f32>>,
}

/// The record of a table integrated with `method` from the points of `points`.
pub(crate) fn sampling_record(method: Method, description: &str, points: &PointSet) -> SamplingRecord {
    let plan = points.plan();
    SamplingRecord {
        method: format!("{} ({description})", method.name()),
        sampler: format!(
            "Owen-scrambled Sobol (sobol_burley), {} replicates x {} points",
            plan.replicates, plan.points
        ),
        samples_per_cell: plan.total(),
        replicates: plan.replicates,
        seed: points.seed(),
    }
}

/// The point set of a table's own samples.
pub(crate) fn table_points(sampling: &crate::config::SamplingConfig, seed: u64) -> crate::error::Result<PointSet> {
    Ok(PointSet::new(SamplePlan::new(sampling.samples, sampling.replicates)?, seed))
}

/// Estimate every node of a 2D table whose axes are `mu` and `alpha`, store the means, and
/// return the estimates in node order. `estimate(node, mu, alpha)` computes one node.
pub(crate) fn fill_mu_alpha_nodes(
    table: &mut Table,
    progress: &dyn Progress,
    estimate: impl Fn(usize, f64, f64) -> Estimate + Sync,
) -> Vec<Estimate> {
    let (mu_axis, alpha_axis) = (&table.axes[0], &table.axes[1]);
    let cells: Vec<u64> = (0..(mu_axis.count * alpha_axis.count) as u64).collect();
    let estimates = crate::integrate::estimate_cells(&cells, &table.name, progress, |cell| {
        let (i, j) = (cell as usize % mu_axis.count, cell as usize / mu_axis.count);
        estimate(cell as usize, mu_axis.node_value(i), alpha_axis.node_value(j))
    });
    let channels = table.channel_count();
    for (values, estimate) in table.data.chunks_mut(channels).zip(&estimates) {
        for (v, m) in values.iter_mut().zip(&estimate.mean) {
            *v = *m as f32;
        }
    }
    estimates
}

/// The standard error of every value of `estimates`, in node order: a table's error map.
pub(crate) fn standard_error_map(estimates: &[Estimate]) -> Vec<f32> {
    estimates.iter().flat_map(|e| e.standard_error.iter().map(|&s| s as f32)).collect()
}

/// RMS and maximum, over all cells and channels, of the replicate standard errors.
pub(crate) fn replicate_error(estimates: &[crate::integrate::Estimate]) -> ErrorSummary {
    ErrorSummary::of_differences(estimates.iter().flat_map(|e| e.standard_error.iter().copied()))
}

/// Seeds of reference estimates are offset from the table's so that their scrambles are
/// independent of the ones the table was built with.
const REFERENCE_SEED_OFFSET: u64 = 0x005E_ED0F_2EF5;

/// The points of reference estimates for a run seeded with `seed`: `samples` per cell, scrambles
/// independent of the table's own.
pub fn reference_points(samples: u64, seed: u64) -> crate::error::Result<PointSet> {
    Ok(PointSet::new(SamplePlan::new(samples, 1)?, seed.wrapping_add(REFERENCE_SEED_OFFSET)))
}

/// Compare a built table, at `reference.cells` cells drawn at random (reproducibly from `seed`),
/// to per-cell estimates ([`TableRecipe::estimate_node`]) with `reference.samples` samples and
/// independent scrambles.
pub(crate) fn compare_to_reference(
    recipe: &dyn TableRecipe,
    table: &Table,
    reference: &crate::config::ReferenceConfig,
    seed: u64,
    progress: &dyn Progress,
) -> crate::error::Result<Option<ReferenceComparison>> {
    compare_nodes_to_reference(
        |points, position| recipe.estimate_node(points, position),
        table,
        reference,
        seed,
        progress,
    )
}

/// [`compare_to_reference`] for a table whose per-cell estimate is `estimate_node(points, position)`.
pub(crate) fn compare_nodes_to_reference(
    estimate_node: impl Fn(&PointSet, &[f64]) -> Estimate + Sync,
    table: &Table,
    reference: &crate::config::ReferenceConfig,
    seed: u64,
    progress: &dyn Progress,
) -> crate::error::Result<Option<ReferenceComparison>> {
    if reference.cells == 0 {
        return Ok(None);
    }
    let cells = random_cells(table.node_count(), reference.cells, seed);
    let points = reference_points(reference.samples, seed)?;
    let label = format!("{} reference", table.name);
    let estimates = crate::integrate::estimate_cells(&cells, &label, progress, |cell| {
        estimate_node(&points, &table.node_position(&table.node_index(cell as usize)))
    });
    let differences = cells.iter().zip(&estimates).flat_map(|(&cell, estimate)| {
        let stored = table.node(&table.node_index(cell as usize));
        stored.iter().zip(&estimate.mean).map(|(&s, &r)| s as f64 - r).collect::<Vec<f64>>()
    });
    Ok(Some(ReferenceComparison {
        samples_per_cell: points.plan().total(),
        difference: ErrorSummary::of_differences(differences),
    }))
}

/// `count` distinct cell numbers below `node_count` (all of them if `count >= node_count`), drawn
/// reproducibly from `seed`, in increasing order.
pub fn random_cells(node_count: usize, count: usize, seed: u64) -> Vec<u64> {
    if count >= node_count {
        return (0..node_count as u64).collect();
    }
    let mut chosen = std::collections::BTreeSet::new();
    let mut draw = 0u32;
    while chosen.len() < count {
        let hash = crate::sampling::sequence::scramble_seed(seed, 0xCE11, draw) as u64;
        let hash = hash << 32 | crate::sampling::sequence::scramble_seed(seed, 0xCE12, draw) as u64;
        chosen.insert(hash % node_count as u64);
        draw += 1;
    }
    chosen.into_iter().collect()
}
