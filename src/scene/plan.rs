//! The build plan of a scene: the fewest tables that answer the lookups the transfer-matrix model
//! makes for its materials ([`super::lookups`]).
//!
//! Tables follow from the lookups: where every lookup of a site is at fixed relative indices, a
//! specialised `(mu, alpha)` slice per site with one channel per distinct index
//! ([`crate::recipes::slices`]); where a texture varies an index, the full table over the sub-range
//! the lookups reach. Sub-ranges are whole nodes of the full table's grid plus `margin_nodes` on
//! each side, so slice nodes coincide with full-table nodes; a roughness that never varies gets a
//! node exactly at its value instead, so that it is read with no interpolation in alpha. GD, read
//! at every lobe roughness, is kept whole.

use std::collections::HashMap;
use std::fmt;

use super::lookups::{LookupKind, LookupRange, lookups, reaches};
use super::{AlbedoPath, Interval, Scene, TirPath, short};
use crate::config::{Config, MAX_NODES_PER_AXIS, TableSettings};
use crate::error::{Error, Result};
use crate::fit::forms::FittedForm;
use crate::formats::FileFormat;
use crate::formats::manifest::{LeftOutRecord, PlanRecord, PlannedTableRecord};
use crate::integrate::GRAZING_COSINE;
use crate::model::Quantity;
use crate::packing::Packing;
use crate::recipes::TableRecipe;
use crate::recipes::slices::{SliceChannel, SliceOf, Slices, lattice_value};
use crate::recipes::tir::TirSettings;
use crate::table::{Axis, Mapping, TableKind};

const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];

/// What a planned table is built from. A plan holds a handful of these, so the size of the largest
/// settings costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum PlannedBuild {
    /// A table of the registry ([`TableSettings`]), whole or over a sub-range of its axes.
    Table(TableSettings),
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
            PlannedBuild::Table(settings) => Some(settings.recipe()),
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
    pub lookups: Vec<LookupRange>,
    pub tables: Vec<PlannedTable>,
    pub left_out: Vec<LeftOutRecord>,
    pub warnings: Vec<String>,
    /// Texel bytes of the planned tables, and of the default set built the same way.
    pub bytes: u64,
    pub default_set_bytes: u64,
    /// Slices of one site that are identical (to the bit: table, settings, grid and indices) to
    /// one planned for another site, in this scene or another of the build: built once, shared.
    pub merged_slices: usize,
    /// The fitted forms the materials name in place of the TIR table (`tir = "fit:PATH"`), each
    /// once.
    pub tir_forms: Vec<FittedForm>,
    /// Those they name in place of an albedo table (`albedo = "fit:PATH"`), each once.
    pub albedo_forms: Vec<FittedForm>,
}

impl Plan {
    /// One line: the tables of the plan and their bytes against the default set's.
    pub fn summary(&self) -> String {
        format!(
            "scene `{}`: {} table(s) ({} identical slice(s) merged), {} of texels against {} for the default set",
            self.scene,
            self.tables.len(),
            self.merged_slices,
            human_bytes(self.bytes),
            human_bytes(self.default_set_bytes)
        )
    }

