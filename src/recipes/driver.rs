//! The recipe driver: the steps every table's build shares, around the part that differs.
//!
//! A table supplies a [`Kernel`]: its layout (an empty [`Table`]), its [`Metadata`] (the integral
//! in words, masking, notes, the sampler's description) and its kernel (the integration of every
//! node, a node on its own by the per-cell method, and the exact integral at any position by the
//! deterministic quadrature). [`build`] does the rest, the same
//! for every table: validation, timing, the table's points, the reference check, the exact values
//! of the interpolation check, and the [`Provenance`] that the manifest publishes beside every file.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::interpolation::ExactValues;
use super::settings::{ReferenceConfig, SamplingConfig};
use crate::error::Result;
use crate::formats::SumRounding;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress};
use crate::physics::{FresnelBasis, MaskingShadowing};
use crate::sampling::sequence::{PointSet, SamplePlan};
use crate::stats::{AccuracyReport, ErrorRecord, ErrorSummary, ReferenceComparison};
use crate::table::{Axis, Channel, Table};

/// What the driver needs of a table: its settings, metadata and kernel.
pub trait Kernel: Sync {
    /// Refuse settings out of range, naming the key and what is allowed.
    fn validate(&self) -> Result<()>;
    fn sampling(&self) -> SamplingConfig;
    fn reference(&self) -> ReferenceConfig;
    fn method(&self) -> Method;
    /// The table with its name, axes and channels, every value 0.
    fn empty_table(&self) -> Result<Table>;
    /// What the manifest says of how the table is made.
    fn metadata(&self) -> Metadata;
    /// Store every node's value in `table`, integrated on `points`.
    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated>;
    /// One node on its own, by the per-cell method (scalar f64), at a position given in the
    /// axes' quantities: the Monte Carlo estimator that `converge` and `bench` set beside
    /// [`Kernel::integrate`].
    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate;
    /// The exact integral at one position, given in the axes' quantities: one value per stored
    /// channel, by the deterministic visible-normal `quadrature` with every jump and kink of the
    /// integrand a panel edge. What the reference nodes and the interpolation check compare with.
    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64>;
    /// How the manifest records the integration on `points`: the method and the point set.
    fn sampling_record(&self, points: &PointSet) -> SamplingRecord {
        sampling_record(self.method(), &self.metadata().sampler, points)
    }
    /// Compare the built table with the exact integral at random nodes
    /// ([`super::compare_nodes_to_reference`]).
    fn check_reference(
        &self,
        table: &Table,
        seed: u64,
        progress: &dyn Progress,
    ) -> Result<Option<ReferenceComparison>> {
        super::compare_nodes_to_reference(
            |quadrature, position| self.exact_value(quadrature, position),
            table,
            &self.reference(),
            seed,
            progress,
        )
    }
    /// The exact integral at random points of the table's domains, for the interpolation check
    /// ([`super::interpolation::exact_values_of`]); none by default.
    fn exact_values(&self, _seed: u64, _progress: &dyn Progress) -> Result<Vec<ExactValues>> {
        Ok(Vec::new())
    }
}

/// The note of every node-aligned table's metadata: where its nodes lie, and that a GPU sampler
/// needs the half-texel correction its manifest gives per axis.
pub const NODE_ALIGNED_NOTE: &str =
    "Node-aligned: node k of N at (k / (N - 1)); a GPU sampler needs the half-texel correction given per axis.";

/// The note of a table whose axes are all placed as `placement` says: [`NODE_ALIGNED_NOTE`], or
/// where cell-centred nodes sit.
pub fn placement_note(placement: crate::table::Placement) -> String {
    match placement {
        crate::table::Placement::NodeAligned => NODE_ALIGNED_NOTE.into(),
        crate::table::Placement::CellCentred => {
            "Cell-centred: node k of N at (k + 0.5) / N of each axis, as a GPU texture places its texels.".into()
        }
    }
}

/// The note of every table with a `mu` axis from 0: its grazing nodes are not evaluated at 0.
pub fn grazing_note() -> String {
    format!("The mu = 0 nodes are the limit mu -> 0+, evaluated at mu = {}.", crate::integrate::GRAZING_COSINE)
}

/// The empty table of a kernel that stores one channel.
pub fn one_channel_table(name: &str, axes: Vec<Axis>, channel: &str, meaning: &str) -> Result<Table> {
    Table::zeros(name, axes, vec![Channel::new(channel, meaning)])
}

/// What a table states of itself, whatever its values.
#[derive(Debug, Clone, Default)]
pub struct Metadata {
    /// The integral, in words and symbols, as the manifest states it.
    pub integrand: String,
    pub masking: Option<MaskingShadowing>,
    /// Conventions a user must know to read the table right.
    pub notes: Vec<String>,
    /// How the kernel uses the points, after the method's name in the manifest's `method`.
    pub sampler: String,
    /// The tabulated Fresnel basis a shader needs to use the table (Belcour only).
    pub fresnel_basis: Option<FresnelBasis>,
    /// For a table whose channels add up to an albedo (Karis): how storage rounds them; the
    /// manifest then states what storage does to their sum.
    pub channel_sum: Option<SumRounding>,
}

