//! The handle of a folder's baked materials ([`crate::formats::baked`]): the array loaded verified,
//! its placement checked once, each material then read at a view cosine as a GPU filters it.

use super::{FileEntry, LutFolder, Table, TextureData, stored_precision};
use crate::error::{Error, Result};
use crate::filter::Filter;
use crate::formats::FileFormat;
use crate::formats::baked::{BakedArrayEntry, BakedMaterialEntry, sample_array};

/// The baked materials of a folder (`tmlut bake`, `tmlut build --scene --bake`).
#[derive(Debug, Clone)]
pub struct BakedLut {
    file: String,
    entry: FileEntry,
    table: Table,
}

impl BakedLut {
    /// The folder's baked array: its file in the order readers prefer formats (the textures as
    /// [`FileFormat::TEXTURES`] lists them, then EXR), loaded verified against the manifest, every
    /// material's place checked. Refused, naming the folder, where it holds no bake.
    pub fn from_folder(folder: &LutFolder) -> Result<Self> {
        const ORDER: [FileFormat; 3] = FileFormat::textures_then(&[FileFormat::Exr]);
        let found = ORDER
            .iter()
            .find_map(|&format| folder.manifest().files.iter().find(|(_, e)| e.format == format && e.baked.is_some()));
        let Some((file, entry)) = found else {
            return Err(Error::Missing {
                path: folder.dir().join(crate::formats::manifest::MANIFEST_FILE),
                reason: "lists no baked array; bake the scene into the folder (tmlut bake, or tmlut build --scene \
                         --bake)"
                    .into(),
            });
        };
        let table = folder.load(file)?;
        let baked = entry.baked.as_ref().expect("found by its baked entry");
        baked.check(&table).map_err(|e| Error::format(folder.dir().join(file), e.to_string()))?;
        Ok(BakedLut { file: file.clone(), entry: entry.clone(), table })
    }

    /// The array's file name in the folder.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The manifest's description of the array and its materials.
    pub fn baked(&self) -> &BakedArrayEntry {
        self.entry.baked.as_ref().expect("checked at opening")
    }

    /// The index of the material named `material`, the index a shader's dispatch takes.
    pub fn material_index(&self, material: &str) -> Option<usize> {
        self.baked().materials.iter().position(|m| m.material == material)
    }

    /// The entry of material `index`.
    pub fn material(&self, index: usize) -> Option<&BakedMaterialEntry> {
        self.baked().materials.get(index)
    }

    /// Material `index`'s values at view cosine `mu` and the values `varied` of its varied
    /// parameters, in the order of its entry's `varied` (those not given at their nominal values;
    /// none for a material whose textures vary nothing), in the order its entry names them
    /// ([`BakedMaterialEntry::values`]), read as a GPU filters the array (8-bit filter weights);
    /// empty for an index past the last material.
    pub fn sample_gpu(&self, index: usize, mu: f32, varied: &[f32]) -> Vec<f32> {
        match self.material(index) {
            Some(material) => sample_array(&self.table, material, mu, varied, Filter::QuantisedWeights { bits: 8 }),
            None => Vec::new(),
        }
    }

    /// The array's texel bytes and texture descriptor, to upload.
    pub fn texture(&self) -> Result<TextureData> {
        TextureData::from_table(&self.table, stored_precision(&self.entry))
    }
}