    pub fn record(&self) -> PlanRecord {
        let tables = self.tables.iter().map(|t| t.record.clone()).collect();
        let mut record =
            PlanRecord::new(tables, self.left_out.clone(), self.warnings.clone(), self.bytes, self.default_set_bytes);
        record.tir_forms = self.tir_forms.clone();
        record.albedo_forms = self.albedo_forms.clone();
        record
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

/// The plan of `scene`, with the table settings (samples, masking, precision) of `config`: the
/// lookups, then each quantity's planner in [`PLANNERS`] order, which is the order of the plan's
/// tables and of what it leaves out.
pub fn plan(scene: &Scene, config: &Config) -> Result<Plan> {
    config.validate()?;
    let (lookups, left_out) = lookups(scene)?;
    let albedo_forms_of: HashMap<&str, &FittedForm> =
        scene.materials.iter().filter_map(|m| m.albedo_form.as_ref().map(|f| (m.name.as_str(), f))).collect();
    let albedo_form_users = lookups
        .iter()
        .filter(|l| matches!(l.kind, LookupKind::Albedo(_)) && albedo_forms_of.contains_key(l.material.as_str()))
        .collect();
    let inputs = PlanInputs { scene, config, lookups: &lookups, albedo_forms_of, albedo_form_users };
    let mut parts = PlanParts { left_out, ..PlanParts::default() };
    for planner in PLANNERS {
        planner(&inputs, &mut parts)?;
    }
    let (tir_forms, albedo_forms) = named_forms(scene)?;
    let bytes = parts.tables.iter().map(|t| t.record.bytes).sum();
    let default_set_bytes =
        config.recipes().filter(|r| r.built_unnamed()).map(recipe_texel_bytes).sum::<Result<u64>>()?;
    Ok(Plan {
        scene: scene.name.clone(),
        lookups,
        tables: parts.tables,
        left_out: parts.left_out,
        warnings: scene.warnings.clone(),
        bytes,
        default_set_bytes,
        merged_slices: parts.merged_slices,
        tir_forms,
        albedo_forms,
    })
}

/// A quantity's planner: the tables, slices or forms that answer its lookups, added to `parts`,
/// and what it leaves out, with why. A new lookup path is a new planner and a line of [`PLANNERS`].
pub type Planner = fn(&PlanInputs, &mut PlanParts) -> Result<()>;

/// The planners, in the order of the plan's tables and of what it leaves out.
pub const PLANNERS: [Planner; 5] = [plan_albedo_forms, plan_fgd, plan_split_sums, plan_tir, plan_gd];

/// What every planner reads: the scene, its lookups and the configuration, and which materials
/// read albedo by a fitted form (`albedo = "fit:PATH"`), whose lookups no table answers.
pub struct PlanInputs<'a> {
    scene: &'a Scene,
    config: &'a Config,
    lookups: &'a [LookupRange],
    albedo_forms_of: HashMap<&'a str, &'a FittedForm>,
    albedo_form_users: Vec<&'a LookupRange>,
}

impl<'a> PlanInputs<'a> {
    /// The lookups of `kind`, those a table answers.
    fn by_table(&self, kind: LookupKind) -> Vec<&'a LookupRange> {
        self.lookups
            .iter()
            .filter(|l| l.kind == kind && !self.albedo_forms_of.contains_key(l.material.as_str()))
            .collect()
    }
}

/// What the planners add to: the tables, identical slices found once, what is left out.
#[derive(Default)]
pub struct PlanParts {
    tables: Vec<PlannedTable>,
    /// Each planned slice's place in `tables`, by a key of its exact grid and indices.
    planned_slices: HashMap<String, usize>,
    merged_slices: usize,
    left_out: Vec<LeftOutRecord>,
}

impl PlanParts {
    /// A slice per site of `fixed` (lookups at fixed indices), identical ones once; returns how
    /// many tables were added.
    fn add_site_slices(&mut self, fixed: &[&LookupRange], prefix: &str, of: &SliceOf) -> Result<usize> {
        let before = self.tables.len();
        for site in sites(fixed) {
            let slices = slice_of(prefix, of.clone(), &site)?;
            self.merged_slices += usize::from(add_slices(&mut self.tables, &mut self.planned_slices, slices, &site));
        }
        Ok(self.tables.len() - before)
    }
}

/// Albedo read by a fitted form (`albedo = "fit:PATH"`): no table.
fn plan_albedo_forms(inputs: &PlanInputs, parts: &mut PlanParts) -> Result<()> {
    for site in sites(&inputs.albedo_form_users) {
        let form = inputs.albedo_forms_of[site[0].material.as_str()];
        parts.left_out.push(LeftOutRecord::new(
            format!("albedo lookups of {}", site_label(&site)),
            format!("albedo = \"fit:{}\": the fitted form `{}` replaces the table", form.source, form.name),
        ));
    }
    Ok(())
}

