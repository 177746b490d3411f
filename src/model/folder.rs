//! The files of a built folder answering the model's lookups exactly as a renderer reads them:
//! which file answers a lookup is [`super::routes`]'s decision, shared with the scene shader; how
//! each is read is this module's.
//!
//! - Textures (`.dds` and `.ktx2`, the DDS file where a table is in both, and the `.bin` tables of
//!   up to three axes, which a renderer uploads as textures too) are sampled the way a GPU samples
//!   them: the manifest's texture coordinate computed in f32, cell-centred linear filtering with
//!   clamp addressing in f32, texels as stored (f16 widened exactly), through
//!   [`crate::filter`].
//! - The 4D FGD table has no texture: its GPU packing (`fgd_lossless.dds` or `.ktx2`) is read
//!   through the very lookup program its shader files print ([`crate::packing::PackedFgd`]), or
//!   the 4D table (`fgd.exr`, or `fgd.bin` in the original layout) is interpolated on the CPU in
//!   4D as the reference plugin does.
//! - Of the slices at a lookup's index, the one whose `(mu, alpha)` range holds it answers
//!   ([`slice_choice_distance`]).
//! - The fitted TIR form is evaluated in f32 with the manifest's coefficients, as its shader; a
//!   form a material names (`tir = "fit:PATH"`) in f32 with its fitted parameters
//!   ([`FolderTables::with_tir_form`]).
//!
//! A lookup no file of the folder can answer reads 0 and is recorded: [`FolderTables::misses`]
//! says what was asked that the folder does not hold, so a caller can refuse the result.

use std::sync::Mutex;

use super::lookup::{AlbedoPath, Lookup, Quantity, Site, Tables, TirPath};
use super::routes::{LookupSource, Paths, Reader, Routes};
use crate::error::{Error, Result};
#[cfg(feature = "generator")]
use crate::fit::forms::fitted::{FittedForm, FittedFormExt};
use crate::formats::FileFormat;
use crate::formats::manifest::{FileEntry, FitEntry};
use crate::ir::compile::FormEvaluator;
use crate::loader::texture::SampledTable;
use crate::loader::{FolderSlice, LutFolder};
use crate::packing::{Filter, PackedFgd, Packing};
#[cfg(feature = "generator")]
use crate::physics::normal_incidence_reflectance;
#[cfg(feature = "generator")]
use crate::table::TableKind;
use crate::table::derived::quantity_in;
use crate::table::{Arithmetic, Axis, Table};

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

/// What a folder could not answer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Misses {
    pub count: u64,
    /// The first lookup missed, in words.
    pub first: Option<String>,
}

/// The CPU's [`Reader`]: each file's texels, sampled as a GPU samples them.
struct Sampling {
    fgd: FgdSource,
}

impl Reader for Sampling {
    type Table = SampledTable;
    type FullFgd = FullFgd;
    type Form = FormEvaluator;
    // A renderer uploads the `.bin` tables of up to three axes as textures too.
    const FORMATS: &'static [FileFormat] = &FileFormat::textures_then::<3>(&[FileFormat::Bin]);
    const FULL_FGD: &'static str = "4D FGD table or lossless FGD packing";

    fn slice(&self, slice: FolderSlice) -> Result<SampledTable> {
        SampledTable::new(&slice.table)
    }

    fn table(&self, folder: &LutFolder, file: &str, _: &FileEntry) -> Result<SampledTable> {
        SampledTable::new(&folder.load(file)?)
    }

    fn full_fgd(
        &self,
        folder: &LutFolder,
        packing: Option<(&str, &FileEntry)>,
        table: Option<(&str, &FileEntry)>,
    ) -> Result<Option<FullFgd>> {
        Ok(match (self.fgd, packing, table) {
            (FgdSource::Packing, Some((file, entry)), _) | (FgdSource::Table, Some((file, entry)), None) => {
                Some(FullFgd::Packed(Box::new(packed_fgd(folder, file, entry)?)))
            }
            (_, _, Some((file, _))) => Some(FullFgd::Table(folder.load(file)?)),
            (_, None, None) => None,
        })
    }

    fn fit(&self, folder: &LutFolder, fit: &FitEntry) -> Result<Option<FormEvaluator>> {
        fitted_form(folder, fit).map(Some)
    }
}

