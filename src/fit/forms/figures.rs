//! The error figures of a form against the data ([`ErrorsByChannel`]: the RMS, 99th percentile and max
//! of each channel and of all together, weighted where the data is): the form evaluated in f32
//! with f32 parameters, as its shader computes it ([`residuals`]).

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::data::FormData;
use super::form::Form;
use super::prepared::CHUNK;
use crate::error::{Error, Result};

/// Error figures of one channel, or of all together.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorFigures {
    pub rms: f64,
    /// The 99th percentile of |error| (nearest rank).
    pub p99: f64,
    pub max: f64,
    /// Where the max is, by variable.
    pub max_at: BTreeMap<String, f64>,
    /// `max_at`'s channel (for the figures of all channels together).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_channel: Option<String>,
}

/// The figures of each channel and of all together.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorsByChannel {
    pub together: ErrorFigures,
    pub channels: BTreeMap<String, ErrorFigures>,
}

/// The form evaluated in f32 with f32 parameters (what its shader computes) against the data.
/// Refuses a value that is not finite, naming the point.
pub fn figures(form: &Form, data: &FormData, parameters: &[f64]) -> Result<ErrorsByChannel> {
    let errors = residuals(form, data, parameters)?;
    Ok(figures_of(data, &errors))
}

/// The residuals behind [`figures`], form minus table, point-major with one per channel. Refuses a
/// value that is not finite, naming the point.
pub fn residuals(form: &Form, data: &FormData, parameters: &[f64]) -> Result<Vec<f64>> {
    let p32: Vec<f32> = parameters.iter().map(|&v| v as f32).collect();
    let channels = data.channels.len();
    let errors: Vec<Vec<f64>> = (0..data.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let (mut scratch, mut out) = (Vec::new(), vec![0.0f32; channels]);
            let mut errors = Vec::new();
            for n in chunk * CHUNK..((chunk + 1) * CHUNK).min(data.len()) {
                let point: Vec<f32> = data.point(n).iter().map(|&v| v as f32).collect();
                form.tape.eval(&point, &p32, &mut scratch, &mut out);
                errors.extend(out.iter().zip(data.targets(n)).map(|(&v, &t)| f64::from(v) - t));
            }
            errors
        })
        .collect();
    let errors: Vec<f64> = errors.concat();
    if let Some(bad) = errors.iter().position(|e| !e.is_finite()) {
        let (n, c) = (bad / channels, bad % channels);
        return Err(Error::invalid(
            "fit",
            format!(
                "form `{}` is not finite in channel `{}` at {} with parameters {parameters:?}",
                form.name,
                data.channels[c],
                describe_point(&data.variables, data.point(n))
            ),
        ));
    }
    Ok(errors)
}

/// The figures of the residuals of [`residuals`], every point counting once.
pub(crate) fn figures_of(data: &FormData, errors: &[f64]) -> ErrorsByChannel {
    figure_set(errors, &data.channels, &data.variables, |n| data.point(n).to_vec(), |_| 1.0)
}

/// The figures of the residuals of [`residuals`] with the data's weights, where they are not
/// uniform: RMS `sqrt(sum w e^2 / sum w)`, the 99th percentile of the weighted distribution of
/// |e|, the max over the points of positive weight.
pub(super) fn weighted_figures_of(data: &FormData, errors: &[f64]) -> Option<ErrorsByChannel> {
    data.weighted
        .then(|| figure_set(errors, &data.channels, &data.variables, |n| data.point(n).to_vec(), |n| data.weights[n]))
}

/// The figures of `errors` (point-major, one per channel) per channel and together, point `n`
/// counting `weight(n)` (a point of weight 0 not at all); `point(n)` is point `n`'s coordinates in
/// `variables`. With weights of 1 these are the plain RMS, the nearest-rank 99th percentile and the
/// max.
pub(super) fn figure_set(
    errors: &[f64],
    channels: &[String],
    variables: &[String],
    point: impl Fn(usize) -> Vec<f64>,
    weight: impl Fn(usize) -> f64,
) -> ErrorsByChannel {
    let count = channels.len();
    let summarise = |selected: &dyn Fn(usize) -> bool, name_channel: bool| -> ErrorFigures {
        let mut abs: Vec<(f64, f64)> = Vec::new();
        let (mut sum, mut total, mut max, mut max_index) = (0.0, 0.0, -1.0, 0);
        for (k, &e) in errors.iter().enumerate().filter(|(k, _)| selected(*k)) {
            let w = weight(k / count);
            if w <= 0.0 {
                continue;
            }
            sum += w * e * e;
            total += w;
            abs.push((e.abs(), w));
            if e.abs() > max {
                max = e.abs();
                max_index = k;
            }
        }
        abs.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Nearest rank: the smallest |e| whose cumulative weight reaches 99 % of the total (with
        // weights of 1, the ceil(0.99 n)-th smallest).
        let target = 0.99 * total;
        let mut cumulative = 0.0;
        let p99 = abs
            .iter()
            .find(|(_, w)| {
                cumulative += w;
                cumulative >= target
            })
            .or(abs.last())
            .map_or(0.0, |a| a.0);
        ErrorFigures {
            rms: if total > 0.0 { (sum / total).sqrt() } else { 0.0 },
            p99,
            max: max.max(0.0),
            max_at: variables.iter().cloned().zip(point(max_index / count)).collect(),
            max_channel: name_channel.then(|| channels[max_index % count].clone()),
        }
    };
    ErrorsByChannel {
        together: summarise(&|_| true, true),
        channels: (0..count).map(|c| (channels[c].clone(), summarise(&|k| k % count == c, false))).collect(),
    }
}

fn describe_point(variables: &[String], point: &[f64]) -> String {
    let parts: Vec<String> = variables.iter().zip(point).map(|(v, x)| format!("{v} = {x}")).collect();
    format!("({})", parts.join(", "))
}