/// Albedo on the FGD path: a slice per site of fixed indices, the 4D table over the hull of the rest.
fn plan_fgd(inputs: &PlanInputs, parts: &mut PlanParts) -> Result<()> {
    let (scene, config, margin) = (inputs.scene, inputs.config, inputs.scene.margin_nodes);
    let fgd_lookups = inputs.by_table(LookupKind::Albedo(AlbedoPath::Fgd));
    let (fixed, varying) = split_by_fixed_sites(&fgd_lookups);
    let slices = parts.add_site_slices(&fixed, TableKind::Fgd.name(), &SliceOf::Fgd(config.fgd.clone()))?;
    if varying.is_empty() {
        let bytes = recipe_texel_bytes(&config.fgd)?;
        let reason = if fgd_lookups.is_empty() {
            by_form_or_none(&inputs.albedo_form_users, AlbedoPath::Fgd)
        } else {
            format!("every FGD lookup is at fixed (eta, kappa): {}", replaced_by_slices(slices))
        };
        parts.left_out.push(LeftOutRecord::new(format!("fgd (4D, {})", human_bytes(bytes)), reason));
        return Ok(());
    }
    let full = config.fgd.axes()?;
    let who = sites_label(&scene.name, &varying, "FGD");
    let mu = covering_axis(&full[0], hull(&varying, |l| l.mu), margin, false, &who)?;
    let alpha = covering_axis(&full[1], hull(&varying, |l| l.alpha), margin, false, &who)?;
    let eta = covering_axis(&full[2], hull(&varying, |l| l.eta), margin, true, &who)?;
    let kappa = covering_axis(&full[3], hull(&varying, |l| l.kappa), margin, true, &who)?;
    let mut settings = config.fgd.clone();
    settings.mu_alpha.mu_range = [mu.start, mu.end];
    settings.mu_alpha.alpha_range = [alpha.start, alpha.end];
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
        parts.left_out.push(LeftOutRecord::new(
            format!("fgd packing `{}`", packing.name()),
            format!("does not fit the sub-range table's {counts:?} nodes"),
        ));
    }
    settings.packings = kept;
    let reasons = sites(&varying)
        .iter()
        .map(|site| format!("{}: an index varies, {}", site_label(site), ranges_label(site)))
        .collect();
    let record =
        record_of(&settings, "FGD 4D over the sub-range the lookups reach, on the full table's grid", reasons)?;
    parts.tables.push(PlannedTable { record, build: PlannedBuild::Table(TableSettings::Fgd(settings)) });
    plan_stand_ins(&mut parts.tables, config, Quantity::Albedo, &varying)
}

