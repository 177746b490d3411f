//! The build plan of a scene: the lookups the transfer-matrix model makes for its materials, then
//! the fewest tables that answer them.
//!
//! Lookups follow the model's layer evaluation (Randrianandrasana et al. 2021, §4; the thesis's
//! listing 5.1 and `notes/tables.md`, "Where the tables enter the transfer-matrix model"):
//! - every interface reads its directional albedo from above at the relative index
//!   `(eta, kappa) / eta_above` (per colour channel), the incident cosine and its own roughness; a
//!   dielectric with anything below it also reads it from below at `1 / eta` (kappa 0);
//! - every crossing of a dielectric interface towards the optically thinner side (relative index
//!   below 1) reads TIR at the lobe's mean cosine and the lobe's roughness, which is at least the
//!   roughest interface the lobe has crossed (Henyey–Greenstein asymmetries multiply, so roughness
//!   only grows) and at most 1;
//! - the 6-flux model normalises its internal lobes by GD;
//! - a lobe's mean direction refracts as a ray (Belcour 2018's transmission operator): below an
//!   interface of relative index `eta`, cosines start at `sqrt(1 - (1 - mu_lo^2) / eta^2)`; a
//!   scattering medium (6-flux) sends light in every direction, so below it, and on the way back
//!   up from it, cosines start at 0;
//! - the model evaluates nothing below an opaque conductor.
//!
//! Tables follow from the lookups: where every lookup of a site is at fixed relative indices, a
//! specialised `(mu, alpha)` slice per site with one channel per distinct index
//! ([`crate::recipes::slices`]); where a texture varies an index, the full table over the sub-range
//! the lookups reach. Sub-ranges are whole nodes of the full table's grid plus `margin_nodes` on
//! each side, so slice nodes coincide with full-table nodes; a roughness that never varies gets a
//! node exactly at its value instead, so that it is read with no interpolation in alpha.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::{AlbedoPath, FluxModel, Interval, Layer, Scene, TirPath, short};
use crate::config::Config;
use crate::error::Result;
use crate::formats::FileFormat;
use crate::formats::manifest::{LeftOutRecord, PlanRecord, PlannedTableRecord};
use crate::packing::Packing;
use crate::physics::{ggx_to_hg, hg_to_ggx};
use crate::recipes::TableRecipe;
use crate::recipes::belcour::BelcourSettings;
use crate::recipes::fgd::FgdSettings;
use crate::recipes::gd::GdSettings;
use crate::recipes::karis::KarisSettings;
use crate::recipes::slices::{SliceChannel, SliceOf, Slices};
use crate::recipes::tir::TirSettings;
use crate::table::Axis;

/// What a lookup reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LookupKind {
    /// Directional albedo (FGD, or a split-sum table on the Belcour and Karis paths).
    Albedo(AlbedoPath),
    Tir(TirPath),
    Gd,
}

/// One lookup the model makes: a site (material, layer, direction), a colour channel, and the
/// range of every parameter it is made at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Lookup {
    pub material: String,
    /// 1-based, top first.
    pub layer: usize,
    pub kind: LookupKind,
    /// "from above", "from below" (albedo), "down", "up" (TIR crossings) or "internal lobes" (GD).
    pub direction: &'static str,
    /// 0, 1, 2 for R, G, B.
    pub channel: usize,
    pub mu: Interval,
    pub alpha: Interval,
    pub eta: Interval,
    pub kappa: Interval,
}

impl Lookup {
    fn site(&self) -> (String, usize, &'static str) {
        (self.material.clone(), self.layer, self.direction)
    }

    fn fixed_index(&self) -> bool {
        self.eta.is_point() && self.kappa.is_point()
    }
}

const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];

