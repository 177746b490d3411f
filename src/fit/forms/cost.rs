//! What a form costs beside the texture fetch it replaces: its operations by kind, counted on the
//! compiled instruction list ([`crate::ir::tape`]), and the CPU time of one evaluation in f32 beside
//! the CPU time of the table's own lookup, read as a GPU sampler reads it (the texture
//! coordinates in f32, exact linear filtering with clamp addressing: [`crate::filter`]).
//! The times are measured, reported and never asserted: they depend on the machine and its load.

use std::hint::black_box;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::form::Form;
use crate::error::{Error, Result};
use crate::filter::{Filter, lerp, linear_taps};
use crate::ir::tape::{Ins, Tape, reads};
use crate::ir::text::{BinOp, Intrinsic};
use crate::table::derived::{CRITICAL_ANGLE_FRACTION, CRITICAL_ANGLE_OFFSET};
use crate::table::{Axis, Placement, Table};

/// The operations of the instructions a channel reads (a derived variable the form never reads is
/// not counted), by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Operations {
    /// `+ - * /`, negation, `x ^ n` for an integer `n` (`|n| - 1` multiplications, and a division
    /// where `n < 0`), abs, sign, min, max, clamp, saturate, floor, fract, step, mix, smoothstep.
    pub arithmetic: usize,
    /// sqrt, rsqrt, exp, exp2, log, log2, pow (and `^` with another exponent), sin, cos, tan, asin,
    /// acos, atan, atan2, sinh, cosh, tanh, asinh.
    pub transcendental: usize,
    /// `select(a, b, condition)`, its comparison included.
    pub select: usize,
}

/// [`Operations`] of a compiled form.
pub fn operations(tape: &Tape) -> Operations {
    let mut live = vec![false; tape.ins.len()];
    for &k in &tape.outputs {
        live[k] = true;
    }
    for k in (0..tape.ins.len()).rev() {
        if live[k] {
            for operand in reads(&tape.ins[k]) {
                live[operand] = true;
            }
        }
    }
    let mut count = Operations::default();
    for (ins, _) in tape.ins.iter().zip(&live).filter(|(_, live)| **live) {
        match *ins {
            Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => {}
            Ins::Neg(_) => count.arithmetic += 1,
            Ins::Bin(BinOp::Pow, ..) => count.transcendental += 1,
            Ins::Bin(..) => count.arithmetic += 1,
            Ins::PowInt(_, n) => count.arithmetic += (n.unsigned_abs() as usize).saturating_sub(1) + usize::from(n < 0),
            Ins::Call(f, _) => match f {
                Intrinsic::Abs
                | Intrinsic::Sign
                | Intrinsic::Min
                | Intrinsic::Max
                | Intrinsic::Clamp
                | Intrinsic::Saturate
                | Intrinsic::Floor
                | Intrinsic::Fract
                | Intrinsic::Step
                | Intrinsic::Mix
                | Intrinsic::Smoothstep => count.arithmetic += 1,
                _ => count.transcendental += 1,
            },
            Ins::Select { .. } => count.select += 1,
        }
    }
    count
}

/// How one axis of a table is addressed from the form's variables, in f32.
#[derive(Debug, Clone)]
enum Quantity {
    Variable(usize),
    Offset { mu: usize, eta: usize },
    Fraction { mu: usize, eta: usize },
}

/// One axis as a sampler reads it: its quantity, its mapping's ends in f32, its node count.
#[derive(Debug, Clone)]
struct SampledAxis {
    quantity: Quantity,
    axis: Axis,
    m0: f32,
    m1: f32,
    stride: usize,
}

impl SampledAxis {
    /// The texture coordinate of a point ([`Axis::texture_coordinate`] in f32) with the ends'
    /// mapping computed once, as a shader holds them as constants, and the half-texel correction
    /// multiplied out: the timed fetch costs what a shader's does, its coordinate within an ulp
    /// or two of the one a shader computes ([`Axis::texture_coordinate_in`]).
    fn coordinate(&self, point: &[f32]) -> f32 {
        let x = match self.quantity {
            Quantity::Variable(k) => point[k],
            Quantity::Offset { mu, eta } => point[eta].clamp(0.0, 1.0).asin() - point[mu].clamp(0.0, 1.0).acos(),
            // crate::table::derived::CRITICAL_ANGLE_FRACTION_FORMULA.
            Quantity::Fraction { mu, eta } => {
                let (v, c) = (point[mu].clamp(0.0, 1.0).acos(), point[eta].clamp(0.0, 1.0).asin());
                if c < v { (c - v) / v } else { (c - v) / (std::f32::consts::FRAC_PI_2 - v).max(1e-7) }
            }
        };
        let u = (self.axis.mapping.forward_f32(x) - self.m0) / (self.m1 - self.m0);
        let n = self.axis.count as f32;
        match self.axis.placement {
            Placement::NodeAligned => u * ((n - 1.0) / n) + 0.5 / n,
            Placement::CellCentred => u,
        }
    }
}

/// A table as a GPU reads it: its texels as stored (f32), every axis filtered linearly with clamp
/// addressing ([`linear_taps`], exact weights), all channels of a texel at once; a fourth axis is
/// two fetches lerped by hand, as a 4D table is read from a volume.
pub struct TableTexture<'a> {
    table: &'a Table,
    axes: Vec<SampledAxis>,
}

