//! One axis of a table: which quantity it samples, over which range, at how many nodes, where
//! those nodes sit, and through which mapping the nodes are spaced.
//!
//! Two coordinates matter and are kept apart:
//! - the *axis coordinate* `u` in [0, 1], linear in the mapped quantity:
//!   `u = (m(x) - m(start)) / (m(end) - m(start))`;
//! - the *texture coordinate* a shader hands to a GPU sampler, which depends on the placement.
//!
//! A node-aligned axis (the original transfer-matrix tables) has node `k` at `u = k / (N - 1)`; a
//! cell-centred axis (a GPU texture) has texel `k` at `u = (k + 0.5) / N`. Sampling a node-aligned
//! table through a texture unit therefore needs `tex = (u * (N - 1) + 0.5) / N`, the half-texel
//! correction the thesis renderer lacked (`docs/formats.md`, "Axis placement").

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Where the nodes of an axis sit relative to its range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Placement {
    /// Node `k` of `N` at `u = k / (N - 1)`: the first and last nodes lie on the range ends.
    NodeAligned,
    /// Texel `k` of `N` at `u = (k + 0.5) / N`, as a GPU texture places its texels.
    CellCentred,
}

/// How an axis spaces its nodes: uniformly in `m(x)` rather than in `x`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mapping {
    /// `m(x) = x`.
    #[default]
    Identity,
    /// `m(x) = sqrt(x)`; for a GGX alpha axis this is the perceptual roughness.
    Sqrt,
    /// `m(x) = sqrt(1 - x)`; for a cosine axis this packs nodes toward the normal (`x = 1`).
    SqrtOneMinus,
    /// `m(x) = (sqrt(x) - sqrt(1 - x) + 1) / 2` on [0, 1]: nodes packed toward both ends, as
    /// `sqrt(x)` near 0 and `sqrt(1 - x)` near 1. For a cosine axis: dense at grazing views, where
    /// masking and the horizon reshape a lobe within a few thousandths of `mu`, and near the normal,
    /// where the view angle `acos(mu)` moves fastest.
    SqrtEnds,
    /// `m(x) = asinh((x - centre) / scale)`: linear within about `scale` of `centre` and
    /// logarithmic beyond, so that equal steps of `m` resolve a transition at `centre` of any
    /// width from `scale` up.
    Asinh {
        /// The width of the linear part, in the quantity's units; finite and above 0.
        scale: f64,
        /// Where the transition lies (omitted from the manifest where 0).
        #[serde(default, skip_serializing_if = "is_zero")]
        centre: f64,
    },
    /// `m(x) = asinh((x - centre) / scale) + slope_below * min(x - centre, 0)`: [`Mapping::Asinh`]
    /// with a ramp below `centre` that keeps nodes there no further apart than `1 / slope_below`
    /// steps of `m`, where the logarithm alone would spread them. A variant of its own, so that a
    /// reader that predates it refuses the manifest rather than read the `asinh` alone.
    AsinhRampBelow {
        /// The width of the linear part, as [`Mapping::Asinh`]'s.
        scale: f64,
        /// Where the transition lies.
        centre: f64,
        /// The ramp's slope below `centre`, in steps of `m` per unit of the quantity; 0 or above.
        slope_below: f64,
    },
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The arithmetic of a table read, written once for every type that computes it: an axis's
/// mapping and coordinates, the point of a derived axis ([`crate::table::derived::point_in`]) and
/// the choice among a scene's slices. Its types: f64 (the tables' own), f32 (as a shader computes
/// the manifest's formulas), and the scene shader's expressions, which print them
/// (`tmlut_ir::shader` builds those). Constants, the mapping of an axis's ends among them, are
/// computed in [`Arithmetic::Constant`] and then become values: a shader prints the very f32
/// constants the CPU's f32 sampler computes.
pub trait Arithmetic:
    Clone
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
{
    /// The precision constants are computed in: the type itself for f64 and f32, f32 for a
    /// shader's expression.
    type Constant: Arithmetic + Copy;
    /// A constant computed in [`Arithmetic::Constant`], as a value of this type.
    fn constant(value: Self::Constant) -> Self;
    /// `value` rounded to this precision.
    fn of(value: f64) -> Self;
    /// The larger of `self` and `other`.
    fn max(self, other: Self) -> Self;
    /// The smaller of `self` and `other`.
    fn min(self, other: Self) -> Self;
    /// `self` held to `[lo, hi]`.
    fn clamp(self, lo: Self, hi: Self) -> Self;
    /// The square root.
    fn sqrt(self) -> Self;
    /// The largest integer not above `self`.
    fn floor(self) -> Self;
    /// The inverse hyperbolic sine.
    fn asinh(self) -> Self;
    /// `acos(self)` (a shader's is its own polynomial: the builtin's error is loosely bounded).
    fn acos(self) -> Self;
    /// A comparison's outcome: `bool`, or a shader's boolean expression.
    type Condition;
    /// `self < other`.
    fn less_than(self, other: Self) -> Self::Condition;
    /// `self <= other`.
    fn at_most(self, other: Self) -> Self::Condition;
    /// Both conditions hold.
    fn both(a: Self::Condition, b: Self::Condition) -> Self::Condition;
    /// `then` where `condition` holds, else `otherwise`: a shader's `select`, both sides computed.
    fn select(condition: Self::Condition, then: Self, otherwise: Self) -> Self;
}

