//! The Henyey–Greenstein phase function, and the statistics of Henyey–Greenstein lobes that the
//! transfer-matrix model uses to carry lobes through a layer stack (Randrianandrasana et al. 2021,
//! §4, as their reference implementation evaluates them, `docs/furnace.md`): the fit
//! `g(alpha) = -0.085 + 1.085 / (1 + (alpha / 0.5)^1.3)` between GGX roughness and asymmetry and
//! its inverse, the asymmetry of a refracted lobe, and the back-hemisphere share of a phase
//! function.
//!
//! The phase function (Henyey & Greenstein 1941, "Diffuse radiation in the galaxy") is
//! written over the cosine `c` between the propagation directions before and after scattering, so
//! `g > 0` scatters forward; its mean cosine is `g`. `g = ±1` are Dirac limits (no change of
//! direction, exact reversal), which every function here returns exactly.

use glam::DVec3;

use crate::ir::real::Real;
use std::f64::consts::PI;

/// Below this asymmetry a lobe counts as fully rough: the model reads `g < 0.2` as 0.2, which maps
/// to the largest roughness.
pub const MIN_ASYMMETRY: f64 = 0.2;
/// Roughness range the inverse mapping is clamped to.
pub const MIN_ROUGHNESS: f64 = 1e-4;
pub const MAX_ROUGHNESS: f64 = 1.0;

/// Henyey–Greenstein asymmetry `g` of a GGX lobe with roughness `alpha`, clamped to [0, 1]; a
/// roughness above 1 (the model scales transmission roughness by a factor that can exceed 2) reads
/// as 1, as in the reference code.
pub fn ggx_to_hg<R: Real>(alpha: R) -> R {
    let alpha = alpha.or_if_nan(1.0).clamp(0.0, 1.0);
    (R::of(1.085) / ((alpha / 0.5).powf(R::of(1.3)) + 1.0) - 0.085).clamp(0.0, 1.0)
}

/// GGX roughness of a Henyey–Greenstein lobe with asymmetry `g`: the inverse of [`ggx_to_hg`],
/// `alpha = 0.5 (1.085 / (g + 0.085) - 1)^(1 / 1.3)`, with `g` first clamped to [0.2, 1] (so the
/// base of the power is never negative) and the result clamped to [1e-4, 1].
pub fn hg_to_ggx<R: Real>(g: R) -> R {
    let g = g.or_if_nan(MIN_ASYMMETRY).clamp(MIN_ASYMMETRY, 1.0);
    let base = (R::of(1.085) / (g + 0.085) - 1.0).max(R::of(0.0));
    (base.powf(R::of(1.0 / 1.3)) * 0.5).clamp(MIN_ROUGHNESS, MAX_ROUGHNESS)
}

/// Asymmetry of a lobe of asymmetry `g` after refraction into a medium of relative index `eta`
/// (index behind over index in front), `min(sqrt(max(1 - (1 - g^2) eta^(3/4), 0)), 1)` (the
/// transfer-matrix reference's `hg_refract`). Entering a denser medium (`eta < 1`) narrows a lobe; leaving one widens it,
/// to 0 when the lobe is wide enough to be totally reflected.
pub fn hg_refract<R: Real>(g: R, eta: R) -> R {
    (R::of(1.0) - (R::of(1.0) - g * g) * eta.powf(R::of(0.75))).max(R::of(0.0)).sqrt().min(R::of(1.0))
}

/// The share of a Henyey–Greenstein phase function of asymmetry `g` scattered into the backward
/// hemisphere: the fit `clamp(0.5039 - 0.8254 |g| + 0.3226 g^2, 0, 0.5)` for `g >= 0`, and one minus
/// it for `g < 0` (the transfer-matrix reference's `hg_lh_norm`).
pub fn hg_backward_share(g: f64) -> f64 {
    let magnitude = g.abs();
    let share = (0.5039 - 0.8254 * magnitude + 0.3226 * magnitude * magnitude).clamp(0.0, 0.5);
    if g < 0.0 { 1.0 - share } else { share }
}

