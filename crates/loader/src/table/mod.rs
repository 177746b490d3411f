//! The table model: axes, channels and f32 data, with multilinear interpolation exactly as each
//! axis's placement says.
//!
//! Storage order is the order of the original transfer-matrix tables and of GPU textures: channels
//! interleaved per texel, then axis 0 fastest, then axis 1, and so on.

mod axis;
pub mod derived;
pub mod kind;

pub use axis::{Arithmetic, Axis, Mapping, Placement};
pub use kind::{PerKind, TableKind, TableShape};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// One stored channel and what its value means.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// A short name (e.g. `scale`, `bias`, `value`).
    pub name: String,
    /// What the value is, in words.
    pub meaning: String,
    /// Parameters of the integral that this channel holds fixed, by name (a slice's `eta` and
    /// `kappa`): what a reader matches a lookup against.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub fixed: std::collections::BTreeMap<String, f64>,
}

impl Channel {
    /// A channel with nothing held fixed.
    pub fn new(name: impl Into<String>, meaning: impl Into<String>) -> Self {
        Channel { name: name.into(), meaning: meaning.into(), fixed: Default::default() }
    }

    /// The channel with parameter `name` held at `value`.
    pub fn with_fixed(mut self, name: &str, value: f64) -> Self {
        self.fixed.insert(name.into(), value);
        self
    }
}

/// Values of a table with these axes and `channels` channels; `None` if the count overflows.
pub fn value_count(axes: &[Axis], channels: usize) -> Option<usize> {
    axes.iter().try_fold(channels, |acc, a| acc.checked_mul(a.count))
}

fn shape_of(axes: &[Axis]) -> Vec<usize> {
    axes.iter().map(|a| a.count).collect()
}

/// Most axes [`Table::interpolate_into`] interpolates over (2^8 corners); tmlut writes tables of
/// one to four.
pub const MAX_INTERPOLATED_AXES: usize = 8;

/// Why a point could not be interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InterpolationError {
    /// The point does not have one coordinate per axis.
    #[error("a point of {given} coordinates given; the table has {axes} axes and needs one coordinate per axis")]
    AxisCount {
        /// The table's axes.
        axes: usize,
        /// The coordinates given.
        given: usize,
    },
    /// The output does not have room for exactly one value per channel.
    #[error("room for {given} values given; the table has {channels} channels and needs one per channel")]
    ChannelCount {
        /// The table's channels.
        channels: usize,
        /// The values the output has room for.
        given: usize,
    },
    /// The table has more than [`MAX_INTERPOLATED_AXES`] axes.
    #[error("the table has {axes} axes; interpolation handles at most {MAX_INTERPOLATED_AXES}")]
    TooManyAxes {
        /// The table's axes.
        axes: usize,
    },
    /// Sampled as a texture, the table has no texture's shape: it has more than three axes.
    #[error("the table has {axes} axes; a texture has 1 to 3")]
    NotATexture {
        /// The table's axes.
        axes: usize,
    },
}

impl From<InterpolationError> for Error {
    fn from(e: InterpolationError) -> Self {
        Error::invalid("point", e.to_string())
    }
}

/// A tabulated function of one to four parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The table's name (e.g. `karis`, `gd`), which messages name it by.
    pub name: String,
    /// One per parameter, axis 0 fastest in `data`.
    pub axes: Vec<Axis>,
    /// The values stored per node, in storage order.
    pub channels: Vec<Channel>,
    /// The values: channels interleaved per node, then axis 0 fastest, then axis 1, and so on.
    pub data: Vec<f32>,
}

/// Minimum, maximum and the count of non-finite values of a table's data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ValueStats {
    /// The smallest finite value (+infinity where there is none).
    pub min: f32,
    /// The largest finite value (-infinity where there is none).
    pub max: f32,
    /// How many values are NaN.
    pub nan_count: usize,
    /// How many values are infinite.
    pub infinite_count: usize,
}

impl Table {
    /// A table whose data length matches its axes and channels.
    pub fn new(name: impl Into<String>, axes: Vec<Axis>, channels: Vec<Channel>, data: Vec<f32>) -> Result<Self> {
        let name = name.into();
        if axes.is_empty() || channels.is_empty() {
            return Err(Error::invalid(&name, "a table needs at least one axis and one channel"));
        }
        for axis in &axes {
            axis.validate()?;
        }
        let expected = value_count(&axes, channels.len()).ok_or_else(|| {
            Error::invalid(
                &name,
                format!("axes of shape {:?} hold more values than memory can address", shape_of(&axes)),
            )
        })?;
        if data.len() != expected {
            return Err(Error::invalid(
                &name,
                format!("{} values given, the axes and channels need {expected}", data.len()),
            ));
        }
        Ok(Table { name, axes, channels, data })
    }

