//! Where a fit counts a point and how much: `--range VAR=LO:HI` keeps the points inside a box of
//! the form's variables (or of `roughness = sqrt(alpha)`), and `--weights` weighs each point
//! (uniform; by `mu`, the cosine of the view; or by how many of a scene's materials read the table
//! there). The objective, the figures, the pictures and the certification all read the same
//! [`Region`]; `docs/fit.md`, "Forms as text", defines each.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::table::Table;

/// One `--range VAR=LO:HI`: the points with `LO <= VAR <= HI` are kept.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Range {
    /// A variable of the form, or `roughness`.
    pub variable: String,
    pub lo: f64,
    pub hi: f64,
}

impl Range {
    /// `VAR=LO:HI`, checked for its shape and `LO < HI` only (the variable against the form in
    /// [`Region::new`]).
    pub fn parse(text: &str) -> Result<Range> {
        let bad = |why: &str| Error::invalid("--range", format!("`{text}`: {why}; expected VAR=LO:HI, e.g. mu=0.2:1"));
        let (variable, bounds) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
        let (lo, hi) = bounds.split_once(':').ok_or_else(|| bad("no `:` between LO and HI"))?;
        let number = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (lo, hi) = match (number(lo), number(hi)) {
            (Some(lo), Some(hi)) => (lo, hi),
            _ => return Err(bad("LO and HI must be finite numbers")),
        };
        if lo >= hi {
            return Err(Error::invalid("--range", format!("`{text}`: LO {lo} must be below HI {hi}")));
        }
        Ok(Range { variable: variable.trim().to_string(), lo, hi })
    }
}

/// What `--weights` names.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum WeightsSpec {
    /// Every point counts once (the default).
    #[default]
    Uniform,
    /// Each point counts `mu`, the cosine of the view.
    Cosine,
    /// Each point counts the number of the scene's materials whose lookups of the table reach it.
    Scene(PathBuf),
}

impl WeightsSpec {
    /// `uniform`, `cosine`, or a scene file (`.toml`).
    pub fn parse(text: &str) -> Result<WeightsSpec> {
        match text {
            "uniform" => Ok(WeightsSpec::Uniform),
            "cosine" => Ok(WeightsSpec::Cosine),
            path if path.ends_with(".toml") => Ok(WeightsSpec::Scene(PathBuf::from(path))),
            other => Err(Error::invalid(
                "--weights",
                format!("`{other}`; allowed: uniform, cosine, or a scene file SCENE.toml"),
            )),
        }
    }
}

/// In words: `uniform`, `cosine`, or `scene PATH`.
impl std::fmt::Display for WeightsSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WeightsSpec::Uniform => write!(f, "uniform"),
            WeightsSpec::Cosine => write!(f, "cosine"),
            WeightsSpec::Scene(path) => write!(f, "scene {}", path.display()),
        }
    }
}

/// The range a variable takes in a table's data: its axis's, or [0, 1] for a variable that no
/// axis samples (`eta` of the TIR table, whose axis is the critical-angle offset).
pub fn variable_range(table: &Table, variable: &str) -> (f64, f64) {
    match table.axes.iter().find(|a| a.name == variable) {
        Some(a) => a.bounds(),
        None => (0.0, 1.0),
    }
}

/// A [`Range`] resolved against the form's variables.
#[derive(Debug, Clone)]
struct Bound {
    /// Index into the form's variables.
    variable: usize,
    /// The range is on `sqrt` of that variable (`roughness = sqrt(alpha)`).
    sqrt: bool,
    lo: f64,
    hi: f64,
}

/// A lookup's parameter hull: `(lo, hi)` of mu, alpha, eta and kappa.
pub type LookupHull = [(f64, f64); 4];

/// A scene's lookups of one table, what `--weights SCENE.toml` counts: read by the scene's
/// planner ([`crate::scene::lookups::table_lookups`]; the scene is a layer above the fit, which
/// is given them).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneLookups {
    /// The scene file.
    pub scene: PathBuf,
    /// The table whose lookups these are.
    pub table: String,
    /// Per material with at least one lookup of the table, in the order first met: its name and
    /// each lookup's parameter hull.
    pub materials: Vec<(String, Vec<LookupHull>)>,
}

/// The lookups of one material of a scene, as boxes in the form's variables.
#[derive(Debug, Clone)]
struct MaterialHulls {
    boxes: Vec<Vec<(f64, f64)>>,
}

#[derive(Debug, Clone)]
enum Weighting {
    Uniform,
    Cosine { mu: usize },
    Scene { materials: Vec<MaterialHulls> },
}

