//! The files tmlut writes, read back: DDS and KTX2 textures, OpenEXR images, the original
//! transfer-matrix `.bin` layout, and the `manifest.json` that states every convention.
//!
//! This is the reading side. The writing side is tmlut's own `formats` module, which re-exports
//! this one and adds each container's writer beside its reader; what both sides must agree on (a
//! header's fields and codes, where a section starts) is public here, in each container's `layout`
//! module. Every reader goes through [`read_bytes_at_most`]; [`files`] says how it meets the file
//! system.

pub mod baked;
pub mod bin;
pub mod dds;
#[cfg(feature = "exr")]
pub mod exr;
pub mod files;
pub mod ktx2;
pub mod manifest;
pub mod slice_array;
#[cfg(test)]
pub(crate) mod test_folder;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::table::{Axis, Channel, Table};

pub use files::{read_bytes_at_most, read_text_at_most};

/// Precision a table's values are stored in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// IEEE binary16, rounded to nearest even (steps of about 4.9e-4 near 1).
    F16,
    /// IEEE binary32, exactly the generator's values.
    F32,
}

impl Precision {
    /// Bytes per stored value: 2 for f16, 4 for f32.
    pub fn bytes(self) -> usize {
        match self {
            Precision::F16 => 2,
            Precision::F32 => 4,
        }
    }

    /// The value a reader gets back after storing `v` in this precision.
    pub fn round(self, v: f32) -> f32 {
        match self {
            Precision::F16 => half::f16::from_f32(v).to_f32(),
            Precision::F32 => v,
        }
    }
}

/// How the values of a table whose channels add up to an albedo (Karis: `scale + bias`, the
/// albedo for `F0 = 1`, at most 1) are rounded to the storage precision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SumRounding {
    /// Each value to nearest even, on its own: the stored sum may exceed 1 by up to an ulp of
    /// each channel where the integrated sum is just below it.
    Nearest,
    /// To nearest, then, where the stored sum exceeds 1, the channels that were rounded up stepped
    /// down by one ulp of the storage precision, the largest rounding first, until it does not;
    /// where the integrated (f32) sum itself exceeds 1 (by the f32 rounding of the generator's
    /// weights, a few 1e-7), the smallest channel is stepped down further. The stored albedo
    /// never exceeds 1 (never creates energy); a stepped value is off by at most one ulp of its
    /// own instead of half of one (one and a half where the f32 sum exceeds 1).
    NoEnergyGain,
}

impl SumRounding {
    /// Its name as configuration files and the manifest spell it (`nearest`, `no-energy-gain`).
    pub fn name(self) -> &'static str {
        match self {
            SumRounding::Nearest => "nearest",
            SumRounding::NoEnergyGain => "no-energy-gain",
        }
    }
}

/// A file format tmlut writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FileFormat {
    /// DirectDraw Surface with the DX10 header: 2D or volume texture.
    Dds,
    /// OpenEXR: 2D image with named channels, or an atlas of 2D slices.
    Exr,
    /// The original transfer-matrix layout (single channel, node-aligned).
    Bin,
    /// Khronos KTX 2.0: 2D or volume texture, uncompressed, with the table's description in its
    /// key/value data.
    Ktx2,
}

impl FileFormat {
    /// Every format, in the order messages list them.
    pub const ALL: [FileFormat; 4] = [FileFormat::Bin, FileFormat::Dds, FileFormat::Exr, FileFormat::Ktx2];

    /// The texture formats a GPU binds directly, in the order readers prefer them where a table
    /// is written in several.
    pub const TEXTURES: [FileFormat; 2] = [FileFormat::Dds, FileFormat::Ktx2];

    /// The order a reader looks for a table's file in: the texture formats as
    /// [`FileFormat::TEXTURES`] lists them, then `others` (formats it takes where no texture is
    /// written), so that every reader's preference follows that one list. `N` is the count of
    /// both, and `others` holds no texture format and no format twice; a constant that breaks
    /// either does not compile.
    pub const fn textures_then<const N: usize>(others: &[FileFormat]) -> [FileFormat; N] {
        assert!(N == FileFormat::TEXTURES.len() + others.len(), "N must count the texture formats and `others`");
        let mut order = [FileFormat::TEXTURES[0]; N];
        let mut k = 0;
        while k < FileFormat::TEXTURES.len() {
            order[k] = FileFormat::TEXTURES[k];
            k += 1;
        }
        let mut j = 0;
        while j < others.len() {
            let mut before = 0;
            while before < k + j {
                // `==` is not const for an enum; the discriminants compare.
                assert!(order[before] as u8 != others[j] as u8, "a format listed twice");
                before += 1;
            }
            order[k + j] = others[j];
            j += 1;
        }
        order
    }

