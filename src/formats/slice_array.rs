//! Packing the slices of a library into texture arrays; the manifest's description of an array,
//! the coordinates of a slice in it and the unpacking are the loader's
//! (`tmlut_loader::formats::slice_array`), re-exported here.
//!
//! Each layer is a fixed `width x height` texels; slices are placed on shelves (rows of slices,
//! tallest first, left to right), each inside a gutter of one texel that repeats its edge. Layers
//! hold at most [`MAX_LAYERS`] per array, the layer count every WebGPU device supports.

pub use tmlut_loader::formats::slice_array::*;

use super::LAYER_AXIS;
use crate::error::{Error, Result};
use crate::table::{Axis, Channel, Table};

/// Layers per array: WebGPU's default `maxTextureArrayLayers`, which every adapter supports
/// (Direct3D 11 allows 2048, Vulkan at least 256).
pub const MAX_LAYERS: usize = 256;

/// The height of a layer where the slices fill more than one: 256 texels (at most 129 nodes of
/// `alpha` plus gutters fit any slice).
pub const LAYER_HEIGHT: usize = 256;

/// Where a slice of `extent` texels (`[mu nodes, alpha nodes]`) goes: its layer and the texel of its
/// first node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    /// The layer, from 0.
    pub layer: usize,
    /// The texel of the slice's first node, `[x, y]`, inside its gutter.
    pub origin: [usize; 2],
}

/// The layout of slices of the given extents in layers of one extent: the layer extent, the number
/// of layers and each slice's slot, in input order. Deterministic: it depends on the extents
/// and their order only.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Texels per layer, `[width, height]`.
    pub layer_extent: [usize; 2],
    /// The number of layers.
    pub layers: usize,
    /// Each slice's slot, in the order the extents were given.
    pub slots: Vec<Slot>,
}

/// Shelf packing (next fit by decreasing height): slices sorted tallest first (input order among
/// equals) fill a shelf left to right; a shelf as tall as its first slice opens below the last
/// where one does not fit across; a layer opens where a shelf does not fit below. Each slice takes
/// its extent plus a gutter of one texel on every side. Layers are [`LAYER_HEIGHT`] tall and of the
/// width among [`LAYER_WIDTHS`] (or the widest slice's, or twice it) that takes the fewest texels.
/// An array has at least two layers (its layer axis, like every axis, at least two nodes): the
/// shelves of one layer are split over two lower ones where they allow it, else the second
/// layer stays empty.
pub fn layout(extents: &[[usize; 2]]) -> Layout {
    let widest = extents.iter().map(|e| e[0] + 2).max().unwrap_or(1);
    let tallest = extents.iter().map(|e| e[1] + 2).max().unwrap_or(1);
    let mut widths: Vec<usize> =
        [widest, 2 * widest].into_iter().chain(LAYER_WIDTHS).filter(|&w| w >= widest).collect();
    widths.sort_unstable();
    widths.dedup();
    let (best, used) = widths
        .into_iter()
        .map(|width| shelf_pack(extents, width, LAYER_HEIGHT.max(tallest)))
        .min_by_key(|(l, used)| l.layer_extent[0] * if l.layers == 1 { *used } else { l.layer_extent[1] * l.layers })
        .expect("at least one width");
    if best.layers != 1 {
        return best;
    }
    let width = best.layer_extent[0];
    (tallest.max(used.div_ceil(2))..=used)
        .map(|height| shelf_pack(extents, width, height).0)
        .find(|l| l.layers == 2)
        .unwrap_or(Layout { layer_extent: [width, used], layers: 2, slots: best.slots })
}

/// Layer widths [`layout`] tries beside the widest slice's.
pub const LAYER_WIDTHS: [usize; 4] = [256, 512, 1024, 2048];

/// The shelves of [`layout`] in layers `width x height`, and the rows the last layer uses.
fn shelf_pack(extents: &[[usize; 2]], width: usize, height: usize) -> (Layout, usize) {
    let mut order: Vec<usize> = (0..extents.len()).collect();
    order.sort_by_key(|&k| std::cmp::Reverse(extents[k][1]));
    let mut slots = vec![Slot { layer: 0, origin: [0, 0] }; extents.len()];
    let (mut layer, mut shelf_y, mut shelf_height, mut x) = (0, 0, 0, 0);
    for k in order {
        let [w, h] = [extents[k][0] + 2, extents[k][1] + 2];
        if x + w > width {
            shelf_y += shelf_height;
            x = 0;
            shelf_height = 0;
        }
        if shelf_y + h > height {
            layer += 1;
            shelf_y = 0;
            x = 0;
            shelf_height = 0;
        }
        slots[k] = Slot { layer, origin: [x + 1, shelf_y + 1] };
        x += w;
        shelf_height = shelf_height.max(h);
    }
    let layers = if extents.is_empty() { 0 } else { layer + 1 };
    (Layout { layer_extent: [width, height], layers, slots }, shelf_y + shelf_height)
}

