use super::*;
use crate::integrate::{Method, estimate_cosine_functions};
use crate::model::{Interface, Medium};
use crate::physics::{critical_cosine, fresnel_reflectance};
use crate::sampling::sequence::{PointSet, SamplePlan};

fn dielectric(eta: f64, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta: [eta; 3], kappa: [0.0; 3], alpha })
}

fn conductor(eta: Rgb, kappa: Rgb, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta, kappa, alpha })
}

fn medium(sigma_s: Rgb, sigma_k: Rgb, depth: f64, g: f64) -> Layer {
    Layer::Medium(Medium { sigma_s, sigma_k, depth, g })
}

fn stack(layers: Vec<Layer>) -> Stack {
    Stack::new(layers).unwrap()
}

/// The two stacks `tmlut bench walk` times, so that what the tests check is what it measures.
fn varnished_conductor() -> Stack {
    crate::report::bench::walk::varnished_conductor().unwrap()
}

fn scattering_coat() -> Stack {
    crate::report::bench::walk::scattering_coat().unwrap()
}

fn settings(target_standard_error: f64) -> WalkSettings {
    WalkSettings { target_standard_error, ..WalkSettings::default() }
}

/// Roulette off and no truncation: every path ends by leaving the stack, being lost or absorbed.
fn exact_accounting(target_standard_error: f64) -> WalkSettings {
    WalkSettings { roulette_after_events: u32::MAX, max_events: u32::MAX, ..settings(target_standard_error) }
}

#[track_caller]
fn assert_within(what: &str, value: f64, reference: f64, allowed: f64) {
    assert!(
        (value - reference).abs() <= allowed,
        "{what}: {value} vs reference {reference} (difference {:.3e}, allowed {allowed:.3e})",
        value - reference
    );
}

/// Estimates held to references, judged together. One comparison may be off by 3 standard errors
/// (plus a tolerance of its own, for rounding or the reference's error); a family of `k` is held to
/// the Bonferroni-corrected equivalent, so that the whole test has the false-alarm rate of a single
/// 3 s.e. comparison (0.27 %) rather than `k` times it (with 3 s.e. each, 50 comparisons would fail
/// one time in eight with no bias at all). That is 3.03 s.e. for one comparison, 3.66 for 10, 4.05
/// for 50: a bias of a few standard errors still fails.
#[derive(Default)]
struct Comparisons {
    rows: Vec<(String, f64, f64, f64, f64)>,
}

impl Comparisons {
    fn check(&mut self, what: impl Into<String>, value: f64, reference: f64, standard_error: f64, tolerance: f64) {
        self.rows.push((what.into(), value, reference, standard_error, tolerance));
    }

    /// `z` with two-sided Gaussian tail `0.0027 / k`, from the Mills-ratio bound
    /// `P(|Z| > z) <= 2 phi(z) / z` (so slightly above the exact quantile: 3.03 for `k = 1`).
    fn threshold(&self) -> f64 {
        let tail = 0.0027 / self.rows.len().max(1) as f64;
        let bound = |z: f64| 2.0 * (-0.5 * z * z).exp() / ((2.0 * std::f64::consts::PI).sqrt() * z);
        let (mut low, mut high) = (1.0, 20.0);
        for _ in 0..100 {
            let middle = 0.5 * (low + high);
            if bound(middle) > tail { low = middle } else { high = middle }
        }
        high
    }

    #[track_caller]
    fn assert_all(self) {
        let z = self.threshold();
        let failures: Vec<String> = self
            .rows
            .iter()
            // Written so that a NaN fails.
            .filter(|(_, value, reference, se, tolerance)| {
                let within = (value - reference).abs() <= z * se + tolerance;
                !within
            })
            .map(|(what, value, reference, se, tolerance)| {
                format!(
                    "{what}: {value} vs {reference}, off by {:.2} s.e. (s.e. {se:.2e}, tolerance {tolerance:.1e})",
                    (value - reference).abs() / se
                )
            })
            .collect();
        assert!(
            failures.is_empty(),
            "{} of {} comparisons beyond {z:.2} s.e.:\n{}",
            failures.len(),
            self.rows.len(),
            failures.join("\n")
        );
    }
}

