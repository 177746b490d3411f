//! Reading a scene file: the TOML of the module docs of [`super`] read by serde into raw structs
//! (which refuse an unknown key or a value of the wrong type), then the values checked, every error
//! naming the material and layer it is about.

use std::path::Path;

use serde::Deserialize;
use serde::de::{DeserializeOwned, Deserializer};

use super::{
    AlbedoPath, DEFAULT_MARGIN_NODES, FluxModel, Interval, Medium, Rgb, Scene, SceneInterface, SceneLayer,
    SceneMaterial, TirPath,
};
use crate::error::{Error, Result};
use crate::fit::forms::fitted::FittedFormExt;
use crate::fit::forms::{FittedForm, fitted};
use crate::table::TableKind;

impl Scene {
    /// Read a scene file; returns the scene and the file's text (which a build records).
    pub fn read(path: &Path) -> Result<(Self, String)> {
        let text = crate::formats::read_text_at_most(path, crate::formats::MAX_TEXT_INPUT_BYTES, "a scene file")?;
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
        let dir = path.parent().unwrap_or(Path::new(""));
        let scene = Self::from_toml_in(&text, &path.display().to_string(), &stem, dir)?;
        Ok((scene, text))
    }

    /// Parse a scene; `origin` names it in errors, `default_name` is its name when it gives none.
    /// A `tir = "fit:PATH"` is read relative to the working directory.
    pub fn from_toml(text: &str, origin: &str, default_name: &str) -> Result<Self> {
        Self::from_toml_in(text, origin, default_name, Path::new(""))
    }

    /// [`Scene::from_toml`] with `tir = "fit:PATH"` read relative to `dir` (the scene file's folder).
    pub fn from_toml_in(text: &str, origin: &str, default_name: &str, dir: &Path) -> Result<Self> {
        // Read from a TOML table rather than from the text: toml's errors then name the keys they
        // are under (which `reason` puts first) in place of an excerpt of the source, as the
        // material and layer an error is in are named.
        let document: toml::Table =
            text.parse().map_err(|e: toml::de::Error| Error::invalid(origin, crate::config::clean_toml_error(&e)))?;
        let raw =
            RawScene::deserialize(toml::Value::Table(document)).map_err(|e| Error::invalid(origin, reason(&e)))?;
        parse_scene(raw, origin, default_name, dir)
    }
}

/// A scene file as written. `model`, `albedo`, `tir` and `margin_nodes` are read with the values
/// (`"fit:PATH"` names a file), so that a value of any kind refused names the values allowed.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: Option<String>,
    model: Option<toml::Value>,
    albedo: Option<toml::Value>,
    tir: Option<toml::Value>,
    /// Nodes of the full grid kept beyond each needed sub-range.
    margin_nodes: Option<toml::Value>,
    #[serde(default, deserialize_with = "materials")]
    material: Vec<Item<RawMaterial>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table ([[material]])")]
struct RawMaterial {
    name: Option<String>,
    #[serde(default, deserialize_with = "layers")]
    layer: Vec<Item<RawLayer>>,
    /// Each in place of the scene's own.
    model: Option<toml::Value>,
    albedo: Option<toml::Value>,
    tir: Option<toml::Value>,
}

