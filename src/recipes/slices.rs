//! Specialised slices: FGD or TIR at a few fixed relative indices, as 2D `(mu, alpha)` tables with
//! one channel per index. Where a scene's materials use only a handful of discrete `(eta, kappa)`
//! pairs, these replace the 4D FGD and 3D TIR tables (`docs/scenes.md`): the same integrals, with
//! no interpolation across `eta` and `kappa`, in a few kilobytes.
//!
//! ```text
//! FGD slice, channel k:  FGD(mu, alpha; eta_k, kappa_k) = E_{h ~ VNDF(wi)}[ F(wi.h; eta_k, kappa_k) G2 / G1(wi) ]
//! TIR slice, channel k:  TIR(mu, alpha; eta_k)          = ∫ rho(w) [1 - w.z^2 > eta_k^2] dw / ∫ rho(w) dw
//! ```
//!
//! An FGD slice is computed exactly as its full table computes a node
//! ([`super::fgd::fgd_pairs_fast`]), with the full table's settings, so that a slice node equals
//! the full table's node at the same parameters up to rounding. A TIR slice is integrated
//! deterministically over the reflected lobe ([`super::tir::tir_column_by_lobe`], [`super::tir::TIR_LOBE_NODES`]):
//! its indicator needs many more Monte Carlo samples than the full table's for the error a
//! material allows, and the lobe quadrature answers every index of a node from one integration.
//! The `mu` and `alpha` axes are sub-ranges of the full table's grid (the planner picks them), so
//! the nodes coincide.

use serde::{Deserialize, Serialize};

use super::driver::{Provenance, TableBuild};
use super::fgd::{FgdSettings, fgd_by_quadrature, fgd_pairs_on_measure, projected_fresnel};
use super::settings::{OutputConfig, ReferenceConfig, SamplingConfig, SharedSettings};
use super::tir::{
    TIR_LOBE_NODES, TirSettings, deterministic, lobe_quadrature_description, tir_by_quadrature, tir_cell,
    tir_column_by_lobe,
};
use super::{Integrated, Kernel, Metadata, fill_mu_alpha_nodes};
use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::integrate::measure::{Projection, cosine_measure};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cosine_functions};
use crate::physics::MaskingShadowing;
use crate::physics::fresnel_reflectance;
use crate::sampling::sequence::PointSet;
use crate::stats::{ErrorRecord, ErrorSummary, ReferenceComparison};
use crate::table::{Axis, Channel, Table};

/// The integral a slice tabulates, with the settings of the full table it specialises.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SliceOf {
    Fgd(FgdSettings),
    Tir(TirSettings),
}

/// One channel of a slice: the relative index it is evaluated at (kappa is 0 for TIR) and which
/// colour channels of which lookups read it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SliceChannel {
    pub eta: f64,
    pub kappa: f64,
    pub used_by: String,
}

/// A DDS texture holds 1, 2 or 4 channels: a slice of three indices gets a fourth, zero channel.
pub const PADDING_CHANNEL: &str = "padding";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Slices {
    pub name: String,
    pub of: SliceOf,
    pub mu: Axis,
    pub alpha: Axis,
    /// The `mu` and `alpha` ranges the lookups reach (inside the axes, which add a margin): the
    /// accuracy check samples these.
    pub lookup_mu: [f64; 2],
    pub lookup_alpha: [f64; 2],
    pub channels: Vec<SliceChannel>,
}

impl Slices {
    pub fn validate(&self) -> Result<()> {
        let key = format!("slices `{}`", self.name);
        if self.channels.is_empty() || self.channels.len() > 4 {
            return Err(Error::invalid(key, format!("{} channels; allowed: 1 to 4", self.channels.len())));
        }
        for axis in [&self.mu, &self.alpha] {
            axis.validate()?;
            if axis.start < 0.0 || axis.end > 1.0 {
                return Err(Error::invalid(&key, format!("axis `{}` leaves [0, 1]", axis.name)));
            }
        }
        match &self.of {
            SliceOf::Fgd(settings) => settings.validate(),
            SliceOf::Tir(settings) => settings.validate(),
        }
    }

    /// Channels as stored: one per index, plus a zero padding channel after three.
    pub fn stored_channel_count(&self) -> usize {
        if self.channels.len() == 3 { 4 } else { self.channels.len() }
    }

    /// Bytes of the stored texels.
    pub fn texel_bytes(&self) -> u64 {
        (self.mu.count * self.alpha.count * self.stored_channel_count() * self.output().precision.bytes()) as u64
    }

    /// The shared settings of the full table the slices are cut from: its samples and reference
    /// check are the slices' too.
    fn full_table_shared(&self) -> &SharedSettings {
        match &self.of {
            SliceOf::Fgd(s) => &s.shared,
            SliceOf::Tir(s) => &s.shared,
        }
    }

