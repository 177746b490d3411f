//! Table recipes: one file per table, each readable as the integral it computes.
//!
//! A recipe supplies its settings, metadata and kernel ([`driver::Kernel`]); the driver
//! ([`driver::build`]) turns them into a [`TableBuild`]: the table itself and its [`Provenance`],
//! the record of how it was made (integrand, masking-shadowing model, sampler, samples, seed, wall
//! time, error estimates) that the manifest publishes beside every file.

/// The part of a [`driver::Kernel`] impl that every table's settings share: the inherent
/// `validate`, the `method` field, `sampling` and `reference` of the `shared` field
/// ([`settings::SharedSettings`]), and the interpolation check over the recipe's domains. Used inside `impl Kernel for ...Settings`, so that each impl states only
/// what differs (the table's layout, metadata and kernel).
macro_rules! kernel_settings {
    () => {
        fn validate(&self) -> Result<()> {
            Self::validate(self)
        }

        fn sampling(&self) -> super::settings::SamplingConfig {
            self.shared.sampling
        }

        fn reference(&self) -> super::settings::ReferenceConfig {
            self.shared.reference
        }

        fn method(&self) -> Method {
            self.method
        }

        fn exact_values(&self, seed: u64, progress: &dyn Progress) -> Result<Vec<super::interpolation::ExactValues>> {
            super::interpolation::exact_values_of(self, seed, progress)
        }
    };
}

/// The part of a [`TableRecipe`] impl that every table's settings share: the module's `NAME`,
/// `DESCRIPTION`, `CHANNEL_COUNT` and `COUNT_KEYS`, the inherent `axes`, the `method` field, and
/// `sampling`, `reference`, `interpolation` and `output` of the `shared` field. Used inside
/// `impl TableRecipe for ...Settings`, so that each impl states only what differs
/// (`companions`, the interpolation check's domains).
macro_rules! table_recipe_accessors {
    () => {
        fn name(&self) -> &'static str {
            NAME
        }

        fn description(&self) -> &'static str {
            DESCRIPTION
        }

        fn method_mut(&mut self) -> &mut Method {
            &mut self.method
        }

        fn sampling_mut(&mut self) -> &mut super::settings::SamplingConfig {
            &mut self.shared.sampling
        }

        fn reference_mut(&mut self) -> &mut super::settings::ReferenceConfig {
            &mut self.shared.reference
        }

        fn interpolation_mut(&mut self) -> &mut super::interpolation::InterpolationConfig {
            &mut self.shared.interpolation
        }

        fn axes(&self) -> Result<Vec<Axis>> {
            Self::axes(self)
        }

        fn output(&self) -> &super::settings::OutputConfig {
            &self.shared.output
        }

        fn output_mut(&mut self) -> &mut super::settings::OutputConfig {
            &mut self.shared.output
        }

        fn interpolation(&self) -> super::interpolation::InterpolationConfig {
            self.shared.interpolation
        }

        fn channel_count(&self) -> usize {
            CHANNEL_COUNT
        }

        fn count_keys(&self) -> &'static [&'static str] {
            COUNT_KEYS
        }
    };
}

/// The kernel of a table over `(mu, alpha)` whose channels are `E[f_j(wi.h) W]` for the channel
/// functions `$f` of the cosine (`W = G2 / G1(wi)` of the settings' `masking`, by their `method`):
/// GD and Kulla & Conty's E (`ggx_e`) integrate the same albedo ([`gd::without_fresnel`]), Karis's
/// table and its multiple-scattering arrangement Schlick's weights. Used inside
/// `impl Kernel for ...Settings`, so that each states only its channel functions.
macro_rules! cosine_function_kernel {
    ($f:path) => {
        fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
            let estimates = super::fill_mu_alpha_nodes(table, progress, |_, mu, alpha| {
                crate::integrate::estimate_cosine_functions(mu, alpha, self.masking, self.method, points, $f)
            });
            Ok(Integrated::of(&estimates))
        }

        fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
            let (mu, alpha) = (position[0], position[1]);
            crate::integrate::estimate_cosine_functions(mu, alpha, self.masking, Method::PerCell, points, $f)
        }

        fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
            quadrature.cosine_functions(position[0], position[1], self.masking, &[], $f).to_vec()
        }
    };
}