/// The Henyey–Greenstein phase function per steradian,
/// `p(c) = (1 - g^2) / (4 pi (1 + g^2 - 2 g c)^(3/2))` (Henyey & Greenstein 1941), for the
/// cosine `c` between the propagation directions before and after scattering. Its integral over
/// the sphere is 1. At `g = ±1` it is a Dirac at `c = g`: `+inf` there, 0 elsewhere.
pub fn henyey_greenstein_phase(cos_theta: f64, g: f64) -> f64 {
    let one_minus_g2 = (1.0 - g) * (1.0 + g);
    if one_minus_g2 == 0.0 {
        return if cos_theta == g { f64::INFINITY } else { 0.0 };
    }
    let denominator = 1.0 + g * g - 2.0 * g * cos_theta.clamp(-1.0, 1.0);
    one_minus_g2 / (4.0 * PI * denominator * denominator.sqrt())
}

/// The cosine of a scattering angle drawn from the Henyey–Greenstein phase function of asymmetry
/// `g` for `u` in [0, 1): the inverse of its cumulative distribution in `c`,
/// `c = (1 + g^2 - ((1 - g^2) / (1 + g v))^2) / (2 g)` with `v = 2 u - 1` (the phase function's
/// integral in `c` solved for `c`). Monotone in `u`: `u = 0` gives `c = -1`, `u -> 1` gives
/// `c -> 1`.
///
/// Two forms, each exact where the other is not: for small `|g|` the difference
/// `1 + g^2 - (...)^2` cancels to `O(g)` and is divided by `2 g`, so there the numerator is
/// multiplied out and `2 g` cancelled by hand,
/// `c = (v + g (v^2 + 3) / 2 + g^2 v + g^3 (v^2 - 1) / 2) / (1 + g v)^2`, which itself cancels
/// where `1 + g v` vanishes (`|g| -> 1`, `v -> -sign g`). `g = ±1` return `±1`, the Dirac limits.
pub fn sample_henyey_greenstein_cosine(g: f64, u: f64) -> f64 {
    if g.abs() >= 1.0 {
        return g.signum();
    }
    let v = 2.0 * u - 1.0;
    let t = 1.0 + g * v;
    let c = if g.abs() < 0.1 {
        (v + 0.5 * g * (v * v + 3.0) + g * g * v + 0.5 * g * g * g * (v * v - 1.0)) / (t * t)
    } else {
        let s = (1.0 - g) * (1.0 + g) / t;
        (1.0 + g * g - s * s) / (2.0 * g)
    };
    c.clamp(-1.0, 1.0)
}

