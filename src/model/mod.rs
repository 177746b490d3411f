//! The transfer-matrix layered material model (Randrianandrasana, Callet & Lucas 2021, "Transfer
//! matrix based layered materials rendering", ACM TOG 40(4)), as a renderer evaluates it: a layer
//! stack and a view cosine in; the outgoing lobes (energy per channel, roughness, direction) and
//! the directional albedo `A(mu)` out.
//!
//! The evaluation follows the authors' reference implementation (`docs/furnace.md`, which pairs
//! its names, quoted here as "the reference's", with the code here): transfer
//! factors per component ([`factors`]), first-order transmission asymmetries and the TIR
//! correction, energy and asymmetry matrices multiplied down the stack ([`tm2`], [`tm6`]), and
//! lobes as the increments of the cumulative reflectance. Its tables reach it through one
//! interface, [`Tables`] (see [`lookup`]).
//!
//! Where this differs from the reference, it is on purpose (`docs/furnace.md` lists each):
//! - hazards are guarded at their limit instead of producing infinities or NaN: a transmission of
//!   0 (TIR = 1) or an asymmetry of 0 in `1 / t`, a mean direction past the critical angle, a
//!   non-absorbing medium (`gamma = 0`, where the reference forces `sigma_k >= 1e-7`), thick media
//!   (products renormalised, so they never overflow);
//! - an index-matched interface or an empty medium is skipped as if absent (the reference reads
//!   an unset asymmetry of 0 from it for the interface above, which makes every lobe returning
//!   through it fully rough); the bottom interface of a stack without a conductor reads the
//!   asymmetry of "nothing below" as 1, as the reference's transmissive variant does;
//! - the 2-flux model lets media absorb (`diag(1 / t, t)`), which the reference's 2-flux code has
//!   no media for.
//!
//! Loader side: built with `default-features = false`, so that a renderer crate can evaluate the
//! materials it loads tables for:
//!
//! ```no_run
//! use tmlut::model::folder::{FgdSource, FolderTables};
//! use tmlut::model::{AlbedoPath, FluxModel, Interface, Layer, Material, Stack, TirPath};
//!
//! let luts = tmlut::loader::LutFolder::open("out/copper-pot")?; // tmlut build --scene
//! let tables = FolderTables::open(&luts, AlbedoPath::Fgd, TirPath::Table, FgdSource::Packing)?;
//! let varnished_copper = Material::new(
//!     FluxModel::TwoFlux,
//!     Stack::new(vec![
//!         Layer::Interface(Interface { eta: [1.1; 3], kappa: [0.0; 3], alpha: 0.01 }),
//!         Layer::Interface(Interface { eta: [0.1, 0.4, 1.6], kappa: [4.0, 2.4, 1.6], alpha: 0.01 }),
//!     ])?,
//! );
//! let evaluation = varnished_copper.evaluate(0.5, &tables); // lobes: energy, roughness, direction
//! let [r, g, b] = evaluation.albedo; // A(mu) per channel
//! # Ok::<(), tmlut::Error>(())
//! ```
//!
//! Any closure answers lookups too, for experiments: here smooth interfaces, whose albedo is
//! Fresnel's, with no TIR loss and lobes that keep all their energy.
//!
//! ```
//! use tmlut::model::{FluxModel, Interface, Layer, Lookup, Material, Quantity, Stack};
//! use tmlut::physics::fresnel_reflectance;
//!
//! let smooth = |l: &Lookup| match l.quantity {
//!     Quantity::Albedo => fresnel_reflectance(l.mu, l.eta, l.kappa),
//!     Quantity::Tir => 0.0,
//!     Quantity::Gd => 1.0,
//! };
//! let glass = Material::new(
//!     FluxModel::TwoFlux,
//!     Stack::new(vec![Layer::Interface(Interface { eta: [1.5; 3], kappa: [0.0; 3], alpha: 0.0 })])?,
//! );
//! assert!((glass.albedo(1.0, &smooth)[0] - 0.04).abs() < 1e-12);
//! # Ok::<(), tmlut::Error>(())
//! ```

pub mod factors;
pub mod folder;
pub mod lookup;
pub mod routes;
pub mod stack;
pub mod tm2;
pub mod tm6;

use serde::{Deserialize, Serialize};

use factors::{Component, Flux, components};
pub use lookup::{AlbedoPath, IndexRegion, Lookup, Quantity, Site, StandIn, Tables, TirPath, stand_in, stand_ins};
pub use stack::{FluxModel, Interface, Layer, MAX_LAYERS, Medium, Rgb, Stack};

