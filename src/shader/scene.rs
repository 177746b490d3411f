//! The transfer-matrix evaluation of a scene's materials as a shader: one function per material,
//! `tm_<material>(mu)`, specialised to its layer stack (layers unrolled, every index and roughness
//! baked in, index-matched layers dropped) and to the tables of a built folder, read with the
//! manifest's coordinates. It returns the lobes (energy per channel, GGX roughness, cosine of the
//! mean direction, GD) and the directional albedo `A(mu)`, computing what
//! [`crate::model::Material::evaluate`] computes, step for step, in f32.
//!
//! Tables are read by hand-filtered texel loads (four `textureLoad`s and two lerps in f32, as
//! [`crate::packing::emulator`] filters with `Filter::Exact`), not by the sampler: hardware
//! filtering weighs texels with 8 fractional bits on most GPUs, which alone moves a value by up to
//! 1/512 of a texel step, and float32 textures are not filterable in WebGPU without a feature.
//!
//! What the generated code guards, that the thesis's hand-written HLSL did not (the project notes'
//! list of its defects): `1 / t` with `t` floored (never a division by 0 when TIR takes everything),
//! ratios that are not finite fall back to the reflectance above (a comparison, so NaN included),
//! the transmission lobes' roughness scale `|(eta_ji r.z + rp.z) / rp.z|` taken whole in `abs`,
//! the top index of every interface that of the layer above (air 1.0, never 1.003), and no read
//! of a layer below the last one.
//!
//! Covered now: the 2-flux model; albedo by FGD slices or the lossless FGD packing; TIR by slices,
//! the fitted form, or off; GD by its 2D table. Refused with a message: the 6-flux model, the
//! Belcour and Karis albedo paths, and the full 3D TIR table (whose asinh axis HLSL has no builtin
//! for).

use std::borrow::Cow;
use std::collections::BTreeMap;

use super::{Expr, Item, Lang, Module, Parens, Stmt, Ty, assign, f, func, let_, name, select, splat3, var};
use crate::error::{Error, Result};
use crate::fit::forms::Form;
use crate::formats::FileFormat;
use crate::formats::manifest::MANIFEST_FILE;
use crate::loader::LutFolder;
pub use crate::loader::shader::{MaterialFunction, ShaderDescription, TextureBinding};
use crate::model::factors::{EXPONENT_LIMIT, INDEX_MATCHED, NEARLY_INDEX_MATCHED};
use crate::model::folder::{is_slice, slice_indices};
use crate::model::tm2::SMALLEST_TRANSMISSION;
use crate::model::{AlbedoPath, FluxModel, Layer, Stack, TirPath};
use crate::packing::{PackedFgd, Packing};
use crate::physics::ggx_to_hg;
use crate::table::{Axis, Mapping, Placement};

/// A material the shader evaluates.
#[derive(Debug, Clone)]
pub struct ShaderMaterial {
    pub name: String,
    pub model: FluxModel,
    pub albedo: AlbedoPath,
    pub tir: TirPath,
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
                    stored (its DXGI format, e.g. R32_FLOAT -> r32float), one mip level, linear; no sampler: the shader \
                    loads and filters texels itself. Call the material's function with the view cosine mu = n.v."
                .into(),
        }
    }
}

/// One 2D table (a slice, or GD) the shader reads: its binding, axes and the channels' fixed indices.
#[derive(Debug, Clone)]
struct Table2 {
    file: String,
    axes: Vec<Axis>,
    /// `(eta, kappa)` per channel, for slices.
    indices: Vec<(f64, f64)>,
    is_tir: bool,
    is_fgd: bool,
}

/// Everything the materials read, found in the folder.
struct Sources {
    slices: Vec<Table2>,
    gd: Option<Table2>,
    packing: Option<(String, PackedFgd)>,
    fit: Option<(Form, Vec<f64>)>,
}

