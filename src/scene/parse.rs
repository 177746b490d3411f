//! Reading a scene file: the TOML of the module docs of [`super`], checked key by key, every error
//! naming the material and layer it is about.

use std::path::Path;

use super::{
    AlbedoPath, DEFAULT_MARGIN_NODES, FluxModel, Interface, Interval, Layer, Material, Medium, Rgb, Scene, TirPath,
};
use crate::error::{Error, Result};
use crate::fit::text::fitted::FittedFormExt;
use crate::fit::text::{FittedForm, fitted};

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
        let document: toml::Table =
            text.parse().map_err(|e: toml::de::Error| Error::invalid(origin, crate::config::clean_toml_error(&e)))?;
        parse_scene(&document, origin, default_name, dir)
    }
}

const SCENE_KEYS: &[&str] = &["name", "model", "albedo", "tir", "margin_nodes", "material"];
const MATERIAL_KEYS: &[&str] = &["name", "model", "albedo", "tir", "layer"];
const INTERFACE_KEYS: &[&str] = &["type", "eta", "kappa", "alpha", "vary"];
const INTERFACE_VARY_KEYS: &[&str] = &["eta", "kappa", "alpha"];
const MEDIUM_KEYS: &[&str] = &["type", "sigma_s", "sigma_k", "depth", "g"];

/// The scene-wide choices a material inherits unless it states its own.
#[derive(Clone)]
struct Paths<'a> {
    model: FluxModel,
    albedo: (AlbedoPath, Option<FittedForm>),
    tir: (TirPath, Option<FittedForm>),
    /// The scene file's folder, which `tir = "fit:PATH"` and `albedo = "fit:PATH"` are relative to.
    dir: &'a Path,
}

