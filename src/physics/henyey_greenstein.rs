//! The mapping between GGX roughness and Henyey–Greenstein asymmetry that the transfer-matrix
//! model uses to carry lobes through a layer stack (Randrianandrasana et al. 2021, §4; the fit
//! `g(alpha) = -0.085 + 1.085 / (1 + (alpha / 0.5)^1.3)` as given in `notes/tables.md`).

/// Below this asymmetry a lobe counts as fully rough: the model reads `g < 0.2` as 0.2, which maps
/// to the largest roughness.
pub const MIN_ASYMMETRY: f64 = 0.2;
/// Roughness range the inverse mapping is clamped to.
pub const MIN_ROUGHNESS: f64 = 1e-4;
pub const MAX_ROUGHNESS: f64 = 1.0;

/// Henyey–Greenstein asymmetry `g` of a GGX lobe with roughness `alpha`, clamped to [0, 1].
pub fn ggx_to_hg(alpha: f64) -> f64 {
    let alpha = alpha.max(0.0);
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
    }
}
