//! A table as a GPU holds it: texel bytes with the extent, dimension and format a texture is
//! created with, and sampling by texture coordinate as a GPU filters.
//!
//! [`TextureDescriptor`] names its fields and formats as WebGPU does, so that each maps onto one
//! field of a `wgpu::TextureDescriptor` (`size.width`, `size.height`,
//! `size.depth_or_array_layers`, `dimension`, `format`, `mip_level_count`) and of the
//! `TexelCopyBufferLayout` that `Queue::write_texture` takes (`bytes_per_row`, `rows_per_image`),
//! without this crate depending on wgpu:
//!
//! ```text
//! wgpu::TextureDescriptor {
//!     size: wgpu::Extent3d { width: d.width, height: d.height, depth_or_array_layers: d.depth_or_layers },
//!     mip_level_count: d.mip_level_count, sample_count: 1,
//!     dimension: match d.dimension { D2 => wgpu::TextureDimension::D2, D3 => wgpu::TextureDimension::D3 },
//!     format: match d.format { R16Float => wgpu::TextureFormat::R16Float, ... },  // same names
//!     ..
//! }
//! ```
//!
//! Rows are packed without padding (`bytes_per_row = width * bytes_per_texel`), as
//! `Queue::write_texture` accepts them; a buffer-to-texture copy needs rows padded to 256 bytes.

use super::{Precision, Table};
use crate::error::{Error, Result};
use crate::filter::{Filter, Texture3D};
use crate::filter::{linear_taps, trilinear};
use crate::table::{Axis, InterpolationError};

/// Texel formats a table is stored in, named as WebGPU names them (all linear, all filterable
/// except the 32-bit ones without the `float32-filterable` feature).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TextureFormat {
    /// One f16 channel (DXGI `R16_FLOAT`, Vulkan `R16_SFLOAT`).
    R16Float,
    /// Two f16 channels (DXGI `R16G16_FLOAT`, Vulkan `R16G16_SFLOAT`).
    Rg16Float,
    /// Four f16 channels (DXGI `R16G16B16A16_FLOAT`, Vulkan `R16G16B16A16_SFLOAT`).
    Rgba16Float,
    /// One f32 channel (DXGI `R32_FLOAT`, Vulkan `R32_SFLOAT`).
    R32Float,
    /// Two f32 channels (DXGI `R32G32_FLOAT`, Vulkan `R32G32_SFLOAT`).
    Rg32Float,
    /// Four f32 channels (DXGI `R32G32B32A32_FLOAT`, Vulkan `R32G32B32A32_SFLOAT`).
    Rgba32Float,
}

impl TextureFormat {
    /// The format of `channels` channels in `precision`; `None` for 3 channels or more than 4,
    /// which no WebGPU format holds.
    pub fn of(channels: usize, precision: Precision) -> Option<Self> {
        use TextureFormat::*;
        Some(match (channels, precision) {
            (1, Precision::F16) => R16Float,
            (2, Precision::F16) => Rg16Float,
            (4, Precision::F16) => Rgba16Float,
            (1, Precision::F32) => R32Float,
            (2, Precision::F32) => Rg32Float,
            (4, Precision::F32) => Rgba32Float,
            _ => return None,
        })
    }

    /// Channels per texel: 1, 2 or 4.
    pub fn channels(self) -> usize {
        use TextureFormat::*;
        match self {
            R16Float | R32Float => 1,
            Rg16Float | Rg32Float => 2,
            Rgba16Float | Rgba32Float => 4,
        }
    }

    /// The precision of each channel.
    pub fn precision(self) -> Precision {
        use TextureFormat::*;
        match self {
            R16Float | Rg16Float | Rgba16Float => Precision::F16,
            R32Float | Rg32Float | Rgba32Float => Precision::F32,
        }
    }

    /// Bytes of one texel, all channels.
    pub fn bytes_per_texel(self) -> u32 {
        (self.channels() * self.precision().bytes()) as u32
    }

    /// The name WGSL and the WebGPU API use, e.g. `rg16float`.
    pub fn webgpu_name(self) -> &'static str {
        use TextureFormat::*;
        match self {
            R16Float => "r16float",
            Rg16Float => "rg16float",
            Rgba16Float => "rgba16float",
            R32Float => "r32float",
            Rg32Float => "rg32float",
            Rgba32Float => "rgba32float",
        }
    }
}

/// A texture's dimension: tables of one or two axes are 2D textures (one axis: one row), tables
/// of three are volume textures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TextureDimension {
    /// A 2D texture (`wgpu::TextureDimension::D2`).
    D2,
    /// A volume texture (`wgpu::TextureDimension::D3`).
    D3,
}

