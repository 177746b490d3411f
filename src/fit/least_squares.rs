//! Least-squares fitting of the TIR forms with NLopt, their error figures and side-by-side cost.
//!
//! - [`minimise`]: a thin layer over NLopt: bounds, several deterministic starts, and every start's
//!   own status kept in the result (never discarded). L-BFGS where the form has a gradient, BOBYQA
//!   (derivative-free) otherwise.
//! - [`fit_form`]: the (optionally weighted) mean squared error over the table's nodes.
//! - [`figures`]: RMSE, MSE, max error and where, evaluated in f32 as a shader would.
//! - [`cost`]: ns per f32 evaluation (median of repeated runs), and the table fetch through the
//!   GPU texture emulator timed the same way.

use std::cmp::Ordering;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use nlopt::{Algorithm, Nlopt, Target};
use serde::{Deserialize, Serialize};

use super::forms::{self, Form, ShaderLanguage};
use crate::error::{Error, Result};
pub use crate::formats::manifest::{ErrorFigures, Minimum, StartRecord};
use crate::packing::emulator::{Filter, Texture3D};
use crate::stats::median;
use crate::table::Table;

/// The table's nodes as fitting data: `(mu, alpha, eta)` and the value, with an optional weight.
#[derive(Debug, Clone)]
pub struct FitData {
    pub points: Vec<[f64; 3]>,
    pub values: Vec<f64>,
    pub weights: Option<Vec<f64>>,
}

/// Nodes per axis of the grid the forms are fitted on when the table's own nodes are not a
/// uniform `(mu, alpha, eta)` grid: the original 64^3 layout.
pub const FIT_GRID_NODES: usize = 64;

/// The TIR table as a uniform grid of `(mu, alpha, eta)` nodes, the grid the forms are fitted and
/// judged on: the table itself when it has that layout (the original `tm_TIR.bin`'s), otherwise
/// the table interpolated (`Table::interpolate`) at the nodes of a [`FIT_GRID_NODES`]^3 grid over
/// its `mu` and `alpha` ranges and `eta` in [0, 1]. A layout whose nodes crowd where the table is
/// steep would otherwise weight the fit there.
pub fn fit_grid(table: &Table) -> Result<Table> {
    let names: Vec<&str> = table.axes.iter().map(|a| a.name.as_str()).collect();
    if table.dimension() != 3 || table.channel_count() != 1 || names[..2] != ["mu", "alpha"] {
        return Err(Error::invalid(
            "fit table",
            format!(
                "axes ({}) and {} channels; allowed: a TIR table (mu, alpha, eta or critical_angle_offset), one channel",
                names.join(", "),
                table.channel_count()
            ),
        ));
    }
    let uniform = |a: &crate::table::Axis| {
        a.placement == crate::table::Placement::NodeAligned && a.mapping == crate::table::Mapping::Identity
    };
    if names[2] == "eta" && table.axes.iter().all(uniform) {
        return Ok(table.clone());
    }
    let n = FIT_GRID_NODES;
    let (mu, alpha) = (&table.axes[0], &table.axes[1]);
    let axes = vec![
        crate::table::Axis::node_aligned("mu", mu.start, mu.end, n)?,
        crate::table::Axis::node_aligned("alpha", alpha.start, alpha.end, n)?,
        crate::table::Axis::node_aligned("eta", 0.0, 1.0, n)?,
    ];
    let grid = Table::zeros(&table.name, axes, table.channels.clone())?;
    let data = (0..grid.node_count())
        .map(|node| {
            let p = grid.node_position(&grid.node_index(node));
            let point = crate::table::derived::point_of(&table.axes, p[0], p[1], p[2], 0.0).ok_or_else(|| {
                Error::invalid("fit table", format!("axis `{}` is not one a TIR lookup addresses", names[2]))
            })?;
            Ok(table.interpolate(&point)[0] as f32)
        })
        .collect::<Result<Vec<f32>>>()?;
    Table::new(&table.name, grid.axes, grid.channels, data)
}

impl FitData {
    /// Every node of a 3-axis, one-channel table (axes in the order mu, alpha, eta).
    pub fn from_table(table: &Table) -> Result<FitData> {
        Self::from_table_nodes(table, 1)
    }