/// The lookups of every material of a scene, with what was noticed on the way (index-matched
/// interfaces, which need no lookup).
pub fn lookups(scene: &Scene) -> (Vec<Lookup>, Vec<LeftOutRecord>) {
    let mut lookups = Vec::new();
    let mut left_out = Vec::new();
    for material in &scene.materials {
        let name = &material.name;
        let mut eta_above = [Interval::point(1.0); 3];
        let mut mu_down = Interval::new(0.0, 1.0);
        // Lower bound of the roughness of a lobe that has come this far down.
        let mut lobe_alpha_lo = lobe_roughness(0.0);
        for (k, layer) in material.layers.iter().enumerate() {
            let layer_number = k + 1;
            let interface = match layer {
                Layer::Medium(medium) => {
                    if material.model == FluxModel::SixFlux && medium.sigma_s.iter().any(|&s| s > 0.0) {
                        mu_down = Interval::new(0.0, 1.0);
                    }
                    continue;
                }
                Layer::Interface(interface) => interface,
            };
            let eta: [Interval; 3] = std::array::from_fn(|c| interface.eta[c].divide(eta_above[c]));
            let kappa: [Interval; 3] = std::array::from_fn(|c| interface.kappa[c].divide(eta_above[c]));
            let site = |kind, direction, channel: usize, mu, alpha, eta, kappa| Lookup {
                material: name.clone(),
                layer: layer_number,
                kind,
                direction,
                channel,
                mu,
                alpha,
                eta,
                kappa,
            };
            let matched = (0..3).all(|c| eta[c] == Interval::point(1.0) && kappa[c] == Interval::point(0.0));
            if matched {
                left_out.push(LeftOutRecord {
                    what: format!("{name}, layer {layer_number}: albedo and TIR lookups"),
                    reason: "index-matched (relative eta 1, kappa 0): the interface reflects nothing, the model needs no lookup".into(),
                });
            } else {
                for c in 0..3 {
                    lookups.push(site(
                        LookupKind::Albedo(material.albedo),
                        "from above",
                        c,
                        mu_down,
                        interface.alpha,
                        eta[c],
                        kappa[c],
                    ));
                }
            }
            if interface.is_conductor() {
                break;
            }
            // Cosines of the transmitted mean direction: a ray refracting at the smallest index.
            let mu_below =
                Interval::new((0..3).map(|c| refracted_cosine(mu_down.lo, eta[c].lo)).fold(1.0, f64::min), 1.0);
            let lobe_alpha_below = lobe_alpha_lo.max(lobe_roughness(interface.alpha.lo));
            // Light that crosses comes back up only from an interface below, or, in the 6-flux
            // model, from a medium that scatters; scattered light comes back at every cosine.
            let below = &material.layers[k + 1..];
            let scatters_below = material.model == FluxModel::SixFlux
                && below.iter().any(|l| matches!(l, Layer::Medium(m) if m.sigma_s.iter().any(|&s| s > 0.0)));
            let has_below = scatters_below || below.iter().any(|l| matches!(l, Layer::Interface(_)));
            let mu_up = if scatters_below { Interval::new(0.0, 1.0) } else { mu_below };
            if !matched {
                for (c, eta) in eta.iter().enumerate() {
                    let tir = LookupKind::Tir(material.tir);
                    let down =
                        site(tir, "down", c, mu_down, Interval::new(lobe_alpha_lo, 1.0), *eta, Interval::point(0.0));
                    push_tir_crossing(&mut lookups, down);
                }
                if has_below {
                    for (c, eta) in eta.iter().enumerate() {
                        let eta_up = eta.reciprocal();
                        let albedo = LookupKind::Albedo(material.albedo);
                        lookups.push(site(
                            albedo,
                            "from below",
                            c,
                            mu_up,
                            interface.alpha,
                            eta_up,
                            Interval::point(0.0),
                        ));
                        let tir = LookupKind::Tir(material.tir);
                        let up = site(
                            tir,
                            "up",
                            c,
                            mu_up,
                            Interval::new(lobe_alpha_below, 1.0),
                            eta_up,
                            Interval::point(0.0),
                        );
                        push_tir_crossing(&mut lookups, up);
                    }
                }
            }
            eta_above = interface.eta;
            mu_down = mu_below;
            lobe_alpha_lo = lobe_alpha_below;
        }
        if material.model == FluxModel::SixFlux {
            // The 6-flux model normalises every internal lobe by GD, whatever the stack holds.
            lookups.push(Lookup {
                material: name.clone(),
                layer: 0,
                kind: LookupKind::Gd,
                direction: "internal lobes",
                channel: 0,
                mu: Interval::new(0.0, 1.0),
                alpha: Interval::new(lobe_roughness(0.0), 1.0),
                eta: Interval::point(1.0),
                kappa: Interval::point(0.0),
            });
        }
    }
    (lookups, left_out)
}