/// The ranges and the weighting of a fit, resolved against a form's variables.
#[derive(Debug, Clone)]
pub struct Region {
    /// As given, checked against the form and the table.
    pub ranges: Vec<Range>,
    pub weights: WeightsSpec,
    bounds: Vec<Bound>,
    weighting: Weighting,
    /// What the report says of the weights.
    pub weights_description: String,
}

impl Region {
    /// Every point, uniform weights.
    pub fn everywhere() -> Region {
        Region {
            ranges: Vec::new(),
            weights: WeightsSpec::Uniform,
            bounds: Vec::new(),
            weighting: Weighting::Uniform,
            weights_description: "uniform".into(),
        }
    }

    /// Resolve `ranges` and `weights` against the form's `variables` on `table`: each range names
    /// one of them or `roughness` (where `alpha` is one), once, and lies inside the table's range
    /// of it; `cosine` needs `mu`; a scene must read the table, its lookups given as `scene`
    /// (read by [`crate::scene::lookups::table_lookups`]).
    pub fn new(
        ranges: &[Range],
        weights: &WeightsSpec,
        scene: Option<&SceneLookups>,
        table: &Table,
        variables: &[String],
    ) -> Result<Region> {
        let alpha = variables.iter().position(|v| v == "alpha");
        let mut allowed: Vec<String> = variables.to_vec();
        if alpha.is_some() {
            allowed.push("roughness".into());
        }
        let mut bounds = Vec::new();
        for (k, range) in ranges.iter().enumerate() {
            let described = format!("{}={}:{}", range.variable, range.lo, range.hi);
            let (variable, sqrt) = match variables.iter().position(|v| *v == range.variable) {
                Some(v) => (v, false),
                None if range.variable == "roughness" && alpha.is_some() => (alpha.unwrap_or(0), true),
                None => {
                    return Err(Error::invalid(
                        "--range",
                        format!(
                            "`{described}`: unknown variable `{}`; allowed for table `{}`: {}",
                            range.variable,
                            table.name,
                            allowed.join(", ")
                        ),
                    ));
                }
            };
            if ranges[..k].iter().any(|r| r.variable == range.variable) {
                return Err(Error::invalid("--range", format!("`{described}`: `{}` given twice", range.variable)));
            }
            let (lo, hi) = variable_range(table, &variables[variable]);
            let (lo, hi) = if sqrt { (lo.max(0.0).sqrt(), hi.max(0.0).sqrt()) } else { (lo, hi) };
            // A range reaching past the table by rounding (a bound printed to fewer digits) is kept.
            let slack = 1e-9 * (hi - lo);
            if range.lo < lo - slack || range.hi > hi + slack {
                return Err(Error::invalid(
                    "--range",
                    format!(
                        "`{described}` lies outside the table's range [{lo}, {hi}] of {} (table `{}`)",
                        range.variable, table.name
                    ),
                ));
            }
            if range.lo >= range.hi {
                return Err(Error::invalid("--range", format!("`{described}`: LO must be below HI")));
            }
            bounds.push(Bound { variable, sqrt, lo: range.lo, hi: range.hi });
        }
        let (weighting, weights_description) = match weights {
            WeightsSpec::Uniform => (Weighting::Uniform, "uniform: every point counts once".to_string()),
            WeightsSpec::Cosine => {
                let mu = variables.iter().position(|v| v == "mu").ok_or_else(|| {
                    Error::invalid("--weights", format!("cosine weighs by `mu`, and table `{}` has none", table.name))
                })?;
                (Weighting::Cosine { mu }, "cosine: each point counts mu, the cosine of its view".to_string())
            }
            WeightsSpec::Scene(path) => {
                let lookups = scene.filter(|s| s.scene == *path && s.table == table.name).ok_or_else(|| {
                    Error::invalid(
                        "--weights",
                        format!("scene {}: its lookups of table `{}` were not read", path.display(), table.name),
                    )
                })?;
                scene_weighting(lookups, table, variables)?
            }
        };
        Ok(Region { ranges: ranges.to_vec(), weights: weights.clone(), bounds, weighting, weights_description })
    }

    /// The box the region spans in each of the form's `variables` on `table`: the table's range
    /// of each ([`variable_range`]) narrowed by the ranges (a `roughness` range bounds `alpha` by
    /// its squares).
    pub fn extent(&self, table: &Table, variables: &[String]) -> Vec<(f64, f64)> {
        let mut extent: Vec<(f64, f64)> = variables.iter().map(|v| variable_range(table, v)).collect();
        for b in &self.bounds {
            let (lo, hi) = if b.sqrt { (b.lo * b.lo, b.hi * b.hi) } else { (b.lo, b.hi) };
            let range = &mut extent[b.variable];
            *range = (range.0.max(lo), range.1.min(hi));
        }
        extent
    }