#[derive(Deserialize)]
#[serde(
    tag = "type",
    rename_all = "lowercase",
    expecting = "a table ([[material.layer]]) with type = \"interface\" or \"medium\""
)]
enum RawLayer {
    Interface(Item<RawInterface>),
    Medium(Item<RawMedium>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInterface {
    eta: Option<Numbers>,
    kappa: Option<Numbers>,
    #[serde(default, deserialize_with = "number")]
    alpha: Option<f64>,
    #[serde(default)]
    vary: RawVary,
}

/// The ranges a texture varies an interface's parameters over.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table, e.g. vary = { alpha = [0.1, 0.4] }")]
struct RawVary {
    eta: Option<Numbers>,
    kappa: Option<Numbers>,
    alpha: Option<Numbers>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMedium {
    sigma_s: Option<Numbers>,
    sigma_k: Option<Numbers>,
    #[serde(default, deserialize_with = "number")]
    depth: Option<f64>,
    #[serde(default, deserialize_with = "number")]
    g: Option<f64>,
}

/// One number or an array of them, as written: how many a key takes (`[r, g, b]`, a range
/// `[lo, hi]`) is checked with the values, naming the key's own form.
enum Numbers {
    One(f64),
    Many(Vec<f64>),
}

impl<'de> Deserialize<'de> for Numbers {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        match toml::Value::deserialize(deserializer)? {
            toml::Value::Array(items) => {
                items.into_iter().map(number_in).collect::<std::result::Result<_, _>>().map(Numbers::Many)
            }
            value @ (toml::Value::Float(_) | toml::Value::Integer(_)) => number_in(value).map(Numbers::One),
            other => Err(serde::de::Error::custom(format!("{other}; must be a number or an array of numbers"))),
        }
    }
}

/// A number: TOML writes `1` and `1.0` apart, a scene means the same by both.
fn number_in<E: serde::de::Error>(value: toml::Value) -> std::result::Result<f64, E> {
    match value {
        toml::Value::Float(x) => Ok(x),
        toml::Value::Integer(n) => Ok(n as f64),
        other => Err(E::custom(format!("{other}; must be a number"))),
    }
}

/// An optional number, for `#[serde(deserialize_with)]`: refused as the scene's other numbers are.
fn number<'de, D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Option<f64>, D::Error> {
    number_in(toml::Value::deserialize(deserializer)?).map(Some)
}

impl std::fmt::Display for Numbers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Numbers::One(x) => f.write_str(&number_text(*x)),
            Numbers::Many(xs) => write!(f, "[{}]", xs.iter().map(|x| number_text(*x)).collect::<Vec<_>>().join(", ")),
        }
    }
}

/// `[[material]]`: an array of tables, said so where it is not.
fn materials<'de, D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Vec<Item<RawMaterial>>, D::Error> {
    array_of_tables(deserializer, "[[material]]")
}

/// `[[material.layer]]`: an array of tables, said so where it is not.
fn layers<'de, D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Vec<Item<RawLayer>>, D::Error> {
    array_of_tables(deserializer, "[[material.layer]]")
}

fn array_of_tables<'de, D: Deserializer<'de>, T: DeserializeOwned>(
    deserializer: D,
    header: &str,
) -> std::result::Result<Vec<Item<T>>, D::Error> {
    match toml::Value::deserialize(deserializer)? {
        value @ toml::Value::Array(_) => Vec::deserialize(value).map_err(serde::de::Error::custom),
        other => Err(serde::de::Error::custom(format!("{other}; must be an array of tables ({header})"))),
    }
}

/// A material or a layer read on its own: what serde refuses in it is kept and reported with
/// where it is (which material, which layer), which serde's message cannot say.
struct Item<T>(std::result::Result<T, String>);

impl<'de, T: DeserializeOwned> Deserialize<'de> for Item<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let value = toml::Value::deserialize(deserializer)?;
        Ok(Item(T::deserialize(value).map_err(|e| reason(&e))))
    }
}

impl<T> Item<T> {
    fn at(self, where_: &str) -> Result<T> {
        self.0.map_err(|reason| Error::invalid(where_, reason))
    }
}

/// What serde refused, after the keys it lies under (`vary.alpha: ...`). toml names them only in
/// its error's text, on a last line "in `KEYS`", where the error has no source excerpt.
fn reason(error: &toml::de::Error) -> String {
    let text = error.to_string();
    match text.lines().last().and_then(|l| l.strip_prefix("in `")).and_then(|l| l.strip_suffix('`')) {
        Some(keys) => format!("{keys}: {}", error.message()),
        None => error.message().to_string(),
    }
}

/// The scene-wide choices a material inherits unless it states its own.
#[derive(Clone)]
struct Paths<'a> {
    model: FluxModel,
    albedo: (AlbedoPath, Option<FittedForm>),
    tir: (TirPath, Option<FittedForm>),
    /// The scene file's folder, which `tir = "fit:PATH"` and `albedo = "fit:PATH"` are relative to.
    dir: &'a Path,
}