    /// Every `stride`-th node along each axis of a TIR table, and each axis's last node (a coarser
    /// grid over the same domain, for a faster fit).
    pub fn from_table_nodes(table: &Table, stride: usize) -> Result<FitData> {
        if table.dimension() != 3 || table.channel_count() != 1 {
            return Err(Error::invalid(
                "fit table",
                format!(
                    "{} axes and {} channels; allowed: a TIR table (mu, alpha, eta), one channel",
                    table.dimension(),
                    table.channel_count()
                ),
            ));
        }
        let mut points = Vec::with_capacity(table.node_count());
        let mut values = Vec::with_capacity(table.node_count());
        let shape = table.shape();
        for n in 0..table.node_count() {
            let index = table.node_index(n);
            if index.iter().zip(&shape).any(|(&i, &count)| i % stride != 0 && i + 1 != count) {
                continue;
            }
            let value = table.data[n] as f64;
            if !value.is_finite() {
                return Err(Error::invalid("fit table", format!("node {n} is not finite ({value})")));
            }
            let p = table.node_position(&index);
            points.push([p[0], p[1], p[2]]);
            values.push(value);
        }
        Ok(FitData { points, values, weights: None })
    }

    fn weight(&self, n: usize) -> f64 {
        self.weights.as_ref().map_or(1.0, |w| w[n])
    }
}

/// How a search is run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Starts: the form's own starting point, then `starts - 1` uniform points in the bounds drawn
    /// from `seed`.
    pub starts: usize,
    pub seed: u64,
    pub max_evaluations: u32,
    /// Relative tolerance on the objective.
    pub ftol_rel: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings { starts: 6, seed: 2021, max_evaluations: 2000, ftol_rel: 1e-10 }
    }
}

/// splitmix64: deterministic start points from the seed, independent of any library's RNG.
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The objective and, where available, its gradient: `f(x, Some(grad))` fills `grad`.
pub type Objective<'a> = dyn Fn(&[f64], Option<&mut [f64]>) -> f64 + 'a;

/// Minimise `objective` within `[lower, upper]` from several starts. `has_gradient` picks L-BFGS
/// (the objective must fill the gradient when asked) or BOBYQA. Returns the best start; every
/// start's status is in the result. A NaN objective (the objective must not panic: a panic inside
/// NLopt's callback aborts the process) makes NLopt stop that start with a failure status.
pub fn minimise(
    objective: &Objective,
    has_gradient: bool,
    start: &[f64],
    lower: &[f64],
    upper: &[f64],
    settings: &FitSettings,
) -> Result<Minimum> {
    let n = start.len();
    if n == 0
        || lower.len() != n
        || upper.len() != n
        || lower.iter().zip(upper).any(|(l, u)| l.partial_cmp(u) != Some(Ordering::Less))
    {
        return Err(Error::invalid("fit bounds", format!("{n} parameters, bounds {lower:?} .. {upper:?}")));
    }
    if settings.starts == 0 {
        return Err(Error::invalid("fit starts", "0; allowed: at least 1"));
    }
    let algorithm = if has_gradient { Algorithm::Lbfgs } else { Algorithm::Bobyqa };
    let mut state = settings.seed;
    let mut starts = Vec::with_capacity(settings.starts);
    for k in 0..settings.starts {
        let x0: Vec<f64> = if k == 0 {
            start.iter().zip(lower.iter().zip(upper)).map(|(&x, (&l, &u))| x.clamp(l, u)).collect()
        } else {
            (0..n)
                .map(|i| {
                    let unit = (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
                    lower[i] + unit * (upper[i] - lower[i])
                })
                .collect()
        };
        starts.push(run_start(objective, algorithm, &x0, lower, upper, settings)?);
    }
    let best_start = (0..starts.len())
        .filter(|&k| starts[k].objective.is_finite())
        .min_by(|&a, &b| starts[a].objective.total_cmp(&starts[b].objective))
        .ok_or_else(|| Error::invalid("fit", "no start reached a finite objective"))?;
    Ok(Minimum {
        algorithm: format!("{algorithm:?}"),
        parameters: starts[best_start].parameters.clone(),
        objective: starts[best_start].objective,
        best_start,
        starts,
    })
}

fn run_start(
    objective: &Objective,
    algorithm: Algorithm,
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    settings: &FitSettings,
) -> Result<StartRecord> {
    let setup = |r: std::result::Result<nlopt::SuccessState, nlopt::FailState>, what: &str| {
        r.map(|_| ()).map_err(|e| Error::invalid("fit", format!("NLopt refused {what}: {e:?}")))
    };
    let counter = std::cell::Cell::new(0u64);
    let mut optimiser = Nlopt::new(
        algorithm,
        x0.len(),
        |x: &[f64], gradient: Option<&mut [f64]>, evaluations: &mut &std::cell::Cell<u64>| {
            evaluations.set(evaluations.get() + 1);
            objective(x, gradient)
        },
        Target::Minimize,
        &counter,
    );
    setup(optimiser.set_lower_bounds(lower), "the lower bounds")?;
    setup(optimiser.set_upper_bounds(upper), "the upper bounds")?;
    setup(optimiser.set_maxeval(settings.max_evaluations), "the evaluation limit")?;
    setup(optimiser.set_ftol_rel(settings.ftol_rel), "the tolerance")?;
    let mut x = x0.to_vec();
    let (status, succeeded, value) = match optimiser.optimize(&mut x) {
        Ok((state, value)) => (format!("{state:?}"), true, value),
        Err((state, value)) => (format!("{state:?}"), false, value),
    };
    drop(optimiser);
    Ok(StartRecord {
        start: x0.to_vec(),
        parameters: x,
        objective: if value.is_finite() { value } else { f64::NAN },
        status,
        succeeded,
        evaluations: counter.get(),
    })
}

/// A fitted (or parameter-free) form with its search record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedForm {
    pub form: Form,
    pub parameters: Vec<f64>,
    /// `None` for a form with no parameters.
    pub search: Option<Minimum>,
}

