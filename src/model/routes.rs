//! Which file of a built folder answers each lookup of the model, decided here once for both of
//! a folder's readers: the CPU evaluator, which samples the files ([`super::folder::FolderTables`]),
//! and the scene shader, which prints their reads ([`crate::shader::scene`]). Each reader keeps
//! what it needs of a file (texels, or a name and axes: a [`Reader`]) and turns an [`LookupSource`]
//! into a value; the order in which files answer is [`Routes::answer`]'s alone:
//!
//! - albedo on the FGD path: the slice holding the lookup's index (a scene's), else the stand-in
//!   whose region holds it ([`super::lookup::stand_in`]), else the full 4D table or its packing;
//! - albedo on a split-sum path: Belcour's or Karis's table, weighed by the Fresnel coefficients
//!   of the index (Belcour's basis from the manifest; Karis's `F0` scale and bias);
//! - TIR on the table path: the slice, else the stand-in, else the 3D TIR table; on the fit path
//!   the folder's fitted form; 0 where TIR is off;
//! - GD: its 2D table;
//! - a form a material names in place of a table (`fit:PATH`): the reader's own.

use super::lookup::{AlbedoPath, Quantity, StandIn, TirPath};
use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::formats::manifest::{FileEntry, FitEntry, MANIFEST_FILE};
use crate::loader::{FolderSlice, LutFolder};
use crate::packing::Packing;
use crate::physics::{FresnelBasis, normal_incidence_reflectance};
use crate::table::TableKind;
use crate::table::derived::point_of;

/// What a reader keeps of a folder's files, made as [`Routes::open`] finds them.
pub trait Reader {
    /// A table of two or three axes: a scene's slice, GD, a split-sum table, the 3D TIR table, a
    /// stand-in.
    type Table;
    /// The full FGD table: its GPU packing or the 4D table.
    type FullFgd;
    /// The folder's fitted TIR form.
    type Form;
    /// The formats it reads a table of two or three axes from, the preferred first.
    const FORMATS: &'static [FileFormat];
    /// The full FGD table as it reads it, in words: what the folder lacks where it lacks it.
    const FULL_FGD: &'static str;

    /// A scene's slice, found with its texels (a file of its own or a region of a texture array).
    fn slice(&self, slice: FolderSlice) -> Result<Self::Table>;
    /// Table `file` of `folder`, listed as `entry`.
    fn table(&self, folder: &LutFolder, file: &str, entry: &FileEntry) -> Result<Self::Table>;
    /// The full FGD table from the folder's lossless packing or its 4D table, each where the
    /// folder lists it; `None` where the reader reads neither.
    fn full_fgd(
        &self,
        folder: &LutFolder,
        packing: Option<(&str, &FileEntry)>,
        table: Option<(&str, &FileEntry)>,
    ) -> Result<Option<Self::FullFgd>>;
    /// The folder's fitted TIR form as its manifest states it; `None` where the reader cannot
    /// read it.
    fn fit(&self, folder: &LutFolder, fit: &FitEntry) -> Result<Option<Self::Form>>;
}

/// How a material reads its tables: what [`Routes::answer`] decides by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Paths {
    pub albedo: AlbedoPath,
    /// The material names a form in place of its albedo table (`albedo = "fit:PATH"`).
    pub albedo_form: bool,
    pub tir: TirPath,
}

impl Paths {
    pub fn new(albedo: AlbedoPath, tir: TirPath) -> Self {
        Paths { albedo, albedo_form: false, tir }
    }
}

