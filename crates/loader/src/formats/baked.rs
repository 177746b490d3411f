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
    /// How far the stored rows, read as a GPU filters them, are from the model.
    pub error: BakedErrors,
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
}

impl Worst {
    /// No difference yet.
    pub fn none() -> Self {
        Worst { max: 0.0, at_mu: 1.0, value: String::new() }
    }

    /// Keep `difference` at `mu`, of the value `value` names, where it is the largest so far.
    pub fn take(&mut self, difference: f64, mu: f64, value: impl FnOnce() -> String) {
        if difference > self.max {
            *self = Worst { max: difference, at_mu: mu, value: value() };
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
}

impl BakedMaterialEntry {
    /// The entry of `material`, of `lobes` lobes, its rows from `first_row` of `layer` holding
    /// `values` (named in storage order, four to a row) at nodes placed by `segments`, `error`
    /// from its model.
    pub fn new(
        material: impl Into<String>,
        lobes: u32,
        (layer, first_row): (u32, u32),
        segments: Vec<BakedSegment>,
        values: Vec<String>,
        error: BakedErrors,
    ) -> Self {
        let rows = values.len().div_ceil(4) as u32;
        BakedMaterialEntry { material: material.into(), lobes, layer, first_row, rows, segments, values, error }
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
            lookup: LOOKUP.into(),
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
            let fits = (m.layer as usize) < layers && (m.first_row + m.rows) as usize <= height;
            let rows_hold_values = m.values.len().div_ceil(4) == m.rows as usize && m.rows > 0;
            let segments_start_at_0 = m.segments.first().is_some_and(|s| s.u_start == 0.0)
                && m.segments.windows(2).all(|w| w[0].u_start < w[1].u_start);
            if !fits || !rows_hold_values || !segments_start_at_0 {
                return Err(refuse(format!(
                    "places material `{}` at layer {}, rows {} to {} with {} values and {} segments: its rows must lie \
                     in one of the {layers} layers of {height} rows, hold its values four to a row, and its segments \
                     start at u = 0 in increasing order",
                    m.material,
                    m.layer,
                    m.first_row,
                    m.first_row + m.rows,
                    m.values.len(),
                    m.segments.len()
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

/// The values of the material at `rows` (its first row and count) and `segments`, read at view
/// cosine `mu` from `texel(row, node)` as a GPU's linear filter reads the array: along the row
/// only (a row's centre gives its neighbours no weight), `values` of them.
pub fn sample(
    segments: &[BakedSegment],
    nodes: usize,
    rows: usize,
    values: usize,
    mu: f32,
    filter: Filter,
    texel: impl Fn(usize, usize) -> [f32; 4],
) -> Vec<f32> {
    let (lower, upper, weight) = linear_taps(texture_coordinate(segments, mu), nodes, filter);
    let mut read: Vec<f32> = (0..rows)
        .flat_map(|row| {
            let (a, b) = (texel(row, lower), texel(row, upper));
            (0..4).map(move |c| lerp(a[c], b[c], weight))
        })
        .collect();
    read.truncate(values);
    read
}

/// The baked values of `material` at `mu` from `array` (a loaded baked file, checked with
/// [`BakedArrayEntry::check`]).
pub fn sample_array(array: &Table, material: &BakedMaterialEntry, mu: f32, filter: Filter) -> Vec<f32> {
    let [width, height] = [array.axes[0].count, array.axes[1].count];
    let texel = |row: usize, node: usize| {
        let at = ((material.layer as usize * height + material.first_row as usize + row) * width + node) * 4;
        [array.data[at], array.data[at + 1], array.data[at + 2], array.data[at + 3]]
    };
    sample(&material.segments, width, material.rows as usize, material.values.len(), mu, filter, texel)
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
        let read = sample(&segments, 3, 2, 6, 0.25, Filter::Exact, texel);
        assert_eq!(read.len(), 6, "the values past the last are not returned");
        // u = 0.5 is node 1 exactly.
        assert_eq!(read, vec![1.0, 1.0, 1.0, 1.0, 11.0, 11.0]);
        let between = sample(&segments, 3, 1, 4, 0.75f32.powi(2), Filter::Exact, texel);
        assert!((between[0] - 1.5).abs() < 1e-6, "{between:?}");
    }
}
