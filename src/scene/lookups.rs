//! The lookups the transfer-matrix model makes for a scene's materials, recorded from the model
//! itself ([`lookups`]): each material is evaluated over the whole hemisphere of views and over
//! samples of the ranges its textures vary, and every lookup it makes (an interface's albedo from
//! above at the relative index `(eta, kappa) / eta_above`, a TIR correction at a crossing toward
//! the lower index, a lobe's GD) is kept with the hull of the parameters it was made at, per site
//! and colour channel. Nothing is looked up below an opaque conductor or at an index-matched
//! interface. [`super::plan`] derives the tables from them.

use serde::{Deserialize, Serialize};

use super::{AlbedoPath, Interval, Scene, SceneLayer, SceneMaterial, TirPath};
use crate::error::{Error, Result};
use crate::formats::manifest::LeftOutRecord;
use crate::integrate::GRAZING_COSINE;
use crate::model::{Lookup as ModelLookup, Quantity, Site, StandIn};
use crate::physics::fresnel_reflectance;
use crate::table::TableKind;

/// What a lookup reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LookupKind {
    /// Directional albedo (FGD, or a split-sum table on the Belcour and Karis paths).
    Albedo(AlbedoPath),
    Tir(TirPath),
    Gd,
}

/// The lookups the model makes at one site (material, layer, direction) and colour channel: the
/// range of every parameter they are made at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LookupRange {
    pub material: String,
    /// 1-based, top first.
    pub layer: usize,
    pub kind: LookupKind,
    /// From above (albedo), down or up (TIR crossings), or, with layer 0, every internal lobe (GD).
    pub site: Site,
    /// 0, 1, 2 for R, G, B.
    pub channel: usize,
    pub mu: Interval,
    pub alpha: Interval,
    pub eta: Interval,
    pub kappa: Interval,
}

impl LookupRange {
    pub(super) fn site(&self) -> (String, usize, Site) {
        (self.material.clone(), self.layer, self.site)
    }

    /// The site's direction as labels and slice file names spell it.
    pub fn direction(&self) -> &'static str {
        match self.site {
            // One site holds every lobe's GD (layer 0).
            Site::Lobe => "internal lobes",
            site => site.name(),
        }
    }

    pub(super) fn fixed_index(&self) -> bool {
        self.eta.is_point() && self.kappa.is_point()
    }
}

/// The lookups of every material of a scene, with what was noticed on the way (index-matched
/// interfaces, which need no lookup).
///
/// They are the lookups the model itself makes ([`crate::model::Material::evaluate`]), recorded
/// while it evaluates each material at [`PLANNING_VIEWS`] view cosines over the whole hemisphere,
/// for every sample of the ranges its textures vary ([`Material::variants`]); each site's and
/// channel's parameters are the hull of what was recorded. The lookups' parameters depend on the
/// stack's geometry and roughness alone, not on the tables' values, except the roughness of a
/// 2-flux lobe's GD, and GD is kept whole.
pub fn lookups(scene: &Scene) -> Result<(Vec<LookupRange>, Vec<LeftOutRecord>)> {
    check_planning_work(scene)?;
    // Materials are recorded on their own, in parallel, and joined in scene order.
    use rayon::prelude::*;
    let per_material: Vec<(Vec<LookupRange>, Vec<LeftOutRecord>)> =
        scene.materials.par_iter().map(material_lookups).collect::<Result<_>>()?;
    let mut lookups = Vec::new();
    let mut left_out = Vec::new();
    for (material_lookups, material_left_out) in per_material {
        lookups.extend(material_lookups);
        left_out.extend(material_left_out);
    }
    Ok((lookups, left_out))
}