#[test]
fn comparison_thresholds_grow_slowly_with_the_family() {
    let family = |k: usize| Comparisons { rows: vec![(String::new(), 0.0, 0.0, 1.0, 0.0); k] }.threshold();
    assert!((family(1) - 3.03).abs() < 0.01 && (family(10) - 3.66).abs() < 0.01 && (family(50) - 4.05).abs() < 0.01);
    let mut biased = Comparisons::default();
    biased.check("biased", 4.2, 0.0, 1.0, 0.0);
    biased.check("fine", 0.0, 0.0, 1.0, 0.0);
    assert!(std::panic::catch_unwind(move || biased.assert_all()).is_err());
}

#[test]
fn smooth_interfaces_reflect_their_fresnel_reflectance() {
    let cases = [
        ("dielectric 1.5", [1.5; 3], [0.0; 3]),
        ("dielectric 0.7", [0.7; 3], [0.0; 3]),
        ("conductor", [0.2, 0.9, 1.5], [3.0, 2.5, 1.0]),
    ];
    let mut comparisons = Comparisons::default();
    for (name, eta, kappa) in cases {
        let stack = stack(vec![conductor(eta, kappa, 0.0)]);
        // Grey dielectrics walk the three channels on one path: channel 0 says it all.
        let channels = if kappa[0] > 0.0 { 3 } else { 1 };
        for mu in [1.0, 0.8, 0.5, 0.2, 0.05, 1e-3, 0.0] {
            // Near grazing incidence transmission is rare (0.6 % at mu = 1e-3): enough paths that
            // its count, and so the estimated standard error, is reliable.
            let estimate = directional_albedo(&stack, mu, &WalkSettings { min_paths: 1 << 18, ..settings(1e-3) });
            let mu_walked = f64::max(mu, GRAZING_COSINE);
            assert!(!estimate.per_channel_walks);
            for c in 0..channels {
                let f = fresnel_reflectance(mu_walked, eta[c], kappa[c]);
                let what = format!("{name} mu {mu} channel {c}");
                let se = estimate.reflected_standard_error[c];
                // A smooth interface gives every path the same weight where F is 0 or 1, and F on a
                // conductor: the standard error is 0 and only rounding separates the mean from F.
                comparisons.check(format!("{what} reflected"), estimate.reflected[c], f, se, 1e-12);
                if kappa[c] == 0.0 {
                    comparisons.check(format!("{what} transmitted"), estimate.transmitted[c], 1.0 - f, se, 1e-12);
                }
                assert_eq!(estimate.lost[c], 0.0, "{what}");
            }
        }
    }
    comparisons.assert_all();
    // Past the critical angle of eta 0.7 everything is reflected, exactly.
    let below_critical = critical_cosine(0.7).unwrap() * 0.9;
    let tir = directional_albedo(&stack(vec![dielectric(0.7, 0.0)]), below_critical, &settings(1e-3));
    assert_eq!((tir.reflected, tir.reflected_standard_error, tir.transmitted), ([1.0; 3], [0.0; 3], [0.0; 3]));
}

/// The FGD integral by the crate's independent per-cell integrator: `E[F(wi.h) G2 / G1(wi)]` over
/// the visible normals, with the walk's masking.
fn fgd_reference(mu: f64, alpha: f64, masking: Masking, eta: Rgb, kappa: Rgb) -> ([f64; 3], [f64; 3]) {
    let points = PointSet::new(SamplePlan::new(1 << 20, 16).unwrap(), 11);
    let estimate =
        estimate_cosine_functions::<3>(mu, alpha, masking.masking_shadowing(), Method::PerCell, &points, |c| {
            std::array::from_fn(|k| fresnel_reflectance(c, eta[k], kappa[k]))
        });
    (std::array::from_fn(|k| estimate.mean[k]), std::array::from_fn(|k| estimate.standard_error[k]))
}

