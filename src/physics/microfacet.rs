//! The GGX (Trowbridge–Reitz) microfacet distribution and its Smith masking-shadowing terms.
//!
//! Local frame with z up; every direction points away from the surface. `alpha` is the GGX
//! roughness (not perceptual roughness). Sources:
//! - Walter, Marschner, Li, Torrance 2007, "Microfacet models for refraction through rough
//!   surfaces", eq. 33 (D) and eq. 34 (G1 of GGX);
//! - Heitz 2014, "Understanding the masking-shadowing function in microfacet-based BRDFs",
//!   eq. 72 (Lambda of GGX), eq. 98 (separable G2) and eq. 99 (height-correlated G2);
//! - Karis 2013, "Real shading in Unreal Engine 4", p. 3 (Schlick–Smith with k = alpha / 2);
//! - Heitz 2018, "Sampling the GGX distribution of visible normals", eq. 1 (the VNDF).
//!
//! Grazing directions (`z = 0`) and `alpha = 0` are limits, not errors: every function here
//! returns the limit there instead of `0 * inf` (`notes/pitfalls.md`).

use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// `alpha^2 tan^2(theta)` of a direction, the argument of Lambda. `+inf` at the horizon for a
/// rough surface, 0 for a smooth one.
#[inline]
fn alpha_squared_tan_squared(w: DVec3, alpha: f64) -> f64 {
    let cos2 = w.z * w.z;
    let sin2 = (1.0 - cos2).max(0.0);
    if alpha == 0.0 || sin2 == 0.0 {
        0.0
    } else if cos2 == 0.0 {
        f64::INFINITY
    } else {
        alpha * alpha * sin2 / cos2
    }
}

/// GGX normal distribution `D(h) = alpha^2 / (pi (1 + (alpha^2 - 1) h.z^2)^2)` (Walter et al.
/// 2007, eq. 33), zero below the horizon, for a unit `h`.
///
/// The denominator is written `alpha^2 h.z^2 + sin^2`, with `sin^2 = h.x^2 + h.y^2` from the
/// tangential components: `1 + (alpha^2 - 1) h.z^2` cancels near the normal, where for small alpha
/// `D` lives (the stability matrix measured 1.6e-3 relative error at alpha = 1e-7, h = n). At
/// `alpha = 0` the distribution is a Dirac at `n`: 0 elsewhere and `+inf` at `n`, where the formula
/// alone gives `0 / 0`.
pub fn ggx_distribution(h: DVec3, alpha: f64) -> f64 {
    if h.z < 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let denominator = a2 * h.z * h.z + (h.x * h.x + h.y * h.y);
    if denominator == 0.0 {
        return if a2 == 0.0 { f64::INFINITY } else { 0.0 };
    }
    a2 / (PI * denominator * denominator)
}

/// Smith's `Lambda(w) = (-1 + sqrt(1 + alpha^2 tan^2)) / 2` for GGX (Heitz 2014, eq. 72),
/// evaluated as `x / (2 (1 + sqrt(1 + x)))` with `x = alpha^2 tan^2`, which is the same quantity
/// without the cancellation that loses all digits for small `x`.
#[inline]
pub fn smith_lambda(w: DVec3, alpha: f64) -> f64 {
    let x = alpha_squared_tan_squared(w, alpha);
    if x.is_infinite() {
        return f64::INFINITY;
    }
    x / (2.0 * (1.0 + (1.0 + x).sqrt()))
}

/// Smith masking `G1(w) = 1 / (1 + Lambda(w))` (Heitz 2014, eq. 43); 0 at and below the horizon
/// of a rough surface.
#[inline]
pub fn smith_g1(w: DVec3, alpha: f64) -> f64 {
    if w.z <= 0.0 && !(w.z == 0.0 && alpha == 0.0) {
        return 0.0;
    }
    1.0 / (1.0 + smith_lambda(w, alpha))
}