    /// Whether the point (in the form's variables) lies inside every range.
    pub fn contains(&self, point: &[f64]) -> bool {
        self.bounds.iter().all(|b| {
            let x = if b.sqrt { point[b.variable].max(0.0).sqrt() } else { point[b.variable] };
            x >= b.lo && x <= b.hi
        })
    }

    /// The point's weight, before the data's normalisation to a mean of 1.
    pub fn weight(&self, point: &[f64]) -> f64 {
        match &self.weighting {
            Weighting::Uniform => 1.0,
            Weighting::Cosine { mu } => point[*mu].max(0.0),
            Weighting::Scene { materials } => materials
                .iter()
                .filter(|m| m.boxes.iter().any(|b| b.iter().zip(point).all(|(&(lo, hi), &x)| x >= lo && x <= hi)))
                .count() as f64,
        }
    }

    /// Whether the weights are other than uniform.
    pub fn is_weighted(&self) -> bool {
        !matches!(self.weighting, Weighting::Uniform)
    }

    /// The ranges as the report prints them: `mu in [0.2, 1], roughness in [0, 0.3]`, or
    /// `the whole table`.
    pub fn describe_ranges(&self) -> String {
        if self.ranges.is_empty() {
            return "the whole table".into();
        }
        let parts: Vec<String> =
            self.ranges.iter().map(|r| format!("{} in [{}, {}]", r.variable, r.lo, r.hi)).collect();
        parts.join(", ")
    }
}

/// The values a variable takes at the data's points, ascending: its axis's nodes where the points
/// are the table's nodes, otherwise the fit grid's ([`crate::fit::forms::data::FormData`]).
fn point_values(table: &Table, variables: &[String], variable: &str) -> Vec<f64> {
    let plain = table.axes.iter().all(|a| variables.contains(&a.name));
    let mut values = match table.axes.iter().find(|a| a.name == variable) {
        Some(axis) if plain => axis.node_values(),
        _ => {
            let (lo, hi) = variable_range(table, variable);
            let n = crate::fit::FIT_GRID_NODES;
            (0..n).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64).collect()
        }
    };
    values.sort_by(f64::total_cmp);
    values
}

/// The scene weighting: a point's weight is the number of the scene's materials with at least one
/// lookup of this table whose parameter hull ([`SceneLookups`]), widened outward to the nearest
/// data point on each side in each variable, contains it in every variable of the form: the points
/// whose values a lookup inside the hull interpolates between (a lookup at one fixed `eta` reaches
/// the two grid values around it, not none).
fn scene_weighting(scene: &SceneLookups, table: &Table, variables: &[String]) -> Result<(Weighting, String)> {
    let path = &scene.scene;
    let values: Vec<Vec<f64>> = variables.iter().map(|v| point_values(table, variables, v)).collect();
    let mut materials: Vec<(String, MaterialHulls)> = Vec::new();
    for (material, lookup) in scene.materials.iter().flat_map(|(m, hulls)| hulls.iter().map(move |h| (m, h))) {
        let hull: Vec<(f64, f64)> = variables
            .iter()
            .zip(&values)
            .map(|(v, values)| {
                let (lo, hi) = match v.as_str() {
                    "mu" => lookup[0],
                    "alpha" => lookup[1],
                    "eta" => lookup[2],
                    _ => lookup[3],
                };
                let (lo, hi) = (lo.min(hi), lo.max(hi));
                let below = values.iter().rev().find(|&&x| x <= lo).or(values.first()).copied().unwrap_or(lo);
                let above = values.iter().find(|&&x| x >= hi).or(values.last()).copied().unwrap_or(hi);
                (below.min(lo), above.max(hi))
            })
            .collect();
        match materials.iter_mut().find(|(m, _)| m == material) {
            Some((_, hulls)) => hulls.boxes.push(hull),
            None => materials.push((material.clone(), MaterialHulls { boxes: vec![hull] })),
        }
    }
    if materials.is_empty() {
        return Err(Error::invalid(
            "--weights",
            format!(
                "no material of scene {} reads table `{}` (a scene reads fgd, karis, belcour, tir, gd and their slices fgd_..., tir_...)",
                path.display(),
                table.name
            ),
        ));
    }
    let names: Vec<&str> = materials.iter().map(|(m, _)| m.as_str()).collect();
    let description = format!(
        "scene {}: each point counts the materials whose lookups of table `{}` reach it ({} of them: {}), each lookup's parameter hull widened outward to the nearest point on each side",
        path.display(),
        table.name,
        names.len(),
        names.join(", ")
    );
    Ok((Weighting::Scene { materials: materials.into_iter().map(|(_, h)| h).collect() }, description))
}
