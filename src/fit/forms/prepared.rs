//! The data as the search reads it ([`SearchData`]): the form's tape split so that what does not
//! depend on the parameters is computed once per point, and the objective the search minimises
//! (the weighted mean squared residual, with its gradient from the tape), summed over fixed chunks
//! of points (`CHUNK`) so that it is the same to the bit whatever the number of threads.

use rayon::prelude::*;

use super::batch::{Batch, LANES};
use super::data::FormData;
use super::form::Form;
use crate::error::{Error, Result};

/// Points per parallel work item: fixed, so that sums are added in the same order whatever the
/// number of threads.
pub(super) const CHUNK: usize = 4096;

/// The data as a search reads it: the form's tape split ([`crate::ir::tape::Tape::split`]) so that
/// everything that does not depend on the parameters is computed once per point, here.
pub struct SearchData<'a> {
    pub(super) data: &'a FormData,
    pub(super) tape: crate::ir::tape::Tape,
    /// Per input of the split tape (the variables, then the values of the split-off
    /// instructions), its value at every point: one column each, for [`Batch`] to read rows of.
    columns: Vec<f64>,
    width: usize,
}

impl<'a> SearchData<'a> {
    /// Refuse a form whose prepared data (every point's inputs of the split tape, held three
    /// times while they are gathered and transposed) this process has no memory for, naming the
    /// limit and its source.
    pub fn check_memory(form: &Form, data: &FormData) -> Result<()> {
        let (_, split_off) = form.tape.split(data.variables.len());
        let bytes = data.len() as u128 * (data.variables.len() + split_off.len()) as u128 * 24;
        let what = format!(
            "fitting it to {} points, the values of its {} parameter-free instructions at every point,",
            data.len(),
            split_off.len()
        );
        if let Some(words) = crate::memory::beyond_limit(bytes, &what) {
            return Err(Error::invalid(
                format!("form `{}`", form.name),
                format!("{words}: fit a region (--range) or share sub-expressions in [let]"),
            ));
        }
        Ok(())
    }

    pub fn new(form: &Form, data: &'a FormData) -> SearchData<'a> {
        let d = data.variables.len();
        let (tape, split_off) = form.tape.split(d);
        let width = d + split_off.len();
        // Split-off instructions do not read the parameters: any values serve.
        let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
        let count = data.len();
        let rows: Vec<Vec<f64>> = (0..count.div_ceil(CHUNK))
            .into_par_iter()
            .map(|chunk| {
                let mut values = Vec::new();
                let mut inputs = Vec::new();
                for n in chunk * CHUNK..((chunk + 1) * CHUNK).min(count) {
                    form.tape.values(data.point(n), &start, &mut values);
                    inputs.extend_from_slice(data.point(n));
                    inputs.extend(split_off.iter().map(|&k| values[k]));
                }
                inputs
            })
            .collect();
        let rows = rows.concat();
        let mut columns = vec![0.0; rows.len()];
        for (n, row) in rows.chunks_exact(width.max(1)).enumerate() {
            for (k, &v) in row.iter().enumerate() {
                columns[k * count + n] = v;
            }
        }
        SearchData { data, tape, columns, width }
    }

    /// Point `n`'s inputs of the split tape, into `point`.
    pub(super) fn point_into(&self, n: usize, point: &mut Vec<f64>) {
        let count = self.data.len();
        point.clear();
        point.extend((0..self.width).map(|k| self.columns[k * count + n]));
    }

    /// The weighted mean squared residual over every point and channel, `sum_n w_n sum_c r_nc^2 /
    /// (points x channels)` with the weights' mean 1 ([`FormData::weights`]), and its gradient when
    /// asked for:
    /// [`LANES`] points at a time ([`Batch`]), the sums of fixed chunks of points added in order,
    /// so the result is the same to the bit whatever the number of threads (and the same as
    /// [`crate::ir::tape::Tape::forward`] and [`crate::ir::tape::Tape::backward`] point by point give).
    pub fn objective(&self, parameters: &[f64], gradient: Option<&mut [f64]>) -> f64 {
        let (data, tape) = (self.data, &self.tape);
        let (count, p) = (data.len(), parameters.len());
        let channels = data.channels.len();
        let want = gradient.is_some();
        let per_chunk: Vec<(f64, Vec<f64>)> = (0..count.div_ceil(CHUNK))
            .into_par_iter()
            .map_init(Batch::default, |batch, chunk| {
                let (mut sum, mut g) = (0.0, vec![0.0; if want { p } else { 0 }]);
                let end = ((chunk + 1) * CHUNK).min(count);
                for first in (chunk * CHUNK..end).step_by(LANES) {
                    let len = LANES.min(end - first);
                    batch.forward(tape, |k| &self.columns[k * count + first..], parameters, len);
                    if want {
                        batch.clear_adjoints(tape);
                    }
                    for l in 0..len {
                        // Weights of 1 leave every product's bits as they were unweighted.
                        let w = data.weights[first + l];
                        for (&k, &t) in tape.outputs.iter().zip(data.targets(first + l)) {
                            let r = batch.value(k, l) - t;
                            sum += w * r * r;
                            if want {
                                batch.seed(k, l, 2.0 * w * r);
                            }
                        }
                    }
                    if want {
                        batch.backward(tape, &mut g);
                    }
                }
                (sum, g)
            })
            .collect();
        let scale = 1.0 / (count * channels).max(1) as f64;
        let mut sum = 0.0;
        let mut g_sum = vec![0.0; p];
        for (s, g) in &per_chunk {
            sum += s;
            for (a, b) in g_sum.iter_mut().zip(g) {
                *a += b;
            }
        }
        if let Some(gradient) = gradient {
            for (g, s) in gradient.iter_mut().zip(&g_sum) {
                *g = s * scale;
            }
        }
        let mse = sum * scale;
        if mse.is_finite() { mse } else { f64::NAN }
    }
}