/// Split-sum paths: their tables are 2D and answer every index through coefficients computed in the shader.
fn plan_split_sums(inputs: &PlanInputs, parts: &mut PlanParts) -> Result<()> {
    let config = inputs.config;
    for (path, kind, description) in [
        (AlbedoPath::Belcour, TableKind::Belcour, "Belcour split-sum, whole"),
        (AlbedoPath::Karis, TableKind::Karis, "Karis split-sum, whole"),
    ] {
        let users = inputs.by_table(LookupKind::Albedo(path));
        let settings = config.recipe(kind);
        if users.is_empty() {
            parts.left_out.push(LeftOutRecord::new(
                format!("{} ({})", settings.name(), human_bytes(recipe_texel_bytes(settings)?)),
                by_form_or_none(&inputs.albedo_form_users, path),
            ));
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
        parts.tables.push(PlannedTable { record, build: PlannedBuild::Table(TableSettings::of(config, kind)) });
    }
    Ok(())
}

/// TIR: the fitted form where a material asks for it, what `off` and named forms leave out, a
/// slice per site of a fixed index, the 3D table over the `mu` and `alpha` the rest reach.
fn plan_tir(inputs: &PlanInputs, parts: &mut PlanParts) -> Result<()> {
    let (scene, config, margin) = (inputs.scene, inputs.config, inputs.scene.margin_nodes);
    let of_path = |path: TirPath| -> Vec<&LookupRange> {
        inputs.lookups.iter().filter(|l| l.kind == LookupKind::Tir(path)).collect()
    };
    let full = config.tir.axes()?;
    // The fitted form: fitted to the full TIR table, which is integrated but not written.
    let fit_users = of_path(TirPath::Fit);
    if !fit_users.is_empty() {
        let reasons = sites(&fit_users)
            .iter()
            .map(|site| format!("{}: TIR by the fitted form, {}", site_label(site), ranges_label(site)))
            .collect();
        let record = PlannedTableRecord::new(
            "tir_fit",
            format!(
                "TIR fitted form `{}` (tir_fit.hlsl, .wgsl; no table)",
                crate::fit::forms::build::BUILD_FORM_FILE.trim_end_matches(".toml")
            ),
            format!(
                "{} coefficients, fitted to the full {} TIR table",
                crate::fit::forms::build::build_form().map_or(0, |form| form.parameters.len()),
                full.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x ")
            ),
            0,
            reasons,
        );
        parts.tables.push(PlannedTable { record, build: PlannedBuild::TirFit(config.tir.clone()) });
    }
    for (path, why) in [
        (TirPath::Fit, "tir = \"fit\": the fitted analytic form (tir_fit) replaces the table"),
        (TirPath::Off, "tir = \"off\""),
    ] {
        for site in sites(&of_path(path)) {
            parts.left_out.push(LeftOutRecord::new(format!("TIR lookups of {}", site_label(&site)), why));
        }
    }
    for site in sites(&of_path(TirPath::Form)) {
        let form = scene.materials.iter().find(|m| m.name == site[0].material).and_then(|m| m.tir_form.as_ref());
        parts.left_out.push(LeftOutRecord::new(
            format!("TIR lookups of {}", site_label(&site)),
            match form {
                Some(form) => {
                    format!("tir = \"fit:{}\": the fitted form `{}` replaces the table", form.source, form.name)
                }
                None => "tir names a fitted form".into(),
            },
        ));
    }
    let tir_lookups = of_path(TirPath::Table);
    let (fixed, varying) = split_by_fixed_sites(&tir_lookups);
    let slices = parts.add_site_slices(&fixed, TableKind::Tir.name(), &SliceOf::Tir(config.tir.clone()))?;
    if varying.is_empty() {
        let bytes = recipe_texel_bytes(&config.tir)?;
        let reason = if tir_lookups.is_empty() {
            "no lookup reads the TIR table (no crossing towards a lower index, or tir = \"fit\" / \"off\")".to_string()
        } else {
            format!("every TIR lookup is at a fixed eta: {}", replaced_by_slices(slices))
        };
        parts.left_out.push(LeftOutRecord::new(format!("tir (3D, {})", human_bytes(bytes)), reason));
        return Ok(());
    }
    let who = sites_label(&scene.name, &varying, "TIR");
    let mu = covering_axis(&full[0], hull(&varying, |l| l.mu), margin, false, &who)?;
    let alpha = covering_axis(&full[1], hull(&varying, |l| l.alpha), margin, false, &who)?;
    let mut settings = config.tir.clone();
    settings.mu_alpha.mu_range = [mu.start, mu.end];
    settings.mu_alpha.alpha_range = [alpha.start, alpha.end];
    settings.mu_count = mu.count;
    settings.alpha_count = alpha.count;
    let reasons = sites(&varying)
        .iter()
        .map(|site| format!("{}: eta varies, {}; the eta axis stays whole", site_label(site), ranges_label(site)))
        .collect();
    let record = record_of(&settings, "TIR 3D over the mu and alpha the lookups reach", reasons)?;
    parts.tables.push(PlannedTable { record, build: PlannedBuild::Table(TableSettings::Tir(settings)) });
    plan_stand_ins(&mut parts.tables, config, Quantity::Tir, &varying)
}

/// GD: the 6-flux model's lobe normalisation, and the 2-flux lobes' albedo; kept whole.
fn plan_gd(inputs: &PlanInputs, parts: &mut PlanParts) -> Result<()> {
    let config = inputs.config;
    let gd_users: Vec<&LookupRange> = inputs.lookups.iter().filter(|l| l.kind == LookupKind::Gd).collect();
    if gd_users.is_empty() {
        parts.left_out.push(LeftOutRecord::new(
            format!("gd ({})", human_bytes(recipe_texel_bytes(&config.gd)?)),
            "no material uses the 6-flux model",
        ));
        return Ok(());
    }
    let reasons = materials_of(&gd_users)
        .into_iter()
        .map(|m| format!("{m}: every internal lobe reads GD at its own roughness (2-flux: the lobe's albedo is its energy times GD; 6-flux: lobes are normalised by it); kept whole"))
        .collect();
    let record = record_of(&config.gd, "GD 2D, whole", reasons)?;
    parts.tables.push(PlannedTable { record, build: PlannedBuild::Table(TableSettings::of(config, TableKind::Gd)) });
    Ok(())
}

/// The stand-ins of `quantity` ([`crate::model::stand_in`]) that some of `varying` (the lookups no
/// slice answers) reach, whole: a folder answers those lookups from them ahead of the full table.
fn plan_stand_ins(
    tables: &mut Vec<PlannedTable>,
    config: &Config,
    quantity: Quantity,
    varying: &[&LookupRange],
) -> Result<()> {
    for stand_in in crate::model::stand_ins().filter(|s| s.quantity == quantity) {
        let reached: Vec<&LookupRange> = varying.iter().copied().filter(|l| reaches(&stand_in, l)).collect();
        if reached.is_empty() {
            continue;
        }
        let reasons = sites(&reached)
            .iter()
            .map(|site| format!("{}: {}, {}", site_label(site), stand_in.why, ranges_label(site)))
            .collect();
        let settings = TableSettings::of(config, stand_in.table);
        let record = record_of(settings.recipe(), &format!("{}, whole", stand_in.what), reasons)?;
        tables.push(PlannedTable { record, build: PlannedBuild::Table(settings) });
    }
    Ok(())
}

/// Why no table of albedo path `path` is built: its lookups are all read by fitted forms, or there
/// are none.
fn by_form_or_none(form_users: &[&LookupRange], path: AlbedoPath) -> String {
    let name = if path == AlbedoPath::Fgd { "FGD" } else { path.name() };
    if form_users.iter().any(|l| l.kind == LookupKind::Albedo(path)) {
        format!("every albedo lookup on the {name} path is read by a fitted form (albedo = \"fit:PATH\")")
    } else {
        format!("no material reads albedo on the {name} path")
    }
}

/// The fitted forms the scene's materials name, each once: those in place of the TIR table, then
/// those in place of an albedo table. Two different forms of one name (one shader function name)
/// are refused, whichever tables they replace.
fn named_forms(scene: &Scene) -> Result<(Vec<FittedForm>, Vec<FittedForm>)> {
    let mut forms: Vec<FittedForm> = Vec::new();
    let named = scene.materials.iter().flat_map(|m| {
        [("tir", &m.tir_form), ("albedo", &m.albedo_form)]
            .into_iter()
            .filter_map(move |(key, f)| Some((m, key, f.as_ref()?)))
    });
    for (material, key, form) in named {
        match forms.iter().find(|f| f.name == form.name) {
            Some(other) if other == form => {}
            Some(other) => {
                return Err(Error::invalid(
                    format!("scene `{}`, material `{}`: {key}", scene.name, material.name),
                    format!(
                        "fit:{} holds form `{}`, and another material's fit:{} holds a different form of that name; \
                         one scene's forms need different names (their shader function is tmlut_<name>)",
                        form.source, form.name, other.source
                    ),
                ));
            }
            None => forms.push(form.clone()),
        }
    }
    Ok(forms.into_iter().partition(|f| f.table == TableKind::Tir.name()))
}

/// "N slice table(s) replace(s) it".
fn replaced_by_slices(count: usize) -> String {
    if count == 1 { "1 slice table replaces it".into() } else { format!("{count} slice tables replace it") }
}

/// `lookups` split into those whose site has fixed indices in every lookup, and the others.
fn split_by_fixed_sites<'a>(lookups: &[&'a LookupRange]) -> (Vec<&'a LookupRange>, Vec<&'a LookupRange>) {
    let varying_sites: std::collections::HashSet<_> =
        lookups.iter().filter(|l| !l.fixed_index()).map(|l| l.site()).collect();
    lookups.iter().partition(|l| !varying_sites.contains(&l.site()))
}

