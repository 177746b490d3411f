//! Scenes: the materials a shader author ships, as layer stacks in the transfer-matrix model's
//! terms (Randrianandrasana et al. 2021; the thesis's section 5.1), read from a TOML file so that
//! [`plan`] can derive the tables those materials look up and nothing else.
//!
//! ```toml
//! name = "varnished-copper"      # optional; default: the file's stem
//! model = "2-flux"               # every material's default: "2-flux" or "6-flux"
//! albedo = "fgd"                 # "fgd" (4D table), "belcour" or "karis" (split-sum tables)
//! tir = "table"                  # "table", "fit" (analytic form), "off", or "fit:PATH" (a form
//!                                # fitted by `tmlut fit --form`: its output folder or fit.json)
//! margin_nodes = 1               # nodes kept beyond each needed sub-range
//!
//! [[material]]
//! name = "pot"
//! [[material.layer]]             # top first; the medium above the stack is air (eta 1)
//! type = "interface"
//! eta = 1.1                      # absolute index of the medium below: one value or [r, g, b]
//! kappa = 0.0                    # default 0
//! alpha = 0.01                   # GGX roughness
//! [[material.layer]]
//! type = "interface"
//! eta = [0.1, 0.4, 1.6]
//! kappa = [4.0, 2.4, 1.6]
//! alpha = 0.01
//! vary = { alpha = [0.005, 0.05] }   # a texture varies alpha over this range
//! ```
//!
//! A medium layer (`type = "medium"`, 6-flux model) has `sigma_s`, `sigma_k` (RGB), `depth` and
//! the phase asymmetry `g`. Every error names the material and layer it is about.

pub mod bake_files;
pub mod build;
pub mod cache;
pub mod certify;
pub mod library;
pub mod lookups;
pub mod memory;
mod parse;
pub mod plan;
pub mod shader_files;
mod stacks;

use serde::{Deserialize, Serialize};

pub use crate::model::{AlbedoPath, FluxModel, Medium, TirPath};
pub use parse::{MAX_COEFFICIENT, MAX_INDEX, MAX_MATERIALS, MAX_NAME_CHARS, MIN_INDEX, MIN_MAGNITUDE, file_name_part};
pub use stacks::MAX_VARIANTS;

/// A closed range `[lo, hi]` of a parameter; a fixed value has `lo == hi`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    pub fn point(x: f64) -> Self {
        Interval { lo: x, hi: x }
    }

    pub fn new(lo: f64, hi: f64) -> Self {
        Interval { lo, hi }
    }

    pub fn is_point(&self) -> bool {
        self.lo == self.hi
    }

    pub fn hull(self, other: Interval) -> Interval {
        Interval { lo: self.lo.min(other.lo), hi: self.hi.max(other.hi) }
    }

    /// `self / other` for positive intervals.
    pub fn divide(self, other: Interval) -> Interval {
        Interval { lo: self.lo / other.hi, hi: self.hi / other.lo }
    }

    /// `1 / self` for a positive interval.
    pub fn reciprocal(self) -> Interval {
        Interval { lo: 1.0 / self.hi, hi: 1.0 / self.lo }
    }
}

impl std::fmt::Display for Interval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_point() {
            write!(f, "{}", short(self.lo))
        } else {
            write!(f, "[{}, {}]", short(self.lo), short(self.hi))
        }
    }
}

/// A number with at most four significant decimals, for plans and messages.
pub fn short(x: f64) -> String {
    let text = format!("{x:.4}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" { "0".into() } else { text.into() }
}

/// One value per colour channel (R, G, B).
pub type Rgb<T> = [T; 3];

/// A rough boundary between two media as a scene describes it: each value a range where a texture
/// varies it. The model evaluates [`crate::model::Interface`] (one value each), `nominal` here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneInterface {
    /// Absolute real index of the medium below, per channel (a range where a texture varies it).
    pub eta: Rgb<Interval>,
    /// Absolute extinction index of the medium below, per channel; any channel above 0 makes the
    /// interface an opaque conductor.
    pub kappa: Rgb<Interval>,
    /// GGX roughness.
    pub alpha: Interval,
    /// The values a material is evaluated at (the furnace, the model): those the scene gives, or
    /// the middle of a `vary` range given without one.
    pub nominal: crate::model::Interface,
}

impl SceneInterface {
    /// Whether light goes no further: the model evaluates nothing below a conductor.
    pub fn is_conductor(&self) -> bool {
        self.kappa.iter().any(|k| k.hi > 0.0)
    }
}

/// A layer of a scene's material ([`crate::model::Layer`] with the ranges of [`SceneInterface`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SceneLayer {
    Interface(SceneInterface),
    Medium(Medium),
}

/// A material as a scene names it: its lookup paths, the forms it reads, and its layers with their
/// ranges. [`crate::model::Material`] is what evaluates one of its stacks ([`SceneMaterial::variants`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneMaterial {
    pub name: String,
    pub model: FluxModel,
    pub albedo: AlbedoPath,
    /// The fitted form read in place of the albedo table of `albedo` (`albedo = "fit:PATH"`: a
    /// form fitted to `karis` or `fgd`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_form: Option<crate::fit::forms::FittedForm>,
    pub tir: TirPath,
    /// The fitted form read in place of the TIR table where `tir` is [`TirPath::Form`]
    /// (`tir = "fit:PATH"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_form: Option<crate::fit::forms::FittedForm>,
    /// Top first.
    pub layers: Vec<SceneLayer>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    pub name: String,
    pub materials: Vec<SceneMaterial>,
    /// Nodes of the default grid kept beyond each needed sub-range, so that the lookup at the edge
    /// of the range interpolates inside the table.
    pub margin_nodes: usize,
    /// What the scene says that the model will not evaluate (layers below a conductor, scattering
    /// in a 2-flux material): said, not refused.
    pub warnings: Vec<String>,
}

pub const DEFAULT_MARGIN_NODES: usize = 1;

#[cfg(test)]
mod tests;