/// A built folder answering the lookups of materials with one albedo path and one TIR path.
pub struct FolderTables {
    routes: Routes<Sampling>,
    paths: Paths,
    /// The form a material names in place of its albedo table, and whether it was fitted to
    /// Karis's split sum (its channels then weighed by F0 as the table's are) rather than FGD.
    #[cfg(feature = "generator")]
    albedo_form: Option<(FormEvaluator, bool)>,
    /// The form a material names in place of its TIR table.
    #[cfg(feature = "generator")]
    tir_form: Option<FormEvaluator>,
    misses: Mutex<Misses>,
    /// Lookups answered by a table whose range did not hold them (read clamped).
    clamped: Mutex<Misses>,
}

impl FolderTables {
    /// The tables of `folder` for materials reading albedo by `albedo` and TIR by `tir`; `fgd`
    /// picks the full FGD table where there are two. A path the folder holds no table for is not
    /// refused here ([`Routes::open`]): its lookups miss instead and [`FolderTables::misses`]
    /// names the first, for the caller to refuse. Fails on a table that is listed but cannot be
    /// read as its path needs.
    pub fn open(folder: &LutFolder, albedo: AlbedoPath, tir: TirPath, fgd: FgdSource) -> Result<Self> {
        let paths = Paths::new(albedo, tir);
        Ok(FolderTables::over(Routes::open(folder, &[paths], &Sampling { fgd })?, paths))
    }

    fn over(routes: Routes<Sampling>, paths: Paths) -> Self {
        FolderTables {
            routes,
            paths,
            #[cfg(feature = "generator")]
            albedo_form: None,
            #[cfg(feature = "generator")]
            tir_form: None,
            misses: Mutex::default(),
            clamped: Mutex::default(),
        }
    }

    /// The same tables with every TIR lookup answered by `form` (a material's `tir = "fit:PATH"`),
    /// evaluated in f32 as its shader computes it.
    #[cfg(feature = "generator")]
    pub fn with_tir_form(mut self, form: &FittedForm) -> Result<Self> {
        self.tir_form = Some(form.evaluator()?);
        self.paths.tir = TirPath::Form;
        Ok(self)
    }