/// Lookups grouped by site, in the order the sites first appear.
fn sites<'a>(lookups: &[&'a LookupRange]) -> Vec<Vec<&'a LookupRange>> {
    let mut groups: Vec<Vec<&LookupRange>> = Vec::new();
    let mut index: std::collections::HashMap<_, usize> = std::collections::HashMap::new();
    for &lookup in lookups {
        match index.get(&lookup.site()) {
            Some(&at) => groups[at].push(lookup),
            None => {
                index.insert(lookup.site(), groups.len());
                groups.push(vec![lookup]);
            }
        }
    }
    groups
}

fn materials_of(lookups: &[&LookupRange]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for l in lookups {
        if !names.contains(&l.material) {
            names.push(l.material.clone());
        }
    }
    names
}

fn site_label(site: &[&LookupRange]) -> String {
    let l = site[0];
    if l.layer == 0 {
        format!("{}, {}", l.material, l.direction())
    } else {
        format!("{}, layer {} {}", l.material, l.layer, l.direction())
    }
}

/// The sites of `lookups`, for an error: `scene `s`, FGD lookups of m, layer 2 from above; ...`.
fn sites_label(scene: &str, lookups: &[&LookupRange], what: &str) -> String {
    let labels: Vec<String> = sites(lookups).iter().map(|site| site_label(site)).collect();
    format!("scene `{scene}`, {what} lookups of {}", labels.join("; "))
}

