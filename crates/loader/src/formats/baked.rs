//! Baked materials: each material of a scene, its whole transfer-matrix result tabulated along the
//! view cosine, as rows of one texture array (tmlut's `bake`; `docs/bake.md`).
//!
//! Every material takes `rows` consecutive rows of one layer, each row `nodes` RGBA texels wide:
//! row `r` holds values `4r..4r + 4` of the material's result at each node, in the order its entry
//! names them ([`BakedMaterialEntry::values`]; zeros past the last). Layers are a power of two
//! rows high, so that a row's centre `(row + 0.5) / height` is exact in f32 and a linear filter
//! gives the rows above and below it a weight of exactly 0: one filtered sample reads one row.
//! Along the row the nodes are placed segment by segment, and a shader finds the texture
//! coordinate of `mu` from `u = sqrt(mu)` by its segment's affine map ([`texture_coordinate`]).
//!
//! A material whose textures vary parameters ([`BakedMaterialEntry::varied`]) has one block of
//! those rows per node of its parameters, blocks one under the other, the first parameter's
//! nodes fastest; a read blends the blocks of the two nodes around each parameter's value, in f32,
//! the first parameter first ([`parameter_taps`], [`sample`]).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::filter::{Filter, lerp, linear_taps};
use crate::table::Table;

/// The manifest's description of a texture array of baked materials (`FileEntry::baked`). The
/// entry's own `axes` are the array's texel axes (`x`: node, `y`: row, [`super::LAYER_AXIS`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct BakedArrayEntry {
    /// The scene (or library) whose materials these are.
    pub scene: String,
    /// What the model read its integrals from when it was baked, in words.
    pub source: String,
    /// Nodes along `mu` per row: the layer's width.
    pub nodes: u32,
    /// The interpolation error a kink or a segment's curvature was allowed before the nodes were
    /// placed on it or the segment cut (tmlut's `BakeSettings::tolerance`).
    pub tolerance: f64,
    /// Texels per layer, `[width, height]`; the height is a power of two.
    pub layer_extent: [u32; 2],
    /// The number of layers.
    pub layers: u32,
    /// How a shader reads a material, in words and symbols.
    pub lookup: String,
    /// Every material, with where it lies.
    pub materials: Vec<BakedMaterialEntry>,
    /// The scene's materials the array does not hold, and why (a parameter a texture varies).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub left_out: Vec<super::manifest::LeftOutRecord>,
    /// The baked shader's files (`<stem>.baked.wgsl`, `.baked.hlsl`, `.baked.shader.json`), each
    /// with its length and SHA-256, verified by `tmlut check` and the loader.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shader_files: Vec<super::manifest::SceneShaderFile>,
}

/// One baked material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct BakedMaterialEntry {
    /// The material's name in its scene.
    pub material: String,
    /// The lobes its model returns.
    pub lobes: u32,
    /// The layer holding its rows.
    pub layer: u32,
    /// Its first row in that layer.
    pub first_row: u32,
    /// Its rows: `ceil(values / 4)`.
    pub rows: u32,
    /// The segments of `u = sqrt(mu)` its nodes are uniform in, each with its map to the texture
    /// coordinate, in increasing `u`; the first starts at 0.
    pub segments: Vec<BakedSegment>,
    /// What each stored value is, in storage order: value `i` is channel `i % 4` of row `i / 4`.
    pub values: Vec<String>,
    /// The parameters its textures vary, each an axis of blocks of its rows; none where nothing
    /// varies (one block).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub varied: Vec<BakedAxis>,
    /// How far the stored rows, read as a GPU filters them, are from the model.
    pub error: BakedErrors,
}

/// A parameter a material's textures vary, baked as an axis: one block of the material's rows per
/// node, uniform across the range the scene declares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedAxis {
    /// The parameter, in words: `layer 1 alpha` (layers counted from 1 at the top).
    pub parameter: String,
    /// The range a texture varies it over, `[lo, hi]`, as the scene declares it.
    pub range: [f64; 2],
    /// The value read where a caller gives none: the material's own.
    pub nominal: f64,
    /// Nodes across the range (at least 2), each a block of the material's rows.
    pub nodes: u32,
    /// Where the nodes lie: `uniform`, node `j` at `lo + j (hi - lo) / (nodes - 1)`.
    pub spacing: String,
    /// The map from a value to its node coordinate in the f32 a shader holds,
    /// `t = (value - start) * scale`: node `j` at `t = j`. `start` is the range's `lo`.
    pub start: f32,
    /// Node coordinate per unit of the value: `(nodes - 1) / (hi - lo)`.
    pub scale: f32,
}