/// Nodes per parallel work item of the objective (fixed, so that sums do not depend on threads).
const OBJECTIVE_CHUNK: usize = 4096;

/// Least squares of one form over the data: minimise the (weighted) mean squared residual.
pub fn fit_form(form: Form, data: &FitData, settings: &FitSettings) -> Result<FittedForm> {
    let (start, lower, upper) = form.start_and_bounds();
    if start.is_empty() {
        return Ok(FittedForm { form, parameters: Vec::new(), search: None });
    }
    let total_weight: f64 = (0..data.values.len()).map(|n| data.weight(n)).sum();
    if total_weight.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return Err(Error::invalid("fit weights", format!("sum {total_weight}; allowed: positive")));
    }
    // Sum of squared residuals (and its gradient) over one chunk of nodes; NaN if the form has no
    // gradient where one is asked for.
    let chunk_sums = |p: &[f64], want_gradient: bool, chunk: usize| -> (f64, Vec<f64>) {
        let mut sum = 0.0;
        let mut g_point = vec![0.0; p.len()];
        let mut g_sum = vec![0.0; if want_gradient { p.len() } else { 0 }];
        let nodes = chunk * OBJECTIVE_CHUNK..((chunk + 1) * OBJECTIVE_CHUNK).min(data.values.len());
        for n in nodes {
            let (point, target) = (&data.points[n], data.values[n]);
            let w = data.weight(n);
            let value = if want_gradient {
                match form.value_and_gradient(p, point[0], point[1], point[2], &mut g_point) {
                    Some(v) => v,
                    None => return (f64::NAN, g_sum),
                }
            } else {
                form.eval(p, point[0], point[1], point[2])
            };
            let residual = value - target;
            sum += w * residual * residual;
            for (g, &d) in g_sum.iter_mut().zip(&g_point) {
                *g += 2.0 * w * residual * d;
            }
        }
        (sum, g_sum)
    };
    let chunks = data.values.len().div_ceil(OBJECTIVE_CHUNK);
    let objective = |p: &[f64], gradient: Option<&mut [f64]>| -> f64 {
        use rayon::prelude::*;
        let want_gradient = gradient.is_some();
        // Chunks in parallel, their sums added in chunk order: the same bits for any thread count.
        let per_chunk: Vec<(f64, Vec<f64>)> =
            (0..chunks).into_par_iter().map(|chunk| chunk_sums(p, want_gradient, chunk)).collect();
        let mut sum = 0.0;
        let mut g_sum = vec![0.0; p.len()];
        for (chunk_sum, chunk_gradient) in &per_chunk {
            sum += chunk_sum;
            for (g, d) in g_sum.iter_mut().zip(chunk_gradient) {
                *g += d;
            }
        }
        if let Some(gradient) = gradient {
            for (g, s) in gradient.iter_mut().zip(&g_sum) {
                *g = s / total_weight;
            }
        }
        let mse = sum / total_weight;
        if mse.is_finite() { mse } else { f64::NAN }
    };
    let minimum = minimise(&objective, true, &start, &lower, &upper, settings)?;
    Ok(FittedForm { form, parameters: minimum.parameters.clone(), search: Some(minimum) })
}

