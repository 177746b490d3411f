//! Reading what tmlut wrote, for renderer crates: built without the generator's dependencies
//! (the `tmlut-loader` crate; add the `exr` feature to read OpenEXR files, `bytemuck` to borrow
//! texel bytes without a copy). `docs/loader.md` walks through it.
//!
//! - [`LutFolder`]: an output folder and its read-only manifest; every file is loaded verified
//!   against its entry (length, SHA-256, axes, channels, value range). The folder's files are
//!   read from disk ([`LutFolder::open`]) or from anywhere else that hands over their bytes by
//!   name ([`LutFolder::from_source`]: files held in memory, [`InMemory`], or a [`LutSource`] of
//!   one's own), with the same checks.
//! - Typed handles ([`KarisLut`], [`BelcourLut`], [`GdLut`], [`TirLut`], [`FgdLut`],
//!   [`FgdRarerLut`], [`GgxELut`], [`GgxEAvgLut`], [`KarisMultiscatterLut`]): sampled with plain arguments, allocation-free, as the CPU interpolates or
//!   as a GPU filters.
//! - [`TextureData`]: a table's texel bytes with the extent, dimension and format of the texture
//!   that holds them, named as WebGPU names them.
//! - [`Table`]: any table, interpolated in its axes' own quantities
//!   ([`Table::interpolate_into`] returns an error on a wrong number of coordinates).
//!
//! DDS files carry no description of their axes: the folder's `manifest.json` supplies it. EXR
//! and KTX2 files written by tmlut carry their own; `.bin` files carry ranges and node counts but not axis
//! names, which the manifest adds when present.

pub mod baked;
pub mod handles;
pub mod roughness;
pub mod shader;
pub mod source;
#[cfg(test)]
mod tests;
pub mod texture;

pub use crate::error::{Error, Result};
pub use crate::formats::manifest::{FileEntry, Manifest, ShaderFile};
pub use crate::formats::{FileFormat, Precision, sha256_hex};
pub use crate::table::{Axis, Channel, InterpolationError, Mapping, Placement, Table};
pub use baked::BakedLut;
pub use handles::{
    BelcourLut, FgdLut, FgdRarerLut, GdLut, GgxEAvgLut, GgxELut, KarisLut, KarisMultiscatterLut, TirLut,
};
pub use roughness::{Alpha, Roughness};
pub use shader::{
    ConstantsBuffer, DeviceLimits, MaterialFunction, SceneShaderFiles, ShaderDescription, ShapeFunction, TextureBinding,
};
pub use source::{InMemory, LutSource, OnDisk};
pub use texture::{
    Texels, TextureData, TextureDescriptor, TextureDimension, TextureFormat, sample_texture, texture_coordinate,
};

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::formats::files::FileKind;
use crate::formats::manifest::{
    COMMIT_JOURNAL, FitEntry, MANIFEST_FILE, check_file_name, pending_commit, pending_commit_error,
};
use crate::formats::{bin, dds, ktx2, read_bytes};

/// An output folder of tmlut and its manifest, read once and never changed: every file loaded
/// through it is verified against the entry read here. Its files are read from a [`LutSource`]:
/// a folder on disk ([`LutFolder::open`]) or files held in memory ([`InMemory`]).
#[derive(Debug, Clone)]
pub struct LutFolder {
    source: Arc<dyn LutSource>,
    manifest: Manifest,
}