fn parse_scene(raw: RawScene, origin: &str, default_name: &str, dir: &Path) -> Result<Scene> {
    let name = raw.name.unwrap_or_else(|| default_name.to_string());
    check_name(&name, &format!("{origin}: name"), "scene")?;
    let defaults = Paths {
        model: raw.model.as_ref().map(|v| choice(v, origin)).transpose()?.unwrap_or(FluxModel::TwoFlux),
        albedo: albedo_choice(raw.albedo.as_ref(), origin, dir)?.unwrap_or((AlbedoPath::Fgd, None)),
        tir: tir_choice(raw.tir.as_ref(), origin, dir)?.unwrap_or((TirPath::Table, None)),
        dir,
    };
    let margin_nodes = match raw.margin_nodes {
        None => DEFAULT_MARGIN_NODES,
        Some(value) => match value.as_integer() {
            Some(n @ 0..=8) => n as usize,
            _ => return Err(Error::invalid(format!("{origin}: margin_nodes"), format!("{value}; allowed: 0 to 8"))),
        },
    };
    let materials = raw.material;
    if materials.is_empty() {
        return Err(Error::invalid(origin, "no [[material]]; a scene needs at least one material"));
    }
    if materials.len() > MAX_MATERIALS {
        return Err(Error::invalid(
            origin,
            format!("{} materials; allowed: at most {MAX_MATERIALS} in one scene", materials.len()),
        ));
    }
    let mut scene = Scene { name, materials: Vec::new(), margin_nodes, warnings: Vec::new() };
    // Each material's files (its slices, its furnace pictures) and shader function are named
    // after it, as `file_name_part` maps it: two names that map to one would overwrite each other's
    // files, or fail the build after `plan` passed them.
    let mut names: std::collections::HashMap<String, (usize, String)> = std::collections::HashMap::new();
    for (index, raw) in materials.into_iter().enumerate() {
        let where_ = format!("{origin}: material {}", index + 1);
        let material = parse_material(raw.at(&where_)?, &where_, index, &defaults, &mut scene.warnings)?;
        let part = file_name_part(&material.name);
        if let Some((other, other_name)) = names.get(&part) {
            let reason = if *other_name == material.name {
                format!("the name `{}` is used twice; names must differ", material.name)
            } else {
                format!(
                    "the name `{}` gives the files and shader function of material {} (`{other_name}`): both \
                     become `{part}` (names are lowercased, and every character but an ASCII letter or digit \
                     becomes `-`); names must differ in more than case and punctuation",
                    material.name,
                    other + 1
                )
            };
            return Err(Error::invalid(where_, reason));
        }
        names.insert(part, (index, material.name.clone()));
        scene.materials.push(material);
    }
    Ok(scene)
}

fn parse_material(
    raw: RawMaterial,
    where_: &str,
    index: usize,
    defaults: &Paths,
    warnings: &mut Vec<String>,
) -> Result<SceneMaterial> {
    let name = raw.name.unwrap_or_else(|| format!("material-{}", index + 1));
    check_name(&name, &format!("{where_}: name"), "material")?;
    let where_ = format!("{where_} (`{name}`)");
    let model = raw.model.as_ref().map(|v| choice(v, &where_)).transpose()?.unwrap_or(defaults.model);
    let (albedo, albedo_form) = match albedo_choice(raw.albedo.as_ref(), &where_, defaults.dir)? {
        Some(chosen) => chosen,
        None => defaults.albedo.clone(),
    };
    let (tir, tir_form) = match tir_choice(raw.tir.as_ref(), &where_, defaults.dir)? {
        Some(chosen) => chosen,
        None => defaults.tir.clone(),
    };
    let layers = raw.layer;
    if layers.is_empty() {
        return Err(Error::invalid(
            &where_,
            "has an empty layer stack; a material needs at least one interface ([[material.layer]] with type = \"interface\")",
        ));
    }
    if layers.len() > crate::model::MAX_LAYERS {
        return Err(Error::invalid(
            &where_,
            format!(
                "has {} layers; allowed: at most {} (the transfer-matrix model's limit)",
                layers.len(),
                crate::model::MAX_LAYERS
            ),
        ));
    }
    let mut parsed = Vec::new();
    for (k, raw) in layers.into_iter().enumerate() {
        let layer_where = format!("{where_}, layer {}", k + 1);
        parsed.push(parse_layer(raw, &layer_where)?);
    }
    if !parsed.iter().any(|l| matches!(l, SceneLayer::Interface(_))) {
        return Err(Error::invalid(&where_, "has no interface layer; a material needs at least one interface"));
    }
    if matches!(parsed[0], SceneLayer::Medium(_)) {
        return Err(Error::invalid(
            format!("{where_}, layer 1"),
            "is a medium; the top layer must be an interface (a medium lies below the interface above it)",
        ));
    }
    // The model stops at the first conductor: what lies below is never evaluated.
    if let Some(conductor) = parsed.iter().position(|l| matches!(l, SceneLayer::Interface(i) if i.is_conductor())) {
        let below = parsed.len() - conductor - 1;
        if below > 0 {
            warnings.push(format!(
                "{where_}: layer{} {} below the opaque conductor of layer {} (kappa > 0); the model never evaluates \
                 {}: ignored",
                if below > 1 { "s" } else { "" },
                ((conductor + 2)..=parsed.len()).map(|k| k.to_string()).collect::<Vec<_>>().join(", "),
                conductor + 1,
                if below > 1 { "them" } else { "it" },
            ));
        }
    }
    if model == FluxModel::TwoFlux {
        for (k, layer) in parsed.iter().enumerate() {
            if let SceneLayer::Medium(m) = layer
                && m.sigma_s.iter().any(|&s| s > 0.0)
            {
                warnings.push(format!(
                    "{where_}, layer {}: sigma_s > 0 but the material uses the 2-flux model, which does not scatter: \
                     sigma_s is ignored (model = \"6-flux\" evaluates it)",
                    k + 1
                ));
            }
        }
    }
    Ok(SceneMaterial { name, model, albedo, albedo_form, tir, tir_form, layers: parsed })
}