pub mod belcour;
pub mod driver;
pub mod fgd;
pub mod fgd_rarer;
pub mod gd;
pub mod ggx_e;
pub mod ggx_e_avg;
pub mod interpolation;
pub mod karis;
pub mod karis_multiscatter;
pub mod settings;
pub mod slices;
pub mod spacing;
pub mod split_sum;
#[cfg(test)]
pub(crate) mod test_estimators;
pub mod tir;

pub use crate::integrate::Method;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Progress};
use crate::sampling::sequence::{PointSet, SamplePlan};
pub use crate::stats::{AccuracyReport, ErrorRecord, ErrorSummary, ReferenceComparison};
use crate::table::Table;
pub(crate) use driver::table_points;
pub use driver::{Integrated, Kernel, Metadata, Provenance, SamplingRecord, TableBuild};
use serde::{Deserialize, Serialize};

use crate::table::{PerKind, TableKind};

/// The registry of tables: one line per table, in build order, as `section: Kind => module::Settings`,
/// pairing each [`TableKind`] of the loader's list (`tmlut_loader::table::kind`, which every reader
/// shares) with its recipe. The section is the table's name, its TOML section and its recipe
/// module here, declared beside it.
///
/// From this list come the [`Config`] fields, the recipe of each kind, and [`TableSettings`] (one
/// table's settings, what a scene's plan builds). The recipe of a kind is taken from a `PerKind`
/// (the loader's value per kind, a field per kind named as the kind is) whose literal names every
/// section: a kind without a recipe here, or a section that is no kind, does not compile.
/// A test holds the sections to the kinds' order.
macro_rules! table_registry {
    ($($section:ident: $kind:ident => $settings:ty),+ $(,)?) => {
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct Config {
            /// Seed of every Monte Carlo estimate: the same configuration and seed give bit-identical files.
            pub seed: u64,
            $(pub $section: $settings,)+
            /// How `tmlut bake` and `build --scene --bake` bake a scene's materials: no table's.
            pub bake: crate::bake::BakeConfig,
        }

        impl Default for Config {
            fn default() -> Self {
                Config { seed: DEFAULT_SEED, $($section: <$settings>::default(),)+ bake: Default::default() }
            }
        }

        impl Config {
            /// The settings of one table.
            pub fn recipe(&self, kind: TableKind) -> &dyn TableRecipe {
                let recipes: PerKind<&dyn TableRecipe> = PerKind { $($section: &self.$section,)+ };
                recipes.take(kind)
            }

            /// The settings of one table, to change.
            pub fn recipe_mut(&mut self, kind: TableKind) -> &mut dyn TableRecipe {
                let recipes: PerKind<&mut dyn TableRecipe> = PerKind { $($section: &mut self.$section,)+ };
                recipes.take(kind)
            }
        }

        /// One table's settings, owned: a whole table a scene's plan builds, or one over a
        /// sub-range of its axes. Serialised as the settings themselves (the cache's keys).
        #[derive(Debug, Clone, PartialEq, Serialize)]
        #[serde(untagged)]
        pub enum TableSettings {
            $($kind($settings),)+
        }

        impl TableSettings {
            /// The settings of `kind` in `config`.
            pub fn of(config: &Config, kind: TableKind) -> Self {
                let settings: PerKind<fn(&Config) -> TableSettings> =
                    PerKind { $($section: |config| TableSettings::$kind(config.$section.clone()),)+ };
                settings.take(kind)(config)
            }

            pub fn kind(&self) -> TableKind {
                match self {
                    $(TableSettings::$kind(_) => TableKind::$kind,)+
                }
            }

            pub fn recipe(&self) -> &dyn TableRecipe {
                match self {
                    $(TableSettings::$kind(s) => s,)+
                }
            }

            pub fn recipe_mut(&mut self) -> &mut dyn TableRecipe {
                match self {
                    $(TableSettings::$kind(s) => s,)+
                }
            }
        }

        /// The registry's sections, in its order.
        #[cfg(test)]
        pub(crate) const REGISTRY_SECTIONS: &[&str] = &[$(stringify!($section),)+];
    };
}

