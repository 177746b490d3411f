//! The least-squares search every fit runs ([`minimise`]: a thin layer over NLopt: bounds,
//! several deterministic starts, and every start's own status kept in the result, never
//! discarded; L-BFGS where the objective has a gradient, BOBYQA otherwise), and the uniform grid
//! a TIR table is fitted and judged on ([`fit_grid`]). The forms and their objectives are
//! [`super::forms`]'s.

use std::cmp::Ordering;

use nlopt::{Algorithm, Nlopt, Target};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
pub use crate::formats::manifest::{ErrorFigures, Minimum, StartRecord};
use crate::table::Table;

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
    let (parameters, objective) = (starts[best_start].parameters.clone(), starts[best_start].objective);
    Ok(Minimum::new(format!("{algorithm:?}"), parameters, objective, best_start, starts))
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
    let objective = if value.is_finite() { value } else { f64::NAN };
    Ok(StartRecord::new(x0.to_vec(), x, objective, status, succeeded, counter.get()))
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
