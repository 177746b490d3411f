//! What baking costs: the baked values read as a GPU reads them (a linear filter between the two
//! nodes around `mu`, [`sample`]) against the model evaluated at that view, over views between
//! the nodes, where linear interpolation errs most.
//!
//! Lobe roughness, mean-direction cosine and GD matter in proportion to the energy of their lobe
//! (a lobe that carries nothing may have any roughness), so their differences are weighted by the
//! lobe's largest channel of energy; the albedo and the lobe energies are compared as they are.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::layout::ValueKind;
use super::{BakeLayout, BakedMaterial, NodePlacement};
use crate::filter::{Filter, lerp, linear_taps};
use crate::model::{Material, Tables};

/// The largest difference of one kind, with where it is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Worst {
    pub max: f64,
    /// The view cosine of the largest difference.
    pub at_mu: f64,
    /// The value it is of (`lobe 2 roughness`), in words.
    pub value: String,
}

impl Worst {
    fn none() -> Self {
        Worst { max: 0.0, at_mu: 1.0, value: String::new() }
    }

    fn take(&mut self, difference: f64, mu: f64, value: impl FnOnce() -> String) {
        if difference > self.max {
            *self = Worst { max: difference, at_mu: mu, value: value() };
        }
    }
}

/// A baked material's errors against its model, over `views` view cosines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedErrors {
    /// The albedo and the top albedo, per channel.
    pub albedo: Worst,
    /// Each lobe's energy, per channel.
    pub lobe_energy: Worst,
    /// Each lobe's roughness, weighted by the lobe's largest energy.
    pub lobe_roughness: Worst,
    /// Each lobe's mean-direction cosine, weighted by the lobe's largest energy.
    pub lobe_cos: Worst,
    /// Each lobe's GD, weighted by the lobe's largest energy.
    pub lobe_gd: Worst,
    /// View cosines compared.
    pub views: usize,
}

impl BakedErrors {
    /// The largest of the five (the first of equals).
    pub fn worst(&self) -> &Worst {
        [&self.lobe_gd, &self.lobe_cos, &self.lobe_roughness, &self.lobe_energy, &self.albedo]
            .into_iter()
            .max_by(|a, b| a.max.total_cmp(&b.max))
            .expect("five kinds")
    }

    /// The largest difference of the five.
    pub fn max(&self) -> f64 {
        self.worst().max
    }
}

/// The baked values of `baked` at view cosine `mu`, as a GPU's linear filter reads them from its
/// rows ([`texture_coordinate`], then the filter of `crate::filter`), in the layout's order.
pub fn sample(baked: &BakedMaterial, mu: f32, filter: Filter) -> Vec<f32> {
    let (lower, upper, weight) = linear_taps(baked.placement.texture_coordinate(mu), baked.nodes(), filter);
    let mut values: Vec<f32> = (0..baked.rows())
        .flat_map(|row| {
            let (a, b) = (baked.texel(row, lower), baked.texel(row, upper));
            (0..4).map(move |c| lerp(a[c], b[c], weight))
        })
        .collect();
    values.truncate(baked.layout.values());
    values
}

/// The view cosines the errors are measured at: `per_interval` views in each interval between
/// nodes, uniform in `sqrt(mu)` as the nodes are (the nodes themselves among them), from the
/// normal to grazing.
pub fn error_views(placement: &NodePlacement, per_interval: usize) -> Vec<f64> {
    let nodes = placement.nodes();
    let mut views: Vec<f64> = (0..nodes - 1)
        .flat_map(|k| {
            let (a, b) = (placement.node_u(k), placement.node_u(k + 1));
            (0..per_interval).map(move |j| a + (b - a) * j as f64 / per_interval as f64)
        })
        .chain(std::iter::once(1.0))
        .map(|u| u * u)
        .collect();
    views.reverse();
    views
}

/// The errors of `baked` against `material` evaluated with `tables` (the exact integrals, for
/// the error the bake adds to the model) at `per_interval` views per interval between nodes,
/// read through `filter`.
pub fn baked_errors(
    baked: &BakedMaterial,
    material: &Material,
    tables: &(dyn Tables + Sync),
    per_interval: usize,
    filter: Filter,
) -> BakedErrors {
    let views = error_views(&baked.placement, per_interval.max(1));
    let layout = baked.layout;
    let model: Vec<Vec<f64>> = views.par_iter().map(|&mu| layout.flatten(&material.evaluate(mu, tables))).collect();
    let mut errors = BakedErrors {
        albedo: Worst::none(),
        lobe_energy: Worst::none(),
        lobe_roughness: Worst::none(),
        lobe_cos: Worst::none(),
        lobe_gd: Worst::none(),
        views: views.len(),
    };
    for (&mu, exact) in views.iter().zip(&model) {
        let read = sample(baked, mu as f32, filter);
        compare(&layout, exact, &read, mu, &mut errors);
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
