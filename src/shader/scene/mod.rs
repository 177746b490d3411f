//! The transfer-matrix evaluation of a scene's materials as a shader: one function per material,
//! `tm_<material>(mu)`, specialised to its layer stack and to the tables of a built folder, read
//! with the manifest's coordinates. It returns the lobes (energy per channel, GGX roughness,
//! cosine of the mean direction, GD) and the directional albedo `A(mu)`. Its body is
//! [`crate::model::Material::evaluate`] itself, recorded ([`material`]): what the stack decides
//! (index-matched layers and empty media dropped, every index, roughness and medium coefficient)
//! is computed while recording, in f64, and printed as constants; what the view decides is
//! computed in the shader, in f32, by the same operations in the same order as the CPU. Each
//! table lookup the model makes is printed as the read of the file the folder answers it with
//! (`reads.rs`), through the filtering helpers (`helpers.rs`).
//!
//! What the generated code guards, that the thesis's hand-written HLSL did not (the project notes'
//! list of its defects), it guards because the model does: `1 / t` with `t` floored (never a
//! division by 0 when TIR takes everything; the floor is 1e-30 in f32, `Real::smallest_transmission`),
//! ratios that are not finite fall back to the reflectance above (a comparison, so NaN included),
//! the transmission lobes' roughness scale `|(eta_ji r.z + rp.z) / rp.z|` taken whole in `abs`,
//! the top index of every interface that of the layer above (air 1.0, never 1.003), and no read
//! of a layer below the last one.
//!
//! Names: a material's function is `tm_` and the material's name ([`material_function`]); every
//! other name the generator makes at module scope begins otherwise (`tmh_` for helpers, texture
//! bindings and slice choosers, `tmlut_` for the fitted TIR form, `fgd_lossless` for the packing's
//! lookup, `TmResult`), so that no material name can give the name of a helper (`finite-or` once
//! redefined `tm_finite_or`). A function's locals are `result` and `v<instruction>` (in a shared
//! function, `v<k>` for the k-th defined: `shapes.rs`).

mod choosers;
mod helpers;
mod material;
mod reads;
mod shapes;

use std::borrow::Cow;
use std::collections::BTreeMap;

use super::{Item, Lang, Module, Parens, Ty};
use crate::error::{Error, Result};
use crate::fit::forms::fitted::{FittedForm, FittedFormExt};
use crate::formats::manifest::MANIFEST_FILE;
use crate::loader::LutFolder;
pub use crate::loader::shader::{
    ConstantsBuffer, DeviceLimits, MaterialFunction, SHADER_DESCRIPTION_FORMAT, ShaderDescription, ShapeFunction,
    TextureBinding,
};
use crate::model::folder::MaterialReads;
use crate::model::routes::Routes;
use crate::model::{AlbedoPath, FluxModel, Stack, TirPath};
use crate::packing::PackedFgd;
use reads::{Printing, paths};

pub use material::RecordedMaterial;
pub use reads::coordinate as texture_coordinate;
pub use shapes::{CONSTANTS, DISPATCH, HEADER_STRIDE};

/// A material the shader evaluates.
#[derive(Debug, Clone)]
pub struct ShaderMaterial {
    pub name: String,
    pub model: FluxModel,
    pub albedo: AlbedoPath,
    /// The fitted form read in place of the albedo table (`albedo = "fit:PATH"`: a form fitted to
    /// `karis`, its channels weighed by F0 as the table's are, or to `fgd`).
    pub albedo_form: Option<FittedForm>,
    pub tir: TirPath,
    /// The fitted form read in place of the TIR table where `tir` is [`TirPath::Form`].
    pub tir_form: Option<FittedForm>,
    pub stack: Stack,
}

impl ShaderMaterial {
    /// How it reads a folder, for the CPU evaluator's tables ([`crate::model::folder::LibraryTables`]).
    pub fn reads(&self) -> MaterialReads<'_> {
        MaterialReads {
            name: &self.name,
            albedo: self.albedo,
            tir: self.tir,
            tir_form: self.tir_form.as_ref(),
            albedo_form: self.albedo_form.as_ref(),
        }
    }
}