impl<'a> TableTexture<'a> {
    /// The table's sampler, each axis addressed from the form's `variables` (a derived axis from
    /// `mu` and `eta`); refuses a table of more than 4 axes or an axis no variable addresses.
    pub fn new(table: &'a Table, variables: &[String]) -> Result<TableTexture<'a>> {
        let var = |name: &str| {
            variables.iter().position(|v| v == name).ok_or_else(|| {
                Error::invalid("cost", format!("table `{}` is addressed by `{name}`, not a variable", table.name))
            })
        };
        if table.axes.is_empty() || table.axes.len() > 4 {
            return Err(Error::invalid(
                "cost",
                format!("table `{}` has {} axes; a lookup reads 1 to 4", table.name, table.axes.len()),
            ));
        }
        let mut stride = 1;
        let mut axes = Vec::new();
        for axis in &table.axes {
            let quantity = match axis.name.as_str() {
                CRITICAL_ANGLE_OFFSET => Quantity::Offset { mu: var("mu")?, eta: var("eta")? },
                CRITICAL_ANGLE_FRACTION => Quantity::Fraction { mu: var("mu")?, eta: var("eta")? },
                name => Quantity::Variable(var(name)?),
            };
            let (m0, m1) = (axis.mapping.forward(axis.start) as f32, axis.mapping.forward(axis.end) as f32);
            axes.push(SampledAxis { quantity, axis: axis.clone(), m0, m1, stride });
            stride *= axis.count;
        }
        Ok(TableTexture { table, axes })
    }

    /// Every channel of the table at `point` (the form's variables), into `out`.
    pub fn sample(&self, point: &[f32], out: &mut [f32]) {
        let mut taps = [(0usize, 0usize, 0f32); 4];
        for (tap, axis) in taps.iter_mut().zip(&self.axes) {
            *tap = linear_taps(axis.coordinate(point), axis.axis.count, Filter::Exact);
        }
        for (c, o) in out.iter_mut().enumerate() {
            *o = self.blend(self.axes.len() - 1, 0, c, &taps);
        }
    }

    /// The multilinear blend over axes `0..=axis` at texel `offset` of the higher axes: x first,
    /// then y, then z, as the sampler filters.
    fn blend(&self, axis: usize, offset: usize, channel: usize, taps: &[(usize, usize, f32); 4]) -> f32 {
        let (a, b, f) = taps[axis];
        let stride = self.axes[axis].stride;
        let (ta, tb) = (offset + a * stride, offset + b * stride);
        if axis == 0 {
            let c = self.table.channels.len();
            lerp(self.table.data[ta * c + channel], self.table.data[tb * c + channel], f)
        } else {
            lerp(self.blend(axis - 1, ta, channel, taps), self.blend(axis - 1, tb, channel, taps), f)
        }
    }
}

/// Measured CPU time per evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Points evaluated per timed run (of the fit's points, evenly spaced).
    pub batch: usize,
    pub runs: usize,
    /// The form in f32 at the fitted parameters (f32), by the tape's interpreter: every channel,
    /// ns per point, the median over the runs.
    pub form_ns: f64,
    /// The table's lookup (every channel): texture coordinates in f32 and linear filtering, ns per
    /// point, the median over the runs.
    pub lookup_ns: f64,
    /// How the lookup was read.
    pub lookup: String,
}

/// The cost of a form: its operations and, when measured, its time beside the lookup's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    /// Counted on the compiled instructions ([`operations`]).
    pub operations: Operations,
    /// `None` with `--timing-runs 0`.
    pub timing: Option<Timing>,
}

/// Points per timed run, at most.
pub const TIMING_BATCH: usize = 4096;

/// Time the form and the table's lookup over the same points (`coordinates`, row-major in the
/// form's variables), `runs` times each, interleaved so that both see the same load; the medians.
pub fn timing(form: &Form, parameters: &[f64], table: &Table, coordinates: &[f64], runs: usize) -> Result<Timing> {
    let d = form.variables.len().max(1);
    let count = coordinates.len() / d;
    let step = count.div_ceil(TIMING_BATCH).max(1);
    let points: Vec<f32> =
        (0..count).step_by(step).flat_map(|n| &coordinates[n * d..(n + 1) * d]).map(|&v| v as f32).collect();
    let batch = points.len() / d;
    let texture = TableTexture::new(table, &form.variables)?;
    let p32: Vec<f32> = parameters.iter().map(|&v| v as f32).collect();
    let (mut scratch, mut out) = (Vec::new(), vec![0.0f32; form.channels.len()]);
    let mut fetched = vec![0.0f32; table.channels.len()];
    let (mut form_times, mut lookup_times) = (Vec::new(), Vec::new());
    let per_point = |started: Instant| started.elapsed().as_secs_f64() * 1e9 / batch.max(1) as f64;
    for _ in 0..runs {
        let started = Instant::now();
        for point in points.chunks_exact(d) {
            form.tape.eval(black_box(point), black_box(&p32), &mut scratch, &mut out);
            black_box(&out);
        }
        form_times.push(per_point(started));
        let started = Instant::now();
        for point in points.chunks_exact(d) {
            texture.sample(black_box(point), &mut fetched);
            black_box(&fetched);
        }
        lookup_times.push(per_point(started));
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    Ok(Timing {
        batch,
        runs,
        form_ns: median(form_times),
        lookup_ns: median(lookup_times),
        lookup: format!(
            "{} axes filtered linearly in f32 (texture coordinates as the manifest's, exact weights, clamp addressing), {} channel(s) per texel",
            table.axes.len(),
            table.channels.len()
        ),
    })
}
