//! The files of a built folder answering the model's lookups exactly as a renderer reads them.
//!
//! - Textures (`.dds` and `.ktx2`, the DDS file where a table is in both, and the `.bin` tables of
//!   up to three axes, which a shader binds as textures) are sampled the way a GPU samples them: the manifest's texture coordinate computed in f32,
//!   cell-centred linear filtering with clamp addressing in f32, texels as stored (f16 widened
//!   exactly), through [`crate::packing::emulator`].
//! - The 4D FGD table has no texture: its GPU packing (`fgd_lossless.dds` or `.ktx2`) is read through the very
//!   lookup program its shader files print ([`crate::packing::PackedFgd`]), or the 4D table (`fgd.exr`,
//!   or `fgd.bin` in the original layout) is
//!   interpolated on the CPU in 4D as the reference plugin does.
//! - A scene folder's slices are found by the indices their channels hold fixed, and the slice
//!   whose `(mu, alpha)` range holds the lookup answers it.
//! - A stand-in table ([`super::lookup::stand_in`]: `fgd_rarer`) answers its quantity's lookups at
//!   the indices of its region where no slice holds them, ahead of the quantity's full table.
//! - The split-sum paths compute their Fresnel coefficients as a shader does: Belcour's from the
//!   basis in the manifest, Karis's `F0` from the relative index at normal incidence.
//! - The fitted TIR form is evaluated in f32 with the manifest's coefficients, as its shader; a
//!   form a material names (`tir = "fit:PATH"`) in f32 with its fitted parameters
//!   ([`FolderTables::with_tir_form`]).
//!
//! A lookup no file of the folder can answer reads 0 and is recorded: [`FolderTables::misses`]
//! says what was asked that the folder does not hold, so a caller can refuse the result.

use std::sync::Mutex;

use super::lookup::{AlbedoPath, Lookup, Quantity, Site, StandIn, Tables, TirPath};
use crate::error::{Error, Result};
use crate::fit::text::compile::FormEvaluator;
#[cfg(feature = "generator")]
use crate::fit::text::fitted::{FittedForm, FittedFormExt};
use crate::formats::FileFormat;
use crate::formats::manifest::{FileEntry, FitEntry};
use crate::loader::LutFolder;
use crate::loader::texture::SampledTable;
use crate::packing::{Filter, PackedFgd, Packing};
use crate::physics::{FresnelBasis, normal_incidence_reflectance};
use crate::table::derived::point_of;
use crate::table::{Arithmetic, Axis, Table, TableKind};

/// How far outside a slice's range (in units of the range) a lookup may lie and still count as
/// inside it, when slices holding the same index compete. A scene's slices end exactly at the
/// extreme lookups their sites make, so lookups land on those ends; the slack makes the choice the
/// same whether the lookup was computed in f64 here or in f32 by the scene's shader
/// ([`crate::shader::scene`]), whose rounding is below 1e-6 of any range. Whether a slice holds a
/// lookup a rounding from its end can still differ between the two ([`slice_choice_distance`]);
/// the slice that holds it then holds the lattice node at that end too, whose value both slices
/// share (a build integrates a shared node once), so the two read the same node.
pub const SLICE_CHOICE_SLACK: f64 = 1e-5;

/// The distance by which slices holding a lookup's index compete for it (the least wins, the
/// first of equals): -1 where every axis's range holds `point` (`lo <= x <= hi`), else the sum
/// over the axes of how far outside the range it lies, in units of the range, less
/// [`SLICE_CHOICE_SLACK`] per axis (so 0 within the slack). The scene's shader prints the same
/// code ([`slice_choice_distance_in`]) and chooses by it in f32 ([`crate::shader::scene`]).
///
/// A slice that holds the lookup beats one that merely lies within the slack of it: slices of
/// different materials end on the same lattice nodes, so a lookup a rounding below the node where
/// one slice begins may lie inside another slice at that index, and taking the first within the
/// slack read it clamped at the first slice's edge (`absorbing-coat-00482` of the generated
/// library, TIR at `alpha = (80/128)^2` minus a rounding).
pub fn slice_choice_distance(axes: &[Axis], point: &[f64]) -> f64 {
    slice_choice_distance_in(axes, point)
}

