//! The transfer-matrix evaluation of a scene's materials as a shader: one function per material,
//! `tm_<material>(mu)`, specialised to its layer stack and to the tables of a built folder, read
//! with the manifest's coordinates. It returns the lobes (energy per channel, GGX roughness,
//! cosine of the mean direction, GD) and the directional albedo `A(mu)`. Its body is
//! [`crate::model::Material::evaluate`] itself, recorded ([`material`]): what the stack decides
//! (index-matched layers and empty media dropped, every index, roughness and medium coefficient)
//! is computed while recording, in f64, and printed as constants; what the view decides is
//! computed in the shader, in f32, by the same operations in the same order as the CPU.//!
//! Tables are read by hand-filtered texel loads (four or eight `textureLoad`s and lerps in f32, as
//! [`crate::packing::emulator`] filters with `Filter::Exact`), not by the sampler: hardware
//! filtering weighs texels with 8 fractional bits on most GPUs, which alone moves a value by up to
//! 1/512 of a texel step, and float32 textures are not filterable in WebGPU without a feature.
//! Every lookup the plan can choose is read: albedo from FGD slices, the lossless FGD packing, or
//! the Belcour and Karis split-sum tables with their Fresnel coefficients folded to constants; TIR
//! from slices, the 3D TIR table (its third axis `eta` or the critical-angle offset), the fitted
//! form, or off; GD from its 2D table.
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
//! redefined `tm_finite_or`). A function's locals are `result` and `v<instruction>`.

mod helpers;
mod material;

use std::borrow::Cow;
use std::collections::BTreeMap;

use super::{Builtin, Expr, Item, Lang, Module, Parens, Ty, call, f, func, name, select};
use crate::error::{Error, Result};
use crate::fit::text::fitted::{FittedForm, FittedFormExt};
use crate::formats::FileFormat;
use crate::formats::manifest::MANIFEST_FILE;
use crate::loader::ArrayPlace;
use crate::loader::LutFolder;
pub use crate::loader::shader::{MaterialFunction, ShaderDescription, TextureBinding};
use crate::model::folder::{is_slice, slice_choice_distance, slice_choice_distance_in, slice_indices};
use crate::model::{AlbedoPath, FluxModel, Quantity, Stack, TirPath};
use crate::packing::{PackedFgd, Packing};
use crate::physics::{FresnelBasis, normal_incidence_reflectance};
use crate::table::derived::{self, CRITICAL_ANGLE_FRACTION, CRITICAL_ANGLE_OFFSET, point_in};
use crate::table::{Arithmetic, Axis, TableKind};

pub use material::RecordedMaterial;

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

/// The shader of a scene: its module (print it with [`Module::print`]) and what a renderer binds.
#[derive(Debug, Clone)]
pub struct SceneShader {
    pub module: Module,
    pub textures: Vec<TextureBinding>,
    pub materials: Vec<MaterialFunction>,
    /// The length of the lobe arrays of `TmResult`.
    pub max_lobes: usize,
}

impl SceneShader {
    pub fn description(&self) -> ShaderDescription<'_> {
        ShaderDescription {
            result_struct: "TmResult".into(),
            max_lobes: self.max_lobes,
            textures: Cow::Borrowed(&self.textures),
            materials: Cow::Borrowed(&self.materials),
            notes: "Each texture is bound in group 0 (HLSL: register tN) at `binding`, created from the file's texels as \
                    stored (`format`: the WebGPU name of the file's DXGI or Vulkan format), one mip level, linear data, \
                    bound with `view_dimension` and `sample_type`; no sampler: the shader loads and filters texels \
                    itself. Call the material's function with the view cosine mu = n.v."
                .into(),
        }
    }
}

/// A table file the shader reads: its axes, channels as stored, and for a slice the `(eta, kappa)`
/// its channels hold fixed.
#[derive(Debug, Clone)]
struct TableFile {
    file: String,
    /// The table's name: a texture array holds several.
    table: String,
    /// Where a slice of a texture array lies in it.
    place: Option<ArrayPlace>,
    axes: Vec<Axis>,
    channels: usize,
    /// `(eta, kappa)` per channel, for slices.
    indices: Vec<(f64, f64)>,
    /// The Fresnel basis its manifest entry states (Belcour's).
    fresnel_basis: Option<FresnelBasis>,
    is_tir: bool,
    is_fgd: bool,
}

impl TableFile {
    fn of(file: &str, entry: &crate::formats::manifest::FileEntry) -> Self {
        let indices = slice_indices(entry);
        TableFile {
            file: file.to_string(),
            table: entry.table.clone(),
            place: None,
            axes: entry.axes.iter().map(|a| a.axis.clone()).collect(),
            channels: padded(entry.channels.len()),
            fresnel_basis: entry.fresnel_basis.clone(),
            is_tir: is_slice(entry, TableKind::Tir),
            is_fgd: is_slice(entry, TableKind::Fgd),
            indices: if is_slice(entry, TableKind::Tir) || is_slice(entry, TableKind::Fgd) {
                indices
            } else {
                Vec::new()
            },
        }
    }
}

/// Everything the materials read, found in the folder.
#[derive(Default)]
struct Sources {
    slices: Vec<TableFile>,
    /// The tables a GPU binds whole, each of its kind's shape: GD, the 3D TIR table, the split-sum
    /// tables, the stand-ins.
    tables: Vec<(TableKind, TableFile)>,
    packing: Option<(String, PackedFgd)>,
    /// The folder's fitted TIR form (its manifest's `fit`), printed as `tmlut_tir`.
    fit: Option<FittedForm>,
}