table_registry! {
    fgd: Fgd => fgd::FgdSettings,
    gd: Gd => gd::GdSettings,
    tir: Tir => tir::TirSettings,
    belcour: Belcour => belcour::BelcourSettings,
    karis: Karis => karis::KarisSettings,
    fgd_rarer: FgdRarer => fgd_rarer::FgdRarerSettings,
    ggx_e: GgxE => ggx_e::GgxESettings,
    ggx_e_avg: GgxEAvg => ggx_e_avg::GgxEAvgSettings,
    karis_multiscatter: KarisMultiscatter => karis_multiscatter::KarisMultiscatterSettings,
}

/// The seed of a configuration that names none.
pub const DEFAULT_SEED: u64 = 2021;

/// Files a table writes beside its own, each from the table as built.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Companions {
    /// Volume-texture packings of the table with their shader lookups (FGD).
    pub packings: Vec<crate::packing::Packing>,
    /// The texture files each packing is written to (DDS, KTX2).
    pub packing_formats: Vec<crate::formats::FileFormat>,
    /// The analytic form fitted to the table, written as shader functions (TIR with `fit = "best"`;
    /// `docs/fit.md`).
    pub fitted_form: bool,
}

impl Companions {
    /// Whether any companion file is written.
    pub fn writes_files(&self) -> bool {
        !self.packings.is_empty() || self.fitted_form
    }
}

/// What the configuration, the pipeline, the reports and the CLI need of every table, beyond what
/// the driver needs ([`Kernel`]). Each table's settings implement it; the registry above lists
/// them.
pub trait TableRecipe: Kernel {
    fn name(&self) -> &'static str;
    /// One line for `tmlut list`.
    fn description(&self) -> &'static str;
    /// Whether a build that names no tables makes this one: every table of the default set does;
    /// an engine's table only where its `build` key is `always` ([`settings::BuildWhen`]).
    fn built_unnamed(&self) -> bool {
        true
    }
    /// Files written beside the table's own: none unless a table's settings ask for some.
    fn companions(&self) -> Companions {
        Companions::default()
    }
    /// The axes of the table these settings describe.
    fn axes(&self) -> crate::error::Result<Vec<crate::table::Axis>>;
    fn output(&self) -> &settings::OutputConfig;
    fn output_mut(&mut self) -> &mut settings::OutputConfig;
    /// Write no files beside the table ([`TableRecipe::companions`]).
    fn clear_companions(&mut self) {}
    /// Clear what decides only how the table is written (its files' formats and precision, the
    /// files beside it), keeping what its values depend on: the settings the table cache keys a
    /// table by (`scene::cache`), so that one integration serves every container and precision.
    fn clear_written_settings(&mut self) {
        *self.output_mut() = settings::OutputConfig { formats: Vec::new(), precision: crate::formats::Precision::F32 };
        self.clear_companions();
    }
    /// Channels of the table.
    fn channel_count(&self) -> usize;
    /// The configuration keys of the node counts, axis 0 first (`mu_count`, ...).
    fn count_keys(&self) -> &'static [&'static str];
    fn method_mut(&mut self) -> &mut Method;
    fn sampling_mut(&mut self) -> &mut settings::SamplingConfig;
    fn reference_mut(&mut self) -> &mut settings::ReferenceConfig;
    fn interpolation_mut(&mut self) -> &mut interpolation::InterpolationConfig;
    /// Hat intervals of the visible-normal measure the build keeps for every `(mu, alpha)` node and
    /// replicate at once, if it keeps one (FGD's fast path, Belcour's accuracy report).
    fn kept_measure_intervals(&self) -> Option<usize> {
        None
    }
    /// Integrate the whole table ([`driver::build`]).
    fn build(&self, seed: u64, progress: &dyn Progress) -> crate::error::Result<TableBuild> {
        driver::build(self, seed, progress)
    }
    /// How the table is checked between its nodes ([`interpolation`]).
    fn interpolation(&self) -> interpolation::InterpolationConfig;
    /// The boxes of lookup parameters the interpolation check draws from: by default each axis's
    /// quantity over its range, whole and at low roughness ([`interpolation::standard_domains`]).
    fn interpolation_domains(&self) -> crate::error::Result<Vec<interpolation::Domain>> {
        let axes = self.axes()?;
        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
        let ranges: Vec<[f64; 2]> = axes.iter().map(|a| a.bounds().into()).collect();
        Ok(interpolation::standard_domains(&names, &ranges))
    }
    /// A point of lookup parameters (in the order of [`TableRecipe::interpolation_domains`]) in
    /// the axes' quantities: the same numbers unless an axis is a quantity derived from them.
    fn position_of(&self, lookup: &[f64]) -> Vec<f64> {
        lookup.to_vec()
    }
}