fn parse_layer(raw: Item<RawLayer>, where_: &str) -> Result<SceneLayer> {
    let raw = raw.0.map_err(|reason| {
        let reason = if reason == "missing field `type`" { "has no `type`".to_string() } else { reason };
        // serde names the types allowed only where `type` is a string that names none.
        let allowed = if reason.contains("interface") { "" } else { "; allowed: \"interface\", \"medium\"" };
        Error::invalid(where_, format!("{reason}{allowed}"))
    })?;
    match raw {
        RawLayer::Interface(raw) => {
            let raw = raw.at(where_)?;
            let vary = raw.vary;
            let (eta, eta_nominal) = rgb_or_range(raw.eta, vary.eta, "eta", None, where_, Bound::Index)?;
            let (kappa, kappa_nominal) =
                rgb_or_range(raw.kappa, vary.kappa, "kappa", Some(0.0), where_, Bound::Extinction)?;
            let (alpha, alpha_nominal) = scalar_or_range(raw.alpha, vary.alpha, "alpha", where_)?;
            let nominal = crate::model::Interface { eta: eta_nominal, kappa: kappa_nominal, alpha: alpha_nominal };
            Ok(SceneLayer::Interface(SceneInterface { eta, kappa, alpha, nominal }))
        }
        RawLayer::Medium(raw) => {
            let raw = raw.at(where_)?;
            let rgb = |value: Option<Numbers>, key: &str| match value {
                Some(value) => rgb_values(&value, &format!("{where_}: {key}"), Bound::NonNegative),
                None => Ok([0.0; 3]),
            };
            let sigma_s = rgb(raw.sigma_s, "sigma_s")?;
            let sigma_k = rgb(raw.sigma_k, "sigma_k")?;
            let Some(depth) = raw.depth else {
                return Err(Error::invalid(
                    where_,
                    "a medium without `depth`; give its thickness, a finite number > 0",
                ));
            };
            if !(depth.is_finite() && depth > 0.0 && shader_holds(depth)) {
                return Err(Error::invalid(
                    format!("{where_}: depth"),
                    format!(
                        "{}; allowed: a finite number from {MIN_MAGNITUDE:e} to {MAX_COEFFICIENT:e} (held in f32 by \
                         the shader)",
                        number_text(depth)
                    ),
                ));
            }
            let g = raw.g.unwrap_or(0.0);
            if !((-1.0..=1.0).contains(&g) && shader_holds(g)) {
                return Err(Error::invalid(
                    format!("{where_}: g"),
                    format!("{}; allowed: -1 to 1, 0 or at least {MIN_MAGNITUDE:e} in magnitude", number_text(g)),
                ));
            }
            Ok(SceneLayer::Medium(Medium { sigma_s, sigma_k, depth, g }))
        }
    }
}