/// The lookups of one material, as [`lookups`] records them.
fn material_lookups(material: &SceneMaterial) -> Result<(Vec<LookupRange>, Vec<LeftOutRecord>)> {
    let mut lookups: Vec<LookupRange> = Vec::new();
    let mut left_out = Vec::new();
    {
        note_index_matched(material, &mut left_out);
        // Where each (layer, direction, kind, channel) of this material is in `lookups`: one hash
        // look-up per recorded lookup, so that planning stays linear in layers and materials.
        let mut index: SiteIndex = SiteIndex::default();
        let recorded = std::cell::RefCell::new(Vec::new());
        // Stand-ins for the tables: which lookups are made, and where, does not depend on them.
        let recorder = |lookup: &ModelLookup| {
            recorded.borrow_mut().push(*lookup);
            match lookup.quantity {
                Quantity::Albedo => fresnel_reflectance(lookup.mu, lookup.eta, lookup.kappa),
                Quantity::Tir => 0.0,
                Quantity::Gd => 1.0,
            }
        };
        for stack in material.variants()? {
            let model = crate::model::Material::new(material.model, stack);
            for k in 0..PLANNING_VIEWS {
                let theta = std::f64::consts::FRAC_PI_2 * k as f64 / (PLANNING_VIEWS - 1) as f64;
                let mu = if k + 1 == PLANNING_VIEWS { GRAZING_COSINE } else { theta.cos() };
                let evaluation = model.evaluate(mu, &recorder);
                // The shader reads GD for every lobe below the top one and keeps it where the lobe
                // carries energy (a select, not a branch the generator can drop): a lobe that
                // carries none at every view (a coat over a conductor that reflects nothing) still
                // binds GD, so the plan must build it.
                for lobe in evaluation.lobes.iter().filter(|l| !l.is_top && l.energy.iter().all(|&e| e == 0.0)) {
                    recorded.borrow_mut().push(ModelLookup {
                        quantity: Quantity::Gd,
                        site: crate::model::Site::Lobe,
                        layer: lobe.layer,
                        channel: None,
                        mu: evaluation.mu,
                        alpha: lobe.roughness,
                        eta: 1.0,
                        kappa: 0.0,
                    });
                }
                // Merged after every evaluation, so that memory does not grow with the variants.
                for recorded in recorded.borrow_mut().drain(..) {
                    merge_lookup(material, &recorded, &mut lookups, &mut index);
                }
            }
        }
    }
    Ok((lookups, left_out))
}

/// Where each (layer, direction, kind, channel) of a material is in its lookups. Planning hashes
/// these keys for every lookup the model makes, millions for a library: a multiplicative hash
/// (Fx, as rustc's) rather than the default SipHash, which took a quarter of planning and whose
/// resistance to chosen keys these keys do not need.
type SiteIndex = std::collections::HashMap<(usize, Site, LookupKind, usize), usize, FxBuild>;

#[derive(Default, Clone, Copy)]
struct FxBuild;

impl std::hash::BuildHasher for FxBuild {
    type Hasher = FxHasher;
    fn build_hasher(&self) -> FxHasher {
        FxHasher(0)
    }
}

struct FxHasher(u64);

