//! The files tmlut writes: each container's writer beside the loader's reader of it, which this
//! module re-exports whole (`tmlut_loader::formats`: the readers, the manifest's types, the
//! layout each container's writer and reader share), so that `crate::formats::dds` reads and
//! writes DDS alike.
//!
//! Every writer goes through [`write_atomically`]: the bytes land in a temporary file beside the
//! target and are renamed over it only once complete, so a failed or interrupted build never
//! leaves a half-written table where a renderer would load it. [`files`] says how the outputs
//! meet the file system.

pub use tmlut_loader::formats::*;

pub mod bin;
pub mod dds;
#[cfg(feature = "exr")]
pub mod exr;
pub mod files;
pub mod ktx2;
pub mod manifest;
pub mod slice_array;
#[cfg(test)]
mod test_tables;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::error::{Error, Result};
use crate::table::{Axis, Table};

pub use files::{write_atomically, write_bytes_atomically};

/// Write a table in a format. DDS and KTX2 take 2- and 3-axis tables with 1, 2 or 4 channels;
/// `.bin` takes single-channel node-aligned tables; EXR takes any table.
pub fn write_table(path: &Path, table: &Table, format: FileFormat, precision: Precision) -> Result<()> {
    match format {
        FileFormat::Dds => dds::write_dds(path, table, precision),
        FileFormat::Ktx2 => ktx2::write_ktx2(path, table, precision),
        FileFormat::Bin => bin::write_bin(path, table),
        #[cfg(feature = "exr")]
        FileFormat::Exr => exr::write_exr(path, table, precision),
        #[cfg(not(feature = "exr"))]
        FileFormat::Exr => Err(Error::format(path, "this build writes no OpenEXR; enable the `exr` feature of tmlut")),
    }
}

/// The extents of the texture that holds `table` in a `container` (`DDS`, `KTX2`), its shape and
/// its texel format (`format_of` the table's channel count and `precision`): 2 axes make a 2D
/// texture, 3 a volume or, where the third is [`LAYER_AXIS`], an array; the table must have 1, 2
/// or 4 channels and values that `precision` stores as finite numbers ([`check_storable_values`]).
pub fn texture_extents<F>(
    table: &Table,
    precision: Precision,
    container: &str,
    format_of: impl Fn(usize, Precision) -> Option<F>,
) -> Result<([u32; 3], TextureShape, F)> {
    let key = format!("table `{}`", table.name);
    if ![1, 2, 4].contains(&table.channel_count()) {
        return Err(Error::invalid(
            &key,
            format!(
                "has {} channels; a {container} texture holds 1, 2 or 4 (R, RG or RGBA float formats)",
                table.channel_count()
            ),
        ));
    }
    if !(2..=3).contains(&table.dimension()) {
        return Err(Error::invalid(
            &key,
            format!(
                "has {} axes; a {container} texture holds 2 (a 2D texture) or 3 (a volume or an array)",
                table.dimension()
            ),
        ));
    }
    let mut extents = [1u32; 3];
    for (extent, axis) in extents.iter_mut().zip(&table.axes) {
        *extent = u32::try_from(axis.count).map_err(|_| {
            Error::invalid(
                &key,
                format!("axis `{}` has {} nodes, more than a {container} extent holds", axis.name, axis.count),
            )
        })?;
    }
    check_storable_values(table, precision)?;
    let format = format_of(table.channel_count(), precision)
        .ok_or_else(|| Error::invalid(&key, format!("has {} channels", table.channel_count())))?;
    Ok((extents, TextureShape::of(table), format))
}

/// `values` in `precision`, little-endian (the byte order of DDS, KTX2 and every GPU), appended
/// to `bytes`; f16 rounded to nearest even.
pub fn put_texels(bytes: &mut Vec<u8>, values: &[f32], precision: Precision) {
    match precision {
        Precision::F32 => values.iter().for_each(|v| bytes.extend_from_slice(&v.to_le_bytes())),
        Precision::F16 => values.iter().for_each(|&v| bytes.extend_from_slice(&half::f16::from_f32(v).to_le_bytes())),
    }
}