    /// The same tables with every albedo lookup answered by `form` (a material's
    /// `albedo = "fit:PATH"`), evaluated in f32 as its shader computes it.
    #[cfg(feature = "generator")]
    pub fn with_albedo_form(mut self, form: &FittedForm) -> Result<Self> {
        self.albedo_form = Some((form.evaluator()?, form.table == TableKind::Karis.name()));
        self.paths.albedo_form = true;
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

    /// One more lookup in `record`, the first kept as `first` says it (made only for the first).
    fn note(record: &Mutex<Misses>, first: impl FnOnce() -> String) {
        if let Ok(mut m) = record.lock() {
            m.count += 1;
            if m.first.is_none() {
                m.first = Some(first());
            }
        }
    }

    /// A lookup answered at the edge of a range that does not hold it.
    fn clamp(&self, lookup: &Lookup) {
        Self::note(&self.clamped, || describe(lookup));
    }

    /// 0 for a lookup the folder holds nothing for, noted with what it lacks.
    fn miss(&self, lookup: &Lookup, lacks: impl FnOnce() -> String) -> f64 {
        Self::note(&self.misses, || format!("{}: {}", describe(lookup), lacks()));
        0.0
    }

    /// Channel `channel` of `texture` at `point`, noted where its range does not hold the point.
    fn sample(&self, texture: &SampledTable, channel: usize, point: &[f64], lookup: &Lookup) -> f64 {
        if !texture.covers(point) {
            self.clamp(lookup);
        }
        texture.sample(channel, point) as f64
    }

    /// The full FGD table at the lookup's point, noted where its range does not hold it.
    fn full_fgd(&self, full: &FullFgd, lookup: &Lookup) -> f64 {
        let point = [lookup.mu, lookup.alpha, lookup.eta, lookup.kappa];
        let holds = |(lo, hi): (f64, f64), x: f64| x >= lo - 1e-12 && x <= hi + 1e-12;
        match full {
            FullFgd::Table(table) => {
                if !table.axes.iter().zip(&point).all(|(axis, &x)| holds(axis.bounds(), x)) {
                    self.clamp(lookup);
                }
                table.interpolate(&point)[0]
            }
            FullFgd::Packed(packed) => {
                if !packed.source_axes.iter().zip(&point).all(|(a, &x)| holds((a.start, a.end), x)) {
                    self.clamp(lookup);
                }
                packed.lookup(point.map(|v| v as f32), Filter::Exact) as f64
            }
        }
    }

    /// The form the material names for the lookup's quantity, evaluated in f32 as its shader
    /// computes it; `None` where it names none.
    #[cfg(feature = "generator")]
    fn material_form(&self, lookup: &Lookup) -> Option<f64> {
        match lookup.quantity {
            Quantity::Albedo => self.albedo_form.as_ref().map(|(form, split_sum)| match split_sum {
                // FGD ~ F0 scale + bias, as the Karis table is read.
                true => {
                    let f0 = normal_incidence_reflectance(lookup.eta, lookup.kappa);
                    let [scale, bias] = form.channels(&[lookup.mu as f32, lookup.alpha as f32])[..] else {
                        unreachable!("a split-sum form has the Karis table's two channels")
                    };
                    f0 * f64::from(scale) + f64::from(bias)
                }
                false => form.eval(&[lookup.mu, lookup.alpha, lookup.eta, lookup.kappa]),
            }),
            Quantity::Tir => self.tir_form.as_ref().map(|form| form.tir(lookup.mu, lookup.alpha, lookup.eta)),
            Quantity::Gd => None,
        }
    }

    #[cfg(not(feature = "generator"))]
    fn material_form(&self, _: &Lookup) -> Option<f64> {
        None
    }
}

impl Tables for FolderTables {
    /// The value of what the folder's routes say answers `lookup` ([`Routes::answer`]), sampled.
    fn value(&self, lookup: &Lookup) -> f64 {
        let point = [lookup.mu, lookup.alpha];
        match self.routes.answer(self.paths, lookup.quantity, lookup.eta, lookup.kappa) {
            LookupSource::Slices(candidates) => {
                // The first slice whose range holds `(mu, alpha)`, else the nearest.
                let distance = |slice: &SampledTable| slice_choice_distance(&slice.axes, &point);
                let (slice, channel) = candidates
                    .into_iter()
                    .min_by(|(a, _), (b, _)| distance(a).total_cmp(&distance(b)))
                    .expect("a lookup's slices are never none");
                self.sample(slice, channel, &point, lookup)
            }
            LookupSource::Table(_, table) => {
                // Two or three axes, each of a known quantity (checked when the folder was
                // opened): the point stays off the heap, as GD is read for every lobe.
                let mut point = [0.0; 3];
                for (x, axis) in point.iter_mut().zip(&table.axes) {
                    *x = quantity_in(&axis.name, lookup.mu, lookup.alpha, lookup.eta, lookup.kappa)
                        .expect("checked when the folder was opened");
                }
                self.sample(table, 0, &point[..table.axes.len()], lookup)
            }
            LookupSource::SplitSum(_, table, c) => {
                (0..table.channel_count().min(4)).map(|k| c[k] * table.sample(k, &point) as f64).sum()
            }
            LookupSource::FullFgd(full) => self.full_fgd(full, lookup),
            LookupSource::FolderForm(form) => form.tir(lookup.mu, lookup.alpha, lookup.eta),
            LookupSource::MaterialForm => self
                .material_form(lookup)
                .unwrap_or_else(|| self.miss(lookup, || "the material names a form for it, and none was given".into())),
            LookupSource::Zero => 0.0,
            LookupSource::Missing => self.miss(lookup, || {
                let lacks = Routes::<Sampling>::missing(self.paths, lookup.quantity, lookup.eta, lookup.kappa);
                format!("the folder lists {lacks}")
            }),
        }
    }
}

impl std::fmt::Debug for FolderTables {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FolderTables").field("paths", &self.paths).finish_non_exhaustive()
    }
}

/// How one material of a library reads a folder: its paths and the forms it names in place of
/// tables ([`FolderTables::with_material_forms`]), with its name for messages.
#[cfg(feature = "generator")]
pub struct MaterialReads<'a> {
    pub name: &'a str,
    pub albedo: AlbedoPath,
    pub tir: TirPath,
    pub tir_form: Option<&'a FittedForm>,
    pub albedo_form: Option<&'a FittedForm>,
}

