//! The tables tmlut builds, as every reader knows them: one list, [`TableKind::ALL`], with each
//! table's name (its manifest `table`, its file stem, its TOML section) and the shape a reader
//! requires of it (axis names and channel count). [`TableKind`] is `#[non_exhaustive]`: a table
//! added is no breaking change to a renderer's `match`, which keeps a wildcard arm. The generator,
//! which must decide something for every kind, does so through `PerKind`, a value per kind whose
//! literal names every kind: its registry (`tmlut::recipes`) pairs each kind with its recipe that
//! way, so a kind without a recipe, or a recipe without a kind, does not compile; the loader's
//! handles, the model's folder tables and the scene shader's sources find each table by its kind,
//! and the model decides for every kind whether it stands in for a quantity's own table
//! (`tmlut::model::stand_in`).

use super::derived::{CRITICAL_ANGLE_FRACTION, CRITICAL_ANGLE_OFFSET};

/// One table tmlut knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TableKind {
    /// `FGD(mu, alpha, eta, kappa)`: an interface's directional albedo, the 4D table.
    Fgd,
    /// `GD(mu, alpha)`: a GGX lobe's directional albedo without Fresnel.
    Gd,
    /// `TIR(mu, alpha, eta)`: the share of a lobe lost to total internal reflection.
    Tir,
    /// The Belcour–Bati–Barla 2020 split-sum table over a Fresnel basis.
    Belcour,
    /// The Karis split-sum table (Schlick Fresnel).
    Karis,
    /// FGD of a dielectric onto a rarer medium, over the critical-angle fraction.
    FgdRarer,
    /// `E(mu, alpha)`: a GGX lobe's directional albedo with `F = 1`, the energy-compensation
    /// table of Kulla & Conty 2017 (GD's integral, with the masking model a setting).
    GgxE,
    /// `E_avg(alpha) = 2 ∫ E(mu, alpha) mu dmu`: the hemispherical average of [`TableKind::GgxE`].
    GgxEAvg,
    /// The Karis split sum arranged for multiple-scattering compensation: `(bias, albedo)`, the
    /// `F90` part and the albedo with `F = 1` (Filament's `DFG` multiscatter pair).
    KarisMultiscatter,
}

/// What a reader requires of a table: the names each axis may have, in order, and the channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableShape {
    /// Per axis, in order, the quantity names it may have (e.g. `eta` or `critical_angle_offset`).
    pub axes: &'static [&'static [&'static str]],
    /// The number of channels.
    pub channels: usize,
}

impl TableKind {
    /// Every table, in build order.
    pub const ALL: &'static [TableKind] = &[
        TableKind::Fgd,
        TableKind::Gd,
        TableKind::Tir,
        TableKind::Belcour,
        TableKind::Karis,
        TableKind::FgdRarer,
        TableKind::GgxE,
        TableKind::GgxEAvg,
        TableKind::KarisMultiscatter,
    ];

    /// The table's name: its manifest `table`, its file stem, its TOML section and `--only` name.
    pub const fn name(self) -> &'static str {
        match self {
            TableKind::Fgd => "fgd",
            TableKind::Gd => "gd",
            TableKind::Tir => "tir",
            TableKind::Belcour => "belcour",
            TableKind::Karis => "karis",
            TableKind::FgdRarer => "fgd_rarer",
            TableKind::GgxE => "ggx_e",
            TableKind::GgxEAvg => "ggx_e_avg",
            TableKind::KarisMultiscatter => "karis_multiscatter",
        }
    }

    /// The table called `name`.
    pub fn named(name: &str) -> Option<TableKind> {
        TableKind::ALL.iter().copied().find(|kind| kind.name() == name)
    }

    /// Every table's name, in build order.
    pub fn names() -> Vec<&'static str> {
        TableKind::ALL.iter().map(|kind| kind.name()).collect()
    }

    /// The axes and channels a reader requires of the whole table (a scene's slices of FGD and
    /// TIR are tables of their own, `fgd_*` and `tir_*`, over `mu` and `alpha`).
    pub fn shape(self) -> TableShape {
        const MU_ALPHA: [&[&str]; 2] = [&["mu"], &["alpha"]];
        match self {
            TableKind::Fgd => TableShape { axes: &[&["mu"], &["alpha"], &["eta"], &["kappa"]], channels: 1 },
            TableKind::Gd => TableShape { axes: &MU_ALPHA, channels: 1 },
            TableKind::Tir => TableShape { axes: &[&["mu"], &["alpha"], &["eta", CRITICAL_ANGLE_OFFSET]], channels: 1 },
            TableKind::Belcour => TableShape { axes: &MU_ALPHA, channels: 4 },
            TableKind::Karis => TableShape { axes: &MU_ALPHA, channels: 2 },
            TableKind::FgdRarer => TableShape { axes: &[&["mu"], &["alpha"], &[CRITICAL_ANGLE_FRACTION]], channels: 1 },
            TableKind::GgxE => TableShape { axes: &MU_ALPHA, channels: 1 },
            TableKind::GgxEAvg => TableShape { axes: &[&["alpha"]], channels: 1 },
            TableKind::KarisMultiscatter => TableShape { axes: &MU_ALPHA, channels: 2 },
        }
    }
}

