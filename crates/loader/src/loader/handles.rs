//! One typed handle per table kind: opened from a folder (verified against its manifest), checked
//! once for the axes and channels its lookup needs, then sampled with plain arguments and fixed-size
//! results, allocating nothing and never failing.
//!
//! Each handle samples two ways:
//! - `sample`: multilinear interpolation in f64, as [`Table::interpolate`] (the reference a CPU
//!   renderer or a test wants);
//! - `sample_gpu` (tables a GPU binds as textures: all but FGD's 4D table): the manifest's texture
//!   coordinates computed in f32 and the texture filtered as a GPU sampler does
//!   ([`super::texture::sample_texture`]), the values a shader reads; `sample_uv`/`sample_uvw`
//!   take the texture coordinates themselves.
//!
//! Karis (both arrangements) and Belcour are looked up by perceptual roughness, as Unreal Engine 4 and Filament pass
//! it (`alpha = roughness^2`); GD, TIR, FGD, `fgd_rarer`, `ggx_e` and `ggx_e_avg` by GGX `alpha`,
//! the quantity of their axes. The argument is typed ([`Roughness`], [`Alpha`]): each handle takes either and converts
//! it, and a bare `f32` does not compile.

use super::roughness::{Alpha, Roughness};
use super::texture::{TextureData, sample_texture, texture_coordinate};
use super::{FileEntry, LutFolder, Precision, Table};
use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::formats::manifest::MANIFEST_FILE;
use crate::table::TableKind;
use crate::table::derived::{CRITICAL_ANGLE_OFFSET, critical_angle_fraction, critical_angle_offset};

/// A verified table with the shape a handle needs.
#[derive(Debug, Clone)]
struct Checked {
    table: Table,
    precision: Precision,
    entry: Option<FileEntry>,
}

/// What a handle requires of a table: the shape of its kind ([`TableKind::shape`]).
struct Shape(TableKind);

const KARIS: Shape = Shape(TableKind::Karis);
const BELCOUR: Shape = Shape(TableKind::Belcour);
const GD: Shape = Shape(TableKind::Gd);
const TIR: Shape = Shape(TableKind::Tir);
const FGD: Shape = Shape(TableKind::Fgd);
const FGD_RARER: Shape = Shape(TableKind::FgdRarer);
const GGX_E: Shape = Shape(TableKind::GgxE);
const GGX_E_AVG: Shape = Shape(TableKind::GgxEAvg);
const KARIS_MULTISCATTER: Shape = Shape(TableKind::KarisMultiscatter);

impl Shape {
    fn describe(&self) -> String {
        let shape = self.0.shape();
        let axes: Vec<String> = shape.axes.iter().map(|names| names.join(" or ")).collect();
        format!(
            "a {} table has the axes ({}) and {} channel{}",
            self.0,
            axes.join(", "),
            shape.channels,
            if shape.channels == 1 { "" } else { "s" }
        )
    }

    fn fits(&self, table: &Table) -> bool {
        let shape = self.0.shape();
        table.axes.len() == shape.axes.len()
            && table.axes.iter().zip(shape.axes).all(|(axis, allowed)| allowed.contains(&axis.name.as_str()))
            && table.channel_count() == shape.channels
    }

    fn check(&self, table: Table, precision: Precision, entry: Option<FileEntry>, path: &str) -> Result<Checked> {
        if !self.fits(&table) {
            let axes: Vec<&str> = table.axes.iter().map(|a| a.name.as_str()).collect();
            return Err(Error::WrongTable {
                path: path.into(),
                reason: format!(
                    "holds a table with the axes ({}) and {} channels; {}",
                    axes.join(", "),
                    table.channel_count(),
                    self.describe()
                ),
            });
        }
        Ok(Checked { table, precision, entry })
    }

    /// Open `file` of `folder` (verified against the manifest) as this kind.
    fn open(&self, folder: &LutFolder, file: &str) -> Result<Checked> {
        let entry = folder.entry(file)?.clone();
        let table = folder.load(file)?;
        let precision = super::stored_precision(&entry);
        self.check(table, precision, Some(entry), &folder.dir().join(file).to_string_lossy())
    }

    /// The formats [`Shape::find`] takes, in its order: the texture formats (DDS before
    /// KTX2), then an OpenEXR file, then a `.bin` one.
    const PREFERENCE: [FileFormat; 4] = FileFormat::textures_then(&[FileFormat::Exr, FileFormat::Bin]);