/// [`slice_choice_distance`] in the arithmetic of `point`.
pub fn slice_choice_distance_in<T: Arithmetic>(axes: &[Axis], point: &[T]) -> T {
    let zero = T::of(0.0);
    let mut holds: Option<T::Condition> = None;
    let mut outside: Option<T> = None;
    for (axis, x) in axes.iter().zip(point) {
        let (lo, hi) = axis.bounds();
        for condition in [T::of(lo).at_most(x.clone()), x.clone().at_most(T::of(hi))] {
            holds = Some(match holds {
                Some(held) => T::both(held, condition),
                None => condition,
            });
        }
        let below_and_above = (T::of(lo) - x.clone()).max(zero.clone()) + (x.clone() - T::of(hi)).max(zero.clone());
        let beyond = (below_and_above / T::of(hi - lo) - T::of(SLICE_CHOICE_SLACK)).max(zero.clone());
        outside = Some(match outside {
            Some(sum) => sum + beyond,
            None => beyond,
        });
    }
    match (holds, outside) {
        (Some(holds), Some(outside)) => T::select(holds, T::of(-1.0), outside),
        _ => T::of(-1.0),
    }
}

/// A scene's slice: a 2D `(mu, alpha)` table with one channel per fixed relative index.
#[derive(Debug, Clone)]
struct Slice {
    quantity: Quantity,
    /// `(eta, kappa)` of each channel (kappa 0 for TIR).
    indices: Vec<(f64, f64)>,
    texture: SampledTable,
}

/// A folder's slices of one quantity, with their channels sorted by `eta`: a library holds
/// thousands, and a lookup finds the few at its index by a binary search, not by reading them all.
#[derive(Debug, Clone)]
struct Slices {
    slices: Vec<Slice>,
    /// `(eta, slice, channel)` of every channel, by `eta`.
    by_eta: Vec<(f64, usize, usize)>,
}

impl Slices {
    fn new(slices: Vec<Slice>) -> Self {
        let mut by_eta: Vec<(f64, usize, usize)> = slices
            .iter()
            .enumerate()
            .flat_map(|(s, slice)| slice.indices.iter().enumerate().map(move |(c, &(eta, _))| (eta, s, c)))
            .collect();
        by_eta.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        Slices { slices, by_eta }
    }

    /// The slices with a channel at `(eta, kappa)` (equal to within 1e-12 of the larger, the
    /// tolerance f32 and f64 lookups of one index agree to), each with its first such channel,
    /// in the folder's order.
    fn at(&self, quantity: Quantity, eta: f64, kappa: f64) -> Vec<(&Slice, usize)> {
        let same = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        // Within the tolerance, |a - b| < 2e-12 |eta|: the window holds every candidate.
        let reach = 2e-12 * eta.abs();
        let from = self.by_eta.partition_point(|e| e.0 < eta - reach);
        let to = self.by_eta.partition_point(|e| e.0 <= eta + reach);
        let mut found: Vec<(usize, usize)> = Vec::new();
        for &(_, s, c) in &self.by_eta[from..to] {
            let slice = &self.slices[s];
            let (e, k) = slice.indices[c];
            if slice.quantity == quantity && same(e, eta) && same(k, kappa) {
                found.push((s, c));
            }
        }
        // Each slice once, at its first matching channel.
        found.sort_unstable();
        found.dedup_by_key(|&mut (s, _)| s);
        found.into_iter().map(|(s, c)| (&self.slices[s], c)).collect()
    }
}

/// Where the FGD path reads a full table.
#[derive(Debug, Clone)]
enum FullFgd {
    /// The 4D table (`fgd.exr`, or `fgd.bin` in the original layout), interpolated on the CPU.
    Table(Table),
    /// A GPU packing read through its shader's lookup program.
    Packed(Box<PackedFgd>),
}

/// Which full FGD table the FGD path reads, where a folder holds both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FgdSource {
    /// The lossless GPU packing where the folder has it, else the 4D table.
    #[default]
    Packing,
    /// The 4D table (`fgd.exr`, or `fgd.bin` in the original layout), interpolated on the CPU.
    Table,
}

