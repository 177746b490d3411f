//! Fitting a form file to a table: the data (the table's nodes, or a uniform grid where an axis
//! is derived), the least-squares search (the same seeded multi-start L-BFGS as the built-in
//! forms, [`crate::fit::minimise`], with the gradient from the tape), the error figures per
//! channel and together, which parameters the data leaves ill-determined, and the files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::batch::{Batch, LANES};
use super::cost::{Cost, operations, timing};
use super::form::{Form, MAX_FORM_BYTES};
use super::pictures::{ERROR_MAP_FILE, RESIDUALS_FILE, write_pictures};
use super::region::{Range, Region, SceneLookups, WeightsSpec, variable_range};
use super::shader::{LANGUAGES, function_name, sources};
use crate::ir::tape::Work;
use crate::commit::{Move, OutputFolder, commit_set};
use crate::error::{Error, Result};
use crate::fit::{FIT_GRID_NODES, FitSettings, Minimum, minimise};
use crate::integrate::measure::symmetric_eigen;
use crate::recipes::interpolation::ExactValues;
use crate::table::Table;

/// The points a form is fitted and judged on: coordinates in the form's variables and the
/// table's values of the form's channels, both row-major.
#[derive(Debug, Clone)]
pub struct FormData {
    pub variables: Vec<String>,
    pub channels: Vec<String>,
    pub coordinates: Vec<f64>,
    pub values: Vec<f64>,
    /// How the points were chosen, for the report.
    pub description: String,
    /// Whether the points are the table's nodes (every axis a variable of the form); otherwise
    /// they are a uniform grid of [`FIT_GRID_NODES`] per variable, the first fastest.
    pub on_table_nodes: bool,
    /// Per point, its number among the table's nodes or the grid's points: the data keeps only
    /// the points inside the region's ranges ([`Region::contains`]).
    pub index: Vec<usize>,
    /// Per point, its weight ([`Region::weight`]) scaled so that the weights' mean is 1 (all 1
    /// for uniform weights, exactly).
    pub weights: Vec<f64>,
    /// Whether the weights are other than uniform.
    pub weighted: bool,
}

