//! A scene shader as a renderer reads it: the WGSL and HLSL that `tmlut shader` (and `tmlut build
//! --scene`) writes, and `<scene>.shader.json`, what each texture binding holds and which function
//! evaluates which material (`docs/shaders.md`).
//!
//! ```no_run
//! use tmlut_loader::{LutFolder, SceneShaderFiles};
//!
//! let luts = LutFolder::open("out/copper-pot")?; // tmlut build --scene: the shader lies beside the tables
//! let shader = SceneShaderFiles::open(luts.dir())?; // verified against the manifest, which lists it
//! for texture in shader.description.textures.iter() {
//!     let data = luts.texture(&texture.file)?; // bound at @group(0) @binding(texture.binding)
//!     # let _ = data;
//! }
//! let wgsl: &str = &shader.wgsl; // one function per material: shader.description.materials
//! # let _ = wgsl;
//! # Ok::<(), tmlut_loader::Error>(())
//! ```

use std::borrow::Cow;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{Manifest, sha256_hex};
use crate::error::{Error, Result};
use crate::formats::files::FileKind;
use crate::formats::manifest::{MANIFEST_FILE, check_file_name};

/// The suffix of a scene shader's description file: `<scene>.shader.json`.
pub const DESCRIPTION_SUFFIX: &str = ".shader.json";

/// A texture the shader binds: its binding in group 0 and the file it holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextureBinding {
    /// The binding number in group 0 (HLSL: register `tN`).
    pub binding: u32,
    /// The variable in the shader.
    pub variable: String,
    /// The folder's file whose texels it holds.
    pub file: String,
    /// `[width, height, depth]` in texels.
    pub extent: [usize; 3],
    /// 2 or 3.
    pub dimension: u8,
    /// Channels per texel as stored (1, 2 or 4).
    pub channels: usize,
    /// An array of 2D textures (slices of a library; `extent[2]` is its layer count), bound as
    /// `texture_2d_array<f32>` / `Texture2DArray<float4>`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub layered: bool,
    /// How WebGPU creates and binds it: the texel format as stored (`r32float`, ...: the file's
    /// DXGI or Vulkan format), the view dimension (`2d`, `3d`, `2d-array`) and the sample type,
    /// always `unfilterable-float`: the shader loads texels and filters them itself.
    #[serde(default)]
    pub format: String,
    /// The WebGPU view dimension: `2d`, `3d` or `2d-array`.
    #[serde(default)]
    pub view_dimension: String,
    /// The WebGPU sample type: `unfilterable-float`.
    #[serde(default)]
    pub sample_type: String,
}

/// A material's function in the shader.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialFunction {
    /// The material's name, as the scene gives it.
    pub material: String,
    /// The name of its function in the WGSL and the HLSL, which takes the view cosine `mu = n.v`.
    pub function: String,
    /// Lobes it fills in `TmResult` (the rest are zero).
    pub lobes: usize,
    /// The bindings of the textures it reads: a pipeline running it alone binds only these (WebGPU
    /// allows 16 sampled textures per stage unless a device asks for more).
    pub textures: Vec<u32>,
    /// The flux model it evaluates: `2-flux` or `6-flux`.
    pub model: String,
    /// What its lookups read: `fgd slice`, `fgd packing`, `fgd_rarer table`, `belcour`, `karis`,
    /// `tir slice`, `tir table` (3D), `tir fit`, `gd`.
    pub reads: Vec<String>,
    /// What one call of it costs, counted on the shader's description (helpers included).
    #[serde(default)]
    pub cost: ShaderCost,
}

/// What one call of a shader function costs a GPU, counted on the shader's description rather than
/// its text (tmlut-ir's `shader::cost`, which states what counts), the functions it calls included
/// where they are called.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShaderCost {
    /// Texture reads: texel loads and filtered samples.
    pub texture_reads: u32,
    /// Arithmetic operations: each operator, builtin call, `select` and scalar conversion.
    pub operations: u32,
}

/// The suffix of a baked shader's description file: `<stem>.baked.shader.json`.
pub const BAKED_DESCRIPTION_SUFFIX: &str = ".baked.shader.json";