/// [`TableRecipe::position_of`] for a table over `(mu, alpha, q)` whose third axis `q` is derived
/// from a lookup's `(mu, alpha, eta)`.
fn position_of_eta_lookup(recipe: &dyn TableRecipe, lookup: &[f64]) -> Vec<f64> {
    let axes = recipe.axes().expect("validated settings have axes");
    crate::table::derived::point_of(&axes, lookup[0], lookup[1], lookup[2], 0.0).expect("the axes are known quantities")
}

/// The most memory the build of one table may ask for: 16 GiB, two thirds of the project's
/// machines (`docs/benchmark.md` states the memory of the one it ran on). Above it a build would be
/// killed or swap for hours.
pub const MAX_BUILD_BYTES: u64 = 16 << 30;

/// The most sample evaluations (one visible normal, weighted) one table's build may make: 2^44,
/// sixteen times the 2^40 of the whole default FGD table by the per-cell method, days on a 2-core
/// machine (`tmlut bench` extrapolates that table's time: `docs/benchmark.md`, "The tables: tmlut
/// bench").
pub const MAX_SAMPLE_EVALUATIONS: u64 = 1 << 44;

/// Bytes per stored value while a table is built: the f32 value, up to four f64 beside it (FGD's
/// product, and with error maps its running mean, sum of squares and replicate product), the f32
/// error map, and the encoded file and its read-back for the interpolation check (8 bytes at f32),
/// which a build holds while the next table integrates.
const BUILD_BYTES_PER_VALUE: u128 = 56;
/// What the process holds besides a table's build: the program, its threads, the manifest.
const BUILD_BYTES_BASE: u128 = 64 << 20;
/// Bytes per cell estimated on its own: an [`Estimate`] (two vectors of a few f64 each, with their
/// allocations).
const BUILD_BYTES_PER_ESTIMATE: u128 = 160;
/// Bytes per sample point: a [`crate::sampling::DiskPoint`] in f64 and its f32 copy.
const BYTES_PER_SAMPLE_POINT: u128 = 36;

/// What building one table asks of the machine, estimated from its settings alone.
#[derive(Debug, Clone, PartialEq)]
pub struct Demand {
    pub bytes: u128,
    pub sample_evaluations: u128,
    /// Each part of `bytes` with the configuration keys it grows with, largest first.
    pub parts: Vec<(u128, String)>,
}

/// Estimate what building `recipe`'s table needs, before anything is allocated. The estimate is an
/// upper bound of the peak resident memory measured (`docs/tables.md`, "What a build may ask for",
/// lists estimates; `docs/benchmark.md`, "Peak memory per table", the peaks of the same builds).
pub fn demand(recipe: &dyn TableRecipe) -> crate::error::Result<Demand> {
    let name = recipe.name();
    let axes = recipe.axes()?;
    let counts: Vec<u128> = axes.iter().map(|a| a.count as u128).collect();
    let nodes: u128 = counts.iter().product();
    let plane = counts[0] * counts.get(1).copied().unwrap_or(1);
    let sampling = recipe.sampling();
    let samples = sampling.samples as u128;
    let estimated_cells = if recipe.method() == Method::PerCell { nodes } else { plane };
    let shape = counts.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" x ");
    let count_keys = recipe.count_keys().iter().map(|k| format!("{name}.{k}")).collect::<Vec<_>>().join(", ");

    let mut parts = vec![
        (
            nodes * recipe.channel_count() as u128 * BUILD_BYTES_PER_VALUE + estimated_cells * BUILD_BYTES_PER_ESTIMATE,
            format!("{shape} nodes of {} channel(s) ({count_keys})", recipe.channel_count()),
        ),
        (samples * BYTES_PER_SAMPLE_POINT, format!("{samples} sample points ({name}.sampling.samples)")),
    ];
    if let Some(intervals) = recipe.kept_measure_intervals() {
        let replicates = crate::sampling::sequence::SamplePlan::new(sampling.samples, sampling.replicates)?.replicates;
        parts.push((
            plane * (replicates as u128 + 1) * (intervals as u128 + 1) * 8,
            format!(
                "a measure on {intervals} hat intervals per (mu, alpha) node and replicate ({name}.cosine_intervals, \
                 the mu and alpha counts, {name}.sampling.replicates)"
            ),
        ));
    }
    parts.push((BUILD_BYTES_BASE, "the program itself".into()));
    parts.sort_by_key(|part| std::cmp::Reverse(part.0));
    let bytes = parts.iter().map(|p| p.0).sum();
    let sample_evaluations = estimated_cells * samples;
    Ok(Demand { bytes, sample_evaluations, parts })
}