/// Refuse a table whose stored values a reader would not get back as finite numbers.
///
/// A NaN or an infinity in a lookup table is a generator bug, and a shader sampling it spreads
/// the bad value over every filtered neighbour; such a table is never written. For f16 storage,
/// finite values beyond the f16 range are refused too, since rounding would turn them into
/// infinities.
pub fn check_storable_values(table: &Table, precision: Precision) -> Result<()> {
    let stats = table.stats();
    if stats.nan_count > 0 || stats.infinite_count > 0 {
        return Err(Error::invalid(
            format!("table `{}`", table.name),
            format!(
                "{} NaN and {} infinite values out of {}; a table with non-finite values is never written",
                stats.nan_count,
                stats.infinite_count,
                table.data.len()
            ),
        ));
    }
    if precision == Precision::F16 {
        let overflowing = table.data.iter().filter(|&&v| precision.round(v).is_infinite()).count();
        if overflowing > 0 {
            return Err(Error::invalid(
                format!("table `{}`", table.name),
                format!(
                    "{overflowing} values lie beyond the f16 range (largest finite {}) and would be stored as \
                     infinities; store this table as f32",
                    half::f16::MAX
                ),
            ));
        }
    }
    Ok(())
}

/// The name of the texel format a texture file states: `DXGI_FORMAT_R16G16_FLOAT` in a DDS file,
/// `VK_FORMAT_R16G16_SFLOAT` in a KTX2 file; `None` for the formats that are not textures.
pub fn texel_format_name(format: FileFormat, channels: usize, precision: Precision) -> Option<String> {
    match format {
        FileFormat::Dds => Some(format!("DXGI_FORMAT_{}", dds::dxgi_format_name(channels, precision))),
        FileFormat::Ktx2 => Some(format!("VK_FORMAT_{}", ktx2::vk_format_name(channels, precision))),
        FileFormat::Exr | FileFormat::Bin => None,
    }
}

/// How a renderer binds a texture file (`format` DDS or KTX2) of `axes` (2 or 3, with their
/// texture-coordinate formulas) and `channels` channels in `precision` and samples it with
/// hardware filtering; `None` for the formats that are not textures.
pub fn binding(axes: &[Axis], channels: usize, precision: Precision, format: FileFormat) -> Option<manifest::Binding> {
    let texel_format = texel_format_name(format, channels, precision)?;
    let dimension = axes.len();
    let (hlsl_texel, swizzle) = match channels {
        1 => ("float", "r"),
        2 => ("float2", "rg"),
        _ => ("float4", "rgba"),
    };
    let webgpu = match (channels, precision) {
        (1, Precision::F16) => "r16float",
        (2, Precision::F16) => "rg16float",
        (_, Precision::F16) => "rgba16float",
        (1, Precision::F32) => "r32float",
        (2, Precision::F32) => "rg32float",
        (_, Precision::F32) => "rgba32float",
    };
    let filterable = match precision {
        Precision::F16 => "filterable".to_string(),
        Precision::F32 => format!(
            "filterable only with the float32-filterable feature; without it bind as unfilterable-float and filter by \
             hand ({} textureLoad texels around each coordinate times the texel count, minus 0.5)",
            1 << dimension
        ),
    };
    if axes.get(2).is_some_and(|a| a.name == LAYER_AXIS) {
        // An array of slices: each slice states its own coordinates in the array.
        return Some(manifest::Binding::new(
            format!(
                "Texture2DArray<{hlsl_texel}> (HLSL), texture_2d_array<f32> (WGSL) of {} layers; {texel_format}, WebGPU \
                 {webgpu} ({filterable}); one mip level; linear data (not sRGB)",
                axes[2].count
            ),
            "linear min and mag filter, clamp-to-edge addressing, mip level 0",
            vec![
                "u = the slice's `texture_coordinate` of mu (slice_array.slices[].axes[0])".into(),
                "v = the slice's `texture_coordinate` of alpha (slice_array.slices[].axes[1])".into(),
                "layer = the slice's `layer` (an integer)".into(),
            ],
            "tex.SampleLevel(linear_clamp, float3(u, v, layer), 0)",
            format!("textureSampleLevel(tex, linear_clamp, vec2<f32>(u, v), layer, 0.0).{swizzle}"),
        ));
    }
    let names = ["u", "v", "w"];
    let coordinates =
        axes.iter().zip(names).map(|(a, n)| format!("{n} = {}", a.texture_coordinate_formula())).collect();
    let list = names[..dimension].join(", ");
    Some(manifest::Binding::new(
        format!(
            "Texture{dimension}D<{hlsl_texel}> (HLSL), texture_{dimension}d<f32> (WGSL); {texel_format}, WebGPU {webgpu} \
             ({filterable}); one mip level; linear data (not sRGB)"
        ),
        "linear min and mag filter, clamp-to-edge addressing on every axis, mip level 0",
        coordinates,
        format!("tex.SampleLevel(linear_clamp, float{dimension}({list}), 0)"),
        format!("textureSampleLevel(tex, linear_clamp, vec{dimension}<f32>({list}), 0.0).{swizzle}"),
    ))
}

