//! What the model reads from its tables, and the one interface through which it reads it.
//!
//! Every precomputed integral the transfer-matrix model needs is a [`Lookup`]: the directional
//! albedo of an interface (FGD), the share of a lobe lost to total internal reflection (TIR), or
//! the albedo of a lobe's microfacet shape without Fresnel (GD). Whoever answers them is a
//! [`Tables`]: the files of a built folder read as a shader reads them, exact integrals computed
//! on the fly, or any closure `Fn(&Lookup) -> f64` a researcher writes.

use serde::{Deserialize, Serialize};

use crate::table::TableKind;

/// Which precomputed integral a lookup reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quantity {
    /// `FGD(mu, alpha, eta, kappa)`: an interface's directional albedo with exact Fresnel.
    Albedo,
    /// `TIR(mu, alpha, eta)`: the share of a lobe of roughness `alpha` lost to total internal
    /// reflection at relative index `eta < 1`.
    Tir,
    /// `GD(mu, alpha)`: the directional albedo of a GGX lobe without Fresnel.
    Gd,
}

/// Where in the stack a lookup is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Site {
    /// An interface's albedo, for light arriving from above.
    FromAbove,
    /// A crossing downward toward a lower index (TIR).
    Down,
    /// A crossing upward toward a lower index (TIR).
    Up,
    /// An outgoing lobe's own albedo (GD).
    Lobe,
}

impl Site {
    pub fn name(self) -> &'static str {
        match self {
            Site::FromAbove => "from above",
            Site::Down => "down",
            Site::Up => "up",
            Site::Lobe => "lobe",
        }
    }
}

/// One value the model needs; its coordinates are of the model's number type (`f64` on the
/// CPU; see [`crate::physics::real::Real`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Lookup<R = f64> {
    pub quantity: Quantity,
    pub site: Site,
    /// 1-based position in the stack's layers, top first (media count); for a lobe's GD, the
    /// layer whose lobe it is.
    pub layer: usize,
    /// The colour channel (0, 1, 2 for R, G, B) whose value this is, or `None` where one value
    /// serves all three (a dielectric's albedo and TIR, GD).
    pub channel: Option<usize>,
    /// Cosine of the incident direction (for TIR, of the lobe's mean direction).
    pub mu: R,
    /// GGX roughness (for TIR and GD, of the lobe).
    pub alpha: R,
    /// Relative real index (1 for GD).
    pub eta: R,
    /// Relative extinction index (0 for TIR and GD).
    pub kappa: R,
}

/// The answers to the model's lookups.
pub trait Tables<R = f64> {
    fn value(&self, lookup: &Lookup<R>) -> R;
}

/// A closure answers lookups: `|lookup: &Lookup| ...` is a [`Tables`].
impl<R, F: Fn(&Lookup<R>) -> R> Tables<R> for F {
    fn value(&self, lookup: &Lookup<R>) -> R {
        self(lookup)
    }
}

/// Which table gives an interface's directional albedo.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AlbedoPath {
    /// The 4D FGD table (or a scene's specialised slices, or its GPU packing).
    Fgd,
    /// The Belcour–Bati–Barla 2020 split-sum table with a Fresnel basis.
    Belcour,
    /// The Karis split-sum table (Schlick Fresnel).
    Karis,
}

impl AlbedoPath {
    pub fn name(self) -> &'static str {
        match self {
            AlbedoPath::Fgd => TableKind::Fgd.name(),
            AlbedoPath::Belcour => TableKind::Belcour.name(),
            AlbedoPath::Karis => TableKind::Karis.name(),
        }
    }
}

/// How total internal reflection is corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TirPath {
    /// The TIR table (or its specialised slices).
    Table,
    /// The fitted analytic form of the folder (`[tir] fit = "best"`, `tir_fit.wgsl`): no table.
    Fit,
    /// A form file fitted by `tmlut fit --form` that the material names (`tir = "fit:PATH"`,
    /// [`crate::fit::text::fitted::FittedForm`]): no table.
    Form,
    /// No correction: every TIR lookup reads 0.
    Off,
}

impl TirPath {
    pub fn name(self) -> &'static str {
        match self {
            TirPath::Table => "table",
            TirPath::Fit => "fit",
            TirPath::Form => "form",
            TirPath::Off => "off",
        }
    }
}