    pub fn sampling(&self) -> SamplingConfig {
        self.full_table_shared().sampling
    }

    pub fn reference(&self) -> ReferenceConfig {
        self.full_table_shared().reference
    }

    /// Slices are textures, written in the precision of the full table's output and in the texture
    /// formats the full table is written in: FGD's `packing_formats` (its 4D table is no
    /// texture), TIR's DDS and KTX2 `output.formats`; as DDS where those list neither.
    pub fn output(&self) -> OutputConfig {
        let (texture_formats, precision) = match &self.of {
            SliceOf::Fgd(s) => (&s.packing_formats, s.shared.output.precision),
            SliceOf::Tir(s) => (&s.shared.output.formats, s.shared.output.precision),
        };
        let mut formats: Vec<FileFormat> =
            texture_formats.iter().copied().filter(|f| FileFormat::TEXTURES.contains(f)).collect();
        if formats.is_empty() {
            formats.push(FileFormat::TEXTURES[0]);
        }
        OutputConfig { formats, precision }
    }

    fn table_name(&self) -> &'static str {
        match self.of {
            SliceOf::Fgd(_) => "FGD",
            SliceOf::Tir(_) => "TIR",
        }
    }

    fn channel_list(&self) -> Vec<Channel> {
        let mut channels: Vec<Channel> = self
            .channels
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let index = match self.of {
                    SliceOf::Fgd(_) => format!("eta {}, kappa {}", c.eta, c.kappa),
                    SliceOf::Tir(_) => format!("eta {}", c.eta),
                };
                let channel = Channel::new(
                    format!("{}{k}", self.table_name().to_lowercase()),
                    format!("{} at {index}; read by {}", self.table_name(), c.used_by),
                )
                .with_fixed("eta", c.eta);
                match self.of {
                    SliceOf::Fgd(_) => channel.with_fixed("kappa", c.kappa),
                    SliceOf::Tir(_) => channel,
                }
            })
            .collect();
        if channels.len() == 3 {
            channels.push(Channel::new(PADDING_CHANNEL, "zero: pads three channels to RGBA (DDS holds 1, 2 or 4)"));
        }
        channels
    }

    fn pairs(&self) -> Vec<(f64, f64)> {
        self.channels.iter().map(|c| (c.eta, c.kappa)).collect()
    }

    /// Every channel at one `(mu, alpha)` by the full table's fast method (padding included): the
    /// node as [`integrate_batch`] computes it, with this slice alone at the node.
    fn estimate_fast(&self, points: &NodePoints, mu: f64, alpha: f64, projections: &[Projection]) -> Estimate {
        self.estimate_on(&SharedNode::new(&self.of, mu, alpha, &[self], points), projections)
    }

    /// Every channel (padding included) from what the slices at one node share.
    fn estimate_on(&self, shared: &SharedNode, projections: &[Projection]) -> Estimate {
        let mut estimate = match shared {
            SharedNode::Fgd(measure) => fgd_pairs_on_measure(measure, &self.pairs(), projections),
            SharedNode::Tir { etas, column } => Estimate::from_channels(
                &self
                    .channels
                    .iter()
                    .map(|c| {
                        let k = etas.partition_point(|&e| e < self.evaluated_eta(c.eta));
                        Estimate { mean: vec![column.mean[k]], standard_error: vec![column.standard_error[k]] }
                    })
                    .collect::<Vec<_>>(),
            ),
        };
        pad(&mut estimate, self.stored_channel_count());
        estimate
    }

    /// The index a TIR channel is integrated at (FGD's are their own).
    fn evaluated_eta(&self, eta: f64) -> f64 {
        match &self.of {
            SliceOf::Tir(settings) => eta.min(settings.top_eta),
            SliceOf::Fgd(_) => eta,
        }
    }

    /// Fresnel of each channel projected on the hat basis (FGD; none for TIR).
    fn projections(&self) -> Vec<Projection> {
        match &self.of {
            SliceOf::Fgd(settings) => {
                self.channels.iter().map(|c| projected_fresnel(settings.cosine_basis(), c.eta, c.kappa)).collect()
            }
            SliceOf::Tir(_) => Vec::new(),
        }
    }

    /// Every channel at one `(mu, alpha)` on its own, in f64 by the per-cell method (padding
    /// included).
    pub fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let (mu, alpha) = (position[0], position[1]);
        let mut estimate = match &self.of {
            // One pass over the samples serves every channel.
            SliceOf::Fgd(settings) => {
                let f = |c: f64, k: usize| fresnel_reflectance(c, self.channels[k].eta, self.channels[k].kappa);
                let cell = |n| {
                    estimate_cosine_functions::<1>(mu, alpha, settings.masking, Method::PerCell, points, move |c| {
                        [f(c, n)]
                    })
                };
                match self.channels.len() {
                    2 => estimate_cosine_functions(mu, alpha, settings.masking, Method::PerCell, points, |c| {
                        [f(c, 0), f(c, 1)]
                    }),
                    3 => estimate_cosine_functions(mu, alpha, settings.masking, Method::PerCell, points, |c| {
                        [f(c, 0), f(c, 1), f(c, 2)]
                    }),
                    _ => Estimate::from_channels(&(0..self.channels.len()).map(cell).collect::<Vec<_>>()),
                }
            }
            SliceOf::Tir(settings) => Estimate::from_channels(
                &self
                    .channels
                    .iter()
                    .map(|c| tir_cell(mu, alpha, c.eta.min(settings.top_eta), points))
                    .collect::<Vec<_>>(),
            ),
        };
        pad(&mut estimate, self.stored_channel_count());
        estimate
    }

    /// Every channel's exact integral at one `(mu, alpha)` by the quadrature (padding included).
    pub fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        let (mu, alpha) = (position[0], position[1]);
        let mut values: Vec<f64> = self
            .channels
            .iter()
            .map(|c| match &self.of {
                SliceOf::Fgd(settings) => fgd_by_quadrature(settings.masking, quadrature, mu, alpha, (c.eta, c.kappa)),
                SliceOf::Tir(_) => tir_by_quadrature(quadrature, mu, alpha, self.evaluated_eta(c.eta)),
            })
            .collect();
        values.resize(self.stored_channel_count(), 0.0);
        values
    }

    /// How the manifest records the integration: FGD's point set, or TIR's quadrature (no samples).
    fn sampling_record(&self, points: &PointSet) -> super::driver::SamplingRecord {
        let sampler = self.metadata().sampler;
        match &self.of {
            SliceOf::Fgd(_) => super::driver::sampling_record(Method::Fast, &sampler, points),
            SliceOf::Tir(_) => super::driver::quadrature_record(&sampler, points.seed()),
        }
    }

    fn masking(&self) -> MaskingShadowing {
        match &self.of {
            SliceOf::Fgd(s) => s.masking,
            SliceOf::Tir(_) => MaskingShadowing::SmithSeparable,
        }
    }
}