/// The form's f32 value at every node.
pub fn values_f32(fitted: &FittedForm, data: &FitData) -> Vec<f32> {
    let p: Vec<f32> = fitted.parameters.iter().map(|&v| v as f32).collect();
    data.points.iter().map(|x| fitted.form.eval(&p, x[0] as f32, x[1] as f32, x[2] as f32)).collect()
}

pub fn figures(fitted: &FittedForm, data: &FitData) -> ErrorFigures {
    let values = values_f32(fitted, data);
    let (mut sum, mut max, mut max_at) = (0.0, -1.0, [f64::NAN; 3]);
    for ((&v, &target), point) in values.iter().zip(&data.values).zip(&data.points) {
        let error = v as f64 - target;
        // A NaN value counts as the worst error, never silently as zero.
        let abs = if error.is_nan() { f64::INFINITY } else { error.abs() };
        sum += error * error;
        if abs > max {
            max = abs;
            max_at = *point;
        }
    }
    let mse = sum / values.len().max(1) as f64;
    ErrorFigures { rmse: mse.sqrt(), mse, max_abs_error: max.max(0.0), max_at, nodes: values.len() }
}

/// One timing run: ns per evaluation of `evaluate` over `queries`, inputs and result through
/// `black_box`. Generic, so that each form's loop is compiled for that form alone.
fn time_one_run(queries: &[[f32; 3]], evaluate: impl Fn(f32, f32, f32) -> f32) -> f64 {
    let started = Instant::now();
    let mut sum = 0.0f32;
    for q in queries {
        let q = black_box(q);
        sum += evaluate(q[0], q[1], q[2]);
    }
    black_box(sum);
    started.elapsed().as_secs_f64() * 1e9 / queries.len().max(1) as f64
}

/// A timed evaluator: one run over the queries, returning ns per evaluation.
pub type TimedRun<'a> = Box<dyn Fn(&[[f32; 3]]) -> f64 + 'a>;

/// Median ns per evaluation of each evaluator, timed side by side: run `r` of every evaluator
/// comes before run `r + 1` of any, so that the machine's load drifts over all of them alike
/// rather than over whichever was timed last.
pub fn time_side_by_side(queries: &[[f32; 3]], runs: usize, evaluators: &[TimedRun<'_>]) -> Vec<f64> {
    let mut per_run = vec![Vec::with_capacity(runs); evaluators.len()];
    for _ in 0..runs.max(1) {
        for (times, run) in per_run.iter_mut().zip(evaluators) {
            times.push(run(queries));
        }
    }
    per_run.iter().map(|times| median(times)).collect()
}

/// Query points for timing: the data's nodes in a fixed scrambled order, so that branches and
/// cache behaviour are not those of a sorted sweep.
pub fn timing_queries(data: &FitData, count: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            let p = &data.points[(splitmix64(&mut state) % data.points.len().max(1) as u64) as usize];
            [p[0] as f32, p[1] as f32, p[2] as f32]
        })
        .collect()
}

/// One timing run of a form in f32, for [`time_side_by_side`].
pub fn form_timing(fitted: &FittedForm) -> TimedRun<'static> {
    let p: Vec<f32> = fitted.parameters.iter().map(|&v| v as f32).collect();
    let form = fitted.form;
    Box::new(move |queries| time_one_run(queries, |mu, alpha, eta| form.eval(black_box(&p[..]), mu, alpha, eta)))
}