/// The shader of `materials` over the tables of `folder`.
pub fn generate(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<SceneShader> {
    let manifest_path = folder.dir().join(MANIFEST_FILE);
    let sources = sources(folder, materials)?;
    let mut g = Generator {
        sources: &sources,
        textures: Vec::new(),
        used: BTreeMap::new(),
        manifest_path: manifest_path.display().to_string(),
        needs_packing: false,
        needs_fit: false,
    };
    let mut functions = Vec::new();
    let mut described = Vec::new();
    let mut max_lobes = 1;
    for material in materials {
        let (function, lobes) = g.material(material)?;
        max_lobes = max_lobes.max(lobes);
        described.push(MaterialFunction { material: material.name.clone(), function: function.name.clone(), lobes });
        functions.push(function);
    }
    let mut module = Module::new(Parens::Minimal);
    module.comment(
        "tmlut shader: the transfer-matrix model (Randrianandrasana, Callet & Lucas 2021, 2-flux) of\n\
         a scene's materials, specialised to their layer stacks and the tables of one built folder.\n\
         Generated; each material's function computes what tmlut's CPU evaluator computes, in f32.\n\
         Bindings: group 0, one texture per table file (see the .shader.json beside this file).",
    );
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
            ty: Ty::Texture { dims: t.dimension, scalar: t.channels == 1 && t.dimension == 3 },
        });
    }
    helpers(&mut module);
    if g.needs_fit
        && let Some((form, parameters)) = &sources.fit
    {
        let fit = crate::fit::forms::module(*form, parameters).ok_or_else(|| {
            Error::format(&manifest_path, format!("the fitted TIR form `{}` has no shader", form.name()))
        })?;
        module.items.extend(fit.items);
    }
    if g.needs_packing
        && let Some((_, packed)) = &sources.packing
    {
        // The packing's lookup prints fully parenthesised; as a function of this module it takes
        // the module's style, which changes only redundant parentheses, not the operations.
        module.items.extend(packed.program.module("The lossless FGD packing's exact lookup (docs/packing.md).").items);
    }
    for function in functions {
        module.push(Item::Function(function));
    }
    let textures = g.textures;
    Ok(SceneShader { module, textures, materials: described, max_lobes })
}

fn sources(folder: &LutFolder, materials: &[ShaderMaterial]) -> Result<Sources> {
    let entries = &folder.manifest().files;
    let mut slices = Vec::new();
    let mut gd = None;
    let mut packing = None;
    for (file, entry) in entries {
        if entry.format != FileFormat::Dds {
            continue;
        }
        if entry.packing.as_ref().is_some_and(|p| p.name == Packing::Lossless.name()) {
            if materials.iter().any(|m| m.albedo == AlbedoPath::Fgd) {
                let table = folder.load(file)?;
                let source_axes: Vec<Axis> = entry
                    .packing
                    .as_ref()
                    .map(|p| p.source_axes.iter().map(|a| a.axis.clone()).collect())
                    .unwrap_or_default();
                let texture = crate::model::folder::SampledTable::new(&table)?.into_channel(0);
                let packed = PackedFgd::with_texture(texture, Packing::Lossless, entry.precision, &source_axes)
                    .map_err(|e| Error::format(folder.dir().join(file), e.to_string()))?;
                packing = Some((file.clone(), packed));
            }
            continue;
        }
        let axes: Vec<Axis> = entry.axes.iter().map(|a| a.axis.clone()).collect();
        let slice_of = |prefix: &str| is_slice(entry, prefix);
        if slice_of("fgd") || slice_of("tir") {
            let indices = slice_indices(entry);
            slices.push(Table2 { file: file.clone(), axes, indices, is_tir: slice_of("tir"), is_fgd: slice_of("fgd") });
        } else if entry.table == "gd" && axes.len() == 2 {
            gd = Some(Table2 { file: file.clone(), axes, indices: Vec::new(), is_tir: false, is_fgd: false });
        }
    }
    let fit = entries
        .values()
        .find_map(|e| e.fit.clone())
        .or_else(|| folder.manifest().scene.as_ref().and_then(|s| s.plan.tir_fit.clone()))
        .and_then(|fit| Form::from_name(&fit.form).map(|form| (form, fit.parameters)));
    Ok(Sources { slices, gd, packing, fit })
}

struct Generator<'a> {
    sources: &'a Sources,
    textures: Vec<TextureBinding>,
    /// File -> variable of the textures bound so far.
    used: BTreeMap<String, String>,
    manifest_path: String,
    needs_packing: bool,
    needs_fit: bool,
}

/// A value per channel: energies of interfaces are equal in all three, so kept as one scalar
/// expression splatted where a vector is needed.
fn v3(e: Expr) -> Expr {
    splat3(e)
}