/// What every slice at one `(mu, alpha)` node shares: FGD's visible-normal measure, or TIR at
/// every index the slices read there, from one integration over the reflected lobe (each value
/// the same whatever other indices share it).
enum SharedNode {
    Fgd(crate::integrate::measure::CosineMeasure),
    Tir { etas: Vec<f64>, column: Estimate },
}

impl SharedNode {
    fn new(of: &SliceOf, mu: f64, alpha: f64, users: &[&Slices], points: &NodePoints) -> SharedNode {
        match of {
            SliceOf::Fgd(settings) => {
                SharedNode::Fgd(cosine_measure(mu, alpha, settings.masking, &points.table, settings.cosine_basis()))
            }
            SliceOf::Tir(_) => {
                let mut etas: Vec<f64> =
                    users.iter().flat_map(|s| s.channels.iter().map(|c| s.evaluated_eta(c.eta))).collect();
                etas.sort_by(f64::total_cmp);
                etas.dedup();
                let column = deterministic(tir_column_by_lobe(&points.lobe, mu, alpha, &etas));
                SharedNode::Tir { etas, column }
            }
        }
    }
}

/// What a slice node is integrated with: the table's points (FGD), and TIR's lobe quadrature.
pub struct NodePoints {
    table: PointSet,
    lobe: VisibleNormalQuadrature,
}

impl NodePoints {
    pub fn new(table: PointSet) -> Result<NodePoints> {
        Ok(NodePoints { table, lobe: VisibleNormalQuadrature::new(TIR_LOBE_NODES)? })
    }
}

fn pad(estimate: &mut Estimate, channels: usize) {
    estimate.mean.resize(channels, 0.0);
    estimate.standard_error.resize(channels, 0.0);
}

impl Kernel for Slices {
    fn validate(&self) -> Result<()> {
        Slices::validate(self)
    }

    fn sampling(&self) -> SamplingConfig {
        Slices::sampling(self)
    }

    fn reference(&self) -> ReferenceConfig {
        Slices::reference(self)
    }

    /// Each channel is computed as the fast method computes the full table's node.
    fn method(&self) -> Method {
        Method::Fast
    }

    fn empty_table(&self) -> Result<Table> {
        Table::zeros(&self.name, vec![self.mu.clone(), self.alpha.clone()], self.channel_list())
    }

