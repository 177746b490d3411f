//! Reading what tmlut wrote, for renderer crates. Built without the generator's dependencies
//! (`default-features = false`; add the `exr` feature to read OpenEXR files).
//!
//! ```no_run
//! let luts = tmlut::loader::LutFolder::open("luts".as_ref())?;
//! let karis = luts.load("karis.dds")?;
//! // Interpolated exactly as the file's axes say; arguments in the axes' own quantities (mu, alpha).
//! let [scale, bias] = karis.interpolate(&[0.5, 0.25])[..] else { unreachable!() };
//! # Ok::<(), tmlut::Error>(())
//! ```
//!
//! DDS files carry no description of their axes: the folder's `manifest.json` supplies it. EXR
//! files written by tmlut carry their own; `.bin` files carry ranges and node counts but not axis
//! names, which the manifest adds when present.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::formats::manifest::{FileEntry, MANIFEST_FILE, Manifest};
use crate::formats::{FileFormat, bin, dds};
use crate::table::Table;

/// An output folder of tmlut and its manifest.
#[derive(Debug, Clone)]
pub struct LutFolder {
    pub dir: PathBuf,
    pub manifest: Manifest,
}

impl LutFolder {
    pub fn open(dir: &Path) -> Result<Self> {
        let manifest = Manifest::read(&dir.join(MANIFEST_FILE))?;
        Ok(LutFolder { dir: dir.to_path_buf(), manifest })
    }

    /// The manifest entry of a file in this folder.
    pub fn entry(&self, file: &str) -> Result<&FileEntry> {
        self.manifest.entry(file).ok_or_else(|| {
            let listed: Vec<&str> = self.manifest.files.keys().map(String::as_str).collect();
            Error::format(
                self.dir.join(MANIFEST_FILE),
                format!("lists no file `{file}`; it lists: {}", listed.join(", ")),
            )
        })
    }

    /// Load a file of this folder as a table with the manifest's axes and channels.
    pub fn load(&self, file: &str) -> Result<Table> {
        let entry = self.entry(file)?;
        load_with_entry(&self.dir.join(file), Some(entry))
    }
}

/// Load a table file, taking its description from the `manifest.json` beside it when there is one.
pub fn load_table(path: &Path) -> Result<Table> {
    let beside = ManifestBeside::of(path)?;
    load_with_entry(path, beside.entry())
}

/// The `manifest.json` of the folder a file sits in, if there is one, and the file's name there.
#[derive(Debug, Clone)]
pub struct ManifestBeside {
    pub manifest_path: PathBuf,
    pub manifest: Option<Manifest>,
    pub file: String,
}

impl ManifestBeside {
    pub fn of(path: &Path) -> Result<Self> {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let manifest_path = dir.join(MANIFEST_FILE);
        let manifest = if manifest_path.exists() { Some(Manifest::read(&manifest_path)?) } else { None };
        Ok(ManifestBeside { manifest_path, manifest, file })
    }

    /// The file's entry, if the manifest lists it.
    pub fn entry(&self) -> Option<&FileEntry> {
        self.manifest.as_ref().and_then(|m| m.entry(&self.file))
    }
}

/// Load a table file described by `entry` (or, without one, by what the file itself holds).
pub(crate) fn load_with_entry(path: &Path, entry: Option<&FileEntry>) -> Result<Table> {
    let format = format_of(path)?;
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
            dds::read_dds(path)?.into_table(&name, axes, entry.channels.clone())
        }
        FileFormat::Bin => {
            let names: Option<Vec<&str>> = entry.map(|e| e.axes.iter().map(|a| a.axis.name.as_str()).collect());
            let mut table = bin::read_bin(path, names.as_deref())?;
            if let Some(entry) = entry {
                table.name = name;
                table.channels = entry.channels.clone();
            }
            Ok(table)
        }
        #[cfg(feature = "exr")]
        FileFormat::Exr => crate::formats::exr::read_exr(path),
        #[cfg(not(feature = "exr"))]
        FileFormat::Exr => Err(crate::formats::no_exr_support(path)),
    }
}

/// The format of a file, from its first bytes (DDS and OpenEXR have magic numbers) or, for the
/// magic-less `.bin` layout, its extension.
pub fn format_of(path: &Path) -> Result<FileFormat> {
    let mut magic = [0u8; 4];
    let read = std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut magic))
        .map_err(|source| Error::io(path, source))?;
    if read == 4 && &magic == b"DDS " {
        return Ok(FileFormat::Dds);
    }
    if read == 4 && magic == [0x76, 0x2f, 0x31, 0x01] {
        return Ok(FileFormat::Exr);
    }
    match path.extension().and_then(|e| e.to_str()).and_then(FileFormat::from_extension) {
        Some(FileFormat::Bin) => Ok(FileFormat::Bin),
        _ => Err(Error::format(
            path,
            "not a table tmlut reads: allowed are DDS (magic `DDS `), OpenEXR (magic 76 2f 31 01) and the transfer-matrix `.bin` layout",
        )),
    }
}

fn file_stem(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}