/// [`BakedAxis::spacing`] of nodes evenly spread across the range.
pub const UNIFORM_SPACING: &str = "uniform";

impl BakedAxis {
    /// The axis of `parameter` over `range`, read at `nominal` where no value is given, with
    /// `nodes` nodes uniform across the range.
    pub fn uniform(parameter: impl Into<String>, range: [f64; 2], nominal: f64, nodes: u32) -> Self {
        let [lo, hi] = range;
        BakedAxis {
            parameter: parameter.into(),
            range,
            nominal,
            nodes,
            spacing: UNIFORM_SPACING.into(),
            start: lo as f32,
            scale: ((f64::from(nodes) - 1.0) / (hi - lo)) as f32,
        }
    }

    /// The value of node `j`.
    pub fn node(&self, j: usize) -> f64 {
        let [lo, hi] = self.range;
        lo + (hi - lo) * j as f64 / (f64::from(self.nodes) - 1.0)
    }
}

/// One segment of a baked material's nodes, in the f32 a shader holds: where it starts in `u`,
/// and the map from `u` to the texture coordinate along the row, `x = u * slope + offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BakedSegment {
    /// Where it starts in `u = sqrt(mu)`.
    pub u_start: f32,
    /// Texture coordinate per unit of `u`.
    pub slope: f32,
    /// Texture coordinate at `u = 0` of its line.
    pub offset: f32,
}

/// The largest difference of one kind between a baked material and its model, and where.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Worst {
    /// The largest difference (weighted as its kind states).
    pub max: f64,
    /// The view cosine of the largest difference.
    pub at_mu: f64,
    /// The value it is of (`lobe 2 roughness`), in words.
    pub value: String,
    /// The values of the material's varied parameters there ([`BakedMaterialEntry::varied`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_varied: Vec<f64>,
}

impl Worst {
    /// No difference yet.
    pub fn none() -> Self {
        Worst { max: 0.0, at_mu: 1.0, value: String::new(), at_varied: Vec::new() }
    }

    /// Keep `difference` at `mu`, of the value `value` names, where it is the largest so far.
    pub fn take(&mut self, difference: f64, mu: f64, value: impl FnOnce() -> String) {
        if difference > self.max {
            *self = Worst { max: difference, at_mu: mu, value: value(), at_varied: Vec::new() };
        }
    }
}

/// A baked material's errors against its model, over `views` view cosines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedErrors {
    /// What the baked values were compared with, in words.
    #[serde(default)]
    pub against: String,
    /// The albedo and the top albedo, per channel.
    pub albedo: Worst,
    /// Each lobe's energy, per channel.
    pub lobe_energy: Worst,
    /// Each lobe's roughness, weighted by the lobe's largest energy.
    pub lobe_roughness: Worst,
    /// Each lobe's mean-direction cosine, weighted by the lobe's largest energy.
    pub lobe_cos: Worst,
    /// Each lobe's GD, weighted by the lobe's largest energy.
    pub lobe_gd: Worst,
    /// View cosines compared.
    pub views: usize,
}

impl BakedErrors {
    /// No difference yet, against what `against` says.
    pub fn none(against: impl Into<String>) -> Self {
        BakedErrors {
            against: against.into(),
            albedo: Worst::none(),
            lobe_energy: Worst::none(),
            lobe_roughness: Worst::none(),
            lobe_cos: Worst::none(),
            lobe_gd: Worst::none(),
            views: 0,
        }
    }

    /// The largest of the five (the first of equals).
    pub fn worst(&self) -> &Worst {
        [&self.lobe_gd, &self.lobe_cos, &self.lobe_roughness, &self.lobe_energy, &self.albedo]
            .into_iter()
            .max_by(|a, b| a.max.total_cmp(&b.max))
            .expect("five kinds")
    }

    /// The largest difference of the five.
    pub fn max(&self) -> f64 {
        self.worst().max
    }

    /// These errors, measured with the varied parameters at `varied`, folded into `self`: the
    /// larger of each kind kept, with the values it was measured at, and the views added up.
    pub fn fold(&mut self, mut other: BakedErrors, varied: &[f64]) {
        self.views += other.views;
        for (mine, theirs) in self.kinds_mut().into_iter().zip(other.kinds_mut()) {
            if theirs.max > mine.max {
                *mine = Worst { at_varied: varied.to_vec(), ..theirs.clone() };
            }
        }
    }