/// The TIR table bound as a texture and read as a shader reads it, in f32: the third axis's
/// quantity from `(mu, eta)` (`eta` itself, or `asin(eta) - acos(mu)`), each axis's mapping, the
/// node-aligned coordinate `u (N - 1) / N + 0.5 / N` (`docs/formats.md`, "Axis placement"), one
/// trilinear fetch through the GPU emulator (exact weights).
pub struct TableFetch {
    texture: Texture3D,
    /// Per axis: mapping, `m(start)`, `1 / (m(end) - m(start))`, node count.
    axes: Vec<(crate::table::Mapping, f32, f32, f32)>,
    critical_angle_offset: bool,
}

impl TableFetch {
    pub fn new(table: &Table) -> Self {
        let shape = table.shape();
        let axes = table
            .axes
            .iter()
            .map(|a| {
                let (m0, m1) = (a.mapping.forward_f32(a.start as f32), a.mapping.forward_f32(a.end as f32));
                (a.mapping, m0, 1.0 / (m1 - m0), a.count as f32)
            })
            .collect();
        TableFetch {
            texture: Texture3D { width: shape[0], height: shape[1], depth: shape[2], texels: table.data.clone() },
            axes,
            critical_angle_offset: table.axes[2].name == crate::table::derived::CRITICAL_ANGLE_OFFSET,
        }
    }

    #[inline]
    pub fn sample(&self, mu: f32, alpha: f32, eta: f32) -> f32 {
        let third =
            if self.critical_angle_offset { eta.clamp(0.0, 1.0).asin() - mu.clamp(0.0, 1.0).acos() } else { eta };
        let coordinate = |d: usize, x: f32| {
            let (mapping, m0, inverse_range, n) = self.axes[d];
            let u = (mapping.forward_f32(x) - m0) * inverse_range;
            u * ((n - 1.0) / n) + 0.5 / n
        };
        self.texture.sample_trilinear(coordinate(0, mu), coordinate(1, alpha), coordinate(2, third), Filter::Exact)
    }
}

/// One timing run of the f32 table fetch, for [`time_side_by_side`].
pub fn fetch_timing(fetch: &TableFetch) -> TimedRun<'_> {
    Box::new(move |queries| time_one_run(queries, |mu, alpha, eta| fetch.sample(mu, alpha, eta)))
}

/// The form a build fits to its TIR table: the most accurate fitted form whose CPU cost was
/// measured no higher than thesis eq. 5.6's, side by side (docs/fit.md). Fixed here rather than
/// timed during the build, so that a build's files depend on its configuration and seed only.
pub const BUILD_FORM: Form = Form::CauchySlope;

/// Starts of the build's fit: the form's own start only. On the default table every start of
/// `tmlut fit tir` ended at the same objective to 1e-3 relative (docs/fit.md), and each start
/// costs about 10 s of CPU in the build.
pub const BUILD_STARTS: usize = 1;

/// The build fits on every `BUILD_NODE_STRIDE`-th node along each axis; its figures are over
/// every node.
pub const BUILD_NODE_STRIDE: usize = 3;

/// Fit [`BUILD_FORM`] to a built TIR table and write its shaders into `dir` as `tir_fit.hlsl` and
/// `tir_fit.wgsl`. Returns the manifest entry and the shader paths.
pub fn fit_for_build(
    table: &Table,
    seed: u64,
    dir: &Path,
) -> Result<(crate::formats::manifest::FitEntry, Vec<PathBuf>)> {
    let grid = fit_grid(table)?;
    let data = FitData::from_table(&grid)?;
    let settings = FitSettings { starts: BUILD_STARTS, seed, ..FitSettings::default() };
    // Fitted on every third node (a 27th of them), judged on all of them.
    let fitted = fit_form(BUILD_FORM, &FitData::from_table_nodes(&grid, BUILD_NODE_STRIDE)?, &settings)?;
    let mut shaders = Vec::new();
    let mut paths = Vec::new();
    for (language, extension) in [(ShaderLanguage::Hlsl, "hlsl"), (ShaderLanguage::Wgsl, "wgsl")] {
        let text = forms::shader(BUILD_FORM, &fitted.parameters, language)
            .ok_or_else(|| Error::invalid("fit", format!("form {} has no shader", BUILD_FORM.name())))?;
        let file = format!("tir_fit.{extension}");
        let path = dir.join(&file);
        crate::formats::write_bytes_atomically(&path, text.as_bytes())?;
        shaders.push(crate::formats::manifest::ShaderFile {
            language: extension.into(),
            file,
            function: "tmlut_tir".into(),
            sha256: crate::loader::sha256_hex(text.as_bytes()),
        });
        paths.push(path);
    }
    let entry = crate::formats::manifest::FitEntry {
        form: BUILD_FORM.name().into(),
        formula: BUILD_FORM.formula().into(),
        definition: BUILD_FORM.definition(),
        chosen_by: "tir.fit = \"best\": the most accurate form measured no costlier than thesis eq. 5.6 (docs/fit.md)"
            .into(),
        parameter_names: BUILD_FORM.parameter_names().map(String::from).collect(),
        parameters: fitted.parameters.clone(),
        figures: figures(&fitted, &data),
        search: fitted.search,
        shaders,
    };
    Ok((entry, paths))
}