impl Generator<'_> {
    fn refuse(&self, material: &str, what: String) -> Error {
        Error::invalid(format!("tmlut shader, material `{material}`"), what)
    }

    /// The texture variable of `file`, binding it on first use.
    fn bind(&mut self, file: &str, extent: [usize; 3], dimension: u8, channels: usize) -> String {
        if let Some(v) = self.used.get(file) {
            return v.clone();
        }
        let variable = format!("tm_table{}", self.textures.len());
        self.textures.push(TextureBinding {
            binding: self.textures.len() as u32,
            variable: variable.clone(),
            file: file.to_string(),
            extent,
            dimension,
            channels,
        });
        self.used.insert(file.to_string(), variable.clone());
        variable
    }

    /// The read of channel `channel` of 2D table `t` at `(mu, alpha)`: the manifest's texture
    /// coordinate of each axis in f32, then bilinear filtering by hand.
    fn read2(&mut self, t: &Table2, channel: usize, mu: Expr, alpha: Expr) -> Expr {
        let channels = if t.indices.is_empty() { 1 } else { padded(t.indices.len()) };
        let variable = self.bind(&t.file, [t.axes[0].count, t.axes[1].count, 1], 2, channels);
        let [u, v] = [0, 1].map(|d| coordinate(&t.axes[d], if d == 0 { mu.clone() } else { alpha.clone() }));
        let sample =
            func("tm_bilinear", vec![name(&variable), u, v, f(t.axes[0].count as f32), f(t.axes[1].count as f32)]);
        sample.member(["x", "y", "z", "w"][channel])
    }

    /// The slice of `quantity` whose channel holds `(eta, kappa)`.
    fn slice(&self, tir: bool, eta: f64, kappa: f64) -> Option<(Table2, usize)> {
        let same = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        self.sources
            .slices
            .iter()
            .filter(|s| if tir { s.is_tir } else { s.is_fgd })
            .find_map(|s| s.indices.iter().position(|&(e, k)| same(e, eta) && same(k, kappa)).map(|c| (s.clone(), c)))
    }

    /// `FGD(mu, alpha, eta, kappa)` for material `m`.
    fn fgd(&mut self, m: &ShaderMaterial, mu: Expr, alpha: f64, eta: f64, kappa: f64) -> Result<Expr> {
        if m.albedo != AlbedoPath::Fgd {
            return Err(self.refuse(
                &m.name,
                format!(
                    "reads albedo on the {} path; the shader covers the fgd path (slices or the lossless packing)",
                    m.albedo.name()
                ),
            ));
        }
        if let Some((t, c)) = self.slice(false, eta, kappa) {
            return Ok(self.read2(&t, c, mu, f(alpha as f32)));
        }
        match &self.sources.packing {
            Some((file, packed)) => {
                let file = file.clone();
                let extent = [packed.texture.width, packed.texture.height, packed.texture.depth];
                let variable = self.bind(&file, extent, 3, 1);
                self.needs_packing = true;
                Ok(func(
                    &packed.program.function,
                    vec![name(&variable), mu, f(alpha as f32), f(eta as f32), f(kappa as f32)],
                ))
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
            TirPath::Fit => {
                if self.sources.fit.is_none() {
                    return Err(Error::format(
                        &self.manifest_path,
                        "lists no fitted TIR form, which the scene's TIR path `fit` reads",
                    ));
                }
                self.needs_fit = true;
                Ok(func("tmlut_tir", vec![mu, alpha, f(eta as f32)]))
            }
            TirPath::Table => match self.slice(true, eta, 0.0) {
                Some((t, c)) => Ok(self.read2(&t, c, mu, alpha)),
                None => Err(self.refuse(
                    &m.name,
                    format!(
                        "reads TIR at eta {eta}, which no TIR slice of the folder holds; the shader reads slices \
                         (tmlut build --scene), not the 3D TIR table"
                    ),
                )),
            },
        }
    }

    fn gd(&mut self, m: &ShaderMaterial, mu: Expr, alpha: Expr) -> Result<Expr> {
        match self.sources.gd.clone() {
            Some(t) => Ok(self.read2(&t, 0, mu, alpha)),
            None => Err(Error::format(
                &self.manifest_path,
                format!("lists no 2D GD table (gd.dds), which material `{}` reads", m.name),
            )),
        }
    }

    /// The function of one material and its lobe count.
    fn material(&mut self, m: &ShaderMaterial) -> Result<(super::Function, usize)> {
        if m.model != FluxModel::TwoFlux {
            return Err(self.refuse(&m.name, "uses the 6-flux model; the shader covers the 2-flux model".into()));
        }
        let layers = m.stack.reachable_layers();
        let mut body = vec![
            Stmt::Comment("The view cosine, clamped as the CPU evaluator clamps it.".into()),
            let_("mu", Ty::F32, name("mu_in").clamp(f(0.0), f(1.0))),
            var("cos_in", Ty::F32, name("mu")),
            // The energy matrices (one 2x2 per channel, entrywise in a vec3) and the asymmetry
            // matrix (the same in all three lanes), and what was reflected above.
            Stmt::Var {
                name: "energy".into(),
                ty: Ty::Named("TmMatrix".into()),
                value: Some(func("tm_identity", vec![])),
            },
            Stmt::Var {
                name: "asym".into(),
                ty: Ty::Named("TmMatrix".into()),
                value: Some(func("tm_identity", vec![])),
            },
            var("r_above", Ty::Vec(3), v3(f(0.0))),
            var("g_above", Ty::F32, f(0.0)),
            var("g_transmitted", Ty::F32, f(1.0)),
            Stmt::Var { name: "result".into(), ty: Ty::Named("TmResult".into()), value: None },
        ];
        // Generation-time walk of the stack, as `model::factors::components` walks it.
        let mut eta_above = [1.0f64; 3];
        enum Kind {
            Dielectric { eta: f64, alpha: f64 },
            Conductor { eta: [f64; 3], kappa: [f64; 3], alpha: f64 },
            Medium { sigma_k: [f64; 3], depth: f64 },
            Pass,
        }
        let mut kinds = Vec::new();
        for layer in layers {
            kinds.push(match layer {
                Layer::Interface(i) if i.is_conductor() => Kind::Conductor {
                    eta: std::array::from_fn(|c| i.eta[c] / eta_above[c]),
                    kappa: std::array::from_fn(|c| i.kappa[c] / eta_above[c]),
                    alpha: i.alpha,
                },
                Layer::Interface(i) => {
                    let eta = (0..3).map(|c| i.eta[c] / eta_above[c]).sum::<f64>() / 3.0;
                    eta_above = i.eta;
                    if (eta - 1.0).abs() < INDEX_MATCHED {
                        Kind::Pass
                    } else {
                        Kind::Dielectric { eta, alpha: i.alpha }
                    }
                }
                // The 2-flux model's media only absorb.
                Layer::Medium(md) => {
                    if md.depth == 0.0 || md.sigma_k.iter().all(|&k| k == 0.0) {
                        Kind::Pass
                    } else {
                        Kind::Medium { sigma_k: md.sigma_k, depth: md.depth }
                    }
                }
            });
        }
        // `model::below` for the 2-flux model: the asymmetry of the next reflecting interface, and
        // whether any lies below.
        let below = |index: usize| -> (f64, bool) {
            for k in &kinds[index + 1..] {
                match k {
                    Kind::Dielectric { alpha, .. } | Kind::Conductor { alpha, .. } => return (ggx_to_hg(*alpha), true),
                    _ => {}
                }
            }
            (1.0, false)
        };
        let mut lobes = 0usize;
        let mut top_albedo: Option<Expr> = None;
        for (index, kind) in kinds.iter().enumerate() {
            let layer = index + 1;
            let p = format!("l{layer}_");
            let n = |s: &str| name(&format!("{p}{s}"));
            let mut s: Vec<Stmt> = vec![Stmt::Comment(format!("Layer {layer}."))];
            let (r_total, g_total) = match kind {
                Kind::Pass => continue,
                Kind::Medium { sigma_k, depth } => {
                    // `factors::medium` without scattering: t = exp(-sigma_k tau), tau the path along
                    // the lobe, cut where sigma_k tau would pass the exponent limit.
                    let largest = sigma_k.iter().copied().fold(0.0, f64::max);
                    let tau_limit = (EXPONENT_LIMIT / largest) as f32;
                    s.push(let_(
                        &format!("{p}tau"),
                        Ty::F32,
                        select(
                            name("cos_in").gt(f(0.0)),
                            (f(*depth as f32) / name("cos_in")).min(f(tau_limit)),
                            f(tau_limit),
                        ),
                    ));
                    let k = super::vec3(f(sigma_k[0] as f32), f(sigma_k[1] as f32), f(sigma_k[2] as f32));
                    s.push(let_(&format!("{p}t"), Ty::Vec(3), func("exp", vec![-k * v3(n("tau"))])));
                    s.push(assign(name("energy"), func("tm_attenuate", vec![name("energy"), n("t")])));
                    s.push(assign(
                        name("asym"),
                        func("tm_attenuate", vec![name("asym"), v3(func("tm_average", vec![n("t")]))]),
                    ));
                    body.extend(s);
                    continue;
                }
                Kind::Dielectric { eta, alpha } => {
                    let (eta, alpha) = (*eta, *alpha);
                    let (g_next, returns_light) = below(index);
                    let g_alpha = ggx_to_hg(alpha) as f32;
                    s.push(let_(
                        &format!("{p}cos_below"),
                        Ty::F32,
                        func("tm_refracted_cosine", vec![name("cos_in"), f(eta as f32)]),
                    ));
                    let albedo = if (eta - 1.0).abs() < NEARLY_INDEX_MATCHED {
                        f(0.0)
                    } else {
                        self.fgd(m, name("cos_in"), alpha, eta, 0.0)?
                    };
                    s.push(let_(&format!("{p}albedo"), Ty::F32, albedo));
                    if layer == 1 {
                        top_albedo = Some(v3(n("albedo")));
                    }
                    let (t_g, tp_g) = if alpha == 0.0 {
                        let g = f(ggx_to_hg(0.0) as f32);
                        (g.clone(), g)
                    } else {
                        (
                            func(
                                "tm_transmission_g",
                                vec![name("cos_in") / f(eta as f32) - n("cos_below"), n("cos_below"), f(alpha as f32)],
                            ),
                            func(
                                "tm_transmission_g",
                                vec![name("cos_in") - f(eta as f32) * n("cos_below"), name("cos_in"), f(alpha as f32)],
                            ),
                        )
                    };
                    // `tm2::transmission_asymmetries`.
                    s.extend([
                        var(&format!("{p}r"), Ty::F32, n("albedo")),
                        var(&format!("{p}t"), Ty::F32, f(1.0) - n("albedo")),
                        var(&format!("{p}rp"), Ty::F32, n("albedo")),
                        var(&format!("{p}tp"), Ty::F32, f(1.0) - n("albedo")),
                        let_(
                            &format!("{p}g_below"),
                            Ty::F32,
                            func("tm_hg_refract", vec![name("g_transmitted"), f((1.0 / eta) as f32)]) * t_g,
                        ),
                        let_(&format!("{p}g_reflected_below"), Ty::F32, n("g_below") * f(g_next as f32)),
                        let_(
                            &format!("{p}g_back_up"),
                            Ty::F32,
                            func("tm_hg_refract", vec![n("g_reflected_below"), f(eta as f32)]) * tp_g,
                        ),
                        let_(
                            &format!("{p}t_g"),
                            Ty::F32,
                            select(name("g_transmitted").ne(f(0.0)), n("g_below") / name("g_transmitted"), f(0.0)),
                        ),
                        let_(
                            &format!("{p}tp_g"),
                            Ty::F32,
                            select(n("g_reflected_below").ne(f(0.0)), n("g_back_up") / n("g_reflected_below"), f(0.0)),
                        ),
                    ]);
                    if eta < 1.0 {
                        let share =
                            self.tir(m, name("cos_in"), func("tm_hg_to_ggx", vec![name("g_transmitted")]), eta)?;
                        s.push(let_(&format!("{p}moved"), Ty::F32, share * n("t")));
                        s.push(assign(n("r"), n("r") + n("moved")));
                        s.push(assign(n("t"), n("t") - n("moved")));
                    } else if returns_light {
                        let share =
                            self.tir(m, n("cos_below"), func("tm_hg_to_ggx", vec![n("g_reflected_below")]), 1.0 / eta)?;
                        s.push(let_(&format!("{p}moved"), Ty::F32, share * n("tp")));
                        s.push(assign(n("rp"), n("rp") + n("moved")));
                        s.push(assign(n("tp"), n("tp") - n("moved")));
                    }
                    s.push(assign(
                        name("energy"),
                        func(
                            "tm_then_interface",
                            vec![name("energy"), v3(n("r")), v3(n("t")), v3(n("rp")), v3(n("tp"))],
                        ),
                    ));
                    s.push(assign(
                        name("asym"),
                        func(
                            "tm_then_interface",
                            vec![
                                name("asym"),
                                v3(n("r") * f(g_alpha)),
                                v3(n("t") * n("t_g")),
                                v3(n("rp") * f(g_alpha)),
                                v3(n("tp") * n("tp_g")),
                            ],
                        ),
                    ));
                    s.push(assign(name("g_transmitted"), n("g_below")));
                    s.push(assign(name("cos_in"), n("cos_below")));
                    (
                        name("energy").member("m21") / name("energy").member("m11"),
                        (name("asym").member("m21") / name("asym").member("m11")).member("x"),
                    )
                }
                Kind::Conductor { eta, kappa, alpha } => {
                    let channels: Vec<Expr> =
                        (0..3).map(|c| self.fgd(m, name("cos_in"), *alpha, eta[c], kappa[c])).collect::<Result<_>>()?;
                    let mut channels = channels.into_iter();
                    let (a, b, c) = (
                        channels.next().unwrap_or(f(0.0)),
                        channels.next().unwrap_or(f(0.0)),
                        channels.next().unwrap_or(f(0.0)),
                    );
                    s.push(let_(&format!("{p}base"), Ty::Vec(3), super::vec3(a, b, c)));
                    if layer == 1 {
                        top_albedo = Some(n("base"));
                    }
                    let g = f(ggx_to_hg(*alpha) as f32);
                    let e = name("energy");
                    let a = name("asym");
                    let over = |m: Expr, base: Expr| {
                        (m.clone().member("m21") + m.clone().member("m22") * base.clone())
                            / (m.clone().member("m11") + m.member("m12") * base)
                    };
                    (over(e, n("base")), over(a, v3(func("tm_average", vec![n("base")]) * g)).member("x"))
                }
            };
            // The lobe: the increment of the cumulative reflectance (`tm2::lobes`).
            let k = lobes;
            s.extend([
                let_(&format!("{p}r_total"), Ty::Vec(3), func("tm_finite_or3", vec![r_total, name("r_above")])),
                let_(&format!("{p}g_total"), Ty::F32, func("tm_finite_or", vec![g_total, name("g_above")])),
                let_(&format!("{p}energy"), Ty::Vec(3), n("r_total") - name("r_above")),
                let_(&format!("{p}mean"), Ty::F32, func("tm_average", vec![n("energy")])),
                let_(
                    &format!("{p}g"),
                    Ty::F32,
                    select(n("mean").gt(f(0.0)), ((n("g_total") - name("g_above")) / n("mean")).min(f(1.0)), f(0.0)),
                ),
                assign(name("r_above"), n("r_total")),
                assign(name("g_above"), n("g_total")),
                let_(&format!("{p}roughness"), Ty::F32, func("tm_hg_to_ggx", vec![n("g")])),
                assign(name("result").member("lobe_energy").index(k), n("energy")),
                assign(name("result").member("lobe_roughness").index(k), n("roughness")),
                assign(name("result").member("lobe_cos").index(k), name("mu")),
            ]);
            if layer != 1 {
                // Every lobe but the top one adds its energy times GD at its roughness.
                let gd = self.gd(m, name("mu"), n("roughness"))?;
                let e = n("energy");
                let has_energy = e
                    .clone()
                    .member("x")
                    .ne(f(0.0))
                    .op(super::Op::Or, e.clone().member("y").ne(f(0.0)))
                    .op(super::Op::Or, e.member("z").ne(f(0.0)));
                s.push(let_(&format!("{p}gd"), Ty::F32, select(has_energy, gd, f(0.0))));
                s.push(assign(name("result").member("lobe_gd").index(k), n("gd")));
                s.push(assign(
                    name("result").member("albedo"),
                    name("result").member("albedo") + n("energy") * v3(n("gd")),
                ));
            }
            lobes += 1;
            body.extend(s);
        }
        if let Some(top) = top_albedo {
            body.push(assign(name("result").member("top_albedo"), top));
            body.push(assign(
                name("result").member("albedo"),
                name("result").member("albedo") + name("result").member("top_albedo"),
            ));
        }
        body.push(Stmt::Return(name("result")));
        let function = super::Function {
            name: format!("tm_{}", identifier(&m.name)),
            params: vec![("mu_in".into(), Ty::F32)],
            returns: Ty::Named("TmResult".into()),
            body,
        };
        Ok((function, lobes))
    }
}

