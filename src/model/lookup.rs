//! What the model reads from its tables, and the one interface through which it reads it.
//!
//! Every precomputed integral the transfer-matrix model needs is a [`Lookup`]: the directional
//! albedo of an interface (FGD), the share of a lobe lost to total internal reflection (TIR), or
//! the albedo of a lobe's microfacet shape without Fresnel (GD). Whoever answers them is a
//! [`Tables`]: the files of a built folder read as a shader reads them, exact integrals computed
//! on the fly, or any closure `Fn(&Lookup) -> f64` a researcher writes.

use serde::{Deserialize, Serialize};

use crate::table::{PerKind, TableKind};

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
/// CPU; see [`crate::ir::real::Real`]).
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

    /// Whether [`Tables::value`] has `lookup`'s answer at hand: false only where answers are
    /// computed on demand at a cost (exact integrals) and this one has not been yet.
    fn knows(&self, _lookup: &Lookup<R>) -> bool {
        true
    }

    /// Compute the answers to `lookups` ahead of their reads, together (in parallel, sharing what
    /// they share), for tables that compute answers on demand; nothing to do for the others.
    fn prepare(&self, _lookups: &[Lookup<R>]) {}
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
    /// [`crate::fit::forms::fitted::FittedForm`]): no table.
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

/// A table that answers, whole, the lookups of one quantity at the relative indices of its
/// region, ahead of the quantity's own table (where no slice of a scene holds the index): a
/// narrower integral where the quantity's own grid cannot follow it. Which kinds stand in is
/// decided once, by [`stand_in`]; the folder's lookups ([`super::folder`]), the scene shader, the
/// planner and a fit's scene weights all follow it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StandIn {
    pub table: TableKind,
    /// The quantity whose lookups it answers: albedo on the FGD path, or TIR on the table path.
    pub quantity: Quantity,
    pub region: IndexRegion,
    /// What the table is, as the planner names it.
    pub what: &'static str,
    /// Why a lookup of its region reads it, as the planner gives it.
    pub why: &'static str,
}

impl StandIn {
    /// Whether it answers a lookup of `quantity` at the index `(eta, kappa)`: the rule the folder's
    /// lookups and the scene shader both choose by.
    pub fn answers(&self, quantity: Quantity, eta: f64, kappa: f64) -> bool {
        self.quantity == quantity && self.region.holds(eta, kappa)
    }
}

/// Relative indices `eta < eta_below` and `kappa <= kappa_at_most`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndexRegion {
    pub eta_below: f64,
    pub kappa_at_most: f64,
}

impl IndexRegion {
    /// Whether the index `(eta, kappa)` lies in the region.
    pub fn holds(&self, eta: f64, kappa: f64) -> bool {
        eta < self.eta_below && kappa <= self.kappa_at_most
    }

    /// Whether some index of the ranges `eta` and `kappa` (each `[lo, hi]`) lies in the region:
    /// the region is bounded above only, so their lower ends decide.
    pub fn meets(&self, eta: [f64; 2], kappa: [f64; 2]) -> bool {
        self.holds(eta[0], kappa[0])
    }
}

/// The stand-in a table of kind `kind` is, or `None` for a quantity's own table (read by its path:
/// FGD's slices, packing and 4D table, TIR's slices, 3D table and forms, GD, the split-sum
/// tables) and for a table the model does not read (an engine's: `ggx_e`, `ggx_e_avg`,
/// `karis_multiscatter`). Every kind is decided here, in a `PerKind` whose literal names every kind: a kind added
/// to the loader's list does not compile until it is.
pub fn stand_in(kind: TableKind) -> Option<StandIn> {
    let stand_ins = PerKind {
        fgd: None,
        gd: None,
        tir: None,
        belcour: None,
        karis: None,
        // A dielectric onto a rarer medium: FGD over an axis that follows the critical angle,
        // which the 4D table's separate axes cannot (docs/tables.md).
        fgd_rarer: Some(StandIn {
            table: TableKind::FgdRarer,
            quantity: Quantity::Albedo,
            region: IndexRegion { eta_below: 1.0, kappa_at_most: 0.0 },
            what: "FGD onto a rarer medium (eta < 1, kappa = 0)",
            why: "a dielectric onto a rarer medium",
        }),
        // An engine's energy-compensation tables: the model reads GD for a lobe's albedo, whose
        // masking and axes it was written for, and nothing of E's average.
        ggx_e: None,
        ggx_e_avg: None,
        karis_multiscatter: None,
    };
    stand_ins.take(kind)
}

/// The stand-ins among the registry's tables, in its order.
pub fn stand_ins() -> impl Iterator<Item = StandIn> {
    TableKind::ALL.iter().filter_map(|&kind| stand_in(kind))
}