    fn kinds_mut(&mut self) -> [&mut Worst; 5] {
        [&mut self.albedo, &mut self.lobe_energy, &mut self.lobe_roughness, &mut self.lobe_cos, &mut self.lobe_gd]
    }
}

impl BakedMaterialEntry {
    /// The entry of `material`, of `lobes` lobes, its rows from `first_row` of `layer` holding
    /// `values` (named in storage order, four to a row) at nodes placed by `segments`, a block of
    /// them per node of the `varied` axes, `error` from its model.
    pub fn new(
        material: impl Into<String>,
        lobes: u32,
        (layer, first_row): (u32, u32),
        segments: Vec<BakedSegment>,
        values: Vec<String>,
        varied: Vec<BakedAxis>,
        error: BakedErrors,
    ) -> Self {
        let rows = values.len().div_ceil(4) as u32;
        BakedMaterialEntry { material: material.into(), lobes, layer, first_row, rows, segments, values, varied, error }
    }

    /// Blocks of rows: one per combination of the varied parameters' nodes (1 where none varies).
    pub fn blocks(&self) -> u64 {
        self.varied.iter().fold(1u64, |blocks, a| blocks.saturating_mul(u64::from(a.nodes)))
    }

    /// Rows the material takes in its layer: `rows` per block.
    pub fn rows_taken(&self) -> u64 {
        u64::from(self.rows).saturating_mul(self.blocks())
    }

    /// Where its values lie and how they are read, for [`sample`], in rows `nodes` texels wide.
    pub fn shape(&self, nodes: usize) -> BakedShape<'_> {
        BakedShape {
            segments: &self.segments,
            axes: &self.varied,
            nodes,
            rows: self.rows as usize,
            values: self.values.len(),
        }
    }
}

impl BakedArrayEntry {
    /// The entry of an array of `layers` layers of `layer_extent` texels, `nodes` wide, holding
    /// `materials` of `scene`, baked from `source` with `tolerance`.
    pub fn new(
        scene: impl Into<String>,
        source: impl Into<String>,
        tolerance: f64,
        layer_extent: [u32; 2],
        layers: u32,
        materials: Vec<BakedMaterialEntry>,
    ) -> Self {
        BakedArrayEntry {
            scene: scene.into(),
            source: source.into(),
            nodes: layer_extent[0],
            tolerance,
            layer_extent,
            layers,
            lookup: match materials.iter().any(|m| !m.varied.is_empty()) {
                false => LOOKUP.into(),
                true => format!("{LOOKUP}{VARIED_LOOKUP}"),
            },
            materials,
            left_out: Vec::new(),
            shader_files: Vec::new(),
        }
    }

    /// The entry of the material named `material`.
    pub fn material(&self, material: &str) -> Option<&BakedMaterialEntry> {
        self.materials.iter().find(|m| m.material == material)
    }

    /// Where a material's rows must lie, checked against the array's extent: refused, naming the
    /// material, where they do not.
    pub fn check(&self, array: &Table) -> Result<()> {
        let refuse = |what: String| Error::invalid(format!("baked array `{}`", array.name), what);
        let [width, height, layers] = match array.axes.as_slice() {
            [x, y, z] if array.channels.len() == 4 => [x.count, y.count, z.count],
            _ => return Err(refuse("is not an array of RGBA layers (3 axes, 4 channels)".into())),
        };
        if [width as u32, height as u32] != self.layer_extent || layers as u32 != self.layers {
            return Err(refuse(format!(
                "holds {layers} layers of {width} x {height} texels where its entry states {} of {:?}",
                self.layers, self.layer_extent
            )));
        }
        if !height.is_power_of_two() {
            return Err(refuse(format!("has layers {height} rows high; a baked array's are a power of two")));
        }
        for m in &self.materials {
            let axes_hold_nodes = m.varied.iter().all(|a| a.nodes >= 2 && a.scale.is_finite() && a.start.is_finite());
            let taken = u64::from(m.first_row).saturating_add(m.rows_taken());
            let fits = (m.layer as usize) < layers && taken <= height as u64;
            let rows_hold_values = m.values.len().div_ceil(4) == m.rows as usize && m.rows > 0;
            let segments_start_at_0 = m.segments.first().is_some_and(|s| s.u_start == 0.0)
                && m.segments.windows(2).all(|w| w[0].u_start < w[1].u_start);
            if !fits || !rows_hold_values || !segments_start_at_0 || !axes_hold_nodes {
                return Err(refuse(format!(
                    "places material `{}` at layer {}, rows {} to {taken} with {} values, {} segments and {} varied \
                     parameters: its rows must lie in one of the {layers} layers of {height} rows, hold its values four \
                     to a row, its segments start at u = 0 in increasing order, and each varied parameter have 2 nodes \
                     or more and a finite map",
                    m.material,
                    m.layer,
                    m.first_row,
                    m.values.len(),
                    m.segments.len(),
                    m.varied.len()
                )));
            }
        }
        Ok(())
    }
}