/// The smallest interval holding `parameter` of every lookup (not empty).
fn hull(lookups: &[&LookupRange], parameter: fn(&LookupRange) -> Interval) -> Interval {
    lookups.iter().map(|l| parameter(l)).reduce(Interval::hull).expect("at least one lookup")
}

fn ranges_label(site: &[&LookupRange]) -> String {
    let h = |parameter| hull(site, parameter);
    format!("mu {}, alpha {}, eta {}, kappa {}", h(|l| l.mu), h(|l| l.alpha), h(|l| l.eta), h(|l| l.kappa))
}

/// The slice table of one site of fixed indices: one channel per distinct index.
fn slice_of(prefix: &str, of: SliceOf, site: &[&LookupRange]) -> Result<Slices> {
    let first = site[0];
    let [mu_lattice, alpha_lattice] = of.lattice();
    let mu_needed = hull(site, |l| l.mu);
    let alpha_needed = hull(site, |l| l.alpha);
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
    let direction = first.direction().replace(' ', "-");
    Ok(Slices {
        name: format!("{prefix}_{}_l{}_{direction}", file_safe(&first.material), first.layer),
        of,
        mu: slice_mu_axis(mu_needed, mu_lattice)?,
        alpha: slice_alpha_axis(alpha_needed, alpha_lattice)?,
        lookup_mu: [mu_needed.lo, mu_needed.hi],
        lookup_alpha: [alpha_needed.lo, alpha_needed.hi],
        channels,
    })
}

