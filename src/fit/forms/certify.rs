//! The fitted form certified against exact integrals ([`Certified`]): its error at the random
//! points of the table's interpolation check, per check domain, beside the table's own
//! interpolation error at the same points.

use serde::{Deserialize, Serialize};

use super::figures::{ErrorsByChannel, figure_set};
use super::form::Form;
use super::region::Region;
use crate::error::{Error, Result};
use crate::recipes::interpolation::ExactValues;
use crate::table::Table;

/// The form's error against exact integrals at random points of one of the table's check domains
/// (the points of its build's interpolation check, [`crate::recipes::interpolation`]: uniform
/// over the domain's lookup parameters, each integrated on its own by the deterministic
/// visible-normal quadrature), beside the table's own interpolation error at the same points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Certified {
    pub domain: String,
    pub points: usize,
    /// Gauss–Legendre nodes per panel of each exact value.
    pub exact_nodes: usize,
    /// The fitted form, in f32, against the exact values.
    pub form: ErrorsByChannel,
    /// The form at its start values.
    pub form_at_start: ErrorsByChannel,
    /// The table, interpolated multilinearly in its axes (`Table::interpolate`, f64 arithmetic on
    /// its stored values), against the same exact values.
    pub table: ErrorsByChannel,
    /// With `--weights` other than uniform: the fitted form's figures with each point weighted
    /// as the fit weighs it ([`Region::weight`] at the point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub form_weighted: Option<ErrorsByChannel>,
    /// The table's, weighted the same.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table_weighted: Option<ErrorsByChannel>,
}

/// [`Certified`] for every domain of `exact` (the exact integrals at random points of the table's
/// domains: [`crate::recipes::interpolation::exact_values_of`] for a full table, where a scene's
/// lookups are made for a slice), over the points of each that lie in `region`'s ranges (a domain
/// with none is left out).
pub fn certify(
    form: &Form,
    table: &Table,
    exact_values: &[ExactValues],
    (start, fitted): (&[f64], &[f64]),
    region: &Region,
) -> Result<Vec<Certified>> {
    let channel_index: Vec<usize> =
        form.channels.iter().map(|c| table.channels.iter().position(|t| t.name == c.name).unwrap_or(0)).collect();
    let channels: Vec<String> = form.channels.iter().map(|c| c.name.clone()).collect();
    let mut out = Vec::new();
    for exact in exact_values {
        // The form's variables from the domain's lookup parameters, by name.
        let Some(order) = form
            .variables
            .iter()
            .map(|v| exact.domain.parameters.iter().position(|p| p == v))
            .collect::<Option<Vec<usize>>>()
        else {
            continue;
        };
        let lookup_point = |n: usize| order.iter().map(|&k| exact.lookups[n][k]).collect::<Vec<f64>>();
        // The domain's points inside the ranges, in order.
        let kept: Vec<usize> = (0..exact.exact.len()).filter(|&n| region.contains(&lookup_point(n))).collect();
        if kept.is_empty() {
            continue;
        }
        let point = |m: usize| lookup_point(kept[m]);
        let form_errors = |parameters: &[f64]| -> Vec<f64> {
            let p32: Vec<f32> = parameters.iter().map(|&v| v as f32).collect();
            let (mut scratch, mut values) = (Vec::new(), vec![0.0f32; channels.len()]);
            let mut errors = Vec::new();
            for (m, &n) in kept.iter().enumerate() {
                let x: Vec<f32> = point(m).iter().map(|&v| v as f32).collect();
                form.tape.eval(&x, &p32, &mut scratch, &mut values);
                errors.extend(channel_index.iter().zip(&values).map(|(&c, &v)| f64::from(v) - exact.exact[n][c]));
            }
            errors
        };
        let mut table_errors = Vec::new();
        for &n in &kept {
            let (read, e) = (table.interpolate(&exact.positions[n]), &exact.exact[n]);
            table_errors.extend(channel_index.iter().map(|&c| read[c] - e[c]));
        }
        let (fitted_errors, start_errors) = (form_errors(fitted), form_errors(start));
        if fitted_errors.iter().chain(&start_errors).chain(&table_errors).any(|e| !e.is_finite()) {
            return Err(Error::invalid(
                "certify",
                format!("a value that is not finite in domain {}", exact.domain.describe()),
            ));
        }
        let set = |errors: &[f64]| figure_set(errors, &channels, &form.variables, point, |_| 1.0);
        let weighted = |errors: &[f64]| {
            region
                .is_weighted()
                .then(|| figure_set(errors, &channels, &form.variables, point, |m| region.weight(&point(m))))
        };
        out.push(Certified {
            domain: exact.domain.describe(),
            points: kept.len(),
            exact_nodes: exact.nodes,
            form: set(&fitted_errors),
            form_at_start: set(&start_errors),
            table: set(&table_errors),
            form_weighted: weighted(&fitted_errors),
            table_weighted: weighted(&table_errors),
        });
    }
    Ok(out)
}