impl LutFolder {
    /// Open the folder `dir` on disk: its manifest, refused if a build was interrupted while
    /// committing into it.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self> {
        Self::from_source(OnDisk::new(dir.as_ref()))
    }

    /// Open the folder whose files `source` holds (files held in memory: [`InMemory`]): its
    /// manifest, refused if it holds the journal of a commit that was interrupted. Every file is
    /// then loaded and verified as [`LutFolder::open`]'s are, with the same errors, each naming a
    /// file by [`LutSource::root`] and its name.
    pub fn from_source(source: impl LutSource + 'static) -> Result<Self> {
        if source.contains(COMMIT_JOURNAL) {
            return Err(pending_commit_error(&source.root().join(COMMIT_JOURNAL)));
        }
        let manifest = {
            let bytes = read_checked(&source, MANIFEST_FILE, FileKind::Manifest)?;
            Manifest::from_bytes(&bytes, &source.root().join(MANIFEST_FILE))?
        };
        Ok(LutFolder { source: Arc::new(source), manifest })
    }

    /// The folder's path, as given to [`LutFolder::open`]; for files held elsewhere, the root
    /// their source names them by ([`LutSource::root`]).
    pub fn dir(&self) -> &Path {
        self.source.root()
    }

    /// Where the folder's files are read from.
    pub fn source(&self) -> &dyn LutSource {
        self.source.as_ref()
    }

    /// The manifest as read at opening.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The names of the files the manifest lists, sorted.
    pub fn files(&self) -> impl Iterator<Item = &str> {
        self.manifest.files.keys().map(String::as_str)
    }

    /// The file holding table `table` whole (not a packing of it): of the manifest's files of
    /// that table, the first in `formats`' order, the first by name within a format. Every reader
    /// finds a table's file this way: the typed handles, the model's folder tables and the scene
    /// shader.
    pub fn table_file(&self, table: &str, formats: &[FileFormat]) -> Option<(&str, &FileEntry)> {
        self.first_file(formats, |e| e.table == table && e.packing.is_none())
    }

    /// The file holding the packing named `packing` (`lossless`), found as [`LutFolder::table_file`]
    /// finds a table's.
    pub fn packing_file(&self, packing: &str, formats: &[FileFormat]) -> Option<(&str, &FileEntry)> {
        self.first_file(formats, |e| e.packing.as_ref().is_some_and(|p| p.name == packing))
    }

    /// The first file in `formats`' order, then by name, whose entry is `wanted`.
    fn first_file(&self, formats: &[FileFormat], wanted: impl Fn(&FileEntry) -> bool) -> Option<(&str, &FileEntry)> {
        formats.iter().find_map(|&format| {
            let mut files = self.manifest.files.iter();
            files.find(|(_, e)| e.format == format && wanted(e)).map(|(file, entry)| (file.as_str(), entry))
        })
    }

    /// The fitted TIR form the folder states: the one beside its TIR table (`[tir] fit`), else its
    /// scene plan's (a scene whose materials read only the form has no TIR table).
    pub fn tir_fit(&self) -> Option<&FitEntry> {
        let beside_a_table = self.manifest.files.values().find_map(|e| e.fit.as_ref());
        beside_a_table.or_else(|| self.manifest.scene.as_ref().and_then(|s| s.plan.tir_fit.as_ref()))
    }

    /// The files a GPU binds as textures, sorted: a table (or packing of it) written in several
    /// texture formats is bound once, from the format [`FileFormat::TEXTURES`] lists first (DDS
    /// before KTX2).
    pub fn gpu_textures(&self) -> impl Iterator<Item = (&str, &FileEntry)> {
        let files = &self.manifest.files;
        let rank = |format: FileFormat| FileFormat::TEXTURES.iter().position(|&f| f == format);
        fn packing(e: &FileEntry) -> Option<&str> {
            e.packing.as_ref().map(|p| p.name.as_str())
        }
        let preferred_twin = move |entry: &FileEntry, rank_of_entry: usize| {
            files.values().any(|e| {
                rank(e.format).is_some_and(|r| r < rank_of_entry)
                    && e.table == entry.table
                    && packing(e) == packing(entry)
            })
        };
        files
            .iter()
            .map(|(file, entry)| (file.as_str(), entry))
            .filter(move |(_, entry)| rank(entry.format).is_some_and(|r| !preferred_twin(entry, r)))
    }

    /// The slices of a scene build that `wanted` picks by their entry, with their tables, whether
    /// each is a file of its own or a region of a texture array ([`FolderSlice`]). Each file is
    /// loaded verified ([`LutFolder::load`]); an array whose manifest places a slice outside it is
    /// refused, naming the slice.
    pub fn scene_slices(&self, wanted: impl Fn(&FileEntry) -> bool) -> Result<Vec<FolderSlice>> {
        let mut slices = Vec::new();
        for (file, entry) in self.gpu_textures() {
            let Some(array) = &entry.slice_array else {
                if entry.axes.len() == 2 && entry.channels.iter().any(|c| !c.fixed.is_empty()) && wanted(entry) {
                    slices.push(FolderSlice {
                        entry: entry.clone(),
                        table: self.load(file)?,
                        file: file.to_string(),
                        place: None,
                    });
                }
                continue;
            };
            let mut base = entry.clone();
            base.slice_array = None;
            base.binding = None;
            let members: Vec<(FileEntry, &crate::formats::slice_array::ArraySlice)> = array
                .slices
                .iter()
                .map(|slice| {
                    let mut member = base.clone();
                    member.table = slice.table.clone();
                    member.axes = slice.axes.clone();
                    member.channels = slice.channels.clone();
                    member.value_range = slice.value_range;
                    member.error = slice.error.clone();
                    member.accuracy = slice.accuracy.clone();
                    (member, slice)
                })
                .filter(|(member, _)| wanted(member))
                .collect();
            if members.is_empty() {
                continue;
            }
            let texels = self.load(file)?;
            for (member, slice) in members {
                let table = crate::formats::slice_array::unpack(&texels, slice)
                    .map_err(|e| Error::format(self.dir().join(file), e.to_string()))?;
                slices.push(FolderSlice {
                    entry: member,
                    table,
                    file: file.to_string(),
                    place: Some(ArrayPlace {
                        layer: slice.layer,
                        origin: slice.origin,
                        layer_extent: array.layer_extent,
                        layers: array.layers,
                    }),
                });
            }
        }
        Ok(slices)
    }

    /// The manifest entry of a file in this folder.
    pub fn entry(&self, file: &str) -> Result<&FileEntry> {
        self.manifest.entry(file).ok_or_else(|| {
            let listed: Vec<&str> = self.manifest.files.keys().map(String::as_str).collect();
            Error::Missing {
                path: self.dir().join(MANIFEST_FILE),
                reason: format!("lists no file `{file}`; it lists: {}", listed.join(", ")),
            }
        })
    }

    /// Load a file of this folder as a table with the manifest's axes and channels, verified
    /// against its entry ([`load_verified`]).
    pub fn load(&self, file: &str) -> Result<Table> {
        check_file_name(file).map_err(|reason| Error::format(self.dir().join(MANIFEST_FILE), reason))?;
        let entry = self.entry(file)?;
        let bytes = read_checked(self.source.as_ref(), file, FileKind::Table)?;
        decode_verified(&self.dir().join(file), &bytes, entry)
    }

    /// The texel bytes and texture descriptor of a file of this folder, in the precision it is
    /// stored in, loaded as [`LutFolder::load`] loads it: what a renderer uploads for a table the
    /// typed handles do not cover (a scene's slices, a packed FGD volume). Refused for a table of
    /// four axes or of three channels, naming it.
    pub fn texture(&self, file: &str) -> Result<TextureData> {
        TextureData::from_table(&self.load(file)?, stored_precision(self.entry(file)?))
    }

    /// The text of a shader file the manifest lists (a packing's lookup, a fitted form's
    /// function: `FileEntry::packing` and `FileEntry::fit` name them), verified against the
    /// SHA-256 stated for it.
    pub fn shader(&self, shader: &ShaderFile) -> Result<String> {
        let file = &shader.file;
        check_file_name(file).map_err(|reason| Error::format(self.dir().join(MANIFEST_FILE), reason))?;
        let bytes = read_checked(self.source.as_ref(), file, FileKind::Shader)?;
        shader::text_verified(&self.dir().join(file), &bytes, None, Some(&shader.sha256))
    }
}