/// What a texture is created with, and the layout of its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TextureDescriptor {
    /// Texels along axis 0.
    pub width: u32,
    /// Texels along axis 1 (1 for a table of one axis).
    pub height: u32,
    /// Texels along axis 2 of a volume texture; 1 for a 2D texture.
    pub depth_or_layers: u32,
    /// 2D or volume.
    pub dimension: TextureDimension,
    /// The texel format, in the table's storage precision.
    pub format: TextureFormat,
    /// Always 1: tables are never mip-mapped (a mip level would average unlike parameters).
    pub mip_level_count: u32,
    /// `width * bytes_per_texel`: rows are packed.
    pub bytes_per_row: u32,
    /// `height`: images (depth slices) are packed.
    pub rows_per_image: u32,
}

impl TextureDescriptor {
    /// The length of the texel bytes: `width * height * depth_or_layers * bytes_per_texel`.
    pub fn byte_len(&self) -> usize {
        self.bytes_per_row as usize * self.rows_per_image as usize * self.depth_or_layers as usize
    }
}

/// Texels in their storage precision, channels interleaved, x fastest, then y, then z.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Texels {
    /// IEEE binary16 bit patterns.
    F16(Vec<u16>),
    /// IEEE binary32 values.
    F32(Vec<f32>),
}

/// A table's texels with the descriptor of the texture that holds them.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureData {
    descriptor: TextureDescriptor,
    texels: Texels,
}

impl TextureData {
    /// The texture of `table` stored in `precision`. Values are rounded to `precision` (exact for a
    /// table read from a file of that precision, whose values are the stored ones). Refused for a
    /// table of more than three axes or of 3 or more than 4 channels, naming the table.
    pub fn from_table(table: &Table, precision: Precision) -> Result<Self> {
        let refuse = |reason: String| Error::invalid(format!("table `{}`", table.name), reason);
        let format = TextureFormat::of(table.channel_count(), precision)
            .ok_or_else(|| refuse(format!("has {} channels; a texture holds 1, 2 or 4", table.channel_count())))?;
        let dimension = match table.dimension() {
            1 | 2 => TextureDimension::D2,
            3 => TextureDimension::D3,
            n => return Err(refuse(format!("has {n} axes; a texture has 1 to 3"))),
        };
        let extent = |d: usize| -> Result<u32> {
            let count = table.axes.get(d).map_or(1, |a| a.count);
            u32::try_from(count)
                .map_err(|_| refuse(format!("axis {d} has {count} nodes; a texture has at most 2^32 - 1")))
        };
        let (width, height, depth_or_layers) = (extent(0)?, extent(1)?, extent(2)?);
        let bytes_per_row = width
            .checked_mul(format.bytes_per_texel())
            .ok_or_else(|| refuse(format!("rows of {width} texels exceed 4 GiB")))?;
        let texels = match precision {
            Precision::F16 => Texels::F16(table.data.iter().map(|&v| half::f16::from_f32(v).to_bits()).collect()),
            Precision::F32 => Texels::F32(table.data.clone()),
        };
        let descriptor = TextureDescriptor {
            width,
            height,
            depth_or_layers,
            dimension,
            format,
            mip_level_count: 1,
            bytes_per_row,
            rows_per_image: height,
        };
        Ok(TextureData { descriptor, texels })
    }

    /// What the texture is created with, and the layout of [`TextureData::to_bytes`].
    pub fn descriptor(&self) -> &TextureDescriptor {
        &self.descriptor
    }

    /// The texels in their storage precision.
    pub fn texels(&self) -> &Texels {
        &self.texels
    }

    /// The binary16 bit patterns of an `*16Float` texture.
    pub fn texels_f16(&self) -> Option<&[u16]> {
        match &self.texels {
            Texels::F16(t) => Some(t),
            Texels::F32(_) => None,
        }
    }

    /// The values of an `*32Float` texture.
    pub fn texels_f32(&self) -> Option<&[f32]> {
        match &self.texels {
            Texels::F32(t) => Some(t),
            Texels::F16(_) => None,
        }
    }