/// Refuse a table whose build would need more than [`MAX_BUILD_BYTES`] of memory, or more than
/// this process may use ([`crate::memory::memory_limit`]), or
/// [`MAX_SAMPLE_EVALUATIONS`] samples, naming the keys that make it so.
pub fn check_demand(recipe: &dyn TableRecipe) -> crate::error::Result<()> {
    let name = recipe.name();
    let demand = demand(recipe)?;
    let gib = |b: u128| {
        let gib = b as f64 / (1u64 << 30) as f64;
        if gib < 1e4 { format!("{gib:.1} GiB") } else { format!("{gib:.2e} GiB") }
    };
    if demand.bytes > MAX_BUILD_BYTES as u128 {
        let (largest, keys) = &demand.parts[0];
        return Err(crate::error::Error::invalid(
            name,
            format!(
                "building this table needs about {} of memory, {} of it for {keys}; allowed: at most {} per table: \
                 lower those keys",
                gib(demand.bytes),
                gib(*largest),
                gib(MAX_BUILD_BYTES as u128)
            ),
        ));
    }
    // A build the machine cannot hold would be killed, or abort on a failed allocation, minutes in.
    if let Some(limit) = crate::memory::memory_limit()
        && demand.bytes > limit.bytes as u128
    {
        let (largest, keys) = &demand.parts[0];
        return Err(crate::error::Error::invalid(
            name,
            format!(
                "building this table needs about {} of memory, {} of it for {keys}; this process may use at most {} \
                 ({}): lower those keys or raise the limit",
                gib(demand.bytes),
                gib(*largest),
                gib(limit.bytes as u128),
                limit.source
            ),
        ));
    }
    if demand.sample_evaluations > MAX_SAMPLE_EVALUATIONS as u128 {
        let cells =
            if recipe.method() == Method::PerCell { "every node (method per-cell)" } else { "every (mu, alpha) node" };
        return Err(crate::error::Error::invalid(
            name,
            format!(
                "building this table evaluates {:.3e} samples ({name}.sampling.samples = {} at {cells}, and the \
                 reference check); allowed: at most 2^44 = {:.3e}: lower the samples, the counts or the method",
                demand.sample_evaluations as f64,
                recipe.sampling().samples,
                MAX_SAMPLE_EVALUATIONS as f64
            ),
        ));
    }
    Ok(())
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
    store_means(table, &estimates);
    estimates
}

/// Store the means of `estimates` (one per node, in node order) as the table's values.
pub(crate) fn store_means(table: &mut Table, estimates: &[Estimate]) {
    let channels = table.channel_count();
    for (values, estimate) in table.data.chunks_mut(channels).zip(estimates) {
        for (v, m) in values.iter_mut().zip(&estimate.mean) {
            *v = *m as f32;
        }
    }
}