#[derive(Debug, Clone)]
enum Albedo {
    Fgd {
        slices: Slices,
        full: Option<FullFgd>,
    },
    Belcour {
        texture: SampledTable,
        basis: Box<FresnelBasis>,
    },
    Karis {
        texture: SampledTable,
    },
    /// A form the material names in place of the table (`albedo = "fit:PATH"`): fitted to Karis's
    /// split sum (`split_sum`: its channels weighed by F0 as the table's are) or to FGD. Read by
    /// the generator's form files only.
    #[cfg(feature = "generator")]
    Form {
        form: FormEvaluator,
        split_sum: bool,
    },
    /// The folder holds no table of the path: every albedo lookup misses.
    Absent,
}

#[derive(Debug, Clone)]
enum Tir {
    Table {
        slices: Slices,
        full: Option<SampledTable>,
    },
    /// The folder's fitted form (compiled from the manifest's definition), or a form the
    /// material names (`tir = "fit:PATH"`, read by the generator's form files).
    Form(FormEvaluator),
    Off,
    /// The folder holds no TIR table or fitted form: every TIR lookup misses.
    Absent,
}

/// What a folder could not answer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Misses {
    pub count: u64,
    /// The first lookup missed, in words.
    pub first: Option<String>,
}

/// A built folder answering the lookups of materials with one albedo path and one TIR path.
#[derive(Debug)]
pub struct FolderTables {
    albedo: Albedo,
    tir: Tir,
    gd: Option<SampledTable>,
    /// The folder's stand-in tables ([`super::lookup::stand_in`]), each answering its quantity's
    /// lookups in its region ahead of the quantity's own table, where no slice holds the index.
    stand_ins: Vec<(StandIn, SampledTable)>,
    misses: Mutex<Misses>,
    /// Lookups answered by a table whose range did not hold them (read clamped).
    clamped: Mutex<Misses>,
}