#[test]
fn rough_interfaces_reflect_the_fgd_integral() {
    let cases = [
        // (mu, alpha, eta, kappa, masking)
        (0.5, 0.3, [0.2, 0.5, 1.2], [3.0, 2.0, 0.5], Masking::Separable),
        (0.1, 0.8, [0.2, 0.5, 1.2], [3.0, 2.0, 0.5], Masking::Separable),
        (0.9, 0.2, [1.5; 3], [0.0; 3], Masking::Separable),
        (0.2, 0.6, [1.5; 3], [0.0; 3], Masking::Separable),
        (0.6, 0.4, [0.7; 3], [0.0; 3], Masking::Separable),
        (0.3, 0.7, [1.5; 3], [0.0; 3], Masking::HeightCorrelated),
        (0.4, 0.9, [0.2, 0.5, 1.2], [3.0, 2.0, 0.5], Masking::HeightCorrelated),
    ];
    let mut comparisons = Comparisons::default();
    for (mu, alpha, eta, kappa, masking) in cases {
        let interface = conductor(eta, kappa, alpha);
        let (reference, reference_se) = fgd_reference(mu, alpha, masking, eta, kappa);
        let is_dielectric = kappa[0] == 0.0;
        // A dielectric on top takes both branches of its first event; behind a clear slab of index
        // 1 (no interface: the slab is in air) the same interface chooses one with probability F.
        let clear = medium([0.0; 3], [0.0; 3], 1.0, 0.0);
        let stacks = if is_dielectric {
            vec![
                ("on top", stack(vec![interface])),
                ("behind a clear slab", stack(vec![dielectric(1.0, 0.5), clear, interface])),
            ]
        } else {
            vec![("on top", stack(vec![interface]))]
        };
        for (place, stack) in stacks {
            let estimate = directional_albedo(&stack, mu, &WalkSettings { masking, ..settings(1e-3) });
            // Grey dielectrics walk the three channels on one path: channel 0 says it all.
            for c in 0..(if is_dielectric { 1 } else { 3 }) {
                let se = estimate.reflected_standard_error[c].hypot(reference_se[c]);
                let what = format!("mu {mu} alpha {alpha} eta {} kappa {} {masking:?} {place}", eta[c], kappa[c]);
                comparisons.check(&what, estimate.reflected[c], reference[c], se, 0.0);
                assert!(estimate.lost[c] > 0.0, "{what}: a rough interface loses energy");
            }
        }
    }
    comparisons.assert_all();
}

/// Reflectance and transmittance of a smooth slab of index `eta` and absorption `sigma_k` (no
/// scattering) between air above and `below`, by the geometric series of its internal reflections:
/// `R = F + (1 - F)^2 r a^2 / (1 - F r a^2)`, `T = (1 - F) (1 - F) a / (1 - F r a^2)` with `a` the
/// transmittance of one crossing and `r` the reflectance of the bottom (Stokes: light inside meets
/// the top with the same `F`).
fn smooth_slab(mu: f64, eta: f64, sigma_k: f64, depth: f64, bottom_reflectance: impl Fn(f64) -> f64) -> (f64, f64) {
    let f = fresnel_reflectance(mu, eta, 0.0);
    let cos_t = (1.0 - (1.0 - mu * mu) / (eta * eta)).sqrt();
    let a = (-sigma_k * depth / cos_t).exp();
    let r = bottom_reflectance(cos_t);
    let denominator = 1.0 - f * r * a * a;
    (f + (1.0 - f).powi(2) * r * a * a / denominator, (1.0 - f) * (1.0 - r) * a / denominator)
}

#[test]
fn smooth_slabs_match_their_geometric_series() {
    let sigma_k = [0.8, 0.1, 0.0];
    let mut comparisons = Comparisons::default();
    for mu in [1.0, 0.6, 0.15] {
        // A free-standing absorbing slab: out into air below.
        let slab = stack(vec![dielectric(1.5, 0.0), medium([0.0; 3], sigma_k, 0.7, 0.0), dielectric(1.0, 0.0)]);
        let estimate = directional_albedo(&slab, mu, &settings(1e-3));
        // A coated conductor: its Fresnel relative to the coat.
        let (eta_c, kappa_c) = ([0.2, 0.6, 1.1], [3.0, 2.6, 2.0]);
        let coated =
            stack(vec![dielectric(1.5, 0.0), medium([0.0; 3], sigma_k, 0.7, 0.0), conductor(eta_c, kappa_c, 0.0)]);
        let coated_estimate = directional_albedo(&coated, mu, &settings(1e-3));
        for c in 0..3 {
            let (r, t) = smooth_slab(mu, 1.5, sigma_k[c], 0.7, |cos| fresnel_reflectance(cos, 1.0 / 1.5, 0.0));
            let what = format!("slab mu {mu} channel {c}");
            comparisons.check(format!("{what} R"), estimate.reflected[c], r, estimate.reflected_standard_error[c], 0.0);
            comparisons.check(
                format!("{what} T"),
                estimate.transmitted[c],
                t,
                estimate.transmitted_standard_error[c],
                0.0,
            );
            let (r, _) =
                smooth_slab(mu, 1.5, sigma_k[c], 0.7, |cos| fresnel_reflectance(cos, eta_c[c] / 1.5, kappa_c[c] / 1.5));
            let what = format!("coated conductor mu {mu} channel {c}");
            let se = coated_estimate.reflected_standard_error[c];
            comparisons.check(format!("{what} R"), coated_estimate.reflected[c], r, se, 0.0);
            assert_eq!(coated_estimate.transmitted[c], 0.0, "{what}");
        }
    }
    comparisons.assert_all();
}