use crate::ir::real::{Real, choose_if_any_nonzero};
use crate::physics::hg_to_ggx;

/// View cosines where the model is stiff: the horizon, a rounding step above it, grazing, the
/// middle, the normal (the stability matrix evaluates every stiff stack at these; the scene
/// shader's reference evaluation includes them).
pub const STIFF_VIEWS: [f64; 5] = [0.0, 1e-7, 1e-3, 0.5, 1.0];

/// Which flux an outgoing lobe comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LobeKind {
    /// Reflected without scattering in a medium (every lobe of the 2-flux model).
    Primary,
    /// Scattered forward in a medium, then reflected (6-flux).
    Forward,
    /// Scattered backward in a medium (6-flux): centred on the view direction itself.
    Backward,
}

/// A lobe as the matrices give it: its energy per channel and Henyey–Greenstein asymmetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawLobe<R = f64> {
    pub layer: usize,
    pub kind: LobeKind,
    pub energy: [R; 3],
    pub g: R,
}

/// One outgoing lobe of a material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Lobe<R = f64> {
    /// 1-based layer whose component produced it.
    pub layer: usize,
    pub kind: LobeKind,
    /// Energy per channel (the increment of the cumulative reflectance it stands for).
    pub energy: [R; 3],
    /// Henyey–Greenstein asymmetry.
    pub asymmetry: R,
    /// GGX roughness of the lobe, `alpha(g)` clamped to [1e-4, 1].
    pub roughness: R,
    /// The direction its microfacet distribution is evaluated from (the reference's `lobes_wi`): the
    /// view direction, or its mirror image about the normal for a backward lobe.
    pub incident: [R; 3],
    /// Its mean outgoing direction: the mirror direction of `incident`.
    pub mean_direction: [R; 3],
    /// Whether it is the top interface's own reflection, which the BSDF replaces with the exact
    /// Fresnel-weighted microfacet term of that interface (Bati et al. 2019's top correction).
    pub is_top: bool,
    /// `GD(mu, roughness)`: in the 2-flux model the lobe's albedo is `energy * gd`; the 6-flux
    /// model normalises its lobes by it, so their albedo is `energy` (0 for the top lobe, whose
    /// albedo is the interface's own FGD, and for lobes without energy, which read nothing).
    pub gd: R,
}

/// The model's result at one view cosine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation<R = f64> {
    pub mu: R,
    pub lobes: Vec<Lobe<R>>,
    /// `FGD(mu, alpha_1, eta_01, kappa_01)` per channel: the albedo of the top term (0 where it is
    /// absent: an index-matched top interface, or a 6-flux top lobe without energy).
    pub top_albedo: [R; 3],
    /// The directional albedo `A(mu)` per channel: the top term plus every other lobe's albedo.
    pub albedo: [R; 3],
}

/// A material: a layer stack evaluated with a flux model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub model: FluxModel,
    pub stack: Stack,
}

impl Material {
    pub fn new(model: FluxModel, stack: Stack) -> Self {
        Material { model, stack }
    }

    /// The lobes and directional albedo at view cosine `mu` (clamped to [0, 1]; NaN reads as 0,
    /// grazing), every integral read from `tables`. Generic over the number type: `f64` evaluates
    /// it; the scene shader's recorder writes the same steps as shader code.
    pub fn evaluate<R: Real>(&self, mu: R, tables: &dyn Tables<R>) -> Evaluation<R> {
        let mu = mu.or_if_nan(0.0).clamp(0.0, 1.0);
        let scattering = self.model == FluxModel::SixFlux;
        let components = components(&self.stack, mu, scattering, tables);
        let raw = match self.model {
            FluxModel::TwoFlux => tm2::lobes(&components, tables),
            FluxModel::SixFlux => tm6::lobes(&components, tables),
        };
        let top_flux = components.first().and_then(|(_, c)| top_reflection(c));
        let zero = R::of(0.0);
        let incident = [(R::of(1.0) - mu * mu).max(zero).sqrt(), zero, mu];
        let mirror = |w: [R; 3]| [-w[0], -w[1], w[2]];
        let mut top_albedo = [zero; 3];
        let mut albedo = [zero; 3];
        let mut lobes = Vec::with_capacity(raw.len());
        for lobe in raw {
            let is_top = lobe.layer == 1 && lobe.kind == LobeKind::Primary;
            let roughness = hg_to_ggx(lobe.g);
            let mut gd = zero;
            if is_top {
                // The 2-flux BSDF always adds the top term; the 6-flux one only where the top lobe
                // carries energy (the reference's 6-flux `eval`).
                if let Some(r) = top_flux {
                    top_albedo = match self.model {
                        FluxModel::TwoFlux => r.energy,
                        FluxModel::SixFlux => r.energy.map(|e| choose_if_any_nonzero(lobe.energy, || e, || zero)),
                    };
                }
            } else {
                // A lobe without energy reads nothing and adds nothing.
                gd = choose_if_any_nonzero(lobe.energy, || gd_lookup(lobe.layer, mu, roughness, tables), || zero);
                for (a, e) in albedo.iter_mut().zip(lobe.energy) {
                    let before = *a;
                    let added = match self.model {
                        FluxModel::TwoFlux => e * gd,
                        FluxModel::SixFlux => e,
                    };
                    *a = choose_if_any_nonzero(lobe.energy, || before + added, || before);
                }
            }
            let incident = if lobe.kind == LobeKind::Backward { mirror(incident) } else { incident };
            lobes.push(Lobe {
                layer: lobe.layer,
                kind: lobe.kind,
                energy: lobe.energy,
                asymmetry: lobe.g,
                roughness,
                incident,
                mean_direction: mirror(incident),
                is_top,
                gd,
            });
        }
        for c in 0..3 {
            albedo[c] = albedo[c] + top_albedo[c];
        }
        Evaluation { mu, lobes, top_albedo, albedo }
    }