/// How a shader reads a baked material, as the manifest states it.
pub const LOOKUP: &str = "u = sqrt(clamp(mu, 0, 1)); s = the last segment with u >= u_start; \
    x = u * slope_s + offset_s; for each row r: texel = textureSampleLevel(array, linear clamp sampler, \
    (x, (first_row + r + 0.5) / height), layer, 0); value 4r + c = texel[c]";

/// What [`LOOKUP`] adds where a material of the array varies parameters.
pub const VARIED_LOOKUP: &str = ". A material with varied parameters: per parameter a (value v, its varied \
    entry's start, scale and nodes n), t = (v - start) * scale clamped to [0, n - 1] (NaN as 0), \
    j = min(floor(t), n - 2), w = t - j; block (j_0, j_1) holds rows from first_row + rows * (j_0 + n_0 j_1); \
    the texels of blocks j and j + 1 blended as (1 - w) a + w b, the first parameter first";

/// The texture coordinate along a baked row of view cosine `mu` (clamped to [0, 1]; NaN reads as
/// grazing, as the model reads it), in f32 as a shader computes it: `u = sqrt(mu)`, then the map
/// of the last segment whose start `u` reaches.
pub fn texture_coordinate(segments: &[BakedSegment], mu: f32) -> f32 {
    let mu = if mu.is_nan() { 0.0 } else { mu.clamp(0.0, 1.0) };
    let u = mu.sqrt();
    match segments.iter().rev().find(|s| u >= s.u_start).or(segments.first()) {
        Some(s) => u * s.slope + s.offset,
        None => 0.0,
    }
}

/// The texture coordinate of the centre of row `row` of a layer `height` rows high: exact in f32
/// for a power-of-two height, so that a linear filter reads that row alone.
pub fn row_coordinate(row: u32, height: u32) -> f32 {
    (row as f32 + 0.5) / height as f32
}

/// The node below a varied parameter's `value` and the weight of the node above, in f32 as a
/// shader computes them: `t = (value - start) * scale` clamped to `[0, nodes - 1]` (NaN reads as
/// 0, the range's start), `j = min(floor(t), nodes - 2)`, `w = t - j`.
pub fn parameter_taps(axis: &BakedAxis, value: f32) -> (usize, f32) {
    let last = (axis.nodes.max(2) - 1) as f32;
    let t = (value - axis.start) * axis.scale;
    let t = if t > 0.0 { t.min(last) } else { 0.0 };
    let node = t.floor().min(last - 1.0);
    (node as usize, t - node)
}

/// What [`sample`] needs of a material: where its nodes lie along `mu` and across its varied
/// parameters, and its rows.
#[derive(Debug, Clone, Copy)]
pub struct BakedShape<'a> {
    /// Its segments along `u = sqrt(mu)`.
    pub segments: &'a [BakedSegment],
    /// Its varied parameters, the first blended first.
    pub axes: &'a [BakedAxis],
    /// Nodes along a row.
    pub nodes: usize,
    /// Rows of one block.
    pub rows: usize,
    /// Values it stores, `rows` four to a row at most.
    pub values: usize,
}