    fn metadata(&self) -> Metadata {
        let (integrand, sampler) = match self.of {
            SliceOf::Fgd(ref settings) => (
                "FGD(mu, alpha; eta_k, kappa_k) = E_{h~VNDF(wi)}[F(wi.h; eta_k, kappa_k) G2(wi,wo) / G1(wi)], one channel per (eta_k, kappa_k)",
                format!(
                    "visible-normal measure per (mu, alpha) on {} hat intervals in wi.h, times projected Fresnel",
                    settings.cosine_intervals
                ),
            ),
            SliceOf::Tir(_) => (
                "TIR(mu, alpha; eta_k) = Σ G1(w) [1 - w.z^2 > eta_k^2] / Σ G1(w), w = reflect(wi, h), h ~ VNDF(wi), one channel per eta_k",
                lobe_quadrature_description(),
            ),
        };
        Metadata {
            integrand: integrand.into(),
            masking: Some(self.masking()),
            notes: vec![
                format!(
                    "A specialised slice of the {} table: fixed relative indices, one per channel; mu and alpha are sub-ranges of the full table's node-aligned grid, lookups outside them clamp.",
                    self.table_name()
                ),
                "Node-aligned: a GPU sampler needs the half-texel correction given per axis.".into(),
            ],
            sampler,
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let projections = self.projections();
        let (mu, alpha, [mu_lattice, alpha_lattice]) = (&self.mu, &self.alpha, self.of.lattice());
        let points = NodePoints::new(points.clone())?;
        let estimates = fill_mu_alpha_nodes(table, progress, |node, _, _| {
            let (i, j) = (node % mu.count, node / mu.count);
            self.estimate_fast(
                &points,
                canonical_node(mu, i, mu_lattice),
                canonical_node(alpha, j, alpha_lattice),
                &projections,
            )
        });
        Ok(Integrated::of(&estimates))
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        Slices::estimate_node(self, points, position)
    }

    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        Slices::exact_value(self, quadrature, position)
    }

    fn sampling_record(&self, points: &PointSet) -> super::driver::SamplingRecord {
        Slices::sampling_record(self, points)
    }
}

/// Slice nodes lie on one lattice per table: `k / lattice` in their axis's mapped quantity (`mu`
/// or `sqrt(mu)`, `sqrt(alpha)`), one density per axis. Slices of a build are sub-ranges of it, so
/// that every slice at a node shares that node's visible-normal measure, however many materials
/// read it ([`integrate_batch`]). FGD's is twice as dense as the default tables' 64 nodes.
pub const FGD_SLICE_LATTICE: [f64; 2] = [128.0, 128.0];

/// TIR's lattice is four times denser in `mu`: at the critical cosine a smooth lobe's TIR steps
/// from 1 to 0 within a few hundredths of `mu`, where FGD is smooth (the copper pot's TIR slice
/// interpolated with an error of 8e-3 on FGD's lattice, and its material 1.0e-3).
pub const TIR_SLICE_LATTICE: [f64; 2] = [512.0, 128.0];

impl SliceOf {
    /// Nodes per unit of the mapped quantity of this table's slice lattice, `mu` then `alpha`.
    pub fn lattice(&self) -> [f64; 2] {
        match self {
            SliceOf::Fgd(_) => FGD_SLICE_LATTICE,
            SliceOf::Tir(_) => TIR_SLICE_LATTICE,
        }
    }
}

/// The value at node `k` of a lattice of `lattice` nodes per unit of `mapping`.
pub fn lattice_value(mapping: crate::table::Mapping, k: f64, lattice: f64) -> f64 {
    mapping.inverse(k / lattice)
}

/// Node `k` of a slice axis, as every slice that holds it integrates it: on the lattice, the
/// lattice's own value (an axis computes its interior nodes from its own range, which may differ in
/// the last bit); off it (a slice made by hand), the axis's.
fn canonical_node(axis: &Axis, k: usize, lattice: f64) -> f64 {
    let value = axis.node_value(k);
    let on_lattice = axis.mapping.forward(value) * lattice;
    if (on_lattice - on_lattice.round()).abs() < 1e-6 {
        lattice_value(axis.mapping, on_lattice.round(), lattice)
    } else {
        value
    }
}

/// A slice's reference figures when its checks are sampled across a batch
/// ([`integrate_batch`]): what the manifest says of them.
pub const BATCH_CHECK_NOTE: &str = "Checked as one of a batch: the reference cells (error.reference) and the exact-integral points of the interpolation check (error.interpolation, where this slice drew any) are drawn at random across every slice of the build integrated on the same settings, so the figures bound the batch's error, not this slice's alone; `tmlut build --scene ... --slice-checks full` checks every slice on its own.";