/// `<stem>.baked.shader.json`: what a renderer binds and calls to read the baked materials of a
/// texture array (tmlut's `shader::baked`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedShaderDescription {
    /// The struct every function returns (`TmResult`, as the scene shader's).
    pub result_struct: String,
    /// The length of its lobe arrays.
    pub max_lobes: usize,
    /// The function every material's is a call of: `(material index, mu) -> TmResult`, for a
    /// renderer that has a material's index rather than its name.
    pub function: String,
    /// The texture array of baked rows: `view_dimension` `2d-array`, `sample_type` `float` (the
    /// sampler filters it).
    pub texture: TextureBinding,
    /// The sampler the rows are read with.
    pub sampler: SamplerBinding,
    /// Every material's function, by index.
    pub materials: Vec<BakedMaterialFunction>,
    /// How to create and bind the texture and the sampler and call the functions, in words.
    pub notes: String,
}

/// A sampler the shader binds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SamplerBinding {
    /// The binding number in group 0 (HLSL: register `sN`).
    pub binding: u32,
    /// The variable in the shader.
    pub variable: String,
    /// The WebGPU filter of magnification and minification: `linear`.
    pub filter: String,
    /// The WebGPU address mode of every axis: `clamp-to-edge`.
    pub address_mode: String,
}

/// A baked material's function.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedMaterialFunction {
    /// The material's name, as the scene gives it.
    pub material: String,
    /// Its function, which takes the view cosine `mu = n.v` (the scene shader's name for it).
    pub function: String,
    /// Its index: the first argument of the shared function.
    pub index: u32,
    /// Lobes it fills in the result (the rest are zero).
    pub lobes: usize,
    /// What one call costs.
    pub cost: ShaderCost,
}

/// `<scene>.shader.json`: what a renderer binds and calls. Borrowed where the generator writes it,
/// owned where it is read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShaderDescription<'a> {
    /// The struct each material's function returns (`TmResult`).
    pub result_struct: Cow<'a, str>,
    /// The length of its lobe arrays.
    pub max_lobes: usize,
    /// Every texture the shader binds.
    pub textures: Cow<'a, [TextureBinding]>,
    /// Every material's function.
    pub materials: Cow<'a, [MaterialFunction]>,
    /// How to create and bind the textures and call the functions, in words.
    pub notes: Cow<'a, str>,
}

/// The scene shader of a folder: its description and its WGSL and HLSL text.
#[derive(Debug, Clone)]
pub struct SceneShaderFiles {
    /// The files' common stem, the scene's name as an identifier (`copper_pot`).
    pub stem: String,
    /// `<stem>.shader.json`, parsed.
    pub description: ShaderDescription<'static>,
    /// The text of `<stem>.wgsl`.
    pub wgsl: String,
    /// The text of `<stem>.hlsl`.
    pub hlsl: String,
}

impl SceneShaderFiles {
    /// The scene shader in `dir`: its one `<scene>.shader.json` and the `<scene>.wgsl` and
    /// `<scene>.hlsl` beside it. Where `dir`'s manifest lists the scene shader (`tmlut build
    /// --scene`), each file is verified against its length and SHA-256, as tables are.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self> {
        let dir = dir.as_ref();
        let manifest_path = dir.join(MANIFEST_FILE);
        let listed = match manifest_path.exists() {
            true => Manifest::read(&manifest_path)?.scene_shader,
            false => None,
        };
        let stem = match &listed {
            Some(record) => {
                record.files.iter().find_map(|f| f.file.strip_suffix(DESCRIPTION_SUFFIX)).map(str::to_owned)
            }
            None => None,
        };
        let stem = match stem {
            Some(stem) => stem,
            None => only_description(dir)?,
        };
        let read = |file: String| -> Result<String> {
            match listed.as_ref().and_then(|r| r.files.iter().find(|f| f.file == file)) {
                Some(entry) => read_text_verified(dir, &file, Some(entry.bytes), Some(&entry.sha256)),
                None => read_text_verified(dir, &file, None, None),
            }
        };
        let description_path = dir.join(format!("{stem}{DESCRIPTION_SUFFIX}"));
        let description = serde_json::from_str(&read(format!("{stem}{DESCRIPTION_SUFFIX}"))?)
            .map_err(|e| Error::format(&description_path, format!("not a scene shader description: {e}")))?;
        Ok(SceneShaderFiles {
            wgsl: read(format!("{stem}.wgsl"))?,
            hlsl: read(format!("{stem}.hlsl"))?,
            description,
            stem,
        })
    }
}

