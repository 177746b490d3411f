//! Baking: a material's whole transfer-matrix result as a table of the view cosine.
//!
//! For one material every quantity the model returns (`TmResult`: the albedo, the top interface's
//! albedo, and per lobe its RGB energy, GGX roughness, mean-direction cosine and GD) depends on
//! the view cosine `mu` alone. Evaluated once at nodes of `mu` ([`bake_material`]) and stored as
//! rows of RGBA texels ([`layout`]), the model costs a shader a few filtered texel reads instead
//! of its matrices and table lookups. What the baking costs in accuracy is measured against the
//! model itself, read between the nodes exactly as a GPU filters them ([`errors`]).

pub mod array;
pub mod errors;
pub mod layout;
pub mod placement;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::model::{Evaluation, Material, Tables};
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
/// the model evaluated at each. Refuses a node count outside [`NODES`] and a model that returns a
/// value that is not finite, naming the material and the view: no NaN enters a baked texel.
pub fn bake_material(
    name: &str,
    material: &Material,
    tables: &(dyn Tables + Sync),
    settings: &BakeSettings,
) -> Result<BakedMaterial> {
    let nodes = settings.nodes;
    if !NODES.contains(&nodes) {
        return Err(Error::invalid(
            "bake nodes",
            format!("{nodes} is not allowed: a bake has {} to {} nodes of mu", NODES.start(), NODES.end()),
        ));
    }
    // The lobe count is the stack's and the flux model's, the same at every view.
    let layout = BakeLayout { lobes: material.evaluate(1.0, tables).lobes.len() };
    let values = |u: f64| finite_values(name, &layout, &material.evaluate(u * u, tables));
    let weights = |values: &[f64]| layout.weights(values);
    let placement = placement::place_nodes(&values, &weights, nodes, settings.tolerance)?;
    let node_values: Vec<Vec<f64>> =
        (0..nodes).into_par_iter().map(|k| values(placement.node_u(k))).collect::<Result<_>>()?;
    let rows = layout.texels_per_node();
    let mut texels = vec![[0.0f32; 4]; rows * nodes];
    for (k, values) in node_values.iter().enumerate() {
        for (i, &value) in values.iter().enumerate() {
            texels[(i / 4) * nodes + k][i % 4] = value as f32;
        }
    }
    Ok(BakedMaterial { name: name.to_string(), layout, placement, texels })
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