/// Add the TIR lookup of a crossing if it goes towards a lower index, made at the part of its
/// eta below 1 (where there is a critical angle).
fn push_tir_crossing(lookups: &mut Vec<Lookup>, lookup: Lookup) {
    if lookup.eta.lo < 1.0 {
        let eta = Interval::new(lookup.eta.lo, lookup.eta.hi.min(1.0));
        lookups.push(Lookup { eta, ..lookup });
    }
}

/// The cosine of a ray of cosine `mu` refracted into a medium of relative index `eta` (Snell's
/// law); 0 where it would be totally reflected.
fn refracted_cosine(mu: f64, eta: f64) -> f64 {
    (1.0 - (1.0 - mu * mu) / (eta * eta)).max(0.0).sqrt()
}

/// The roughness the model reads for a lobe of GGX roughness `alpha` after its Henyey–Greenstein
/// round trip (clamped to [1e-4, 1]).
fn lobe_roughness(alpha: f64) -> f64 {
    hg_to_ggx(ggx_to_hg(alpha))
}

/// What a planned table is built from.
#[derive(Debug, Clone, PartialEq)]
pub enum PlannedBuild {
    Fgd(FgdSettings),
    Gd(GdSettings),
    Tir(TirSettings),
    Belcour(BelcourSettings),
    Karis(KarisSettings),
    Slices(Slices),
    /// The analytic TIR form fitted to the full TIR table of these settings; only its shaders
    /// and coefficients are written.
    TirFit(TirSettings),
}

impl PlannedBuild {
    /// The recipe of a full (or sub-range) table (for the fitted form, the table it is fitted to);
    /// `None` for slices.
    pub fn recipe(&self) -> Option<&dyn TableRecipe> {
        match self {
            PlannedBuild::Fgd(s) => Some(s),
            PlannedBuild::Gd(s) => Some(s),
            PlannedBuild::Tir(s) => Some(s),
            PlannedBuild::Belcour(s) => Some(s),
            PlannedBuild::Karis(s) => Some(s),
            PlannedBuild::TirFit(s) => Some(s),
            PlannedBuild::Slices(_) => None,
        }
    }
}

/// A table of the plan: what it is, its size, and why it is built.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTable {
    pub record: PlannedTableRecord,
    pub build: PlannedBuild,
}

/// The plan of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub scene: String,
    pub lookups: Vec<Lookup>,
    pub tables: Vec<PlannedTable>,
    pub left_out: Vec<LeftOutRecord>,
    pub warnings: Vec<String>,
    /// Texel bytes of the planned tables, and of the default set built the same way.
    pub bytes: u64,
    pub default_set_bytes: u64,
}

impl Plan {
    pub fn record(&self) -> PlanRecord {
        PlanRecord {
            tables: self.tables.iter().map(|t| t.record.clone()).collect(),
            left_out: self.left_out.clone(),
            warnings: self.warnings.clone(),
            bytes: self.bytes,
            default_set_bytes: self.default_set_bytes,
            tir_fit: None,
        }
    }
}

/// Bytes of the texels a renderer binds for a full table: every node and channel at the stored
/// precision (`.bin` is f32; the FGD packings hold the same values).
pub fn recipe_texel_bytes(recipe: &dyn TableRecipe) -> Result<u64> {
    let nodes: usize = recipe.axes()?.iter().map(|a| a.count).product();
    let output = recipe.output();
    let value_bytes = if output.formats.iter().all(|&f| f == FileFormat::Bin) { 4 } else { output.precision.bytes() };
    Ok((nodes * recipe.channel_count() * value_bytes) as u64)
}