/// The bytes of `file` of `source`, refused beyond the limit of their `kind` however the source
/// came by them.
fn read_checked<'a>(source: &'a dyn LutSource, file: &str, kind: FileKind) -> Result<Cow<'a, [u8]>> {
    let bytes = source.read(file, kind)?;
    kind.check_length(&source.root().join(file), bytes.len())?;
    Ok(bytes)
}

/// A slice of a scene build as [`LutFolder::scene_slices`] finds it.
#[derive(Debug, Clone)]
pub struct FolderSlice {
    /// Its entry: its own file's or, in a texture array, the array's with the slice's table name,
    /// axes (their `texture_coordinate` in the array), channels, value range and error.
    pub entry: FileEntry,
    /// The slice's values, cut out of the array where it lies in one.
    pub table: Table,
    /// The file holding it.
    pub file: String,
    /// Where in the array, for a slice of one.
    pub place: Option<ArrayPlace>,
}

/// Where a slice lies in a texture array: its layer, the texel of its first node, and the array's
/// extent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArrayPlace {
    /// The layer holding the slice, from 0.
    pub layer: u32,
    /// The texel of its first node, `[x, y]`.
    pub origin: [u32; 2],
    /// The array's texels per layer, `[width, height]`.
    pub layer_extent: [u32; 2],
    /// The array's number of layers.
    pub layers: u32,
}