/// A folder's tables for each material of a library, opened once per way the materials read it:
/// opening reads and verifies every table the paths read (a library's thousands of slices), so
/// opening it per material costs the square of the library's size. The materials that read alike
/// share one [`FolderTables`]; take its counts ([`FolderTables::take_counts`]) around each
/// material's lookups for that material's own.
#[cfg(feature = "generator")]
pub struct LibraryTables {
    opened: Vec<FolderTables>,
    /// Each material's index in `opened`.
    of_material: Vec<usize>,
}

#[cfg(feature = "generator")]
impl LibraryTables {
    /// The tables of `folder` for `materials`, in their order; `fgd` as [`FolderTables::open`]
    /// takes it. An error names the first material whose tables could not be opened.
    pub fn open<'a>(
        folder: &LutFolder,
        fgd: FgdSource,
        materials: impl IntoIterator<Item = MaterialReads<'a>>,
    ) -> Result<Self> {
        let mut ways: Vec<MaterialReads<'a>> = Vec::new();
        let mut opened = Vec::new();
        let mut of_material = Vec::new();
        for m in materials {
            let alike = |w: &MaterialReads| {
                (w.albedo, w.tir, w.tir_form, w.albedo_form) == (m.albedo, m.tir, m.tir_form, m.albedo_form)
            };
            let index = match ways.iter().position(alike) {
                Some(index) => index,
                None => {
                    let tables = FolderTables::open(folder, m.albedo, m.tir, fgd)
                        .and_then(|t| t.with_material_forms(m.tir_form, m.albedo_form))
                        .map_err(|e| Error::invalid(format!("material `{}`", m.name), e.to_string()))?;
                    opened.push(tables);
                    ways.push(m);
                    opened.len() - 1
                }
            };
            of_material.push(index);
        }
        Ok(LibraryTables { opened, of_material })
    }

    /// The tables of material `index` (its place in the order opened).
    pub fn of(&self, index: usize) -> &FolderTables {
        &self.opened[self.of_material[index]]
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
fn fitted_form(folder: &LutFolder, fit: &FitEntry) -> Result<FormEvaluator> {
    let where_ = folder.dir().join(crate::formats::manifest::MANIFEST_FILE);
    let refuse = |reason: String| Error::format(&where_, format!("the fitted TIR form `{}`: {reason}", fit.form));
    let form =
        FormEvaluator::from_definition(&fit.definition, &fit.parameter_names, &fit.parameters).map_err(refuse)?;
    if form.variables != ["mu", "alpha", "eta"] {
        return Err(refuse(format!("reads {}; allowed: mu, alpha, eta", form.variables.join(", "))));
    }
    Ok(form)
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
    fn tir_slice(alpha: (f64, f64), value: f32) -> SampledTable {
        let axes = vec![
            Axis::node_aligned("mu", 0.701171875, 1.0, 4).unwrap(),
            Axis::node_aligned("alpha", alpha.0, alpha.1, 3).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
        ];
        let texture = Texture3D { width: 4, height: 3, depth: 1, texels: vec![value; 12] };
        SampledTable { name: "tir".into(), axes, channels: vec![texture] }
    }

    #[test]
    fn the_cpu_reads_the_texture_formats_in_their_order_then_a_bin_table() {
        // The scene shader binds `FileFormat::TEXTURES` in that order: where a table is written
        // in several, the CPU evaluator reads the file the shader reads.
        assert!(Sampling::FORMATS.starts_with(&FileFormat::TEXTURES), "{:?}", Sampling::FORMATS);
        assert_eq!(Sampling::FORMATS[FileFormat::TEXTURES.len()..], [FileFormat::Bin]);
    }

    fn folder(slices: Vec<SampledTable>) -> FolderTables {
        let slices = slices.into_iter().map(|slice| (slice, vec![(ETA, 0.0)])).collect();
        FolderTables::over(Routes::of_tir_slices(slices), Paths::new(AlbedoPath::Fgd, TirPath::Table))
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
                assert_eq!(slice_choice_distance(&other().axes, &[0.723594, alpha]), 0.0, "{alpha}");
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