macro_rules! arithmetic {
    ($t:ident) => {
        impl Arithmetic for $t {
            type Constant = $t;
            fn constant(value: $t) -> Self {
                value
            }
            fn of(value: f64) -> Self {
                value as $t
            }
            fn max(self, other: Self) -> Self {
                $t::max(self, other)
            }
            fn min(self, other: Self) -> Self {
                $t::min(self, other)
            }
            fn clamp(self, lo: Self, hi: Self) -> Self {
                $t::clamp(self, lo, hi)
            }
            fn sqrt(self) -> Self {
                $t::sqrt(self)
            }
            fn floor(self) -> Self {
                $t::floor(self)
            }
            fn asinh(self) -> Self {
                $t::asinh(self)
            }
            fn acos(self) -> Self {
                $t::acos(self)
            }
            type Condition = bool;
            fn less_than(self, other: Self) -> bool {
                self < other
            }
            fn at_most(self, other: Self) -> bool {
                self <= other
            }
            fn both(a: bool, b: bool) -> bool {
                a && b
            }
            fn select(condition: bool, then: Self, otherwise: Self) -> Self {
                if condition { then } else { otherwise }
            }
        }
    };
}

arithmetic!(f64);
arithmetic!(f32);

impl Mapping {
    /// `(scale, centre, slope_below)` of either `asinh` mapping (slope 0 for [`Mapping::Asinh`]):
    /// every evaluation of the two is one formula.
    pub fn asinh_parts(self) -> Option<(f64, f64, f64)> {
        match self {
            Mapping::Asinh { scale, centre } => Some((scale, centre, 0.0)),
            Mapping::AsinhRampBelow { scale, centre, slope_below } => Some((scale, centre, slope_below)),
            _ => None,
        }
    }

    /// `m(x)`: the mapped value of the quantity `x`, in f64.
    pub fn forward(self, x: f64) -> f64 {
        self.forward_in(x)
    }

    /// [`Mapping::forward`] in f32, as a shader evaluates it.
    pub fn forward_f32(self, x: f32) -> f32 {
        self.forward_in(x)
    }

    /// [`Mapping::forward`] in the arithmetic of `x`, the parameters rounded to its precision
    /// first. A centre or ramp of 0 is left out, which changes no finite value.
    pub fn forward_in<T: Arithmetic>(self, x: T) -> T {
        let [zero, half, one] = [0.0, 0.5, 1.0].map(T::of);
        match self {
            Mapping::Identity => x,
            Mapping::Sqrt => x.max(zero).sqrt(),
            Mapping::SqrtOneMinus => (one - x).max(zero).sqrt(),
            Mapping::SqrtEnds => {
                let x = x.clamp(zero, one.clone());
                half * (x.clone().sqrt() - (one.clone() - x).sqrt() + one)
            }
            Mapping::Asinh { .. } | Mapping::AsinhRampBelow { .. } => {
                let (scale, centre, slope_below) = self.asinh_parts().unwrap_or_default();
                let from_centre = if centre == 0.0 { x } else { x - T::of(centre) };
                let asinh = (from_centre.clone() / T::of(scale)).asinh();
                if slope_below == 0.0 { asinh } else { asinh + T::of(slope_below) * from_centre.min(zero) }
            }
        }
    }