/// The precision a file's values are stored in: its entry's, f32 for `.bin` (which has no
/// precision field: f32 by definition).
fn stored_precision(entry: &FileEntry) -> Precision {
    if entry.format == FileFormat::Bin { Precision::F32 } else { entry.precision }
}

/// Load a file listed in a manifest and verify it against its entry: the bytes must have the
/// entry's length and SHA-256, the entry the claims the build sealed
/// ([`FileEntry::claims_disagreement`]), and what the file states about itself (axes, orientation,
/// channels, value range, non-finite values) must be what the entry states. A file replaced or
/// damaged after the build that described it is refused, naming what differs.
///
/// Hashing 64 MiB (the FGD table) takes 34 ms on the project's 2-core machine (`docs/formats.md`);
/// it is done on every load, since a table that is not what its manifest says is read wrong
/// without any other sign.
pub fn load_verified(path: impl AsRef<Path>, entry: &FileEntry) -> Result<Table> {
    let path = path.as_ref();
    decode_verified(path, &read_bytes(path)?, entry)
}

/// The table a file's `bytes` hold, verified against its entry as [`load_verified`] verifies a
/// file it reads; `path` names the file in errors.
pub fn decode_verified(path: &Path, bytes: &[u8], entry: &FileEntry) -> Result<Table> {
    let format = format_of_bytes(path, bytes)?;
    let mut disagreements = byte_disagreements(entry, bytes);
    disagreements.extend(entry.claims_disagreement());
    if disagreements.is_empty() {
        let table = decode(path, bytes, format, Some(entry))?;
        disagreements = table_disagreements(entry, format, bytes, &table);
        if disagreements.is_empty() {
            return Ok(table);
        }
    }
    Err(Error::Mismatch {
        path: path.to_path_buf(),
        reason: format!("differs from its entry in {MANIFEST_FILE}: {}", disagreements.join("; ")),
    })
}

/// Load a table file, taking its description from the `manifest.json` beside it when there is one
/// (and then verified against it, as [`load_verified`]).
pub fn load_table(path: impl AsRef<Path>) -> Result<Table> {
    let path = path.as_ref();
    let beside = ManifestBeside::of(path)?;
    match beside.entry() {
        Some(entry) => load_verified(path, entry),
        None => {
            let bytes = read_bytes(path)?;
            decode(path, &bytes, format_of_bytes(path, &bytes)?, None)
        }
    }
}

/// The `manifest.json` of the folder a file sits in, if there is one, and the file's name there.
#[derive(Debug, Clone)]
pub struct ManifestBeside {
    /// Where the manifest is or would be: `manifest.json` in the file's folder.
    pub manifest_path: PathBuf,
    /// The manifest, where the folder has one.
    pub manifest: Option<Manifest>,
    /// The file's name inside its folder.
    pub file: String,
}

impl ManifestBeside {
    /// The manifest beside `path`; refused where a build was interrupted while committing into
    /// its folder, or the manifest there cannot be read.
    pub fn of(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if let Some(journal) = pending_commit(dir) {
            return Err(pending_commit_error(&journal));
        }
        let manifest_path = dir.join(MANIFEST_FILE);
        let manifest = if manifest_path.exists() { Some(Manifest::read(&manifest_path)?) } else { None };
        Ok(ManifestBeside { manifest_path, manifest, file })
    }

    /// The file's entry, if the manifest lists it.
    pub fn entry(&self) -> Option<&FileEntry> {
        self.manifest.as_ref().and_then(|m| m.entry(&self.file))
    }
}

