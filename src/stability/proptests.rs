//! Property-based tests over the whole parameter domain (proptest), for the properties the matrix
//! checks at its stiff points. Case counts are kept moderate so that `cargo test` stays fast; the
//! table properties, which integrate, run fewer cases on fewer samples.

use glam::DVec3;
use proptest::prelude::*;

use super::physics::reference_fresnel;
use super::properties::{self as p, Check};
use crate::formats::Precision;
use crate::physics::henyey_greenstein::{MAX_ROUGHNESS, MIN_ROUGHNESS};
use crate::physics::{
    MaskingShadowing, critical_cosine, direction_from_cosine, fresnel_reflectance, ggx_distribution, ggx_to_hg,
    hg_to_ggx, smith_g1, smith_lambda,
};
use crate::recipes::Kernel;
use crate::recipes::fgd::FgdSettings;
use crate::recipes::gd::GdSettings;
use crate::sampling::sample_visible_normal;
use crate::sampling::sequence::{PointSet, SamplePlan};

fn holds(check: Check) -> Result<(), TestCaseError> {
    prop_assert!(check.passed(), "{}: {}", check.property, check.detail);
    Ok(())
}

/// Values drawn from the whole range and, one time in four, an edge of it, where faults live.
fn unit_with_edges() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.0..=1.0f64, 1 => prop::sample::select(vec![0.0, 1e-12, 1e-7, 1.0 - 1e-7, 1.0 - 1e-12, 1.0])]
}

fn eta() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.0..=20.0f64, 1 => prop::sample::select(vec![0.0, 1e-3, 1.0 - 1e-6, 1.0, 1.0 + 1e-6, 10.0])]
}

fn kappa() -> impl Strategy<Value = f64> {
    prop_oneof![2 => Just(0.0), 3 => 0.0..=200.0f64, 1 => 0.0..=1e-5f64]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn fresnel_is_a_reflectance_and_matches_the_textbook_form(c in unit_with_edges(), eta in eta(), kappa in kappa()) {
        let f = fresnel_reflectance(c, eta, kappa);
        let (reference, transmitted) = reference_fresnel(c, eta, kappa);
        holds(p::finite(f))?;
        holds(p::unit_interval(f, 0.0))?;
        holds(p::close_relative("matches the textbook form", f, reference, 1e-9, 1e-20))?;
        holds(p::close_relative("1 - F matches the textbook transmittance", 1.0 - f, transmitted, 1e-8, 4.0 * f64::EPSILON))?;
    }

    #[test]
    fn past_the_critical_angle_everything_reflects(eta in 1e-6..1.0f64, t in 0.0..1.0f64) {
        let critical = critical_cosine(eta).unwrap();
        holds(p::exact("total internal reflection", fresnel_reflectance(t * critical, eta, 0.0), 1.0))?;
    }

    #[test]
    fn microfacet_terms_stay_in_range(alpha in unit_with_edges(), mu in unit_with_edges(), mu_o in unit_with_edges()) {
        let (wi, wo) = (direction_from_cosine(mu), direction_from_cosine(mu_o) * DVec3::new(-1.0, 1.0, 1.0));
        let d = ggx_distribution(wi, alpha);
        prop_assert!(d >= 0.0, "D = {d}");
        prop_assert!(d.is_finite() || (alpha == 0.0 && mu == 1.0), "D = {d}");
        prop_assert!(smith_lambda(wi, alpha) >= 0.0);
        holds(p::unit_interval(smith_g1(wi, alpha), 0.0))?;
        for masking in MaskingShadowing::ALL {
            let g2 = masking.g2(wi, wo, alpha);
            let weight = masking.visible_normal_weight(wi, wo, alpha);
            holds(p::unit_interval(g2, 0.0))?;
            holds(p::finite(weight))?;
            let slack = if masking == MaskingShadowing::SchlickSmith { 0.05 } else { 1e-15 };
            holds(p::unit_interval(weight, slack))?;
        }
    }

    #[test]
    fn visible_normals_are_unit_and_visible(alpha in unit_with_edges(), mu in unit_with_edges(), u0 in unit_with_edges(), u1 in unit_with_edges()) {
        let wi = direction_from_cosine(mu);
        let h = sample_visible_normal(wi, alpha, [u0, u1]);
        prop_assert!(h.is_finite() && (h.length() - 1.0).abs() < 1e-12 && h.z >= 0.0, "{h:?}");
        prop_assert!(wi.dot(h) >= -1e-12, "wi.h = {}", wi.dot(h));
    }

    #[test]
    fn henyey_greenstein_mappings_stay_in_range(g in -2.0..2.0f64, alpha in 0.0..10.0f64) {
        holds(p::within("alpha in [1e-4, 1]", hg_to_ggx(g), MIN_ROUGHNESS, MAX_ROUGHNESS))?;
        holds(p::unit_interval(ggx_to_hg(alpha), 0.0))?;
    }

    #[test]
    fn half_floats_keep_unit_values_in_range(v in 0.0..=1.0f32) {
        let stored = Precision::F16.round(v);
        holds(p::unit_interval(stored as f64, 0.0))?;
        let bound = v as f64 * 2f64.powi(-11) + 2f64.powi(-25);
        holds(p::close("within half a step", stored as f64, v as f64, bound))?;
    }
}

proptest! {
    // Each case integrates two nodes by two paths; a few dozen cover the domain without slowing CI.
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn fgd_is_an_albedo_below_gd_and_both_paths_agree(mu in unit_with_edges(), alpha in unit_with_edges(), eta in eta(), kappa in kappa()) {
        let points = PointSet::new(SamplePlan::new(1 << 10, 4).unwrap(), 5);
        let fgd = FgdSettings::default();
        let position = [mu, alpha, eta, kappa];
        let (per_cell, fast) = (fgd.estimate_node(&points, &position), fgd.estimate_node_fast(&points, &position));
        let gd = GdSettings::default().estimate_node(&points, &[mu, alpha]).mean[0];
        holds(p::finite(per_cell.mean[0]))?;
        holds(p::unit_interval(per_cell.mean[0], 1e-6))?;
        holds(p::unit_interval(fast.mean[0], super::tables::FAST_PATH_RANGE_SLACK))?;
        holds(p::at_most("FGD <= GD", per_cell.mean[0], gd, 1e-12))?;
        let tolerance = super::tables::PATH_STANDARD_ERRORS * per_cell.standard_error[0].hypot(fast.standard_error[0])
            + super::tables::PATH_ABSOLUTE_TOLERANCE;
        holds(p::close("paths agree", fast.mean[0], per_cell.mean[0], tolerance))?;
    }
}