    /// The directional albedo `A(mu)` per channel.
    pub fn albedo(&self, mu: f64, tables: &dyn Tables) -> Rgb {
        self.evaluate(mu, tables).albedo
    }
}

/// The top interface's reflection before any TIR correction: its FGD at the view cosine.
fn top_reflection<R: Real>(component: &Component<R>) -> Option<Flux<R>> {
    match component {
        Component::Dielectric(f) => Some(f.r),
        Component::Conductor { r } => Some(*r),
        Component::Pass | Component::Medium(_) => None,
    }
}

/// The GD lookup of lobe `layer`.
fn gd_lookup<R: Real>(layer: usize, mu: R, alpha: R, tables: &dyn Tables<R>) -> R {
    tables.value(&Lookup {
        quantity: Quantity::Gd,
        site: Site::Lobe,
        layer,
        channel: None,
        mu,
        alpha,
        eta: R::of(1.0),
        kappa: R::of(0.0),
    })
}

/// What a dielectric's first-order terms need of the stack below it: the asymmetry of the next
/// interface's reflection (1 where nothing below reflects), the product of the forward
/// asymmetries of the media crossed to reach it (6-flux secondary flux), and whether anything
/// below sends light back up at all.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Below<R = f64> {
    pub reflection_g: R,
    pub media_forward_g: R,
    pub returns_light: bool,
}

/// [`Below`] for the components under a dielectric; index-matched interfaces and empty media are
/// skipped as absent.
pub fn below<R: Real>(components: &[(usize, Component<R>)]) -> Below<R> {
    let mut media_forward_g = R::of(1.0);
    let mut scatters = false;
    for (_, component) in components {
        match component {
            Component::Pass => {}
            Component::Medium(m) => {
                media_forward_g = media_forward_g * m.t_ff.g;
                scatters |= m.scatters_back;
            }
            Component::Dielectric(f) => return Below { reflection_g: f.r.g, media_forward_g, returns_light: true },
            Component::Conductor { r } => return Below { reflection_g: r.g, media_forward_g, returns_light: true },
        }
    }
    Below { reflection_g: R::of(1.0), media_forward_g, returns_light: scatters }
}

/// The TIR correction of one crossing (the reference's 2-flux `outgoing_lobes`): the share of the transmitted
/// lobe (roughness `alpha(g_lobe)`, mean cosine `mu`) past the critical angle of relative index
/// `eta < 1` is reflected instead: `tir = TIR(mu, alpha(g), eta) t; r += tir; t -= tir`.
#[allow(clippy::too_many_arguments)]
pub fn first_order_tir<R: Real>(
    r: &mut Flux<R>,
    t: &mut Flux<R>,
    layer: usize,
    site: Site,
    mu: R,
    g_lobe: R,
    eta: f64,
    tables: &dyn Tables<R>,
) {
    let share = tables.value(&Lookup {
        quantity: Quantity::Tir,
        site,
        layer,
        channel: None,
        mu,
        alpha: hg_to_ggx(g_lobe),
        eta: R::of(eta),
        kappa: R::of(0.0),
    });
    for c in 0..3 {
        let moved = share * t.energy[c];
        r.energy[c] = r.energy[c] + moved;
        t.energy[c] = t.energy[c] - moved;
    }
}

#[cfg(test)]
mod tests;
