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

/// The format of the shader descriptions this loader writes (`format_version` in `*.shader.json`),
/// and the newest it reads. Version 1, the descriptions written before the field existed, stated no
/// device limits, no dispatch function and no texture's depth or layers apart from `extent`, and
/// left `layered` out where it was false; the loader reads it, deriving them. Version 2's scene
/// shaders bound textures only, a function of its own per material; version 3's share one function
/// per stack shape, their constants in a storage buffer (`constants`, `shapes`, each material's
/// `shape` and `constants_offset`, the storage limits), and name the dispatch function.
pub const SHADER_DESCRIPTION_FORMAT: u32 = 3;

/// A texture the shader binds: its binding in group 0 and the file it holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TextureBindingFields")]
pub struct TextureBinding {
    /// The binding number in group 0 (HLSL: register `tN`).
    pub binding: u32,
    /// The variable in the shader.
    pub variable: String,
    /// The folder's file whose texels it holds.
    pub file: String,
    /// The texture's size as WebGPU's `createTexture` takes it: `[width, height,
    /// depth_or_array_layers]` in texels, the third the volume's depth or the array's layers
    /// (`depth` times `array_layers`).
    pub extent: [usize; 3],
    /// The texture's dimension: 2 (a 2D texture, or an array of them) or 3 (a volume).
    pub dimension: u8,
    /// Texels along the third axis of a volume; 1 for a 2D texture or array.
    pub depth: usize,
    /// Layers of a texture array, each `extent[0] x extent[1]` texels; 1 for a texture that is no
    /// array.
    pub array_layers: usize,
    /// Channels per texel as stored (1, 2 or 4).
    pub channels: usize,
    /// An array of 2D textures (a library's slices, a baked array), bound as
    /// `texture_2d_array<f32>` / `Texture2DArray<float4>`; always written, `false` included.
    pub layered: bool,
    /// How WebGPU creates and binds it: the texel format as stored (`r32float`, ...: the file's
    /// DXGI or Vulkan format), the view dimension (`2d`, `3d`, `2d-array`) and the sample type,
    /// always `unfilterable-float`: the shader loads texels and filters them itself.
    pub format: String,
    /// The WebGPU view dimension: `2d`, `3d` or `2d-array`.
    pub view_dimension: String,
    /// The WebGPU sample type: `unfilterable-float` (`float` for a baked array, which a sampler
    /// filters).
    pub sample_type: String,
}

/// A [`TextureBinding`] as a description of any format version states it.
#[derive(Deserialize)]
struct TextureBindingFields {
    binding: u32,
    variable: String,
    file: String,
    extent: [usize; 3],
    dimension: u8,
    depth: Option<usize>,
    array_layers: Option<usize>,
    channels: usize,
    #[serde(default)]
    layered: bool,
    #[serde(default)]
    format: String,
    #[serde(default)]
    view_dimension: String,
    #[serde(default)]
    sample_type: String,
}

impl TryFrom<TextureBindingFields> for TextureBinding {
    type Error = String;

    /// Version 1's texture, its depth and layers read from `extent`; in any version, a depth and
    /// layer count that do not make `extent[2]`, or a third dimension where there is none, refused.
    fn try_from(f: TextureBindingFields) -> std::result::Result<Self, String> {
        let what = format!("texture binding {} (`{}`)", f.binding, f.file);
        match (f.dimension, f.layered) {
            (2, _) | (3, false) => {}
            (3, true) => return Err(format!("{what}: a texture array is of 2D textures; it states dimension 3")),
            (d, _) => return Err(format!("{what}: dimension {d}; allowed: 2 or 3")),
        }
        let depth = f.depth.unwrap_or(if f.dimension == 3 { f.extent[2] } else { 1 });
        let array_layers = f.array_layers.unwrap_or(if f.layered { f.extent[2] } else { 1 });
        if (f.dimension == 2 && depth != 1) || (!f.layered && array_layers != 1) {
            return Err(format!(
                "{what}: depth {depth} and {array_layers} array layers; only a volume has a depth, only an array layers"
            ));
        }
        if depth.checked_mul(array_layers) != Some(f.extent[2]) {
            return Err(format!(
                "{what}: extent {:?} against depth {depth} times {array_layers} array layers",
                f.extent
            ));
        }
        Ok(TextureBinding {
            binding: f.binding,
            variable: f.variable,
            file: f.file,
            extent: f.extent,
            dimension: f.dimension,
            depth,
            array_layers,
            channels: f.channels,
            layered: f.layered,
            format: f.format,
            view_dimension: f.view_dimension,
            sample_type: f.sample_type,
        })
    }
}

