//! Baking: a material's whole transfer-matrix result as a table of the view cosine.
//!
//! For one material every quantity the model returns (`TmResult`: the albedo, the top interface's
//! albedo, and per lobe its RGB energy, GGX roughness, mean-direction cosine and GD) depends on
//! the view cosine `mu` alone. Evaluated once at nodes of `mu` ([`bake_material`]) and stored as
//! rows of RGBA texels ([`layout`]), the model costs a shader a few filtered texel reads instead
//! of its matrices and table lookups. What the baking costs in accuracy is measured against the
//! model itself, read between the nodes exactly as a GPU filters them ([`errors`]). A material
//! whose textures vary parameters is baked at nodes of each, a block of rows per node
//! ([`varied`]).

pub mod array;
pub mod config;
pub mod errors;
pub mod layout;
pub mod placement;
pub mod varied;

use std::cell::RefCell;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::formats::baked::BakedAxis;
use crate::integrate::Progress;
use crate::model::{Lookup, Material, Tables};
pub use config::{BakeConfig, BakeSource, TABLES_REFERENCE, TABLES_SOURCE, measured_against_its_tables};
pub use errors::{BakedErrors, Worst, baked_errors};
pub use layout::BakeLayout;
pub use placement::NodePlacement;
pub use varied::{MaterialFamily, VariedParameter};

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

/// The error a baked material is held to, in tolerances: 1e-3 at the default tolerance, the
/// limit `tmlut check` holds a bake to unless a budget says otherwise.
pub const HELD_TO_TOLERANCES: f64 = 4.0;

impl BakeSettings {
    /// The error a baked material is held to: [`HELD_TO_TOLERANCES`] times the tolerance. A
    /// material whose textures vary parameters and which errs by more at the most nodes it may
    /// take is left out of a scene's bake (`scene::bake_files`).
    pub fn held_to(&self) -> f64 {
        HELD_TO_TOLERANCES * self.tolerance
    }
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

/// One material's baked rows: a block per combination of its varied parameters' nodes (one where
/// nothing varies; [`varied::block_values`] orders them), each of `layout.texels_per_node()` rows
/// of `placement.nodes()` RGBA texels, row `r` of a block holding values `4r..4r + 4` of every
/// node's [`BakeLayout::flatten`] (zeros past the last).
#[derive(Debug, Clone, PartialEq)]
pub struct BakedMaterial {
    pub name: String,
    pub layout: BakeLayout,
    /// Where the nodes sit along `mu`, the same in every block.
    pub placement: NodePlacement,
    /// The parameters its textures vary, with their nodes.
    pub axes: Vec<BakedAxis>,
    /// `rows() * nodes()` texels, node fastest: row `r`, node `k` is `texels[r * nodes() + k]`.
    pub texels: Vec<[f32; 4]>,
}

impl BakedMaterial {
    /// Rows of texels the material takes: its blocks' rows.
    pub fn rows(&self) -> usize {
        self.block_rows() * self.blocks()
    }

    /// Rows of one block: the texels of one node.
    pub fn block_rows(&self) -> usize {
        self.layout.texels_per_node()
    }