/// Decode a table file's bytes; a DDS file needs its manifest entry for axes and channels (EXR and
/// KTX2 files written by tmlut state their own).
pub fn decode(path: &Path, bytes: &[u8], format: FileFormat, entry: Option<&FileEntry>) -> Result<Table> {
    let name = entry.map(|e| e.table.clone()).unwrap_or_else(|| file_stem(path));
    match format {
        FileFormat::Dds => {
            let entry = entry.ok_or_else(|| {
                Error::format(
                    path,
                    format!(
                        "a DDS file stores no axes; expected {MANIFEST_FILE} beside it with an entry for this file"
                    ),
                )
            })?;
            let axes = entry.axes.iter().map(|a| a.axis.clone()).collect();
            dds::decode_dds(bytes, path)?
                .into_table(&name, axes, entry.channels.clone())
                .map_err(|e| crate::formats::as_format_error(e, path))
        }
        FileFormat::Bin => {
            let names: Option<Vec<&str>> = entry.map(|e| e.axes.iter().map(|a| a.axis.name.as_str()).collect());
            let mut table = bin::decode_bin(bytes, path, names.as_deref())?;
            if let Some(entry) = entry {
                if entry.channels.len() != 1 {
                    return Err(Error::format(
                        path,
                        format!(
                            "{MANIFEST_FILE} states {} channels; a .bin file holds exactly one",
                            entry.channels.len()
                        ),
                    ));
                }
                table.name = name;
                table.channels = entry.channels.clone();
            }
            Ok(table)
        }
        // A KTX2 file written by tmlut describes its own table, as an EXR file does.
        FileFormat::Ktx2 => {
            ktx2::decode_ktx2(bytes, path)?.into_table().map_err(|e| crate::formats::as_format_error(e, path))
        }
        #[cfg(feature = "exr")]
        FileFormat::Exr => crate::formats::exr::decode_exr(bytes, path),
        #[cfg(not(feature = "exr"))]
        FileFormat::Exr => Err(crate::formats::no_exr_support(path)),
    }
}

/// Where a file's bytes disagree with its entry: length and SHA-256.
pub fn byte_disagreements(entry: &FileEntry, bytes: &[u8]) -> Vec<String> {
    let mut found = Vec::new();
    if entry.bytes != bytes.len() as u64 {
        found.push(format!("the file has {} bytes, the manifest states {}", bytes.len(), entry.bytes));
    }
    let sha256 = sha256_hex(bytes);
    if sha256 != entry.sha256 {
        found.push(format!("its SHA-256 is {sha256}, the manifest states {}", entry.sha256));
    }
    found
}