#[test]
fn energy_is_conserved_when_nothing_absorbs() {
    let layers = |alpha: [f64; 3]| {
        vec![
            dielectric(1.5, alpha[0]),
            medium([2.0; 3], [0.0; 3], 1.0, 0.6),
            dielectric(1.3, alpha[1]),
            medium([0.5; 3], [0.0; 3], 2.0, -0.3),
            dielectric(1.0, alpha[2]),
        ]
    };
    for mu in [1.0, 0.4, 0.05] {
        // Smooth interfaces and a non-absorbing medium: no path loses weight.
        let smooth = directional_albedo(&stack(layers([0.0; 3])), mu, &exact_accounting(2e-3));
        for c in 0..3 {
            assert_within(&format!("smooth, mu {mu}"), smooth.reflected[c] + smooth.transmitted[c], 1.0, 1e-12);
            assert_eq!(smooth.lost[c], 0.0);
        }
        assert!(smooth.transmitted[0] > 0.1 && smooth.reflected[0] > 0.05, "{smooth:?}");
        // Rough interfaces drop weight, and exactly what they drop is reported as lost.
        for masking in [Masking::Separable, Masking::HeightCorrelated] {
            let rough = directional_albedo(
                &stack(layers([0.3, 0.6, 0.2])),
                mu,
                &WalkSettings { masking, ..exact_accounting(2e-3) },
            );
            for c in 0..3 {
                let total = rough.reflected[c] + rough.transmitted[c] + rough.lost[c];
                assert_within(&format!("rough {masking:?}, mu {mu}"), total, 1.0, 1e-12);
                assert!(rough.lost[c] > 0.01, "{masking:?} mu {mu}: {rough:?}");
            }
            assert_eq!(rough.truncated_paths, 0);
        }
    }
    // With absorption, what is neither reflected, transmitted nor lost was absorbed.
    let absorbing =
        stack(vec![dielectric(1.5, 0.3), medium([1.0; 3], [0.0, 0.2, 2.0], 1.0, 0.0), dielectric(1.0, 0.3)]);
    let estimate = directional_albedo(&absorbing, 0.5, &exact_accounting(2e-3));
    let absorbed =
        estimate.reflected.iter().zip(estimate.transmitted).zip(estimate.lost).map(|((r, t), l)| 1.0 - r - t - l);
    let absorbed: Vec<f64> = absorbed.collect();
    assert!(absorbed[0].abs() < 1e-12 && absorbed[1] > 0.05 && absorbed[2] > absorbed[1], "{absorbed:?}");
}

#[test]
fn index_matched_interfaces_are_no_interface() {
    // An interface with the index of the medium above does nothing, rough or not.
    let bare = stack(vec![dielectric(1.0, 0.7)]);
    let estimate = directional_albedo(&bare, 0.3, &settings(1e-3));
    assert_eq!((estimate.reflected, estimate.transmitted, estimate.lost), ([0.0; 3], [1.0; 3], [0.0; 3]));
    let with = stack(vec![dielectric(1.5, 0.3), dielectric(1.5, 0.9), conductor([0.2; 3], [3.0; 3], 0.2)]);
    let without = stack(vec![dielectric(1.5, 0.3), conductor([0.2; 3], [3.0; 3], 0.2)]);
    let s = settings(1e-3);
    assert_eq!(directional_albedo(&with, 0.7, &s), directional_albedo(&without, 0.7, &s));
}