/// The plan of `scene`, with the table settings (samples, masking, precision) of `config`.
pub fn plan(scene: &Scene, config: &Config) -> Result<Plan> {
    config.validate()?;
    let (lookups, mut left_out) = lookups(scene);
    let margin = scene.margin_nodes;
    let mut tables: Vec<PlannedTable> = Vec::new();
    let full_fgd_axes = config.fgd.axes()?;
    let full_tir_axes = config.tir.axes()?;

    // Albedo on the FGD path: a slice per site of fixed indices, the 4D table over the hull of the rest.
    let fgd_lookups: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Albedo(AlbedoPath::Fgd)).collect();
    let (fixed, varying): (Vec<&Lookup>, Vec<&Lookup>) =
        fgd_lookups.iter().partition(|l| site_is_fixed(l, &fgd_lookups));
    for site in sites(&fixed) {
        let slices = slice_of(
            "fgd",
            SliceOf::Fgd(config.fgd.clone()),
            &site,
            &full_fgd_axes[0],
            &full_fgd_axes[1],
            site[0].alpha,
            margin,
        )?;
        add_slices(&mut tables, slices, &site, "FGD");
    }
    if !varying.is_empty() {
        let mu = covering_axis(&full_fgd_axes[0], hull(&varying, |l| l.mu), margin, false)?;
        let alpha = covering_axis(&full_fgd_axes[1], hull(&varying, |l| l.alpha), margin, false)?;
        let eta = covering_axis(&full_fgd_axes[2], hull(&varying, |l| l.eta), margin, true)?;
        let kappa = covering_axis(&full_fgd_axes[3], hull(&varying, |l| l.kappa), margin, true)?;
        let mut settings = config.fgd.clone();
        settings.mu_range = [mu.start, mu.end];
        settings.alpha_range = [alpha.start, alpha.end];
        settings.eta_range = [eta.start, eta.end];
        settings.kappa_range = [kappa.start, kappa.end];
        settings.mu_count = mu.count;
        settings.alpha_count = alpha.count;
        settings.eta_count = eta.count;
        settings.kappa_count = kappa.count;
        let counts = [mu.count, alpha.count, eta.count, kappa.count];
        let (kept, dropped): (Vec<Packing>, Vec<Packing>) =
            settings.packings.iter().partition(|p| p.extent(counts).is_ok());
        for packing in dropped {
            left_out.push(LeftOutRecord {
                what: format!("fgd packing `{}`", packing.name()),
                reason: format!("does not fit the sub-range table's {counts:?} nodes"),
            });
        }
        settings.packings = kept;
        let reasons = sites(&varying)
            .iter()
            .map(|site| format!("{}: an index varies, {}", site_label(site), ranges_label(site)))
            .collect();
        let record =
            record_of(&settings, "FGD 4D over the sub-range the lookups reach, on the full table's grid", reasons)?;
        tables.push(PlannedTable { record, build: PlannedBuild::Fgd(settings) });
    } else {
        let bytes = recipe_texel_bytes(&config.fgd)?;
        let reason = if fgd_lookups.is_empty() {
            "no material reads albedo on the FGD path".to_string()
        } else {
            format!("every FGD lookup is at fixed (eta, kappa): {}", replaced_by_slices(tables.len()))
        };
        left_out.push(LeftOutRecord { what: format!("fgd (4D, {})", human_bytes(bytes)), reason });
    }

    // Split-sum paths: their tables are 2D and answer every index through coefficients computed in the shader.
    for (path, recipe, description) in [
        (AlbedoPath::Belcour, PlannedBuild::Belcour(config.belcour.clone()), "Belcour split-sum, whole"),
        (AlbedoPath::Karis, PlannedBuild::Karis(config.karis.clone()), "Karis split-sum, whole"),
    ] {
        let users: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Albedo(path)).collect();
        let settings = recipe.recipe().expect("a full table");
        if users.is_empty() {
            left_out.push(LeftOutRecord {
                what: format!("{} ({})", settings.name(), human_bytes(recipe_texel_bytes(settings)?)),
                reason: format!("no material reads albedo on the {} path", settings.name()),
            });
            continue;
        }
        let mut reasons: Vec<String> = materials_of(&users)
            .into_iter()
            .map(|m| {
                format!(
                    "{m}: albedo = \"{}\"; 2D, the coefficients of every (eta, kappa) are computed in the shader",
                    settings.name()
                )
            })
            .collect();
        if path == AlbedoPath::Belcour && users.iter().any(|l| l.eta.lo < 1.0 && l.kappa.hi == 0.0) {
            reasons.push(
                "warning: some lookups are at a dielectric eta < 1 (from below), outside the basis's fitted domain; see the table's accuracy report".into(),
            );
        }
        let record = record_of(settings, description, reasons)?;
        tables.push(PlannedTable { record, build: recipe });
    }

    // TIR.
    let tir_lookups: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Tir(TirPath::Table)).collect();
    // The fitted form: fitted to the full TIR table, which is integrated but not written.
    let fit_users: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Tir(TirPath::Fit)).collect();
    if !fit_users.is_empty() {
        let reasons = sites(&fit_users)
            .iter()
            .map(|site| format!("{}: TIR by the fitted form, {}", site_label(site), ranges_label(site)))
            .collect();
        let record = PlannedTableRecord {
            name: "tir_fit".into(),
            kind: format!("TIR fitted form `{}` (tir_fit.hlsl, .wgsl; no table)", crate::fit::BUILD_FORM.name()),
            shape: format!(
                "{} coefficients, fitted to the full {} TIR table",
                crate::fit::BUILD_FORM.parameter_names().len(),
                full_tir_axes.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x ")
            ),
            bytes: 0,
            reasons,
        };
        tables.push(PlannedTable { record, build: PlannedBuild::TirFit(config.tir.clone()) });
    }
    for (path, why) in [
        (TirPath::Fit, "tir = \"fit\": the fitted analytic form (tir_fit) replaces the table"),
        (TirPath::Off, "tir = \"off\""),
    ] {
        let skipped: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Tir(path)).collect();
        for site in sites(&skipped) {
            left_out.push(LeftOutRecord { what: format!("TIR lookups of {}", site_label(&site)), reason: why.into() });
        }
    }
    let (fixed, varying): (Vec<&Lookup>, Vec<&Lookup>) =
        tir_lookups.iter().partition(|l| site_is_fixed(l, &tir_lookups));
    let slices_before = tables.len();
    for site in sites(&fixed) {
        let alpha_needed = Interval::new(site.iter().map(|l| l.alpha.lo).fold(1.0, f64::min), 1.0);
        let slices = slice_of(
            "tir",
            SliceOf::Tir(config.tir.clone()),
            &site,
            &full_tir_axes[0],
            &full_tir_axes[1],
            alpha_needed,
            margin,
        )?;
        add_slices(&mut tables, slices, &site, "TIR");
    }
    let tir_slices = tables.len() - slices_before;
    if !varying.is_empty() {
        let mu = covering_axis(&full_tir_axes[0], hull(&varying, |l| l.mu), margin, false)?;
        let alpha = covering_axis(&full_tir_axes[1], hull(&varying, |l| l.alpha), margin, false)?;
        let mut settings = config.tir.clone();
        settings.mu_range = [mu.start, mu.end];
        settings.alpha_range = [alpha.start, alpha.end];
        settings.mu_count = mu.count;
        settings.alpha_count = alpha.count;
        let reasons = sites(&varying)
            .iter()
            .map(|site| format!("{}: eta varies, {}; the eta axis stays whole", site_label(site), ranges_label(site)))
            .collect();
        let record = record_of(&settings, "TIR 3D over the mu and alpha the lookups reach", reasons)?;
        tables.push(PlannedTable { record, build: PlannedBuild::Tir(settings) });
    } else {
        let bytes = recipe_texel_bytes(&config.tir)?;
        let reason = if tir_lookups.is_empty() {
            "no lookup reads the TIR table (no crossing towards a lower index, or tir = \"fit\" / \"off\")".to_string()
        } else {
            format!("every TIR lookup is at a fixed eta: {}", replaced_by_slices(tir_slices))
        };
        left_out.push(LeftOutRecord { what: format!("tir (3D, {})", human_bytes(bytes)), reason });
    }

    // GD: the 6-flux model's lobe normalisation.
    let gd_users: Vec<&Lookup> = lookups.iter().filter(|l| l.kind == LookupKind::Gd).collect();
    if gd_users.is_empty() {
        left_out.push(LeftOutRecord {
            what: format!("gd ({})", human_bytes(recipe_texel_bytes(&config.gd)?)),
            reason: "no material uses the 6-flux model".into(),
        });
    } else {
        let reasons = materials_of(&gd_users)
            .into_iter()
            .map(|m| format!("{m}: 6-flux normalises its internal lobes by GD, at any cosine and any lobe roughness up to 1; kept whole"))
            .collect();
        let record = record_of(&config.gd, "GD 2D, whole", reasons)?;
        tables.push(PlannedTable { record, build: PlannedBuild::Gd(config.gd.clone()) });
    }

    let bytes = tables.iter().map(|t| t.record.bytes).sum();
    let default_set_bytes = config.recipes().iter().map(|r| recipe_texel_bytes(*r)).sum::<Result<u64>>()?;
    Ok(Plan {
        scene: scene.name.clone(),
        lookups,
        tables,
        left_out,
        warnings: scene.warnings.clone(),
        bytes,
        default_set_bytes,
    })
}