/// The values of one texel whose channels add up to an albedo as stored in `precision`, rounded
/// by `rounding` (its variants say how).
pub fn round_texel(rounding: SumRounding, values: &[f32], precision: Precision) -> Vec<f32> {
    let mut stored: Vec<f32> = values.iter().map(|&v| precision.round(v)).collect();
    if rounding == SumRounding::Nearest {
        return stored;
    }
    while stored.iter().map(|&v| v as f64).sum::<f64>() > 1.0 {
        let rounded_up = (0..stored.len())
            .filter(|&k| stored[k] > values[k])
            .max_by(|&a, &b| (stored[a] - values[a]).total_cmp(&(stored[b] - values[b])));
        let smallest =
            || (0..stored.len()).filter(|&k| stored[k] > 0.0).min_by(|&a, &b| stored[a].total_cmp(&stored[b]));
        match rounded_up.or_else(smallest) {
            Some(k) => stored[k] = step_toward_zero(stored[k], precision),
            None => break,
        }
    }
    stored
}

/// The value of `precision` next to `v` (a value of it) toward zero; `v` itself at zero.
fn step_toward_zero(v: f32, precision: Precision) -> f32 {
    match precision {
        Precision::F16 => {
            let bits = half::f16::from_f32(v).to_bits();
            if bits & 0x7FFF == 0 { v } else { half::f16::from_bits(bits - 1).to_f32() }
        }
        Precision::F32 => {
            if v == 0.0 {
                v
            } else {
                f32::from_bits(v.to_bits() - 1)
            }
        }
    }
}

#[cfg(test)]
mod rounding_tests {
    use super::*;

    /// The f16 spacing at `v`: the gap to the next f16 away from zero.
    fn f16_ulp(v: f32) -> f32 {
        let h = half::f16::from_f32(v.abs());
        half::f16::from_bits(h.to_bits() + 1).to_f32() - h.to_f32()
    }

    #[test]
    fn no_energy_gain_keeps_every_sum_at_most_one_within_an_ulp_of_each_value() {
        // Pairs that add to at most 1, many just below it where nearest rounding goes over, and a
        // few whose own sum exceeds 1 by f32 rounding of the generator's weights.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut stepped = 0;
        for n in 0..200_000 {
            let scale = uniform() as f32;
            let total = match n % 3 {
                0 => 1.0 - 1e-4 * uniform(),
                1 => uniform(),
                _ => 1.0 + 4e-7 * uniform(),
            };
            let bias = ((total - scale as f64).max(0.0)) as f32;
            let values = [scale, bias];
            let nearest = round_texel(SumRounding::Nearest, &values, Precision::F16);
            assert_eq!(nearest, values.map(|v| Precision::F16.round(v)));
            let kept = round_texel(SumRounding::NoEnergyGain, &values, Precision::F16);
            assert!(kept[0] as f64 + kept[1] as f64 <= 1.0, "{values:?} -> {kept:?}");
            let ulps = if values[0] as f64 + values[1] as f64 <= 1.0 { 1.0 } else { 1.5 };
            for k in 0..2 {
                let error = (kept[k] - values[k]).abs();
                assert!(kept[k] >= 0.0 && error <= ulps * f16_ulp(values[k]), "{values:?} -> {kept:?}");
                assert_eq!(kept[k], Precision::F16.round(kept[k]), "stored values are f16 values");
            }
            if kept != nearest {
                stepped += 1;
                assert!(nearest[0] as f64 + nearest[1] as f64 > 1.0, "only sums above 1 change: {values:?}");
            }
        }
        assert!(stepped > 1000, "the case arises: {stepped}");
    }
}
