//! The parameters a material's textures vary, as axes of its baked table.
//!
//! Where a scene lets a texture vary a parameter over a range (`vary`), the material has no one
//! curve along `mu`: it is baked at nodes of the parameter across the range, one block of its rows
//! per node, and a read blends the blocks of the two nodes around the texture's value. The nodes
//! are uniform across the range, as few as keep linear interpolation between them within the
//! bake's tolerance ([`node_counts`]): from the range's two ends, the nodes of the parameter whose
//! midpoints err most are doubled (a new node midway in each interval) until every parameter's
//! midpoints are within the tolerance, or it has [`MAX_PARAMETER_NODES`], or the material
//! [`MAX_BLOCKS`].

use rayon::prelude::*;

use super::{BakeLayout, BakeSettings, prepare};
use crate::error::{Error, Result};
use crate::formats::baked::BakedAxis;
use crate::model::{Evaluation, Material, Tables};

/// The most parameters a baked material varies: each doubles its texture reads.
pub const MAX_VARIED: usize = 2;
/// The most nodes across one parameter's range: 32 intervals, its range halved five times.
pub const MAX_PARAMETER_NODES: u32 = 33;
/// The most blocks of rows one material takes (the product of its parameters' nodes).
pub const MAX_BLOCKS: u32 = 64;

/// A parameter a material's textures vary, as the bake takes it.
#[derive(Debug, Clone, PartialEq)]
pub struct VariedParameter {
    /// In words: `layer 1 alpha` (layers counted from 1 at the top).
    pub name: String,
    /// The range a texture varies it over, `[lo, hi]`, `lo < hi`.
    pub range: [f64; 2],
    /// The material's own value, read where a caller gives none.
    pub nominal: f64,
}

/// The material whose model `at` returns at given values of its varied parameters.
pub type MaterialAt<'a> = dyn Fn(&[f64]) -> Result<Material> + Send + Sync + 'a;

/// What a bake evaluates: a material's model at each value of the parameters its textures vary
/// (none, for a material that varies nothing).
pub struct MaterialFamily<'a> {
    parameters: Vec<VariedParameter>,
    at: Box<MaterialAt<'a>>,
}

impl<'a> MaterialFamily<'a> {
    /// A material that varies nothing.
    pub fn fixed(material: &'a Material) -> Self {
        MaterialFamily { parameters: Vec::new(), at: Box::new(move |_| Ok(material.clone())) }
    }

    /// The material `at(values)` returns, `values` one per parameter of `parameters`.
    pub fn varied(parameters: Vec<VariedParameter>, at: Box<MaterialAt<'a>>) -> Self {
        MaterialFamily { parameters, at }
    }

    pub fn parameters(&self) -> &[VariedParameter] {
        &self.parameters
    }

    /// The material at `values` of its parameters, in order.
    pub fn at(&self, values: &[f64]) -> Result<Material> {
        (self.at)(values)
    }

    /// The material at its parameters' own values.
    pub fn nominal(&self) -> Result<Material> {
        self.at(&self.nominal_values())
    }

    pub fn nominal_values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }
}

/// The parameters' values in words, for messages: `layer 1 alpha = 0.25, layer 2 eta = 1.5`.
pub fn values_in_words(parameters: &[VariedParameter], values: &[f64]) -> String {
    parameters.iter().zip(values).map(|(p, v)| format!("{} = {v}", p.name)).collect::<Vec<_>>().join(", ")
}

/// The values of every block, in storage order: each combination of the axes' nodes, the first
/// axis's fastest.
pub fn block_values(axes: &[BakedAxis]) -> Vec<Vec<f64>> {
    grid(axes, |axis| (0..axis.nodes as usize).map(|j| axis.node(j)).collect())
}

/// The parameter values a baked material's error is measured at: each combination of every axis's
/// nodes and the midpoints between them (where linear interpolation errs most), the first axis's
/// fastest; one point of no values where nothing varies.
pub fn error_values(axes: &[BakedAxis]) -> Vec<Vec<f64>> {
    grid(axes, |axis| {
        let nodes = axis.nodes as usize;
        (0..2 * nodes - 1)
            .map(|i| match i % 2 {
                0 => axis.node(i / 2),
                _ => 0.5 * (axis.node(i / 2) + axis.node(i / 2 + 1)),
            })
            .collect()
    })
}

/// Every combination of the values `along` gives each axis, the first axis's fastest.
fn grid(axes: &[BakedAxis], along: impl Fn(&BakedAxis) -> Vec<f64>) -> Vec<Vec<f64>> {
    axes.iter().fold(vec![Vec::new()], |points, axis| {
        along(axis)
            .into_iter()
            .flat_map(|value| {
                points.iter().map(move |p| {
                    let mut p = p.clone();
                    p.push(value);
                    p
                })
            })
            .collect()
    })
}

/// The flattened values of each of `materials` (each with its parameter values, for messages) at
/// each `u = sqrt(mu)` of `us`, the lookups of all computed ahead together ([`prepare`]); refused
/// where one is not finite or a material returns other than `layout`'s lobes.
pub fn read_points(
    name: &str,
    parameters: &[VariedParameter],
    layout: &BakeLayout,
    materials: &[(Vec<f64>, Material)],
    tables: &(dyn Tables + Sync),
    us: &[f64],
) -> Result<Vec<Vec<Vec<f64>>>> {
    let models: Vec<&Material> = materials.iter().map(|(_, m)| m).collect();
    prepare(&models, tables, &us.iter().map(|u| u * u).collect::<Vec<_>>());
    materials
        .iter()
        .map(|(values, material)| {
            us.par_iter()
                .map(|&u| {
                    let evaluation = material.evaluate(u * u, tables);
                    finite_values(name, layout, &evaluation, &values_in_words(parameters, values))
                })
                .collect()
        })
        .collect()
}