/// "N slice table(s) replace(s) it".
fn replaced_by_slices(count: usize) -> String {
    if count == 1 { "1 slice table replaces it".into() } else { format!("{count} slice tables replace it") }
}

/// Whether every lookup at `lookup`'s site has fixed indices.
fn site_is_fixed(lookup: &Lookup, all: &[&Lookup]) -> bool {
    all.iter().filter(|l| l.site() == lookup.site()).all(|l| l.fixed_index())
}

/// Lookups grouped by site, in the order the sites first appear.
fn sites<'a>(lookups: &[&'a Lookup]) -> Vec<Vec<&'a Lookup>> {
    let mut groups: Vec<Vec<&Lookup>> = Vec::new();
    for &lookup in lookups {
        match groups.iter_mut().find(|g| g[0].site() == lookup.site()) {
            Some(group) => group.push(lookup),
            None => groups.push(vec![lookup]),
        }
    }
    groups
}

fn materials_of(lookups: &[&Lookup]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for l in lookups {
        if !names.contains(&l.material) {
            names.push(l.material.clone());
        }
    }
    names
}

fn site_label(site: &[&Lookup]) -> String {
    let l = site[0];
    if l.layer == 0 {
        format!("{}, {}", l.material, l.direction)
    } else {
        format!("{}, layer {} {}", l.material, l.layer, l.direction)
    }
}

