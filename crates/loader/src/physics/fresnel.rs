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
/// With `s^2 = 1 - c^2`, `t0 = eta^2 - kappa^2 - s^2`, `a^2 + b^2 = sqrt(t0^2 + 4 eta^2 kappa^2)`,
/// `a^2 = (a^2 + b^2 + t0) / 2` and `b^2 = (a^2 + b^2 - t0) / 2` (so that `a + ib = n cos theta_t`):
/// `Rs = ((a - c)^2 + b^2) / ((a + c)^2 + b^2)`,
/// `Rp = Rs ((ac - s^2)^2 + (bc)^2) / ((ac + s^2)^2 + (bc)^2)`, `F = (Rs + Rp) / 2` — the
/// `a^2 + b^2` form of Heavens 1965 (as collected by Lagarde 2013) with its numerators multiplied
/// out as sums of squares, which is what keeps them non-negative and exact near `F = 0`.
///
/// Every difference that could cancel is taken in exact form (the stability matrix found each,
/// `docs/stability.md`): `t0 = (eta - 1)(eta + 1) - kappa^2 + c^2` and `s^2 = (1 - c)(1 + c)`
/// (`1 - c^2` loses every digit near the normal, which moved the critical angle of `eta = 1e-3`);
/// of `a^2` and `b^2` the one that would cancel is `2 eta^2 kappa^2` over the other
/// (`(a^2 + b^2)^2 - t0^2 = 4 eta^2 kappa^2`), where `(a^2 + b^2 + t0) / 2` lost the absorption of a
/// barely absorbing medium past its critical angle. Past the critical angle of a dielectric with
/// `eta < 1`, `a = 0` and both ratios are exactly 1 (total internal reflection). `eta = 1,
/// kappa = 0` is no interface at all and reflects nothing (the ratios alone are `0 / 0` at grazing
/// incidence); at normal incidence with `eta = kappa = 0` the `Rp` ratio is `0 / 0` and its limit,
/// 1, is taken.
pub fn fresnel_reflectance(cos_theta: f64, eta: f64, kappa: f64) -> f64 {
    if eta == 1.0 && kappa == 0.0 {
        return 0.0;
    }
    let c = cos_theta.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = (1.0 - c) * (1.0 + c);
    let t0 = (eta - 1.0) * (eta + 1.0) - kappa * kappa + c2;
    let two_eta_kappa = 2.0 * eta * kappa;
    let (a2, b2) = if kappa == 0.0 {
        // A dielectric: exactly what the general form below gives with `hypot(t0, 0) = |t0|`,
        // without the library call (a build evaluates a dielectric's Fresnel some 10^8 times, in the
        // per-sample estimates of `fgd_rarer` and of FGD's `kappa = 0` plane).
        if t0 >= 0.0 { (t0, 0.0) } else { (0.0, -t0) }
    } else {
        // Of `a^2` and `b^2`, the one on the side of `t0`'s sign is `|t0|` plus the small
        // `((a^2 + b^2) - |t0|) / 2`, taken as `y^2 / (2 ((a^2 + b^2) + |t0|))` with
        // `y = 2 eta kappa`: no cancellation, and the modulus's own rounding reaches the result
        // only through that small term (near `eta = 1` and the normal, `F` is the square of the
        // difference of nearly equal `a` and `c`, and an ulp of the modulus moved it by 1e-10).
        let y2 = two_eta_kappa * two_eta_kappa;
        let magnitude = t0.abs();
        let larger = magnitude + 0.5 * y2 / (modulus(t0, two_eta_kappa) + magnitude);
        let smaller = if larger > 0.0 { 0.25 * y2 / larger } else { 0.0 };
        if t0 >= 0.0 { (larger, smaller) } else { (smaller, larger) }
    };
    let (a, b) = (a2.sqrt(), b2.sqrt());
    let rs = ((a - c).powi(2) + b2) / ((a + c).powi(2) + b2);
    let rp_denominator = (a * c + s2).powi(2) + (b * c).powi(2);
    let rp_ratio = if rp_denominator == 0.0 { 1.0 } else { ((a * c - s2).powi(2) + (b * c).powi(2)) / rp_denominator };
    (0.5 * rs * (1.0 + rp_ratio)).clamp(0.0, 1.0)
}

/// `sqrt(x^2 + y^2)`, inline: the library's `hypot` is a call the compiler cannot inline or
/// vectorise, and a build evaluates a conductor's Fresnel some 10^8 times (narrow lobes'
/// corrections, the exact values of the interpolation checks). The squares lose nothing unless
/// their sum leaves the normal range, where `hypot`'s scaling takes over.
#[inline(always)]
fn modulus(x: f64, y: f64) -> f64 {
    let sum_of_squares = x * x + y * y;
    if (f64::MIN_POSITIVE..f64::MAX).contains(&sum_of_squares) { sum_of_squares.sqrt() } else { x.hypot(y) }
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
    fn no_cancellation_near_the_normal_or_with_faint_absorption() {
        // Found by the stability matrix. The critical cosine of eta = 1e-3 is 1 - 5e-7, where
        // 1 - c^2 kept 9 digits and put F(c*) at 0.982; the textbook amplitudes give 0.9710663 (not
        // 1: the kink is so steep that the rounding of c* itself moves F by 3e-2).
        let critical = critical_cosine(1e-3).unwrap();
        assert!((fresnel_reflectance(critical, 1e-3, 0.0) - 0.971_066_347_069_6).abs() < 1e-9);
        // Past the critical angle, kappa = 1e-6 absorbs 3.5e-9 of the light at c = 0.5 (the
        // textbook complex amplitudes); (a^2 + b^2 + t0) / 2 cancelled to 0 and gave F = 1.
        let f = fresnel_reflectance(0.5, 1e-3, 1e-6);
        assert!((1.0 - f - 3.4641066e-9).abs() < 1e-15, "{f}");
        // Just above 1: ((eta - 1) / (eta + 1))^2 to 12 digits, not 4.
        let eta = 1.0 + 1e-6;
        let expected = normal_incidence_reflectance(eta, 0.0);
        assert!((fresnel_reflectance(1.0 - 1e-7, eta, 0.0) - expected).abs() < 1e-3 * expected);
    }

    #[test]
    fn schlick_is_exact_at_the_ends() {
        assert_eq!(schlick_reflectance(1.0, 0.04), 0.04);
        assert_eq!(schlick_reflectance(0.0, 0.04), 1.0);
        assert_eq!(schlick_weight(0.5), 1.0 / 32.0);
    }
}
