//! Texture arrays of slices: the many small `(mu, alpha)` slices of a library (`docs/scenes.md`,
//! "What a renderer binds") packed into a few arrays of 2D textures, so that a renderer binds a
//! handful of textures, not one per slice.
//!
//! Slices of one kind, channel count and precision share an array. Each slice lies inside a
//! gutter of one texel that repeats its edge. Read with its coordinate clamped to its own nodes,
//! a slice then filters exactly as it would as a texture of its own with clamp addressing, by the
//! hardware sampler as by explicit texel loads: a bilinear footprint that reaches past the last
//! node reaches a copy of it. How tmlut places the slices in layers (shelves, tallest first) is
//! the writing side's, tmlut's `formats::slice_array`.
//!
//! The manifest entry of an array lists each slice it holds ([`ArraySlice`]): its name, layer, the
//! texel of its first node, its axes and channels as its own file would state them, and the
//! texture coordinate of each axis in the array. [`unpack`] cuts a slice back out.

use serde::{Deserialize, Serialize};

use super::manifest::{AxisEntry, ErrorEntry};
use crate::error::{Error, Result};
use crate::stats::AccuracyReport;
use crate::table::{Arithmetic, Axis, Channel, Table};

/// The manifest's description of a texture array of slices (`FileEntry::slice_array`). The
/// entry's own `axes` are the array's texel axes (`x`, `y`, [`super::LAYER_AXIS`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct SliceArrayEntry {
    /// Texels per layer, `[width, height]`, and the number of layers.
    pub layer_extent: [u32; 2],
    /// The number of layers.
    pub layers: u32,
    /// Every slice the array holds, with where it lies.
    pub slices: Vec<ArraySlice>,
}

/// One slice of a texture array.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ArraySlice {
    /// The slice's table name (what its own file would be called, without the extension).
    pub table: String,
    /// The layer holding it.
    pub layer: u32,
    /// The texel holding its first node (node 0 of `mu` and of `alpha`), `[x, y]`; its gutter is
    /// the texel before and after it along each axis.
    pub origin: [u32; 2],
    /// Its axes, with the texture coordinate of each *in the array*: the node position clamped
    /// to the slice, plus the origin and half a texel, over the layer's extent.
    pub axes: Vec<AxisEntry>,
    /// Each channel's name and meaning, in storage order.
    pub channels: Vec<Channel>,
    /// `[min, max]` of the slice's finite values in f32, before rounding to the array's precision.
    pub value_range: [f32; 2],
    /// Its integration, storage and interpolation error, as its own file's entry states them.
    pub error: ErrorEntry,
    /// Further measured accuracy figures, as its own file's entry states them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub accuracy: Vec<AccuracyReport>,
}

impl SliceArrayEntry {
    /// An array of `layers` layers of `layer_extent` texels holding `slices`.
    pub fn new(layer_extent: [u32; 2], layers: u32, slices: Vec<ArraySlice>) -> Self {
        SliceArrayEntry { layer_extent, layers, slices }
    }
}

impl ArraySlice {
    /// The slice `table` at `origin` of `layer`, over `axes` (their coordinates in the array),
    /// with `channels`, values over `value_range` and `error`; no further accuracy figures yet.
    pub fn new(
        table: impl Into<String>,
        layer: u32,
        origin: [u32; 2],
        axes: Vec<AxisEntry>,
        channels: Vec<Channel>,
        value_range: [f32; 2],
        error: ErrorEntry,
    ) -> Self {
        ArraySlice { table: table.into(), layer, origin, axes, channels, value_range, error, accuracy: Vec::new() }
    }

    /// Its axes as quantities, without the array's texture-coordinate formulas.
    pub fn axes(&self) -> Vec<Axis> {
        self.axes.iter().map(|a| a.axis.clone()).collect()
    }
}

/// The slice `slice` of `array` (as tmlut packs it): its nodes copied out of their layer, as a
/// table of its own axes and channels. Fails, naming the slice, where the manifest places it
/// outside the array.
pub fn unpack(array: &Table, slice: &ArraySlice) -> Result<Table> {
    let refuse =
        |what: String| Error::invalid(format!("slice `{}` of texture array `{}`", slice.table, array.name), what);
    let axes = slice.axes();
    if array.axes.len() != 3 || axes.len() != 2 || slice.channels.len() != array.channels.len() {
        return Err(refuse(format!(
            "states {} axes and {} channels in an array of {} axes and {} channels; a slice has 2 axes and the array's channels",
            axes.len(),
            slice.channels.len(),
            array.axes.len(),
            array.channels.len()
        )));
    }
    let [width, height, layers] = [0, 1, 2].map(|d| array.axes[d].count);
    let [nx, ny] = [axes[0].count, axes[1].count];
    let [x0, y0] = slice.origin.map(|o| o as usize);
    let layer = slice.layer as usize;
    if layer >= layers || x0 == 0 || y0 == 0 || x0 + nx + 1 > width || y0 + ny + 1 > height {
        return Err(refuse(format!(
            "is placed at layer {layer}, texel ({x0}, {y0}) with {nx} x {ny} nodes and its gutter, outside the array's {layers} layers of {width} x {height}"
        )));
    }
    let c = array.channels.len();
    let mut data = Vec::with_capacity(nx * ny * c);
    for y in 0..ny {
        let row = ((layer * height + y0 + y) * width + x0) * c;
        data.extend_from_slice(&array.data[row..row + nx * c]);
    }
    Table::new(&slice.table, axes, slice.channels.clone(), data)
}