    /// The quantity whose mapped value is `m`: the inverse of [`Mapping::forward`].
    pub fn inverse(self, m: f64) -> f64 {
        match self {
            Mapping::Identity => m,
            Mapping::Sqrt => m * m,
            Mapping::SqrtOneMinus => 1.0 - m * m,
            Mapping::SqrtEnds => {
                // a = sqrt(x), b = sqrt(1 - x): a - b = 2 m - 1 and a^2 + b^2 = 1.
                let difference = (2.0 * m - 1.0).clamp(-1.0, 1.0);
                let a = 0.5 * (difference + (2.0 - difference * difference).sqrt());
                (a * a).clamp(0.0, 1.0)
            }
            Mapping::AsinhRampBelow { scale, centre, slope_below } if m < 0.0 && slope_below > 0.0 => {
                // asinh(y) + slope_below * scale * y = m has one root y = (x - centre) / scale,
                // between the roots of either term alone; bisection halves that bracket to f64's
                // resolution.
                let slope = slope_below * scale;
                let (mut lo, mut hi) = ((m / slope).max(m.sinh()), 0.0);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if mid == lo || mid == hi {
                        break;
                    }
                    if mid.asinh() + slope * mid < m {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                centre + scale * 0.5 * (lo + hi)
            }
            Mapping::Asinh { scale, centre } | Mapping::AsinhRampBelow { scale, centre, .. } => {
                centre + scale * m.sinh()
            }
        }
    }

    /// The values of `x` the mapping is defined on, as `(lo, hi)`.
    pub fn domain(self) -> (f64, f64) {
        match self {
            Mapping::Identity | Mapping::Asinh { .. } | Mapping::AsinhRampBelow { .. } => {
                (f64::NEG_INFINITY, f64::INFINITY)
            }
            Mapping::Sqrt => (0.0, f64::INFINITY),
            Mapping::SqrtOneMinus => (f64::NEG_INFINITY, 1.0),
            Mapping::SqrtEnds => (0.0, 1.0),
        }
    }

    /// `m(x)` written out for a shader or a manifest, with `x` named.
    pub fn formula(self, x: &str) -> String {
        match self {
            Mapping::Identity => x.to_string(),
            Mapping::Sqrt => format!("sqrt({x})"),
            Mapping::SqrtOneMinus => format!("sqrt(1 - {x})"),
            Mapping::SqrtEnds => format!("(sqrt({x}) - sqrt(1 - {x}) + 1) / 2"),
            Mapping::Asinh { scale, centre: 0.0 } => format!("asinh({x} / {scale:?})"),
            Mapping::Asinh { scale, centre } => format!("asinh(({x} - {centre:?}) / {scale:?})"),
            Mapping::AsinhRampBelow { scale, centre, slope_below } => {
                format!("asinh(({x} - {centre:?}) / {scale:?}) + {slope_below:?} * min({x} - {centre:?}, 0)")
            }
        }
    }

    /// Whether the mapping is valid: a finite, positive `asinh` scale.
    pub fn validate(self) -> Result<()> {
        let Some((scale, centre, slope_below)) = self.asinh_parts() else {
            return Ok(());
        };
        let problem = if !(scale.is_finite() && scale > 0.0) {
            format!("asinh scale {scale}; allowed: finite and > 0")
        } else if !centre.is_finite() {
            format!("asinh centre {centre}; allowed: finite")
        } else if !(slope_below.is_finite() && slope_below >= 0.0) {
            format!("asinh slope below the centre {slope_below}; allowed: finite and >= 0")
        } else {
            return Ok(());
        };
        Err(Error::invalid("mapping", problem))
    }
}

/// One axis of a table. `start` is the value at axis coordinate 0 and `end` the value at 1; `end`
/// may be below `start` (the Karis table runs its roughness axis from 1 at row 0 down to 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// The quantity sampled, e.g. `mu` (cosine of the incident angle), `alpha`, `eta`, `kappa`.
    pub name: String,
    /// The quantity's value at axis coordinate 0.
    pub start: f64,
    /// The quantity's value at axis coordinate 1 (may be below `start`).
    pub end: f64,
    /// The number of nodes (texels along the axis); at least 2.
    pub count: usize,
    /// Where the nodes sit in the range: on its ends, or at texel centres.
    pub placement: Placement,
    /// How the nodes are spaced in the quantity ([`Mapping::Identity`] where the manifest names none).
    #[serde(default)]
    pub mapping: Mapping,
}