/// The longest scene or material name, in characters. Names become parts of file names (a
/// material's slices `fgd_<material>_l<layer>_<direction>.ktx2`, its furnace pictures, the scene's
/// `<scene>.shader.json` and furnace folder) that must stay under the 255 bytes a file name may
/// have with room for the rest; 300-character names passed `plan` and failed the build.
pub const MAX_NAME_CHARS: usize = 64;

/// Refuse a scene or material name that cannot name files: empty (a scene named `""` wrote into
/// the output folder itself), or longer than [`MAX_NAME_CHARS`].
fn check_name(name: &str, key: &str, what: &str) -> Result<()> {
    if name.is_empty() {
        return Err(Error::invalid(key, format!("is empty; a {what} needs a name (it names files)")));
    }
    let chars = name.chars().count();
    if chars > MAX_NAME_CHARS {
        return Err(Error::invalid(
            key,
            format!(
                "`{}...` is {chars} characters long; allowed: 1 to {MAX_NAME_CHARS} (the name becomes part of file \
                 names)",
                name.chars().take(16).collect::<String>()
            ),
        ));
    }
    Ok(())
}

/// A name as it appears in file names and shader identifiers: lowercased, every character but an
/// ASCII letter or digit a `-`. The scene's files map names the same way (`plan`'s slice names and
/// the furnace's file names keep `-`, the shader's identifiers write `_` for it), so two names
/// that give one part give one file.
pub fn file_name_part(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' }).collect()
}

/// The smallest real index an interface's medium may have: below every real medium (silver's is
/// about 0.05 in the visible), and above 0, where relative indices grow without bound.
pub const MIN_INDEX: f64 = 0.01;
/// The largest real index or extinction index: far above every real medium in the visible (about 4
/// for the real part, 11 for aluminium's extinction) and far beyond what a table covers (4 by
/// default), so that a value past it is a slip, not a material.
pub const MAX_INDEX: f64 = 100.0;
/// The most materials a scene holds.
pub const MAX_MATERIALS: usize = 256;

/// The smallest magnitude of a value other than 0: the scene's shader holds every value, and the
/// constants folded from them (a medium's path limit `45 / sigma`, its backward scattering
/// `sigma_s` times a share), in f32, whose normal numbers end at 1.2e-38. A kappa of 5e-324 was a
/// conductor to the planner and 0 to the shader; 1e-40 folded to an infinite path limit.
pub const MIN_MAGNITUDE: f64 = 1e-30;
/// The largest medium coefficient (`sigma_s`, `sigma_k`) or depth: f32 ends at 3.4e38, and the
/// constants folded from coefficients (their sums, `sqrt` of their products) must stay inside it.
pub const MAX_COEFFICIENT: f64 = 1e30;

/// Whether the scene's shader holds `x` as the value it is: 0, or a magnitude in
/// [`MIN_MAGNITUDE`, `MAX_COEFFICIENT`].
fn shader_holds(x: f64) -> bool {
    x == 0.0 || (MIN_MAGNITUDE..=MAX_COEFFICIENT).contains(&x.abs())
}

/// What values a parameter admits.
#[derive(Clone, Copy)]
enum Bound {
    /// A real index of refraction.
    Index,
    /// An extinction index.
    Extinction,
    NonNegative,
    Unit,
}

impl Bound {
    fn admits(self, x: f64) -> bool {
        x.is_finite()
            && match self {
                Bound::Index => (MIN_INDEX..=MAX_INDEX).contains(&x),
                Bound::Extinction => (0.0..=MAX_INDEX).contains(&x) && shader_holds(x),
                Bound::NonNegative => (0.0..=MAX_COEFFICIENT).contains(&x) && shader_holds(x),
                Bound::Unit => (0.0..=1.0).contains(&x) && shader_holds(x),
            }
    }

    fn allowed(self) -> String {
        match self {
            Bound::Index => format!("{MIN_INDEX} to {MAX_INDEX} (a real medium's index)"),
            Bound::Extinction => format!("0, or {MIN_MAGNITUDE:e} to {MAX_INDEX} (a real medium's extinction index)"),
            Bound::NonNegative => format!("0, or {MIN_MAGNITUDE:e} to {MAX_COEFFICIENT:e} (held in f32 by the shader)"),
            Bound::Unit => format!("0, or {MIN_MAGNITUDE:e} to 1"),
        }
    }
}