/// The texel axes of an array: `x` and `y` of a layer, then the layers.
pub fn texel_axes(layer_extent: [usize; 2], layers: usize) -> Result<Vec<Axis>> {
    let axis = |name: &str, count: usize| Axis::node_aligned(name, 0.0, (count - 1) as f64, count);
    Ok(vec![axis("x", layer_extent[0])?, axis("y", layer_extent[1])?, axis(LAYER_AXIS, layers)?])
}

/// The slices (each a table of two axes with the same channel count) laid out by [`layout`] into
/// one array table named `name`, gutters repeating each slice's edge, texels of no slice zero.
/// Fails where the layout needs more than [`MAX_LAYERS`] layers: the caller splits the slices.
pub fn pack(name: &str, slices: &[&Table], channels: Vec<Channel>) -> Result<(Table, Layout)> {
    let extents: Vec<[usize; 2]> = slices.iter().map(|t| [t.axes[0].count, t.axes[1].count]).collect();
    let layout = layout(&extents);
    if layout.layers > MAX_LAYERS {
        return Err(Error::invalid(
            format!("texture array `{name}`"),
            format!("needs {} layers; allowed: at most {MAX_LAYERS}", layout.layers),
        ));
    }
    let c = channels.len();
    let [width, height] = layout.layer_extent;
    if slices.is_empty() {
        return Err(Error::invalid(format!("texture array `{name}`"), "holds no slice"));
    }
    let mut data = vec![0f32; width * height * layout.layers * c];
    for (slice, slot) in slices.iter().zip(&layout.slots) {
        if slice.channels.len() != c || slice.axes.len() != 2 {
            return Err(Error::invalid(
                format!("texture array `{name}`"),
                format!(
                    "slice `{}` has {} axes and {} channels; it needs 2 and {c}",
                    slice.name,
                    slice.axes.len(),
                    slice.channels.len()
                ),
            ));
        }
        let [nx, ny] = [slice.axes[0].count, slice.axes[1].count];
        // The gutter rows and columns (-1 and n) read the nearest node: clamp addressing.
        for gy in -1..=ny as isize {
            let sy = gy.clamp(0, ny as isize - 1) as usize;
            let ty = (slot.origin[1] as isize + gy) as usize;
            for gx in -1..=nx as isize {
                let sx = gx.clamp(0, nx as isize - 1) as usize;
                let tx = (slot.origin[0] as isize + gx) as usize;
                let from = (sy * nx + sx) * c;
                let to = ((slot.layer * height + ty) * width + tx) * c;
                data[to..to + c].copy_from_slice(&slice.data[from..from + c]);
            }
        }
    }
    let table = Table::new(name, texel_axes(layout.layer_extent, layout.layers)?, channels, data)?;
    Ok((table, layout))
}