    /// Blocks of rows, one per combination of its varied parameters' nodes.
    pub fn blocks(&self) -> usize {
        self.axes.iter().map(|a| a.nodes as usize).product()
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

/// Bake `material` (named `name` in errors), which varies nothing: [`bake_family`].
pub fn bake_material(
    name: &str,
    material: &Material,
    tables: &(dyn Tables + Sync),
    settings: &BakeSettings,
) -> Result<BakedMaterial> {
    bake_family(name, &MaterialFamily::fixed(material), tables, settings)
}

/// Bake `family` (named `name` in errors), every integral read from `tables` (exact integrals, or
/// a built folder's tables): the nodes of its varied parameters chosen ([`varied::node_counts`]),
/// then its nodes along `mu` placed ([`placement::place_nodes`]) on the values of every block
/// together, so that one placement serves them all, then the model evaluated at each node of each
/// block, a point the placement has read already not read again. Where `tables` computes its
/// answers on demand, those the model will ask at a batch of points are computed ahead, together
/// ([`prepare`]). Refuses settings [`BakeSettings::check`] refuses, more than [`varied::MAX_VARIED`] varied
/// parameters, and a model that returns a value that is not finite (naming the material, the view
/// and the parameters' values: no NaN enters a baked texel) or, somewhere in its parameters'
/// ranges, another lobe count than at its own values.
pub fn bake_family(
    name: &str,
    family: &MaterialFamily,
    tables: &(dyn Tables + Sync),
    settings: &BakeSettings,
) -> Result<BakedMaterial> {
    settings.check()?;
    let nodes = settings.nodes;
    let parameters = family.parameters();
    if parameters.len() > varied::MAX_VARIED {
        return Err(Error::invalid(
            format!("material `{name}`"),
            format!(
                "its textures vary {} parameters; a baked material varies at most {}",
                parameters.len(),
                varied::MAX_VARIED
            ),
        ));
    }
    // The lobe count is the stack's and the flux model's, the same at every view; every block
    // must have the nominal material's.
    let layout = BakeLayout { lobes: family.nominal()?.evaluate(1.0, tables).lobes.len() };
    let counts = varied::node_counts(name, family, &layout, tables, settings)?;
    let axes = varied::axes(parameters, &counts);
    let blocks: Vec<(Vec<f64>, Material)> = varied::block_values(&axes)
        .into_iter()
        .map(|values| Ok((values.clone(), family.at(&values)?)))
        .collect::<Result<_>>()?;
    // A point of `u` reads every block: its values are theirs, one after the other.
    let read = |us: &[f64]| -> Result<Vec<Vec<f64>>> {
        let per_block = varied::read_points(name, parameters, &layout, &blocks, tables, us)?;
        Ok((0..us.len()).map(|k| per_block.iter().flat_map(|block| block[k].iter().copied()).collect()).collect())
    };
    let mut samples = placement::Samples::new(&read);
    let weights = |values: &[f64]| values.chunks(layout.values()).flat_map(|block| layout.weights(block)).collect();
    let placement = placement::place_nodes(&mut samples, &weights, nodes, settings.tolerance)?;
    let node_u: Vec<f64> = (0..nodes).map(|k| placement.node_u(k)).collect();
    let node_values = samples.at(&node_u)?;
    let rows = layout.texels_per_node();
    let mut texels = vec![[0.0f32; 4]; rows * blocks.len() * nodes];
    for (k, values) in node_values.iter().enumerate() {
        for (b, block) in values.chunks(layout.values()).enumerate() {
            for (i, &value) in block.iter().enumerate() {
                texels[(b * rows + i / 4) * nodes + k][i % 4] = value as f32;
            }
        }
    }
    Ok(BakedMaterial { name: name.to_string(), layout, placement, axes, texels })
}

/// [`bake_family`] for each of `materials` (name, material), side by side on the threads of the
/// pool, material `i` reading `tables_of(i)` (one set of exact integrals for all of them, so that
/// what one material has computed serves another that asks the same; or each material's own
/// tables), advancing `progress` by one per material. The first error refuses the whole bake.
pub fn bake_materials<'t>(
    materials: &[(&str, &MaterialFamily)],
    tables_of: impl Fn(usize) -> &'t (dyn Tables + Sync) + Sync,
    settings: &BakeSettings,
    progress: &dyn Progress,
) -> Result<Vec<BakedMaterial>> {
    (0..materials.len())
        .into_par_iter()
        .map(|i| {
            let (name, material) = materials[i];
            let baked = bake_family(name, material, tables_of(i), settings);
            progress.advance(1);
            baked
        })
        .collect()
}

/// The most passes [`prepare`] makes: each computes the lookups the one before made known, as
/// deep as the model's lookups depend on each other's answers.
const PREPARE_PASSES: usize = 8;

/// Have `tables` compute, together ([`Tables::prepare`]), the answers each of `materials` will
/// read at each view cosine of `mus`, where they are computed on demand ([`Tables::knows`]): a
/// pass evaluates the models at every point, answering what is not known yet by a stand-in, and
/// hands over the lookups asked whatever the stand-in ([`lookups_to_come`]); the next pass, with
/// those known, reaches the lookups that depend on them. What is left (a lookup whose parameters
/// the stand-ins moved) is computed when the model reads it.
pub(crate) fn prepare(materials: &[&Material], tables: &(dyn Tables + Sync), mus: &[f64]) {
    for _ in 0..PREPARE_PASSES {
        let missing: Vec<Lookup> = materials
            .iter()
            .flat_map(|&material| {
                mus.par_iter().flat_map_iter(|&mu| lookups_to_come(material, tables, mu)).collect::<Vec<_>>()
            })
            .collect();
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

#[cfg(test)]
pub(crate) mod tests;