/// A value for each table kind, a field per kind named as the kind is ([`TableKind::name`]).
///
/// Outside this crate a `match` on [`TableKind`] needs a wildcard arm, so it no longer says that
/// every kind was decided; a literal of this struct does, and [`PerKind::take`] is the exhaustive
/// `match`, here. The generator decides each kind through it (its registry of recipes, its stiff
/// cases, the model's stand-ins): a kind added here does not compile there until it is decided.
/// Hidden from the documentation because it gains a field with each kind, on purpose: a renderer
/// matches [`TableKind`] with a wildcard arm instead.
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PerKind<T> {
    /// [`TableKind::Fgd`]'s value.
    pub fgd: T,
    /// [`TableKind::Gd`]'s value.
    pub gd: T,
    /// [`TableKind::Tir`]'s value.
    pub tir: T,
    /// [`TableKind::Belcour`]'s value.
    pub belcour: T,
    /// [`TableKind::Karis`]'s value.
    pub karis: T,
    /// [`TableKind::FgdRarer`]'s value.
    pub fgd_rarer: T,
    /// [`TableKind::GgxE`]'s value.
    pub ggx_e: T,
    /// [`TableKind::GgxEAvg`]'s value.
    pub ggx_e_avg: T,
    /// [`TableKind::KarisMultiscatter`]'s value.
    pub karis_multiscatter: T,
}

impl<T> PerKind<T> {
    /// The value of `kind`, the others dropped.
    pub fn take(self, kind: TableKind) -> T {
        match kind {
            TableKind::Fgd => self.fgd,
            TableKind::Gd => self.gd,
            TableKind::Tir => self.tir,
            TableKind::Belcour => self.belcour,
            TableKind::Karis => self.karis,
            TableKind::FgdRarer => self.fgd_rarer,
            TableKind::GgxE => self.ggx_e,
            TableKind::GgxEAvg => self.ggx_e_avg,
            TableKind::KarisMultiscatter => self.karis_multiscatter,
        }
    }
}

impl std::fmt::Display for TableKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_takes_the_field_of_its_name() {
        let names = PerKind {
            fgd: "fgd",
            gd: "gd",
            tir: "tir",
            belcour: "belcour",
            karis: "karis",
            fgd_rarer: "fgd_rarer",
            ggx_e: "ggx_e",
            ggx_e_avg: "ggx_e_avg",
            karis_multiscatter: "karis_multiscatter",
        };
        for &kind in TableKind::ALL {
            assert_eq!(names.take(kind), kind.name());
        }
    }
}
