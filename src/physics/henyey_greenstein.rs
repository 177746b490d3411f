//! The mapping between GGX roughness and Henyey–Greenstein asymmetry that the transfer-matrix
//! model uses to carry lobes through a layer stack, and the two statistics of a lobe it needs
//! besides (Randrianandrasana et al. 2021, §4, as their reference code `tm.h` evaluates it): the
//! fit `g(alpha) = -0.085 + 1.085 / (1 + (alpha / 0.5)^1.3)` and its inverse, the asymmetry of a
//! refracted lobe, and the back-hemisphere share of a phase function.

/// Below this asymmetry a lobe counts as fully rough: the model reads `g < 0.2` as 0.2, which maps
/// to the largest roughness.
pub const MIN_ASYMMETRY: f64 = 0.2;
/// Roughness range the inverse mapping is clamped to.
pub const MIN_ROUGHNESS: f64 = 1e-4;
pub const MAX_ROUGHNESS: f64 = 1.0;

/// Henyey–Greenstein asymmetry `g` of a GGX lobe with roughness `alpha`, clamped to [0, 1]; a
/// roughness above 1 (the model scales transmission roughness by a factor that can exceed 2) reads
/// as 1, as in the reference code.
pub fn ggx_to_hg(alpha: f64) -> f64 {
    let alpha = if alpha.is_nan() { 1.0 } else { alpha.clamp(0.0, 1.0) };
    (-0.085 + 1.085 / (1.0 + (alpha / 0.5).powf(1.3))).clamp(0.0, 1.0)
}

/// GGX roughness of a Henyey–Greenstein lobe with asymmetry `g`: the inverse of [`ggx_to_hg`],
/// `alpha = 0.5 (1.085 / (g + 0.085) - 1)^(1 / 1.3)`, with `g` first clamped to [0.2, 1] (so the
/// base of the power is never negative) and the result clamped to [1e-4, 1].
pub fn hg_to_ggx(g: f64) -> f64 {
    let g = if g.is_nan() { MIN_ASYMMETRY } else { g.clamp(MIN_ASYMMETRY, 1.0) };
    let base = (1.085 / (g + 0.085) - 1.0).max(0.0);
    (0.5 * base.powf(1.0 / 1.3)).clamp(MIN_ROUGHNESS, MAX_ROUGHNESS)
}

/// Asymmetry of a lobe of asymmetry `g` after refraction into a medium of relative index `eta`
/// (index behind over index in front), `min(sqrt(max(1 - (1 - g^2) eta^(3/4), 0)), 1)` (the
/// transfer-matrix reference, `tm.h`, `hg_refract`). Entering a denser medium (`eta < 1`) narrows a lobe; leaving one widens it,
/// to 0 when the lobe is wide enough to be totally reflected.
pub fn hg_refract(g: f64, eta: f64) -> f64 {
    (1.0 - (1.0 - g * g) * eta.powf(0.75)).max(0.0).sqrt().min(1.0)
}

/// The share of a Henyey–Greenstein phase function of asymmetry `g` scattered into the backward
/// hemisphere: the fit `clamp(0.5039 - 0.8254 |g| + 0.3226 g^2, 0, 0.5)` for `g >= 0`, and one minus
/// it for `g < 0` (the transfer-matrix reference, `tm.h`, `hg_lh_norm`).
pub fn hg_backward_share(g: f64) -> f64 {
    let magnitude = g.abs();
    let share = (0.5039 - 0.8254 * magnitude + 0.3226 * magnitude * magnitude).clamp(0.0, 0.5);
    if g < 0.0 { 1.0 - share } else { share }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mappings_are_inverse_inside_the_clamped_range() {
        for alpha in [0.01, 0.1, 0.3, 0.6, 0.9] {
            let g = ggx_to_hg(alpha);
            if g >= MIN_ASYMMETRY {
                assert!((hg_to_ggx(g) - alpha).abs() < 1e-10, "alpha {alpha} -> g {g}");
            }
        }
    }

    #[test]
    fn known_values_and_clamps() {
        assert_eq!(ggx_to_hg(0.0), 1.0);
        // alpha = 0.5: -0.085 + 1.085 / 2.
        assert!((ggx_to_hg(0.5) - 0.4575).abs() < 1e-12);
        assert_eq!(hg_to_ggx(1.0), MIN_ROUGHNESS);
        assert_eq!(hg_to_ggx(1.5), MIN_ROUGHNESS);
        assert_eq!(hg_to_ggx(0.1), MAX_ROUGHNESS);
        assert_eq!(hg_to_ggx(-1.0), MAX_ROUGHNESS);
        assert_eq!(hg_to_ggx(f64::NAN), MAX_ROUGHNESS);
        assert_eq!(ggx_to_hg(2.5), ggx_to_hg(1.0));
        assert_eq!(ggx_to_hg(f64::NAN), ggx_to_hg(1.0));
    }

    #[test]
    fn refraction_narrows_a_lobe_entering_a_denser_medium() {
        assert_eq!(hg_refract(1.0, 0.6), 1.0);
        assert!(hg_refract(0.5, 1.0 / 1.5) > 0.5);
        assert!(hg_refract(0.5, 1.5) < 0.5);
        assert_eq!(hg_refract(0.5, 1.0), 0.5);
        // A wide lobe leaving a dense medium: all of it would be past the critical angle.
        assert_eq!(hg_refract(0.0, 2.0), 0.0);
    }

    #[test]
    fn backward_share_is_a_half_for_isotropic_scattering_and_mirrors_for_negative_g() {
        assert!((hg_backward_share(0.0) - 0.5).abs() < 1e-15);
        // The fit leaves 0.0011 behind at g = 1.
        assert!((hg_backward_share(1.0) - 0.0011).abs() < 1e-12);
        assert!((hg_backward_share(-0.3) - (1.0 - hg_backward_share(0.3))).abs() < 1e-15);
        assert!(hg_backward_share(0.9) < hg_backward_share(0.5));
    }
}