#[test]
fn per_channel_walks_agree_with_a_shared_walk_where_both_apply() {
    // The scattering coat may share one walk (its scattering is grey); walking each channel on its
    // own, on the same streams and without roulette (whose choice reads all channels), must give
    // the same paths and so the same bits.
    let coat = scattering_coat();
    let s = exact_accounting(1e-3);
    let WalkPlan::Shared(shared) = WalkPlan::new(&coat) else { panic!("the coat should share one walk") };
    let per_channel =
        WalkPlan::PerChannel(std::array::from_fn(|c| WalkStack::new(coat.reachable_layers(), |v| v[c], |v| [v[c]])));
    let a = estimate_view(&WalkPlan::Shared(shared), 0.45, &s);
    let b = estimate_view(&per_channel, 0.45, &s);
    assert_eq!(
        (a.reflected, a.reflected_standard_error, a.lost, a.paths),
        (b.reflected, b.reflected_standard_error, b.lost, b.paths)
    );
    assert!(!a.per_channel_walks && b.per_channel_walks);
    // A dispersive coat, or a medium that scatters each channel differently, needs one walk per channel.
    let dispersive = stack(vec![conductor([1.4, 1.5, 1.6], [0.0; 3], 0.1)]);
    assert!(directional_albedo(&dispersive, 0.5, &settings(2e-3)).per_channel_walks);
    let tinted = stack(vec![dielectric(1.5, 0.1), medium([0.5, 1.0, 2.0], [0.1; 3], 1.0, 0.3)]);
    assert!(directional_albedo(&tinted, 0.5, &settings(2e-3)).per_channel_walks);
    // g = 1 does not scatter at all, so its sigma_s decides nothing.
    let forward = stack(vec![dielectric(1.5, 0.1), medium([0.5, 1.0, 2.0], [0.1; 3], 1.0, 1.0)]);
    assert!(!directional_albedo(&forward, 0.5, &settings(2e-3)).per_channel_walks);
}

/// Every number of an estimate, as bits.
fn bits(estimate: &WalkEstimate) -> Vec<u64> {
    let e = estimate;
    [e.reflected, e.reflected_standard_error, e.transmitted, e.transmitted_standard_error, e.lost]
        .iter()
        .flatten()
        .map(|v| v.to_bits())
        .chain([e.mu.to_bits(), e.paths, e.truncated_paths, e.per_channel_walks as u64])
        .collect()
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let tinted =
        stack(vec![dielectric(1.5, 0.3), medium([0.5, 1.0, 2.0], [0.1, 0.3, 0.0], 1.0, 0.6), dielectric(1.2, 0.2)]);
    let mus = [0.0, 0.3, 1.0];
    let s = WalkSettings { roulette_after_events: 4, ..settings(2e-3) };
    for stack in [scattering_coat(), tinted] {
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| directional_albedo_curve(&stack, &mus, &s, &()))
        };
        let (one, three) = (run(1), run(3));
        assert!(one[0].paths > WalkSettings::default().min_paths, "several rounds should run");
        for ((a, b), &mu) in one.iter().zip(&three).zip(&mus) {
            assert_eq!(bits(a), bits(b), "mu {mu}");
            assert_eq!(bits(a), bits(&directional_albedo(&stack, mu, &s)), "mu {mu}: the curve and one view differ");
        }
        // Another seed gives other paths.
        let reseeded = directional_albedo(&stack, 0.3, &WalkSettings { seed: 2, ..s });
        assert_ne!(bits(&reseeded), bits(&one[1]));
    }
}

#[test]
fn the_adaptive_stop_reaches_the_default_target() {
    let defaults = WalkSettings::default();
    for mu in [1.0, 0.5, 0.05] {
        let estimate = directional_albedo(&varnished_conductor(), mu, &defaults);
        for c in 0..3 {
            assert!(estimate.reflected_standard_error[c] <= defaults.target_standard_error, "mu {mu}: {estimate:?}");
        }
        assert!(estimate.paths >= defaults.min_paths && estimate.paths < defaults.max_paths, "mu {mu}: {estimate:?}");
        assert_eq!(estimate.truncated_paths, 0);
    }
    // No spread: the first round is enough. An unreachable target: stop at the maximum.
    let smooth_conductor = stack(vec![conductor([0.2; 3], [3.0; 3], 0.0)]);
    assert_eq!(directional_albedo(&smooth_conductor, 0.5, &defaults).paths, defaults.min_paths);
    let capped = WalkSettings { target_standard_error: 1e-9, max_paths: 5 * BATCH_PATHS, ..defaults };
    let estimate = directional_albedo(&varnished_conductor(), 0.5, &capped);
    assert_eq!(estimate.paths, 5 * BATCH_PATHS, "max_paths caps even a larger min_paths");
    // Rounds of 2, then 2 (doubling), then 1 batch (up to the cap).
    let capped = WalkSettings { min_paths: 2 * BATCH_PATHS, ..capped };
    let estimate = directional_albedo(&varnished_conductor(), 0.5, &capped);
    assert_eq!(estimate.paths, 5 * BATCH_PATHS);
    assert!(estimate.reflected_standard_error[0] > 1e-9);
}