/// A propagation direction after scattering `w` (a unit vector) with a Henyey–Greenstein phase
/// function of asymmetry `g`: the polar cosine from [`sample_henyey_greenstein_cosine`] with
/// `u[0]`, the azimuth `2 pi u[1]` about `w`. The result is a unit vector; at `g = ±1` it is `±w`
/// exactly.
pub fn sample_henyey_greenstein(w: DVec3, g: f64, u: [f64; 2]) -> DVec3 {
    let cos_theta = sample_henyey_greenstein_cosine(g, u[0]);
    if cos_theta.abs() == 1.0 {
        return cos_theta * w;
    }
    let sin_theta = ((1.0 - cos_theta) * (1.0 + cos_theta)).sqrt();
    let (sin_phi, cos_phi) = (2.0 * PI * u[1]).sin_cos();
    // Any frame around w: the azimuth is uniform, so which one does not matter.
    let (t1, t2) = w.any_orthonormal_pair();
    (cos_theta * w + sin_theta * (cos_phi * t1 + sin_phi * t2)).normalize()
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
    /// Midpoint rule over `n` equal steps of [0, 1).
    fn midpoints(n: usize) -> impl Iterator<Item = f64> {
        (0..n).map(move |i| (i as f64 + 0.5) / n as f64)
    }

    #[test]
    fn phase_function_integrates_to_one_with_mean_cosine_g() {
        for g in [-0.9, -0.3, 0.0, 0.05, 0.5, 0.9] {
            // Over the sphere: 2 pi times the integral over c in [-1, 1].
            let n = 200_000;
            let (mut total, mut mean) = (0.0, 0.0);
            for t in midpoints(n) {
                let c = 2.0 * t - 1.0;
                let p = henyey_greenstein_phase(c, g) * 2.0 * PI * 2.0 / n as f64;
                total += p;
                mean += c * p;
            }
            assert!((total - 1.0).abs() < 1e-6, "g {g}: {total}");
            assert!((mean - g).abs() < 1e-6, "g {g}: mean cosine {mean}");
        }
        assert_eq!(henyey_greenstein_phase(1.0, 1.0), f64::INFINITY);
        assert_eq!(henyey_greenstein_phase(0.3, 1.0), 0.0);
        assert_eq!(henyey_greenstein_phase(-1.0, -1.0), f64::INFINITY);
        assert!((henyey_greenstein_phase(0.3, 0.0) - 0.25 / PI).abs() < 1e-16);
    }

    #[test]
    fn sampled_cosines_follow_the_phase_function() {
        // The inverse CDF of a fine u grid, binned in c, against the phase function integrated over
        // each bin; both forms of the inverse (|g| below and above 0.1) are covered.
        for g in [-0.95, -0.5, -0.05, 0.0, 1e-9, 0.02, 0.099, 0.1, 0.6, 0.99] {
            let bins = 20;
            let n = 400_000;
            let mut sampled = vec![0.0; bins];
            let mut mean = 0.0;
            let mut previous = -1.0;
            for u in midpoints(n) {
                let c = sample_henyey_greenstein_cosine(g, u);
                assert!(c >= previous, "g {g}: not monotone at u {u}");
                previous = c;
                mean += c / n as f64;
                sampled[(((c + 1.0) / 2.0 * bins as f64) as usize).min(bins - 1)] += 1.0 / n as f64;
            }
            assert!((mean - g).abs() < 1e-5, "g {g}: mean {mean}");
            for (k, &s) in sampled.iter().enumerate() {
                let m = 20_000;
                let expected: f64 = midpoints(m)
                    .map(|t| {
                        let c = -1.0 + 2.0 * (k as f64 + t) / bins as f64;
                        henyey_greenstein_phase(c, g) * 2.0 * PI * (2.0 / bins as f64) / m as f64
                    })
                    .sum();
                assert!((s - expected).abs() < 2e-4 + 1e-3 * expected, "g {g} bin {k}: {s} vs {expected}");
            }
        }
    }

    #[test]
    fn sampled_cosines_are_exact_at_the_ends_and_in_the_dirac_limits() {
        for g in [-0.999, -0.5, -1e-7, 0.0, 1e-7, 0.5, 0.999] {
            assert!(sample_henyey_greenstein_cosine(g, 0.0) + 1.0 < 1e-15, "g {g}");
            assert!(sample_henyey_greenstein_cosine(g, 1.0 - 1e-16) > 1.0 - 1e-12, "g {g}");
        }
        for u in [0.0, 0.3, 0.999_999] {
            assert_eq!(sample_henyey_greenstein_cosine(1.0, u), 1.0);
            assert_eq!(sample_henyey_greenstein_cosine(-1.0, u), -1.0);
        }
        // Near-Dirac lobes stay inside [-1, 1] and put almost everything at the peak.
        let forward = sample_henyey_greenstein_cosine(0.999, 0.5);
        assert!(forward > 0.999 && forward <= 1.0, "{forward}");
        let backward = sample_henyey_greenstein_cosine(-0.999, 0.5);
        assert!((-1.0..-0.999).contains(&backward), "{backward}");
    }

    #[test]
    fn scattered_directions_have_the_sampled_cosine_to_the_incident_one() {
        let w = DVec3::new(0.3, -0.4, -0.5).normalize();
        for g in [-1.0, -0.7, 0.0, 0.4, 0.999, 1.0] {
            for u in [[0.1, 0.2], [0.5, 0.9], [0.93, 0.0]] {
                let scattered = sample_henyey_greenstein(w, g, u);
                assert!((scattered.length() - 1.0).abs() < 1e-14, "g {g}");
                let expected = sample_henyey_greenstein_cosine(g, u[0]);
                assert!((scattered.dot(w) - expected).abs() < 1e-12, "g {g} u {u:?}");
            }
        }
        assert_eq!(sample_henyey_greenstein(w, 1.0, [0.3, 0.3]), w);
        assert_eq!(sample_henyey_greenstein(w, -1.0, [0.3, 0.3]), -w);
        // Horizontal directions are no special case.
        let horizontal = sample_henyey_greenstein(DVec3::X, 0.3, [0.6, 0.2]);
        assert!(horizontal.is_finite() && (horizontal.length() - 1.0).abs() < 1e-14);
    }
}