/// The shader of a scene: its module (print it with [`Module::print`]) and what a renderer binds.
#[derive(Debug, Clone)]
pub struct SceneShader {
    pub module: Module,
    pub textures: Vec<TextureBinding>,
    pub materials: Vec<MaterialFunction>,
    /// The length of the lobe arrays of `TmResult`.
    pub max_lobes: usize,
    /// Of each binding, in the order of `textures`, what reads it, for the message refusing more
    /// textures than a renderer allows.
    pub readers: Vec<BindingReaders>,
    /// The shared functions, one per stack shape ([`shapes`]), in the order of their ids.
    pub shapes: Vec<ShapeFunction>,
    /// The contents of the storage buffer [`CONSTANTS`]: each material's shape and first constant
    /// ([`HEADER_STRIDE`] elements per material), then the constants the shared functions read.
    pub constants: Vec<f32>,
    /// Its binding in group 0: the one after the textures'.
    pub constants_binding: u32,
}

/// What reads one of a shader's textures.
#[derive(Debug, Clone, Default)]
pub struct BindingReaders {
    /// The lookups, as `FGD of `copper``.
    pub lookups: Vec<String>,
    /// Whether the texture is a slice in a file of its own (not a full table, a packing or an
    /// array).
    pub slice_file: bool,
}

/// The most textures a scene shader binds unless told otherwise (`--max-textures`): half of the 16
/// a WebGPU shader stage binds by default, so that a renderer has the other half for its own.
pub const DEFAULT_MAX_TEXTURES: usize = 8;

impl SceneShader {
    /// What a renderer binds and calls, the constants buffer's contents in `constants_file`.
    pub fn description(&self, constants_file: &str) -> ShaderDescription<'_> {
        let constants_bytes = self.constants.len() * 4;
        ShaderDescription {
            format_version: SHADER_DESCRIPTION_FORMAT,
            result_struct: RESULT_STRUCT.into(),
            max_lobes: self.max_lobes,
            dispatch_function: Some(DISPATCH.into()),
            limits: DeviceLimits::of(&self.textures, 0).with_storage_buffer(constants_bytes),
            textures: Cow::Borrowed(&self.textures),
            constants: Some(ConstantsBuffer {
                binding: self.constants_binding,
                variable: CONSTANTS.into(),
                file: constants_file.into(),
                buffer_type: "read-only-storage".into(),
                element_type: "f32".into(),
                element_stride: 4,
                byte_order: "little-endian".into(),
                elements: self.constants.len(),
                header_stride: HEADER_STRIDE,
            }),
            shapes: Cow::Borrowed(&self.shapes),
            materials: Cow::Borrowed(&self.materials),
            notes:
                "Each texture is bound in group 0 (HLSL: register tN) at `binding`, created from the file's texels as \
                    stored (`format`: the WebGPU name of the file's DXGI or Vulkan format) with WebGPU's `size` \
                    `extent` ([width, height, depth or array layers]) and `dimension`, one mip level, linear data, \
                    bound with `view_dimension` and `sample_type`; no sampler: the shader loads and filters texels \
                    itself. The constants buffer is bound in group 0 at `constants.binding` as a read-only storage \
                    buffer holding `constants.file` (little-endian f32) whole; every function reads it. A device \
                    needs at least `limits` (WebGPU's names), the renderer's own bindings added. Call \
                    `dispatch_function` with a material's index in `materials` and the view cosine mu = n.v, or the \
                    material's own `function` with mu."
                    .into(),
        }
    }

    /// The constants buffer's contents as its file holds them: little-endian f32.
    pub fn constants_bytes(&self) -> Vec<u8> {
        self.constants.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// Refuse a shader that binds more than `max_textures` textures, naming each texture with the
    /// lookups that read it.
    pub fn check_texture_count(&self, scene: &str, max_textures: usize) -> Result<()> {
        if self.textures.len() <= max_textures {
            return Ok(());
        }
        let slice_files = self.readers.iter().filter(|r| r.slice_file).count();
        let listed: Vec<String> = self
            .textures
            .iter()
            .zip(&self.readers)
            .take(TEXTURES_NAMED)
            .map(|(t, readers)| format!("{} ({})", t.file, first_of(&readers.lookups, LOOKUPS_NAMED)))
            .collect();
        let more = match self.textures.len().saturating_sub(TEXTURES_NAMED) {
            0 => String::new(),
            n => format!("; and {n} more"),
        };
        let hint = match slice_files {
            0 => String::new(),
            n => format!(
                "; {n} of them are slices in files of their own, which a build with `--slice-layout arrays` puts in \
                 a few texture arrays"
            ),
        };
        Err(Error::invalid(
            format!("scene `{scene}`"),
            format!(
                "its shader binds {} textures, more than --max-textures {max_textures} allows{hint}; raise \
                 --max-textures where the renderer's device binds that many per shader stage. The textures and the \
                 lookups reading them: {}{more}",
                self.textures.len(),
                listed.join("; ")
            ),
        ))
    }
}