/// Channels as stored: DDS holds 1, 2 or 4.
fn padded(n: usize) -> usize {
    match n {
        0 | 1 => 1,
        2 => 2,
        _ => 4,
    }
}

/// A shader identifier from a material name: letters, digits and `_`.
pub fn identifier(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect()
}

/// The manifest's texture coordinate of `x` along `axis` as [`crate::model::folder::texture_coordinate_f32`]
/// computes it: the mapping in f32, its ends folded to f32 constants here, then the half-texel
/// correction of a node-aligned axis.
fn coordinate(axis: &Axis, x: Expr) -> Expr {
    let m0 = axis.mapping.forward_f32(axis.start as f32);
    let m1 = axis.mapping.forward_f32(axis.end as f32);
    let mapped = match axis.mapping {
        Mapping::Identity => x,
        Mapping::Sqrt => x.max(f(0.0)).sqrt(),
        Mapping::SqrtOneMinus => (f(1.0) - x).max(f(0.0)).sqrt(),
        Mapping::SqrtEnds => {
            let x = x.clamp(f(0.0), f(1.0));
            f(0.5) * (x.clone().sqrt() - (f(1.0) - x).sqrt() + f(1.0))
        }
        // Refused before: slices and GD are never spaced in asinh.
        Mapping::Asinh { .. } => x,
    };
    let u = (mapped - f(m0)) / f(m1 - m0);
    let n = axis.count as f32;
    match axis.placement {
        Placement::NodeAligned => (u * f(n - 1.0) + f(0.5)) / f(n),
        Placement::CellCentred => u,
    }
}