fn parse_scene(document: &toml::Table, origin: &str, default_name: &str, dir: &Path) -> Result<Scene> {
    check_keys(document, SCENE_KEYS, origin)?;
    let name = match document.get("name") {
        Some(value) => string(value, &format!("{origin}: name"))?.to_string(),
        None => default_name.to_string(),
    };
    check_name(&name, &format!("{origin}: name"), "scene")?;
    let defaults = Paths {
        model: choice(document, "model", origin)?.unwrap_or(FluxModel::TwoFlux),
        albedo: albedo_choice(document, origin, dir)?.unwrap_or((AlbedoPath::Fgd, None)),
        tir: tir_choice(document, origin, dir)?.unwrap_or((TirPath::Table, None)),
        dir,
    };
    let margin_nodes = match document.get("margin_nodes") {
        None => DEFAULT_MARGIN_NODES,
        Some(value) => match value.as_integer() {
            Some(n @ 0..=8) => n as usize,
            _ => return Err(Error::invalid(format!("{origin}: margin_nodes"), format!("{value}; allowed: 0 to 8"))),
        },
    };
    let Some(materials) = document.get("material") else {
        return Err(Error::invalid(origin, "no [[material]]; a scene needs at least one material"));
    };
    let Some(materials) = materials.as_array() else {
        return Err(Error::invalid(format!("{origin}: material"), "must be an array of tables ([[material]])"));
    };
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
    for (index, value) in materials.iter().enumerate() {
        let where_ = format!("{origin}: material {}", index + 1);
        let table = value.as_table().ok_or_else(|| Error::invalid(&where_, "must be a table ([[material]])"))?;
        let material = parse_material(table, &where_, index, &defaults, &mut scene.warnings)?;
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
    table: &toml::Table,
    where_: &str,
    index: usize,
    defaults: &Paths,
    warnings: &mut Vec<String>,
) -> Result<Material> {
    check_keys(table, MATERIAL_KEYS, where_)?;
    let name = match table.get("name") {
        Some(value) => string(value, &format!("{where_}: name"))?.to_string(),
        None => format!("material-{}", index + 1),
    };
    check_name(&name, &format!("{where_}: name"), "material")?;
    let where_ = format!("{where_} (`{name}`)");
    let model = choice(table, "model", &where_)?.unwrap_or(defaults.model);
    let (albedo, albedo_form) = match albedo_choice(table, &where_, defaults.dir)? {
        Some(chosen) => chosen,
        None => defaults.albedo.clone(),
    };
    let (tir, tir_form) = match tir_choice(table, &where_, defaults.dir)? {
        Some(chosen) => chosen,
        None => defaults.tir.clone(),
    };
    let layers = match table.get("layer") {
        None => Vec::new(),
        Some(value) => value
            .as_array()
            .ok_or_else(|| {
                Error::invalid(format!("{where_}: layer"), "must be an array of tables ([[material.layer]])")
            })?
            .clone(),
    };
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
    for (k, value) in layers.iter().enumerate() {
        let layer_where = format!("{where_}, layer {}", k + 1);
        let table = value.as_table().ok_or_else(|| Error::invalid(&layer_where, "must be a table"))?;
        parsed.push(parse_layer(table, &layer_where)?);
    }
    if !parsed.iter().any(|l| matches!(l, Layer::Interface(_))) {
        return Err(Error::invalid(&where_, "has no interface layer; a material needs at least one interface"));
    }
    if matches!(parsed[0], Layer::Medium(_)) {
        return Err(Error::invalid(
            format!("{where_}, layer 1"),
            "is a medium; the top layer must be an interface (a medium lies below the interface above it)",
        ));
    }
    // The model stops at the first conductor: what lies below is never evaluated.
    if let Some(conductor) = parsed.iter().position(|l| matches!(l, Layer::Interface(i) if i.is_conductor())) {
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
            if let Layer::Medium(m) = layer
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
    Ok(Material { name, model, albedo, albedo_form, tir, tir_form, layers: parsed })
}

fn parse_layer(table: &toml::Table, where_: &str) -> Result<Layer> {
    let kind = match table.get("type") {
        Some(value) => string(value, &format!("{where_}: type"))?,
        None => return Err(Error::invalid(where_, "has no `type`; allowed: \"interface\", \"medium\"")),
    };
    match kind {
        "interface" => {
            check_keys(table, INTERFACE_KEYS, where_)?;
            let vary = match table.get("vary") {
                None => toml::Table::new(),
                Some(value) => {
                    let vary = value
                        .as_table()
                        .ok_or_else(|| {
                            Error::invalid(
                                format!("{where_}: vary"),
                                "must be a table, e.g. vary = { alpha = [0.1, 0.4] }",
                            )
                        })?
                        .clone();
                    check_keys(&vary, INTERFACE_VARY_KEYS, &format!("{where_}: vary"))?;
                    vary
                }
            };
            let (eta, eta_nominal) = rgb_or_range(table, &vary, "eta", None, where_, Bound::Index)?;
            let (kappa, kappa_nominal) = rgb_or_range(table, &vary, "kappa", Some(0.0), where_, Bound::Extinction)?;
            let (alpha, alpha_nominal) = scalar_or_range(table, &vary, "alpha", where_)?;
            let nominal = crate::model::Interface { eta: eta_nominal, kappa: kappa_nominal, alpha: alpha_nominal };
            Ok(Layer::Interface(Interface { eta, kappa, alpha, nominal }))
        }
        "medium" => {
            check_keys(table, MEDIUM_KEYS, where_)?;
            let sigma_s = rgb(table, "sigma_s", where_)?.unwrap_or([0.0; 3]);
            let sigma_k = rgb(table, "sigma_k", where_)?.unwrap_or([0.0; 3]);
            let Some(depth) = table.get("depth") else {
                return Err(Error::invalid(
                    where_,
                    "a medium without `depth`; give its thickness, a finite number > 0",
                ));
            };
            let depth = number(depth, &format!("{where_}: depth"))?;
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
            let g = match table.get("g") {
                None => 0.0,
                Some(value) => number(value, &format!("{where_}: g"))?,
            };
            if !((-1.0..=1.0).contains(&g) && shader_holds(g)) {
                return Err(Error::invalid(
                    format!("{where_}: g"),
                    format!("{}; allowed: -1 to 1, 0 or at least {MIN_MAGNITUDE:e} in magnitude", number_text(g)),
                ));
            }
            Ok(Layer::Medium(Medium { sigma_s, sigma_k, depth, g }))
        }
        other => {
            Err(Error::invalid(format!("{where_}: type"), format!("`{other}`; allowed: \"interface\", \"medium\"")))
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

fn check_keys(table: &toml::Table, allowed: &[&str], where_: &str) -> Result<()> {
    for key in table.keys() {
        if !allowed.contains(&key.as_str()) {
            return Err(Error::invalid(where_, format!("unknown key `{key}`; allowed: {}", allowed.join(", "))));
        }
    }
    Ok(())
}

fn string<'a>(value: &'a toml::Value, key: &str) -> Result<&'a str> {
    value.as_str().ok_or_else(|| Error::invalid(key, format!("{value}; must be a string")))
}

fn number(value: &toml::Value, key: &str) -> Result<f64> {
    match value {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(n) => Ok(*n as f64),
        other => Err(Error::invalid(key, format!("{other}; must be a number"))),
    }
}

/// A kebab-case choice (`model`, `albedo`, `tir`), read through its serde names.
fn choice<T: serde::de::DeserializeOwned>(table: &toml::Table, key: &str, where_: &str) -> Result<Option<T>> {
    let Some(value) = table.get(key) else { return Ok(None) };
    let allowed = match key {
        "model" => "\"2-flux\", \"6-flux\"",
        "albedo" => "\"fgd\", \"belcour\", \"karis\", \"fit:PATH\"",
        _ => "\"table\", \"fit\", \"off\", \"fit:PATH\"",
    };
    T::deserialize(value.clone())
        .map(Some)
        .map_err(|_| Error::invalid(format!("{where_}: {key}"), format!("{value}; allowed: {allowed}")))
}

/// The fitted form `key = "fit:PATH"` names (PATH read relative to `dir`), fitted to one of
/// `tables`; `None` where `key` is not written `fit:...`.
fn named_form(table: &toml::Table, key: &str, where_: &str, dir: &Path, tables: &[&str]) -> Result<Option<FittedForm>> {
    let Some(path) = table.get(key).and_then(|v| v.as_str()).and_then(|t| t.strip_prefix("fit:")) else {
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
fn tir_choice(table: &toml::Table, where_: &str, dir: &Path) -> Result<Option<(TirPath, Option<FittedForm>)>> {
    if let Some(form) = named_form(table, "tir", where_, dir, fitted::TIR_TABLES)? {
        return Ok(Some((TirPath::Form, Some(form))));
    }
    match choice(table, "tir", where_)? {
        // The path of a named form is only ever written `fit:PATH`.
        Some(TirPath::Form) => Err(Error::invalid(
            format!("{where_}: tir"),
            format!("\"form\" names no form; allowed: \"table\", \"fit\", \"off\", {}", fitted::ALLOWED),
        )),
        other => Ok(other.map(|path| (path, None))),
    }
}

/// `albedo`: a path, or `fit:PATH` with the fitted form it names (read relative to `dir`), whose
/// table sets the path: a form fitted to `karis` is read on the Karis path (its channels weighed by
/// the interface's F0), one fitted to `fgd` on the FGD path.
fn albedo_choice(table: &toml::Table, where_: &str, dir: &Path) -> Result<Option<(AlbedoPath, Option<FittedForm>)>> {
    if let Some(form) = named_form(table, "albedo", where_, dir, fitted::ALBEDO_TABLES)? {
        let path = if form.table == "karis" { AlbedoPath::Karis } else { AlbedoPath::Fgd };
        return Ok(Some((path, Some(form))));
    }
    Ok(choice(table, "albedo", where_)?.map(|path| (path, None)))
}

/// A number as a person wrote it: `1e20` rather than its 21 digits.
fn number_text(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) { format!("{x:e}") } else { format!("{x}") }
}

/// One number for all channels, or `[r, g, b]`, each admitted by `bound`.
fn rgb_values(value: &toml::Value, key: &str, bound: Bound) -> Result<Rgb<f64>> {
    let values = match value {
        toml::Value::Array(items) if items.len() == 3 => {
            let mut v = [0.0; 3];
            for (slot, item) in v.iter_mut().zip(items) {
                *slot = number(item, key)?;
            }
            v
        }
        toml::Value::Array(items) => {
            return Err(Error::invalid(key, format!("has {} values; give one number or [r, g, b]", items.len())));
        }
        other => [number(other, key)?; 3],
    };
    if let Some(bad) = values.iter().find(|x| !bound.admits(**x)) {
        return Err(Error::invalid(key, format!("{}; allowed: {}", number_text(*bad), bound.allowed())));
    }
    Ok(values)
}

fn rgb(table: &toml::Table, key: &str, where_: &str) -> Result<Option<Rgb<f64>>> {
    table.get(key).map(|v| rgb_values(v, &format!("{where_}: {key}"), Bound::NonNegative)).transpose()
}

/// A `vary` range `[lo, hi]`, admitted by `bound`.
fn range(vary: &toml::Table, key: &str, where_: &str, bound: Bound) -> Result<Option<Interval>> {
    let Some(value) = vary.get(key) else { return Ok(None) };
    let key = format!("{where_}: vary.{key}");
    let items = value
        .as_array()
        .filter(|a| a.len() == 2)
        .ok_or_else(|| Error::invalid(&key, format!("{value}; give a range [lo, hi]")))?;
    let (lo, hi) = (number(&items[0], &key)?, number(&items[1], &key)?);
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
    table: &toml::Table,
    vary: &toml::Table,
    key: &str,
    default: Option<f64>,
    where_: &str,
    bound: Bound,
) -> Result<(Rgb<Interval>, Rgb<f64>)> {
    let given = match table.get(key) {
        Some(value) => Some(rgb_values(value, &format!("{where_}: {key}"), bound)?),
        None => None,
    };
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
fn scalar_or_range(table: &toml::Table, vary: &toml::Table, key: &str, where_: &str) -> Result<(Interval, f64)> {
    let given = match table.get(key) {
        Some(value) => {
            let key = format!("{where_}: {key}");
            let x = number(value, &key)?;
            if !Bound::Unit.admits(x) {
                return Err(Error::invalid(&key, format!("{}; allowed: {}", number_text(x), Bound::Unit.allowed())));
            }
            Some(x)
        }
        None => None,
    };
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