/// The most textures, and lookups of one texture, a refusal names: a library's array is read by
/// every material.
const TEXTURES_NAMED: usize = 32;
const LOOKUPS_NAMED: usize = 4;

/// The first `count` of `items`, and how many more there are.
fn first_of(items: &[String], count: usize) -> String {
    match items.len().checked_sub(count) {
        Some(more) if more > 0 => format!("{}, and {more} more", items[..count].join(", ")),
        _ => items.join(", "),
    }
}

impl SceneShader {
    /// What one call of each material's function costs ([`super::cost`]: its texture reads and
    /// operations, the helpers it calls included), in the order of `materials`, with its constants
    /// as the buffer holds them: a shared slice chooser counts the candidates of the material's own
    /// lookup ([`choosers`]).
    pub fn costs(&self) -> Result<Vec<super::ShaderCost>> {
        let functions: Vec<&str> = self.materials.iter().map(|m| m.function.as_str()).collect();
        super::costs_with_buffer(&self.module, &functions, (CONSTANTS, self.constants.clone()))
    }
}

/// What the generated functions call beyond the helpers every scene shader has.
#[derive(Debug, Clone, Copy, Default)]
struct Needs {
    trilinear: bool,
    /// A slice is read from a texture array.
    layers: bool,
    asinh: bool,
    acos: bool,
}