    /// The file of `folder` holding this kind's table: the one its manifest lists under the
    /// table's name, not a packing, in the order of [`Shape::PREFERENCE`].
    fn find<'a>(&self, folder: &'a LutFolder) -> Result<&'a str> {
        folder.table_file(self.0.name(), &Self::PREFERENCE).map(|(file, _)| file).ok_or_else(|| Error::Missing {
            path: folder.dir().join(MANIFEST_FILE),
            reason: format!("lists no `{}` table (a file whose entry has \"table\": \"{}\")", self.0, self.0),
        })
    }
}

/// Converts the `mu` and `alpha` of a lookup into the texture coordinate of a 2D table.
fn uv(table: &Table, mu: f64, alpha: f64) -> [f32; 2] {
    [texture_coordinate(&table.axes[0], mu), texture_coordinate(&table.axes[1], alpha)]
}

/// The methods every handle has.
macro_rules! common {
    ($handle:ident, $shape:ident) => {
        impl $handle {
            /// Open `file` of `folder`, verified against the manifest and checked for this table's
            /// axes and channels.
            pub fn open(folder: &LutFolder, file: &str) -> Result<Self> {
                $shape.open(folder, file).map($handle)
            }

            /// Open the file of `folder` that holds this table (a DDS file before a KTX2 one
            /// before an OpenEXR one before a `.bin` one).
            pub fn from_folder(folder: &LutFolder) -> Result<Self> {
                Self::open(folder, $shape.find(folder)?)
            }

            /// Wrap a table already loaded, stored in `precision`; checked for this table's axes
            /// and channels.
            pub fn from_table(table: Table, precision: Precision) -> Result<Self> {
                let name = format!("table `{}`", table.name);
                $shape.check(table, precision, None, &name).map($handle)
            }

            /// The table the handle samples.
            pub fn table(&self) -> &Table {
                &self.0.table
            }

            /// The manifest entry the file was verified against (none for [`Self::from_table`]).
            pub fn entry(&self) -> Option<&FileEntry> {
                self.0.entry.as_ref()
            }

            /// The precision the values are stored in.
            pub fn precision(&self) -> Precision {
                self.0.precision
            }

            /// The table the handle samples, the handle consumed.
            pub fn into_table(self) -> Table {
                self.0.table
            }
        }
    };
}

/// Methods of the handles a GPU binds as a texture.
macro_rules! texture {
    ($handle:ident, $channels:expr, $dims:expr) => {
        impl $handle {
            /// The texel bytes and texture descriptor of the table, in its storage precision.
            pub fn texture(&self) -> Result<TextureData> {
                TextureData::from_table(&self.0.table, self.0.precision)
            }

            fn filter(&self, coordinate: [f32; $dims]) -> [f32; $channels] {
                let mut out = [0.0; $channels];
                // The shape was checked at opening: the counts agree.
                let _ = sample_texture(&self.0.table, &coordinate, &mut out);
                out
            }
        }
    };
}

/// The sampling methods of a split-sum handle, whose `$channels` channels (`$values`) lie over
/// `(n.v, alpha)` and are looked up by perceptual roughness.
macro_rules! split_sum {
    ($handle:ident, $channels:expr, $values:literal) => {
        impl $handle {
            #[doc = concat!("`", $values, "` at `n_dot_v` and perceptual `roughness` (`alpha = roughness^2`; an [`Alpha`] converts).")]
            pub fn sample(&self, n_dot_v: f32, roughness: impl Into<Roughness>) -> [f32; $channels] {
                let roughness = roughness.into().0 as f64;
                interpolate(&self.0.table, [n_dot_v as f64, roughness * roughness])
            }

            /// [`Self::sample`] as a shader reads the texture.
            pub fn sample_gpu(&self, n_dot_v: f32, roughness: impl Into<Roughness>) -> [f32; $channels] {
                let roughness = roughness.into().0 as f64;
                self.filter(uv(&self.0.table, n_dot_v as f64, roughness * roughness))
            }

            /// The texture sampled at texture coordinate `(u, v)`.
            pub fn sample_uv(&self, u: f32, v: f32) -> [f32; $channels] {
                self.filter([u, v])
            }
        }
    };
}

fn interpolate<const D: usize, const C: usize>(table: &Table, point: [f64; D]) -> [f32; C] {
    let mut out = [0.0f64; C];
    // The shape was checked at opening: the counts agree.
    let _ = table.interpolate_into(&point, &mut out);
    out.map(|v| v as f32)
}