/// The values of a material of `shape` read at view cosine `mu` and at `varied`, one value per
/// varied parameter (a parameter past those given read at its nominal value), from `texel(row,
/// node)` (rows counted from the material's first, blocks one under the other) as a GPU's linear
/// filter reads the array: along the row only (a row's centre gives its neighbours no weight),
/// then blended between the blocks of the nodes around each parameter's value ([`parameter_taps`]),
/// the first parameter first, `values` of them.
pub fn sample(
    shape: &BakedShape,
    mu: f32,
    varied: &[f32],
    filter: Filter,
    texel: impl Fn(usize, usize) -> [f32; 4],
) -> Vec<f32> {
    let (lower, upper, weight) = linear_taps(texture_coordinate(shape.segments, mu), shape.nodes, filter);
    let block = |first_row: usize| -> Vec<f32> {
        (0..shape.rows)
            .flat_map(|row| {
                let (a, b) = (texel(first_row + row, lower), texel(first_row + row, upper));
                (0..4).map(move |c| lerp(a[c], b[c], weight))
            })
            .collect()
    };
    let taps: Vec<(usize, f32)> = shape
        .axes
        .iter()
        .enumerate()
        .map(|(a, axis)| parameter_taps(axis, varied.get(a).copied().unwrap_or(axis.nominal as f32)))
        .collect();
    // Rows from one node of a parameter to the next: a block for the first, the first's blocks
    // for the second.
    let strides: Vec<usize> = shape
        .axes
        .iter()
        .scan(shape.rows, |stride, axis| {
            let this = *stride;
            *stride = stride.saturating_mul(axis.nodes as usize);
            Some(this)
        })
        .collect();
    let mut read = blend(&taps, &strides, 0, &block);
    read.truncate(shape.values);
    read
}

/// The rows from `first_row` blended across parameters `..taps.len()`, the last outermost: the
/// blocks of its two nodes around the value, each blended across the parameters before it.
fn blend(taps: &[(usize, f32)], strides: &[usize], first_row: usize, block: &dyn Fn(usize) -> Vec<f32>) -> Vec<f32> {
    let Some((&(node, weight), inner)) = taps.split_last() else { return block(first_row) };
    let stride = strides[inner.len()];
    let below = blend(inner, strides, first_row + node * stride, block);
    let above = blend(inner, strides, first_row + (node + 1) * stride, block);
    below.iter().zip(&above).map(|(&a, &b)| lerp(a, b, weight)).collect()
}