/// A kebab-case choice of a material, read through its serde names: its key and the values it
/// allows, as its error states them.
trait Choice: DeserializeOwned {
    const KEY: &'static str;
    const ALLOWED: &'static str;
}

impl Choice for FluxModel {
    const KEY: &'static str = "model";
    const ALLOWED: &'static str = "\"2-flux\", \"6-flux\"";
}

impl Choice for AlbedoPath {
    const KEY: &'static str = "albedo";
    const ALLOWED: &'static str = "\"fgd\", \"belcour\", \"karis\", \"fit:PATH\"";
}

impl Choice for TirPath {
    const KEY: &'static str = "tir";
    const ALLOWED: &'static str = "\"table\", \"fit\", \"off\", \"fit:PATH\"";
}

fn choice<T: Choice>(value: &toml::Value, where_: &str) -> Result<T> {
    T::deserialize(value.clone())
        .map_err(|_| Error::invalid(format!("{where_}: {}", T::KEY), format!("{value}; allowed: {}", T::ALLOWED)))
}

/// The fitted form `key = "fit:PATH"` names (PATH read relative to `dir`), fitted to one of
/// `tables`; `None` where `value` is not written `fit:...`.
fn named_form(value: &toml::Value, key: &str, where_: &str, dir: &Path, tables: &[&str]) -> Result<Option<FittedForm>> {
    let Some(path) = value.as_str().and_then(|v| v.strip_prefix("fit:")) else {
        return Ok(None);
    };
    let key = format!("{where_}: {key}");
    if path.is_empty() {
        return Err(Error::invalid(key, format!("\"fit:\" names no form; allowed: {}", fitted::ALLOWED)));
    }
    let form = FittedForm::read(&dir.join(path), path, tables).map_err(|e| Error::invalid(key, e.to_string()))?;
    Ok(Some(form))
}

/// `tir`: a path, or `fit:PATH` with the fitted form it names (read relative to `dir`).
fn tir_choice(value: Option<&toml::Value>, where_: &str, dir: &Path) -> Result<Option<(TirPath, Option<FittedForm>)>> {
    let Some(value) = value else { return Ok(None) };
    if let Some(form) = named_form(value, "tir", where_, dir, fitted::TIR_TABLES)? {
        return Ok(Some((TirPath::Form, Some(form))));
    }
    match choice(value, where_)? {
        // The path of a named form is only ever written `fit:PATH`.
        TirPath::Form => Err(Error::invalid(
            format!("{where_}: tir"),
            format!("\"form\" names no form; allowed: \"table\", \"fit\", \"off\", {}", fitted::ALLOWED),
        )),
        path => Ok(Some((path, None))),
    }
}

/// `albedo`: a path, or `fit:PATH` with the fitted form it names (read relative to `dir`), whose
/// table sets the path: a form fitted to `karis` is read on the Karis path (its channels weighed by
/// the interface's F0), one fitted to `fgd` on the FGD path.
fn albedo_choice(
    value: Option<&toml::Value>,
    where_: &str,
    dir: &Path,
) -> Result<Option<(AlbedoPath, Option<FittedForm>)>> {
    let Some(value) = value else { return Ok(None) };
    if let Some(form) = named_form(value, "albedo", where_, dir, fitted::ALBEDO_TABLES)? {
        let path = match TableKind::named(&form.table) {
            Some(TableKind::Karis) => AlbedoPath::Karis,
            Some(TableKind::Fgd) => AlbedoPath::Fgd,
            _ => {
                let allowed = fitted::ALBEDO_TABLES.join(", ");
                let reason = format!("a form fitted to `{}` reads on no albedo path; allowed: {allowed}", form.table);
                return Err(Error::invalid(format!("{where_}: albedo"), reason));
            }
        };
        return Ok(Some((path, Some(form))));
    }
    Ok(Some((choice(value, where_)?, None)))
}

/// A number as a person wrote it: `1e20` rather than its 21 digits.
fn number_text(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) { format!("{x:e}") } else { format!("{x}") }
}