/// One form's entry in `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormReport {
    pub name: String,
    pub formula: String,
    /// Statement by statement ([`Form::definition`]).
    pub definition: Vec<String>,
    pub parameter_names: Vec<String>,
    pub parameters: Vec<f64>,
    pub figures: ErrorFigures,
    pub cost_ns_per_evaluation_f32: f64,
    pub search: Option<Minimum>,
    pub shaders: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitManifest {
    pub table: String,
    pub settings: FitSettings,
    pub timing: String,
    pub table_fetch_cost_ns_f32: f64,
    pub forms: Vec<FormReport>,
    /// The most accurate form costing no more than eq. 5.6 as measured here: the lowest max error
    /// over the nodes (a formula in place of a table shows its worst node, as an artifact), then
    /// the lowest RMSE.
    pub best_under_eq56_cost: Option<String>,
}

pub struct FitRequest {
    pub table_path: PathBuf,
    pub forms: Vec<Form>,
    pub out: PathBuf,
    pub settings: FitSettings,
    pub timing_runs: usize,
    pub timing_queries: usize,
}

/// Fit every requested form, time them and the table fetch, and write `fit.json`, shaders and the
/// error-against-cost plot into `out`.
pub fn fit_tir(table: &Table, request: &FitRequest) -> Result<FitManifest> {
    let grid = fit_grid(table)?;
    let data = FitData::from_table(&grid)?;
    std::fs::create_dir_all(&request.out).map_err(|e| Error::io(&request.out, e))?;
    let queries = timing_queries(&data, request.timing_queries, request.settings.seed);
    let fetch = TableFetch::new(table);
    let mut forms = Vec::new();
    let mut timings = Vec::new();
    for &form in &request.forms {
        let fitted = fit_form(form, &data, &request.settings)?;
        let figures = figures(&fitted, &data);
        error_maps(&request.out, form, &grid, &fitted, &data)?;
        let mut shaders = Vec::new();
        for (language, extension) in [(ShaderLanguage::Hlsl, "hlsl"), (ShaderLanguage::Wgsl, "wgsl")] {
            if let Some(text) = forms::shader(form, &fitted.parameters, language) {
                let name = format!("tir_{}.{extension}", form.name());
                crate::formats::write_bytes_atomically(&request.out.join(&name), text.as_bytes())?;
                shaders.push(name);
            }
        }
        timings.push(form_timing(&fitted));
        forms.push(FormReport {
            name: form.name().into(),
            formula: form.formula().into(),
            definition: form.definition(),
            parameter_names: form.parameter_names().map(String::from).collect(),
            parameters: fitted.parameters.clone(),
            figures,
            cost_ns_per_evaluation_f32: f64::NAN,
            search: fitted.search,
            shaders,
        });
    }
    // Every form and the table fetch are timed side by side, after all the fits.
    timings.push(fetch_timing(&fetch));
    let mut costs = time_side_by_side(&queries, request.timing_runs, &timings);
    let fetch = costs.pop().expect("the fetch was timed");
    for (form, cost) in forms.iter_mut().zip(costs) {
        form.cost_ns_per_evaluation_f32 = cost;
    }
    let eq56_cost = forms.iter().find(|f| f.name == Form::Eq56.name()).map(|f| f.cost_ns_per_evaluation_f32);
    let best_under_eq56_cost = eq56_cost.and_then(|limit| most_accurate_within(&forms, limit));
    let manifest = FitManifest {
        table: request.table_path.display().to_string(),
        settings: request.settings,
        timing: format!(
            "ns per f32 evaluation on the CPU: median of {} runs over {} scrambled table nodes, every form and the table fetch timed side by side (run r of each before run r + 1 of any); table fetch = GPU emulator trilinear (exact weights)",
            request.timing_runs, request.timing_queries
        ),
        table_fetch_cost_ns_f32: fetch,
        forms,
        best_under_eq56_cost,
    };
    let json = serde_json::to_string_pretty(&manifest).map_err(|e| Error::format(&request.out, e.to_string()))?;
    crate::formats::write_bytes_atomically(&request.out.join("fit.json"), json.as_bytes())?;
    plot(&request.out.join("error_vs_cost.png"), &manifest)?;
    Ok(manifest)
}