impl Axis {
    /// A validated axis: at least two nodes, finite distinct ends inside the mapping's domain.
    pub fn new(
        name: impl Into<String>,
        start: f64,
        end: f64,
        count: usize,
        placement: Placement,
        mapping: Mapping,
    ) -> Result<Self> {
        let axis = Axis { name: name.into(), start, end, count, placement, mapping };
        axis.validate()?;
        Ok(axis)
    }

    /// A validated axis with nodes on its range's ends, spaced uniformly in the quantity.
    pub fn node_aligned(name: impl Into<String>, start: f64, end: f64, count: usize) -> Result<Self> {
        Self::new(name, start, end, count, Placement::NodeAligned, Mapping::Identity)
    }

    /// A validated axis with nodes at texel centres, spaced uniformly in the quantity.
    pub fn cell_centred(name: impl Into<String>, start: f64, end: f64, count: usize) -> Result<Self> {
        Self::new(name, start, end, count, Placement::CellCentred, Mapping::Identity)
    }

    /// The axis with its nodes spaced by `mapping`, validated again.
    pub fn with_mapping(mut self, mapping: Mapping) -> Result<Self> {
        self.mapping = mapping;
        self.validate()?;
        Ok(self)
    }

    /// Whether the axis is valid: at least two nodes, a valid mapping, and finite ends inside the
    /// mapping's domain whose mapped values differ.
    pub fn validate(&self) -> Result<()> {
        let key = format!("axis `{}`", self.name);
        if self.count < 2 {
            return Err(Error::invalid(key, format!("{} nodes; an axis needs at least 2 to interpolate", self.count)));
        }
        if !self.start.is_finite() || !self.end.is_finite() {
            return Err(Error::invalid(key, format!("range [{}, {}] is not finite", self.start, self.end)));
        }
        self.mapping.validate().map_err(|e| Error::invalid(&key, e.to_string()))?;
        let (lo, hi) = self.mapping.domain();
        for x in [self.start, self.end] {
            if x < lo || x > hi {
                return Err(Error::invalid(
                    key,
                    format!(
                        "{x} lies outside the domain [{lo}, {hi}] of the mapping {}",
                        self.mapping.formula(&self.name)
                    ),
                ));
            }
        }
        if self.mapping.forward(self.start) == self.mapping.forward(self.end) {
            return Err(Error::invalid(key, format!("range [{}, {}] is empty", self.start, self.end)));
        }
        Ok(())
    }

    /// The range's ends, the lower first: an axis may run from its larger end.
    pub fn bounds(&self) -> (f64, f64) {
        if self.start <= self.end { (self.start, self.end) } else { (self.end, self.start) }
    }

    /// Axis coordinate `u` of a value, linear in the mapped quantity; not clamped.
    pub fn coordinate(&self, x: f64) -> f64 {
        self.coordinate_in(x)
    }

    /// [`Axis::coordinate`] in the arithmetic of `x`: `(m(x) - m(start)) / (m(end) - m(start))`,
    /// the ends mapped in its constants' precision.
    pub fn coordinate_in<T: Arithmetic>(&self, x: T) -> T {
        let m = |v: f64| self.mapping.forward_in(T::Constant::of(v));
        let (m0, m1) = (m(self.start), m(self.end));
        (self.mapping.forward_in(x) - T::constant(m0)) / T::constant(m1 - m0)
    }

    /// The value at axis coordinate `u`; the inverse of [`Axis::coordinate`].
    pub fn value_at(&self, u: f64) -> f64 {
        let m0 = self.mapping.forward(self.start);
        let m1 = self.mapping.forward(self.end);
        self.mapping.inverse(m0 + u * (m1 - m0))
    }

    /// Axis coordinate of node `k`.
    pub fn node_coordinate(&self, k: usize) -> f64 {
        let n = self.count as f64;
        match self.placement {
            Placement::NodeAligned => k as f64 / (n - 1.0),
            Placement::CellCentred => (k as f64 + 0.5) / n,
        }
    }

