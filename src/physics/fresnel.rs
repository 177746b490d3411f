//! Fresnel reflectance of a smooth interface.
//!
//! `eta + i kappa` is the complex index of the medium below relative to the medium above. One
//! formula covers dielectrics (`kappa = 0`, with total internal reflection when `eta < 1`) and
//! conductors. Sources:
//! - Born & Wolf, *Principles of Optics*, §14.2 (reflection at an absorbing medium), in the
//!   `a^2 + b^2` form of Heavens 1965 as collected by S. Lagarde 2013, "Memo on Fresnel equations";
//! - Schlick 1994, "An inexpensive BRDF model for physically-based rendering", eq. 15.

/// Unpolarised reflectance at incident cosine `cos_theta` (clamped to [0, 1]) of an interface with
/// relative complex index `eta + i kappa`.
///
/// With `s^2 = 1 - c^2`, `t0 = eta^2 - kappa^2 - s^2`, `a^2 + b^2 = sqrt(t0^2 + 4 eta^2 kappa^2)`
/// and `a = sqrt((a^2 + b^2 + t0) / 2)`:
/// `Rs = (a^2 + b^2 + c^2 - 2ac) / (a^2 + b^2 + c^2 + 2ac)`,
/// `Rp = Rs (c^2 (a^2 + b^2) + s^4 - 2acs^2) / (c^2 (a^2 + b^2) + s^4 + 2acs^2)`,
/// `F = (Rs + Rp) / 2`.
///
/// Guards, each at the root of a known failure (`notes/pitfalls.md`): `(a^2 + b^2 + t0) / 2` can
/// round below zero, so it is clamped before the square root; past the critical angle of a
/// dielectric with `eta < 1` it is exactly zero and both ratios become 1 (total internal
/// reflection); `eta = 1, kappa = 0` is no interface at all and reflects nothing, where the
/// formula alone would give `0 / 0` at grazing incidence; at normal incidence `Rp = Rs`, where the
/// formula alone would give `0 / 0` for `eta = kappa = 0`.
pub fn fresnel_reflectance(cos_theta: f64, eta: f64, kappa: f64) -> f64 {
    if eta == 1.0 && kappa == 0.0 {
        return 0.0;
    }
    let c = cos_theta.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let eta2 = eta * eta;
    let kappa2 = kappa * kappa;
    let t0 = eta2 - kappa2 - s2;
    let a2_plus_b2 = (t0 * t0 + 4.0 * eta2 * kappa2).sqrt();
    let a = (0.5 * (a2_plus_b2 + t0)).max(0.0).sqrt();
    let t1 = a2_plus_b2 + c2;
    let t2 = 2.0 * a * c;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2_plus_b2 + s2 * s2;
    let t4 = t2 * s2;
    // At normal incidence the two polarisations are the same wave; the ratio is 0 / 0 there when
    // eta = kappa = 0.
    let rp = if s2 == 0.0 { rs } else { rs * (t3 - t4) / (t3 + t4) };
    (0.5 * (rs + rp)).clamp(0.0, 1.0)
}

/// Reflectance at normal incidence, `((eta - 1)^2 + kappa^2) / ((eta + 1)^2 + kappa^2)`.
pub fn normal_incidence_reflectance(eta: f64, kappa: f64) -> f64 {
    ((eta - 1.0).powi(2) + kappa * kappa) / ((eta + 1.0).powi(2) + kappa * kappa)
}

/// Cosine of the critical angle of a dielectric interface with relative index `eta < 1`:
/// directions with a smaller cosine are totally reflected (`sin theta > eta`). `None` for
/// `eta >= 1`, where every direction transmits.
pub fn critical_cosine(eta: f64) -> Option<f64> {
    (eta < 1.0).then(|| (1.0 - eta * eta).max(0.0).sqrt())
}

/// Schlick's approximation `F0 + (1 - F0) (1 - c)^5` (Schlick 1994, eq. 15).
pub fn schlick_reflectance(cos_theta: f64, f0: f64) -> f64 {
    f0 + (1.0 - f0) * schlick_weight(cos_theta)
}

/// The Schlick weight `(1 - c)^5` on its own: the Karis split-sum table integrates it.
pub fn schlick_weight(cos_theta: f64) -> f64 {
    (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_the_closed_form() {
        for (eta, kappa) in [(1.5, 0.0), (0.2, 3.0), (1.0, 1.0), (4.0, 4.0), (0.5, 0.0), (2.0, 100.0), (0.0, 0.0)] {
            let f = fresnel_reflectance(1.0, eta, kappa);
            let expected = normal_incidence_reflectance(eta, kappa);
            assert!((f - expected).abs() < 1e-14, "eta {eta} kappa {kappa}: {f} vs {expected}");
        }
        assert!((fresnel_reflectance(1.0, 1.5, 0.0) - 0.04).abs() < 1e-15);
    }

    #[test]
    fn dielectric_matches_the_polarised_textbook_form() {
        let eta: f64 = 1.5;
        for c in [0.05f64, 0.3, 0.7, 0.95] {
            let s = (1.0 - c * c).sqrt();
            let ct = (1.0 - (s / eta).powi(2)).sqrt();
            let rs = ((c - eta * ct) / (c + eta * ct)).powi(2);
            let rp = ((eta * c - ct) / (eta * c + ct)).powi(2);
            let f = fresnel_reflectance(c, eta, 0.0);
            assert!((f - 0.5 * (rs + rp)).abs() < 1e-13, "c {c}: {f}");
        }
    }

    #[test]
    fn total_internal_reflection_past_the_critical_angle() {
        let eta = 1.0 / 1.5;
        let critical = critical_cosine(eta).unwrap();
        assert!((critical - (1.0 - eta * eta).sqrt()).abs() < 1e-15);
        assert_eq!(fresnel_reflectance(critical * 0.999, eta, 0.0), 1.0);
        assert_eq!(fresnel_reflectance(0.0, eta, 0.0), 1.0);
        assert!(fresnel_reflectance(critical * 1.001, eta, 0.0) < 1.0);
        // Continuous at the critical angle: F rises to 1 there.
        assert!(fresnel_reflectance(critical + 1e-10, eta, 0.0) > 0.999);
        assert_eq!(critical_cosine(1.2), None);
    }

    #[test]
    fn no_interface_reflects_nothing() {
        for c in [0.0, 0.5, 1.0] {
            assert_eq!(fresnel_reflectance(c, 1.0, 0.0), 0.0);
        }
    }

    #[test]
    fn grazing_incidence_reflects_everything() {
        for (eta, kappa) in [(1.5, 0.0), (0.3, 2.0), (1.000001, 0.0)] {
            assert!((fresnel_reflectance(0.0, eta, kappa) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn large_kappa_approaches_total_reflection_and_stays_finite() {
        for c in [0.0, 1e-7, 0.3, 1.0] {
            let f = fresnel_reflectance(c, 1.0, 1e4);
            assert!(f.is_finite() && f > 0.9999 && f <= 1.0, "c {c}: {f}");
        }
    }

    #[test]
    fn schlick_is_exact_at_the_ends() {
        assert_eq!(schlick_reflectance(1.0, 0.04), 0.04);
        assert_eq!(schlick_reflectance(0.0, 0.04), 1.0);
        assert_eq!(schlick_weight(0.5), 1.0 / 32.0);
    }
}