/// Add a slice table, or, where an identical one is planned already (another material with the
/// same layer), add this site to its reasons and return true.
fn add_slices(
    tables: &mut Vec<PlannedTable>,
    planned_slices: &mut std::collections::HashMap<String, usize>,
    slices: Slices,
    site: &[&LookupRange],
) -> bool {
    let (what, reason) = match slices.of {
        SliceOf::Fgd(_) => {
            let indices: Vec<String> =
                slices.channels.iter().map(|c| format!("({}, {})", short(c.eta), short(c.kappa))).collect();
            ("FGD", format!("{}: FGD at (eta, kappa) = {}", site_label(site), indices.join(", ")))
        }
        SliceOf::Tir(_) => {
            let etas: Vec<String> = slices.channels.iter().map(|c| short(c.eta)).collect();
            ("TIR", format!("{}: TIR at eta {} (crossing towards the lower index)", site_label(site), etas.join(", ")))
        }
    };
    // Identical slices (same table, grid and indices) are one table; found by a key of their exact
    // values, in constant time, so that the plan stays linear in the number of sites.
    let channel_indices: Vec<(u64, u64)> =
        slices.channels.iter().map(|c| (c.eta.to_bits(), c.kappa.to_bits())).collect();
    let key = format!("{what}|{:?}|{:?}|{channel_indices:?}", slices.mu, slices.alpha);
    if let Some(&existing) = planned_slices.get(&key) {
        tables[existing].record.reasons.push(format!("{reason} (same slice)"));
        return true;
    }
    planned_slices.insert(key, tables.len());
    let channel_count = slices.stored_channel_count();
    let record = PlannedTableRecord::new(
        slices.name.clone(),
        format!("{what} slice"),
        format!(
            "{} x {} (mu {}, alpha {}), {} channel{}{}",
            slices.mu.count,
            slices.alpha.count,
            range_label(&slices.mu),
            range_label(&slices.alpha),
            slices.channels.len(),
            if slices.channels.len() == 1 { "" } else { "s" },
            if channel_count > slices.channels.len() { " + 1 padding" } else { "" },
        ),
        slices.texel_bytes(),
        vec![reason],
    );
    tables.push(PlannedTable { record, build: PlannedBuild::Slices(slices) });
    false
}

fn record_of(recipe: &dyn TableRecipe, kind: &str, reasons: Vec<String>) -> Result<PlannedTableRecord> {
    crate::recipes::check_demand(recipe)?;
    let axes = recipe.axes()?;
    Ok(PlannedTableRecord::new(
        recipe.name(),
        kind,
        format!(
            "{} ({}), {} channel{}",
            axes.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x "),
            axes.iter().map(|a| format!("{} {}", a.name, range_label(a))).collect::<Vec<_>>().join(", "),
            recipe.channel_count(),
            if recipe.channel_count() == 1 { "" } else { "s" },
        ),
        recipe_texel_bytes(recipe)?,
        reasons,
    ))
}

fn range_label(axis: &Axis) -> String {
    let (lo, hi) = axis.bounds();
    Interval::new(lo, hi).to_string()
}

/// The nodes of the node-aligned axis `full` (evenly spaced in its mapping) that cover `needed`, with `margin` more on
/// each side; with `extend`, the range may run past `full`'s end on the same spacing (an index
/// above the full table's range: the full table would clamp there). `who` names the lookups in
/// the error when the range needs more than [`MAX_NODES_PER_AXIS`] nodes.
pub fn covering_axis(full: &Axis, needed: Interval, margin: usize, extend: bool, who: &str) -> Result<Axis> {
    // Node positions along the axis, in its mapped quantity (nodes are evenly spaced there); a
    // value within rounding of a node counts as that node. Node numbers stay in f64 until they
    // are known to be small: a far index would saturate a conversion and wrap the sums after it.
    let position = |x: f64| full.coordinate(x) * (full.count - 1) as f64;
    let first = (position(needed.lo) + 1e-9).floor().max(0.0);
    let last = (position(needed.hi) - 1e-9).ceil().max(0.0).max(first);
    let (first, last) = (first - (margin as f64).min(first), last + margin as f64);
    // NaN positions (an infinite range) fail this too.
    let within = last - first < MAX_NODES_PER_AXIS as f64;
    if !within {
        return Err(Error::invalid(
            who,
            format!(
                "its lookups reach {} {} to {}, which the table's grid ({} nodes over {} to {}) covers with {} \
                 nodes; allowed: at most {MAX_NODES_PER_AXIS} nodes per axis (narrow the range a texture varies)",
                full.name,
                short(needed.lo),
                short(needed.hi),
                full.count,
                short(full.start),
                short(full.end),
                last - first + 1.0
            ),
        ));
    }
    let last_node = full.count - 1;
    let (mut first, mut last) = (first as usize, last as usize);
    if !extend {
        last = last.min(last_node);
        first = first.min(last);
    }
    if first == last {
        if last < last_node || extend { last += 1 } else { first -= 1 }
    }
    // Past the last node (where `extend` allows it) the nodes continue at the same spacing.
    let node = |k: usize| if k <= last_node { full.node_value(k) } else { full.value_at(k as f64 / last_node as f64) };
    Axis::node_aligned(full.name.clone(), node(first), node(last), last - first + 1)?.with_mapping(full.mapping)
}