/// The text of the shader file `file` of `dir` (a plain file name), verified against the length
/// and SHA-256 a manifest states for it, where it states them.
fn read_text_verified(
    dir: &Path,
    file: &str,
    stated_bytes: Option<u64>,
    stated_sha256: Option<&str>,
) -> Result<String> {
    check_file_name(file).map_err(|reason| Error::format(dir.join(MANIFEST_FILE), reason))?;
    let path = dir.join(file);
    text_verified(&path, &FileKind::Shader.read(&path)?, stated_bytes, stated_sha256)
}

/// The text of a shader file's `bytes`, verified against the length and SHA-256 a manifest states
/// for it, where it states them; `path` names the file in errors.
pub(crate) fn text_verified(
    path: &Path,
    bytes: &[u8],
    stated_bytes: Option<u64>,
    stated_sha256: Option<&str>,
) -> Result<String> {
    let mut disagreements = Vec::new();
    if let Some(stated) = stated_bytes
        && stated != bytes.len() as u64
    {
        disagreements.push(format!("the file has {} bytes, the manifest states {stated}", bytes.len()));
    }
    if let Some(stated) = stated_sha256 {
        let sha256 = sha256_hex(bytes);
        if sha256 != stated {
            disagreements.push(format!("its SHA-256 is {sha256}, the manifest states {stated}"));
        }
    }
    if !disagreements.is_empty() {
        return Err(Error::Mismatch {
            path: path.to_path_buf(),
            reason: format!("differs from its entry in {MANIFEST_FILE}: {}", disagreements.join("; ")),
        });
    }
    String::from_utf8(bytes.to_vec()).map_err(|_| Error::format(path, "is not UTF-8 text"))
}

/// The stem of the one `*.shader.json` in `dir`.
fn only_description(dir: &Path) -> Result<String> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::io(dir, source))?;
    let mut stems: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        // A baked shader's description is not a scene shader's.
        .filter(|name| !name.ends_with(BAKED_DESCRIPTION_SUFFIX))
        .filter_map(|name| name.strip_suffix(DESCRIPTION_SUFFIX).map(str::to_owned))
        .collect();
    stems.sort();
    match stems.as_slice() {
        [stem] => Ok(stem.clone()),
        [] => Err(Error::format(
            dir,
            format!(
                "holds no scene shader (*{DESCRIPTION_SUFFIX}); `tmlut shader SCENE --luts DIR --out DIR` writes one"
            ),
        )),
        _ => Err(Error::format(
            dir,
            format!(
                "holds {} scene shaders ({}); open one folder per scene",
                stems.len(),
                stems.iter().map(|s| format!("{s}{DESCRIPTION_SUFFIX}")).collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_without_a_manifest_holds_exactly_one_scene_shader() {
        let dir = tempfile::tempdir().unwrap();
        let err = SceneShaderFiles::open(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds no scene shader (*.shader.json)"), "{err}");

        let description = ShaderDescription {
            result_struct: "TmResult".into(),
            max_lobes: 1,
            textures: Cow::Owned(vec![TextureBinding {
                binding: 0,
                variable: "tm_table0".into(),
                file: "gd.dds".into(),
                extent: [64, 64, 1],
                dimension: 2,
                channels: 1,
                layered: false,
                format: "r32float".into(),
                view_dimension: "2d".into(),
                sample_type: "unfilterable-float".into(),
            }]),
            materials: Cow::Owned(vec![MaterialFunction {
                material: "m".into(),
                function: "tm_m".into(),
                lobes: 1,
                textures: vec![0],
                model: "2-flux".into(),
                reads: vec!["gd".into()],
                cost: ShaderCost { texture_reads: 4, operations: 30 },
            }]),
            notes: "".into(),
        };
        std::fs::write(dir.path().join("a.shader.json"), serde_json::to_string(&description).unwrap()).unwrap();
        std::fs::write(dir.path().join("a.wgsl"), "fn tm_m() {}").unwrap();
        std::fs::write(dir.path().join("a.hlsl"), "").unwrap();
        let read = SceneShaderFiles::open(dir.path()).unwrap();
        assert_eq!((read.stem.as_str(), read.wgsl.as_str()), ("a", "fn tm_m() {}"));
        assert_eq!(read.description, description);

        std::fs::write(dir.path().join("b.shader.json"), "{}").unwrap();
        let err = SceneShaderFiles::open(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds 2 scene shaders (a.shader.json, b.shader.json)"), "{err}");
    }
}
