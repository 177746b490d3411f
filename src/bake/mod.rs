//! Baking: a material's whole transfer-matrix result as a table of the view cosine.
//!
//! For one material every quantity the model returns (`TmResult`: the albedo, the top interface's
//! albedo, and per lobe its RGB energy, GGX roughness, mean-direction cosine and GD) depends on
//! the view cosine `mu` alone. Evaluated once at nodes of `mu` ([`bake_material`]) and stored as
//! rows of RGBA texels ([`layout`]), the model costs a shader a few filtered texel reads instead
//! of its matrices and table lookups. What the baking costs in accuracy is measured against the
//! model itself, read between the nodes exactly as a GPU filters them ([`errors`]).

pub mod array;
pub mod config;
pub mod errors;
pub mod layout;
pub mod placement;

use std::cell::RefCell;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::integrate::Progress;
use crate::model::{Evaluation, Lookup, Material, Tables};
pub use config::{BakeConfig, BakeSource};
pub use errors::{BakedErrors, Worst, baked_errors};
pub use layout::BakeLayout;
pub use placement::NodePlacement;

/// How a material is baked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BakeSettings {
    /// Nodes along `mu` per material.
    pub nodes: usize,
    /// The interpolation error a kink of the model, or a segment's curvature, may be estimated
    /// to cause before the nodes are placed on the kink or the segment is cut
    /// ([`placement::place_nodes`]).
    pub tolerance: f64,
}

impl Default for BakeSettings {
    /// 64 nodes, and a tolerance of a quarter of the 1e-3 a baked material is held to: the
    /// example scenes' materials then stay within 1e-3 of their
    /// model (`the_example_materials_baked_by_default_stay_within_1e_3_of_their_model`).
    fn default() -> Self {
        BakeSettings { nodes: 64, tolerance: 2.5e-4 }
    }
}

impl BakeSettings {
    /// Refuses a node count outside [`NODES`] and a tolerance that is not a positive number.
    pub fn check(&self) -> Result<()> {
        if !NODES.contains(&self.nodes) {
            return Err(Error::invalid(
                "bake.nodes",
                format!("{} is not allowed: a bake has {} to {} nodes of mu", self.nodes, NODES.start(), NODES.end()),
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::invalid("bake.tolerance", format!("{}; allowed: a positive number", self.tolerance)));
        }
        Ok(())
    }
}

/// The most nodes a bake may have: beyond 8192 a row no longer fits the texture width every
/// WebGPU device supports. The fewest: one interval per segment for the most segments.
pub const NODES: std::ops::RangeInclusive<usize> = placement::MAX_BREAKS + 2..=8192;

/// One material's baked rows: `layout.texels_per_node()` rows of `placement.nodes()` RGBA texels
/// each, row `r` holding values `4r..4r + 4` of every node's [`BakeLayout::flatten`] (zeros past
/// the last).
#[derive(Debug, Clone, PartialEq)]
pub struct BakedMaterial {
    pub name: String,
    pub layout: BakeLayout,
    /// Where the nodes sit along `mu`.
    pub placement: NodePlacement,
    /// `rows() * nodes()` texels, node fastest: row `r`, node `k` is `texels[r * nodes() + k]`.
    pub texels: Vec<[f32; 4]>,
}

impl BakedMaterial {
    /// Rows of texels the material takes.
    pub fn rows(&self) -> usize {
        self.layout.texels_per_node()
    }

    /// Nodes along `mu`.
    pub fn nodes(&self) -> usize {
        self.placement.nodes()
    }