/// Every slice of `slices` integrated in one pass over the `(mu, alpha)` nodes they hold: slices
/// of the same table and settings share each node's visible-normal measure (FGD) or its one
/// integration over the reflected lobe (TIR), so a slice costs its dot products, not its measures. Each slice's
/// values are bit-identical to those it gets built alone: a node is integrated at its lattice value
/// ([`canonical_node`]), each `(eta, kappa)` on its own ([`fgd_pairs_on_measure`]), each TIR index
/// from panels that depend on the node alone ([`tir_column_by_lobe`]).
///
/// The reference check draws `reference.cells` random nodes across the slices of each group
/// (instead of per slice), each against its exact integral by the quadrature; the
/// figure is recorded in every slice of the group, with [`BATCH_CHECK_NOTE`]. Returns one build per
/// slice, in order, with the wall time of the whole batch.
pub fn integrate_batch(slices: &[&Slices], seed: u64, progress: &dyn Progress) -> Result<Vec<TableBuild>> {
    integrate_batch_among(slices, slices, seed, progress)
}

/// [`integrate_batch`], with the reference check drawn across `population` (a build's slices,
/// `slices` among them): the nodes drawn, and so every slice's figure, depend on the population,
/// not on which of its slices this call integrates, so a shard of a build, or a build that reads
/// some slices from the cache, records what the whole build records. A drawn node of a slice not
/// integrated here is integrated for the check alone.
pub fn integrate_batch_among(
    slices: &[&Slices],
    population: &[&Slices],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<TableBuild>> {
    for slice in slices {
        slice.validate()?;
    }
    let started = std::time::Instant::now();
    let integrated = integrate_tables(slices, seed, progress)?;
    let mut references: Vec<Option<ReferenceComparison>> = vec![None; slices.len()];
    // The reference check of each group of the population that holds a slice integrated here.
    let population_groups = settings_groups(population)?;
    for (key, members) in &settings_groups(slices)? {
        let first = slices[members[0]];
        let reference = first.reference();
        if reference.cells == 0 {
            continue;
        }
        let everyone: Vec<&Slices> = match population_groups.get(key) {
            Some(all) => all.iter().map(|&p| population[p]).collect(),
            None => members.iter().map(|&s| slices[s]).collect(),
        };
        let sizes: Vec<usize> = everyone.iter().map(|s| s.mu.count * s.alpha.count).collect();
        let total: usize = sizes.iter().sum();
        let cells = super::random_cells(total, reference.cells, seed ^ 0x5A1CE);
        let located: Vec<(usize, usize)> = cells
            .iter()
            .map(|&cell| {
                let (mut slice, mut cell) = (0, cell as usize);
                while cell >= sizes[slice] {
                    cell -= sizes[slice];
                    slice += 1;
                }
                (slice, cell)
            })
            .collect();
        // The stored values of drawn slices: integrated here, or on their own for the check.
        let here: std::collections::HashMap<&str, usize> =
            members.iter().map(|&s| (slices[s].name.as_str(), s)).collect();
        let mut outsiders: Vec<&Slices> =
            located.iter().map(|&(p, _)| everyone[p]).filter(|p| !here.contains_key(p.name.as_str())).collect();
        outsiders.sort_by(|a, b| a.name.cmp(&b.name));
        outsiders.dedup_by(|a, b| a.name == b.name);
        let outsider_tables = integrate_tables(&outsiders, seed, progress)?.tables;
        let table_of = |slice: &Slices| -> &Table {
            match here.get(slice.name.as_str()) {
                Some(&s) => &integrated.tables[s],
                None => {
                    &outsider_tables[outsiders.iter().position(|o| o.name == slice.name).expect("integrated above")]
                }
            }
        };
        let quadrature = VisibleNormalQuadrature::new(reference.nodes)?;
        let numbers: Vec<u64> = (0..located.len() as u64).collect();
        let label = format!(
            "{} slices reference ({} cells across {} slices)",
            first.table_name(),
            located.len(),
            everyone.len()
        );
        let differences: Vec<Vec<f64>> = crate::integrate::estimate_cells(&numbers, &label, progress, |n| {
            let (p, cell) = located[n as usize];
            let table = table_of(everyone[p]);
            let index = table.node_index(cell);
            let exact = everyone[p].exact_value(&quadrature, &table.node_position(&index));
            table.node(&index).iter().zip(&exact).map(|(&stored, &e)| stored as f64 - e).collect()
        });
        let comparison =
            ReferenceComparison::new(reference.nodes, ErrorSummary::of_differences(differences.into_iter().flatten()));
        for &s in members {
            references[s] = Some(comparison.clone());
        }
    }
    let wall_time_s = started.elapsed().as_secs_f64();
    let BatchTables { tables, standard_errors, records } = integrated;
    Ok(slices
        .iter()
        .zip(tables)
        .zip(standard_errors)
        .zip(references)
        .zip(records)
        .map(|((((slice, table), standard_errors), reference), sampling)| {
            let integrated = Integrated::of_standard_errors(&standard_errors);
            let mut metadata = slice.metadata();
            metadata.notes.push(BATCH_CHECK_NOTE.into());
            TableBuild {
                table,
                provenance: Provenance {
                    metadata,
                    sampling,
                    error: ErrorRecord::new(integrated.replicate_standard_error, reference),
                    wall_time_s,
                    accuracy: Vec::new(),
                    standard_error: integrated.standard_error,
                    interpolation: Vec::new(),
                },
            }
        })
        .collect())
}

/// Slices integrated together: per slice its table, the replicate standard error of every value
/// (in the table's layout) and its sampling record.
struct BatchTables {
    tables: Vec<Table>,
    standard_errors: Vec<Vec<f64>>,
    records: Vec<super::driver::SamplingRecord>,
}

/// The indices of `slices` by the settings they are integrated on (the same table and settings:
/// sampling, masking, basis), which share measures and a reference check.
fn settings_groups(slices: &[&Slices]) -> Result<std::collections::BTreeMap<String, Vec<usize>>> {
    let mut groups: std::collections::BTreeMap<String, Vec<usize>> = std::collections::BTreeMap::new();
    for (index, slice) in slices.iter().enumerate() {
        let key = serde_json::to_string(&slice.of).map_err(|e| Error::invalid(&slice.name, e.to_string()))?;
        groups.entry(key).or_default().push(index);
    }
    Ok(groups)
}

/// A lattice node (the bits of its `mu` and `alpha`) and the (slice, node number) pairs that hold it.
type NodeUsers = ((u64, u64), Vec<(usize, usize)>);

/// Every node of `slices` integrated, each distinct lattice node of a group once for all the
/// slices that hold it.
fn integrate_tables(slices: &[&Slices], seed: u64, progress: &dyn Progress) -> Result<BatchTables> {
    let mut tables: Vec<Table> = slices.iter().map(|s| s.empty_table()).collect::<Result<_>>()?;
    let mut standard_errors: Vec<Vec<f64>> = tables.iter().map(|t| vec![0.0; t.data.len()]).collect();
    let mut records: Vec<Option<super::driver::SamplingRecord>> = vec![None; slices.len()];
    for members in settings_groups(slices)?.values() {
        let first = slices[members[0]];
        let points = NodePoints::new(super::driver::table_points(&first.sampling(), seed)?)?;
        // Each node of the group once, with the (slice, node number) pairs that hold it.
        let mut nodes: std::collections::BTreeMap<(u64, u64), Vec<(usize, usize)>> = std::collections::BTreeMap::new();
        for &s in members {
            let (mu, alpha, [mu_lattice, alpha_lattice]) = (&slices[s].mu, &slices[s].alpha, slices[s].of.lattice());
            for j in 0..alpha.count {
                for i in 0..mu.count {
                    let key = (
                        canonical_node(mu, i, mu_lattice).to_bits(),
                        canonical_node(alpha, j, alpha_lattice).to_bits(),
                    );
                    nodes.entry(key).or_default().push((s, j * mu.count + i));
                }
            }
        }
        let nodes: Vec<NodeUsers> = nodes.into_iter().collect();
        let projections: Vec<Vec<Projection>> = members.iter().map(|&s| slices[s].projections()).collect();
        let member_of: std::collections::HashMap<usize, usize> =
            members.iter().enumerate().map(|(m, &s)| (s, m)).collect();
        let numbers: Vec<u64> = (0..nodes.len() as u64).collect();
        let label = format!("{} slices ({} nodes shared by {} slices)", first.table_name(), nodes.len(), members.len());
        // Each node's estimates for every slice that holds it, in one flat vector (per user its
        // means, then its standard errors): a library's millions of slice nodes are held at once
        // until they are stored, and two small vectors per node per slice would cost several
        // times the values.
        let per_node: Vec<Vec<f64>> = crate::integrate::estimate_cells(&numbers, &label, progress, |n| {
            let ((mu, alpha), users) = &nodes[n as usize];
            let user_slices: Vec<&Slices> = users.iter().map(|&(s, _)| slices[s]).collect();
            let shared = SharedNode::new(&first.of, f64::from_bits(*mu), f64::from_bits(*alpha), &user_slices, &points);
            users
                .iter()
                .flat_map(|&(s, _)| {
                    let estimate = slices[s].estimate_on(&shared, &projections[member_of[&s]]);
                    estimate.mean.into_iter().chain(estimate.standard_error)
                })
                .collect()
        });
        for ((_, users), flat) in nodes.iter().zip(per_node) {
            let mut rest = flat.as_slice();
            for &(s, node) in users {
                let channels = tables[s].channel_count();
                let (means, errors) = rest[..2 * channels].split_at(channels);
                let range = node * channels..(node + 1) * channels;
                // FGD and TIR are shares of energy: a fast-path FGD next to a critical angle may
                // overshoot [0, 1] (an L2 projection of a kink), which the 4D table clamps too.
                for (value, &mean) in tables[s].data[range.clone()].iter_mut().zip(means) {
                    *value = mean.clamp(0.0, 1.0) as f32;
                }
                standard_errors[s][range].copy_from_slice(errors);
                rest = &rest[2 * channels..];
            }
        }
        for &s in members {
            records[s] = Some(slices[s].sampling_record(&points.table));
        }
    }
    let records = records.into_iter().map(|r| r.expect("every slice is in a group")).collect();
    Ok(BatchTables { tables, standard_errors, records })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::table_points;

    #[test]
    fn tir_channels_in_any_order_equal_their_single_channel_values() {
        let settings = TirSettings::default();
        let axis = |name: &str| Axis::node_aligned(name, 0.25, 0.75, 3).unwrap();
        let slices = |etas: &[f64]| Slices {
            name: "tir_test".into(),
            of: SliceOf::Tir(settings.clone()),
            mu: axis("mu"),
            alpha: axis("alpha"),
            lookup_mu: [0.25, 0.75],
            lookup_alpha: [0.25, 0.75],
            channels: etas.iter().map(|&eta| SliceChannel { eta, kappa: 0.0, used_by: "test".into() }).collect(),
        };
        let points = NodePoints::new(table_points(&SamplingConfig::replicated(1 << 12), 3).unwrap()).unwrap();
        // Descending, as R, G, B of a coat whose index falls with wavelength.
        let both = slices(&[0.9, 0.6]).estimate_fast(&points, 0.5, 0.5, &[]);
        for (k, eta) in [0.9, 0.6].into_iter().enumerate() {
            let alone = slices(&[eta]).estimate_fast(&points, 0.5, 0.5, &[]);
            assert_eq!(both.mean[k], alone.mean[0], "eta {eta}");
        }
        assert!(both.mean[0] < both.mean[1], "a higher index loses less: {:?}", both.mean);
    }

    /// A slice on the lattice: `mu` over lattice nodes `mu_nodes`, `alpha` over `alpha_nodes` (in
    /// sqrt(alpha)), with the given channels.
    fn lattice_slices(
        name: &str,
        of: SliceOf,
        mu_nodes: [f64; 2],
        alpha_nodes: [f64; 2],
        channels: &[(f64, f64)],
    ) -> Slices {
        let axis = |name: &str, nodes: [f64; 2], mapping, lattice| {
            let [first, last] = nodes;
            Axis::node_aligned(
                name,
                lattice_value(mapping, first, lattice),
                lattice_value(mapping, last, lattice),
                (last - first) as usize + 1,
            )
            .unwrap()
            .with_mapping(mapping)
            .unwrap()
        };
        let [mu_lattice, alpha_lattice] = of.lattice();
        let mu = axis("mu", mu_nodes, crate::table::Mapping::Identity, mu_lattice);
        let alpha = axis("alpha", alpha_nodes, crate::table::Mapping::Sqrt, alpha_lattice);
        Slices {
            name: name.into(),
            of,
            lookup_mu: [mu.start, mu.end],
            lookup_alpha: [alpha.start, alpha.end],
            mu,
            alpha,
            channels: channels
                .iter()
                .map(|&(eta, kappa)| SliceChannel { eta, kappa, used_by: "test".into() })
                .collect(),
        }
    }

    #[test]
    fn a_slice_is_bit_identical_built_alone_or_in_a_batch_that_shares_its_nodes() {
        let mut fgd = FgdSettings::default();
        fgd.shared.sampling = SamplingConfig::replicated(1 << 10);
        fgd.shared.reference.cells = 0;
        let mut tir = TirSettings::default();
        tir.shared.sampling = SamplingConfig::replicated(1 << 10);
        tir.shared.reference.cells = 0;
        let (fgd, tir) = (SliceOf::Fgd(fgd), SliceOf::Tir(tir));
        let copper = [(0.27, 3.61), (0.68, 2.63), (1.22, 2.29)];
        // Lattice nodes: FGD's in 1/128, TIR's in 1/512 (mu) and 1/128 (sqrt(alpha)).
        let alone = [
            lattice_slices("fgd_a", fgd.clone(), [100.0, 110.0], [20.0, 21.0], &copper),
            lattice_slices("tir_a", tir.clone(), [400.0, 410.0], [30.0, 33.0], &[(0.66, 0.0)]),
        ];
        // Others overlapping their nodes, at other indices, and one of another kind in between.
        let others = [
            lattice_slices("fgd_b", fgd.clone(), [105.0, 120.0], [19.0, 22.0], &[(1.5, 0.0), (0.27, 3.61)]),
            lattice_slices("tir_b", tir.clone(), [405.0, 409.0], [31.0, 32.0], &[(0.9, 0.0), (0.5, 0.0), (0.66, 0.0)]),
            lattice_slices("fgd_c", fgd, [50.0, 52.0], [20.0, 21.0], &[(0.8, 0.0)]),
        ];
        let progress = ();
        for slice in &alone {
            let by_itself = integrate_batch(&[slice], 7, &progress).unwrap().remove(0);
            let mut batch: Vec<&Slices> = others.iter().collect();
            batch.insert(1, slice);
            let among_others = integrate_batch(&batch, 7, &progress).unwrap().remove(1);
            let bits = |t: &Table| t.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&by_itself.table), bits(&among_others.table), "{}", slice.name);
            // And through the driver, as `--slice-checks full` builds it.
            let driven = crate::recipes::driver::build(slice, 7, &progress).unwrap();
            assert_eq!(bits(&by_itself.table), bits(&driven.table), "{}", slice.name);
            assert!(by_itself.table.data.iter().all(|v| v.is_finite()), "{}", slice.name);
            assert!(by_itself.table.data.iter().any(|&v| v > 0.0), "{}", slice.name);
        }
    }

    #[test]
    fn an_fgd_slice_stores_no_overshoot_of_its_fast_path_below_0() {
        // A dielectric onto a barely rarer medium seen at grazing views: the fast path's L2
        // projection of Fresnel, whose kink lies at the critical cosine 0.0014, overshoots below 0.
        let mut settings = FgdSettings::default();
        settings.shared.sampling = SamplingConfig::replicated(1 << 10);
        settings.shared.reference.cells = 0;
        let slice = lattice_slices("fgd_grazing", SliceOf::Fgd(settings), [0.0, 2.0], [56.0, 60.0], &[(0.999999, 0.0)]);
        let (points, projections) =
            (NodePoints::new(table_points(&slice.sampling(), 7).unwrap()).unwrap(), slice.projections());
        let raw: Vec<f64> = slice
            .alpha
            .node_values()
            .into_iter()
            .flat_map(|alpha| slice.mu.node_values().into_iter().map(move |mu| (mu, alpha)))
            .map(|(mu, alpha)| slice.estimate_fast(&points, mu, alpha, &projections).mean[0])
            .collect();
        let lowest = raw.iter().copied().fold(f64::INFINITY, f64::min);
        eprintln!("the fast path's lowest estimate: {lowest:e}");
        assert!(lowest < 0.0, "no overshoot to clamp: {raw:?}");
        let built = integrate_batch(&[&slice], 7, &()).unwrap().remove(0);
        assert!(built.table.data.iter().all(|v| (0.0..=1.0).contains(v)), "{:?}", built.table.data);
    }

    #[test]
    fn a_tir_slice_value_is_the_exact_integral_whatever_shares_the_node() {
        let settings = TirSettings::default();
        let slices = |etas: &[f64]| Slices {
            name: "tir_test".into(),
            of: SliceOf::Tir(settings.clone()),
            mu: Axis::node_aligned("mu", 0.75, 1.0, 3).unwrap(),
            alpha: Axis::node_aligned("alpha", 0.5, 1.0, 3).unwrap(),
            lookup_mu: [0.75, 1.0],
            lookup_alpha: [0.5, 1.0],
            channels: etas.iter().map(|&eta| SliceChannel { eta, kappa: 0.0, used_by: "test".into() }).collect(),
        };
        let points = NodePoints::new(table_points(&settings.shared.sampling, 11).unwrap()).unwrap();
        let reference = VisibleNormalQuadrature::new(16).unwrap();
        // scattering-coat-00909's coat from below (eta 1 / 1.627) under a broad lobe, where 2^15
        // Monte Carlo samples left TIR 1.5e-3 off; and a smooth lobe seen past the critical angle.
        for (mu, alpha) in [(0.85, 0.8), (0.5, 0.01)] {
            let (coat, other) = (1.0 / 1.627, 0.95);
            let both = slices(&[coat, other]).estimate_fast(&points, mu, alpha, &[]);
            for (k, eta) in [coat, other].into_iter().enumerate() {
                let alone = slices(&[eta]).estimate_fast(&points, mu, alpha, &[]);
                assert_eq!(alone.mean[0].to_bits(), both.mean[k].to_bits(), "mu {mu} alpha {alpha} eta {eta}");
                assert_eq!(both.standard_error[k], 0.0, "deterministic");
                let exact = tir_by_quadrature(&reference, mu, alpha, eta);
                assert!(
                    (both.mean[k] - exact).abs() < 2e-5,
                    "mu {mu} alpha {alpha} eta {eta}: {} vs {exact}",
                    both.mean[k]
                );
            }
        }
    }
}
