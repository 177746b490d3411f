//! What the two split-sum tables (Karis, Belcour) share: 2D textures over `x = n.v` and
//! roughness, with the roughness spacing and orientation as options, because existing renderers
//! disagree on both and users trip over it (the thesis renderer read Unreal's table unflipped and
//! by alpha instead of roughness).

use serde::{Deserialize, Serialize};

use super::settings::{SharedSettings, check_counts, check_unit_range};
pub use super::spacing::RoughnessAxis;
use crate::error::Result;
use crate::formats::FileFormat;
use crate::integrate::Method;
use crate::physics::MaskingShadowing;
use crate::table::Axis;

/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "roughness_count"];

/// Which end of the roughness axis is row 0 (the first row in memory and in the file).
///
/// Direct3D, Vulkan, Metal and WebGPU address the first row of a texture at `v = 0`, and so does
/// OpenGL when the rows are uploaded as stored (`glTexImage2D` puts the first row at `t = 0`).
/// Unreal Engine 4 and Filament sample their split-sum table at `float2(NoV, roughness)`, so their
/// table has row 0 = roughness 0; a table with the other order, read by code ported from them, is
/// read upside down (rough where the surface is smooth).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Orientation {
    /// Row 0 is the smoothest texel: `v = roughness`, sampled directly at `float2(NoV, roughness)`.
    SmoothFirst,
    /// Row 0 is the roughest texel: the rows of an image drawn with roughness 0 at the bottom and
    /// stored top row first, as GL-era tools wrote it (the thesis's shipped table). Sampled at
    /// `float2(NoV, 1 - roughness)` as stored, or at `float2(NoV, roughness)` after flipping the
    /// rows at load (a bottom-up loader, as `stbi_set_flip_vertically_on_load` gives).
    #[serde(alias = "rough-first")]
    BottomUpImage,
}

/// The settings both split-sum tables have, and `Own`, the keys only one of them has (Karis's
/// f16 rounding, Belcour's hat intervals). In the TOML file they are one section: `Own`'s keys sit
/// beside these (`[karis] storage_rounding`), so `Own` is flattened in, as the shared keys are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SplitSumSettings<Own> {
    /// Nodes along `x = n.v`, one per texel, at its centre.
    pub mu_count: usize,
    /// Nodes along roughness, one per texel, at its centre.
    pub roughness_count: usize,
    /// Range of GGX alpha covered, before orientation.
    pub alpha_range: [f64; 2],
    pub roughness_axis: RoughnessAxis,
    pub orientation: Orientation,
    pub masking: MaskingShadowing,
    pub method: Method,
    #[serde(flatten)]
    pub shared: SharedSettings,
    /// The settings of this table only.
    #[serde(flatten)]
    pub own: Own,
}

impl<Own> SplitSumSettings<Own> {
    /// Check the settings both tables have; `table` names the configuration section in errors,
    /// `formats` the file formats that can hold the table.
    pub fn validate_split_sum(&self, table: &str, formats: &[FileFormat]) -> Result<()> {
        check_counts(table, COUNT_KEYS, &[self.mu_count, self.roughness_count])?;
        check_unit_range(&format!("{table}.alpha_range"), self.alpha_range)?;
        self.shared.validate(table, formats)
    }

    /// The table's axes: `mu` cell-centred over [0, 1]; `alpha` cell-centred, spaced and ordered
    /// as configured.
    pub fn axes(&self) -> Result<Vec<Axis>> {
        let mu = Axis::cell_centred("mu", 0.0, 1.0, self.mu_count)?;
        let [smooth, rough] = self.alpha_range;
        let (start, end) = match self.orientation {
            Orientation::BottomUpImage => (rough, smooth),
            Orientation::SmoothFirst => (smooth, rough),
        };
        let alpha = Axis::cell_centred("alpha", start, end, self.roughness_count)?
            .with_mapping(self.roughness_axis.mapping())?;
        Ok(vec![mu, alpha])
    }

    /// The conventions a user must know to sample the texture, and the call that samples it.
    pub fn layout_notes(&self) -> Vec<String> {
        let (quantity, of_alpha) = match self.roughness_axis {
            RoughnessAxis::Perceptual => ("roughness", "roughness = sqrt(alpha)"),
            RoughnessAxis::Alpha => ("alpha", "spaced linearly in GGX alpha"),
        };
        let orientation = match self.orientation {
            Orientation::SmoothFirst => format!(
                "Row 0 (the first row in memory) = {quantity} 0: v = {quantity}, {of_alpha}. Direct3D, Vulkan, Metal and WebGPU \
                 address row 0 at v = 0 (OpenGL too, rows uploaded as stored), so the texture samples as Unreal Engine 4 and \
                 Filament sample theirs: HLSL lut.SampleLevel(linear_clamp, float2(NoV, {quantity}), 0), WGSL \
                 textureSampleLevel(lut, linear_clamp, vec2<f32>(n_dot_v, {quantity}), 0.0)."
            ),
            Orientation::BottomUpImage => format!(
                "Row 0 (the first row in memory) = {quantity} 1: v = 1 - {quantity}, {of_alpha}; the image order of GL-era \
                 tools (roughness 0 at the bottom of the image, stored top row first), as the thesis's shipped table. Sample \
                 at float2(NoV, 1 - {quantity}) as stored, or flip the rows at load and sample at float2(NoV, {quantity}); \
                 code ported from Unreal Engine 4 or Filament, which samples at float2(NoV, {quantity}), reads it upside down."
            ),
        };
        vec![
            "Texture coordinate x = n.v at texel centres (cell-centred); sample with clamp addressing, linear data (not sRGB).".into(),
            orientation,
        ]
    }
}