impl FormData {
    pub fn len(&self) -> usize {
        self.coordinates.len() / self.variables.len().max(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn point(&self, n: usize) -> &[f64] {
        let d = self.variables.len();
        &self.coordinates[n * d..(n + 1) * d]
    }

    fn targets(&self, n: usize) -> &[f64] {
        let c = self.channels.len();
        &self.values[n * c..(n + 1) * c]
    }

    /// The table's nodes where every axis is one of the form's variables; otherwise a uniform
    /// grid of [`FIT_GRID_NODES`] per variable over the table's ranges (`eta` over [0, 1]) with
    /// the table interpolated there, so that an axis whose nodes crowd where the table is steep
    /// (TIR's critical-angle axis) does not weight the fit there.
    pub fn from_table(table: &Table, form: &Form) -> Result<FormData> {
        FormData::from_table_in(table, form, &Region::everywhere())
    }

    /// [`FormData::from_table`] keeping the points inside `region`'s ranges, each weighted by it.
    pub fn from_table_in(table: &Table, form: &Form, region: &Region) -> Result<FormData> {
        let channel_index: Vec<usize> =
            form.channels.iter().map(|c| table.channels.iter().position(|t| t.name == c.name).unwrap_or(0)).collect();
        let d = form.variables.len();
        let mut coordinates = Vec::new();
        let mut values = Vec::new();
        let mut index_of_point = Vec::new();
        let plain = table.axes.iter().all(|a| form.variables.contains(&a.name));
        let description;
        if plain {
            // Axis k of the table is the form's variable order[k].
            let order: Vec<usize> =
                table.axes.iter().map(|a| form.variables.iter().position(|v| *v == a.name).unwrap_or(0)).collect();
            for n in 0..table.node_count() {
                let index = table.node_index(n);
                let position = table.node_position(&index);
                let mut point = vec![0.0; d];
                for (k, &v) in order.iter().enumerate() {
                    point[v] = position[k];
                }
                if !region.contains(&point) {
                    continue;
                }
                index_of_point.push(n);
                coordinates.extend(point);
                let node = table.node(&index);
                values.extend(channel_index.iter().map(|&c| f64::from(node[c])));
            }
            description = format!("the table's {} nodes", table.node_count());
        } else {
            let ranges: Vec<(f64, f64)> = form.variables.iter().map(|v| variable_range(table, v)).collect();
            let n = FIT_GRID_NODES;
            let total = n.pow(d as u32);
            let mut value = vec![0.0; table.channel_count()];
            for k in 0..total {
                let mut rest = k;
                let mut point = vec![0.0; d];
                for (p, &(lo, hi)) in point.iter_mut().zip(&ranges) {
                    *p = lo + (hi - lo) * (rest % n) as f64 / (n - 1) as f64;
                    rest /= n;
                }
                if !region.contains(&point) {
                    continue;
                }
                let get = |name: &str| form.variables.iter().position(|v| v == name).map_or(0.0, |i| point[i]);
                let at =
                    crate::table::derived::point_of(&table.axes, get("mu"), get("alpha"), get("eta"), get("kappa"))
                        .ok_or_else(|| {
                            Error::invalid(
                                "fit table",
                                format!("table `{}` has an axis no lookup addresses", table.name),
                            )
                        })?;
                table.interpolate_into(&at, &mut value).map_err(|e| Error::invalid("fit table", format!("{e:?}")))?;
                index_of_point.push(k);
                coordinates.extend(point);
                values.extend(channel_index.iter().map(|&c| value[c]));
            }
            description = format!(
                "a uniform grid of {n} points per variable ({total} in all) over the table's ranges (eta over [0, 1]), the table interpolated there"
            );
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid("fit table", format!("value {bad} of table `{}` is not finite", table.name)));
        }
        let count = index_of_point.len();
        if count == 0 {
            return Err(Error::invalid(
                "--range",
                format!("no point of the data ({description}) lies in {}", region.describe_ranges()),
            ));
        }
        let description = if region.ranges.is_empty() {
            description
        } else {
            format!("{description}; the {count} of them in {}", region.describe_ranges())
        };
        let mut weights: Vec<f64> = coordinates.chunks_exact(d.max(1)).map(|p| region.weight(p)).collect();
        if region.is_weighted() {
            let total: f64 = weights.iter().sum();
            if !(total > 0.0 && total.is_finite()) {
                return Err(Error::invalid(
                    "--weights",
                    format!(
                        "every point in {} has weight 0 ({})",
                        region.describe_ranges(),
                        region.weights_description
                    ),
                ));
            }
            // A mean of 1 keeps the objective on the scale of the unweighted one.
            let scale = count as f64 / total;
            weights.iter_mut().for_each(|w| *w *= scale);
        }
        Ok(FormData {
            variables: form.variables.clone(),
            channels: form.channels.iter().map(|c| c.name.clone()).collect(),
            coordinates,
            values,
            description,
            on_table_nodes: plain,
            index: index_of_point,
            weights,
            weighted: region.is_weighted(),
        })
    }
}

impl FormData {
    /// Every `stride`-th point along each variable (or axis, on the table's nodes) and each one's
    /// last point, of those the data holds (the region's): a coarser grid over the same domain,
    /// for a faster fit judged on every point. `table` is the table the data was read from. The
    /// weights kept are scaled again to a mean of 1.
    pub fn every(&self, table: &Table, stride: usize) -> FormData {
        let shape: Vec<usize> =
            if self.on_table_nodes { table.shape() } else { vec![FIT_GRID_NODES; self.variables.len()] };
        let (d, c) = (self.variables.len(), self.channels.len());
        let mut kept = FormData {
            coordinates: Vec::new(),
            values: Vec::new(),
            index: Vec::new(),
            weights: Vec::new(),
            ..self.clone()
        };
        for (n, &number) in self.index.iter().enumerate() {
            // The first axis runs fastest, on the table's nodes (Table::node_index) as on the grid.
            let mut rest = number;
            let keep = shape.iter().all(|&count| {
                let i = rest % count;
                rest /= count;
                i % stride == 0 || i + 1 == count
            });
            if keep {
                kept.coordinates.extend_from_slice(&self.coordinates[n * d..(n + 1) * d]);
                kept.values.extend_from_slice(&self.values[n * c..(n + 1) * c]);
                kept.index.push(number);
                kept.weights.push(self.weights[n]);
            }
        }
        if self.weighted {
            let total: f64 = kept.weights.iter().sum();
            if total > 0.0 {
                let scale = kept.weights.len() as f64 / total;
                kept.weights.iter_mut().for_each(|w| *w *= scale);
            }
        }
        kept.description = format!("every {stride}th point along each variable of {}", self.description);
        kept
    }
}

/// Points per parallel work item: fixed, so that sums are added in the same order whatever the
/// number of threads.
const CHUNK: usize = 4096;

/// The data as a search reads it: the form's tape split ([`crate::ir::tape::Tape::split`]) so that
/// everything that does not depend on the parameters is computed once per point, here.
pub struct Prepared<'a> {
    data: &'a FormData,
    tape: crate::ir::tape::Tape,
    /// Per input of the split tape (the variables, then the values of the split-off
    /// instructions), its value at every point: one column each, for [`Batch`] to read rows of.
    columns: Vec<f64>,
    width: usize,
}