    /// The formats that can hold a table of `axes` axes, in [`FileFormat::ALL`]'s order: OpenEXR
    /// any, a texture format 2 or 3, and the original `.bin` layout only a table that has one
    /// (`original_layout`: FGD, GD and TIR).
    pub fn for_table(axes: usize, original_layout: bool) -> Vec<FileFormat> {
        let holds = |format: FileFormat| match format {
            FileFormat::Bin => original_layout,
            FileFormat::Exr => true,
            texture => FileFormat::TEXTURES.contains(&texture) && (2..=3).contains(&axes),
        };
        FileFormat::ALL.into_iter().filter(|&f| holds(f)).collect()
    }

    /// The file name extension, lowercase, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            FileFormat::Dds => "dds",
            FileFormat::Exr => "exr",
            FileFormat::Bin => "bin",
            FileFormat::Ktx2 => "ktx2",
        }
    }

    /// The format whose [`FileFormat::extension`] `extension` is, in any case.
    pub fn from_extension(extension: &str) -> Option<Self> {
        FileFormat::ALL.into_iter().find(|format| format.extension().eq_ignore_ascii_case(extension))
    }
}

#[cfg(not(feature = "exr"))]
pub(crate) fn no_exr_support(path: &Path) -> Error {
    Error::format(
        path,
        "this build reads no OpenEXR; enable the `exr` feature of tmlut-loader (or of tmlut, which passes it on)",
    )
}

/// A table's texels as a DDS or KTX2 file stores them: a 2D or volume texture of 1, 2 or 4 float
/// channels in one precision, one mip level, channels interleaved, x fastest, then y (row 0
/// first), then z. That is a table's own storage order: axis 0 is the width, axis 1 the height,
/// axis 2 the depth.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredTexture {
    /// Texels along x (axis 0's nodes).
    pub width: u32,
    /// Texels along y (axis 1's nodes).
    pub height: u32,
    /// 1 for a 2D texture; the layer count of a texture array.
    pub depth: u32,
    /// Channels per texel: 1, 2 or 4.
    pub channels: usize,
    /// The precision the texels are stored in.
    pub precision: Precision,
    /// A volume (3D) texture, `depth` texels deep.
    pub volume: bool,
    /// An array of `depth` 2D textures ([`LAYER_AXIS`]).
    pub layered: bool,
    /// Channels interleaved, x fastest, then y, then z.
    pub data: Vec<f32>,
}

/// The third axis of a table stored as an array of 2D textures rather than a volume: the texel
/// layers of a library's slices (`tmlut`'s `scene::build`). A renderer binds it as `Texture2DArray`
/// (HLSL) or `texture_2d_array` (WGSL), addressing the layer by its integer index.
pub const LAYER_AXIS: &str = "layer";

/// What kind of texture holds a table of two or three axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextureShape {
    /// A 2D texture: a table of two axes.
    Flat,
    /// A volume texture: a table of three axes, the third not [`LAYER_AXIS`].
    Volume,
    /// An array of 2D textures: the third axis is [`LAYER_AXIS`].
    Layers,
}

impl TextureShape {
    /// The shape of the texture that holds `table`, from its axes.
    pub fn of(table: &Table) -> Self {
        match table.axes.get(2) {
            None => TextureShape::Flat,
            Some(axis) if axis.name == LAYER_AXIS => TextureShape::Layers,
            Some(_) => TextureShape::Volume,
        }
    }
}

/// The values of little-endian texel bytes in `precision` (whole values only).
pub fn texel_values(bytes: &[u8], precision: Precision) -> Vec<f32> {
    match precision {
        Precision::F32 => bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect(),
        Precision::F16 => bytes.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()).collect(),
    }
}

impl StoredTexture {
    /// "2D texture" or "volume texture" with its extent, e.g. `volume texture 64 x 64 x 129`.
    pub fn describe(&self) -> String {
        if self.volume {
            format!("volume texture {} x {} x {}", self.width, self.height, self.depth)
        } else if self.layered {
            format!("array of {} 2D textures {} x {}", self.depth, self.width, self.height)
        } else {
            format!("2D texture {} x {}", self.width, self.height)
        }
    }

    /// The table this texture stores, given what its axes and channels are.
    pub fn into_table(self, name: &str, axes: Vec<Axis>, channels: Vec<Channel>) -> Result<Table> {
        self.check_shape(name, &axes, channels.len())?;
        Table::new(name, axes, channels, self.data)
    }