/// The texture coordinate of `axis` of a slice in an array whose layers are `extent` texels along
/// it, the slice's first node at texel `origin`: the node position clamped to the slice, shifted
/// to its texels. As a formula over the axis's quantity, for the manifest.
pub fn texture_coordinate_formula(axis: &Axis, origin: u32, extent: usize) -> String {
    let m0 = axis.mapping.forward(axis.start);
    let m1 = axis.mapping.forward(axis.end);
    let mapped = axis.mapping.formula(&axis.name);
    let minus_m0 = if m0 < 0.0 { format!("+ {}", -m0) } else { format!("- {m0}") };
    format!("({origin} + 0.5 + clamp(({mapped} {minus_m0}) / ({m1} {minus_m0}), 0, 1) * {}) / {extent}", axis.count - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::manifest::{AxisEntry, ErrorEntry};
    use crate::table::Mapping;

    fn slice(name: &str, nx: usize, ny: usize, channels: usize, seed: f32) -> Table {
        let axes = vec![
            Axis::node_aligned("mu", 0.25, 1.0, nx).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
            Axis::node_aligned("alpha", 0.1, 0.2, ny).unwrap(),
        ];
        let data = (0..nx * ny * channels).map(|i| seed + i as f32 * 0.5).collect();
        let channels = (0..channels).map(|c| Channel::new(format!("c{c}"), "")).collect();
        Table::new(name, axes, channels, data).unwrap()
    }

    fn entry_of(table: &Table, slot: Slot) -> ArraySlice {
        ArraySlice::new(
            table.name.clone(),
            slot.layer as u32,
            slot.origin.map(|o| o as u32),
            table.axes.iter().map(|a| AxisEntry::new(a, "x")).collect(),
            table.channels.clone(),
            [0.0, 0.0],
            ErrorEntry::default(),
        )
    }

    #[test]
    fn slices_never_overlap_with_their_gutters_and_stay_inside_their_layer() {
        // Extents as a library's FGD and TIR slices have them, enough to need several layers.
        let extents: Vec<[usize; 2]> =
            (0..900).map(|k| [20 + (k * 37) % 110, 2 + (k * 13) % 12]).chain([[129, 2], [513, 129]]).collect();
        let layout = layout(&extents);
        assert!(layout.layers > 1);
        let [width, height] = layout.layer_extent;
        let mut owner = vec![usize::MAX; width * height * layout.layers];
        for (k, (slot, e)) in layout.slots.iter().zip(&extents).enumerate() {
            assert!(slot.origin[0] >= 1 && slot.origin[1] >= 1, "{k}");
            assert!(slot.origin[0] + e[0] < width && slot.origin[1] + e[1] < height, "{k}: {slot:?} {e:?}");
            for y in slot.origin[1] - 1..=slot.origin[1] + e[1] {
                for x in slot.origin[0] - 1..=slot.origin[0] + e[0] {
                    let texel = &mut owner[(slot.layer * height + y) * width + x];
                    assert_eq!(*texel, usize::MAX, "slices {} and {k} overlap at {x}, {y}", *texel);
                    *texel = k;
                }
            }
        }
    }

    #[test]
    fn the_shelves_of_one_layer_are_split_over_two() {
        let layout = layout(&[[129, 2], [129, 2], [33, 3]]);
        // Three shelves of 5, 4 and 4 rows in 131 columns (256 columns would take more texels): the
        // first in one layer, the other two in the second.
        assert_eq!((layout.layers, layout.layer_extent), (2, [131, 8]));
        assert_eq!(layout.slots[2], Slot { layer: 0, origin: [1, 1] });
        assert_eq!(layout.slots[1], Slot { layer: 1, origin: [1, 5] });
        // One shelf cannot be split: the second layer stays empty.
        let single = super::layout(&[[10, 2]]);
        assert_eq!((single.layers, single.layer_extent), (2, [12, 4]));
    }

    #[test]
    fn every_slice_unpacks_to_itself_and_its_gutter_repeats_its_edge() {
        let slices: Vec<Table> =
            (0..40).map(|k| slice(&format!("s{k}"), 5 + k % 7, 2 + k % 3, 2, k as f32 * 100.0)).collect();
        let refs: Vec<&Table> = slices.iter().collect();
        let (array, layout) = pack("fgd_slices", &refs, slices[0].channels.clone()).unwrap();
        let [width, height] = layout.layer_extent;
        for (table, slot) in slices.iter().zip(&layout.slots) {
            assert_eq!(&unpack(&array, &entry_of(table, *slot)).unwrap(), table);
            // The texel left of the first node and the one below the last node hold copies.
            let at = |x: usize, y: usize, c: usize| array.data[((slot.layer * height + y) * width + x) * 2 + c];
            let [x0, y0] = slot.origin;
            let [nx, ny] = [table.axes[0].count, table.axes[1].count];
            assert_eq!(at(x0 - 1, y0, 1), table.data[1]);
            assert_eq!(at(x0 + nx, y0 + ny, 0), table.data[(ny * nx - 1) * 2]);
        }
    }

    #[test]
    fn the_coordinate_formula_and_its_f32_evaluation_agree_on_the_nodes() {
        let axis = Axis::node_aligned("mu", 0.25, 1.0, 9).unwrap().with_mapping(Mapping::Sqrt).unwrap();
        let formula = texture_coordinate_formula(&axis, 7, 64);
        assert!(formula.starts_with("(7 + 0.5 + clamp((sqrt(mu) - 0.5) / (1 - 0.5), 0, 1) * 8) / 64"), "{formula}");
        for k in 0..9 {
            let u = texture_coordinate(&axis, 7, 64, axis.node_value(k));
            assert!((u * 64.0 - (7.5 + k as f32)).abs() < 1e-4, "node {k}: {u}");
        }
        // Outside the slice the coordinate stays on its end nodes.
        assert_eq!(texture_coordinate(&axis, 7, 64, 0.0), 7.5 / 64.0);
    }
}