/// The split-sum table of Karis (2013): `(scale, bias)` with `F0 * scale + bias` the specular
/// albedo, over `(n.v, roughness)`.
#[derive(Debug, Clone)]
pub struct KarisLut(Checked);
common!(KarisLut, KARIS);
texture!(KarisLut, 2, 2);
split_sum!(KarisLut, 2, "[scale, bias]");

/// The Karis split sum for multiple-scattering compensation (Filament's multiscatter `DFG`):
/// `(bias, albedo)` with `F0 * albedo + (1 - F0) * bias` the specular albedo and `albedo` the one
/// with `F = 1`, over `(n.v, roughness)`.
#[derive(Debug, Clone)]
pub struct KarisMultiscatterLut(Checked);
common!(KarisMultiscatterLut, KARIS_MULTISCATTER);
texture!(KarisMultiscatterLut, 2, 2);
split_sum!(KarisMultiscatterLut, 2, "[bias, albedo]");

/// Belcour's Fresnel-basis split sum: four channels `b0..b3` over `(n.v, roughness)`; the albedo
/// is `Σ c_k b_k` with the coefficients of the manifest's `fresnel_basis`.
#[derive(Debug, Clone)]
pub struct BelcourLut(Checked);
common!(BelcourLut, BELCOUR);
texture!(BelcourLut, 4, 2);
split_sum!(BelcourLut, 4, "[b0, b1, b2, b3]");

/// The sampling methods of a handle whose one channel lies over `(mu, alpha)` and is looked up by
/// GGX `alpha`.
macro_rules! mu_alpha {
    ($handle:ident) => {
        impl $handle {
            /// The value at `mu` (cosine of the view angle) and GGX `alpha` (a [`Roughness`]
            /// converts), interpolated in f64.
            pub fn sample(&self, mu: f32, alpha: impl Into<Alpha>) -> f32 {
                let alpha = alpha.into().0;
                let [v] = interpolate(&self.0.table, [mu as f64, alpha as f64]);
                v
            }

            /// [`Self::sample`] as a shader reads the texture.
            pub fn sample_gpu(&self, mu: f32, alpha: impl Into<Alpha>) -> f32 {
                let alpha = alpha.into().0;
                self.filter(uv(&self.0.table, mu as f64, alpha as f64))[0]
            }

            /// The texture sampled at texture coordinate `(u, v)`.
            pub fn sample_uv(&self, u: f32, v: f32) -> f32 {
                self.filter([u, v])[0]
            }
        }
    };
}

/// The albedo of the GGX lobe without Fresnel, over `(mu, alpha)`.
#[derive(Debug, Clone)]
pub struct GdLut(Checked);
common!(GdLut, GD);
texture!(GdLut, 1, 2);
mu_alpha!(GdLut);

/// Kulla & Conty's `E`: the albedo of the GGX lobe with `F = 1` (GD's integral, with the masking
/// model its manifest entry states), over `(mu, alpha)`.
#[derive(Debug, Clone)]
pub struct GgxELut(Checked);
common!(GgxELut, GGX_E);
texture!(GgxELut, 1, 2);
mu_alpha!(GgxELut);

/// Kulla & Conty's `E_avg = 2 ∫ E mu dmu`, over `alpha` alone: a texture of one row.
#[derive(Debug, Clone)]
pub struct GgxEAvgLut(Checked);
common!(GgxEAvgLut, GGX_E_AVG);
texture!(GgxEAvgLut, 1, 1);

impl GgxEAvgLut {
    /// The average at GGX `alpha` (a [`Roughness`] converts), interpolated in f64.
    pub fn sample(&self, alpha: impl Into<Alpha>) -> f32 {
        let [v] = interpolate(&self.0.table, [alpha.into().0 as f64]);
        v
    }

    /// [`GgxEAvgLut::sample`] as a shader reads the texture (a row, sampled at its centre).
    pub fn sample_gpu(&self, alpha: impl Into<Alpha>) -> f32 {
        self.filter([texture_coordinate(&self.0.table.axes[0], alpha.into().0 as f64)])[0]
    }
}

/// The fraction lost to total internal reflection, over `(mu, alpha)` and `eta` or the
/// critical-angle offset `asin(eta) - acos(mu)` (`docs/tables.md`); the handle computes the
/// offset where the table's third axis is it.
#[derive(Debug, Clone)]
pub struct TirLut(Checked);
common!(TirLut, TIR);
texture!(TirLut, 1, 3);

impl TirLut {
    /// The value the third axis samples at `(mu, eta)`.
    fn third(&self, mu: f64, eta: f64) -> f64 {
        if self.0.table.axes[2].name == CRITICAL_ANGLE_OFFSET { critical_angle_offset(mu, eta) } else { eta }
    }