    /// The texel bytes, little-endian (the byte order of every GPU and of DDS files), copied.
    pub fn to_bytes(&self) -> Vec<u8> {
        match &self.texels {
            Texels::F16(t) => t.iter().flat_map(|v| v.to_le_bytes()).collect(),
            Texels::F32(t) => t.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }

    /// The texel bytes without a copy, in the host's byte order (little-endian on every platform
    /// wgpu runs on; [`TextureData::to_bytes`] is little-endian everywhere).
    #[cfg(feature = "bytemuck")]
    pub fn bytes(&self) -> &[u8] {
        match &self.texels {
            Texels::F16(t) => bytemuck::cast_slice(t),
            Texels::F32(t) => bytemuck::cast_slice(t),
        }
    }
}

/// The texture coordinate of value `x` along `axis`, in f32 as a shader computes the manifest's
/// formula ([`Axis::texture_coordinate_in`], which the scene shader prints):
/// `u = (m(x) - m(start)) / (m(end) - m(start))`, then `(u (N - 1) + 0.5) / N` for a node-aligned
/// axis.
pub fn texture_coordinate(axis: &Axis, x: f64) -> f32 {
    axis.texture_coordinate_in(x as f32)
}

/// `SampleLevel(sampler, coordinate, 0)` of `table` bound as a texture (one to three axes): a
/// linear, clamp-addressed sampler, filtering in f32 x first, then y, then z, over the values as
/// stored, one value per channel into `out`. Bit for bit the sampler of
/// [`crate::filter`] with [`Filter::Exact`]; allocates nothing.
pub fn sample_texture(table: &Table, coordinate: &[f32], out: &mut [f32]) -> Result<(), InterpolationError> {
    let dimension = table.dimension();
    if coordinate.len() != dimension {
        return Err(InterpolationError::AxisCount { axes: dimension, given: coordinate.len() });
    }
    let channels = table.channel_count();
    if out.len() != channels {
        return Err(InterpolationError::ChannelCount { channels, given: out.len() });
    }
    if dimension > 3 {
        return Err(InterpolationError::NotATexture { axes: dimension });
    }
    let count = |d: usize| table.axes.get(d).map_or(1, |a| a.count);
    let (width, height) = (count(0), count(1));
    // A missing axis is one texel wide, read at its centre, as a 2D texture is a volume of depth 1.
    let taps = |d: usize| linear_taps(coordinate.get(d).copied().unwrap_or(0.5), count(d), Filter::Exact);
    let taps = [taps(0), taps(1), taps(2)];
    for (k, value) in out.iter_mut().enumerate() {
        *value = trilinear(taps, |x, y, z| table.data[(x + width * (y + height * z)) * channels + k]);
    }
    Ok(())
}

/// A table of one to three axes bound as a texture: one single-channel volume per channel,
/// sampled by the GPU emulator ([`crate::filter`]) as [`sample_texture`] samples it.
#[derive(Debug, Clone)]
pub struct SampledTable {
    /// The table's name.
    pub name: String,
    /// The table's axes, which turn a point into texture coordinates.
    pub axes: Vec<Axis>,
    /// One volume per channel, each of the axes' node counts (1 along a missing axis).
    pub channels: Vec<Texture3D>,
}

impl SampledTable {
    /// The texture of `table` (at most three axes), its values as stored.
    pub fn new(table: &Table) -> Result<Self> {
        if table.dimension() > 3 {
            return Err(Error::invalid(
                format!("table `{}`", table.name),
                format!("has {} axes; a texture has at most 3", table.dimension()),
            ));
        }
        let count = |d: usize| table.axes.get(d).map_or(1, |a| a.count);
        let channels = (0..table.channel_count())
            .map(|c| Texture3D {
                width: count(0),
                height: count(1),
                depth: count(2),
                texels: table.channel_values(c).collect(),
            })
            .collect();
        Ok(SampledTable { name: table.name.clone(), axes: table.axes.clone(), channels })
    }

    /// The number of channels.
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// The texture of channel `channel` (empty where there is none).
    pub fn into_channel(self, channel: usize) -> Texture3D {
        self.channels.into_iter().nth(channel).unwrap_or(Texture3D {
            width: 0,
            height: 0,
            depth: 0,
            texels: Vec::new(),
        })
    }

    /// Channel `channel` at `point` (one value per axis), filtered as a GPU does.
    pub fn sample(&self, channel: usize, point: &[f64]) -> f32 {
        let mut uvw = [0.5f32; 3];
        for (d, axis) in self.axes.iter().enumerate() {
            uvw[d] = texture_coordinate(axis, point[d]);
        }
        self.channels[channel].sample_trilinear(uvw[0], uvw[1], uvw[2], Filter::Exact)
    }

    /// Whether `point` lies in the range of every axis (within rounding).
    pub fn covers(&self, point: &[f64]) -> bool {
        self.axes.iter().zip(point).all(|(axis, &x)| {
            let (lo, hi) = axis.bounds();
            let slack = 1e-9 * (hi - lo);
            x >= lo - slack && x <= hi + slack
        })
    }
}