/// Where the table a file holds disagrees with what its entry states: format, axes (node counts
/// and, where the file stores them, ranges and orientation), channels, non-finite values and the
/// value range (the manifest's range, rounded to the file's precision, must be the stored one).
pub fn table_disagreements(entry: &FileEntry, format: FileFormat, bytes: &[u8], table: &Table) -> Vec<String> {
    let mut found = Vec::new();
    if entry.format != format {
        found.push(format!("the file is {format:?}, the manifest states {:?}", entry.format));
    }
    let texel_format = match format {
        FileFormat::Dds => dds::stored_format(bytes)
            .map(|(c, p)| (dds::dxgi_format_name(c, p), p, entry.dxgi_format.as_deref(), "DXGI")),
        FileFormat::Ktx2 => ktx2::stored_format(bytes)
            .map(|(c, p)| (ktx2::vk_format_name(c, p), p, entry.vk_format.as_deref(), "Vulkan")),
        FileFormat::Exr | FileFormat::Bin => None,
    };
    if let Some((stored, precision, stated, api)) = texel_format
        && (stated != Some(stored.as_str()) || entry.precision != precision)
    {
        found.push(format!(
            "the texture is {stored}, the manifest states {} ({:?})",
            stated.unwrap_or(&format!("no {api} format")),
            entry.precision
        ));
    }
    let stated: Vec<&crate::table::Axis> = entry.axes.iter().map(|a| &a.axis).collect();
    if stated.len() != table.axes.len() {
        found.push(format!("the file has {} axes, the manifest states {}", table.axes.len(), stated.len()));
    } else {
        for (stored, stated) in table.axes.iter().zip(stated) {
            let same = match format {
                // A DDS file stores node counts only; its axes are the manifest's own.
                FileFormat::Dds => stored.count == stated.count,
                // `.bin` stores the range ends as float32.
                FileFormat::Bin => {
                    stored.count == stated.count
                        && stored.start as f32 == stated.start as f32
                        && stored.end as f32 == stated.end as f32
                }
                FileFormat::Exr | FileFormat::Ktx2 => stored == stated,
            };
            if !same {
                found.push(format!(
                    "axis `{}`: the file has {} nodes over [{}, {}], the manifest states {} nodes over [{}, {}]",
                    stated.name, stored.count, stored.start, stored.end, stated.count, stated.start, stated.end
                ));
            }
        }
    }
    if table.channels.len() != entry.channels.len()
        || (matches!(format, FileFormat::Exr | FileFormat::Ktx2)
            && table.channels.iter().zip(&entry.channels).any(|(a, b)| a.name != b.name))
    {
        let names = |c: &[crate::table::Channel]| c.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ");
        found.push(format!(
            "the file has the channels [{}], the manifest states [{}]",
            names(&table.channels),
            names(&entry.channels)
        ));
    }
    let stats = table.stats();
    let non_finite = stats.nan_count + stats.infinite_count;
    if non_finite != entry.nan_count {
        found.push(format!(
            "the file holds {non_finite} NaN or infinite values, the manifest states {}",
            entry.nan_count
        ));
    }
    // Rounding is monotonic, so the stored extremes are the rounded extremes of the f32 table.
    let precision = if format == FileFormat::Bin { Precision::F32 } else { entry.precision };
    let [lo, hi] = entry.value_range.map(|v| precision.round(v));
    let values_present = stats.min <= stats.max;
    if values_present && (stats.min.to_bits() != lo.to_bits() || stats.max.to_bits() != hi.to_bits()) {
        found.push(format!(
            "its values span [{}, {}], the manifest states [{}, {}] ({:?})",
            stats.min, stats.max, entry.value_range[0], entry.value_range[1], precision
        ));
    }
    found
}

/// The format of a file, from its first bytes (see [`format_of`]).
pub fn format_of_bytes(path: &Path, bytes: &[u8]) -> Result<FileFormat> {
    let magic: [u8; 4] = bytes.get(..4).and_then(|m| m.try_into().ok()).unwrap_or_default();
    format_of_magic(path, magic, bytes.len() >= 4)
}

/// The format of a file, from its first bytes (DDS, OpenEXR and KTX2 have magic numbers) or, for
/// the magic-less `.bin` layout, its extension.
pub fn format_of(path: impl AsRef<Path>) -> Result<FileFormat> {
    let path = path.as_ref();
    let mut magic = [0u8; 4];
    let (mut file, _) = crate::formats::files::open_regular(path, "a table file")?;
    let read = std::io::Read::read(&mut file, &mut magic).map_err(|source| Error::io(path, source))?;
    format_of_magic(path, magic, read == 4)
}

fn format_of_magic(path: &Path, magic: [u8; 4], complete: bool) -> Result<FileFormat> {
    if complete && &magic == b"DDS " {
        return Ok(FileFormat::Dds);
    }
    if complete && magic == [0x76, 0x2f, 0x31, 0x01] {
        return Ok(FileFormat::Exr);
    }
    // `«KTX`, the start of the 12-byte KTX identifier (the reader checks the rest: version 2.0).
    if complete && magic == [0xAB, b'K', b'T', b'X'] {
        return Ok(FileFormat::Ktx2);
    }
    match path.extension().and_then(|e| e.to_str()).and_then(FileFormat::from_extension) {
        Some(FileFormat::Bin) => Ok(FileFormat::Bin),
        _ => Err(Error::format(
            path,
            "not a table tmlut reads: allowed are DDS (magic `DDS `), OpenEXR (magic 76 2f 31 01), KTX2 (identifier \
             «KTX 20»\\r\\n\\x1A\\n) and the transfer-matrix `.bin` layout",
        )),
    }
}

fn file_stem(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}