#[derive(serde::Deserialize)]
struct AddingDoublingCase {
    albedo: f64,
    optical_thickness: f64,
    g: f64,
    mu: f64,
    reflectance: f64,
    transmittance: f64,
    reflectance_tolerance: f64,
    transmittance_tolerance: f64,
}

#[test]
fn index_matched_slabs_match_adding_doubling() {
    // Made by notebooks/adding_doubling.py with Prahl's iadpython; scripts/test checks that it
    // still matches what iadpython computes.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/adding_doubling.json");
    let file: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let cases: Vec<AddingDoublingCase> = serde_json::from_value(file["cases"].clone()).unwrap();
    assert_eq!(cases.len(), 24);
    let mut comparisons = Comparisons::default();
    for case in cases {
        let (a, b) = (case.albedo, case.optical_thickness);
        // Index 1 on both sides: the interfaces are no interfaces, the slab is all there is.
        let slab = stack(vec![
            dielectric(1.0, 0.3),
            medium([a * b; 3], [(1.0 - a) * b; 3], 1.0, case.g),
            dielectric(1.0, 0.0),
        ]);
        let estimate = directional_albedo(&slab, case.mu, &settings(5e-4));
        assert_eq!(estimate.lost, [0.0; 3]);
        let what = format!("a {a} b {b} g {} mu {}", case.g, case.mu);
        comparisons.check(
            format!("{what} R"),
            estimate.reflected[0],
            case.reflectance,
            estimate.reflected_standard_error[0],
            case.reflectance_tolerance,
        );
        comparisons.check(
            format!("{what} T"),
            estimate.transmitted[0],
            case.transmittance,
            estimate.transmitted_standard_error[0],
            case.transmittance_tolerance,
        );
    }
    comparisons.assert_all();
}