/// A slice's `mu` axis over exactly the cosines its lookups reach, widened to the nodes of its
/// table's slice lattice (`lattice` nodes per unit; [`SliceOf::lattice`]) around them. From
/// grazing (`mu = 0`, the limit at [`GRAZING_COSINE`]) it is spaced in `sqrt(mu)`, dense where the
/// albedo of smooth interfaces turns fastest; elsewhere in `mu`.
fn slice_mu_axis(needed: Interval, lattice: f64) -> Result<Axis> {
    let (lo, hi) = (needed.lo, needed.hi);
    if lo <= GRAZING_COSINE {
        return lattice_axis("mu", 0.0, hi, Mapping::Sqrt, lattice);
    }
    lattice_axis("mu", lo, hi, Mapping::Identity, lattice)
}

/// A slice's `alpha` axis: the lattice nodes (in `sqrt(alpha)`) around the roughnesses its lookups
/// reach; a roughness that never varies falls between two of them, or on one.
fn slice_alpha_axis(needed: Interval, lattice: f64) -> Result<Axis> {
    lattice_axis("alpha", needed.lo, needed.hi, Mapping::Sqrt, lattice)
}

/// Within this of a lattice node (in lattice units), a value counts as on it.
const LATTICE_TOLERANCE: f64 = 1e-9;

/// The node-aligned axis over the nodes of a lattice of `lattice` nodes per unit of `mapping`
/// (within `[0, 1]`) that cover `[lo, hi]`; at least two nodes.
fn lattice_axis(name: &str, lo: f64, hi: f64, mapping: Mapping, lattice: f64) -> Result<Axis> {
    let mut first = (mapping.forward(lo) * lattice + LATTICE_TOLERANCE).floor().clamp(0.0, lattice);
    let mut last = (mapping.forward(hi) * lattice - LATTICE_TOLERANCE).ceil().clamp(first, lattice);
    if first == last {
        if last < lattice { last += 1.0 } else { first -= 1.0 }
    }
    let node = |k: f64| lattice_value(mapping, k, lattice);
    Axis::node_aligned(name, node(first), node(last), (last - first) as usize + 1)?.with_mapping(mapping)
}

/// A material name as it may appear in a file name: the one mapping the scene parser holds names
/// apart by.
fn file_safe(name: &str) -> String {
    super::file_name_part(name)
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
        let refs: Vec<&LookupRange> = self.lookups.iter().collect();
        for site in sites(&refs) {
            let kind = match site[0].kind {
                LookupKind::Albedo(AlbedoPath::Fgd) => "albedo (FGD)".to_string(),
                LookupKind::Albedo(AlbedoPath::Belcour) => "albedo (Belcour split-sum)".to_string(),
                LookupKind::Albedo(AlbedoPath::Karis) => "albedo (Karis split-sum)".to_string(),
                LookupKind::Tir(TirPath::Table) => "TIR (table)".to_string(),
                LookupKind::Tir(TirPath::Fit) => "TIR (fitted form)".to_string(),
                LookupKind::Tir(TirPath::Off) => "TIR (off)".to_string(),
                LookupKind::Tir(TirPath::Form) => "TIR (named form)".to_string(),
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
            "\nIdentical slices merged: {} (built once, read by every site listed under them)",
            self.merged_slices
        )?;
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