/// Separable Smith masking-shadowing `G2 = G1(wi) G1(wo)` (Heitz 2014, eq. 98), the form of
/// Mitsuba and of the transfer-matrix reference implementation.
pub fn smith_g2_separable(wi: DVec3, wo: DVec3, alpha: f64) -> f64 {
    smith_g1(wi, alpha) * smith_g1(wo, alpha)
}

/// Height-correlated Smith masking-shadowing `G2 = 1 / (1 + Lambda(wi) + Lambda(wo))`
/// (Heitz 2014, eq. 99), the form the thesis renderer evaluates.
pub fn smith_g2_height_correlated(wi: DVec3, wo: DVec3, alpha: f64) -> f64 {
    if wi.z < 0.0 || wo.z < 0.0 {
        return 0.0;
    }
    1.0 / (1.0 + smith_lambda(wi, alpha) + smith_lambda(wo, alpha))
}

/// The Schlick approximation of Smith's G1 as Unreal Engine 4 uses it for image-based lighting:
/// `G1(w) = w.z / (w.z (1 - k) + k)` with `k = alpha / 2` (Karis 2013, eq. 4).
#[inline]
pub fn schlick_smith_g1(w: DVec3, alpha: f64) -> f64 {
    let k = alpha / 2.0;
    let cos = w.z.max(0.0);
    if cos == 0.0 && k == 0.0 {
        return 1.0;
    }
    cos / (cos * (1.0 - k) + k)
}

/// Which masking-shadowing function a table integrates with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaskingShadowing {
    /// `G1(wi) G1(wo)`, Smith GGX (Heitz 2014, eq. 98).
    SmithSeparable,
    /// `1 / (1 + Lambda(wi) + Lambda(wo))` (Heitz 2014, eq. 99).
    SmithHeightCorrelated,
    /// Schlick–Smith with `k = alpha / 2`, separable, as in Unreal Engine 4 (Karis 2013).
    SchlickSmith,
}

impl MaskingShadowing {
    pub const ALL: [MaskingShadowing; 3] =
        [MaskingShadowing::SmithSeparable, MaskingShadowing::SmithHeightCorrelated, MaskingShadowing::SchlickSmith];

    pub fn name(self) -> &'static str {
        match self {
            MaskingShadowing::SmithSeparable => "smith-separable",
            MaskingShadowing::SmithHeightCorrelated => "smith-height-correlated",
            MaskingShadowing::SchlickSmith => "schlick-smith",
        }
    }

    /// `G2(wi, wo)`.
    pub fn g2(self, wi: DVec3, wo: DVec3, alpha: f64) -> f64 {
        match self {
            MaskingShadowing::SmithSeparable => smith_g2_separable(wi, wo, alpha),
            MaskingShadowing::SmithHeightCorrelated => smith_g2_height_correlated(wi, wo, alpha),
            MaskingShadowing::SchlickSmith => schlick_smith_g1(wi, alpha) * schlick_smith_g1(wo, alpha),
        }
    }

    /// `G2(wi, wo) / G1(wi)` with Smith's G1 of GGX in the denominator: the weight of a sample drawn
    /// from the visible normals of `wi`, for which `∫ f(wi.h) D G2 / (4 wi.z) dwo = E[f(wi.h) *
    /// weight]` (Heitz 2018, eq. 1 and §2). Zero when `wo` is below the horizon. Written so that
    /// it keeps its finite limit at grazing `wi`, where both `G2` and `G1(wi)` vanish.
    #[inline]
    pub fn visible_normal_weight(self, wi: DVec3, wo: DVec3, alpha: f64) -> f64 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        match self {
            // G1(wi) G1(wo) / G1(wi).
            MaskingShadowing::SmithSeparable => smith_g1(wo, alpha),
            // (1 + Lambda_i) / (1 + Lambda_i + Lambda_o) = 1 / (1 + Lambda_o / (1 + Lambda_i)),
            // which tends to 1 as Lambda_i grows without bound at the horizon.
            MaskingShadowing::SmithHeightCorrelated => {
                let lambda_i = smith_lambda(wi, alpha);
                1.0 / (1.0 + smith_lambda(wo, alpha) / (1.0 + lambda_i))
            }
            // G1s(wi) (1 + Lambda_i) G1s(wo) with G1s(wi) (1 + Lambda_i) multiplied out as
            // (mu + sqrt(mu^2 + alpha^2 (1 - mu^2))) / (2 (mu (1 - k) + k)), finite at mu = 0.
            MaskingShadowing::SchlickSmith => {
                let mu = wi.z.max(0.0);
                let k = alpha / 2.0;
                let numerator = mu + (mu * mu + alpha * alpha * (1.0 - mu * mu)).max(0.0).sqrt();
                let denominator = 2.0 * (mu * (1.0 - k) + k);
                let ratio = if denominator == 0.0 { 1.0 } else { numerator / denominator };
                ratio * schlick_smith_g1(wo, alpha)
            }
        }
    }
}

