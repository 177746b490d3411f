//! What baking costs: the baked values read as a GPU reads them (a linear filter between the two
//! nodes around `mu`, [`sample`]) against the model evaluated at that view, over views between
//! the nodes, where linear interpolation errs most.
//!
//! Lobe roughness, mean-direction cosine and GD matter in proportion to the energy of their lobe
//! (a lobe that carries nothing may have any roughness), so their differences are weighted by the
//! lobe's largest channel of energy; the albedo and the lobe energies are compared as they are.

use rayon::prelude::*;

use super::layout::ValueKind;
use super::varied::error_values;
use super::{BakeLayout, BakedMaterial, MaterialFamily, NodePlacement, prepare};
use crate::error::Result;
use crate::filter::Filter;
use crate::formats::baked::{BakedAxis, BakedShape};
use crate::model::{Material, Tables};
pub use tmlut_loader::formats::baked::{BakedErrors, Worst};

/// The baked values of `baked` at view cosine `mu` and the values `varied` of its varied
/// parameters (those not given at their nominal values), as a GPU's linear filter reads them from
/// its rows ([`texture_coordinate`], then the filter of `crate::filter`), in the layout's order.
pub fn sample(baked: &BakedMaterial, mu: f32, varied: &[f32], filter: Filter) -> Vec<f32> {
    let segments = baked.placement.segment_maps();
    let shape = BakedShape {
        segments: &segments,
        axes: &baked.axes,
        nodes: baked.nodes(),
        rows: baked.block_rows(),
        values: baked.layout.values(),
    };
    tmlut_loader::formats::baked::sample(&shape, mu, varied, filter, |row, k| baked.texel(row, k))
}

/// The view cosines the errors are measured at: `per_interval` views in each interval between
/// nodes, uniform in `sqrt(mu)` as the nodes are (the nodes themselves among them), from the
/// normal to grazing; in the interval of a jump (`Segment::jump`) only its nodes, since the model
/// jumps somewhere between them and no texel row follows it there.
pub fn error_views(placement: &NodePlacement, per_interval: usize) -> Vec<f64> {
    let mut views: Vec<f64> = placement
        .segments()
        .iter()
        .flat_map(|s| {
            let per_interval = if s.jump { 1 } else { per_interval };
            (s.first_node..s.first_node + s.intervals).flat_map(move |k| {
                let (a, b) = (placement.node_u(k), placement.node_u(k + 1));
                (0..per_interval).map(move |j| a + (b - a) * j as f64 / per_interval as f64)
            })
        })
        .chain(std::iter::once(1.0))
        .map(|u| u * u)
        .collect();
    views.reverse();
    views
}

/// The errors of `baked` against `family` evaluated with `tables` (the exact integrals, for the
/// error the bake adds to the model) at `per_interval` views per interval between nodes, and at
/// the nodes of its varied parameters and midway between them, read through `filter`.
pub fn baked_errors(
    baked: &BakedMaterial,
    family: &MaterialFamily,
    tables: &(dyn Tables + Sync),
    per_interval: usize,
    filter: Filter,
) -> Result<BakedErrors> {
    let views = error_views(&baked.placement, per_interval.max(1));
    errors_across(&baked.layout, &baked.axes, &views, family, tables, |mu, varied| sample(baked, mu, varied, filter))
}

/// The errors of the baked values `read` returns at a view cosine and values of the varied
/// parameters of `axes` (a material of `layout`, read from memory or from its file) against
/// `family` evaluated with `tables`, at `views` and at every point of [`error_values`]: the largest
/// of each kind, with the parameters' values where it is.
pub fn errors_across(
    layout: &BakeLayout,
    axes: &[BakedAxis],
    views: &[f64],
    family: &MaterialFamily,
    tables: &(dyn Tables + Sync),
    read: impl Fn(f32, &[f32]) -> Vec<f32>,
) -> Result<BakedErrors> {
    let mut errors = BakedErrors::none("");
    for values in error_values(axes) {
        let material = family.at(&values)?;
        let at: Vec<f32> = values.iter().map(|&v| v as f32).collect();
        errors.fold(reading_errors(layout, views, &material, tables, |mu| read(mu, &at)), &values);
    }
    Ok(errors)
}

/// The errors of the baked values `read` returns at a view cosine (a material of `layout`, read
/// from memory or from its file) against `material` evaluated with `tables`, at `views`. Where
/// `tables` computes its answers on demand (exact integrals), those the model asks at the views
/// are computed ahead, together ([`prepare`]): a conductor's three channels in one pass over the
/// quadrature instead of three, the answers the same bits either way.
pub fn reading_errors(
    layout: &BakeLayout,
    views: &[f64],
    material: &Material,
    tables: &(dyn Tables + Sync),
    read: impl Fn(f32) -> Vec<f32>,
) -> BakedErrors {
    prepare(&[material], tables, views);
    let model: Vec<Vec<f64>> = views.par_iter().map(|&mu| layout.flatten(&material.evaluate(mu, tables))).collect();
    let mut errors = BakedErrors { views: views.len(), ..BakedErrors::none("") };
    for (&mu, exact) in views.iter().zip(&model) {
        compare(layout, exact, &read(mu as f32), mu, &mut errors);
    }
    errors
}

/// Fold the differences at one view into `errors`, each weighed as [`BakeLayout::weights`] says.
fn compare(layout: &BakeLayout, exact: &[f64], read: &[f32], mu: f64, errors: &mut BakedErrors) {
    let weights = layout.weights(exact);
    for (i, (&exact, &read)) in exact.iter().zip(read).enumerate() {
        let worst = match layout.kind(i) {
            ValueKind::Albedo => &mut errors.albedo,
            ValueKind::LobeEnergy => &mut errors.lobe_energy,
            ValueKind::LobeRoughness => &mut errors.lobe_roughness,
            ValueKind::LobeCos => &mut errors.lobe_cos,
            ValueKind::LobeGd => &mut errors.lobe_gd,
        };
        worst.take((f64::from(read) - exact).abs() * weights[i], mu, || layout.value_name(i));
    }
}