/// The baked values of `material` at `mu` and `varied` (one value per varied parameter, those not
/// given at their nominal values) from `array` (a loaded baked file, checked with
/// [`BakedArrayEntry::check`]).
pub fn sample_array(array: &Table, material: &BakedMaterialEntry, mu: f32, varied: &[f32], filter: Filter) -> Vec<f32> {
    let [width, height] = [array.axes[0].count, array.axes[1].count];
    let texel = |row: usize, node: usize| {
        let at = ((material.layer as usize * height + material.first_row as usize + row) * width + node) * 4;
        [array.data[at], array.data[at + 1], array.data[at + 2], array.data[at + 3]]
    };
    sample(&material.shape(width), mu, varied, filter, texel)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_centre_is_exact_for_a_power_of_two_height() {
        for height in [1u32, 2, 8, 64, 4096] {
            for row in 0..height.min(64) {
                let v = row_coordinate(row, height);
                // The filter's position v * height - 0.5 is the row itself, with no fraction.
                assert_eq!(v * height as f32 - 0.5, row as f32, "row {row} of {height}");
            }
        }
    }

    #[test]
    fn the_coordinate_follows_the_segment_of_u_and_reads_nan_as_grazing() {
        // Two segments meeting at u = 0.5: 4 intervals below, 2 above, 7 nodes.
        let segments = [
            BakedSegment { u_start: 0.0, slope: 8.0 / 7.0, offset: 0.5 / 7.0 },
            BakedSegment { u_start: 0.5, slope: 4.0 / 7.0, offset: 2.5 / 7.0 },
        ];
        let node = |x: f32| x * 7.0 - 0.5;
        assert!((node(texture_coordinate(&segments, 0.0)) - 0.0).abs() < 1e-6);
        assert!((node(texture_coordinate(&segments, 0.25)) - 4.0).abs() < 1e-5);
        assert!((node(texture_coordinate(&segments, 1.0)) - 6.0).abs() < 1e-5);
        assert_eq!(texture_coordinate(&segments, f32::NAN), texture_coordinate(&segments, 0.0));
        assert_eq!(texture_coordinate(&segments, 2.0), texture_coordinate(&segments, 1.0));
        assert_eq!(texture_coordinate(&[], 0.5), 0.0, "no segment reads node 0, never a panic");
    }

    #[test]
    fn a_sample_between_nodes_blends_the_two_texels_of_each_row() {
        let segments = [BakedSegment { u_start: 0.0, slope: 2.0 / 3.0, offset: 0.5 / 3.0 }];
        // Node k of row r holds (10 r + k) in every channel.
        let texel = |row: usize, node: usize| [(10 * row + node) as f32; 4];
        let shape = |rows: usize, values: usize| BakedShape { segments: &segments, axes: &[], nodes: 3, rows, values };
        let read = sample(&shape(2, 6), 0.25, &[], Filter::Exact, texel);
        assert_eq!(read.len(), 6, "the values past the last are not returned");
        // u = 0.5 is node 1 exactly.
        assert_eq!(read, vec![1.0, 1.0, 1.0, 1.0, 11.0, 11.0]);
        let between = sample(&shape(1, 4), 0.75f32.powi(2), &[], Filter::Exact, texel);
        assert!((between[0] - 1.5).abs() < 1e-6, "{between:?}");
    }

    /// Blocks of one row, node `k` of block `b` holding `100 b + k` in every channel: a read is
    /// `100 (block coordinate) + (node coordinate)`.
    fn block_texel(row: usize, node: usize) -> [f32; 4] {
        [(100 * row + node) as f32; 4]
    }

    #[test]
    fn a_varied_parameter_reads_its_nodes_blocks_and_blends_between_them() {
        let segments = [BakedSegment { u_start: 0.0, slope: 2.0 / 3.0, offset: 0.5 / 3.0 }];
        let axis = BakedAxis::uniform("layer 1 alpha", [0.1, 0.5], 0.25, 3);
        let axes = [axis.clone()];
        let shape = BakedShape { segments: &segments, axes: &axes, nodes: 3, rows: 1, values: 4 };
        let read = |alpha: f32| sample(&shape, 0.25, &[alpha], Filter::Exact, block_texel)[0];
        // The ends of the range are their blocks to the bit; beyond and NaN, the nearer end.
        assert_eq!(read(0.1), 1.0);
        assert_eq!(read(0.5), 201.0, "the last node is the upper block at weight 1");
        assert_eq!(read(-3.0), 1.0);
        assert_eq!(read(f32::NAN), 1.0, "NaN reads the range's start");
        assert_eq!(read(9.0), 201.0);
        // The middle node, from either side of it in f32, is its block within f32's rounding of t.
        for alpha in [0.3f32, f32::from_bits(0.3f32.to_bits() - 1), f32::from_bits(0.3f32.to_bits() + 1)] {
            assert!((read(alpha) - 101.0).abs() < 1e-3, "{alpha}: {}", read(alpha));
        }
        assert!((read(0.2) - 51.0).abs() < 1e-3, "midway between the first two nodes: {}", read(0.2));
        assert!((read(0.45) - 176.0).abs() < 1e-3, "a quarter before the last: {}", read(0.45));
        // No value given: the nominal one.
        assert_eq!(
            sample(&shape, 0.25, &[], Filter::Exact, block_texel),
            sample(&shape, 0.25, &[0.25], Filter::Exact, block_texel)
        );
        assert_eq!(parameter_taps(&axis, 0.5), (1, 1.0));
        assert_eq!(parameter_taps(&axis, 0.1), (0, 0.0));
    }

    #[test]
    fn two_varied_parameters_read_the_block_of_each_pair_of_nodes_the_first_fastest() {
        let segments = [BakedSegment { u_start: 0.0, slope: 2.0 / 3.0, offset: 0.5 / 3.0 }];
        let axes = [
            BakedAxis::uniform("layer 1 alpha", [0.0, 1.0], 0.5, 3),
            BakedAxis::uniform("layer 2 eta", [1.0, 2.0], 1.5, 2),
        ];
        // Two rows a block: block (j0, j1) starts at row 2 (j0 + 3 j1).
        let shape = BakedShape { segments: &segments, axes: &axes, nodes: 3, rows: 2, values: 8 };
        for (j0, alpha) in [(0, 0.0), (1, 0.5), (2, 1.0)] {
            for (j1, eta) in [(0, 1.0), (1, 2.0)] {
                let read = sample(&shape, 0.25, &[alpha, eta], Filter::Exact, block_texel);
                let first_row = 2 * (j0 + 3 * j1);
                let expected = [first_row, first_row + 1].map(|row| (100 * row + 1) as f32);
                assert_eq!([read[0], read[4]], expected, "alpha {alpha}, eta {eta}");
            }
        }
        // Between nodes of both: the blend of the four blocks around.
        let read = sample(&shape, 0.25, &[0.25, 1.5], Filter::Exact, block_texel);
        let expected = 100.0 * 2.0 * (0.5 + 3.0 * 0.5) + 1.0;
        assert!((read[0] - expected).abs() < 1e-3, "{read:?} against {expected}");
    }
}