/// The most accurate fitted form whose cost is at most `cost_limit` ns: the lowest max error over
/// the nodes (a formula in place of a table shows its worst node, as an artifact), then the lowest
/// RMSE.
fn most_accurate_within(forms: &[FormReport], cost_limit: f64) -> Option<String> {
    forms
        .iter()
        .filter(|f| !f.parameters.is_empty() && f.cost_ns_per_evaluation_f32 <= cost_limit)
        .min_by(|a, b| {
            a.figures.max_abs_error.total_cmp(&b.figures.max_abs_error).then(a.figures.rmse.total_cmp(&b.figures.rmse))
        })
        .map(|f| f.name.clone())
}

/// `|form - table|` at every node, as an EXR table (`tir_error_<form>.exr`, same axes) and PNG
/// heatmaps over `(mu, alpha)` at four `eta` slices (`tir_error_<form>.png`).
fn error_maps(out: &Path, form: Form, table: &Table, fitted: &FittedForm, data: &FitData) -> Result<()> {
    use crate::report::plot::{Panel, heatmaps_png};
    let errors: Vec<f32> =
        values_f32(fitted, data).iter().zip(&data.values).map(|(&v, &t)| (v as f64 - t).abs() as f32).collect();
    let channel = crate::table::Channel::new("abs_error", format!("|{} - table| at each node", form.name()));
    let map = Table::new(format!("tir_error_{}", form.name()), table.axes.clone(), vec![channel], errors)?;
    crate::formats::exr::write_exr(
        &out.join(format!("tir_error_{}.exr", form.name())),
        &map,
        crate::formats::Precision::F32,
    )?;
    let shape = table.shape();
    let (nx, ny, nz) = (shape[0], shape[1], shape[2]);
    let panels: Vec<Panel> = [0, nz / 3, (2 * nz) / 3, nz - 1]
        .iter()
        .map(|&k| Panel {
            title: format!("eta = {:.3}", table.axes[2].node_value(k)),
            x: ("mu".into(), 0.0, 1.0),
            y: ("alpha".into(), 0.0, 1.0),
            nx,
            ny,
            values: map.data[k * nx * ny..(k + 1) * nx * ny].iter().map(|&v| v as f64).collect(),
        })
        .collect();
    heatmaps_png(
        &out.join(format!("tir_error_{}.png", form.name())),
        &format!("TIR: |{} - table|", form.name()),
        "abs error",
        &panels,
        2,
    )
}

/// RMSE against cost, one point per form, the table fetch as a reference at the table's own
/// error (0 is off a log axis, so it is drawn at the smallest RMSE over 10).
fn plot(path: &Path, manifest: &FitManifest) -> Result<()> {
    use crate::report::plot::{Series, loglog_png};
    let floor = manifest.forms.iter().map(|f| f.figures.rmse).filter(|&v| v > 0.0).fold(f64::INFINITY, f64::min);
    let mut series: Vec<Series> = manifest
        .forms
        .iter()
        .map(|f| Series {
            name: format!("{} (RMSE {:.3})", f.name, f.figures.rmse),
            points: vec![(f.cost_ns_per_evaluation_f32, f.figures.rmse)],
        })
        .collect();
    let reference = if floor.is_finite() { floor / 10.0 } else { 1e-4 };
    series.push(Series {
        name: "table fetch (emulated; RMSE 0 at nodes, drawn low)".into(),
        points: vec![(manifest.table_fetch_cost_ns_f32, reference)],
    });
    loglog_png(
        path,
        "TIR approximations: error against cost",
        "ns per f32 evaluation (CPU)",
        "RMSE over the table's nodes",
        &series,
    )
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