    /// The value of the quantity at node `k`. The range ends of a node-aligned axis are returned
    /// exactly, so that edge nodes sit exactly on `start` and `end`.
    pub fn node_value(&self, k: usize) -> f64 {
        match (self.placement, k) {
            (Placement::NodeAligned, 0) => self.start,
            (Placement::NodeAligned, k) if k + 1 == self.count => self.end,
            _ => self.value_at(self.node_coordinate(k)),
        }
    }

    /// All node values, in storage order.
    pub fn node_values(&self) -> Vec<f64> {
        (0..self.count).map(|k| self.node_value(k)).collect()
    }

    /// The continuous node index of a value, clamped to `[0, N - 1]` (clamp addressing).
    pub fn continuous_index(&self, x: f64) -> f64 {
        let u = self.coordinate(x);
        let n = self.count as f64;
        let i = match self.placement {
            Placement::NodeAligned => u * (n - 1.0),
            Placement::CellCentred => u * n - 0.5,
        };
        // NaN compares false both ways and would survive `clamp`: send it to node 0 explicitly.
        if i.is_nan() { 0.0 } else { i.clamp(0.0, n - 1.0) }
    }

    /// The two nodes around a value and the weight of the upper one.
    pub fn bracket(&self, x: f64) -> (usize, usize, f64) {
        let i = self.continuous_index(x);
        let lower = (i.floor() as usize).min(self.count - 2);
        (lower, lower + 1, i - lower as f64)
    }

    /// The texture coordinate a GPU sampler (cell-centred, clamp addressing) must be given so that
    /// hardware filtering reproduces this axis's interpolation.
    pub fn texture_coordinate(&self, x: f64) -> f64 {
        self.texture_coordinate_in(x)
    }

    /// [`Axis::texture_coordinate`] in the arithmetic of `x`: in f32, what a shader computes from
    /// the manifest's formula; as a shader expression, that formula printed.
    pub fn texture_coordinate_in<T: Arithmetic>(&self, x: T) -> T {
        let u = self.coordinate_in(x);
        let n = self.count as f64;
        match self.placement {
            Placement::NodeAligned => (u * T::of(n - 1.0) + T::of(0.5)) / T::of(n),
            Placement::CellCentred => u,
        }
    }