/// The smallest interval holding `parameter` of every lookup (not empty).
fn hull(lookups: &[&Lookup], parameter: fn(&Lookup) -> Interval) -> Interval {
    lookups.iter().map(|l| parameter(l)).reduce(Interval::hull).expect("at least one lookup")
}

fn ranges_label(site: &[&Lookup]) -> String {
    let h = |parameter| hull(site, parameter);
    format!("mu {}, alpha {}, eta {}, kappa {}", h(|l| l.mu), h(|l| l.alpha), h(|l| l.eta), h(|l| l.kappa))
}

/// The slice table of one site of fixed indices: one channel per distinct index.
fn slice_of(
    prefix: &str,
    of: SliceOf,
    site: &[&Lookup],
    full_mu: &Axis,
    full_alpha: &Axis,
    alpha_needed: Interval,
    margin: usize,
) -> Result<Slices> {
    let first = site[0];
    let mu_needed = hull(site, |l| l.mu);
    let mut channels: Vec<SliceChannel> = Vec::new();
    for l in site {
        let (eta, kappa) = (l.eta.lo, l.kappa.lo);
        match channels.iter_mut().find(|c| c.eta == eta && c.kappa == kappa) {
            Some(channel) => channel.used_by.push_str(&format!(", {}", CHANNEL_NAMES[l.channel])),
            None => channels.push(SliceChannel {
                eta,
                kappa,
                used_by: format!("{}: {}", site_label(site), CHANNEL_NAMES[l.channel]),
            }),
        }
    }
    let direction = first.direction.replace(' ', "-");
    Ok(Slices {
        name: format!("{prefix}_{}_l{}_{direction}", file_safe(&first.material), first.layer),
        of,
        mu: covering_axis(full_mu, mu_needed, margin, false)?,
        alpha: if alpha_needed.is_point() {
            exact_node_axis(full_alpha, alpha_needed.lo)?
        } else {
            covering_axis(full_alpha, alpha_needed, margin, false)?
        },
        lookup_mu: [mu_needed.lo, mu_needed.hi],
        lookup_alpha: [alpha_needed.lo, alpha_needed.hi],
        channels,
    })
}