/// The texture coordinate of value `x` along `axis` of a slice in an array whose layers are
/// `extent` texels along it, the slice's first node at texel `origin`: the node position clamped
/// to the slice, shifted to its texels, in f32 as a shader computes it (the formula the manifest
/// states for the axis, `texture_coordinate`).
pub fn texture_coordinate(axis: &Axis, origin: u32, extent: usize, x: f64) -> f32 {
    texture_coordinate_in(axis, origin, extent, x as f32)
}

/// [`texture_coordinate`] in the arithmetic of `x` (the scene shader prints it).
pub fn texture_coordinate_in<T: Arithmetic>(axis: &Axis, origin: u32, extent: usize, x: T) -> T {
    let t = axis.coordinate_in(x).clamp(T::of(0.0), T::of(1.0));
    (T::of(origin as f64 + 0.5) + t * T::of((axis.count - 1) as f64)) / T::of(extent as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::{ErrorRecord, ErrorSummary};
    use crate::table::Mapping;

    /// An array of 2 layers of 8 x 5 texels, 2 channels, each texel holding its own index.
    fn array() -> Table {
        let axes = vec![
            Axis::node_aligned("x", 0.0, 7.0, 8).unwrap(),
            Axis::node_aligned("y", 0.0, 4.0, 5).unwrap(),
            Axis::node_aligned(crate::formats::LAYER_AXIS, 0.0, 1.0, 2).unwrap(),
        ];
        let data = (0..8 * 5 * 2 * 2).map(|i| i as f32).collect();
        Table::new("fgd_array_rg", axes, vec![Channel::new("c0", ""), Channel::new("c1", "")], data).unwrap()
    }

    /// The entry of a slice of `nx` x `ny` nodes at `origin` of `layer`.
    fn slice(layer: u32, origin: [u32; 2], [nx, ny]: [usize; 2]) -> ArraySlice {
        let axes =
            [Axis::node_aligned("mu", 0.25, 1.0, nx).unwrap(), Axis::node_aligned("alpha", 0.1, 0.2, ny).unwrap()];
        let no_error = ErrorSummary { count: 0, rms: 0.0, max: 0.0 };
        ArraySlice {
            table: "fgd_a".into(),
            layer,
            origin,
            axes: axes.iter().zip(["x", "y"]).map(|(a, along)| AxisEntry::new(a, along)).collect(),
            channels: array().channels,
            value_range: [0.0, 0.0],
            error: ErrorEntry {
                integration: ErrorRecord { replicate_standard_error: no_error, reference: None },
                storage_rounding_max: 0.0,
                storage_channel_sum: None,
                interpolation: Vec::new(),
            },
            accuracy: Vec::new(),
        }
    }

    #[test]
    fn a_slice_unpacks_to_its_nodes_inside_its_gutter() {
        let unpacked = unpack(&array(), &slice(1, [2, 1], [3, 2])).unwrap();
        assert_eq!(unpacked.name, "fgd_a");
        assert_eq!(unpacked.shape(), [3, 2]);
        // Texel (x, y) of layer 1 is node (x - 2, y - 1); its index is ((1 * 5 + y) * 8 + x) * 2 + c.
        let index = |x: usize, y: usize, c: usize| (((5 + y) * 8 + x) * 2 + c) as f32;
        assert_eq!(unpacked.node(&[0, 0]), [index(2, 1, 0), index(2, 1, 1)]);
        assert_eq!(unpacked.node(&[2, 1]), [index(4, 2, 0), index(4, 2, 1)]);
    }

    #[test]
    fn a_slice_placed_outside_its_array_is_refused_with_its_name() {
        for (layer, origin) in [(0, [3, 0]), (2, [1, 1]), (0, [5, 1]), (0, [1, 3])] {
            let error = unpack(&array(), &slice(layer, origin, [3, 2])).unwrap_err().to_string();
            assert!(error.contains("fgd_a") && error.contains("outside the array"), "{layer} {origin:?}: {error}");
        }
        let mut one_channel = slice(0, [1, 1], [3, 2]);
        one_channel.channels.pop();
        assert!(unpack(&array(), &one_channel).unwrap_err().to_string().contains("a slice has 2 axes"));
    }

    #[test]
    fn the_coordinate_lies_on_the_slices_texels_and_stays_on_its_end_nodes() {
        let axis = Axis::node_aligned("mu", 0.25, 1.0, 9).unwrap().with_mapping(Mapping::Sqrt).unwrap();
        for k in 0..9 {
            let u = texture_coordinate(&axis, 7, 64, axis.node_value(k));
            assert!((u * 64.0 - (7.5 + k as f32)).abs() < 1e-4, "node {k}: {u}");
        }
        assert_eq!(texture_coordinate(&axis, 7, 64, 0.0), 7.5 / 64.0);
        assert_eq!(texture_coordinate(&axis, 7, 64, 2.0), 15.5 / 64.0);
    }
}