/// The device limits a shader needs, named as WebGPU's limits are in wgpu's `Limits`, so that a
/// renderer requests at least these when it creates its device (and adds its own textures and
/// samplers to the first two). WebGPU grants [`DeviceLimits::WEBGPU_DEFAULTS`] unless asked for more.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct DeviceLimits {
    /// Textures the shader binds, all in one stage: every binding, not only one material's.
    pub max_sampled_textures_per_shader_stage: u32,
    /// Samplers it binds (0 where it loads texels itself).
    pub max_samplers_per_shader_stage: u32,
    /// The most layers of one 2D texture or array (1 for a plain 2D texture; 0 where it binds no
    /// 2D texture).
    pub max_texture_array_layers: u32,
    /// The largest width or height of a 2D texture or array (0 where it binds none).
    pub max_texture_dimension_2d: u32,
    /// The largest width, height or depth of a volume (0 where it binds none).
    pub max_texture_dimension_3d: u32,
    /// Storage buffers it binds: 1 for a scene shader's constants (0 before format version 3).
    #[serde(default)]
    pub max_storage_buffers_per_shader_stage: u32,
    /// The bytes of its largest storage buffer (0 where it binds none).
    #[serde(default)]
    pub max_storage_buffer_binding_size: u32,
}

impl DeviceLimits {
    /// What WebGPU grants a device that asks for nothing more (the specification's defaults).
    pub const WEBGPU_DEFAULTS: DeviceLimits = DeviceLimits {
        max_sampled_textures_per_shader_stage: 16,
        max_samplers_per_shader_stage: 16,
        max_texture_array_layers: 256,
        max_texture_dimension_2d: 8192,
        max_texture_dimension_3d: 2048,
        max_storage_buffers_per_shader_stage: 8,
        max_storage_buffer_binding_size: 1 << 27,
    };

    /// What binding `textures` and `samplers` samplers in one shader stage needs.
    pub fn of(textures: &[TextureBinding], samplers: u32) -> Self {
        let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        let planar = textures.iter().filter(|t| t.dimension == 2);
        let volumes = textures.iter().filter(|t| t.dimension == 3);
        DeviceLimits {
            max_sampled_textures_per_shader_stage: count(textures.len()),
            max_samplers_per_shader_stage: samplers,
            max_texture_array_layers: count(planar.clone().map(|t| t.array_layers).max().unwrap_or(0)),
            max_texture_dimension_2d: count(planar.map(|t| t.extent[0].max(t.extent[1])).max().unwrap_or(0)),
            max_texture_dimension_3d: count(
                volumes.map(|t| t.extent[0].max(t.extent[1]).max(t.depth)).max().unwrap_or(0),
            ),
            max_storage_buffers_per_shader_stage: 0,
            max_storage_buffer_binding_size: 0,
        }
    }

    /// These needs with a storage buffer of `bytes` bound too.
    pub fn with_storage_buffer(self, bytes: usize) -> Self {
        DeviceLimits {
            max_storage_buffers_per_shader_stage: self.max_storage_buffers_per_shader_stage + 1,
            max_storage_buffer_binding_size: self
                .max_storage_buffer_binding_size
                .max(u32::try_from(bytes).unwrap_or(u32::MAX)),
            ..self
        }
    }