    /// The texel of row `row` at node `k`.
    pub fn texel(&self, row: usize, k: usize) -> [f32; 4] {
        self.texels[row * self.nodes() + k]
    }
}

/// Bake `material` (named `name` in errors), every integral read from `tables` (exact
/// integrals, or a built folder's tables): its nodes placed ([`placement::place_nodes`]), then
/// the model evaluated at each, a point the placement has read already not read again. Where
/// `tables` computes its answers on demand, those the model will ask at a batch of points are
/// computed ahead, together ([`prepare`]). Refuses settings [`BakeSettings::check`] refuses and a model that
/// returns a value that is not finite, naming the material and the view: no NaN enters a baked
/// texel.
pub fn bake_material(
    name: &str,
    material: &Material,
    tables: &(dyn Tables + Sync),
    settings: &BakeSettings,
) -> Result<BakedMaterial> {
    settings.check()?;
    let nodes = settings.nodes;
    // The lobe count is the stack's and the flux model's, the same at every view.
    let layout = BakeLayout { lobes: material.evaluate(1.0, tables).lobes.len() };
    let read = |us: &[f64]| -> Result<Vec<Vec<f64>>> {
        prepare(material, tables, us);
        us.par_iter().map(|&u| finite_values(name, &layout, &material.evaluate(u * u, tables))).collect()
    };
    let mut samples = placement::Samples::new(&read);
    let weights = |values: &[f64]| layout.weights(values);
    let placement = placement::place_nodes(&mut samples, &weights, nodes, settings.tolerance)?;
    let node_u: Vec<f64> = (0..nodes).map(|k| placement.node_u(k)).collect();
    let node_values = samples.at(&node_u)?;
    let rows = layout.texels_per_node();
    let mut texels = vec![[0.0f32; 4]; rows * nodes];
    for (k, values) in node_values.iter().enumerate() {
        for (i, &value) in values.iter().enumerate() {
            texels[(i / 4) * nodes + k][i % 4] = value as f32;
        }
    }
    Ok(BakedMaterial { name: name.to_string(), layout, placement, texels })
}

/// [`bake_material`] for each of `materials` (name, material), side by side on the threads of the
/// pool, material `i` reading `tables_of(i)` (one set of exact integrals for all of them, so that
/// what one material has computed serves another that asks the same; or each material's own
/// tables), advancing `progress` by one per material. The first error refuses the whole bake.
pub fn bake_materials<'t>(
    materials: &[(&str, &Material)],
    tables_of: impl Fn(usize) -> &'t (dyn Tables + Sync) + Sync,
    settings: &BakeSettings,
    progress: &dyn Progress,
) -> Result<Vec<BakedMaterial>> {
    (0..materials.len())
        .into_par_iter()
        .map(|i| {
            let (name, material) = materials[i];
            let baked = bake_material(name, material, tables_of(i), settings);
            progress.advance(1);
            baked
        })
        .collect()
}

/// The most passes [`prepare`] makes: each computes the lookups the one before made known, as
/// deep as the model's lookups depend on each other's answers.
const PREPARE_PASSES: usize = 8;

/// Have `tables` compute, together ([`Tables::prepare`]), the answers `material` will read at
/// `u = sqrt(mu)` of each of `us`, where they are computed on demand ([`Tables::knows`]): a
/// pass evaluates the model at every point, answering what is not known yet by a stand-in, and
/// hands over the lookups asked whatever the stand-in ([`lookups_to_come`]); the next pass, with
/// those known, reaches the lookups that depend on them. What is left (a lookup whose parameters
/// the stand-ins moved) is computed when the model reads it.
fn prepare(material: &Material, tables: &(dyn Tables + Sync), us: &[f64]) {
    for _ in 0..PREPARE_PASSES {
        let missing: Vec<Lookup> = us.par_iter().flat_map_iter(|&u| lookups_to_come(material, tables, u * u)).collect();
        if missing.is_empty() {
            return;
        }
        tables.prepare(&missing);
    }
}

/// The lookups `material` asks at `mu` that `tables` does not know yet and that it asks at the
/// same parameters whether an unknown answer reads as 0.25 or as 0.75: those whose parameters do
/// not depend on an answer still unknown.
fn lookups_to_come(material: &Material, tables: &dyn Tables, mu: f64) -> Vec<Lookup> {
    let asked = |stand_in: f64| {
        let recording = Unknown { tables, stand_in, asked: RefCell::new(Vec::new()) };
        material.evaluate(mu, &recording);
        recording.asked.into_inner()
    };
    let low = asked(0.25);
    if low.is_empty() {
        return low;
    }
    let high = asked(0.75);
    low.into_iter().filter(|l| high.contains(l)).collect()
}

/// `tables` where it knows the answer; elsewhere the lookup is noted and read as `stand_in`.
struct Unknown<'a> {
    tables: &'a dyn Tables,
    stand_in: f64,
    asked: RefCell<Vec<Lookup>>,
}

impl Tables for Unknown<'_> {
    fn value(&self, lookup: &Lookup) -> f64 {
        if self.tables.knows(lookup) {
            return self.tables.value(lookup);
        }
        self.asked.borrow_mut().push(*lookup);
        self.stand_in
    }
}

/// An evaluation's values in `layout`'s order, refused where one is not finite, naming the
/// material, the value and the view.
fn finite_values(name: &str, layout: &BakeLayout, evaluation: &Evaluation) -> Result<Vec<f64>> {
    let values = layout.flatten(evaluation);
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(values),
        Some(at) => Err(Error::invalid(
            format!("material `{name}`"),
            format!(
                "its model returns {} for {} at the view cosine mu = {}: nothing is baked",
                values[at],
                layout.value_name(at),
                evaluation.mu
            ),
        )),
    }
}

#[cfg(test)]
pub(crate) mod tests;