    /// At `mu`, GGX `alpha` and the relative index `eta` (below 1: TIR happens inside the layer).
    pub fn sample(&self, mu: f32, alpha: impl Into<Alpha>, eta: f32) -> f32 {
        let alpha = alpha.into().0;
        let (mu, eta) = (mu as f64, eta as f64);
        let [v] = interpolate(&self.0.table, [mu, alpha as f64, self.third(mu, eta)]);
        v
    }

    /// [`TirLut::sample`] as a shader reads the texture: the third axis's quantity computed in f64,
    /// then every texture coordinate in f32 from the manifest's formulas.
    pub fn sample_gpu(&self, mu: f32, alpha: impl Into<Alpha>, eta: f32) -> f32 {
        let alpha = alpha.into().0;
        let table = &self.0.table;
        let (mu, eta) = (mu as f64, eta as f64);
        let [u, v] = uv(table, mu, alpha as f64);
        self.filter([u, v, texture_coordinate(&table.axes[2], self.third(mu, eta))])[0]
    }

    /// The texture sampled at texture coordinate `(u, v, w)`.
    pub fn sample_uvw(&self, u: f32, v: f32, w: f32) -> f32 {
        self.filter([u, v, w])[0]
    }
}

/// The directional albedo with exact Fresnel of a conductor or dielectric, over
/// `(mu, alpha, eta, kappa)`. Four axes: no texture holds it as it is (the GPU packings of
/// `docs/packing.md` do, read through `tmlut::packing`); it is interpolated on the CPU.
#[derive(Debug, Clone)]
pub struct FgdLut(Checked);
common!(FgdLut, FGD);

impl FgdLut {
    /// The albedo at `mu`, GGX `alpha` and the relative complex index `eta + i kappa`,
    /// interpolated in f64.
    pub fn sample(&self, mu: f32, alpha: impl Into<Alpha>, eta: f32, kappa: f32) -> f32 {
        let alpha = alpha.into().0;
        let [v] = interpolate(&self.0.table, [mu as f64, alpha as f64, eta as f64, kappa as f64]);
        v
    }
}

/// FGD of a dielectric onto a rarer medium (`kappa = 0`, `eta < 1`: a layer's light crossing up
/// into a lower index), over `(mu, alpha)` and the critical-angle fraction (`docs/tables.md`),
/// which the handle computes from `(mu, eta)`: a grid that follows the critical angle, where the 4D
/// table's separate `eta` axis cannot.
#[derive(Debug, Clone)]
pub struct FgdRarerLut(Checked);
common!(FgdRarerLut, FGD_RARER);
texture!(FgdRarerLut, 1, 3);

impl FgdRarerLut {
    /// At `mu`, GGX `alpha` and the relative index `eta` (below 1; clamped to [0, 1]).
    pub fn sample(&self, mu: f32, alpha: impl Into<Alpha>, eta: f32) -> f32 {
        let alpha = alpha.into().0;
        let (mu, eta) = (mu as f64, eta as f64);
        let [v] = interpolate(&self.0.table, [mu, alpha as f64, critical_angle_fraction(mu, eta)]);
        v
    }

    /// [`FgdRarerLut::sample`] as a shader reads the texture: the fraction computed in f64, then
    /// every texture coordinate in f32 from the manifest's formulas.
    pub fn sample_gpu(&self, mu: f32, alpha: impl Into<Alpha>, eta: f32) -> f32 {
        let alpha = alpha.into().0;
        let table = &self.0.table;
        let (mu, eta) = (mu as f64, eta as f64);
        let [u, v] = uv(table, mu, alpha as f64);
        self.filter([u, v, texture_coordinate(&table.axes[2], critical_angle_fraction(mu, eta))])[0]
    }

    /// The texture sampled at texture coordinate `(u, v, w)`.
    pub fn sample_uvw(&self, u: f32, v: f32, w: f32) -> f32 {
        self.filter([u, v, w])[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_handle_takes_the_texture_formats_in_their_order_then_every_other_format_once() {
        let preference = Shape::PREFERENCE;
        assert!(preference.starts_with(&FileFormat::TEXTURES), "{preference:?}");
        // A handle opens its table from whichever format a build wrote it in.
        for format in FileFormat::ALL {
            assert_eq!(preference.iter().filter(|&&f| f == format).count(), 1, "{format:?} in {preference:?}");
        }
    }
}