    /// Each limit as WebGPU names it, with its value.
    pub fn named(&self) -> [(&'static str, u32); 7] {
        [
            ("maxSampledTexturesPerShaderStage", self.max_sampled_textures_per_shader_stage),
            ("maxSamplersPerShaderStage", self.max_samplers_per_shader_stage),
            ("maxTextureArrayLayers", self.max_texture_array_layers),
            ("maxTextureDimension2D", self.max_texture_dimension_2d),
            ("maxTextureDimension3D", self.max_texture_dimension_3d),
            ("maxStorageBuffersPerShaderStage", self.max_storage_buffers_per_shader_stage),
            ("maxStorageBufferBindingSize", self.max_storage_buffer_binding_size),
        ]
    }

    /// The limits these needs exceed in `granted`: each as WebGPU names it, needed and granted.
    pub fn beyond(&self, granted: &DeviceLimits) -> Vec<(&'static str, u32, u32)> {
        self.named()
            .into_iter()
            .zip(granted.named())
            .filter(|((_, needed), (_, allowed))| needed > allowed)
            .map(|((name, needed), (_, allowed))| (name, needed, allowed))
            .collect()
    }
}

/// The format version a description states, or 1 where it states none (it predates the field);
/// refused where it is newer than this loader reads.
fn format_version(stated: Option<u32>) -> std::result::Result<u32, String> {
    match stated.unwrap_or(1) {
        0 => Err("format_version 0; versions begin at 1".into()),
        v if v > SHADER_DESCRIPTION_FORMAT => Err(format!(
            "format_version {v} is newer than this loader reads (1 to {SHADER_DESCRIPTION_FORMAT}): update tmlut-loader"
        )),
        v => Ok(v),
    }
}

/// The device limits a description states: required from version 2 on, derived from its
/// bindings in version 1.
fn stated_limits(
    version: u32,
    stated: Option<DeviceLimits>,
    textures: &[TextureBinding],
    samplers: u32,
) -> std::result::Result<DeviceLimits, String> {
    match (stated, version) {
        (Some(limits), _) => Ok(limits),
        (None, 1) => Ok(DeviceLimits::of(textures, samplers)),
        (None, v) => Err(format!("format_version {v} states `limits`, the device limits the shader needs; none here")),
    }
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
    /// Its stack shape: the index in `shapes` of the function its own calls (0 before format
    /// version 3).
    #[serde(default)]
    pub shape: usize,
    /// The first of its constants in the constants buffer, the first argument of its shape's
    /// function (0 where the shape's function reads none, and before format version 3).
    #[serde(default)]
    pub constants_offset: u32,
}

/// A function that materials of one stack shape share, their constants read from the constants
/// buffer from the first argument on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeFunction {
    /// Its name: `(first constant, mu) -> TmResult`.
    pub function: String,
    /// How many materials share it.
    pub materials: usize,
    /// How many constants each of them stores in the buffer (0: it reads none).
    pub constants: usize,
}

/// The storage buffer of a scene shader's constants: little-endian f32 in a file beside the
/// shader, uploaded whole and bound read-only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConstantsBuffer {
    /// The binding number in group 0 (HLSL: register `tN`, a `StructuredBuffer<float>`).
    pub binding: u32,
    /// The variable in the shader.
    pub variable: String,
    /// The file beside the shader holding its contents.
    pub file: String,
    /// The WebGPU buffer binding type: `read-only-storage`.
    pub buffer_type: String,
    /// The element type: `f32`.
    pub element_type: String,
    /// Bytes per element: 4.
    pub element_stride: usize,
    /// The byte order of the file: `little-endian`.
    pub byte_order: String,
    /// Elements in the buffer (the file's length over `element_stride`).
    pub elements: usize,
    /// Elements per material at the buffer's start: material `i`'s shape at `header_stride * i`,
    /// the first of its constants after it, integers stored exactly as f32.
    pub header_stride: usize,
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
#[serde(try_from = "BakedShaderDescriptionFields")]
pub struct BakedShaderDescription {
    /// The description's format ([`SHADER_DESCRIPTION_FORMAT`] where tmlut writes it).
    pub format_version: u32,
    /// The struct every function returns (`TmResult`, as the scene shader's).
    pub result_struct: String,
    /// The length of its lobe arrays.
    pub max_lobes: usize,
    /// The function every material's is a call of: `(material index, mu) -> TmResult`, for a
    /// renderer that has a material's index rather than its name.
    pub function: String,
    /// The device limits the shader needs: one texture array and one sampler.
    pub limits: DeviceLimits,
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

/// A [`BakedShaderDescription`] as a description of any format version states it.
#[derive(Deserialize)]
struct BakedShaderDescriptionFields {
    format_version: Option<u32>,
    result_struct: String,
    max_lobes: usize,
    function: String,
    limits: Option<DeviceLimits>,
    texture: TextureBinding,
    sampler: SamplerBinding,
    materials: Vec<BakedMaterialFunction>,
    notes: String,
}

impl TryFrom<BakedShaderDescriptionFields> for BakedShaderDescription {
    type Error = String;

