//! Which parameters the data leaves ill-determined at the optimum ([`Identifiability`]): the
//! eigenvalues and eigenvectors of `J^T W J` ([`crate::integrate::measure::symmetric_eigen`]),
//! `J` the Jacobian of the residuals with each column scaled by its parameter's bound range; and
//! the parameters at a bound.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::form::Form;
use super::prepared::{CHUNK, SearchData};
use crate::integrate::measure::symmetric_eigen;
use crate::ir::tape::EvaluationBuffers;

/// What the data leaves undetermined at the optimum, from the Jacobian `J` of the residuals with
/// respect to the parameters, each column scaled by its parameter's bound range (so that a unit
/// step is "the whole allowed range" for every parameter).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    /// Singular values of the scaled `J / sqrt(points x channels)`, largest first: the RMS change
    /// of the residuals per unit step along each principal direction.
    pub singular_values: Vec<f64>,
    /// Directions whose singular value is below [`ILL_DETERMINED_RATIO`] of the largest: moving
    /// along them changes the fit by almost nothing. Each lists the parameters that make up most
    /// of it (|component| >= 0.1) and the direction itself, in parameter order.
    pub ill_determined: Vec<WeakDirection>,
    /// The parameters the ill-determined directions are made of: those whose projection onto the
    /// space they span is at least 0.1 long. Where two directions are about equally weak, the
    /// directions themselves are any basis of that space; this list is not.
    pub ill_determined_parameters: Vec<String>,
    /// Parameters whose fitted value is at a bound (within 1e-9 of its range).
    pub at_bounds: Vec<String>,
    pub rule: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeakDirection {
    pub parameters: Vec<String>,
    pub singular_value_ratio: f64,
    pub direction: Vec<f64>,
}

/// A direction of parameter space is ill-determined when its singular value is below this share
/// of the largest: along it a step over the whole bound range moves the residuals' RMS by less
/// than a thousandth of what the best-determined direction does.
pub const ILL_DETERMINED_RATIO: f64 = 1e-3;

pub fn identifiability(form: &Form, prepared: &SearchData, parameters: &[f64]) -> Identifiability {
    let (data, tape) = (prepared.data, &prepared.tape);
    let p = parameters.len();
    let channels = data.channels.len();
    let scale: Vec<f64> = form.parameters.iter().map(|q| q.max - q.min).collect();
    // J^T J, summed in fixed chunks in order: each chunk's rows of J (scaled by the bound ranges)
    // and of W J, then one matrix product (matrixmultiply's blocked GEMM; a rank-one update per
    // row took the time of the whole fit at 100 parameters).
    let per_chunk: Vec<Vec<f64>> = (0..data.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut work = EvaluationBuffers::default();
            let points = chunk * CHUNK..((chunk + 1) * CHUNK).min(data.len());
            let rows = points.len() * channels;
            let mut jacobian = vec![0.0; rows * p];
            let mut weighted = vec![0.0; rows * p];
            let mut seeds = vec![0.0; channels];
            let mut point = Vec::new();
            for (r, n) in points.clone().flat_map(|n| std::iter::repeat_n(n, channels)).enumerate() {
                let c = r % channels;
                if c == 0 {
                    prepared.point_into(n, &mut point);
                    tape.forward(&point, parameters, &mut work);
                }
                seeds.iter_mut().enumerate().for_each(|(k, s)| *s = if k == c { 1.0 } else { 0.0 });
                let row = &mut jacobian[r * p..(r + 1) * p];
                tape.backward(&mut work, &seeds, row);
                // The weighted least squares' Jacobian is sqrt(w) J: J^T W J.
                for (i, (x, y)) in row.iter_mut().zip(&mut weighted[r * p..(r + 1) * p]).enumerate() {
                    *x *= scale[i];
                    *y = *x * data.weights[n];
                }
            }
            let mut jtj = vec![0.0; p * p];
            // SAFETY: `jacobian` and `weighted` hold `rows x p` row-major elements, `jtj` `p x p`,
            // as the dimensions and strides passed state; the output does not alias the inputs.
            unsafe {
                matrixmultiply::dgemm(
                    p,
                    rows,
                    p,
                    1.0,
                    jacobian.as_ptr(),
                    1,
                    p as isize,
                    weighted.as_ptr(),
                    p as isize,
                    1,
                    0.0,
                    jtj.as_mut_ptr(),
                    p as isize,
                    1,
                );
            }
            jtj
        })
        .collect();
    let rows = (data.len() * channels).max(1) as f64;
    let mut jtj = vec![0.0; p * p];
    for part in &per_chunk {
        for (a, b) in jtj.iter_mut().zip(part) {
            *a += b / rows;
        }
    }
    let (eigenvalues, vectors) = symmetric_eigen(&jtj, p);
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by(|&a, &b| eigenvalues[b].total_cmp(&eigenvalues[a]));
    let singular: Vec<f64> = order.iter().map(|&k| eigenvalues[k].max(0.0).sqrt()).collect();
    let largest = singular.first().copied().unwrap_or(0.0);
    let names = form.parameter_names();
    let ill_determined: Vec<WeakDirection> = order
        .iter()
        .zip(&singular)
        .filter(|(_, s)| **s <= ILL_DETERMINED_RATIO * largest)
        .map(|(&k, &s)| {
            let direction: Vec<f64> = (0..p).map(|i| vectors[i * p + k]).collect();
            WeakDirection {
                parameters: (0..p).filter(|&i| direction[i].abs() >= 0.1).map(|i| names[i].clone()).collect(),
                singular_value_ratio: if largest > 0.0 { s / largest } else { 0.0 },
                direction,
            }
        })
        .collect();
    let ill_determined_parameters = (0..p)
        .filter(|&i| {
            let projection: f64 = ill_determined.iter().map(|w: &WeakDirection| w.direction[i].powi(2)).sum();
            projection >= 0.01
        })
        .map(|i| names[i].clone())
        .collect();
    let at_bounds = form
        .parameters
        .iter()
        .zip(parameters)
        .filter(|(q, v)| (**v - q.min).abs() <= 1e-9 * (q.max - q.min) || (q.max - **v).abs() <= 1e-9 * (q.max - q.min))
        .map(|(q, _)| q.name.clone())
        .collect();
    Identifiability {
        singular_values: singular,
        ill_determined,
        ill_determined_parameters,
        at_bounds,
        rule: format!(
            "columns of the Jacobian scaled by each parameter's bound range; a direction is ill-determined when its singular value is below {ILL_DETERMINED_RATIO} of the largest"
        ),
    }
}