impl FolderTables {
    /// The tables of `folder` for materials reading albedo by `albedo` and TIR by `tir`; `fgd`
    /// picks the full FGD table where there are two. A path the folder holds no table for is not
    /// refused here: a scene's plan leaves out what its materials never look up (a bare conductor
    /// makes no TIR lookup, an index-matched interface no albedo lookup), so its lookups miss
    /// instead and [`FolderTables::misses`] names the first, for the caller to refuse. Fails on a
    /// table that is listed but cannot be read as its path needs.
    pub fn open(folder: &LutFolder, albedo: AlbedoPath, tir: TirPath, fgd: FgdSource) -> Result<Self> {
        let missing = |what: &str| {
            Error::format(folder.dir().join(crate::formats::manifest::MANIFEST_FILE), format!("lists no {what}"))
        };
        let slices_of = |kind: TableKind, quantity: Quantity| -> Result<Slices> {
            let slices = folder
                .scene_slices(|entry| is_slice(entry, kind))?
                .into_iter()
                .map(|slice| {
                    let indices = slice_indices(&slice.entry);
                    Ok(Slice { quantity, indices, texture: SampledTable::new(&slice.table)? })
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(Slices::new(slices))
        };
        // The texture of a table a GPU binds: its DDS file, else its KTX2 file; else, for a table
        // of up to three axes, its `.bin` file, which a renderer uploads as a texture too.
        let texture = |table: TableKind| folder.table_file(table.name(), &FileFormat::TEXTURES);
        let texture_or_bin =
            |table: TableKind| folder.table_file(table.name(), &[FileFormat::Dds, FileFormat::Ktx2, FileFormat::Bin]);
        let albedo = match albedo {
            AlbedoPath::Fgd => {
                let slices = slices_of(TableKind::Fgd, Quantity::Albedo)?;
                let packed = folder.packing_file(Packing::Lossless.name(), &FileFormat::TEXTURES);
                let table = folder.table_file(TableKind::Fgd.name(), &[FileFormat::Exr, FileFormat::Bin]);
                let full = match (fgd, packed, table) {
                    (FgdSource::Packing, Some((file, entry)), _) => {
                        Some(FullFgd::Packed(Box::new(packed_fgd(folder, file, entry)?)))
                    }
                    (_, _, Some((file, _))) => Some(FullFgd::Table(folder.load(file)?)),
                    (FgdSource::Table, Some((file, entry)), None) => {
                        Some(FullFgd::Packed(Box::new(packed_fgd(folder, file, entry)?)))
                    }
                    (_, None, None) => None,
                };
                Albedo::Fgd { slices, full }
            }
            AlbedoPath::Belcour => match texture(TableKind::Belcour) {
                Some((file, entry)) => {
                    let basis =
                        entry.fresnel_basis.clone().ok_or_else(|| missing("Fresnel basis beside belcour.dds"))?;
                    Albedo::Belcour { texture: SampledTable::new(&folder.load(file)?)?, basis: Box::new(basis) }
                }
                None => Albedo::Absent,
            },
            AlbedoPath::Karis => match texture(TableKind::Karis) {
                Some((file, _)) => Albedo::Karis { texture: SampledTable::new(&folder.load(file)?)? },
                None => Albedo::Absent,
            },
        };
        let tir = match tir {
            TirPath::Table => {
                let slices = slices_of(TableKind::Tir, Quantity::Tir)?;
                let full = match texture_or_bin(TableKind::Tir) {
                    Some((file, _)) => {
                        let texture = SampledTable::new(&folder.load(file)?)?;
                        if point_of(&texture.axes, 0.5, 0.5, 0.5, 0.0).is_none() {
                            let names: Vec<&str> = texture.axes.iter().map(|a| a.name.as_str()).collect();
                            return Err(Error::format(
                                folder.dir().join(file),
                                format!(
                                    "has axes ({}); a TIR lookup addresses mu, alpha and eta or critical_angle_offset",
                                    names.join(", ")
                                ),
                            ));
                        }
                        Some(texture)
                    }
                    None => None,
                };
                Tir::Table { slices, full }
            }
            TirPath::Fit => match folder.tir_fit() {
                Some(fit) => fitted_form(folder, fit)?,
                None => Tir::Absent,
            },
            // The form is the material's, not the folder's: [`FolderTables::with_tir_form`].
            TirPath::Form => Tir::Absent,
            TirPath::Off => Tir::Off,
        };
        let gd = match texture_or_bin(TableKind::Gd) {
            Some((file, _)) => Some(SampledTable::new(&folder.load(file)?)?),
            None => None,
        };
        let mut stand_ins = Vec::new();
        for stand_in in super::lookup::stand_ins() {
            if let Some((file, _)) = texture(stand_in.table) {
                stand_ins.push((stand_in, SampledTable::new(&folder.load(file)?)?));
            }
        }
        Ok(FolderTables { albedo, tir, gd, stand_ins, misses: Mutex::default(), clamped: Mutex::default() })
    }

    /// The same tables with every TIR lookup answered by `form` (a material's `tir = "fit:PATH"`),
    /// evaluated in f32 as its shader computes it.
    #[cfg(feature = "generator")]
    pub fn with_tir_form(mut self, form: &FittedForm) -> Result<Self> {
        self.tir = Tir::Form(form.evaluator()?);
        Ok(self)
    }

    /// The same tables with every albedo lookup answered by `form` (a material's
    /// `albedo = "fit:PATH"`), evaluated in f32 as its shader computes it.
    #[cfg(feature = "generator")]
    pub fn with_albedo_form(mut self, form: &FittedForm) -> Result<Self> {
        self.albedo = Albedo::Form { form: form.evaluator()?, split_sum: form.table == TableKind::Karis.name() };
        Ok(self)
    }

    /// The same tables with the forms a material names in place of its TIR table
    /// ([`FolderTables::with_tir_form`]) and its albedo table ([`FolderTables::with_albedo_form`]).
    #[cfg(feature = "generator")]
    pub fn with_material_forms(self, tir: Option<&FittedForm>, albedo: Option<&FittedForm>) -> Result<Self> {
        let tables = match tir {
            Some(form) => self.with_tir_form(form)?,
            None => self,
        };
        match albedo {
            Some(form) => tables.with_albedo_form(form),
            None => Ok(tables),
        }
    }

    /// Lookups the folder holds no table for (each read 0).
    pub fn misses(&self) -> Misses {
        self.misses.lock().map(|m| m.clone()).unwrap_or_default()
    }

    /// Lookups answered by a table whose range does not hold them (read at its edge, as clamp
    /// addressing does).
    pub fn clamped(&self) -> Misses {
        self.clamped.lock().map(|m| m.clone()).unwrap_or_default()
    }

    /// [`FolderTables::misses`] and [`FolderTables::clamped`], then both counts restarted: one
    /// folder, opened once, serves the materials of a library in turn, each with its own counts.
    pub fn take_counts(&self) -> (Misses, Misses) {
        let take = |record: &Mutex<Misses>| record.lock().map(|mut m| std::mem::take(&mut *m)).unwrap_or_default();
        (take(&self.misses), take(&self.clamped))
    }

    fn note(record: &Mutex<Misses>, lookup: &Lookup) {
        if let Ok(mut m) = record.lock() {
            m.count += 1;
            if m.first.is_none() {
                m.first = Some(describe(lookup));
            }
        }
    }

    fn miss(&self, lookup: &Lookup) -> f64 {
        Self::note(&self.misses, lookup);
        0.0
    }

    /// The slice answering `lookup`: a channel at its indices, the first slice whose range holds
    /// `(mu, alpha)`, else the nearest ([`slice_choice_distance`]).
    fn slice_value(&self, slices: &Slices, lookup: &Lookup) -> Option<f64> {
        let point = [lookup.mu, lookup.alpha];
        let candidates = slices.at(lookup.quantity, lookup.eta, lookup.kappa);
        let distance = |slice: &Slice| slice_choice_distance(&slice.texture.axes, &point);
        let (slice, channel) = candidates.into_iter().min_by(|(a, _), (b, _)| distance(a).total_cmp(&distance(b)))?;
        if !slice.texture.covers(&point) {
            Self::note(&self.clamped, lookup);
        }
        Some(slice.texture.sample(channel, &point) as f64)
    }

    /// The first stand-in of the lookup's quantity whose region holds its index, read at the point
    /// its axes name.
    fn stand_in_value(&self, lookup: &Lookup) -> Option<f64> {
        self.stand_ins
            .iter()
            .filter(|(stand_in, _)| stand_in.answers(lookup.quantity, lookup.eta, lookup.kappa))
            .find_map(|(_, texture)| {
                let point = point_of(&texture.axes, lookup.mu, lookup.alpha, lookup.eta, lookup.kappa)?;
                Some(self.full(texture, &point, lookup))
            })
    }

    fn full(&self, texture: &SampledTable, point: &[f64], lookup: &Lookup) -> f64 {
        if !texture.covers(point) {
            Self::note(&self.clamped, lookup);
        }
        texture.sample(0, point) as f64
    }

    fn albedo(&self, lookup: &Lookup) -> f64 {
        match &self.albedo {
            Albedo::Fgd { slices, full } => {
                if let Some(value) = self.slice_value(slices, lookup).or_else(|| self.stand_in_value(lookup)) {
                    return value;
                }
                let point = [lookup.mu, lookup.alpha, lookup.eta, lookup.kappa];
                match full {
                    Some(FullFgd::Table(table)) => {
                        let holds = |axis: &Axis, x: f64| {
                            let (lo, hi) = axis.bounds();
                            x >= lo - 1e-12 && x <= hi + 1e-12
                        };
                        if !table.axes.iter().zip(&point).all(|(axis, &x)| holds(axis, x)) {
                            Self::note(&self.clamped, lookup);
                        }
                        table.interpolate(&point)[0]
                    }
                    Some(FullFgd::Packed(packed)) => {
                        if !packed
                            .source_axes
                            .iter()
                            .zip(&point)
                            .all(|(a, &x)| x >= a.start - 1e-12 && x <= a.end + 1e-12)
                        {
                            Self::note(&self.clamped, lookup);
                        }
                        packed.lookup(point.map(|v| v as f32), Filter::Exact) as f64
                    }
                    None => self.miss(lookup),
                }
            }
            Albedo::Belcour { texture, basis } => {
                let c = basis.coefficients(lookup.eta, lookup.kappa);
                let point = [lookup.mu, lookup.alpha];
                (0..4).map(|k| c[k] * texture.sample(k, &point) as f64).sum()
            }
            Albedo::Karis { texture } => {
                let f0 = normal_incidence_reflectance(lookup.eta, lookup.kappa);
                let point = [lookup.mu, lookup.alpha];
                f0 * texture.sample(0, &point) as f64 + texture.sample(1, &point) as f64
            }
            #[cfg(feature = "generator")]
            Albedo::Form { form, split_sum: true } => {
                let f0 = normal_incidence_reflectance(lookup.eta, lookup.kappa);
                let [scale, bias] = form.channels(&[lookup.mu as f32, lookup.alpha as f32])[..] else {
                    unreachable!("a split-sum form has the Karis table's two channels")
                };
                f0 * f64::from(scale) + f64::from(bias)
            }
            #[cfg(feature = "generator")]
            Albedo::Form { form, split_sum: false } => form.eval(&[lookup.mu, lookup.alpha, lookup.eta, lookup.kappa]),
            Albedo::Absent => self.miss(lookup),
        }
    }

    fn tir(&self, lookup: &Lookup) -> f64 {
        match &self.tir {
            Tir::Table { slices, full } => {
                if let Some(value) = self.slice_value(slices, lookup).or_else(|| self.stand_in_value(lookup)) {
                    return value;
                }
                // The third axis is eta, or the critical-angle offset computed from mu and eta.
                match full {
                    Some(texture) => {
                        let point = point_of(&texture.axes, lookup.mu, lookup.alpha, lookup.eta, 0.0)
                            .expect("checked when the folder was opened");
                        self.full(texture, &point, lookup)
                    }
                    None => self.miss(lookup),
                }
            }
            Tir::Form(form) => form.tir(lookup.mu, lookup.alpha, lookup.eta),
            Tir::Off => 0.0,
            Tir::Absent => self.miss(lookup),
        }
    }
}

impl Tables for FolderTables {
    fn value(&self, lookup: &Lookup) -> f64 {
        match lookup.quantity {
            Quantity::Albedo => self.albedo(lookup),
            Quantity::Tir => self.tir(lookup),
            Quantity::Gd => match &self.gd {
                Some(texture) => self.full(texture, &[lookup.mu, lookup.alpha], lookup),
                None => self.miss(lookup),
            },
        }
    }
}

/// A lookup in words, for messages.
pub fn describe(lookup: &Lookup) -> String {
    let what = match lookup.quantity {
        Quantity::Albedo => "FGD",
        Quantity::Tir => "TIR",
        Quantity::Gd => "GD",
    };
    let channel = lookup.channel.map(|c| format!(", channel {}", ["R", "G", "B"][c])).unwrap_or_default();
    let site = if lookup.site == Site::Lobe { "lobe".to_string() } else { lookup.site.name().to_string() };
    format!(
        "{what} of layer {} ({site}{channel}) at mu {:.6}, alpha {:.6}, eta {:.6}, kappa {:.6}",
        lookup.layer, lookup.mu, lookup.alpha, lookup.eta, lookup.kappa
    )
}

/// Whether a file is a scene slice of table `kind` (FGD or TIR): two axes, and channels that
/// state the indices they hold fixed.
pub(crate) fn is_slice(entry: &FileEntry, kind: TableKind) -> bool {
    entry.axes.len() == 2
        && entry.table.starts_with(&format!("{}_", kind.name()))
        && entry.channels.iter().any(|c| !c.fixed.is_empty())
}

/// The `(eta, kappa)` a slice's channels hold fixed, in channel order (its padding channel, which
/// fixes none, left out).
pub(crate) fn slice_indices(entry: &FileEntry) -> Vec<(f64, f64)> {
    entry
        .channels
        .iter()
        .filter(|c| !c.fixed.is_empty())
        .map(|c| (c.fixed.get("eta").copied().unwrap_or(f64::NAN), c.fixed.get("kappa").copied().unwrap_or(0.0)))
        .collect()
}

/// The packed FGD texture of `file` with the lookup of its packing.
pub(crate) fn packed_fgd(folder: &LutFolder, file: &str, entry: &FileEntry) -> Result<PackedFgd> {
    let packing_entry = entry.packing.as_ref().expect("chosen for its packing");
    let packing = Packing::parse(&packing_entry.name)?;
    let path = folder.dir().join(file);
    let sampled = SampledTable::new(&folder.load(file)?)?;
    if sampled.channel_count() == 0 {
        return Err(Error::format(&path, "has no channel"));
    }
    let texels = sampled.into_channel(0);
    let axes: Vec<Axis> = packing_entry.source_axes.iter().map(|a| a.axis.clone()).collect();
    PackedFgd::with_texture(texels, packing, entry.precision, &axes).map_err(|e| Error::format(&path, e.to_string()))
}

/// The folder's fitted TIR form, compiled from the definition its manifest states.
fn fitted_form(folder: &LutFolder, fit: &FitEntry) -> Result<Tir> {
    let where_ = folder.dir().join(crate::formats::manifest::MANIFEST_FILE);
    let refuse = |reason: String| Error::format(&where_, format!("the fitted TIR form `{}`: {reason}", fit.form));
    let form =
        FormEvaluator::from_definition(&fit.definition, &fit.parameter_names, &fit.parameters).map_err(refuse)?;
    if form.variables != ["mu", "alpha", "eta"] {
        return Err(refuse(format!("reads {}; allowed: mu, alpha, eta", form.variables.join(", "))));
    }
    Ok(Tir::Form(form))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::Texture3D;
    use crate::table::Mapping;

    /// Lattice node 80 of the slices' alpha axis, `(80/128)^2`, exact in f32 and f64.
    const NODE: f64 = 0.390625;
    /// The index of `absorbing-coat-00482`'s TIR of layer 1 (up) in the generated library.
    const ETA: f64 = 0.7122507122507123;

    /// A TIR slice at [`ETA`] over `mu` in [0.701171875, 1] and `alpha` in `alpha`, every texel `value`.
    fn tir_slice(alpha: (f64, f64), value: f32) -> Slice {
        let axes = vec![
            Axis::node_aligned("mu", 0.701171875, 1.0, 4).unwrap(),
            Axis::node_aligned("alpha", alpha.0, alpha.1, 3).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
        ];
        let texture = Texture3D { width: 4, height: 3, depth: 1, texels: vec![value; 12] };
        Slice {
            quantity: Quantity::Tir,
            indices: vec![(ETA, 0.0)],
            texture: SampledTable { name: "tir".into(), axes, channels: vec![texture] },
        }
    }

    fn folder(slices: Vec<Slice>) -> FolderTables {
        FolderTables {
            albedo: Albedo::Absent,
            tir: Tir::Table { slices: Slices::new(slices), full: None },
            gd: None,
            stand_ins: Vec::new(),
            misses: Mutex::default(),
            clamped: Mutex::default(),
        }
    }

    fn tir(mu: f64, alpha: f64) -> Lookup {
        Lookup { quantity: Quantity::Tir, site: Site::Up, layer: 1, channel: None, mu, alpha, eta: ETA, kappa: 0.0 }
    }

    #[test]
    fn a_slice_that_holds_the_lookup_beats_one_whose_end_lies_within_the_slack() {
        // absorbing-coat-00482 of `scripts/make-library 1000 1 DIR --per-scene 250` read TIR at
        // alpha a rounding below lattice node 80, where the slice of another material at the same
        // index begins (listed first, read 0.25 here), and its own slice holds it inside (0.75):
        // both lie within SLICE_CHOICE_SLACK of the lookup, and the first of them was read, at its
        // edge (one clamped lookup). A slice that holds a lookup comes first, in either order.
        let other = || tir_slice((NODE, 1.0), 0.25);
        let own = || tir_slice((0.32525634765625, 0.4306640625), 0.75);
        for (slices, first) in [(vec![other(), own()], 0.25), (vec![own(), other()], 0.75)] {
            let tables = folder(slices);
            for alpha in [NODE - 1e-12, NODE * (1.0 - 1e-7), NODE - 5e-6] {
                assert_eq!(slice_choice_distance(&other().texture.axes, &[0.723594, alpha]), 0.0, "{alpha}");
                assert_eq!(tables.value(&tir(0.723594, alpha)), 0.75, "alpha {alpha}");
            }
            // Held by both, or by neither and within the slack of both: the first listed, as
            // before; past the own slice's end, the other slice, which holds it.
            assert_eq!(tables.value(&tir(0.723594, 0.42)), first);
            assert_eq!(tables.value(&tir(1.0 + 1e-9, 0.42)), first);
            assert_eq!(tables.value(&tir(0.723594, 0.5)), 0.25);
            assert_eq!(tables.clamped().count, 1, "only the lookup held by neither reads clamped");
            assert_eq!(tables.misses().count, 0);
        }
    }
}