    fn try_from(f: BakedShaderDescriptionFields) -> std::result::Result<Self, String> {
        let format_version = format_version(f.format_version)?;
        let limits = stated_limits(format_version, f.limits, std::slice::from_ref(&f.texture), 1)?;
        Ok(BakedShaderDescription {
            format_version,
            result_struct: f.result_struct,
            max_lobes: f.max_lobes,
            function: f.function,
            limits,
            texture: f.texture,
            sampler: f.sampler,
            materials: f.materials,
            notes: f.notes,
        })
    }
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
    /// The parameters its textures vary, its function's arguments after `mu`, in order; none for
    /// a material that varies nothing.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parameters: Vec<BakedParameter>,
}

/// A varied parameter of a baked material's function.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BakedParameter {
    /// The function's argument (`layer_1_alpha`).
    pub argument: String,
    /// The parameter in words (`layer 1 alpha`, layers counted from 1 at the top).
    pub parameter: String,
    /// The range its texture varies it over, `[lo, hi]`: a value outside reads the nearer end.
    pub range: [f64; 2],
    /// The material's own value, where no texture gives one.
    pub nominal: f64,
}

/// `<scene>.shader.json`: what a renderer binds and calls (`docs/shaders.md` has its schema).
/// Borrowed where the generator writes it, owned where it is read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ShaderDescriptionFields")]
pub struct ShaderDescription<'a> {
    /// The description's format ([`SHADER_DESCRIPTION_FORMAT`] where tmlut writes it; 1 where
    /// a description older than the field was read).
    pub format_version: u32,
    /// The struct each material's function returns (`TmResult`).
    pub result_struct: Cow<'a, str>,
    /// The length of its lobe arrays.
    pub max_lobes: usize,
    /// The function `(material index, mu) -> TmResult` that evaluates any material, where the
    /// shader has one; `None` (written `null`) where each material has only its own function.
    pub dispatch_function: Option<Cow<'a, str>>,
    /// The device limits the shader needs, all its textures bound in one stage.
    pub limits: DeviceLimits,
    /// Every texture the shader binds.
    pub textures: Cow<'a, [TextureBinding]>,
    /// The storage buffer of the materials' constants (from format version 3 on).
    pub constants: Option<ConstantsBuffer>,
    /// The functions materials of one stack shape share, by shape (empty before version 3).
    pub shapes: Cow<'a, [ShapeFunction]>,
    /// Every material's function.
    pub materials: Cow<'a, [MaterialFunction]>,
    /// How to create and bind the textures and call the functions, in words.
    pub notes: Cow<'a, str>,
}

/// A [`ShaderDescription`] as a description of any format version states it.
#[derive(Deserialize)]
struct ShaderDescriptionFields {
    format_version: Option<u32>,
    result_struct: String,
    max_lobes: usize,
    #[serde(default)]
    dispatch_function: Option<String>,
    limits: Option<DeviceLimits>,
    textures: Vec<TextureBinding>,
    constants: Option<ConstantsBuffer>,
    #[serde(default)]
    shapes: Vec<ShapeFunction>,
    materials: Vec<MaterialFunction>,
    notes: String,
}