    /// Whether `axes` and `channels` channels describe this texture: one axis per dimension, each
    /// with the texture's extent along it, and the texture's channels.
    pub fn check_shape(&self, name: &str, axes: &[Axis], channels: usize) -> Result<()> {
        let key = format!("table `{name}`");
        let three = self.volume || self.layered;
        let extents: &[u32] = if three { &[self.width, self.height, self.depth] } else { &[self.width, self.height] };
        if axes.len() != extents.len() {
            return Err(Error::invalid(
                key,
                format!(
                    "{} axes given; a {} texture needs {}",
                    axes.len(),
                    if self.volume {
                        "volume"
                    } else if self.layered {
                        "layered"
                    } else {
                        "2D"
                    },
                    extents.len()
                ),
            ));
        }
        for ((axis, &extent), dimension) in axes.iter().zip(extents).zip(["width", "height", "depth"]) {
            if axis.count as u64 != u64::from(extent) {
                return Err(Error::invalid(
                    key,
                    format!("axis `{}` has {} nodes, the texture {dimension} is {extent}", axis.name, axis.count),
                ));
            }
        }
        if axes.len() == 3 && (axes[2].name == LAYER_AXIS) != self.layered {
            return Err(Error::invalid(
                key,
                if self.layered {
                    format!("the texture is an array, so its third axis is `{LAYER_AXIS}`, not `{}`", axes[2].name)
                } else {
                    format!("the texture is a volume, its third axis cannot be the layers of an array (`{LAYER_AXIS}`)")
                },
            ));
        }
        if channels != self.channels {
            return Err(Error::invalid(key, format!("{channels} channels given, the texture holds {}", self.channels)));
        }
        Ok(())
    }
}

/// The components of a float texel format of `channels` channels in `precision`, as DXGI and
/// Vulkan name them: `R16G16` for two f16 channels.
pub(crate) fn component_layout(channels: usize, precision: Precision) -> String {
    let bits = precision.bytes() * 8;
    ["R", "G", "B", "A"][..channels.min(4)].iter().map(|c| format!("{c}{bits}")).collect()
}

/// A table or axis refused while reading means the file, not an argument, is wrong: re-raise an
/// `Invalid` error as a `Format` error of `path`, keeping what was invalid and why.
pub fn as_format_error(error: Error, path: &Path) -> Error {
    match error {
        Error::Invalid { key, reason } => Error::format(path, format!("{key}: {reason}")),
        other => other,
    }
}

/// The largest table file tmlut reads: 4 GiB, above the largest table a build may make
/// (`tmlut`'s `recipes::MAX_BUILD_BYTES` bounds what one table needs in memory, well below it).
pub const MAX_TABLE_FILE_BYTES: u64 = 1 << 32;

/// The largest `manifest.json` or furnace report tmlut reads or writes: 256 MiB. The default set's
/// manifest is about 1 MiB; a scene's carries its text, its plan and an entry per slice, and the
/// largest library a build plans (10,240 materials, `scene::library::MAX_LIBRARY_MATERIALS`) writes
/// about 90 MB (`docs/scenes.md`).
pub const MAX_MANIFEST_BYTES: u64 = 256 << 20;

/// The largest shader file tmlut reads or writes: 512 MiB. A library's shader has a function per
/// material in each language, about 8 KiB of WGSL each: the largest library's is about 90 MB.
pub const MAX_SHADER_FILE_BYTES: u64 = 512 << 20;

/// The largest configuration, scene or budgets file tmlut reads: 16 MiB.
pub const MAX_TEXT_INPUT_BYTES: u64 = 16 << 20;

/// Read a table file, naming it in the error ([`files::FileKind::read`]: a regular file of at most
/// [`MAX_TABLE_FILE_BYTES`], held to the memory this process may use where large).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    files::FileKind::Table.read(path)
}

/// SHA-256 of `bytes` in lowercase hexadecimal, as the manifest states it.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textures_then_lists_the_texture_formats_first_and_refuses_a_wrong_count_or_a_repeat() {
        let order: [FileFormat; 3] = FileFormat::textures_then(&[FileFormat::Exr]);
        assert_eq!(order[..FileFormat::TEXTURES.len()], FileFormat::TEXTURES);
        assert_eq!(order[FileFormat::TEXTURES.len()..], [FileFormat::Exr]);
        assert!(std::panic::catch_unwind(|| FileFormat::textures_then::<4>(&[FileFormat::Exr])).is_err());
        assert!(std::panic::catch_unwind(|| FileFormat::textures_then::<3>(&[FileFormat::Ktx2])).is_err());
        assert!(
            std::panic::catch_unwind(|| FileFormat::textures_then::<4>(&[FileFormat::Bin, FileFormat::Bin])).is_err()
        );
    }

    #[test]
    fn textures_hold_two_or_three_axes_and_bin_only_an_original_layout() {
        use FileFormat::{Bin, Dds, Exr, Ktx2};
        assert_eq!(FileFormat::for_table(4, true), [Bin, Exr]);
        assert_eq!(FileFormat::for_table(3, true), [Bin, Dds, Exr, Ktx2]);
        assert_eq!(FileFormat::for_table(2, false), [Dds, Exr, Ktx2]);
        assert_eq!(FileFormat::for_table(1, false), [Exr]);
    }
}