#[test]
fn stiff_stacks_stay_finite_and_bounded() {
    let coat = |eta: f64, alpha: f64| dielectric(eta, alpha);
    let base = |alpha: f64| conductor([0.2, 0.9, 1.4], [3.5, 2.2, 1.1], alpha);
    let slab = |sigma_s: f64, depth: f64, g: f64| medium([sigma_s; 3], [0.0, 0.3, 1e3], depth, g);
    let stacks: Vec<(&str, Vec<Layer>)> = vec![
        ("index-matched only", vec![coat(1.0, 1.0)]),
        ("eta < 1", vec![coat(0.7, 1.0)]),
        ("eta 1 layers around a slab", vec![coat(1.0, 0.0), slab(2.0, 1.0, 0.3), coat(1.0, 1.0)]),
        ("kappa 1e4, smooth", vec![conductor([1.0; 3], [1e4; 3], 0.0)]),
        ("kappa 1e4 under a rough coat", vec![coat(1.5, 1.0), conductor([0.5; 3], [1e4; 3], 1.0)]),
        ("depth 0", vec![coat(1.5, 0.3), slab(1.0, 0.0, 0.5), base(0.3)]),
        ("depth 1e6, no scattering", vec![coat(1.5, 0.3), medium([0.0; 3], [0.0; 3], 1e6, 0.0), base(0.3)]),
        ("depth 1e6, scattering", vec![coat(1.3, 0.2), medium([1.0; 3], [0.0, 1e-3, 0.1], 1e6, 0.0)]),
        ("sigma_s 0", vec![coat(1.5, 0.5), slab(0.0, 1.0, 0.0), coat(1.2, 0.5)]),
        ("g 0.999", vec![coat(1.5, 0.1), slab(5.0, 2.0, 0.999), base(0.1)]),
        ("g -0.999", vec![coat(1.5, 0.1), slab(5.0, 2.0, -0.999), base(0.1)]),
        ("g 1", vec![coat(1.5, 0.1), slab(5.0, 2.0, 1.0), coat(1.0, 0.0)]),
        ("g -1", vec![coat(1.5, 0.1), slab(5.0, 2.0, -1.0), coat(1.0, 0.0)]),
        ("g 0.999, semi-infinite", vec![coat(1.5, 0.1), medium([1.0; 3], [0.0; 3], 1e6, 0.999)]),
        ("alpha 1 everywhere", vec![coat(1.5, 1.0), slab(1.0, 1.0, 0.0), coat(2.0, 1.0), base(1.0)]),
        (
            "dispersive, eta < 1 inside",
            vec![conductor([1.4, 1.5, 1.6], [0.0; 3], 0.2), slab(1.0, 0.5, 0.2), coat(0.8, 0.4), base(0.2)],
        ),
        (
            "8 layers",
            vec![
                coat(1.5, 0.2),
                slab(0.5, 0.3, 0.7),
                coat(1.2, 0.6),
                coat(2.0, 0.0),
                slab(3.0, 0.2, -0.4),
                slab(0.0, 1.0, 0.0),
                coat(1.0, 0.1),
                base(0.05),
            ],
        ),
    ];
    for masking in [Masking::Separable, Masking::HeightCorrelated] {
        // One round of paths, short event budgets: the point is what the numbers are, not how
        // precise.
        let s = WalkSettings {
            masking,
            min_paths: 2 * BATCH_PATHS,
            max_paths: 2 * BATCH_PATHS,
            max_events: 2048,
            roulette_after_events: 16,
            ..WalkSettings::default()
        };
        for (name, layers) in &stacks {
            let stack = stack(layers.clone());
            for mu in [0.0, 1e-3, 0.4, 1.0] {
                let e = directional_albedo(&stack, mu, &s);
                let what = format!("{name}, {masking:?}, mu {mu}: {e:?}");
                let numbers =
                    [e.reflected, e.reflected_standard_error, e.transmitted, e.transmitted_standard_error, e.lost];
                assert!(numbers.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{what}");
                for c in 0..3 {
                    assert!(e.reflected[c] <= 1.0 + 3.0 * e.reflected_standard_error[c], "{what}");
                    assert!(e.transmitted[c] <= 1.0 + 3.0 * e.transmitted_standard_error[c], "{what}");
                }
                assert_eq!(e.paths, 2 * BATCH_PATHS, "{what}");
            }
        }
    }
}

#[test]
fn paths_parallel_to_a_slab_do_not_hang() {
    let mut rng = Pcg64Mcg::new(7);
    let limits = EventLimits { roulette_after: 64, max: 1000 };
    let mut path =
        Path { rng: &mut rng, limits, w: DVec3::X, weight: [1.0], events: 0, outcome: PathOutcome::default() };
    // Nothing to scatter it: it never leaves, and its weight is counted as lost.
    assert_eq!(path.cross_slab(0.0, &[0.5], 1.0, 0.0), Fate::Ends);
    assert_eq!(path.outcome.lost, [1.0]);
    // Scattering that never turns it (g = 1 reached directly): the event cap ends it.
    path.w = DVec3::X;
    assert_eq!(path.cross_slab(1.0, &[0.0], 1.0, 1.0), Fate::Ends);
    assert!(path.outcome.truncated && path.events == 1000);
    // In a slab of no thickness the next scattering turns it out.
    path.events = 0;
    path.w = DVec3::X;
    assert_eq!(path.cross_slab(1.0, &[0.0], 0.0, 0.3), Fate::Continues);
    assert!(path.w.z != 0.0);
}

#[test]
fn modelling_choices_name_every_choice() {
    let text = modelling_choices(&WalkSettings::default()).join("\n");
    for phrase in
        ["separable", "lost", "mirrored", "eta_above", "no eta^2", "exp(-sigma_k", "roulette", "PCG", "standard error"]
    {
        assert!(text.contains(phrase), "{phrase} missing from:\n{text}");
    }
    let correlated = modelling_choices(&WalkSettings { masking: Masking::HeightCorrelated, ..WalkSettings::default() });
    assert!(correlated.join(" ").contains("Beta-function"));
}