/// Add a slice table, or, where an identical one is planned already (another material with the
/// same layer), add this site to its reasons.
fn add_slices(tables: &mut Vec<PlannedTable>, slices: Slices, site: &[&Lookup], what: &str) {
    let indices = slices.channels.iter().map(|c| format!("({}, {})", short(c.eta), short(c.kappa))).collect::<Vec<_>>();
    let reason = match what {
        "TIR" => format!(
            "{}: TIR at eta {} (crossing towards the lower index)",
            site_label(site),
            slices.channels.iter().map(|c| short(c.eta)).collect::<Vec<_>>().join(", ")
        ),
        _ => format!("{}: FGD at (eta, kappa) = {}", site_label(site), indices.join(", ")),
    };
    let same = |t: &PlannedTable| match &t.build {
        PlannedBuild::Slices(s) => {
            s.of == slices.of
                && s.mu == slices.mu
                && s.alpha == slices.alpha
                && s.channels.iter().map(|c| (c.eta, c.kappa)).eq(slices.channels.iter().map(|c| (c.eta, c.kappa)))
        }
        _ => false,
    };
    if let Some(existing) = tables.iter_mut().find(|t| same(t)) {
        existing.record.reasons.push(format!("{reason} (same slice)"));
        return;
    }
    let channel_count = slices.stored_channel_count();
    let record = PlannedTableRecord {
        name: slices.name.clone(),
        kind: format!("{what} slice"),
        shape: format!(
            "{} x {} (mu {}, alpha {}), {} channel{}{}",
            slices.mu.count,
            slices.alpha.count,
            range_label(&slices.mu),
            range_label(&slices.alpha),
            slices.channels.len(),
            if slices.channels.len() == 1 { "" } else { "s" },
            if channel_count > slices.channels.len() { " + 1 padding" } else { "" },
        ),
        bytes: slices.texel_bytes(),
        reasons: vec![reason],
    };
    tables.push(PlannedTable { record, build: PlannedBuild::Slices(slices) });
}

fn record_of(recipe: &dyn TableRecipe, kind: &str, reasons: Vec<String>) -> Result<PlannedTableRecord> {
    let axes = recipe.axes()?;
    Ok(PlannedTableRecord {
        name: recipe.name().into(),
        kind: kind.into(),
        shape: format!(
            "{} ({}), {} channel{}",
            axes.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x "),
            axes.iter().map(|a| format!("{} {}", a.name, range_label(a))).collect::<Vec<_>>().join(", "),
            recipe.channel_count(),
            if recipe.channel_count() == 1 { "" } else { "s" },
        ),
        bytes: recipe_texel_bytes(recipe)?,
        reasons,
    })
}

fn range_label(axis: &Axis) -> String {
    let (lo, hi) = if axis.start <= axis.end { (axis.start, axis.end) } else { (axis.end, axis.start) };
    Interval::new(lo, hi).to_string()
}