/// Estimate every node of a 3D table whose first two axes are `mu` and `alpha` a column at a time:
/// `column(cell, mu, alpha)` estimates the whole third axis at the `(mu, alpha)` node numbered
/// `cell` (`mu` fastest), one channel
/// per node of it (one pass over the samples serves them all). Returns one single-channel estimate
/// per node, in the table's node order.
pub(crate) fn estimate_mu_alpha_columns(
    table: &Table,
    progress: &dyn Progress,
    column: impl Fn(usize, f64, f64) -> Estimate + Sync,
) -> Vec<Estimate> {
    let (mu_axis, alpha_axis) = (&table.axes[0], &table.axes[1]);
    let plane = mu_axis.count * alpha_axis.count;
    let cells: Vec<u64> = (0..plane as u64).collect();
    let columns = crate::integrate::estimate_cells(&cells, &table.name, progress, |cell| {
        let (i, j) = (cell as usize % mu_axis.count, cell as usize / mu_axis.count);
        column(cell as usize, mu_axis.node_value(i), alpha_axis.node_value(j))
    });
    // From (mu, alpha) columns of third-axis values to the table's node order.
    (0..table.node_count())
        .map(|n| {
            let (column, k) = (&columns[n % plane], n / plane);
            Estimate { mean: vec![column.mean[k]], standard_error: vec![column.standard_error[k]] }
        })
        .collect()
}

/// Seeds of high-sample reference estimates (`bench`, `converge`, the packing report) are offset
/// from the table's so that their scrambles are independent of the ones the table was built with.
const REFERENCE_SEED_OFFSET: u64 = 0x005E_ED0F_2EF5;

/// The points of high-sample reference estimates for a run seeded with `seed`: `samples` per cell,
/// scrambles independent of the table's own.
///
/// 2^20 points take a tenth of a second to draw, so the last set drawn is kept and handed out
/// again for the same `samples` and `seed` (the points depend on nothing else).
pub fn reference_points(samples: u64, seed: u64) -> crate::error::Result<std::sync::Arc<PointSet>> {
    static LAST: std::sync::Mutex<Option<std::sync::Arc<PointSet>>> = std::sync::Mutex::new(None);
    let (plan, seed) = (SamplePlan::new(samples, 1)?, seed.wrapping_add(REFERENCE_SEED_OFFSET));
    // A panic elsewhere while the lock was held leaves at worst a complete set or none.
    let mut last = LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(points) = last.as_ref().filter(|points| points.plan() == plan && points.seed() == seed) {
        return Ok(points.clone());
    }
    let points = std::sync::Arc::new(PointSet::new(plan, seed));
    *last = Some(points.clone());
    Ok(points)
}

/// Compare a built table, at `reference.cells` nodes drawn at random (reproducibly from `seed`),
/// with `exact(quadrature, position)`, the exact integral by the quadrature of `reference.nodes`
/// nodes per panel.
pub(crate) fn compare_nodes_to_reference(
    exact: impl Fn(&VisibleNormalQuadrature, &[f64]) -> Vec<f64> + Sync,
    table: &Table,
    reference: &settings::ReferenceConfig,
    seed: u64,
    progress: &dyn Progress,
) -> crate::error::Result<Option<ReferenceComparison>> {
    if reference.cells == 0 {
        return Ok(None);
    }
    let quadrature = VisibleNormalQuadrature::new(reference.nodes)?;
    let cells = random_cells(table.node_count(), reference.cells, seed);
    let label = format!("{} reference", table.name);
    let values = crate::integrate::estimate_cells(&cells, &label, progress, |cell| {
        exact(&quadrature, &table.node_position(&table.node_index(cell as usize)))
    });
    let differences = cells.iter().zip(&values).flat_map(|(&cell, exact)| {
        let stored = table.node(&table.node_index(cell as usize));
        stored.iter().zip(exact).map(|(&s, &e)| s as f64 - e).collect::<Vec<f64>>()
    });
    Ok(Some(ReferenceComparison::new(reference.nodes, ErrorSummary::of_differences(differences))))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_check_does_not_depend_on_the_thread_count() {
        let mut settings = fgd::FgdSettings {
            mu_count: 6,
            alpha_count: 5,
            eta_count: 4,
            kappa_count: 3,
            replicate_error_columns: 4,
            ..fgd::FgdSettings::default()
        };
        settings.shared.sampling = settings::SamplingConfig::replicated(1 << 10);
        settings.shared.reference = settings::ReferenceConfig { cells: 13, nodes: 4 };
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| driver::build(&settings, 3, &()).unwrap().provenance.error.reference.unwrap())
        };
        let (one, three) = (run(1), run(3));
        assert_eq!(one.difference.count, 13);
        assert_eq!(one.difference.rms.to_bits(), three.difference.rms.to_bits());
        assert_eq!(one.difference.max.to_bits(), three.difference.max.to_bits());
    }
}