/// What a kernel knows of the error of the values it stored.
#[derive(Debug, Clone)]
pub struct Integrated {
    /// RMS and maximum of the replicate standard errors, over the nodes where they were computed.
    pub replicate_standard_error: ErrorSummary,
    /// The replicate standard error of every stored value, in the table's layout, where it was
    /// computed for every node.
    pub standard_error: Option<Vec<f32>>,
    /// Further measured accuracy figures (for instance, how well a split-sum reproduces FGD).
    pub accuracy: Vec<AccuracyReport>,
}

impl Integrated {
    /// The errors of a table whose every node has its estimate in `estimates`, in node order.
    pub fn of(estimates: &[Estimate]) -> Integrated {
        Integrated {
            replicate_standard_error: replicate_error(estimates),
            standard_error: Some(standard_error_map(estimates)),
            accuracy: Vec::new(),
        }
    }

    /// The errors of a table computed without random points: no replicate spread, and no map of it.
    pub fn deterministic() -> Integrated {
        Integrated {
            replicate_standard_error: ErrorSummary::of_differences(std::iter::empty()),
            standard_error: None,
            accuracy: Vec::new(),
        }
    }

    /// [`Integrated::of`] from the standard error of every value alone, in the table's layout
    /// (node after node, the channels of a node together).
    pub fn of_standard_errors(standard_errors: &[f64]) -> Integrated {
        Integrated {
            replicate_standard_error: ErrorSummary::of_differences(standard_errors.iter().copied()),
            standard_error: Some(standard_errors.iter().map(|&s| s as f32).collect()),
            accuracy: Vec::new(),
        }
    }
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
    pub provenance: Provenance,
}

/// How a table was made: everything the manifest publishes beside its values.
#[derive(Debug, Clone)]
pub struct Provenance {
    /// What the table states of itself (its recipe's [`Kernel::metadata`]). A build read from the
    /// scene cache has only what the cache stores: integrand, masking and notes.
    pub metadata: Metadata,
    pub sampling: SamplingRecord,
    pub error: ErrorRecord,
    pub wall_time_s: f64,
    /// Further measured accuracy figures (for instance, how well a split-sum reproduces FGD).
    pub accuracy: Vec<AccuracyReport>,
    /// The replicate standard error of every stored value, in the table's layout, where it was
    /// computed for every node (the error maps draw it).
    pub standard_error: Option<Vec<f32>>,
    /// The exact integral at random points of the table's domains: each written file is read
    /// there as a renderer reads it and compared ([`super::interpolation::compare`]).
    pub interpolation: Vec<ExactValues>,
}

impl Provenance {
    /// The provenance of a table computed from this one without integrating again (a packing):
    /// the same integral, sampling and integration error, and none of the figures that describe
    /// the source's own layout (error map, interpolation check, accuracy, Fresnel basis, channel
    /// sum).
    pub fn of_derived_table(&self) -> Provenance {
        Provenance {
            metadata: Metadata { fresnel_basis: None, channel_sum: None, ..self.metadata.clone() },
            sampling: self.sampling.clone(),
            error: self.error.clone(),
            wall_time_s: self.wall_time_s,
            accuracy: Vec::new(),
            standard_error: None,
            interpolation: Vec::new(),
        }
    }
}

/// Validate `kernel`'s settings, integrate its table with `seed`, check it against reference
/// estimates and record how it was made. The wall time covers the integration and the reference
/// check, not the interpolation check's exact values.
pub fn build<K: Kernel + ?Sized>(kernel: &K, seed: u64, progress: &dyn Progress) -> Result<TableBuild> {
    kernel.validate()?;
    let started = Instant::now();
    let points = table_points(&kernel.sampling(), seed)?;
    let mut table = kernel.empty_table()?;
    let integrated = kernel.integrate(&mut table, &points, progress)?;
    let reference = kernel.check_reference(&table, seed, progress)?;
    let wall_time_s = started.elapsed().as_secs_f64();
    let provenance = Provenance {
        metadata: kernel.metadata(),
        sampling: kernel.sampling_record(&points),
        error: ErrorRecord::new(integrated.replicate_standard_error, reference),
        wall_time_s,
        accuracy: integrated.accuracy,
        standard_error: integrated.standard_error,
        interpolation: kernel.exact_values(seed, progress)?,
    };
    Ok(TableBuild { table, provenance })
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

/// The record of a table integrated by a deterministic quadrature (`description`), with no random
/// points: the seed is kept for the checks that draw them.
pub(crate) fn quadrature_record(description: &str, seed: u64) -> SamplingRecord {
    SamplingRecord {
        method: format!("quadrature ({description})"),
        sampler: "none: no random points".into(),
        samples_per_cell: 0,
        replicates: 0,
        seed,
    }
}

/// The point set of a table's own samples.
pub(crate) fn table_points(sampling: &SamplingConfig, seed: u64) -> Result<PointSet> {
    Ok(PointSet::new(SamplePlan::new(sampling.samples, sampling.replicates)?, seed))
}

/// The standard error of every value of `estimates`, in node order: a table's error map.
pub(crate) fn standard_error_map(estimates: &[Estimate]) -> Vec<f32> {
    estimates.iter().flat_map(|e| e.standard_error.iter().map(|&s| s as f32)).collect()
}

/// RMS and maximum, over all cells and channels, of the replicate standard errors.
pub(crate) fn replicate_error(estimates: &[Estimate]) -> ErrorSummary {
    ErrorSummary::of_differences(estimates.iter().flat_map(|e| e.standard_error.iter().copied()))
}