impl std::hash::Hasher for FxHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, word: usize) {
        self.write_u64(word as u64);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Add one lookup the model made to the hull of its site and channel.
fn merge_lookup(
    material: &SceneMaterial,
    recorded: &ModelLookup,
    lookups: &mut Vec<LookupRange>,
    index: &mut SiteIndex,
) {
    let (kind, site, layer) = match recorded.quantity {
        Quantity::Albedo => (LookupKind::Albedo(material.albedo), recorded.site, recorded.layer),
        Quantity::Tir => (LookupKind::Tir(material.tir), recorded.site, recorded.layer),
        // One site for every lobe's GD: the table is kept whole anyway.
        Quantity::Gd => (LookupKind::Gd, Site::Lobe, 0),
    };
    // A value that serves every channel is a lookup of each, except GD, which has none.
    let channels = match (recorded.channel, recorded.quantity) {
        (Some(c), _) => c..c + 1,
        (None, Quantity::Gd) => 0..1,
        (None, _) => 0..3,
    };
    for channel in channels {
        match index.get(&(layer, site, kind, channel)) {
            Some(&at) => {
                let l = &mut lookups[at];
                l.mu = l.mu.hull(Interval::point(recorded.mu));
                l.alpha = l.alpha.hull(Interval::point(recorded.alpha));
                l.eta = l.eta.hull(Interval::point(recorded.eta));
                l.kappa = l.kappa.hull(Interval::point(recorded.kappa));
            }
            None => {
                index.insert((layer, site, kind, channel), lookups.len());
                lookups.push(LookupRange {
                    material: material.name.clone(),
                    layer,
                    kind,
                    site,
                    channel,
                    mu: Interval::point(recorded.mu),
                    alpha: Interval::point(recorded.alpha),
                    eta: Interval::point(recorded.eta),
                    kappa: Interval::point(recorded.kappa),
                });
            }
        }
    }
}

/// Layer evaluations a plan may make ([`PLANNING_VIEWS`] views of every variant of every material,
/// each as many layers deep as the material): 2^25, about 15 s. On the project's 2-core machine
/// `tmlut plan` takes 3.8 s for 256 materials of 64 layers (8.4 million) and 4.6 s for one
/// 64-layer material whose textures vary six roughnesses (12 million; `docs/scenes.md`).
pub const MAX_PLANNING_WORK: u64 = 1 << 25;

/// Refuse a scene whose plan would evaluate the model more than [`MAX_PLANNING_WORK`] layers,
/// naming the materials that cost most.
fn check_planning_work(scene: &Scene) -> Result<()> {
    let cost = |m: &SceneMaterial| (m.variant_count() * PLANNING_VIEWS * m.layers.len()) as u64;
    let work: u64 = scene.materials.iter().map(cost).sum();
    if work <= MAX_PLANNING_WORK {
        return Ok(());
    }
    let mut costly: Vec<&SceneMaterial> = scene.materials.iter().collect();
    costly.sort_by_key(|m| std::cmp::Reverse(cost(m)));
    let named: Vec<String> = costly
        .iter()
        .take(3)
        .map(|m| {
            format!("`{}` ({} layers, {} stacks over its `vary` ranges)", m.name, m.layers.len(), m.variant_count())
        })
        .collect();
    Err(Error::invalid(
        format!("scene `{}`", scene.name),
        format!(
            "planning it evaluates {work} layers ({PLANNING_VIEWS} views of every stack of every material); allowed: \
             at most {MAX_PLANNING_WORK}. Most of it: {}. Vary fewer parameters per material, or split the scene",
            named.join(", ")
        ),
    ))
}

/// Whether some index of `lookup`'s ranges lies in the region of stand-in `stand_in`.
pub fn reaches(stand_in: &StandIn, lookup: &LookupRange) -> bool {
    stand_in.region.meets([lookup.eta.lo, lookup.eta.hi], [lookup.kappa.lo, lookup.kappa.hi])
}

/// View cosines the planner evaluates each material at, uniform in angle from the normal to
/// grazing (both included): 0.35 degrees apart.
pub const PLANNING_VIEWS: usize = 257;

/// Record each interface of `material` whose indices match the medium above in every channel:
/// the model skips it and looks nothing up there.
fn note_index_matched(material: &SceneMaterial, left_out: &mut Vec<LeftOutRecord>) {
    let mut eta_above = [Interval::point(1.0); 3];
    for (k, layer) in material.layers.iter().enumerate() {
        let SceneLayer::Interface(interface) = layer else { continue };
        let matched = (0..3).all(|c| {
            interface.eta[c].divide(eta_above[c]) == Interval::point(1.0) && interface.kappa[c] == Interval::point(0.0)
        });
        if matched {
            left_out.push(LeftOutRecord::new(
                format!("{}, layer {}: albedo and TIR lookups", material.name, k + 1),
                "index-matched (relative eta 1, kappa 0): the interface reflects nothing, the model needs no lookup",
            ));
        }
        if interface.is_conductor() {
            break;
        }
        eta_above = interface.eta;
    }
}

/// The lookups of table `table` that the scene file `path` makes ([`lookups`]), per material:
/// what `tmlut fit --form --weights SCENE.toml` weighs the table's points by. A lookup reads the
/// table when its kind does: FGD albedo `fgd` and the scene's `fgd_...` slices; TIR `tir` and
/// `tir_...`; GD `gd`; the split-sum paths `karis` and `belcour`; a stand-in (`fgd_rarer`,
/// [`crate::model::stand_in`]) the lookups of its quantity that reach its region.
pub fn table_lookups(path: &std::path::Path, table: &str) -> Result<crate::fit::forms::region::SceneLookups> {
    let (scene, _) = Scene::read(path)?;
    let (lookups, _) = lookups(&scene)?;
    let stand_in = TableKind::named(table).and_then(crate::model::stand_in);
    let is = |kind: TableKind| table == kind.name() || table.starts_with(&format!("{}_", kind.name()));
    let reads = |lookup: &LookupRange| match (stand_in, lookup.kind) {
        (Some(s), LookupKind::Albedo(AlbedoPath::Fgd)) => s.quantity == Quantity::Albedo && reaches(&s, lookup),
        (Some(s), LookupKind::Tir(TirPath::Table)) => s.quantity == Quantity::Tir && reaches(&s, lookup),
        (Some(_), _) => false,
        (None, LookupKind::Albedo(AlbedoPath::Fgd)) => is(TableKind::Fgd),
        (None, LookupKind::Albedo(AlbedoPath::Karis)) => table == TableKind::Karis.name(),
        (None, LookupKind::Albedo(AlbedoPath::Belcour)) => table == TableKind::Belcour.name(),
        (None, LookupKind::Tir(TirPath::Off)) => false,
        (None, LookupKind::Tir(_)) => is(TableKind::Tir),
        (None, LookupKind::Gd) => is(TableKind::Gd),
    };
    let mut materials: Vec<(String, Vec<crate::fit::forms::region::LookupHull>)> = Vec::new();
    for lookup in lookups.iter().filter(|l| reads(l)) {
        let hull = [lookup.mu, lookup.alpha, lookup.eta, lookup.kappa].map(|i| (i.lo, i.hi));
        match materials.iter_mut().find(|(m, _)| *m == lookup.material) {
            Some((_, hulls)) => hulls.push(hull),
            None => materials.push((lookup.material.clone(), vec![hull])),
        }
    }
    Ok(crate::fit::forms::region::SceneLookups { scene: path.to_path_buf(), table: table.to_string(), materials })
}