impl TryFrom<ShaderDescriptionFields> for ShaderDescription<'_> {
    type Error = String;

    fn try_from(f: ShaderDescriptionFields) -> std::result::Result<Self, String> {
        let format_version = format_version(f.format_version)?;
        let limits = stated_limits(format_version, f.limits, &f.textures, 0)?;
        if format_version >= 3 && f.constants.is_none() {
            return Err(format!(
                "format_version {format_version} states `constants`, the buffer the shader's functions read; none here"
            ));
        }
        if let Some(m) = f.materials.iter().find(|m| format_version >= 3 && m.shape >= f.shapes.len()) {
            return Err(format!("material `{}`: shape {} of {} shapes", m.material, m.shape, f.shapes.len()));
        }
        Ok(ShaderDescription {
            format_version,
            result_struct: f.result_struct.into(),
            max_lobes: f.max_lobes,
            dispatch_function: f.dispatch_function.map(Cow::Owned),
            limits,
            textures: f.textures.into(),
            constants: f.constants,
            shapes: f.shapes.into(),
            materials: f.materials.into(),
            notes: f.notes.into(),
        })
    }
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
    /// The contents of the constants buffer (`description.constants`), read from its file; empty
    /// before format version 3.
    pub constants: Vec<f32>,
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
        let read_bytes = |file: &str| -> Result<Vec<u8>> {
            match listed.as_ref().and_then(|r| r.files.iter().find(|f| f.file == file)) {
                Some(entry) => read_verified(dir, file, Some(entry.bytes), Some(&entry.sha256)),
                None => read_verified(dir, file, None, None),
            }
        };
        let read = |file: String| -> Result<String> {
            String::from_utf8(read_bytes(&file)?).map_err(|_| Error::format(dir.join(&file), "is not UTF-8 text"))
        };
        let description_path = dir.join(format!("{stem}{DESCRIPTION_SUFFIX}"));
        let description: ShaderDescription = serde_json::from_str(&read(format!("{stem}{DESCRIPTION_SUFFIX}"))?)
            .map_err(|e| Error::format(&description_path, format!("not a scene shader description: {e}")))?;
        let constants = match &description.constants {
            Some(buffer) => {
                check_file_name(&buffer.file).map_err(|reason| Error::format(&description_path, reason))?;
                let bytes = read_bytes(&buffer.file)?;
                if buffer.element_stride != 4 || bytes.len() != buffer.elements.saturating_mul(4) {
                    return Err(Error::format(
                        dir.join(&buffer.file),
                        format!(
                            "holds {} bytes; its description states {} elements of {} bytes (little-endian f32: 4)",
                            bytes.len(),
                            buffer.elements,
                            buffer.element_stride
                        ),
                    ));
                }
                bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
            }
            None => Vec::new(),
        };
        Ok(SceneShaderFiles {
            wgsl: read(format!("{stem}.wgsl"))?,
            hlsl: read(format!("{stem}.hlsl"))?,
            description,
            constants,
            stem,
        })
    }
}

/// The bytes of the shader file `file` of `dir` (a plain file name), verified against the length
/// and SHA-256 a manifest states for it, where it states them.
fn read_verified(dir: &Path, file: &str, stated_bytes: Option<u64>, stated_sha256: Option<&str>) -> Result<Vec<u8>> {
    check_file_name(file).map_err(|reason| Error::format(dir.join(MANIFEST_FILE), reason))?;
    let path = dir.join(file);
    let bytes = FileKind::Shader.read(&path)?;
    verify(&path, &bytes, stated_bytes, stated_sha256)?;
    Ok(bytes)
}

/// The text of a shader file's `bytes`, verified against the length and SHA-256 a manifest states
/// for it, where it states them; `path` names the file in errors.
pub(crate) fn text_verified(
    path: &Path,
    bytes: &[u8],
    stated_bytes: Option<u64>,
    stated_sha256: Option<&str>,
) -> Result<String> {
    verify(path, bytes, stated_bytes, stated_sha256)?;
    String::from_utf8(bytes.to_vec()).map_err(|_| Error::format(path, "is not UTF-8 text"))
}