impl<'a> Prepared<'a> {
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
        if let Some(words) = crate::machine::beyond_limit(bytes, &what) {
            return Err(Error::invalid(
                format!("form `{}`", form.name),
                format!("{words}: fit a region (--range) or share sub-expressions in [let]"),
            ));
        }
        Ok(())
    }

    pub fn new(form: &Form, data: &'a FormData) -> Prepared<'a> {
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
        Prepared { data, tape, columns, width }
    }

    /// Point `n`'s inputs of the split tape, into `point`.
    fn point_into(&self, n: usize, point: &mut Vec<f64>) {
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

/// Error figures of one channel, or of all together.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figures {
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
pub struct FigureSet {
    pub together: Figures,
    pub channels: BTreeMap<String, Figures>,
}

/// The form evaluated in f32 with f32 parameters (what its shader computes) against the data.
/// Refuses a value that is not finite, naming the point.
pub fn figures(form: &Form, data: &FormData, parameters: &[f64]) -> Result<FigureSet> {
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
pub(crate) fn figures_of(data: &FormData, errors: &[f64]) -> FigureSet {
    figure_set(errors, &data.channels, &data.variables, |n| data.point(n).to_vec(), |_| 1.0)
}

/// The figures of the residuals of [`residuals`] with the data's weights, where they are not
/// uniform: RMS `sqrt(sum w e^2 / sum w)`, the 99th percentile of the weighted distribution of
/// |e|, the max over the points of positive weight.
fn weighted_figures_of(data: &FormData, errors: &[f64]) -> Option<FigureSet> {
    data.weighted
        .then(|| figure_set(errors, &data.channels, &data.variables, |n| data.point(n).to_vec(), |n| data.weights[n]))
}

/// The figures of `errors` (point-major, one per channel) per channel and together, point `n`
/// counting `weight(n)` (a point of weight 0 not at all); `point(n)` is point `n`'s coordinates in
/// `variables`. With weights of 1 these are the plain RMS, the nearest-rank 99th percentile and the
/// max.
fn figure_set(
    errors: &[f64],
    channels: &[String],
    variables: &[String],
    point: impl Fn(usize) -> Vec<f64>,
    weight: impl Fn(usize) -> f64,
) -> FigureSet {
    let count = channels.len();
    let summarise = |selected: &dyn Fn(usize) -> bool, name_channel: bool| -> Figures {
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
        Figures {
            rms: if total > 0.0 { (sum / total).sqrt() } else { 0.0 },
            p99,
            max: max.max(0.0),
            max_at: variables.iter().cloned().zip(point(max_index / count)).collect(),
            max_channel: name_channel.then(|| channels[max_index % count].clone()),
        }
    };
    FigureSet {
        together: summarise(&|_| true, true),
        channels: (0..count).map(|c| (channels[c].clone(), summarise(&|k| k % count == c, false))).collect(),
    }
}

fn describe_point(variables: &[String], point: &[f64]) -> String {
    let parts: Vec<String> = variables.iter().zip(point).map(|(v, x)| format!("{v} = {x}")).collect();
    format!("({})", parts.join(", "))
}

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

pub fn identifiability(form: &Form, prepared: &Prepared, parameters: &[f64]) -> Identifiability {
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
            let mut work = Work::default();
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
    pub form: FigureSet,
    /// The form at its start values.
    pub form_at_start: FigureSet,
    /// The table, interpolated multilinearly in its axes (`Table::interpolate`, f64 arithmetic on
    /// its stored values), against the same exact values.
    pub table: FigureSet,
    /// With `--weights` other than uniform: the fitted form's figures with each point weighted
    /// as the fit weighs it ([`Region::weight`] at the point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub form_weighted: Option<FigureSet>,
    /// The table's, weighted the same.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table_weighted: Option<FigureSet>,
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

/// A form fitted to a table.
#[derive(Debug, Clone, PartialEq)]
pub struct FormFit {
    pub parameters: Vec<f64>,
    /// `None` when no search ran (`max_evaluations = 0`: the form at its start values).
    pub search: Option<Minimum>,
}

/// Fit `form` to `data`: the form's start and `settings.starts - 1` seeded uniform points in the
/// bounds, each searched by L-BFGS with the exact gradient; the best wins. `max_evaluations = 0`
/// evaluates the form at its start values.
pub fn fit(form: &Form, prepared: &Prepared, settings: &FitSettings) -> Result<FormFit> {
    let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
    // A form without parameters (a published baseline) has nothing to search.
    if settings.max_evaluations == 0 || start.is_empty() {
        return Ok(FormFit { parameters: start, search: None });
    }
    let lower: Vec<f64> = form.parameters.iter().map(|p| p.min).collect();
    let upper: Vec<f64> = form.parameters.iter().map(|p| p.max).collect();
    let objective = |x: &[f64], g: Option<&mut [f64]>| prepared.objective(x, g);
    let minimum = minimise(&objective, true, &start, &lower, &upper, settings)?;
    Ok(FormFit { parameters: minimum.parameters.clone(), search: Some(minimum) })
}

/// `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormReport {
    pub form: String,
    pub form_file: String,
    pub table: String,
    pub table_file: String,
    pub variables: Vec<String>,
    pub channels: Vec<String>,
    /// The form statement by statement ([`Form::definition`]).
    pub definition: Vec<String>,
    /// The form file's text, as read: with `parameters`, what a scene's `tir = "fit:..."` reads
    /// ([`super::fitted`]). Empty in files written before it was recorded.
    #[serde(default)]
    pub form_text: String,
    pub parameters: BTreeMap<String, f64>,
    pub parameter_order: Vec<String>,
    pub start: BTreeMap<String, f64>,
    pub bounds: BTreeMap<String, [f64; 2]>,
    pub points: usize,
    pub points_are: String,
    /// `--range`: the box of the variables the points are kept in; empty for the whole table.
    #[serde(default)]
    pub ranges: Vec<Range>,
    /// `--weights`.
    #[serde(default)]
    pub weights: WeightsSpec,
    /// What the weights are, in words.
    #[serde(default)]
    pub weights_are: String,
    /// At the fitted parameters, the form in f32 against the table's values, every point counting
    /// once.
    pub figures: FigureSet,
    /// The same at the start values.
    pub start_figures: FigureSet,
    /// With weights other than uniform: the figures with each point counting its weight (the
    /// fit's objective is their RMS squared, in f64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_figures: Option<FigureSet>,
    /// The same at the start values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_start_figures: Option<FigureSet>,
    /// The form's operations, and its time per evaluation beside the table's lookup.
    #[serde(default)]
    pub cost: Option<Cost>,
    pub settings: FitSettings,
    pub search: Option<Minimum>,
    pub identifiability: Identifiability,
    /// Against exact integrals at random points, per check domain; empty when not asked for.
    pub certified: Vec<Certified>,
    pub shader_function: String,
    /// Every file of the set, `fit.json` and `report.md` included.
    pub files: Vec<String>,
}

/// The file that lists the set, moved into place last.
pub const FIT_FILE: &str = super::fitted::FIT_FILE;
pub const REPORT_FILE: &str = "report.md";

/// What `tmlut fit --form FILE` is asked: one form file, fitted into `out`.
pub struct FormFitRequest {
    pub form: PathBuf,
    pub out: PathBuf,
    pub options: FitOptions,
}

/// How a form is fitted and judged, the same for every form of a `--form DIR`.
#[derive(Clone)]
pub struct FitOptions {
    /// The table file, as the report names it.
    pub table: PathBuf,
    pub settings: FitSettings,
    /// The exact integrals to certify the form against (computed once for every form of a
    /// folder); `None` skips the certification.
    pub certify: Option<std::sync::Arc<Vec<ExactValues>>>,
    /// `--range`: only the points inside every range are fitted, judged, drawn and certified.
    pub ranges: Vec<Range>,
    /// `--weights`.
    pub weights: WeightsSpec,
    /// With `--weights SCENE.toml`: the scene's lookups of the table
    /// ([`crate::scene::lookups::table_lookups`]).
    pub scene: Option<SceneLookups>,
    /// Timed runs of the form and of the table's lookup ([`super::cost::timing`]); 0 times
    /// nothing (the file is then the same bytes on every run).
    pub timing_runs: usize,
}

/// Read the form against the table, fit it, and write `fit.json`, `report.md` and the shader
/// files into `out` as one set ([`commit_set`]: every file staged, `fit.json` moved last; files of
/// an earlier set that this one does not replace are removed with the commit).
pub fn fit_form_file(table: &Table, request: &FormFitRequest) -> Result<FormReport> {
    let form_text = crate::formats::read_text_at_most(&request.form, MAX_FORM_BYTES, "form file")?;
    let form = Form::parse(&request.form, &form_text, table)?;
    let region = Region::new(
        &request.options.ranges,
        &request.options.weights,
        request.options.scene.as_ref(),
        table,
        &form.variables,
    )?;
    let data = FormData::from_table_in(table, &form, &region)?;
    let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
    let start_residuals = residuals(&form, &data, &start)?;
    Prepared::check_memory(&form, &data)?;
    let prepared = Prepared::new(&form, &data);
    let fitted = fit(&form, &prepared, &request.options.settings)?;
    let fitted_residuals = residuals(&form, &data, &fitted.parameters)?;
    let fitted_figures = figures_of(&data, &fitted_residuals);
    let timed = match request.options.timing_runs {
        0 => None,
        runs => Some(timing(&form, &fitted.parameters, table, &data.coordinates, runs)?),
    };
    let shaders = sources(&form, &fitted.parameters)?;
    let shader_files: Vec<String> = LANGUAGES.iter().map(|(_, ext)| format!("{}.{ext}", form.name)).collect();
    let mut files = shader_files.clone();
    files.extend([ERROR_MAP_FILE, RESIDUALS_FILE, REPORT_FILE, FIT_FILE].map(String::from));
    let names = form.parameter_names();
    let report = FormReport {
        form: form.name.clone(),
        form_file: request.form.display().to_string(),
        table: table.name.clone(),
        table_file: request.options.table.display().to_string(),
        variables: form.variables.clone(),
        channels: data.channels.clone(),
        definition: form.definition(),
        form_text,
        parameters: names.iter().cloned().zip(fitted.parameters.iter().copied()).collect(),
        parameter_order: names.clone(),
        start: form.parameters.iter().map(|p| (p.name.clone(), p.start)).collect(),
        bounds: form.parameters.iter().map(|p| (p.name.clone(), [p.min, p.max])).collect(),
        points: data.len(),
        points_are: data.description.clone(),
        ranges: request.options.ranges.clone(),
        weights: request.options.weights.clone(),
        weights_are: region.weights_description.clone(),
        figures: fitted_figures,
        start_figures: figures_of(&data, &start_residuals),
        weighted_figures: weighted_figures_of(&data, &fitted_residuals),
        weighted_start_figures: weighted_figures_of(&data, &start_residuals),
        cost: Some(Cost { operations: operations(&form.tape), timing: timed }),
        settings: request.options.settings,
        search: fitted.search,
        identifiability: identifiability(&form, &prepared, &fitted.parameters),
        certified: match &request.options.certify {
            Some(exact) => certify(&form, table, exact, (&start, &fitted.parameters), &region)?,
            None => Vec::new(),
        },
        shader_function: function_name(&form),
        files,
    };
    let pictures = |dir: &Path| write_pictures(dir, &report.form, table, &data, &fitted_residuals, &report.figures);
    write_set(&request.out, &report, &shader_files, &shaders, pictures)?;
    Ok(report)
}

/// The list `tmlut fit --form DIR` writes beside the fits' folders.
pub const FORMS_FILE: &str = "forms.json";

/// One form of a folder fitted to a table: where its set is, its figures and its cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankedForm {
    pub form: String,
    pub form_file: String,
    /// The fit's folder (`fit.json` and the rest of its set), relative to `forms.json`.
    pub folder: String,
    pub parameters: usize,
    /// At the fitted parameters, all channels together (the form in f32 against the table), over
    /// the region's points, every point counting once.
    pub figures: Figures,
    /// With weights other than uniform: the same with each point counting its weight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_figures: Option<Figures>,
    /// The form's operations, and its time per evaluation beside the table's lookup where timed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<Cost>,
}

impl RankedForm {
    /// The figures the ranking reads: the weighted ones where the points are weighted.
    pub fn ranked_by(&self) -> &Figures {
        self.weighted_figures.as_ref().unwrap_or(&self.figures)
    }
}

/// `forms.json`: the forms of a folder fitted to one table, ranked by max error (a formula in
/// place of a table shows its worst point as an artifact), then by RMS; with weights other than
/// uniform, by the weighted figures (the max over the points of positive weight, the weighted
/// RMS the fit minimised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FolderFits {
    pub table: String,
    pub table_file: String,
    pub settings: FitSettings,
    /// `--range`: the box every form was fitted and judged in; empty for the whole table.
    #[serde(default)]
    pub ranges: Vec<Range>,
    /// `--weights`.
    #[serde(default)]
    pub weights: WeightsSpec,
    /// `--timing-runs` (0: no form was timed).
    #[serde(default)]
    pub timing_runs: usize,
    pub rule: String,
    pub forms: Vec<RankedForm>,
}

/// What `tmlut fit --form DIR` is asked: every form file of `files` fitted to the table with the
/// same options, each into `out/<form>/`.
pub struct FolderFitRequest {
    pub files: Vec<PathBuf>,
    pub out: PathBuf,
    pub options: FitOptions,
}

/// Fit every form file of the request to `table` ([`fit_form_file`], each into `out/<form>/`),
/// rank them by max error then RMS (weighted, where the weights are not uniform) and write
/// [`FORMS_FILE`] into `out`.
pub fn fit_form_files(table: &Table, request: &FolderFitRequest) -> Result<FolderFits> {
    let mut forms = Vec::with_capacity(request.files.len());
    let folders = super::form::distinct_form_names(&request.files)?;
    for (file, folder) in request.files.iter().zip(folders) {
        // Each form's folder is one tmlut makes inside the given one: never a link planted there.
        crate::formats::files::create_folders_inside(&request.out, Path::new(&folder))?;
        let one =
            FormFitRequest { form: file.clone(), out: request.out.join(&folder), options: request.options.clone() };
        let report = fit_form_file(table, &one)?;
        forms.push(RankedForm {
            form: report.form,
            form_file: report.form_file,
            folder,
            parameters: report.parameter_order.len(),
            figures: report.figures.together,
            weighted_figures: report.weighted_figures.map(|w| w.together),
            cost: report.cost,
        });
    }
    forms.sort_by(|a, b| {
        let (a, b) = (a.ranked_by(), b.ranked_by());
        a.max.total_cmp(&b.max).then(a.rms.total_cmp(&b.rms))
    });
    let weighted = forms.iter().any(|f| f.weighted_figures.is_some());
    let ranking = FolderFits {
        table: table.name.clone(),
        table_file: request.options.table.display().to_string(),
        settings: request.options.settings,
        ranges: request.options.ranges.clone(),
        weights: request.options.weights.clone(),
        timing_runs: request.options.timing_runs,
        rule: if weighted {
            "by the weighted figures: max |form - table| over the points of positive weight, then by the weighted RMS"
                .into()
        } else {
            "by max |form - table| over the points, then by RMS".into()
        },
        forms,
    };
    let json = serde_json::to_string_pretty(&ranking).map_err(|e| Error::invalid("forms.json", e.to_string()))?;
    crate::formats::write_bytes_atomically(&request.out.join(FORMS_FILE), json.as_bytes())?;
    Ok(ranking)
}

/// The ranking as a table, best first, with each form's cost.
pub fn ranking_markdown(ranking: &FolderFits) -> String {
    use std::fmt::Write as _;
    let mut s = format!("# Forms fitted to table `{}` ({})\n\n", ranking.table, ranking.table_file);
    let weighted = ranking.forms.iter().any(|f| f.weighted_figures.is_some());
    if !ranking.ranges.is_empty() || weighted {
        let ranges: Vec<String> =
            ranking.ranges.iter().map(|r| format!("{} in [{}, {}]", r.variable, r.lo, r.hi)).collect();
        let _ = writeln!(
            s,
            "Region: {}; weights: {}. Each form's report.md has its figures in full.\n",
            if ranges.is_empty() { "the whole table".to_string() } else { ranges.join(", ") },
            ranking.weights
        );
    }
    let timed = ranking.forms.iter().any(|f| f.cost.as_ref().is_some_and(|c| c.timing.is_some()));
    let figures = if weighted { "weighted RMS | weighted p99 | weighted max" } else { "RMS | p99 | max" };
    let _ = writeln!(
        s,
        "| rank | form | parameters | {figures} | max at | operations (arith, transc, select) |{} fit |",
        if timed { " ns, form / lookup |" } else { "" }
    );
    let _ = writeln!(s, "|---:|---|---:|---:|---:|---:|---|---|{}---|", if timed { "---|" } else { "" });
    for (k, f) in ranking.forms.iter().enumerate() {
        let figures = f.ranked_by();
        let at: Vec<String> = figures.max_at.iter().map(|(v, x)| format!("{v} {x:.3}")).collect();
        let operations = f.cost.as_ref().map_or("-".to_string(), |c| {
            let o = &c.operations;
            format!("{}, {}, {}", o.arithmetic, o.transcendental, o.select)
        });
        let time = match f.cost.as_ref().and_then(|c| c.timing.as_ref()) {
            Some(t) => format!(" {:.1} / {:.1} |", t.form_ns, t.lookup_ns),
            None if timed => " - |".to_string(),
            None => String::new(),
        };
        let _ = writeln!(
            s,
            "| {} | `{}` | {} | {:.6} | {:.6} | {:.6} | {} | {operations} |{time} {}/ |",
            k + 1,
            f.form_file,
            f.parameters,
            figures.rms,
            figures.p99,
            figures.max,
            at.join(", "),
            f.folder
        );
    }
    let _ = writeln!(s, "\nRanked {}.", ranking.rule);
    if timed {
        let _ = writeln!(
            s,
            "CPU times per evaluation: medians of {} runs (the form in f32, the table's lookup as a GPU samples it); \
             measured, not asserted.",
            ranking.timing_runs
        );
    }
    s
}

/// Stage every file (`pictures` draws [`ERROR_MAP_FILE`] and [`RESIDUALS_FILE`] into the folder
/// it is given) and commit them as one set.
fn write_set(
    out: &Path,
    report: &FormReport,
    shader_files: &[String],
    shaders: &[String],
    pictures: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    let folder = OutputFolder::take(out, |_| {})?;
    let staging = &mut folder.staging()?;
    pictures(&staging.dir)?;
    let json = serde_json::to_string_pretty(report).map_err(|e| Error::format(out, e.to_string()))?;
    let mut texts: Vec<(&str, String)> = shader_files.iter().map(String::as_str).zip(shaders.iter().cloned()).collect();
    texts.push((REPORT_FILE, markdown(report)));
    texts.push((FIT_FILE, json));
    for (file, text) in &texts {
        crate::formats::write_bytes_atomically(&staging.dir.join(file), text.as_bytes())?;
    }
    let moves: Vec<Move> = [ERROR_MAP_FILE, RESIDUALS_FILE]
        .into_iter()
        .chain(texts[..texts.len() - 1].iter().map(|(file, _)| *file))
        .map(|file| Move { staged: file.to_string(), destination: file.to_string() })
        .collect();
    // An earlier set's files this one does not replace (a form of another name).
    let removals = crate::formats::read_text_at_most(&out.join(FIT_FILE), 1 << 24, "fit.json")
        .ok()
        .and_then(|text| serde_json::from_str::<FormReport>(&text).ok())
        .map(|old| old.files.into_iter().filter(|f| !report.files.contains(f)).collect())
        .unwrap_or_default();
    commit_set(&folder, staging, moves, removals, FIT_FILE)
}

/// The report a researcher reads: the figures at the start and fitted values, the parameters,
/// what is ill-determined, and the files.
pub fn markdown(report: &FormReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "# Form `{}` fitted to table `{}`\n", report.form, report.table);
    let _ = writeln!(
        s,
        "Form file `{}`, table file `{}`; {} points: {}.\n",
        report.form_file, report.table_file, report.points, report.points_are
    );
    if !report.ranges.is_empty() || report.weighted_figures.is_some() {
        let ranges: Vec<String> =
            report.ranges.iter().map(|r| format!("{} in [{}, {}]", r.variable, r.lo, r.hi)).collect();
        let _ = writeln!(
            s,
            "Region: {}; weights: {}. The fit minimises the weighted mean squared residual; every figure below \
             is over the region's points, weighted where it says so.\n",
            if ranges.is_empty() { "the whole table".to_string() } else { ranges.join(", ") },
            report.weights_are
        );
    }
    let _ = writeln!(s, "```text\n{}\n```\n", report.definition.join("\n"));
    let _ = writeln!(s, "| channel | RMS at start | RMS fitted | p99 fitted | max fitted | max at |");
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|");
    let rows = std::iter::once(("together".to_string(), &report.start_figures.together, &report.figures.together))
        .chain(report.figures.channels.iter().map(|(c, f)| (c.clone(), &report.start_figures.channels[c], f)));
    let weighted = report.weighted_figures.as_ref().zip(report.weighted_start_figures.as_ref()).map(|(f, st)| {
        std::iter::once(("together, weighted".to_string(), &st.together, &f.together))
            .chain(f.channels.iter().map(|(c, x)| (format!("{c}, weighted"), &st.channels[c], x)))
    });
    for (channel, start, fitted) in rows.chain(weighted.into_iter().flatten()) {
        let at: Vec<String> = fitted.max_at.iter().map(|(v, x)| format!("{v} {x:.4}")).collect();
        let _ = writeln!(
            s,
            "| {channel} | {:.6} | {:.6} | {:.6} | {:.6} | {}{} |",
            start.rms,
            fitted.rms,
            fitted.p99,
            fitted.max,
            at.join(", "),
            fitted.max_channel.as_ref().map(|c| format!(" ({c})")).unwrap_or_default()
        );
    }
    for c in &report.certified {
        let _ = writeln!(
            s,
            "\nAgainst exact integrals at {} random points (the quadrature, {} Gauss–Legendre nodes per panel), {}{}:\n",
            c.points,
            c.exact_nodes,
            c.domain,
            if report.ranges.is_empty() { "" } else { ", those of them inside the region" }
        );
        let _ = writeln!(
            s,
            "| channel | form at start: RMS | fitted: RMS | p99 | max | max at | table interpolated: RMS | p99 | max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---|---:|---:|---:|");
        let rows =
            std::iter::once(("together".to_string(), &c.form_at_start.together, &c.form.together, &c.table.together))
                .chain(
                    c.form
                        .channels
                        .iter()
                        .map(|(k, f)| (k.clone(), &c.form_at_start.channels[k], f, &c.table.channels[k])),
                );
        // Weighted, the start's figures are not kept: its column repeats the unweighted one's.
        let weighted = c.form_weighted.as_ref().zip(c.table_weighted.as_ref()).map(|(f, t)| {
            std::iter::once(("together, weighted".to_string(), &c.form_at_start.together, &f.together, &t.together))
                .chain(
                    f.channels
                        .iter()
                        .map(|(k, x)| (format!("{k}, weighted"), &c.form_at_start.channels[k], x, &t.channels[k])),
                )
        });
        for (channel, start, fitted, table) in rows.chain(weighted.into_iter().flatten()) {
            let at: Vec<String> = fitted.max_at.iter().map(|(v, x)| format!("{v} {x:.4}")).collect();
            let _ = writeln!(
                s,
                "| {channel} | {:.6} | {:.6} | {:.6} | {:.6} | {} | {:.2e} | {:.2e} | {:.2e} |",
                start.rms,
                fitted.rms,
                fitted.p99,
                fitted.max,
                at.join(", "),
                table.rms,
                table.p99,
                table.max
            );
        }
    }
    let _ = writeln!(s, "\n| parameter | start | fitted | bounds |\n|---|---:|---:|---|");
    for name in &report.parameter_order {
        let [lo, hi] = report.bounds[name];
        let _ = writeln!(s, "| {name} | {} | {} | [{lo}, {hi}] |", report.start[name], report.parameters[name]);
    }
    let id = &report.identifiability;
    let _ = writeln!(s);
    if let Some(search) = &report.search {
        let succeeded = search.starts.iter().filter(|s| s.succeeded).count();
        let _ = writeln!(
            s,
            "Search: {} from {} starts (seed {}), {succeeded} ended with a success status; start {} won, mean squared residual {:.6e}.",
            search.algorithm,
            search.starts.len(),
            report.settings.seed,
            search.best_start,
            search.objective
        );
    } else {
        let _ = writeln!(s, "No search (no parameters, or max evaluations 0): the figures are the start values'.");
    }
    if id.ill_determined.is_empty() {
        let _ = writeln!(s, "\nEvery parameter is determined by the data ({}).", id.rule);
    } else {
        let ratios: Vec<String> = id.ill_determined.iter().map(|w| format!("{:.1e}", w.singular_value_ratio)).collect();
        let _ = writeln!(
            s,
            "\nIll-determined: {} direction(s) of parameter space, made of {} (singular values {} of the largest; {}): \
             the data fixes fewer combinations of these than there are parameters.",
            id.ill_determined.len(),
            id.ill_determined_parameters.join(", "),
            ratios.join(", "),
            id.rule
        );
    }
    if !id.at_bounds.is_empty() {
        let _ = writeln!(s, "\nAt a bound: {}.", id.at_bounds.join(", "));
    }
    if let Some(cost) = &report.cost {
        let o = &cost.operations;
        let _ = writeln!(
            s,
            "\nCost: {} arithmetic operations, {} transcendental functions, {} selects (the instructions the channels read).",
            o.arithmetic, o.transcendental, o.select
        );
        if let Some(t) = &cost.timing {
            let _ = writeln!(
                s,
                "CPU time per evaluation, median of {} runs over {} of the points: the form {:.1} ns (f32, the instruction list \
                 interpreted), the table's lookup {:.1} ns ({}; the GPU emulator's sampling in Rust). Measured, not asserted: \
                 it depends on the machine and its load.",
                t.runs, t.batch, t.form_ns, t.lookup_ns, t.lookup
            );
        }
    }
    let _ = writeln!(
        s,
        "\nShader function `{}` in: {}.",
        report.shader_function,
        report.files[..LANGUAGES.len()].join(", ")
    );
    if report.files.iter().any(|f| f == ERROR_MAP_FILE) {
        let _ = writeln!(
            s,
            "\n![|form - table| over two axes]({ERROR_MAP_FILE})\n\n\
             [`{ERROR_MAP_FILE}`]({ERROR_MAP_FILE}): |form - table| of the channel with the largest error \
             over the table's first two axes (over the form's first two variables where the points are a \
             uniform grid), the max over any other axis, on a logarithmic colour scale.\n\n\
             ![histogram of the residuals]({RESIDUALS_FILE})\n\n\
             [`{RESIDUALS_FILE}`]({RESIDUALS_FILE}): every residual (form - table), all points and channels, \
             with the RMS and 99th percentile of |r| marked."
        );
    }
    s
}
