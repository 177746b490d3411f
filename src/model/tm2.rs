//! The 2-flux transfer matrices: one 2 × 2 energy matrix per colour channel and one asymmetry
//! matrix per interface, their product down the stack, and the outgoing lobes as the increments
//! of the cumulative reflectance (Randrianandrasana et al. 2021, §4.3–4.4; the reference's
//! `transfer_matrix_2`, `energy_matrix`, `asymmetry_matrix` and 2-flux `outgoing_lobes`,
//! `docs/furnace.md`).

use super::factors::{Component, DielectricFactors, average};
use super::lookup::{Site, Tables};
use super::stack::Rgb;
use super::{LobeKind, RawLobe, below, first_order_tir};
use crate::physics::hg_refract;

/// Transmissions below this are read as this in `1 / t`: a lobe totally reflected (TIR = 1) or an
/// asymmetry of 0 gives the limit where nothing crosses, where the reference divides by zero.
pub const SMALLEST_TRANSMISSION: f64 = 1e-150;

/// `[[m11, m12], [m21, m22]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix2 {
    pub m11: f64,
    pub m12: f64,
    pub m21: f64,
    pub m22: f64,
}

impl Matrix2 {
    pub const IDENTITY: Matrix2 = Matrix2 { m11: 1.0, m12: 0.0, m21: 0.0, m22: 1.0 };

    /// The transfer matrix of an interface from its reflections and transmissions down (`r`, `t`)
    /// and up (`rp`, `tp`): `(1 / t) [[1, -rp], [r, t tp - r rp]]`.
    pub fn interface(r: f64, t: f64, rp: f64, tp: f64) -> Self {
        let inverse = 1.0 / t.max(SMALLEST_TRANSMISSION);
        Matrix2 { m11: inverse, m12: -rp * inverse, m21: r * inverse, m22: (t * tp - r * rp) * inverse }
    }

    /// A medium that only attenuates, by `t` each way: `diag(1 / t, t)`.
    pub fn attenuation(t: f64) -> Self {
        Matrix2 { m11: 1.0 / t.max(SMALLEST_TRANSMISSION), m12: 0.0, m21: 0.0, m22: t }
    }

    /// `self * other`, divided by its largest entry: the reflectances below are ratios of entries,
    /// so the scale is free, and removing it keeps a product of many strongly attenuating layers
    /// finite.
    pub fn then(&self, other: &Matrix2) -> Self {
        let m = Matrix2 {
            m11: self.m11 * other.m11 + self.m12 * other.m21,
            m12: self.m11 * other.m12 + self.m12 * other.m22,
            m21: self.m21 * other.m11 + self.m22 * other.m21,
            m22: self.m21 * other.m12 + self.m22 * other.m22,
        };
        let largest = m.m11.abs().max(m.m12.abs()).max(m.m21.abs()).max(m.m22.abs());
        if largest > 0.0 && largest.is_finite() {
            Matrix2 { m11: m.m11 / largest, m12: m.m12 / largest, m21: m.m21 / largest, m22: m.m22 / largest }
        } else {
            m
        }
    }

    /// Reflectance of the stack the matrix describes: `m21 / m11`.
    pub fn reflectance(&self) -> f64 {
        self.m21 / self.m11
    }

    /// Reflectance over a base of reflectance `base`: `(m21 + m22 base) / (m11 + m12 base)`.
    pub fn reflectance_over(&self, base: f64) -> f64 {
        (self.m21 + self.m22 * base) / (self.m11 + self.m12 * base)
    }
}