/// `bytes` of the file at `path` against the length and SHA-256 a manifest states for it.
fn verify(path: &Path, bytes: &[u8], stated_bytes: Option<u64>, stated_sha256: Option<&str>) -> Result<()> {
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
    Ok(())
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

    /// A 2D texture, bound at `binding`, of `extent[2]` layers where `layered`.
    fn texture(binding: u32, extent: [usize; 3], layered: bool) -> TextureBinding {
        TextureBinding {
            binding,
            variable: format!("tmh_table{binding}"),
            file: format!("table{binding}.dds"),
            extent,
            dimension: 2,
            depth: 1,
            array_layers: if layered { extent[2] } else { 1 },
            channels: 1,
            layered,
            format: "r32float".into(),
            view_dimension: if layered { "2d-array" } else { "2d" }.into(),
            sample_type: "unfilterable-float".into(),
        }
    }

    /// A description of one material reading a plain texture, an array and a volume.
    fn example_description() -> ShaderDescription<'static> {
        let mut volume = texture(2, [33, 17, 9], false);
        (volume.dimension, volume.depth, volume.view_dimension) = (3, 9, "3d".into());
        let textures = vec![texture(0, [64, 64, 1], false), texture(1, [262, 256, 9], true), volume];
        ShaderDescription {
            format_version: SHADER_DESCRIPTION_FORMAT,
            result_struct: "TmResult".into(),
            max_lobes: 1,
            dispatch_function: Some("tm_material".into()),
            limits: DeviceLimits::of(&textures, 0).with_storage_buffer(16),
            textures: Cow::Owned(textures),
            constants: Some(ConstantsBuffer {
                binding: 3,
                variable: "tmh_constants".into(),
                file: "a.constants.bin".into(),
                buffer_type: "read-only-storage".into(),
                element_type: "f32".into(),
                element_stride: 4,
                byte_order: "little-endian".into(),
                elements: 4,
                header_stride: 2,
            }),
            shapes: Cow::Owned(vec![ShapeFunction { function: "tmh_shape0".into(), materials: 1, constants: 2 }]),
            materials: Cow::Owned(vec![MaterialFunction {
                material: "m".into(),
                function: "tm_m".into(),
                lobes: 1,
                textures: vec![0, 1, 2],
                model: "2-flux".into(),
                reads: vec!["gd".into(), "fgd slice".into(), "tir table".into()],
                cost: ShaderCost { texture_reads: 16, operations: 30 },
                shape: 0,
                constants_offset: 2,
            }]),
            notes: "".into(),
        }
    }

    #[test]
    fn the_limits_are_those_of_the_bindings() {
        let description = example_description();
        let expected = DeviceLimits {
            max_sampled_textures_per_shader_stage: 3,
            max_samplers_per_shader_stage: 0,
            max_texture_array_layers: 9,
            max_texture_dimension_2d: 262,
            max_texture_dimension_3d: 33,
            max_storage_buffers_per_shader_stage: 1,
            max_storage_buffer_binding_size: 16,
        };
        assert_eq!(description.limits, expected);
        assert!(expected.beyond(&DeviceLimits::WEBGPU_DEFAULTS).is_empty());
        let granted = DeviceLimits { max_texture_array_layers: 4, ..DeviceLimits::WEBGPU_DEFAULTS };
        assert_eq!(expected.beyond(&granted), [("maxTextureArrayLayers", 9, 4)]);
    }

    #[test]
    fn every_field_is_written_false_and_none_included() {
        let json = serde_json::to_value(example_description()).unwrap();
        assert_eq!(json["format_version"], SHADER_DESCRIPTION_FORMAT);
        assert_eq!(json["dispatch_function"], "tm_material");
        assert_eq!(json["constants"]["header_stride"], 2);
        assert_eq!((&json["materials"][0]["shape"], &json["materials"][0]["constants_offset"]), (&0.into(), &2.into()));
        assert_eq!(json["textures"][0]["layered"], false);
        assert_eq!((&json["textures"][1]["array_layers"], &json["textures"][1]["depth"]), (&9.into(), &1.into()));
        assert_eq!(json["limits"]["max_texture_array_layers"], 9);
    }

    #[test]
    fn a_version_1_description_is_read_with_what_it_left_out_derived() {
        // As tmlut wrote it before `format_version`: no limits, depth or layers, `layered` only
        // where true.
        let mut json = serde_json::to_value(example_description()).unwrap();
        let object = json.as_object_mut().unwrap();
        for field in ["format_version", "dispatch_function", "limits", "constants", "shapes"] {
            object.remove(field);
        }
        for material in object["materials"].as_array_mut().unwrap() {
            let material = material.as_object_mut().unwrap();
            material.remove("shape");
            material.remove("constants_offset");
        }
        for texture in object["textures"].as_array_mut().unwrap() {
            let texture = texture.as_object_mut().unwrap();
            texture.remove("depth");
            texture.remove("array_layers");
            if texture["layered"] == false {
                texture.remove("layered");
            }
        }
        let read: ShaderDescription = serde_json::from_value(json).unwrap();
        let example = example_description();
        let mut materials = example.materials.to_vec();
        materials[0].constants_offset = 0;
        let expected = ShaderDescription {
            format_version: 1,
            dispatch_function: None,
            limits: DeviceLimits::of(&example.textures, 0),
            constants: None,
            shapes: Cow::Owned(Vec::new()),
            materials: Cow::Owned(materials),
            ..example
        };
        assert_eq!(read, expected);
    }

    #[test]
    fn a_description_that_contradicts_itself_or_is_too_new_is_refused() {
        let refused = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut json = serde_json::to_value(example_description()).unwrap();
            edit(&mut json);
            serde_json::from_value::<ShaderDescription>(json).unwrap_err().to_string()
        };
        let error = refused(&|j| j["format_version"] = (SHADER_DESCRIPTION_FORMAT + 1).into());
        assert!(error.contains("newer than this loader reads"), "{error}");
        let error = refused(&|j| {
            j.as_object_mut().unwrap().remove("limits");
        });
        assert!(error.contains("states `limits`"), "{error}");
        let error = refused(&|j| {
            j.as_object_mut().unwrap().remove("constants");
        });
        assert!(error.contains("format_version 3 states `constants`"), "{error}");
        let error = refused(&|j| j["materials"][0]["shape"] = 1.into());
        assert!(error.contains("material `m`: shape 1 of 1 shapes"), "{error}");
        let error = refused(&|j| j["textures"][1]["array_layers"] = 8.into());
        assert!(error.contains("table1.dds") && error.contains("8 array layers"), "{error}");
        let error = refused(&|j| j["textures"][0]["depth"] = 2.into());
        assert!(error.contains("only a volume has a depth"), "{error}");
        let error = refused(&|j| j["textures"][2]["layered"] = true.into());
        assert!(error.contains("dimension 3"), "{error}");
    }

    #[test]
    fn a_folder_without_a_manifest_holds_exactly_one_scene_shader() {
        let dir = tempfile::tempdir().unwrap();
        let err = SceneShaderFiles::open(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds no scene shader (*.shader.json)"), "{err}");

        let description = example_description();
        std::fs::write(dir.path().join("a.shader.json"), serde_json::to_string(&description).unwrap()).unwrap();
        std::fs::write(dir.path().join("a.wgsl"), "fn tm_m() {}").unwrap();
        std::fs::write(dir.path().join("a.hlsl"), "").unwrap();
        std::fs::write(dir.path().join("a.constants.bin"), [0u8; 12]).unwrap();
        let err = SceneShaderFiles::open(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds 12 bytes; its description states 4 elements of 4 bytes"), "{err}");
        let constants: Vec<u8> = [0.0f32, 2.0, 1.5, -0.25].iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(dir.path().join("a.constants.bin"), constants).unwrap();
        let read = SceneShaderFiles::open(dir.path()).unwrap();
        assert_eq!((read.stem.as_str(), read.wgsl.as_str()), ("a", "fn tm_m() {}"));
        assert_eq!(read.description, description);
        assert_eq!(read.constants, [0.0, 2.0, 1.5, -0.25]);

        std::fs::write(dir.path().join("b.shader.json"), "{}").unwrap();
        let err = SceneShaderFiles::open(dir.path()).unwrap_err().to_string();
        assert!(err.contains("holds 2 scene shaders (a.shader.json, b.shader.json)"), "{err}");
    }
}