/// The shader of `materials` over the tables of `folder`: the materials of each stack shape share
/// one function, their constants in the buffer [`CONSTANTS`] ([`shapes`]), each material's own
/// function a call of it, and [`DISPATCH`] evaluates any material by its index.
pub fn generate(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<SceneShader> {
    let Parts { mut module, bindings_end, textures, mut described, max_lobes, readers, choosers, functions } =
        parts(folder, materials, true)?;
    let constants_binding = textures.len() as u32;
    module.items.insert(
        bindings_end,
        Item::Binding { group: 0, binding: constants_binding, name: CONSTANTS.into(), ty: Ty::StorageArray },
    );
    let mut constants = vec![0.0f32; HEADER_STRIDE * materials.len()];
    let chooser_names: Vec<String> = choosers.iter().map(|f| f.name.clone()).collect();
    let choosers = shapes::share(choosers, "slice choosers", |k| format!("tmh_slices{k}"), &mut constants)?;
    let renamed: std::collections::HashMap<String, (String, u32)> = chooser_names
        .into_iter()
        .zip(&choosers.members)
        .map(|(old, &(shape, base))| (old, (choosers.functions[shape].name.clone(), base)))
        .collect();
    let mut functions = functions;
    for function in &mut functions {
        shapes::rename_calls(function, &renamed);
    }
    let shared = shapes::share(functions, "materials", |k| format!("tmh_shape{k}"), &mut constants)?;
    let shape_names: Vec<String> = shared.functions.iter().map(|f| f.name.clone()).collect();
    let mut wrappers = Vec::with_capacity(materials.len());
    for (k, (material, &(shape, base))) in described.iter_mut().zip(&shared.members).enumerate() {
        constants[HEADER_STRIDE * k] = shape as f32;
        constants[HEADER_STRIDE * k + 1] = base as f32;
        material.shape = shape;
        material.constants_offset = base;
        wrappers.push(shapes::material_function(&material.function, &shape_names[shape], base));
    }
    let shape_functions = shared
        .shapes
        .iter()
        .zip(&shape_names)
        .map(|(&(materials, constants), function)| ShapeFunction { function: function.clone(), materials, constants })
        .collect();
    let dispatch = shapes::dispatch_function(materials.len(), &shape_names);
    for function in choosers.functions.into_iter().chain(shared.functions).chain(wrappers).chain([dispatch]) {
        module.push(Item::Function(function));
    }
    let mut shader = SceneShader {
        module,
        textures,
        materials: described,
        max_lobes,
        readers,
        shapes: shape_functions,
        constants,
        constants_binding,
    };
    let costs = shader.costs()?;
    for (material, cost) in shader.materials.iter_mut().zip(costs) {
        material.cost = cost;
    }
    Ok(shader)
}

/// The module of `materials` with a function of its own per material, its constants literals, as
/// [`generate`] shares them: no buffer, no dispatch. What the shared functions are held to (bit for
/// bit, run by the emulator).
pub fn per_material_module(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<Module> {
    let Parts { mut module, choosers, functions, .. } = parts(folder, materials, false)?;
    for function in choosers.into_iter().chain(functions) {
        module.push(Item::Function(function));
    }
    Ok(module)
}

/// What the shader of `materials` is made of before its materials' functions are shared: the
/// module up to them (the struct, the bindings, the helpers and forms), the slice choosers and each
/// material's function. `to_share`: every slice read through a chooser, padded for sharing
/// ([`choosers::padded`]), else each chooser reading every candidate and one slice read directly.
struct Parts {
    module: Module,
    /// Where the module's bindings end, for the buffer's.
    bindings_end: usize,
    textures: Vec<TextureBinding>,
    described: Vec<MaterialFunction>,
    max_lobes: usize,
    readers: Vec<BindingReaders>,
    choosers: Vec<super::Function>,
    functions: Vec<super::Function>,
}

fn parts(folder: &LutFolder, materials: &[ShaderMaterial], to_share: bool) -> Result<Parts> {
    let manifest_path = folder.dir().join(MANIFEST_FILE);
    let routes = Routes::open(folder, &materials.iter().map(paths).collect::<Vec<_>>(), &Printing)?;
    let mut g = Generator::new(&routes, manifest_path.display().to_string());
    g.slices_through_choosers = to_share;
    let mut functions = Vec::new();
    let mut described = Vec::new();
    let mut max_lobes = 1;
    for material in materials {
        g.reading.clear();
        g.reads.clear();
        let (function, lobes) = material::function(&mut g, material)?;
        if function.name == DISPATCH {
            return Err(g.refuse(
                &material.name,
                format!(
                    "its function name `{DISPATCH}` is that of the function evaluating any material by its index; \
                     rename the material"
                ),
            ));
        }
        if let Some(other) = described.iter().find(|d: &&MaterialFunction| d.function == function.name) {
            return Err(g.refuse(
                &material.name,
                format!(
                    "its function name `{}` is that of material `{}`; material names must differ in more than \
                     punctuation and case",
                    function.name, other.material
                ),
            ));
        }
        max_lobes = max_lobes.max(lobes);
        described.push(MaterialFunction {
            material: material.name.clone(),
            function: function.name.clone(),
            lobes,
            textures: g.reading.iter().copied().collect(),
            model: material.model.name().to_string(),
            reads: g.reads.iter().cloned().collect(),
            // Counted once the module holds every helper it calls.
            cost: Default::default(),
            // Known once the functions are shared.
            shape: 0,
            constants_offset: 0,
        });
        functions.push(function);
    }
    let models: Vec<&str> = [FluxModel::TwoFlux, FluxModel::SixFlux]
        .into_iter()
        .filter(|model| materials.iter().any(|m| m.model == *model))
        .map(FluxModel::name)
        .collect();
    let mut module = Module::new(Parens::Minimal);
    module.comment(&format!(
        "tmlut shader: the transfer-matrix model (Randrianandrasana, Callet & Lucas 2021, {}) of\n\
         a scene's materials, specialised to their layer stacks and the tables of one built folder.\n\
         Generated; each material's function computes what tmlut's CPU evaluator computes, in f32.\n\
         \"The reference's\" names a function of the paper authors' reference implementation that\n\
         a helper follows (tmlut's docs/furnace.md pairs each with the CPU evaluator's).\n\
         Bindings: group 0, one texture per table file, then the materials' constants (see the\n\
         .shader.json beside this file).",
        if models.is_empty() { "2-flux".to_string() } else { models.join(" and ") }
    ));
    module.push(result_struct(max_lobes));
    for t in &g.textures {
        module.push(Item::Binding {
            group: 0,
            binding: t.binding,
            name: t.variable.clone(),
            ty: if t.layered {
                Ty::TextureArray
            } else {
                Ty::Texture { dims: t.dimension, scalar: t.channels == 1 && t.dimension == 3 }
            },
        });
    }
    let bindings_end = module.items.len();
    helpers::common(&mut module);
    if g.needs.trilinear {
        helpers::trilinear(&mut module);
    }
    if g.needs.layers {
        helpers::bilinear_layer(&mut module);
    }
    if g.needs.asinh {
        helpers::asinh(&mut module);
    }
    if g.needs.acos {
        helpers::acos(&mut module);
    }
    push_forms(&mut module, &g)?;
    if let Some(packed) = g.packing {
        // The packing's lookup prints fully parenthesised; as a function of this module it takes
        // the module's style, which changes only redundant parentheses, not the operations.
        module.items.extend(packed.program.module("The lossless FGD packing's exact lookup (docs/packing.md).").items);
    }
    let mut textures = g.textures;
    for texture in &mut textures {
        let entry = folder.entry(&texture.file)?;
        texture.format = crate::loader::TextureFormat::of(texture.channels, entry.precision)
            .map(|f| f.webgpu_name().to_string())
            .ok_or_else(|| {
                Error::format(
                    &manifest_path,
                    format!(
                        "lists `{}` with {} channels in {:?}, which no WebGPU texel format holds",
                        texture.file, texture.channels, entry.precision
                    ),
                )
            })?;
    }
    Ok(Parts {
        module,
        bindings_end,
        textures,
        described,
        max_lobes,
        readers: g.readers,
        choosers: if to_share {
            choosers::padded(&g.slice_choosers)
        } else {
            choosers::reading_each(&g.slice_choosers)
        },
        functions,
    })
}

/// The folder's fitted form (`tmlut_tir`), then the forms materials name, each after the helpers
/// it needs; a helper two forms share (`tmlut_pow_2`, `tmlut_asinh`: the same code whoever prints
/// it) is printed once.
fn push_forms(module: &mut Module, g: &Generator) -> Result<()> {
    let folder_fit = g.folder_form.map(|fitted| (fitted, true));
    for (fitted, is_folder_fit) in folder_fit.into_iter().chain(g.forms.iter().map(|fitted| (fitted, false))) {
        if !is_folder_fit
            && g.folder_form.is_some()
            && crate::fit::forms::shader::lookup_function_name(&fitted.form()?) == "tmlut_tir"
        {
            return Err(Error::invalid(
                format!("fit:{}", fitted.source),
                "form `tir` has the shader function of the built-in fitted form (tmlut_tir), which another material's \
                 tir = \"fit\" reads; rename the form file",
            ));
        }
        let items = crate::fit::forms::shader::lookup_module(&fitted.form()?, &fitted.parameters)?.items;
        for item in items {
            let printed = |name: &str| {
                module.items.iter().any(|i| matches!(i, Item::Function(function) if function.name == name))
            };
            if let Item::Function(function) = &item
                && printed(&function.name)
            {
                continue;
            }
            module.items.push(item);
        }
    }
    Ok(())
}

struct Generator<'a> {
    routes: &'a Routes<Printing>,
    textures: Vec<TextureBinding>,
    /// File -> binding of the textures bound so far.
    used: BTreeMap<String, u32>,
    /// Of each binding, what reads it.
    readers: Vec<BindingReaders>,
    /// The lookup being printed, as [`BindingReaders::lookups`] names it, and whether it reads
    /// slices.
    lookup: String,
    lookup_reads_slices: bool,
    /// The bindings the material being generated reads, and what kinds of table.
    reading: std::collections::BTreeSet<u32>,
    reads: std::collections::BTreeSet<String>,
    manifest_path: String,
    needs: Needs,
    /// The functions choosing among slices ([`Self::slice`]), by their candidates.
    choosers: BTreeMap<String, String>,
    slice_choosers: Vec<choosers::Chooser>,
    /// Whether a lookup of one slice is read through a chooser too ([`choosers`]).
    slices_through_choosers: bool,
    /// The fitted forms the materials name (`tir = "fit:PATH"`), in first use.
    forms: Vec<FittedForm>,
    /// The folder's fitted TIR form, printed as `tmlut_tir` where a material reads it.
    folder_form: Option<&'a FittedForm>,
    /// The lossless FGD packing, whose lookup is printed where a material reads it.
    packing: Option<&'a PackedFgd>,
}

impl<'a> Generator<'a> {
    /// A generator over `sources` that has read nothing yet; `manifest_path` for its messages.
    fn new(routes: &'a Routes<Printing>, manifest_path: String) -> Self {
        Generator {
            routes,
            textures: Vec::new(),
            used: BTreeMap::new(),
            readers: Vec::new(),
            lookup: String::new(),
            lookup_reads_slices: false,
            reading: Default::default(),
            reads: Default::default(),
            manifest_path,
            needs: Needs::default(),
            choosers: BTreeMap::new(),
            slice_choosers: Vec::new(),
            slices_through_choosers: false,
            forms: Vec::new(),
            folder_form: None,
            packing: None,
        }
    }

    fn refuse(&self, material: &str, what: String) -> Error {
        Error::invalid(format!("tmlut shader, material `{material}`"), what)
    }
}

/// The struct every material's function returns, `TmResult`, with lobe arrays `max_lobes` long:
/// the baked shader's too ([`super::baked`]), so that a renderer calls either alike.
pub fn result_struct(max_lobes: usize) -> Item {
    Item::Struct {
        name: RESULT_STRUCT.into(),
        fields: vec![
            ("albedo".into(), Ty::Vec(3)),
            ("top_albedo".into(), Ty::Vec(3)),
            ("lobe_energy".into(), Ty::Array(Box::new(Ty::Vec(3)), max_lobes)),
            ("lobe_roughness".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
            ("lobe_cos".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
            ("lobe_gd".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
        ],
    }
}

/// The name of the struct material functions return.
pub const RESULT_STRUCT: &str = "TmResult";

/// The function of material `name`: `tm_` and its [`identifier`]. Nothing else the generator
/// makes begins with `tm_` (the module docs), so material names collide only with each other.
pub fn material_function(name: &str) -> String {
    format!("tm_{}", identifier(name))
}

/// A shader identifier from a material name: letters, digits and `_`.
pub fn identifier(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect()
}

/// Print `shader` in both languages.
pub fn texts(shader: &SceneShader) -> [(Lang, String); 2] {
    [Lang::Hlsl, Lang::Wgsl].map(|lang| (lang, shader.module.print(lang)))
}