/// The outgoing lobes of the 2-flux model for a view of cosine `mu`, one per component.
pub fn lobes(components: &[(usize, Component)], tables: &dyn Tables) -> Vec<RawLobe> {
    let mut energy_matrix = [Matrix2::IDENTITY; 3];
    let mut asymmetry_matrix = Matrix2::IDENTITY;
    let (mut r_above, mut g_above): (Rgb, f64) = ([0.0; 3], 0.0);
    // First-order transmission asymmetry of the lobe arriving at the current interface.
    let mut g_transmitted = 1.0;
    let mut lobes = Vec::with_capacity(components.len());
    for (index, &(layer, component)) in components.iter().enumerate() {
        let (r_total, g_total): (Rgb, f64) = match component {
            Component::Pass => continue,
            Component::Dielectric(mut f) => {
                let below = below(&components[index + 1..]);
                g_transmitted = transmission_asymmetries(
                    &mut f,
                    g_transmitted,
                    below.reflection_g,
                    below.returns_light,
                    layer,
                    tables,
                );
                for (c, m) in energy_matrix.iter_mut().enumerate() {
                    *m = m.then(&Matrix2::interface(f.r.energy[c], f.t.energy[c], f.rp.energy[c], f.tp.energy[c]));
                }
                asymmetry_matrix = asymmetry_matrix.then(&Matrix2::interface(
                    f.r.weighted_g(),
                    f.t.weighted_g(),
                    f.rp.weighted_g(),
                    f.tp.weighted_g(),
                ));
                (energy_matrix.map(|m| m.reflectance()), asymmetry_matrix.reflectance())
            }
            Component::Medium(m) => {
                // An attenuator leaves the reflectance above it as it is: no lobe of its own.
                for (c, matrix) in energy_matrix.iter_mut().enumerate() {
                    *matrix = matrix.then(&Matrix2::attenuation(m.t.energy[c]));
                }
                asymmetry_matrix = asymmetry_matrix.then(&Matrix2::attenuation(m.t.weighted_g()));
                continue;
            }
            Component::Conductor { r } => (
                std::array::from_fn(|c| energy_matrix[c].reflectance_over(r.energy[c])),
                asymmetry_matrix.reflectance_over(r.weighted_g()),
            ),
        };
        // Where nothing crosses to what lies below (both sides reflecting totally), the ratios are
        // 0 / 0; their limit adds nothing to the light reflected above.
        let r_total: Rgb = std::array::from_fn(|c| if r_total[c].is_finite() { r_total[c] } else { r_above[c] });
        let g_total = if g_total.is_finite() { g_total } else { g_above };
        let energy: Rgb = std::array::from_fn(|c| r_total[c] - r_above[c]);
        let mean = average(&energy);
        // As the reference: g = min((G_0i - G_0h) / avg(e), 1) where the lobe carries energy, else 0.
        let g = if mean > 0.0 { ((g_total - g_above) / mean).min(1.0) } else { 0.0 };
        lobes.push(RawLobe { layer, kind: LobeKind::Primary, energy, g });
        r_above = r_total;
        g_above = g_total;
    }
    lobes
}

/// The first-order transmission asymmetries of a dielectric and its TIR correction (the reference's
/// 2-flux `outgoing_lobes`): `t.g` and `tp.g` become the ratios of the asymmetry a lobe has after
/// crossing to the one it had before, and the share of the transmitted lobe past the critical
/// angle moves from transmission to reflection on the side toward the lower index. Returns the
/// asymmetry of the lobe transmitted below, for the next interface.
///
/// `g_next_reflection` is the asymmetry a lobe keeps when reflected below (the next interface's,
/// times the media's crossed on the way for the 6-flux secondary flux). The upward correction is
/// made only where something below sends light back up: otherwise nothing crosses upward, and the
/// reflectances do not depend on it.
pub fn transmission_asymmetries(
    f: &mut DielectricFactors,
    g_arriving: f64,
    g_next_reflection: f64,
    light_returns: bool,
    layer: usize,
    tables: &dyn Tables,
) -> f64 {
    let (eta_down, eta_up) = (f.eta, 1.0 / f.eta);
    let g_below = hg_refract(g_arriving, eta_up) * f.t.g;
    let g_reflected_below = g_below * g_next_reflection;
    let g_back_up = hg_refract(g_reflected_below, eta_down) * f.tp.g;
    f.t.g = if g_arriving != 0.0 { g_below / g_arriving } else { 0.0 };
    f.tp.g = if g_reflected_below != 0.0 { g_back_up / g_reflected_below } else { 0.0 };
    if eta_down < 1.0 {
        first_order_tir(&mut f.r, &mut f.t, layer, Site::Down, f.cos_in, g_arriving, eta_down, tables);
    } else if light_returns {
        first_order_tir(&mut f.rp, &mut f.tp, layer, Site::Up, f.cos_below, g_reflected_below, eta_up, tables);
    }
    g_below
}