/// What answers one lookup.
pub enum LookupSource<'a, R: Reader> {
    /// The slices with a channel at the lookup's index, each with its first such channel, in the
    /// folder's order (never empty): the one ranked first by
    /// [`super::folder::slice_choice_distance`] at the lookup's `(mu, alpha)` answers, the first
    /// of equals.
    Slices(Vec<(&'a R::Table, usize)>),
    /// Channel 0 of a table of kind `TableKind` (GD, the 3D TIR table, a stand-in) at the point
    /// its axes name ([`point_of`]).
    Table(TableKind, &'a R::Table),
    /// The channels of split-sum table `TableKind` at `(mu, alpha)`, weighed by these Fresnel
    /// coefficients of the lookup's index.
    SplitSum(TableKind, &'a R::Table, [f64; 4]),
    FullFgd(&'a R::FullFgd),
    /// The folder's fitted TIR form.
    FolderForm(&'a R::Form),
    /// The form the material names (`fit:PATH`), which the reader holds.
    MaterialForm,
    /// No correction: TIR is off.
    Zero,
    /// The folder holds nothing that answers it.
    Missing,
}

/// A slice with the `(eta, kappa)` its channels hold fixed (kappa 0 for TIR), in channel order.
type SliceAt<T> = (T, Vec<(f64, f64)>);

/// A folder's slices of one quantity, with their channels sorted by `eta`: a library holds
/// thousands, and a lookup finds the few at its index by a binary search, not by reading them all.
struct Slices<T> {
    slices: Vec<SliceAt<T>>,
    /// `(eta, slice, channel)` of every channel, by `eta`.
    by_eta: Vec<(f64, usize, usize)>,
}

impl<T> Slices<T> {
    fn new(slices: Vec<SliceAt<T>>) -> Self {
        let mut by_eta: Vec<(f64, usize, usize)> = slices
            .iter()
            .enumerate()
            .flat_map(|(s, (_, indices))| indices.iter().enumerate().map(move |(c, &(eta, _))| (eta, s, c)))
            .collect();
        by_eta.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        Slices { slices, by_eta }
    }

    /// The slices with a channel at `(eta, kappa)` (equal to within 1e-12 of the larger, the
    /// tolerance f32 and f64 lookups of one index agree to), each with its first such channel,
    /// in the folder's order.
    fn at(&self, eta: f64, kappa: f64) -> Vec<(&T, usize)> {
        let same = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        // Within the tolerance, |a - b| < 2e-12 |eta|: the window holds every candidate.
        let reach = 2e-12 * eta.abs();
        let from = self.by_eta.partition_point(|e| e.0 < eta - reach);
        let to = self.by_eta.partition_point(|e| e.0 <= eta + reach);
        let mut found: Vec<(usize, usize)> = Vec::new();
        for &(_, s, c) in &self.by_eta[from..to] {
            let (e, k) = self.slices[s].1[c];
            if same(e, eta) && same(k, kappa) {
                found.push((s, c));
            }
        }
        // Each slice once, at its first matching channel.
        found.sort_unstable();
        found.dedup_by_key(|&mut (s, _)| s);
        found.into_iter().map(|(s, c)| (&self.slices[s].0, c)).collect()
    }
}

/// The files of a folder that the lookups of materials reading by some [`Paths`] need, as a
/// reader keeps them.
pub struct Routes<R: Reader> {
    fgd_slices: Slices<R::Table>,
    tir_slices: Slices<R::Table>,
    full_fgd: Option<R::FullFgd>,
    belcour: Option<(R::Table, FresnelBasis)>,
    karis: Option<R::Table>,
    tir: Option<R::Table>,
    gd: Option<R::Table>,
    /// The folder's stand-in tables, each answering its quantity's lookups in its region ahead of
    /// the quantity's own table, where no slice holds the index.
    stand_ins: Vec<(StandIn, R::Table)>,
    fit: Option<R::Form>,
}

impl<R: Reader> Routes<R> {
    /// The files of `folder` that materials reading by `paths` look up, kept by `reader`; GD
    /// whatever the paths. A path the folder holds no file for is not refused here:
    /// a scene's plan leaves out what its materials never look up (a bare conductor makes no TIR
    /// lookup), so its lookups are [`LookupSource::Missing`] instead, for the reader to refuse. Fails on
    /// a file that is listed but cannot be read as its path needs.
    pub fn open(folder: &LutFolder, paths: &[Paths], reader: &R) -> Result<Self> {
        let reads_albedo = |path: AlbedoPath| paths.iter().any(|p| p.albedo == path);
        let reads_tir = |path: TirPath| paths.iter().any(|p| p.tir == path);
        let (mut fgd_slices, mut tir_slices) = (Vec::new(), Vec::new());
        let wanted = |entry: &FileEntry| {
            (reads_albedo(AlbedoPath::Fgd) && is_slice(entry, TableKind::Fgd))
                || (reads_tir(TirPath::Table) && is_slice(entry, TableKind::Tir))
        };
        for slice in folder.scene_slices(wanted)? {
            let slices = if is_slice(&slice.entry, TableKind::Fgd) { &mut fgd_slices } else { &mut tir_slices };
            let indices = slice_indices(&slice.entry);
            slices.push((reader.slice(slice)?, indices));
        }
        // A table of its kind's shape whose axes a lookup addresses, kept by the reader.
        let table = |kind: TableKind| -> Result<Option<(R::Table, &FileEntry)>> {
            let Some((file, entry)) = folder.table_file(kind.name(), R::FORMATS) else {
                return Ok(None);
            };
            let axes: Vec<_> = entry.axes.iter().map(|a| a.axis.clone()).collect();
            if axes.len() != kind.shape().axes.len() || point_of(&axes, 0.5, 0.5, 0.5, 0.0).is_none() {
                let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
                return Err(Error::format(
                    folder.dir().join(file),
                    format!(
                        "has axes ({}); a lookup of table `{}` addresses {}",
                        names.join(", "),
                        kind.name(),
                        kind.shape().axes.iter().map(|names| names.join(" or ")).collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
            Ok(Some((reader.table(folder, file, entry)?, entry)))
        };
        let full_fgd = match reads_albedo(AlbedoPath::Fgd) {
            true => reader.full_fgd(
                folder,
                folder.packing_file(Packing::Lossless.name(), &FileFormat::TEXTURES),
                folder.table_file(TableKind::Fgd.name(), &[FileFormat::Exr, FileFormat::Bin]),
            )?,
            false => None,
        };
        let belcour = match reads_albedo(AlbedoPath::Belcour) {
            true => match table(TableKind::Belcour)? {
                Some((table, entry)) => {
                    let basis = entry.fresnel_basis.clone().ok_or_else(|| {
                        Error::format(folder.dir().join(MANIFEST_FILE), "lists no Fresnel basis beside belcour.dds")
                    })?;
                    Some((table, basis))
                }
                None => None,
            },
            false => None,
        };
        let karis = if reads_albedo(AlbedoPath::Karis) { table(TableKind::Karis)?.map(|(t, _)| t) } else { None };
        let tir = if reads_tir(TirPath::Table) { table(TableKind::Tir)?.map(|(t, _)| t) } else { None };
        let fit = match (reads_tir(TirPath::Fit), folder.tir_fit()) {
            (true, Some(fit)) => reader.fit(folder, fit)?,
            _ => None,
        };
        // A stand-in answers ahead of its quantity's own table, on the path that reads that table
        // ([`Routes::answer`]; albedo on the FGD path, TIR on the table path: `StandIn::quantity`).
        let read = |quantity: Quantity| match quantity {
            Quantity::Albedo => reads_albedo(AlbedoPath::Fgd),
            Quantity::Tir => reads_tir(TirPath::Table),
            Quantity::Gd => false,
        };
        let mut stand_ins = Vec::new();
        for stand_in in super::lookup::stand_ins().filter(|stand_in| read(stand_in.quantity)) {
            if let Some((table, _)) = table(stand_in.table)? {
                stand_ins.push((stand_in, table));
            }
        }
        Ok(Routes {
            fgd_slices: Slices::new(fgd_slices),
            tir_slices: Slices::new(tir_slices),
            full_fgd,
            belcour,
            karis,
            tir,
            gd: table(TableKind::Gd)?.map(|(t, _)| t),
            stand_ins,
            fit,
        })
    }

    /// What answers a lookup of `quantity` at the relative index `(eta, kappa)` for a material
    /// reading by `paths`: the module's list, in its order.
    pub fn answer(&self, paths: Paths, quantity: Quantity, eta: f64, kappa: f64) -> LookupSource<'_, R> {
        let answer = match quantity {
            Quantity::Albedo if paths.albedo_form => Some(LookupSource::MaterialForm),
            Quantity::Albedo => match paths.albedo {
                AlbedoPath::Fgd => self
                    .slice_or_stand_in(&self.fgd_slices, quantity, eta, kappa)
                    .or_else(|| self.full_fgd.as_ref().map(LookupSource::FullFgd)),
                AlbedoPath::Belcour => self.belcour.as_ref().map(|(table, basis)| {
                    LookupSource::SplitSum(TableKind::Belcour, table, basis.coefficients(eta, kappa))
                }),
                // FGD ~ F0 scale + bias, with F0 at the relative index.
                AlbedoPath::Karis => self.karis.as_ref().map(|table| {
                    LookupSource::SplitSum(
                        TableKind::Karis,
                        table,
                        [normal_incidence_reflectance(eta, kappa), 1.0, 0.0, 0.0],
                    )
                }),
            },
            Quantity::Tir => match paths.tir {
                TirPath::Table => self
                    .slice_or_stand_in(&self.tir_slices, quantity, eta, kappa)
                    .or_else(|| self.tir.as_ref().map(|table| LookupSource::Table(TableKind::Tir, table))),
                TirPath::Fit => self.fit.as_ref().map(LookupSource::FolderForm),
                TirPath::Form => Some(LookupSource::MaterialForm),
                TirPath::Off => Some(LookupSource::Zero),
            },
            Quantity::Gd => self.gd.as_ref().map(|table| LookupSource::Table(TableKind::Gd, table)),
        };
        answer.unwrap_or(LookupSource::Missing)
    }

    /// What the folder lacks where [`Routes::answer`] finds nothing ([`LookupSource::Missing`]), in words
    /// ("no ..."): the table the path reads.
    pub fn missing(paths: Paths, quantity: Quantity, eta: f64, kappa: f64) -> String {
        match (quantity, paths.albedo, paths.tir) {
            (Quantity::Albedo, AlbedoPath::Fgd, _) => {
                format!("no FGD slice at (eta, kappa) = ({eta}, {kappa}) and no {}", R::FULL_FGD)
            }
            (Quantity::Albedo, AlbedoPath::Belcour, _) => {
                "no Belcour split-sum table (belcour.dds with its Fresnel basis)".into()
            }
            (Quantity::Albedo, AlbedoPath::Karis, _) => "no Karis split-sum table (karis.dds)".into(),
            (Quantity::Tir, _, TirPath::Fit) => "no fitted TIR form, which the TIR path `fit` reads".into(),
            (Quantity::Tir, _, _) => format!("no TIR slice at eta {eta} and no 3D TIR table (tir.dds)"),
            (Quantity::Gd, _, _) => "no 2D GD table (gd.dds)".into(),
        }
    }

    /// The slices holding the index, else the first stand-in whose region holds it.
    fn slice_or_stand_in<'a>(
        &'a self,
        slices: &'a Slices<R::Table>,
        quantity: Quantity,
        eta: f64,
        kappa: f64,
    ) -> Option<LookupSource<'a, R>> {
        let candidates = slices.at(eta, kappa);
        if !candidates.is_empty() {
            return Some(LookupSource::Slices(candidates));
        }
        self.stand_ins
            .iter()
            .find(|(stand_in, _)| stand_in.answers(quantity, eta, kappa))
            .map(|(stand_in, table)| LookupSource::Table(stand_in.table, table))
    }
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
fn slice_indices(entry: &FileEntry) -> Vec<(f64, f64)> {
    entry
        .channels
        .iter()
        .filter(|c| !c.fixed.is_empty())
        .map(|c| (c.fixed.get("eta").copied().unwrap_or(f64::NAN), c.fixed.get("kappa").copied().unwrap_or(0.0)))
        .collect()
}

#[cfg(test)]
impl<R: Reader> Routes<R> {
    /// Routes with these TIR slices only.
    pub(crate) fn of_tir_slices(slices: Vec<SliceAt<R::Table>>) -> Self {
        Routes {
            fgd_slices: Slices::new(Vec::new()),
            tir_slices: Slices::new(slices),
            full_fgd: None,
            belcour: None,
            karis: None,
            tir: None,
            gd: None,
            stand_ins: Vec::new(),
            fit: None,
        }
    }
}