/// The nodes of the node-aligned, uniform axis `full` that cover `needed`, with `margin` more on
/// each side; with `extend`, the range may run past `full`'s end on the same spacing (an index
/// above the full table's range: the full table would clamp there).
pub fn covering_axis(full: &Axis, needed: Interval, margin: usize, extend: bool) -> Result<Axis> {
    let spacing = (full.end - full.start) / (full.count - 1) as f64;
    // A value within rounding of a node counts as that node.
    let position = |x: f64| (x - full.start) / spacing;
    let last_node = full.count - 1;
    let mut first = (position(needed.lo) + 1e-9).floor().max(0.0) as usize;
    let mut last = ((position(needed.hi) - 1e-9).ceil().max(0.0) as usize).max(first);
    first = first.saturating_sub(margin);
    last += margin;
    if !extend {
        last = last.min(last_node);
        first = first.min(last);
    }
    if first == last {
        if last < last_node || extend { last += 1 } else { first -= 1 }
    }
    let node = |k: usize| if k == last_node { full.end } else { full.start + k as f64 * spacing };
    Axis::node_aligned(full.name.clone(), node(first), node(last), last - first + 1)
}

/// Two nodes of `full`'s spacing, the first exactly at `value` (the last, at the end of the axis):
/// a parameter that never varies is then read at a node, with no interpolation error.
fn exact_node_axis(full: &Axis, value: f64) -> Result<Axis> {
    let spacing = (full.end - full.start) / (full.count - 1) as f64;
    let (start, end) = if value + spacing <= full.end { (value, value + spacing) } else { (value - spacing, value) };
    Axis::node_aligned(full.name.clone(), start, end, 2)
}

/// A material name as it may appear in a file name.
fn file_safe(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c.to_ascii_lowercase() } else { '-' }).collect()
}

pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 { format!("{bytes} B") } else { format!("{value:.1} {}", UNITS[unit]) }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "Plan for scene `{}`", self.scene)?;
        writeln!(f, "\nLookups the transfer-matrix model makes:")?;
        let refs: Vec<&Lookup> = self.lookups.iter().collect();
        for site in sites(&refs) {
            let kind = match site[0].kind {
                LookupKind::Albedo(AlbedoPath::Fgd) => "albedo (FGD)".to_string(),
                LookupKind::Albedo(AlbedoPath::Belcour) => "albedo (Belcour split-sum)".to_string(),
                LookupKind::Albedo(AlbedoPath::Karis) => "albedo (Karis split-sum)".to_string(),
                LookupKind::Tir(TirPath::Table) => "TIR (table)".to_string(),
                LookupKind::Tir(TirPath::Fit) => "TIR (fitted form)".to_string(),
                LookupKind::Tir(TirPath::Off) => "TIR (off)".to_string(),
                LookupKind::Gd => "GD".to_string(),
            };
            let channels: Vec<String> =
                site.iter().map(|l| format!("{} eta {} kappa {}", CHANNEL_NAMES[l.channel], l.eta, l.kappa)).collect();
            let l = site[0];
            if l.kind == LookupKind::Gd {
                writeln!(f, "  {:<34} {kind}: mu {}, alpha {}", site_label(&site), l.mu, l.alpha)?;
            } else {
                writeln!(
                    f,
                    "  {:<34} {kind}: mu {}, alpha {}; {}",
                    site_label(&site),
                    l.mu,
                    l.alpha,
                    channels.join("; ")
                )?;
            }
        }
        writeln!(f, "\nTables built:")?;
        for table in &self.tables {
            let r = &table.record;
            writeln!(f, "  {:<30} {:>10}  {}: {}", r.name, human_bytes(r.bytes), r.kind, r.shape)?;
            for reason in &r.reasons {
                writeln!(f, "  {:<30} {:>10}  - {reason}", "", "")?;
            }
        }
        writeln!(f, "\nLeft out:")?;
        for left in &self.left_out {
            writeln!(f, "  {}: {}", left.what, left.reason)?;
        }
        if !self.warnings.is_empty() {
            writeln!(f, "\nWarnings:")?;
            for warning in &self.warnings {
                writeln!(f, "  {warning}")?;
            }
        }
        writeln!(
            f,
            "\nTotal: {} ({} bytes) against {} ({} bytes) for the default set: {:.3} % of it",
            human_bytes(self.bytes),
            self.bytes,
            human_bytes(self.default_set_bytes),
            self.default_set_bytes,
            100.0 * self.bytes as f64 / self.default_set_bytes as f64
        )
    }
}