/// The helper functions every scene shader shares.
fn helpers(module: &mut Module) {
    let (x, g, eta, t) = (name("x"), name("g"), name("eta"), name("t"));
    let matrix = Ty::Named("TmMatrix".into());
    module.push(Item::Struct {
        name: "TmMatrix".into(),
        fields: ["m11", "m12", "m21", "m22"].iter().map(|n| (n.to_string(), Ty::Vec(3))).collect(),
    });
    module.comment("Henyey-Greenstein asymmetry of a GGX lobe of roughness alpha (tm.h, hg_from_ggx).");
    module.function(
        "tm_ggx_to_hg",
        vec![("alpha", Ty::F32)],
        Ty::F32,
        vec![
            let_("a", Ty::F32, name("alpha").clamp(f(0.0), f(1.0))),
            Stmt::Return(
                (f(-0.085) + f(1.085) / (f(1.0) + func("pow", vec![name("a") / f(0.5), f(1.3)]))).clamp(f(0.0), f(1.0)),
            ),
        ],
    );
    module.comment("GGX roughness of an HG lobe: the inverse, g clamped to [0.2, 1], alpha to [1e-4, 1].");
    module.function(
        "tm_hg_to_ggx",
        vec![("g_in", Ty::F32)],
        Ty::F32,
        vec![
            let_("g", Ty::F32, name("g_in").clamp(f(0.2), f(1.0))),
            let_("base", Ty::F32, (f(1.085) / (g.clone() + f(0.085)) - f(1.0)).max(f(0.0))),
            Stmt::Return((f(0.5) * func("pow", vec![name("base"), f((1.0 / 1.3) as f32)])).clamp(f(1e-4), f(1.0))),
        ],
    );
    module.comment("Asymmetry of a lobe refracted into relative index eta (tm.h, hg_refract).");
    module.function(
        "tm_hg_refract",
        vec![("g", Ty::F32), ("eta", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return(
            (f(1.0) - (f(1.0) - g.clone() * g) * func("pow", vec![eta.clone(), f(0.75)]))
                .max(f(0.0))
                .sqrt()
                .min(f(1.0)),
        )],
    );
    module.comment("Snell's law on cosines; 0 where the direction is totally reflected.");
    module.function(
        "tm_refracted_cosine",
        vec![("c", Ty::F32), ("eta", Ty::F32)],
        Ty::F32,
        vec![
            let_("sin2_in", Ty::F32, (f(1.0) - name("c")) * (f(1.0) + name("c"))),
            let_("cos2", Ty::F32, f(1.0) - name("sin2_in") / (eta.clone() * eta)),
            Stmt::Return(select(name("cos2").gt(f(0.0)), name("cos2").max(f(0.0)).sqrt(), f(0.0))),
        ],
    );
    module.comment(
        "Asymmetry of a transmission lobe whose roughness the refraction scales by |n / d| (tm.h:\n\
         hg_from_ggx(0.5 s alpha), the ratio taken whole in abs); a mean direction at the horizon\n\
         (d = 0) gives the roughest lobe.",
    );
    module.function(
        "tm_transmission_g",
        vec![("n", Ty::F32), ("d", Ty::F32), ("alpha", Ty::F32)],
        Ty::F32,
        vec![
            let_("scale", Ty::F32, (name("n") / select(name("d").ne(f(0.0)), name("d"), f(1.0))).abs()),
            Stmt::Return(select(
                name("d").ne(f(0.0)),
                func("tm_ggx_to_hg", vec![f(0.5) * name("scale") * name("alpha")]),
                func("tm_ggx_to_hg", vec![f(1.0)]),
            )),
        ],
    );
    module.function(
        "tm_average",
        vec![("v", Ty::Vec(3))],
        Ty::F32,
        vec![Stmt::Return((name("v").member("x") + name("v").member("y") + name("v").member("z")) / f(3.0))],
    );
    module.comment("x where it is finite (a comparison: false for NaN and infinities), else the fallback.");
    module.function(
        "tm_finite_or",
        vec![("x", Ty::F32), ("fallback", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return(select(x.abs().le(f(f32::MAX)), name("x"), name("fallback")))],
    );
    let lane = |c: &str| func("tm_finite_or", vec![name("v").member(c), name("fallback").member(c)]);
    module.function(
        "tm_finite_or3",
        vec![("v", Ty::Vec(3)), ("fallback", Ty::Vec(3))],
        Ty::Vec(3),
        vec![Stmt::Return(super::vec3(lane("x"), lane("y"), lane("z")))],
    );
    module.function(
        "tm_identity",
        vec![],
        matrix.clone(),
        vec![
            Stmt::Var { name: "m".into(), ty: matrix.clone(), value: None },
            assign(name("m").member("m11"), v3(f(1.0))),
            assign(name("m").member("m22"), v3(f(1.0))),
            Stmt::Return(name("m")),
        ],
    );
    module.comment(
        "m divided by its largest entry per channel: the reflectances are ratios of entries, so the\n\
         scale is free, and removing it keeps a product of many attenuating layers finite.",
    );
    let abs = |e: &str| name("m").member(e).abs();
    module.function(
        "tm_normalised",
        vec![("m", matrix.clone())],
        matrix.clone(),
        vec![
            let_("largest", Ty::Vec(3), abs("m11").max(abs("m12")).max(abs("m21").max(abs("m22")))),
            let_("s", Ty::Vec(3), name("largest").max(v3(f(1e-30)))),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), name("m").member("m11") / name("s")),
            assign(name("o").member("m12"), name("m").member("m12") / name("s")),
            assign(name("o").member("m21"), name("m").member("m21") / name("s")),
            assign(name("o").member("m22"), name("m").member("m22") / name("s")),
            Stmt::Return(name("o")),
        ],
    );
    module.comment(
        "m times the transfer matrix of an interface, (1 / t) [[1, -rp], [r, t tp - r rp]], with t\n\
         floored so that a total reflection (t = 0) gives the limit where nothing crosses.",
    );
    let e = |a: &str, b: &str| name("m").member(a) * name(b);
    module.function(
        "tm_then_interface",
        vec![("m", matrix.clone()), ("r", Ty::Vec(3)), ("t", Ty::Vec(3)), ("rp", Ty::Vec(3)), ("tp", Ty::Vec(3))],
        matrix.clone(),
        vec![
            let_("inverse", Ty::Vec(3), v3(f(1.0)) / t.clone().max(v3(f(SMALLEST_TRANSMISSION_F32)))),
            let_("e11", Ty::Vec(3), name("inverse")),
            let_("e12", Ty::Vec(3), -name("rp") * name("inverse")),
            let_("e21", Ty::Vec(3), name("r") * name("inverse")),
            let_("e22", Ty::Vec(3), (t * name("tp") - name("r") * name("rp")) * name("inverse")),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), e("m11", "e11") + e("m12", "e21")),
            assign(name("o").member("m12"), e("m11", "e12") + e("m12", "e22")),
            assign(name("o").member("m21"), e("m21", "e11") + e("m22", "e21")),
            assign(name("o").member("m22"), e("m21", "e12") + e("m22", "e22")),
            Stmt::Return(func("tm_normalised", vec![name("o")])),
        ],
    );
    module.comment("m times a medium that only attenuates, by t each way: diag(1 / t, t).");
    module.function(
        "tm_attenuate",
        vec![("m", matrix.clone()), ("t", Ty::Vec(3))],
        matrix.clone(),
        vec![
            let_("inverse", Ty::Vec(3), v3(f(1.0)) / name("t").max(v3(f(SMALLEST_TRANSMISSION_F32)))),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), name("m").member("m11") * name("inverse")),
            assign(name("o").member("m12"), name("m").member("m12") * name("t")),
            assign(name("o").member("m21"), name("m").member("m21") * name("inverse")),
            assign(name("o").member("m22"), name("m").member("m22") * name("t")),
            Stmt::Return(func("tm_normalised", vec![name("o")])),
        ],
    );
    module.comment(
        "Channel c of a 2D table at texture coordinates (u, v), filtered by hand: clamp addressing,\n\
         cell-centred texels, weights in f32 (what the sampler computes, without its 8-bit weights).",
    );
    let taps = |c: &str, n: &str| -> Vec<Stmt> {
        let a = format!("a{c}");
        vec![
            let_(&a, Ty::F32, name(c) * name(n) - f(0.5)),
            let_(&format!("i{c}"), Ty::F32, name(&a).floor()),
            let_(&format!("f{c}"), Ty::F32, name(&a) - name(&format!("i{c}"))),
            let_(
                &format!("{c}0"),
                Ty::I32,
                Expr::Construct(Ty::I32, vec![name(&format!("i{c}")).clamp(f(0.0), name(n) - f(1.0))]),
            ),
            let_(
                &format!("{c}1"),
                Ty::I32,
                Expr::Construct(Ty::I32, vec![(name(&format!("i{c}")) + f(1.0)).clamp(f(0.0), name(n) - f(1.0))]),
            ),
        ]
    };
    let load = |x: &str, y: &str| Expr::Load {
        texture: "tex".into(),
        scalar_texture: false,
        coordinates: vec![name(x), name(y)],
        swizzle: "xyzw",
    };
    let lerp = |a: Expr, b: Expr, w: &str| (v4(f(1.0)) - v4(name(w))) * a + v4(name(w)) * b;
    let mut body = taps("u", "width");
    body.extend(taps("v", "height"));
    body.push(let_("row0", Ty::Vec(4), lerp(load("u0", "v0"), load("u1", "v0"), "fu")));
    body.push(let_("row1", Ty::Vec(4), lerp(load("u0", "v1"), load("u1", "v1"), "fu")));
    body.push(Stmt::Return(lerp(name("row0"), name("row1"), "fv")));
    module.function(
        "tm_bilinear",
        vec![
            ("tex", Ty::Texture { dims: 2, scalar: false }),
            ("u", Ty::F32),
            ("v", Ty::F32),
            ("width", Ty::F32),
            ("height", Ty::F32),
        ],
        Ty::Vec(4),
        body,
    );
}

/// The f32 floor of a transmission in `1 / t`: [`SMALLEST_TRANSMISSION`] is below the f32 range;
/// this keeps `1 / t` at most 1e30, so that a product with an entry of at most 1 stays finite.
pub const SMALLEST_TRANSMISSION_F32: f32 = 1e-30;
const _: () = assert!(SMALLEST_TRANSMISSION < SMALLEST_TRANSMISSION_F32 as f64);

fn v4(e: Expr) -> Expr {
    Expr::Construct(Ty::Vec(4), vec![e])
}

/// Print `shader` in both languages.
pub fn texts(shader: &SceneShader) -> [(Lang, String); 2] {
    [Lang::Hlsl, Lang::Wgsl].map(|lang| (lang, shader.module.print(lang)))
}