/// One number for all channels, or `[r, g, b]`, each admitted by `bound`.
fn rgb_values(value: &Numbers, key: &str, bound: Bound) -> Result<Rgb<f64>> {
    let values = match value {
        Numbers::One(x) => [*x; 3],
        Numbers::Many(xs) => <Rgb<f64>>::try_from(xs.as_slice())
            .map_err(|_| Error::invalid(key, format!("has {} values; give one number or [r, g, b]", xs.len())))?,
    };
    if let Some(bad) = values.iter().find(|x| !bound.admits(**x)) {
        return Err(Error::invalid(key, format!("{}; allowed: {}", number_text(*bad), bound.allowed())));
    }
    Ok(values)
}

/// A `vary` range `[lo, hi]`, admitted by `bound`.
fn range(value: Option<Numbers>, key: &str, where_: &str, bound: Bound) -> Result<Option<Interval>> {
    let Some(value) = value else { return Ok(None) };
    let key = format!("{where_}: vary.{key}");
    let (lo, hi) = match &value {
        Numbers::Many(xs) if xs.len() == 2 => (xs[0], xs[1]),
        _ => return Err(Error::invalid(&key, format!("{value}; give a range [lo, hi]"))),
    };
    for x in [lo, hi] {
        if !bound.admits(x) {
            return Err(Error::invalid(&key, format!("{}; allowed: {}", number_text(x), bound.allowed())));
        }
    }
    if lo > hi {
        return Err(Error::invalid(&key, format!("[{lo}, {hi}] is inverted; allowed: lo <= hi")));
    }
    Ok(Some(Interval::new(lo, hi)))
}

/// An RGB parameter, or the range a texture varies it over (the same for every channel), with its
/// nominal value: the one given beside the range (which must lie inside it), or the range's middle.
fn rgb_or_range(
    given: Option<Numbers>,
    vary: Option<Numbers>,
    key: &str,
    default: Option<f64>,
    where_: &str,
    bound: Bound,
) -> Result<(Rgb<Interval>, Rgb<f64>)> {
    let given = given.map(|value| rgb_values(&value, &format!("{where_}: {key}"), bound)).transpose()?;
    if let Some(range) = range(vary, key, where_, bound)? {
        let nominal = match given {
            Some(values) => {
                nominal_inside(&values, range, key, where_)?;
                values
            }
            None => [0.5 * (range.lo + range.hi); 3],
        };
        return Ok(([range; 3], nominal));
    }
    match (given, default) {
        (Some(values), _) => Ok((values.map(Interval::point), values)),
        (None, Some(default)) => Ok(([Interval::point(default); 3], [default; 3])),
        (None, None) => Err(Error::invalid(
            where_,
            format!(
                "an interface without `{key}`; give one number or [r, g, b] ({}), or vary.{key} = [lo, hi]",
                bound.allowed()
            ),
        )),
    }
}

/// Refuse a nominal value outside the `vary` range given beside it.
fn nominal_inside(values: &[f64], range: Interval, key: &str, where_: &str) -> Result<()> {
    match values.iter().find(|&&v| v < range.lo || v > range.hi) {
        Some(bad) => Err(Error::invalid(
            format!("{where_}: {key}"),
            format!(
                "{bad} lies outside vary.{key} = [{}, {}]; the value evaluated must lie in the range a texture varies",
                range.lo, range.hi
            ),
        )),
        None => Ok(()),
    }
}

/// A scalar parameter in [0, 1] (roughness), or the range a texture varies it over, with its nominal
/// value as in [`rgb_or_range`].
fn scalar_or_range(given: Option<f64>, vary: Option<Numbers>, key: &str, where_: &str) -> Result<(Interval, f64)> {
    if let Some(x) = given
        && !Bound::Unit.admits(x)
    {
        return Err(Error::invalid(
            format!("{where_}: {key}"),
            format!("{}; allowed: {}", number_text(x), Bound::Unit.allowed()),
        ));
    }
    if let Some(range) = range(vary, key, where_, Bound::Unit)? {
        let nominal = match given {
            Some(x) => {
                nominal_inside(&[x], range, key, where_)?;
                x
            }
            None => 0.5 * (range.lo + range.hi),
        };
        return Ok((range, nominal));
    }
    match given {
        Some(x) => Ok((Interval::point(x), x)),
        None => Err(Error::invalid(
            where_,
            format!("an interface without `{key}`; give a number from 0 to 1, or vary.{key} = [lo, hi]"),
        )),
    }
}