impl Sources {
    fn table(&self, kind: TableKind) -> Option<TableFile> {
        self.tables.iter().find(|(k, _)| *k == kind).map(|(_, table)| table.clone())
    }
}

/// What the generated functions call beyond the helpers every scene shader has.
#[derive(Debug, Clone, Copy, Default)]
struct Needs {
    packing: bool,
    fit: bool,
    trilinear: bool,
    /// A slice is read from a texture array.
    layers: bool,
    asinh: bool,
    acos: bool,
}

/// The shader of `materials` over the tables of `folder`.
pub fn generate(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<SceneShader> {
    let manifest_path = folder.dir().join(MANIFEST_FILE);
    let sources = sources(folder, materials)?;
    let mut g = Generator::new(&sources, manifest_path.display().to_string());
    let mut functions = Vec::new();
    let mut described = Vec::new();
    let mut max_lobes = 1;
    for material in materials {
        g.reading.clear();
        g.reads.clear();
        let (function, lobes) = material::function(&mut g, material)?;
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
         Bindings: group 0, one texture per table file (see the .shader.json beside this file).",
        if models.is_empty() { "2-flux".to_string() } else { models.join(" and ") }
    ));
    module.push(Item::Struct {
        name: "TmResult".into(),
        fields: vec![
            ("albedo".into(), Ty::Vec(3)),
            ("top_albedo".into(), Ty::Vec(3)),
            ("lobe_energy".into(), Ty::Array(Box::new(Ty::Vec(3)), max_lobes)),
            ("lobe_roughness".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
            ("lobe_cos".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
            ("lobe_gd".into(), Ty::Array(Box::new(Ty::F32), max_lobes)),
        ],
    });
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
    // The folder's fitted form (`tmlut_tir`), then the forms materials name, each after the helpers
    // it needs; a helper two forms share (`tmlut_pow_2`, `tmlut_asinh`: the same code whoever
    // prints it) is printed once.
    let folder_fit = sources.fit.iter().filter(|_| g.needs.fit).map(|fitted| (fitted, true));
    for (fitted, is_folder_fit) in folder_fit.chain(g.forms.iter().map(|fitted| (fitted, false))) {
        if !is_folder_fit && g.needs.fit && crate::fit::text::shader::function_name(&fitted.form()?) == "tmlut_tir" {
            return Err(Error::invalid(
                format!("fit:{}", fitted.source),
                "form `tir` has the shader function of the built-in fitted form (tmlut_tir), which another material's \
                 tir = \"fit\" reads; rename the form file",
            ));
        }
        let items = crate::fit::text::shader::module(&fitted.form()?, &fitted.parameters)?.items;
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
    if g.needs.packing
        && let Some((_, packed)) = &sources.packing
    {
        // The packing's lookup prints fully parenthesised; as a function of this module it takes
        // the module's style, which changes only redundant parentheses, not the operations.
        module.items.extend(packed.program.module("The lossless FGD packing's exact lookup (docs/packing.md).").items);
    }
    for function in g.chooser_functions.drain(..).chain(functions) {
        module.push(Item::Function(function));
    }
    let mut textures = g.textures;
    for texture in &mut textures {
        let entry = folder.entry(&texture.file)?;
        texture.format = crate::loader::TextureFormat::of(texture.channels, entry.precision)
            .map(|f| f.webgpu_name().to_string())
            .unwrap_or_default();
    }
    Ok(SceneShader { module, textures, materials: described, max_lobes })
}

fn sources(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<Sources> {
    let mut sources = Sources::default();
    // The slices in the order the CPU evaluator finds them (`model::folder`), which decides among equals.
    for slice in folder.scene_slices(|e| is_slice(e, TableKind::Fgd) || is_slice(e, TableKind::Tir))? {
        let mut table = TableFile::of(&slice.file, &slice.entry);
        table.place = slice.place;
        sources.slices.push(table);
    }
    // The tables a GPU binds whole, found as the CPU evaluator finds them. A table of another
    // shape than its kind's is not read (the 4D FGD table is no texture: the shader reads its
    // packing).
    for &kind in TableKind::ALL {
        if let Some((file, entry)) = folder.table_file(kind.name(), &FileFormat::TEXTURES)
            && entry.axes.len() == kind.shape().axes.len()
        {
            sources.tables.push((kind, TableFile::of(file, entry)));
        }
    }
    if materials.iter().any(|m| m.albedo == AlbedoPath::Fgd)
        && let Some((file, entry)) = folder.packing_file(Packing::Lossless.name(), &FileFormat::TEXTURES)
    {
        sources.packing = Some((file.to_string(), crate::model::folder::packed_fgd(folder, file, entry)?));
    }
    sources.fit = folder.tir_fit().and_then(FittedForm::of_build);
    Ok(sources)
}

struct Generator<'a> {
    sources: &'a Sources,
    textures: Vec<TextureBinding>,
    /// File -> binding of the textures bound so far.
    used: BTreeMap<String, u32>,
    /// The bindings the material being generated reads, and what kinds of table.
    reading: std::collections::BTreeSet<u32>,
    reads: std::collections::BTreeSet<String>,
    manifest_path: String,
    needs: Needs,
    /// The functions choosing among slices ([`Self::slice`]), by their candidates.
    choosers: BTreeMap<String, String>,
    chooser_functions: Vec<super::Function>,
    /// The fitted forms the materials name (`tir = "fit:PATH"`), in first use.
    forms: Vec<FittedForm>,
}

impl<'a> Generator<'a> {
    /// A generator over `sources` that has read nothing yet; `manifest_path` for its messages.
    fn new(sources: &'a Sources, manifest_path: String) -> Self {
        Generator {
            sources,
            textures: Vec::new(),
            used: BTreeMap::new(),
            reading: Default::default(),
            reads: Default::default(),
            manifest_path,
            needs: Needs::default(),
            choosers: BTreeMap::new(),
            chooser_functions: Vec::new(),
            forms: Vec::new(),
        }
    }

    fn refuse(&self, material: &str, what: String) -> Error {
        Error::invalid(format!("tmlut shader, material `{material}`"), what)
    }

    /// The texture variable of `file`, binding it on first use.
    fn bind(&mut self, file: &str, extent: [usize; 3], dimension: u8, channels: usize, layered: bool) -> String {
        if let Some(&binding) = self.used.get(file) {
            self.reading.insert(binding);
            return self.textures[binding as usize].variable.clone();
        }
        let binding = self.textures.len() as u32;
        let variable = format!("tmh_table{binding}");
        self.textures.push(TextureBinding {
            binding,
            variable: variable.clone(),
            file: file.to_string(),
            extent,
            dimension,
            channels,
            layered,
            format: String::new(),
            view_dimension: match (layered, dimension) {
                (true, _) => "2d-array",
                (false, 3) => "3d",
                _ => "2d",
            }
            .into(),
            sample_type: "unfilterable-float".into(),
        });
        self.used.insert(file.to_string(), binding);
        self.reading.insert(binding);
        variable
    }

    /// The texture variable of a table of two or three axes, one texel per node.
    fn bind_table(&mut self, t: &TableFile) -> String {
        let count = |d: usize| t.axes.get(d).map_or(1, |a| a.count);
        if t.axes.iter().any(|a| a.mapping.asinh_parts().is_some()) {
            self.needs.asinh = true;
        }
        match t.place {
            Some(place) => {
                let [width, height] = place.layer_extent.map(|e| e as usize);
                self.bind(&t.file, [width, height, place.layers as usize], 2, t.channels, true)
            }
            None => self.bind(&t.file, [count(0), count(1), count(2)], t.axes.len() as u8, t.channels, false),
        }
    }

    /// Every channel of 2D table `t` at `(mu, alpha)`: the manifest's texture coordinate of each
    /// axis in f32, then bilinear filtering by hand (a `vec4`).
    fn read2(&mut self, t: &TableFile, mu: Expr, alpha: Expr) -> Expr {
        let variable = self.bind_table(t);
        if let Some(place) = t.place {
            // A slice of a texture array: its coordinates clamped to its nodes, in the array
            // (`formats::slice_array::texture_coordinate`), and its layer.
            self.needs.layers = true;
            let [u, v] = [0, 1].map(|d| {
                let x = if d == 0 { mu.clone() } else { alpha.clone() };
                array_coordinate(&t.axes[d], place.origin[d], place.layer_extent[d], x)
            });
            let [width, height] = place.layer_extent.map(|e| f(e as f32));
            let layer = Expr::Construct(Ty::I32, vec![f(place.layer as f32)]);
            return func("tmh_bilinear_layer", vec![name(&variable), u, v, width, height, layer]);
        }
        let [u, v] = [0, 1].map(|d| coordinate(&t.axes[d], if d == 0 { mu.clone() } else { alpha.clone() }));
        func("tmh_bilinear", vec![name(&variable), u, v, f(t.axes[0].count as f32), f(t.axes[1].count as f32)])
    }

    /// The value of the slice answering a lookup at `(eta, kappa)`, as
    /// [`crate::model::folder::FolderTables`] chooses it: of the slices with a channel at those
    /// indices (in the manifest's order), the one with the least [`slice_choice_distance`] (-1
    /// where its `(mu, alpha)` range holds the lookup, else the sum over both axes of the distance
    /// outside the range, in units of the range, less the slack), the first of equals: the first
    /// that holds it, else the nearest. `None` where no slice has those indices.
    ///
    /// One candidate is read directly. Where several are, the ones that can never be chosen are
    /// dropped when `alpha` is known here (a slice whose alpha range misses it by more than the
    /// slack loses to one that holds it and every `mu`, and so does any slice after that one); the
    /// rest are compared in a function of their own, `tmh_slice<N>(mu, alpha)`.
    fn slice(
        &mut self,
        tir: bool,
        eta: f64,
        kappa: f64,
        mu: Expr,
        alpha: Expr,
        known_alpha: Option<f64>,
    ) -> Option<Expr> {
        let same = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        let candidates: Vec<(TableFile, usize)> = self
            .sources
            .slices
            .iter()
            .filter(|s| if tir { s.is_tir } else { s.is_fgd })
            .filter_map(|s| s.indices.iter().position(|&(e, k)| same(e, eta) && same(k, kappa)).map(|c| (s.clone(), c)))
            .collect();
        let candidates = match known_alpha {
            Some(alpha) => {
                // Holds alpha as the chooser compares it, in f32 (the lattice's ends are exact in f32).
                let holds_alpha = |axis: &Axis| {
                    let (lo, hi) = axis.bounds();
                    lo as f32 <= alpha as f32 && alpha as f32 <= hi as f32
                };
                let always_chosen = candidates.iter().position(|(t, _)| {
                    let (lo, hi) = t.axes[0].bounds();
                    holds_alpha(&t.axes[1]) && lo <= 0.0 && hi >= 1.0
                });
                match always_chosen {
                    Some(k) => candidates
                        .into_iter()
                        .take(k + 1)
                        .enumerate()
                        .filter(|(i, (t, _))| *i == k || slice_choice_distance(&t.axes[1..2], &[alpha]) <= 0.0)
                        .map(|(_, c)| c)
                        .collect(),
                    None => candidates,
                }
            }
            None => candidates,
        };
        if !candidates.is_empty() {
            self.reads.insert(if tir { "tir slice" } else { "fgd slice" }.into());
        }
        match candidates.len() {
            0 => None,
            1 => {
                let (t, c) = &candidates[0];
                Some(self.read2(t, mu, alpha).member(CHANNELS[*c]))
            }
            _ => Some(func(&self.slice_chooser(&candidates), vec![mu, alpha])),
        }
    }

    /// The function choosing among slice `candidates` at `(mu, alpha)` as [`Self::slice`] says.
    fn slice_chooser(&mut self, candidates: &[(TableFile, usize)]) -> String {
        let key = candidates.iter().map(|(t, c)| format!("{}/{}#{c}", t.file, t.table)).collect::<Vec<_>>().join(",");
        if let Some(function) = self.choosers.get(&key).cloned() {
            for (t, _) in candidates {
                self.bind_table(t);
            }
            return function;
        }
        let function = format!("tmh_slice{}", self.choosers.len());
        let mut body = Vec::new();
        for (k, (t, c)) in candidates.iter().enumerate() {
            // `slice_choice_distance` in f32: -1 where the range holds (mu, alpha), so that such a
            // slice beats one the lookup merely lies within the slack of.
            let distance = slice_choice_distance_in(&t.axes[..2], &[InShader(name("mu")), InShader(name("alpha"))]).0;
            let value = self.read2(t, name("mu"), name("alpha")).member(CHANNELS[*c]);
            if k == 0 {
                body.push(super::var("nearest", Ty::F32, distance));
                body.push(super::var("value", Ty::F32, value));
            } else {
                let (d, v) = (format!("distance{k}"), format!("value{k}"));
                body.push(super::let_(&d, Ty::F32, distance));
                body.push(super::let_(&v, Ty::F32, value));
                body.push(super::Stmt::If {
                    condition: name(&d).lt(name("nearest")),
                    then: vec![super::assign(name("nearest"), name(&d)), super::assign(name("value"), name(&v))],
                    otherwise: Vec::new(),
                });
            }
        }
        body.push(super::Stmt::Return(name("value")));
        self.chooser_functions.push(super::Function {
            name: function.clone(),
            params: vec![("mu".into(), Ty::F32), ("alpha".into(), Ty::F32)],
            returns: Ty::F32,
            body,
        });
        self.choosers.insert(key, function.clone());
        function
    }

    /// The shader function of a form a material names, printed once in the module whoever calls
    /// it; `read` says what it answers.
    fn form_function(&mut self, fitted: &FittedForm, read: &'static str) -> String {
        if !self.forms.contains(fitted) {
            self.forms.push(fitted.clone());
        }
        self.reads.insert(read.into());
        format!("tmlut_{}", fitted.name)
    }

    /// The directional albedo of an interface of roughness `alpha` and relative index
    /// `(eta, kappa)` at cosine `mu`, on material `m`'s albedo path.
    fn albedo(&mut self, m: &ShaderMaterial, mu: Expr, alpha: f64, eta: f64, kappa: f64) -> Result<Expr> {
        if let Some(fitted) = &m.albedo_form {
            let function = self.form_function(fitted, "albedo form");
            return Ok(match m.albedo {
                // FGD ~ F0 scale + bias, as the Karis table is read.
                AlbedoPath::Karis => {
                    let f0 = normal_incidence_reflectance(eta, kappa);
                    let weights = Expr::Construct(Ty::Vec(2), vec![f(f0 as f32), f(1.0)]);
                    call(Builtin::Dot, vec![weights, func(&function, vec![mu, f(alpha as f32)])])
                }
                // A form of the lookup's own variables: the scene parser sets the FGD path for a
                // form fitted to `fgd`, and no form reads on the Belcour path.
                AlbedoPath::Fgd | AlbedoPath::Belcour => {
                    func(&function, vec![mu, f(alpha as f32), f(eta as f32), f(kappa as f32)])
                }
            });
        }
        match m.albedo {
            AlbedoPath::Fgd => self.fgd(m, mu, alpha, eta, kappa),
            AlbedoPath::Belcour => {
                let Some((basis, table)) = self
                    .sources
                    .table(TableKind::Belcour)
                    .and_then(|table| Some((table.fresnel_basis.clone()?, table)))
                else {
                    return Err(self.missing(m, "the Belcour split-sum table (belcour.dds with its Fresnel basis)"));
                };
                self.reads.insert("belcour".into());
                Ok(self.split_sum(&table, basis.coefficients(eta, kappa), mu, alpha))
            }
            AlbedoPath::Karis => {
                let Some(table) = self.sources.table(TableKind::Karis) else {
                    return Err(self.missing(m, "the Karis split-sum table (karis.dds)"));
                };
                // FGD ~ F0 scale + bias, with F0 at the relative index (model::folder).
                let f0 = normal_incidence_reflectance(eta, kappa);
                self.reads.insert("karis".into());
                Ok(self.split_sum(&table, [f0, 1.0, 0.0, 0.0], mu, alpha))
            }
        }
    }

    /// A split-sum table's channels weighed by `coefficients`, constants for the interface's index.
    fn split_sum(&mut self, table: &TableFile, coefficients: [f64; 4], mu: Expr, alpha: f64) -> Expr {
        let c = Expr::Construct(Ty::Vec(4), coefficients.iter().map(|&c| f(c as f32)).collect());
        call(Builtin::Dot, vec![c, self.read2(table, mu, f(alpha as f32))])
    }

    fn missing(&self, m: &ShaderMaterial, what: &str) -> Error {
        Error::format(&self.manifest_path, format!("lists no {what}, which material `{}` reads", m.name))
    }

    /// `FGD(mu, alpha, eta, kappa)`: the slice holding the index, else a stand-in whose region
    /// holds it (`fgd_rarer`), else the lossless packing (as `model::folder` reads them).
    fn fgd(&mut self, m: &ShaderMaterial, mu: Expr, alpha: f64, eta: f64, kappa: f64) -> Result<Expr> {
        if let Some(value) = self.slice(false, eta, kappa, mu.clone(), f(alpha as f32), Some(alpha)) {
            return Ok(value);
        }
        if let Some(value) = self.stand_in(m, Quantity::Albedo, mu.clone(), f(alpha as f32), eta, kappa) {
            return value;
        }
        match &self.sources.packing {
            Some((file, packed)) => {
                let (file, function) = (file.clone(), packed.program.function.clone());
                let extent = [packed.texture.width, packed.texture.height, packed.texture.depth];
                let variable = self.bind(&file, extent, 3, 1, false);
                self.needs.packing = true;
                self.reads.insert("fgd packing".into());
                Ok(func(&function, vec![name(&variable), mu, f(alpha as f32), f(eta as f32), f(kappa as f32)]))
            }
            None => Err(Error::format(
                &self.manifest_path,
                format!(
                    "holds no FGD slice at (eta, kappa) = ({eta}, {kappa}) and no lossless FGD packing, which material `{}` reads",
                    m.name
                ),
            )),
        }
    }

    /// `TIR(mu, alpha, eta)` for material `m`; `alpha` is a shader expression (a lobe's roughness).
    fn tir(&mut self, m: &ShaderMaterial, mu: Expr, alpha: Expr, eta: f64) -> Result<Expr> {
        match m.tir {
            TirPath::Off => Ok(f(0.0)),
            TirPath::Form => {
                let Some(fitted) = &m.tir_form else {
                    return Err(self.refuse(&m.name, "names a TIR form (tir = \"fit:PATH\") and none was given".into()));
                };
                let function = self.form_function(fitted, "tir form");
                Ok(func(&function, vec![mu, alpha, f(eta as f32)]))
            }
            TirPath::Fit => {
                if self.sources.fit.is_none() {
                    return Err(Error::format(
                        &self.manifest_path,
                        "lists no fitted TIR form, which the scene's TIR path `fit` reads",
                    ));
                }
                self.needs.fit = true;
                self.reads.insert("tir fit".into());
                Ok(func("tmlut_tir", vec![mu, alpha, f(eta as f32)]))
            }
            TirPath::Table => {
                if let Some(value) = self.slice(true, eta, 0.0, mu.clone(), alpha.clone(), None) {
                    return Ok(value);
                }
                if let Some(value) = self.stand_in(m, Quantity::Tir, mu.clone(), alpha.clone(), eta, 0.0) {
                    return value;
                }
                let Some(table) = self.sources.table(TableKind::Tir) else {
                    return Err(self.refuse(
                        &m.name,
                        format!(
                            "reads TIR at eta {eta}, which neither a TIR slice of the folder holds nor a 3D TIR table \
                             (tir.dds) answers"
                        ),
                    ));
                };
                self.volume(m, &table, (mu, alpha), (eta, 0.0), "tir table".into())
            }
        }
    }

    /// The first stand-in of `quantity` the folder holds whose region holds `(eta, kappa)`
    /// ([`crate::model::stand_in`]), read at `(mu, alpha)`.
    fn stand_in(
        &mut self,
        m: &ShaderMaterial,
        quantity: Quantity,
        mu: Expr,
        alpha: Expr,
        eta: f64,
        kappa: f64,
    ) -> Option<Result<Expr>> {
        let (stand_in, table) = crate::model::stand_ins()
            .filter(|s| s.answers(quantity, eta, kappa))
            .find_map(|s| Some((s, self.sources.table(s.table)?)))?;
        Some(self.volume(m, &table, (mu, alpha), (eta, kappa), format!("{} table", stand_in.table.name())))
    }

    /// A 3D table (TIR, or a stand-in such as FGD onto a rarer medium) at the point the CPU
    /// computes ([`crate::table::derived::point_in`], printed): each axis's quantity by name, the
    /// critical-angle offset or fraction with `asin(eta)` folded to a constant and `acos` by
    /// [`helpers::acos`], not the builtin, whose error Vulkan bounds only loosely and which the
    /// axes' asinh spacing magnifies up to a thousandfold near the critical angle.
    fn volume(
        &mut self,
        m: &ShaderMaterial,
        t: &TableFile,
        (mu, alpha): (Expr, Expr),
        (eta, kappa): (f64, f64),
        what: String,
    ) -> Result<Expr> {
        let names: Vec<&str> = t.axes.iter().map(|a| a.name.as_str()).collect();
        let point = match point_in(&t.axes, InShader(mu), InShader(alpha), eta, kappa) {
            Some(point) if point.len() == 3 => point,
            _ => {
                return Err(self.refuse(
                    &m.name,
                    format!(
                        "reads {what} {} of axes ({}); the shader reads a 3D table of mu, alpha, and eta, kappa, \
                         {CRITICAL_ANGLE_OFFSET} or {CRITICAL_ANGLE_FRACTION}",
                        t.file,
                        names.join(", ")
                    ),
                ));
            }
        };
        self.needs.acos |= names.iter().any(|name| derived::definition(name).is_some());
        let variable = self.bind_table(t);
        self.needs.trilinear = true;
        self.reads.insert(what);
        let mut arguments = vec![name(&variable)];
        arguments.extend(t.axes.iter().zip(point).map(|(axis, x)| coordinate(axis, x.0)));
        arguments.extend(t.axes.iter().map(|axis| f(axis.count as f32)));
        Ok(func("tmh_trilinear", arguments))
    }

    /// `GD(mu, alpha)`.
    fn gd(&mut self, m: &ShaderMaterial, mu: Expr, alpha: Expr) -> Result<Expr> {
        match self.sources.table(TableKind::Gd) {
            Some(t) => {
                self.reads.insert("gd".into());
                Ok(self.read2(&t, mu, alpha).member("x"))
            }
            None => Err(self.missing(m, "2D GD table (gd.dds)")),
        }
    }
}

const CHANNELS: [&str; 4] = ["x", "y", "z", "w"];

/// Channels as stored: DDS holds 1, 2 or 4.
fn padded(n: usize) -> usize {
    match n {
        0 | 1 => 1,
        2 => 2,
        _ => 4,
    }
}

/// The function of material `name`: `tm_` and its [`identifier`]. Nothing else the generator
/// makes begins with `tm_` (the module docs), so material names collide only with each other.
pub fn material_function(name: &str) -> String {
    format!("tm_{}", identifier(name))
}

/// A shader identifier from a material name: letters, digits and `_`.
pub fn identifier(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect()
}

/// The manifest's texture coordinate of `x` along `axis`, as the CPU's f32 sampler computes it
/// ([`Axis::texture_coordinate_in`]), printed.
fn coordinate(axis: &Axis, x: Expr) -> Expr {
    axis.texture_coordinate_in(InShader(x)).0
}

/// The texture coordinate of `x` along node-aligned `axis` of a slice whose first node is texel
/// `origin` of a texture array `extent` texels wide along it
/// ([`crate::formats::slice_array::texture_coordinate_in`]), printed.
fn array_coordinate(axis: &Axis, origin: u32, extent: u32, x: Expr) -> Expr {
    crate::formats::slice_array::texture_coordinate_in(axis, origin, extent as usize, InShader(x)).0
}

/// A shader expression in the arithmetic of an axis's coordinates ([`Arithmetic`]), so that the
/// formulas the CPU computes in f32 are printed from the same code: its constants are those f32
/// values, and its `asinh` and `acos` the helpers' ([`helpers::asinh`], [`helpers::acos`]).
#[derive(Clone)]
struct InShader(Expr);

macro_rules! in_shader_operator {
    ($trait:ident, $method:ident) => {
        impl std::ops::$trait for InShader {
            type Output = InShader;
            fn $method(self, other: InShader) -> InShader {
                InShader(std::ops::$trait::$method(self.0, other.0))
            }
        }
    };
}
in_shader_operator!(Add, add);
in_shader_operator!(Sub, sub);
in_shader_operator!(Mul, mul);
in_shader_operator!(Div, div);

impl Arithmetic for InShader {
    type Constant = f32;
    fn constant(value: f32) -> Self {
        InShader(f(value))
    }
    fn of(value: f64) -> Self {
        InShader(f(value as f32))
    }
    fn max(self, other: Self) -> Self {
        InShader(self.0.max(other.0))
    }
    fn min(self, other: Self) -> Self {
        InShader(self.0.min(other.0))
    }
    fn clamp(self, lo: Self, hi: Self) -> Self {
        InShader(self.0.clamp(lo.0, hi.0))
    }
    fn sqrt(self) -> Self {
        InShader(self.0.sqrt())
    }
    fn asinh(self) -> Self {
        InShader(func("tmh_asinh", vec![self.0]))
    }
    fn acos(self) -> Self {
        InShader(func("tmh_acos", vec![self.0]))
    }
    type Condition = Expr;
    fn less_than(self, other: Self) -> Expr {
        self.0.lt(other.0)
    }
    fn at_most(self, other: Self) -> Expr {
        self.0.le(other.0)
    }
    fn both(a: Expr, b: Expr) -> Expr {
        a.and(b)
    }
    fn select(condition: Expr, then: Self, otherwise: Self) -> Self {
        InShader(select(condition, then.0, otherwise.0))
    }
}

/// Print `shader` in both languages.
pub fn texts(shader: &SceneShader) -> [(Lang, String); 2] {
    [Lang::Hlsl, Lang::Wgsl].map(|lang| (lang, shader.module.print(lang)))
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::super::{Function, Intrinsic, Op, Stmt};
    use super::*;
    use crate::table::Mapping;

    /// A value of the chooser functions' f32 arithmetic.
    #[derive(Debug, Clone, Copy)]
    enum Value {
        F(f32),
        B(bool),
    }

    impl Value {
        fn f(self) -> f32 {
            match self {
                Value::F(x) => x,
                Value::B(_) => panic!("a bool where an f32 is read"),
            }
        }
        fn b(self) -> bool {
            match self {
                Value::B(b) => b,
                Value::F(_) => panic!("an f32 where a bool is read"),
            }
        }
    }

    /// Evaluates a slice read's or a texture coordinate's expression in f32, as a GPU computes it: a chooser of
    /// `functions` it calls is run. A texture read (`tmh_bilinear(tmh_tableN, ...)`) stands for the
    /// slice it reads: it is `N`, the binding.
    fn evaluate(e: &Expr, scope: &HashMap<String, Value>, functions: &[Function]) -> Value {
        let eval = |e: &Expr| evaluate(e, scope, functions);
        match e {
            Expr::Name(n) => scope[n],
            Expr::F32(x) => Value::F(*x),
            Expr::Paren(e) | Expr::Member(e, _) => eval(e),
            Expr::Function(function, args) if function == "tmh_bilinear" => match &args[0] {
                Expr::Name(texture) => Value::F(texture.trim_start_matches("tmh_table").parse::<f32>().unwrap()),
                other => panic!("a texture read of {other:?}"),
            },
            // The axis arithmetic's helper, as the CPU's f32 arithmetic computes it (the helper's
            // own body is the GPU's, which the GPU check runs).
            Expr::Function(function, args) if function == "tmh_asinh" => Value::F(eval(&args[0]).f().asinh()),
            Expr::Function(function, args) => {
                let called = functions.iter().find(|f| &f.name == function).expect("a chooser of the module");
                let mut inner: HashMap<String, Value> =
                    called.params.iter().zip(args).map(|((p, _), a)| (p.clone(), eval(a))).collect();
                run(&called.body, &mut inner, functions).expect("the chooser returns")
            }
            Expr::Call(Builtin::Intrinsic(intrinsic), args) => {
                let x: Vec<f32> = args.iter().map(|a| eval(a).f()).collect();
                Value::F(match intrinsic {
                    Intrinsic::Max => x[0].max(x[1]),
                    Intrinsic::Min => x[0].min(x[1]),
                    Intrinsic::Clamp => x[0].clamp(x[1], x[2]),
                    Intrinsic::Sqrt => x[0].sqrt(),
                    other => panic!("the evaluator reads no {other:?}"),
                })
            }
            Expr::Select { condition, then, otherwise } => {
                if eval(condition).b() {
                    eval(then)
                } else {
                    eval(otherwise)
                }
            }
            Expr::Binary(op, a, b) => {
                let (a, b) = (eval(a), eval(b));
                match op {
                    Op::Add => Value::F(a.f() + b.f()),
                    Op::Sub => Value::F(a.f() - b.f()),
                    Op::Mul => Value::F(a.f() * b.f()),
                    Op::Div => Value::F(a.f() / b.f()),
                    Op::Compare(compare) => Value::B(compare.holds(f64::from(a.f()), f64::from(b.f()))),
                    Op::And => Value::B(a.b() && b.b()),
                    Op::Or => Value::B(a.b() || b.b()),
                }
            }
            other => panic!("the chooser evaluator reads no {other:?}"),
        }
    }

    /// Runs `body` from `scope`; `Some` of what it returns.
    fn run(body: &[Stmt], scope: &mut HashMap<String, Value>, functions: &[Function]) -> Option<Value> {
        for statement in body {
            match statement {
                Stmt::Let { name, value, .. } | Stmt::Var { name, value: Some(value), .. } => {
                    let v = evaluate(value, scope, functions);
                    scope.insert(name.clone(), v);
                }
                Stmt::Assign(Expr::Name(name), value) => {
                    let v = evaluate(value, scope, functions);
                    scope.insert(name.clone(), v);
                }
                Stmt::If { condition, then, otherwise } => {
                    let branch = if evaluate(condition, scope, functions).b() { then } else { otherwise };
                    if let Some(v) = run(branch, scope, functions) {
                        return Some(v);
                    }
                }
                Stmt::Return(e) => return Some(evaluate(e, scope, functions)),
                Stmt::Comment(_) => {}
                other => panic!("the chooser evaluator runs no {other:?}"),
            }
        }
        None
    }

    /// The texture coordinates the shader prints are the CPU's f32 ones bit for bit, for every
    /// mapping and placement and in a texture array: the printed expression run in f32.
    #[test]
    fn printed_texture_coordinates_are_the_cpus_f32_ones() {
        let mappings = [
            Mapping::Identity,
            Mapping::Sqrt,
            Mapping::SqrtOneMinus,
            Mapping::SqrtEnds,
            Mapping::Asinh { scale: 0.001, centre: 0.0 },
            Mapping::Asinh { scale: 0.05, centre: 0.3 },
            Mapping::AsinhRampBelow { scale: 0.01, centre: 0.2, slope_below: 2.0 },
        ];
        for mapping in mappings {
            for node_aligned in [true, false] {
                let axis = if node_aligned {
                    Axis::node_aligned("x", 0.05, 0.95, 33)
                } else {
                    Axis::cell_centred("x", 0.95, 0.05, 33)
                };
                let axis = axis.unwrap().with_mapping(mapping).unwrap();
                for x in [0.0, 0.05, 0.123456789, 0.3, 0.5001, 0.95, 1.0] {
                    let scope = HashMap::from([("x".to_string(), Value::F(x as f32))]);
                    let printed = evaluate(&coordinate(&axis, name("x")), &scope, &[]).f();
                    let cpu = crate::loader::texture_coordinate(&axis, x);
                    assert_eq!(printed.to_bits(), cpu.to_bits(), "{mapping:?} at {x}: printed {printed}, CPU {cpu}");
                    if node_aligned {
                        let printed = evaluate(&array_coordinate(&axis, 7, 100, name("x")), &scope, &[]).f();
                        let cpu = crate::formats::slice_array::texture_coordinate(&axis, 7, 100, x);
                        assert_eq!(printed.to_bits(), cpu.to_bits(), "{mapping:?} at {x} in an array");
                    }
                }
            }
        }
    }

    /// Lattice node 80 of the slices' alpha axis, `(80/128)^2`, exact in f32 and f64.
    const NODE: f64 = 0.390625;
    const ETA: f64 = 0.7122507122507123;

    /// A slice file (TIR, or FGD at `kappa = 0`) at [`ETA`] over `mu` from `mu_start` to 1 and
    /// `alpha` in `alpha`.
    fn slice_file(file: &str, tir: bool, mu_start: f64, alpha: (f64, f64)) -> TableFile {
        TableFile {
            file: file.into(),
            table: file.trim_end_matches(".dds").into(),
            place: None,
            axes: vec![
                Axis::node_aligned("mu", mu_start, 1.0, 154).unwrap(),
                Axis::node_aligned("alpha", alpha.0, alpha.1, 12).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
            ],
            channels: 1,
            indices: vec![(ETA, 0.0)],
            fresnel_basis: None,
            is_tir: tir,
            is_fgd: !tir,
        }
    }

    /// The file of the slice the scene shader reads among `slices` at `(mu, alpha)`, run in f32;
    /// `known_alpha` where the generator knows the roughness (an interface's FGD).
    fn chosen(slices: &[TableFile], tir: bool, mu: f32, alpha: f32, known_alpha: Option<f64>) -> String {
        let sources = Sources { slices: slices.to_vec(), ..Sources::default() };
        let mut g = Generator::new(&sources, String::new());
        let alpha_expr = if known_alpha.is_some() { f(alpha) } else { name("alpha") };
        let read = g.slice(tir, ETA, 0.0, name("mu"), alpha_expr, known_alpha).expect("slices at the index");
        let scope = HashMap::from([("mu".to_string(), Value::F(mu)), ("alpha".to_string(), Value::F(alpha))]);
        let binding = evaluate(&read, &scope, &g.chooser_functions).f();
        g.textures[binding as usize].file.clone()
    }

    #[test]
    fn the_slice_chooser_prefers_a_slice_that_holds_the_lookup_as_the_cpu_evaluator_does() {
        // absorbing-coat-00482 of `scripts/make-library 1000 1 DIR --per-scene 250` (as in
        // `model::folder::tests`): TIR at alpha a rounding below lattice node 80, where another
        // material's slice at the index begins; the material's own slice holds it inside. The
        // printed chooser, run in f32, reads the slice that holds it, in either order.
        let other = slice_file("other.dds", true, 0.701171875, (NODE, 1.0));
        let own = slice_file("own.dds", true, 0.701171875, (0.32525634765625, 0.4306640625));
        let below = |ulps: u32| f32::from_bits((NODE as f32).to_bits() - ulps);
        for (slices, first) in [([other.clone(), own.clone()], "other.dds"), ([own, other], "own.dds")] {
            for alpha in [below(1), below(8), (NODE - 5e-6) as f32] {
                assert_eq!(chosen(&slices, true, 0.723594, alpha, None), "own.dds", "alpha {alpha}");
            }
            // Held by both, or by neither and within the slack of both: the first listed; past
            // the own slice's end, the other slice, which holds it.
            assert_eq!(chosen(&slices, true, 0.723594, 0.42, None), first);
            assert_eq!(chosen(&slices, true, 1.0 + 2.0 * f32::EPSILON, 0.42, None), first);
            assert_eq!(chosen(&slices, true, 0.723594, 0.5, None), "other.dds");
        }
        // An interface's FGD, whose roughness the generator knows: a slice over every mu that
        // holds it is always chosen, and the slices that cannot beat it are left out, but not one
        // whose end merely lies within the slack of it (the other slice, listed first).
        let other = slice_file("other.dds", false, 0.0, (NODE, 1.0));
        let own = slice_file("own.dds", false, 0.0, (0.32525634765625, 0.4306640625));
        let slices = [other, own];
        for alpha in [NODE - 1e-6, 0.38] {
            assert_eq!(chosen(&slices, false, 0.5, alpha as f32, Some(alpha)), "own.dds", "alpha {alpha}");
        }
        assert_eq!(chosen(&slices, false, 0.5, NODE as f32, Some(NODE)), "other.dds");
        assert_eq!(chosen(&slices, false, 0.5, 0.42, Some(0.42)), "other.dds");
    }
}