    /// [`Axis::texture_coordinate`] written as a formula, with every constant spelled out.
    pub fn texture_coordinate_formula(&self) -> String {
        let m0 = self.mapping.forward(self.start);
        let m1 = self.mapping.forward(self.end);
        let mapped = self.mapping.formula(&self.name);
        let u = if m0 == 0.0 && m1 == 1.0 {
            mapped
        } else if m0 == 0.0 {
            format!("{mapped} / {m1}")
        } else {
            let minus_m0 = if m0 < 0.0 { format!("+ {}", -m0) } else { format!("- {m0}") };
            format!("({mapped} {minus_m0}) / ({m1} {minus_m0})")
        };
        match self.placement {
            Placement::NodeAligned => {
                format!("({u}) * {} / {} + 0.5 / {}", self.count - 1, self.count, self.count)
            }
            Placement::CellCentred => u,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_aligned_ends_sit_on_the_range() {
        let axis = Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap();
        assert_eq!(axis.node_value(0), 0.0);
        assert_eq!(axis.node_value(63), 1.0);
        assert!((axis.node_value(21) - 21.0 / 63.0).abs() < 1e-15);
        assert_eq!(axis.continuous_index(1.0), 63.0);
    }

    #[test]
    fn cell_centred_nodes_sit_at_texel_centres() {
        let axis = Axis::cell_centred("mu", 0.0, 1.0, 512).unwrap();
        assert!((axis.node_value(0) - 0.5 / 512.0).abs() < 1e-15);
        assert!((axis.continuous_index(0.5 / 512.0)).abs() < 1e-12);
        // Outside the first texel centre the index clamps, as clamp addressing does.
        assert_eq!(axis.continuous_index(0.0), 0.0);
    }

    #[test]
    fn texture_coordinate_of_a_node_is_its_texel_centre() {
        for placement in [Placement::NodeAligned, Placement::CellCentred] {
            let axis = Axis::new("alpha", 0.0, 1.0, 17, placement, Mapping::Sqrt).unwrap();
            for k in 0..axis.count {
                let tex = axis.texture_coordinate(axis.node_value(k));
                assert!((tex - (k as f64 + 0.5) / 17.0).abs() < 1e-12, "{placement:?} node {k}: {tex}");
            }
        }
    }

    #[test]
    fn descending_axis_runs_from_start_to_end() {
        let axis = Axis::cell_centred("alpha", 1.0, 0.0, 4).unwrap().with_mapping(Mapping::Sqrt).unwrap();
        let roughness: Vec<f64> = axis.node_values().iter().map(|a| a.sqrt()).collect();
        let expected = [0.875, 0.625, 0.375, 0.125];
        for (r, e) in roughness.iter().zip(expected) {
            assert!((r - e).abs() < 1e-12, "{roughness:?}");
        }
    }

    #[test]
    fn mapped_axis_round_trips_values() {
        let axis = Axis::node_aligned("mu", 0.0, 1.0, 33).unwrap().with_mapping(Mapping::SqrtOneMinus).unwrap();
        for x in [0.0, 0.1, 0.5, 0.99, 1.0] {
            let back = axis.value_at(axis.coordinate(x));
            assert!((back - x).abs() < 1e-12, "{x} -> {back}");
        }
    }

    #[test]
    fn invalid_axes_are_refused_with_the_axis_named() {
        let one = Axis::node_aligned("mu", 0.0, 1.0, 1).unwrap_err().to_string();
        assert!(one.contains("axis `mu`") && one.contains("at least 2"), "{one}");
        let empty = Axis::node_aligned("eta", 2.0, 2.0, 8).unwrap_err().to_string();
        assert!(empty.contains("empty"), "{empty}");
        let domain = Axis::node_aligned("alpha", -1.0, 1.0, 8).unwrap().with_mapping(Mapping::Sqrt);
        assert!(domain.unwrap_err().to_string().contains("domain"));
        assert!(Axis::node_aligned("x", 0.0, f64::NAN, 8).is_err());
    }

    #[test]
    fn formula_spells_out_the_half_texel_correction() {
        let axis = Axis::node_aligned("eta", 0.0, 4.0, 64).unwrap();
        assert_eq!(axis.texture_coordinate_formula(), "(eta / 4) * 63 / 64 + 0.5 / 64");
        let offset = Axis::node_aligned("d", -2.0, 2.0, 5)
            .unwrap()
            .with_mapping(Mapping::Asinh { scale: 0.5, centre: 0.0 })
            .unwrap();
        let m1 = 4.0f64.asinh();
        assert_eq!(
            offset.texture_coordinate_formula(),
            format!("((asinh(d / 0.5) + {m1}) / ({m1} + {m1})) * 4 / 5 + 0.5 / 5")
        );
    }

    #[test]
    fn the_new_spacings_round_trip_and_pack_their_nodes_where_stated() {
        let ends = Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap().with_mapping(Mapping::SqrtEnds).unwrap();
        let offset = Axis::node_aligned("d", -1.5, 1.5, 129)
            .unwrap()
            .with_mapping(Mapping::Asinh { scale: 1e-3, centre: 0.0 })
            .unwrap();
        for axis in [&ends, &offset] {
            for k in 0..axis.count {
                let x = axis.node_value(k);
                assert!((axis.coordinate(x) - axis.node_coordinate(k)).abs() < 1e-12, "{} node {k}", axis.name);
                // The f32 mapping a shader evaluates agrees to f32 rounding.
                let m = axis.mapping.forward(x);
                assert!((axis.mapping.forward_f32(x as f32) as f64 - m).abs() <= 4e-7 * m.abs().max(1.0), "{x}");
            }
        }
        // sqrt-ends: the first and last cells are a thousandth of mu wide, the middle ones ~0.022.
        let width = |axis: &Axis, k: usize| axis.node_value(k + 1) - axis.node_value(k);
        assert!(width(&ends, 0) < 1.1e-3 && width(&ends, 62) < 1.1e-3, "{} {}", width(&ends, 0), width(&ends, 62));
        assert!((0.02..0.03).contains(&width(&ends, 31)), "{}", width(&ends, 31));
        // asinh: offset 0 is the middle node of an odd count, its neighbours 1e-3 sinh(asinh(1500) / 64)
        // = 1.25e-4 away, the spacing growing 13 % a node to the ends at 1.5.
        assert_eq!(offset.node_value(64), 0.0);
        assert!((offset.node_value(65) - 1e-3 * (1500f64.asinh() / 64.0).sinh()).abs() < 1e-15);
        assert!(offset.node_value(65) < 1.3e-4, "{}", offset.node_value(65));
        assert_eq!((offset.node_value(0), offset.node_value(128)), (-1.5, 1.5));
        let bad =
            Axis::node_aligned("d", -1.0, 1.0, 4).unwrap().with_mapping(Mapping::Asinh { scale: 0.0, centre: 0.0 });
        assert!(bad.unwrap_err().to_string().contains("asinh scale"));
    }

    #[test]
    fn an_asinh_spacing_centred_off_zero_is_dense_at_its_centre_and_its_ramp_below() {
        // FGD's eta axis: 64 nodes over [0, 4] in asinh((eta - 1) / 0.25) + 2 min(eta - 1, 0).
        let ramp = Mapping::AsinhRampBelow { scale: 0.25, centre: 1.0, slope_below: 2.0 };
        let eta = Axis::node_aligned("eta", 0.0, 4.0, 64).unwrap().with_mapping(ramp).unwrap();
        for k in 0..eta.count {
            let x = eta.node_value(k);
            assert!((eta.coordinate(x) - eta.node_coordinate(k)).abs() < 1e-12, "node {k}");
            let m = eta.mapping.forward(x);
            assert!((eta.mapping.forward_f32(x as f32) as f64 - m).abs() <= 4e-7 * m.abs().max(1.0), "{x}");
        }
        // The ramp's inverse is exact at its ends and continuous through the centre.
        for x in [0.0, 0.3, 1.0 - 1e-12, 1.0, 1.0 + 1e-12, 2.5] {
            assert!((ramp.inverse(ramp.forward(x)) - x).abs() < 1e-13, "{x}");
        }
        let width = |k: usize| eta.node_value(k + 1) - eta.node_value(k);
        let at_one = eta.continuous_index(1.0).floor() as usize;
        // Without the ramp (scale 0.2) the first cell is 0.092 wide; with it every cell below 1 is
        // at most 0.04, and the cells grow to 0.35 at 4.
        assert!(
            width(at_one) < 0.03 && (0..at_one).all(|k| width(k) < 0.04) && width(62) > 0.3,
            "{} {} {}",
            width(at_one),
            width(0),
            width(62)
        );
        assert_eq!(eta.mapping.formula("eta"), "asinh((eta - 1.0) / 0.25) + 2.0 * min(eta - 1.0, 0)");
        let plain = Mapping::Asinh { scale: 0.2, centre: 1.0 };
        assert_eq!(plain.formula("eta"), "asinh((eta - 1.0) / 0.2)");
        // The ramp is a variant of its own in the manifest, which a reader without it refuses.
        let json = serde_json::to_string(&ramp).unwrap();
        assert_eq!(json, r#"{"asinh-ramp-below":{"scale":0.25,"centre":1.0,"slope_below":2.0}}"#);
        assert_eq!(serde_json::from_str::<Mapping>(&json).unwrap(), ramp);
        // The centre is omitted from the manifest where it is 0, so that axes written before it
        // existed read back equal.
        let json = serde_json::to_string(&Mapping::Asinh { scale: 0.5, centre: 0.0 }).unwrap();
        assert_eq!(json, r#"{"asinh":{"scale":0.5}}"#);
        assert_eq!(serde_json::from_str::<Mapping>(&json).unwrap(), Mapping::Asinh { scale: 0.5, centre: 0.0 });
        let bad =
            Axis::node_aligned("d", 0.0, 1.0, 4).unwrap().with_mapping(Mapping::Asinh { scale: 1.0, centre: f64::NAN });
        assert!(bad.unwrap_err().to_string().contains("asinh centre"));
        let falling = Axis::node_aligned("d", 0.0, 1.0, 4).unwrap().with_mapping(Mapping::AsinhRampBelow {
            scale: 1.0,
            centre: 0.5,
            slope_below: -1.0,
        });
        assert!(falling.unwrap_err().to_string().contains("slope below the centre -1"));
    }
}
