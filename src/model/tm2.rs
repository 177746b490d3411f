//! The 2-flux transfer matrices: one 2 × 2 energy matrix per colour channel and one asymmetry
//! matrix per interface, their product down the stack, and the outgoing lobes as the increments
//! of the cumulative reflectance (Randrianandrasana et al. 2021, §4.3–4.4; the reference's
//! `transfer_matrix_2`, `energy_matrix`, `asymmetry_matrix` and 2-flux `outgoing_lobes`,
//! `docs/furnace.md`).

use super::factors::{Component, DielectricFactors, average};
use super::lookup::{Site, Tables};
use super::{LobeKind, RawLobe, below, first_order_tir};
use crate::ir::real::{Compare, Real};
use crate::physics::hg_refract;

/// Transmissions below this are read as this in `1 / t`: a lobe totally reflected (TIR = 1) or an
/// asymmetry of 0 gives the limit where nothing crosses, where the reference divides by zero
/// (the f64 value of [`Real::smallest_transmission`]).
pub const SMALLEST_TRANSMISSION: f64 = 1e-150;

/// `1 / t`, with `t` floored at the number type's smallest transmission.
pub fn inverse<R: Real>(t: R) -> R {
    R::of(1.0) / t.max(R::smallest_transmission())
}

/// What a transfer matrix is divided by to keep its entries finite: its largest entry in
/// magnitude, or 1 where that is 0 or not finite. The reflectances are ratios of entries, so the
/// scale is free, and removing it keeps a product of many strongly attenuating layers finite.
pub fn normalising_scale<R: Real>(largest: R) -> R {
    let one = R::of(1.0);
    R::choose(
        Compare::Gt,
        largest,
        R::of(0.0),
        || R::choose(Compare::Le, largest, R::largest_finite(), || largest, || one),
        || one,
    )
}

/// `[[m11, m12], [m21, m22]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix2<R = f64> {
    pub m11: R,
    pub m12: R,
    pub m21: R,
    pub m22: R,
}

impl<R: Real> Matrix2<R> {
    pub fn identity() -> Self {
        let (zero, one) = (R::of(0.0), R::of(1.0));
        Matrix2 { m11: one, m12: zero, m21: zero, m22: one }
    }

    /// The transfer matrix of an interface from its reflections and transmissions down (`r`, `t`)
    /// and up (`rp`, `tp`): `(1 / t) [[1, -rp], [r, t tp - r rp]]`.
    pub fn interface(r: R, t: R, rp: R, tp: R) -> Self {
        let inverse = inverse(t);
        Matrix2 { m11: inverse, m12: -rp * inverse, m21: r * inverse, m22: (t * tp - r * rp) * inverse }
    }

    /// A medium that only attenuates, by `t` each way: `diag(1 / t, t)`.
    pub fn attenuation(t: R) -> Self {
        let zero = R::of(0.0);
        Matrix2 { m11: inverse(t), m12: zero, m21: zero, m22: t }
    }

    /// `self * other`, divided by its [`normalising_scale`].
    pub fn then(&self, other: &Matrix2<R>) -> Self {
        let m = Matrix2 {
            m11: self.m11 * other.m11 + self.m12 * other.m21,
            m12: self.m11 * other.m12 + self.m12 * other.m22,
            m21: self.m21 * other.m11 + self.m22 * other.m21,
            m22: self.m21 * other.m12 + self.m22 * other.m22,
        };
        let largest = m.m11.abs().max(m.m12.abs()).max(m.m21.abs()).max(m.m22.abs());
        let scale = normalising_scale(largest);
        Matrix2 { m11: m.m11 / scale, m12: m.m12 / scale, m21: m.m21 / scale, m22: m.m22 / scale }
    }

    /// Reflectance of the stack the matrix describes: `m21 / m11`.
    pub fn reflectance(&self) -> R {
        self.m21 / self.m11
    }

    /// Reflectance over a base of reflectance `base`: `(m21 + m22 base) / (m11 + m12 base)`.
    pub fn reflectance_over(&self, base: R) -> R {
        (self.m21 + self.m22 * base) / (self.m11 + self.m12 * base)
    }
}

/// The outgoing lobes of the 2-flux model for a view of cosine `mu`, one per component.
pub fn lobes<R: Real>(components: &[(usize, Component<R>)], tables: &dyn Tables<R>) -> Vec<RawLobe<R>> {
    let zero = R::of(0.0);
    let mut energy_matrix = [Matrix2::identity(); 3];
    let mut asymmetry_matrix = Matrix2::identity();
    let (mut r_above, mut g_above) = ([zero; 3], zero);
    // First-order transmission asymmetry of the lobe arriving at the current interface.
    let mut g_transmitted = R::of(1.0);
    let mut lobes = Vec::with_capacity(components.len());
    for (index, &(layer, component)) in components.iter().enumerate() {
        let (r_total, g_total): ([R; 3], R) = match component {
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
        let r_total: [R; 3] = std::array::from_fn(|c| r_total[c].finite_or(r_above[c]));
        let g_total = g_total.finite_or(g_above);
        let energy: [R; 3] = std::array::from_fn(|c| r_total[c] - r_above[c]);
        let mean = average(&energy);
        // As the reference: g = min((G_0i - G_0h) / avg(e), 1) where the lobe carries energy, else 0.
        let g = R::choose(Compare::Gt, mean, zero, || ((g_total - g_above) / mean).min(R::of(1.0)), || zero);
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
pub fn transmission_asymmetries<R: Real>(
    f: &mut DielectricFactors<R>,
    g_arriving: R,
    g_next_reflection: R,
    light_returns: bool,
    layer: usize,
    tables: &dyn Tables<R>,
) -> R {
    let (eta_down, eta_up) = (f.eta, 1.0 / f.eta);
    let zero = R::of(0.0);
    let g_below = hg_refract(g_arriving, R::of(eta_up)) * f.t.g;
    let g_reflected_below = g_below * g_next_reflection;
    let g_back_up = hg_refract(g_reflected_below, R::of(eta_down)) * f.tp.g;
    f.t.g = R::choose(Compare::Ne, g_arriving, zero, || g_below / g_arriving, || zero);
    f.tp.g = R::choose(Compare::Ne, g_reflected_below, zero, || g_back_up / g_reflected_below, || zero);
    if eta_down < 1.0 {
        first_order_tir(&mut f.r, &mut f.t, layer, Site::Down, f.cos_in, g_arriving, eta_down, tables);
    } else if light_returns {
        first_order_tir(&mut f.rp, &mut f.tp, layer, Site::Up, f.cos_below, g_reflected_below, eta_up, tables);
    }
    g_below
}