/// An evaluation's values in `layout`'s order, refused where one is not finite (naming the
/// material, the value, the view and `where_`, the varied parameters' values, where any) or where
/// the evaluation has other than the layout's lobes: no NaN enters a baked texel, and one table
/// holds one lobe count.
pub fn finite_values(name: &str, layout: &BakeLayout, evaluation: &Evaluation, where_: &str) -> Result<Vec<f64>> {
    let at = if where_.is_empty() { String::new() } else { format!(" ({where_})") };
    if evaluation.lobes.len() != layout.lobes {
        return Err(Error::invalid(
            format!("material `{name}`"),
            format!(
                "its model returns {} lobes{at} and {} at its own values: one baked table holds one lobe count; \
                 narrow the range its textures vary",
                evaluation.lobes.len(),
                layout.lobes
            ),
        ));
    }
    let values = layout.flatten(evaluation);
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(values),
        Some(i) => Err(Error::invalid(
            format!("material `{name}`"),
            format!(
                "its model returns {} for {} at the view cosine mu = {}{at}: nothing is baked",
                values[i],
                layout.value_name(i),
                evaluation.mu
            ),
        )),
    }
}

/// The nodes of each of `family`'s parameters: 2 (the range's ends), then, while a parameter's
/// linear interpolation errs by more than `settings.tolerance` midway between its nodes (at the
/// uniform nodes of `u`, the other parameters at their nodes), the one that errs most gets a node
/// midway in each interval, up to [`MAX_PARAMETER_NODES`] and [`MAX_BLOCKS`] in all. What error is
/// left at the cap is measured with the rest of the bake's.
pub fn node_counts(
    name: &str,
    family: &MaterialFamily,
    layout: &BakeLayout,
    tables: &(dyn Tables + Sync),
    settings: &BakeSettings,
) -> Result<Vec<u32>> {
    let parameters = family.parameters();
    let mut counts = vec![2u32; parameters.len()];
    if parameters.is_empty() {
        return Ok(counts);
    }
    let us: Vec<f64> = (0..settings.nodes).map(|k| k as f64 / (settings.nodes - 1) as f64).collect();
    loop {
        let axes: Vec<BakedAxis> = axes(parameters, &counts);
        let errors: Vec<f64> = (0..axes.len())
            .map(|a| midpoint_error(name, family, layout, tables, &axes, a, &us))
            .collect::<Result<_>>()?;
        let blocks: u32 = counts.iter().product();
        let refinable = |a: usize| {
            let more = 2 * counts[a] - 1;
            more <= MAX_PARAMETER_NODES && blocks / counts[a] * more <= MAX_BLOCKS
        };
        let worst = (0..axes.len())
            .filter(|&a| errors[a] > settings.tolerance && refinable(a))
            .max_by(|&a, &b| errors[a].total_cmp(&errors[b]).then(b.cmp(&a)));
        match worst {
            Some(a) => counts[a] = 2 * counts[a] - 1,
            None => return Ok(counts),
        }
    }
}

/// The axes of `parameters` with `counts` nodes each.
pub fn axes(parameters: &[VariedParameter], counts: &[u32]) -> Vec<BakedAxis> {
    parameters.iter().zip(counts).map(|(p, &n)| BakedAxis::uniform(&p.name, p.range, p.nominal, n)).collect()
}

/// The largest weighed difference, at the views `u = sqrt(mu)` of `us`, between the model midway
/// between two nodes of axis `a` and the mean of the model at those nodes, every other axis at each
/// of its nodes.
fn midpoint_error(
    name: &str,
    family: &MaterialFamily,
    layout: &BakeLayout,
    tables: &(dyn Tables + Sync),
    axes: &[BakedAxis],
    a: usize,
    us: &[f64],
) -> Result<f64> {
    // Each node of the others, with the axis's nodes and midpoints: (node, midpoint, node) runs.
    let mut refined = axes.to_vec();
    refined[a] = BakedAxis { nodes: 2 * axes[a].nodes - 1, ..axes[a].clone() };
    let values: Vec<Vec<f64>> = block_values(&refined);
    let materials: Vec<(Vec<f64>, Material)> =
        values.iter().map(|v| Ok((v.clone(), family.at(v)?))).collect::<Result<_>>()?;
    let read = read_points(name, family.parameters(), layout, &materials, tables, us)?;
    // Block index of each point in `refined`: stepping axis `a` by one is a stride of the nodes of
    // the axes before it.
    let stride: usize = refined[..a].iter().map(|x| x.nodes as usize).product();
    let mut worst = 0.0f64;
    for i in 0..values.len() {
        // A node of axis `a` (even in the refined count): nothing to compare.
        if ((i / stride) % refined[a].nodes as usize).is_multiple_of(2) {
            continue;
        }
        let (below, mid, above) = (&read[i - stride], &read[i], &read[i + stride]);
        for k in 0..us.len() {
            let weights = layout.weights(&mid[k]);
            for (c, weight) in weights.iter().enumerate() {
                let linear = 0.5 * (below[k][c] + above[k][c]);
                worst = worst.max((mid[k][c] - linear).abs() * weight);
            }
        }
    }
    Ok(worst)
}