/// Density of the visible normals of `wi`, `D_wi(h) = G1(wi) max(0, wi.h) D(h) / wi.z`
/// (Heitz 2018, eq. 1), with respect to solid angle of `h`.
pub fn visible_normal_density(wi: DVec3, h: DVec3, alpha: f64) -> f64 {
    if wi.z <= 0.0 {
        return 0.0;
    }
    smith_g1(wi, alpha) * wi.dot(h).max(0.0) * ggx_distribution(h, alpha) / wi.z
}

/// Mirror `w` about the normal `h`: `2 (w.h) h - w`.
#[inline]
pub fn reflect(w: DVec3, h: DVec3) -> DVec3 {
    2.0 * w.dot(h) * h - w
}

/// The direction with cosine `mu` to the normal, in the xz plane (the tables' convention). The sine
/// is `sqrt((1 - mu)(1 + mu))`: `1 - mu^2` cancels near the normal.
pub fn direction_from_cosine(mu: f64) -> DVec3 {
    let mu = mu.clamp(0.0, 1.0);
    DVec3::new(((1.0 - mu) * (1.0 + mu)).sqrt(), 0.0, mu)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint quadrature over the upper hemisphere in (cos theta, phi).
    fn hemisphere_integral(f: impl Fn(DVec3) -> f64, n_theta: usize, n_phi: usize) -> f64 {
        let mut sum = 0.0;
        for i in 0..n_theta {
            // Substitute cos theta = 1 - s^2 to resolve the narrow peak of D around the normal.
            let s = (i as f64 + 0.5) / n_theta as f64;
            let cos = 1.0 - s * s;
            let jacobian = 2.0 * s / n_theta as f64;
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            for j in 0..n_phi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / n_phi as f64;
                sum += f(DVec3::new(sin * phi.cos(), sin * phi.sin(), cos)) * jacobian * 2.0 * PI / n_phi as f64;
            }
        }
        sum
    }

    #[test]
    fn projected_area_of_ggx_is_one() {
        for alpha in [0.05, 0.2, 0.5, 1.0] {
            let area = hemisphere_integral(|h| ggx_distribution(h, alpha) * h.z, 4000, 8);
            assert!((area - 1.0).abs() < 1e-4, "alpha {alpha}: {area}");
        }
    }

    #[test]
    fn visible_normals_integrate_to_one() {
        for alpha in [0.1, 0.5, 1.0] {
            for mu in [0.05, 0.5, 1.0] {
                let wi = direction_from_cosine(mu);
                let total = hemisphere_integral(|h| visible_normal_density(wi, h, alpha), 3000, 256);
                assert!((total - 1.0).abs() < 2e-3, "alpha {alpha} mu {mu}: {total}");
            }
        }
    }

    #[test]
    fn lambda_matches_the_direct_formula_and_vanishes_when_smooth() {
        let w = direction_from_cosine(0.3);
        let alpha: f64 = 0.7;
        let tan2 = (1.0 - 0.09) / 0.09;
        let direct = (-1.0 + (1.0 + alpha * alpha * tan2).sqrt()) / 2.0;
        assert!((smith_lambda(w, alpha) - direct).abs() < 1e-14);
        assert_eq!(smith_lambda(w, 0.0), 0.0);
        assert_eq!(smith_g1(direction_from_cosine(0.0), 0.0), 1.0);
        assert_eq!(smith_g1(direction_from_cosine(0.0), 0.5), 0.0);
        // The cancellation-free form keeps digits where the direct one returns 0.
        let tiny = smith_lambda(direction_from_cosine(0.5), 1e-9);
        assert!(tiny > 0.0 && (tiny - 0.25 * 1e-18 * 3.0).abs() < 1e-30, "{tiny}");
    }

    #[test]
    fn g1_has_the_square_root() {
        // 2 / (2 + alpha^2 tan^2) is the wrong G1 the pitfalls list; check against Heitz's form.
        let w = direction_from_cosine(0.2);
        let alpha: f64 = 0.8;
        let x = alpha * alpha * (1.0 - 0.04) / 0.04;
        let expected = 2.0 / (1.0 + (1.0 + x).sqrt());
        assert!((smith_g1(w, alpha) - expected).abs() < 1e-14);
    }

    #[test]
    fn visible_normal_weight_is_g2_over_g1() {
        let alpha = 0.4;
        let wi = direction_from_cosine(0.35);
        let wo = DVec3::new(-0.3, 0.2, 0.5).normalize();
        for g in [MaskingShadowing::SmithSeparable, MaskingShadowing::SmithHeightCorrelated] {
            let expected = g.g2(wi, wo, alpha) / smith_g1(wi, alpha);
            assert!((g.visible_normal_weight(wi, wo, alpha) - expected).abs() < 1e-14, "{g:?}");
        }
        let expected = MaskingShadowing::SchlickSmith.g2(wi, wo, alpha) / smith_g1(wi, alpha);
        assert!((MaskingShadowing::SchlickSmith.visible_normal_weight(wi, wo, alpha) - expected).abs() < 1e-12);
    }

    #[test]
    fn visible_normal_weight_keeps_its_limit_at_grazing_incidence() {
        let alpha = 0.5;
        let wo = DVec3::new(0.1, 0.3, 0.8).normalize();
        for g in MaskingShadowing::ALL {
            let at_zero = g.visible_normal_weight(direction_from_cosine(0.0), wo, alpha);
            let near_zero = g.visible_normal_weight(direction_from_cosine(1e-9), wo, alpha);
            assert!(at_zero.is_finite() && (at_zero - near_zero).abs() < 1e-6, "{g:?}: {at_zero} vs {near_zero}");
        }
    }

    #[test]
    fn distribution_is_a_dirac_when_smooth_and_exact_near_the_normal() {
        // Found by the stability matrix: NaN at alpha = 0, h = n; 1.6e-3 off at alpha = 1e-7.
        assert_eq!(ggx_distribution(DVec3::Z, 0.0), f64::INFINITY);
        assert_eq!(ggx_distribution(direction_from_cosine(0.5), 0.0), 0.0);
        let alpha: f64 = 1e-7;
        assert!((ggx_distribution(DVec3::Z, alpha) - 1.0 / (PI * alpha * alpha)).abs() < 1e-12 / (alpha * alpha));
        // At the horizon D is its limit from above, alpha^2 / pi, not 0.
        assert!((ggx_distribution(DVec3::X, 0.5) - 0.25 / PI).abs() < 1e-15);
    }

    #[test]
    fn schlick_smith_uses_k_half_alpha() {
        let w = direction_from_cosine(0.5);
        assert!((schlick_smith_g1(w, 0.6) - 0.5 / (0.5 * 0.7 + 0.3)).abs() < 1e-15);
        assert_eq!(schlick_smith_g1(w, 0.0), 1.0);
    }
}