    /// A table of zeros, to be filled node by node.
    pub fn zeros(name: impl Into<String>, axes: Vec<Axis>, channels: Vec<Channel>) -> Result<Self> {
        let name = name.into();
        let len = value_count(&axes, channels.len()).ok_or_else(|| {
            Error::invalid(
                &name,
                format!("axes of shape {:?} hold more values than memory can address", shape_of(&axes)),
            )
        })?;
        Self::new(name, axes, channels, vec![0.0; len])
    }

    /// The number of axes.
    pub fn dimension(&self) -> usize {
        self.axes.len()
    }

    /// The number of channels.
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// Node counts, axis 0 first.
    pub fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(|a| a.count).collect()
    }

    /// Number of nodes (texels), all channels of a node counting once.
    pub fn node_count(&self) -> usize {
        self.axes.iter().map(|a| a.count).product()
    }

    /// The axis of the quantity `name` (e.g. `mu`, `alpha`), if the table has one.
    pub fn axis(&self, name: &str) -> Option<&Axis> {
        self.axes.iter().find(|a| a.name == name)
    }

    /// Linear node number of a multi-index (axis 0 fastest).
    pub fn node_number(&self, index: &[usize]) -> usize {
        debug_assert_eq!(index.len(), self.axes.len());
        index.iter().zip(&self.axes).rev().fold(0, |acc, (&i, axis)| acc * axis.count + i)
    }

    /// Multi-index of a linear node number; the inverse of [`Table::node_number`].
    pub fn node_index(&self, mut number: usize) -> Vec<usize> {
        self.axes
            .iter()
            .map(|axis| {
                let i = number % axis.count;
                number /= axis.count;
                i
            })
            .collect()
    }

    /// Parameter values at a node, one per axis.
    pub fn node_position(&self, index: &[usize]) -> Vec<f64> {
        index.iter().zip(&self.axes).map(|(&i, axis)| axis.node_value(i)).collect()
    }

    /// The stored values of all channels at a node.
    pub fn node(&self, index: &[usize]) -> &[f32] {
        let c = self.channels.len();
        let start = self.node_number(index) * c;
        &self.data[start..start + c]
    }

    /// Multilinear interpolation at a point given in the axes' own quantities (one per axis),
    /// with clamp addressing outside the range; one value per channel, computed in f64.
    ///
    /// Panics when `point` does not hold one coordinate per axis; [`Table::interpolate_into`]
    /// returns an error instead and allocates nothing.
    pub fn interpolate(&self, point: &[f64]) -> Vec<f64> {
        assert_eq!(point.len(), self.axes.len(), "{}: one coordinate per axis", self.name);
        let mut result = vec![0.0; self.channels.len()];
        if let Err(e) = self.interpolate_into(point, &mut result) {
            panic!("{}: {e}", self.name);
        }
        result
    }

    /// [`Table::interpolate`] into `out` (one value per channel), without allocating: an error
    /// when `point` does not hold one coordinate per axis, `out` not one value per channel, or the
    /// table has more than [`MAX_INTERPOLATED_AXES`] axes.
    pub fn interpolate_into(&self, point: &[f64], out: &mut [f64]) -> Result<(), InterpolationError> {
        let dimension = self.axes.len();
        if point.len() != dimension {
            return Err(InterpolationError::AxisCount { axes: dimension, given: point.len() });
        }
        if out.len() != self.channels.len() {
            return Err(InterpolationError::ChannelCount { channels: self.channels.len(), given: out.len() });
        }
        if dimension > MAX_INTERPOLATED_AXES {
            return Err(InterpolationError::TooManyAxes { axes: dimension });
        }
        let mut brackets = [(0usize, 0usize, 0.0f64); MAX_INTERPOLATED_AXES];
        for ((bracket, axis), &x) in brackets.iter_mut().zip(&self.axes).zip(point) {
            *bracket = axis.bracket(x);
        }
        let brackets = &brackets[..dimension];
        out.fill(0.0);
        let channels = self.channels.len();
        for corner in 0..(1usize << dimension) {
            let mut weight = 1.0;
            // The node number is accumulated last axis first, as `node_number` does.
            let mut number = 0usize;
            for (d, &(lower, upper, _)) in brackets.iter().enumerate().rev() {
                let take_upper = corner >> d & 1 == 1;
                number = number * self.axes[d].count + if take_upper { upper } else { lower };
            }
            for (d, &(_, _, t)) in brackets.iter().enumerate() {
                weight *= if corner >> d & 1 == 1 { t } else { 1.0 - t };
            }
            if weight == 0.0 {
                continue;
            }
            let start = number * channels;
            for (r, &v) in out.iter_mut().zip(&self.data[start..start + channels]) {
                *r += weight * v as f64;
            }
        }
        Ok(())
    }

    /// The range of the finite values and the count of the others, over all channels.
    pub fn stats(&self) -> ValueStats {
        let mut stats = ValueStats { min: f32::INFINITY, max: f32::NEG_INFINITY, nan_count: 0, infinite_count: 0 };
        for &v in &self.data {
            if v.is_nan() {
                stats.nan_count += 1;
            } else if v.is_infinite() {
                stats.infinite_count += 1;
            } else {
                stats.min = stats.min.min(v);
                stats.max = stats.max.max(v);
            }
        }
        stats
    }

    /// The values of one channel, in node order.
    pub fn channel_values(&self, channel: usize) -> impl Iterator<Item = f32> + '_ {
        self.data.iter().skip(channel).step_by(self.channels.len()).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp_table(placement: Placement) -> Table {
        // f(x, y) = x + 10 y, exactly representable by multilinear interpolation.
        let ax = Axis::new("x", 0.0, 1.0, 5, placement, Mapping::Identity).unwrap();
        let ay = Axis::new("y", 2.0, 0.0, 3, placement, Mapping::Identity).unwrap();
        let mut data = Vec::new();
        for j in 0..3 {
            for i in 0..5 {
                data.push((ax.node_value(i) + 10.0 * ay.node_value(j)) as f32);
            }
        }
        Table::new("ramp", vec![ax, ay], vec![Channel::new("v", "x + 10 y")], data).unwrap()
    }

    #[test]
    fn interpolation_reproduces_a_bilinear_function_inside_the_nodes() {
        for placement in [Placement::NodeAligned, Placement::CellCentred] {
            let table = ramp_table(placement);
            let (x0, x1) = (table.axes[0].node_value(0), table.axes[0].node_value(4));
            let (y0, y1) = (table.axes[1].node_value(0), table.axes[1].node_value(2));
            for (s, t) in [(0.0, 0.0), (0.3, 0.7), (1.0, 1.0), (0.55, 0.12)] {
                let x = x0 + s * (x1 - x0);
                let y = y0 + t * (y1 - y0);
                let v = table.interpolate(&[x, y])[0];
                assert!((v - (x + 10.0 * y)).abs() < 1e-5, "{placement:?} at ({x}, {y}): {v}");
            }
        }
    }

    #[test]
    fn interpolation_clamps_outside_the_range() {
        let table = ramp_table(Placement::NodeAligned);
        assert_eq!(table.interpolate(&[-3.0, 0.0])[0], table.interpolate(&[0.0, 0.0])[0]);
        assert_eq!(table.interpolate(&[0.5, 9.0])[0], table.interpolate(&[0.5, 2.0])[0]);
    }

    #[test]
    fn node_number_and_index_are_inverse() {
        let table = ramp_table(Placement::NodeAligned);
        for n in 0..table.node_count() {
            assert_eq!(table.node_number(&table.node_index(n)), n);
        }
        assert_eq!(table.node(&[4, 2])[0], table.data[14]);
    }

    #[test]
    fn wrong_data_length_is_refused() {
        let ax = Axis::node_aligned("x", 0.0, 1.0, 4).unwrap();
        let err = Table::new("t", vec![ax], vec![Channel::new("v", "")], vec![0.0; 3]).unwrap_err();
        assert!(err.to_string().contains("need 4"), "{err}");
    }

    #[test]
    fn stats_count_non_finite_values() {
        let ax = Axis::node_aligned("x", 0.0, 1.0, 4).unwrap();
        let t =
            Table::new("t", vec![ax], vec![Channel::new("v", "")], vec![0.5, f32::NAN, f32::INFINITY, -1.0]).unwrap();
        let s = t.stats();
        assert_eq!((s.min, s.max, s.nan_count, s.infinite_count), (-1.0, 0.5, 1, 1));
    }
}
