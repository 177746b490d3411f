use super::*;
use crate::fit::ALL_FORMS;
use std::path::Path;

use crate::table::{Axis, Channel};

/// A small TIR-shaped table built from a form with known parameters.
fn synthetic(form: Form, parameters: &[f64]) -> Table {
    synthetic_sized(form, parameters, [17, 9, 17])
}

fn synthetic_sized(form: Form, parameters: &[f64], [mu, alpha, eta]: [usize; 3]) -> Table {
    let axes = vec![
        Axis::node_aligned("mu", 0.0, 1.0, mu).unwrap(),
        Axis::node_aligned("alpha", 0.0, 1.0, alpha).unwrap(),
        Axis::node_aligned("eta", 0.0, 1.0, eta).unwrap(),
    ];
    let mut table = Table::zeros("tir", axes, vec![Channel::new("tir", "synthetic")]).unwrap();
    for n in 0..table.node_count() {
        let p = table.node_position(&table.node_index(n));
        table.data[n] = form.eval(parameters, p[0], p[1], p[2]) as f32;
    }
    table
}

const KNOWN: [f64; 7] = [0.4, 0.2, -0.1, 0.05, 0.1, -0.05, 0.02];

#[test]
fn fit_recovers_known_parameters_from_a_synthetic_table() {
    let table = synthetic(Form::Logistic, &KNOWN);
    let data = FitData::from_table(&table).unwrap();
    let settings = FitSettings { starts: 3, ..FitSettings::default() };
    let fitted = fit_form(Form::Logistic, &data, &settings).unwrap();
    for (got, want) in fitted.parameters.iter().zip(KNOWN) {
        assert!((got - want).abs() < 1e-3, "{:?} vs {KNOWN:?}", fitted.parameters);
    }
    let search = fitted.search.as_ref().unwrap();
    assert_eq!(search.starts.len(), 3);
    assert!(search.starts.iter().all(|s| !s.status.is_empty() && s.evaluations > 0));
    assert!(figures(&fitted, &data).rmse < 1e-5);
    // Reproducible: same table and seed, same coefficients, bit for bit.
    assert_eq!(fit_form(Form::Logistic, &data, &settings).unwrap().parameters, fitted.parameters);
}

/// Cauchy-cap parameters near the fit to the built table (docs/fit.md).
const KNOWN_CAUCHY: [f64; 10] = [1.3, -0.35, -0.45, 0.7, -0.35, 1.75, 1.3, 1.35, 0.6, 0.4];

#[test]
fn cauchy_cap_fit_recovers_known_parameters_reproducibly() {
    let table = synthetic(Form::CauchyCap, &KNOWN_CAUCHY);
    let data = FitData::from_table(&table).unwrap();
    let settings = FitSettings { starts: 2, ..FitSettings::default() };
    let fitted = fit_form(Form::CauchyCap, &data, &settings).unwrap();
    for (got, want) in fitted.parameters.iter().zip(KNOWN_CAUCHY) {
        assert!((got - want).abs() < 1e-2, "{:?} vs {KNOWN_CAUCHY:?}", fitted.parameters);
    }
    assert!(figures(&fitted, &data).rmse < 1e-5);
    assert_eq!(fit_form(Form::CauchyCap, &data, &settings).unwrap().parameters, fitted.parameters);
}

/// Cauchy-slope parameters near the fit to the built table (docs/fit.md).
const KNOWN_CAUCHY_SLOPE: [f64; 10] = [1.45, -0.5, -0.5, 0.7, -0.4, 1.4, 0.65, 0.55, 0.4, 15.0];

#[test]
fn cauchy_slope_fit_recovers_known_parameters_reproducibly() {
    let table = synthetic_sized(Form::CauchySlope, &KNOWN_CAUCHY_SLOPE, [33, 17, 33]);
    let data = FitData::from_table(&table).unwrap();
    let settings = FitSettings { starts: 1, ..FitSettings::default() };
    let fitted = fit_form(Form::CauchySlope, &data, &settings).unwrap();
    for (got, want) in fitted.parameters.iter().zip(KNOWN_CAUCHY_SLOPE) {
        assert!((got - want).abs() < 2e-2 * want.abs().max(1.0), "{:?} vs {KNOWN_CAUCHY_SLOPE:?}", fitted.parameters);
    }
    assert!(figures(&fitted, &data).rmse < 1e-5);
    assert_eq!(fit_form(Form::CauchySlope, &data, &settings).unwrap().parameters, fitted.parameters);
}

/// The slope lobe's share above a cosine against sampling: in-plane GGX slopes of scale `s`
/// (a Student t with two degrees of freedom, inverse CDF `t = s x / sqrt(1 - x^2)`, `x = 2U - 1`),
/// each weighted by its projected area `mu + t` where positive, reflected to cosine `mu + 2 t`.
#[test]
fn slope_lobe_share_matches_sampled_visible_slopes() {
    let mut state = 11u64;
    let mut uniform = || (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
    for &(mu, scale, cosine) in &[(0.03, 0.03, 0.18), (0.0, 0.05, 0.1), (0.2, 0.02, 0.15), (0.1, 0.1, 0.5)] {
        let samples = 400_000;
        let (mut above, mut total) = (0.0, 0.0);
        for _ in 0..samples {
            let x = 2.0 * uniform() - 1.0;
            let t = scale * x / (1.0 - x * x).sqrt();
            let weight = (mu + t).max(0.0);
            total += weight;
            if mu + 2.0 * t > cosine {
                above += weight;
            }
        }
        let sampled = above / total;
        // The closed form up to a common factor: normalise by its value at the lowest cosine a
        // seen facet reflects to, `mu - 2 mu = -mu`, where the whole lobe is above.
        let closed = forms::slope_lobe_above(cosine, mu, scale) / forms::slope_lobe_above(-mu, mu, scale);
        assert!((sampled - closed).abs() < 3e-3, "{mu} {scale} {cosine}: {sampled} vs {closed}");
    }
}

/// The cap share in closed form against sampling: GGX slopes of scale `l` (density
/// `1 / (pi l^2 (1 + r^2 / l^2)^2)`, inverse CDF `r^2 = l^2 U / (1 - U)`) lifted to the sphere by
/// the inverse stereographic projection `tan(theta / 2) = r` around the lobe's centre.
#[test]
fn cap_share_matches_sampled_spherical_cauchy() {
    let mut state = 7u64;
    let mut uniform = || (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
    for &(centre_cosine, scale, cap_cosine) in &[(0.9, 0.1, 0.95), (0.3, 0.4, 0.6), (1.0, 0.05, 0.99), (0.0, 1.0, 0.0)]
    {
        let samples = 200_000;
        let centre_sine = (1.0f64 - centre_cosine * centre_cosine).sqrt();
        let mut inside = 0usize;
        for _ in 0..samples {
            let u = uniform();
            let r = scale * (u / (1.0 - u)).sqrt();
            let theta = 2.0 * r.atan();
            let phi = 2.0 * std::f64::consts::PI * uniform();
            // Cosine to the normal of a direction at angle theta, azimuth phi from the centre.
            let z = centre_cosine * theta.cos() - centre_sine * theta.sin() * phi.cos();
            inside += (z > cap_cosine) as usize;
        }
        let sampled = inside as f64 / samples as f64;
        let cap_sine = (1.0f64 - cap_cosine * cap_cosine).sqrt();
        let u = scale * scale * (centre_cosine + cap_cosine) + (cap_cosine - centre_cosine);
        let closed = forms::cap_share(u, 2.0 * scale * cap_sine);
        assert!((sampled - closed).abs() < 4e-3, "{centre_cosine} {scale} {cap_cosine}: {sampled} vs {closed}");
    }
}

#[test]
fn fitted_coefficients_do_not_depend_on_the_thread_count() {
    // Several objective chunks, so that the threads really split the sum.
    let table = synthetic_sized(Form::Logistic, &KNOWN, [33, 17, 33]);
    let data = FitData::from_table(&table).unwrap();
    assert!(data.values.len() > 3 * OBJECTIVE_CHUNK);
    let settings = FitSettings { starts: 1, ..FitSettings::default() };
    let with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| fit_form(Form::Rational, &data, &settings).unwrap().parameters)
    };
    assert_eq!(with(1), with(3));
}

#[test]
fn derivative_free_search_solves_a_bounded_least_squares_problem() {
    // (x - 0.3)^2 + (y + 0.2)^2 with the bound y >= 0: minimum at (0.3, 0).
    let objective = |x: &[f64], _: Option<&mut [f64]>| (x[0] - 0.3).powi(2) + (x[1] + 0.2).powi(2);
    let m = minimise(&objective, false, &[0.9, 0.9], &[-1.0, 0.0], &[1.0, 1.0], &FitSettings::default()).unwrap();
    assert_eq!(m.algorithm, "Bobyqa");
    assert!((m.parameters[0] - 0.3).abs() < 1e-5 && m.parameters[1].abs() < 1e-9, "{:?}", m.parameters);
    // A NaN objective is reported as a failed start, not hidden.
    let nan = |_: &[f64], _: Option<&mut [f64]>| f64::NAN;
    let err = minimise(&nan, false, &[0.5], &[0.0], &[1.0], &FitSettings { starts: 2, ..FitSettings::default() });
    assert!(err.is_err());
    assert!(minimise(&objective, false, &[0.0], &[1.0], &[0.0], &FitSettings::default()).is_err(), "bad bounds");
}

#[test]
fn analytic_gradient_matches_finite_differences() {
    for form in [Form::Logistic, Form::Smoothstep, Form::Algebraic, Form::Rational] {
        let mut gradient = [0.0; 7];
        let (mu, alpha, eta) = (0.55, 0.4, 0.8);
        form.value_and_gradient(&KNOWN, mu, alpha, eta, &mut gradient).unwrap();
        for k in 0..7 {
            let h = 1e-6;
            let (mut up, mut down) = (KNOWN, KNOWN);
            up[k] += h;
            down[k] -= h;
            let numeric = (form.eval(&up, mu, alpha, eta) - form.eval(&down, mu, alpha, eta)) / (2.0 * h);
            assert!((numeric - gradient[k]).abs() < 1e-6, "{form:?} {k}: {numeric} vs {}", gradient[k]);
        }
    }
    // The dual-number gradients of the Cauchy forms, at points on each side of their branches.
    for (form, known) in [(Form::CauchyCap, KNOWN_CAUCHY), (Form::CauchySlope, KNOWN_CAUCHY_SLOPE)] {
        for &(mu, alpha, eta) in &[(0.55, 0.4, 0.8), (0.05, 0.1, 0.97), (0.98, 0.03, 0.1), (0.3, 0.9, 0.5)] {
            let mut gradient = [0.0; 10];
            form.value_and_gradient(&known, mu, alpha, eta, &mut gradient).unwrap();
            for k in 0..10 {
                let h = 1e-6;
                let (mut up, mut down) = (known, known);
                up[k] += h;
                down[k] -= h;
                let f = |p: &[f64]| form.eval(p, mu, alpha, eta);
                let numeric = (f(&up) - f(&down)) / (2.0 * h);
                assert!(
                    (numeric - gradient[k]).abs() < 1e-6,
                    "{form:?} {k} at {mu} {alpha} {eta}: {numeric} vs {}",
                    gradient[k]
                );
            }
        }
    }
}

#[test]
fn reported_errors_match_an_independent_evaluation() {
    let table = synthetic(Form::Logistic, &KNOWN);
    let data = FitData::from_table(&table).unwrap();
    let fitted =
        FittedForm { form: Form::Rational, parameters: vec![0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01], search: None };
    let reported = figures(&fitted, &data);
    // Independently: walk the table by index, evaluate in f32, accumulate in f64.
    let p = [0.3f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01];
    let (mut sum, mut max, mut count) = (0.0f64, 0.0f64, 0usize);
    for k in 0..17 {
        for j in 0..9 {
            for i in 0..17 {
                let (mu, alpha, eta) = (i as f32 / 16.0, j as f32 / 8.0, k as f32 / 16.0);
                let v = Form::Rational.eval(&p, mu, alpha, eta) as f64;
                let e = v - table.node(&[i, j, k])[0] as f64;
                sum += e * e;
                max = max.max(e.abs());
                count += 1;
            }
        }
    }
    assert_eq!(reported.nodes, count);
    assert!((reported.mse - sum / count as f64).abs() < 1e-12);
    assert!((reported.rmse - (sum / count as f64).sqrt()).abs() < 1e-12);
    assert_eq!(reported.max_abs_error, max);
    let at = reported.max_at;
    let v = Form::Rational.eval(&p, at[0] as f32, at[1] as f32, at[2] as f32) as f64;
    assert!((v - table.interpolate(&at)[0]).abs() == max, "max at {at:?}");
}

#[test]
fn eq56_as_published_is_mostly_zero_and_the_baselines_have_no_parameters() {
    // The published step keeps only w_s.z <= 0, and 1 - F(w_o.z; 1/1.5) vanishes for
    // theta_o = pi/4 (1 + mu) >= 45 degrees, past the 41.8 degree critical angle.
    let mut non_zero = 0;
    for i in 0..=20 {
        for k in 0..=20 {
            let v = Form::Eq56.eval::<f64>(&[], i as f64 / 20.0, 0.5, k as f64 / 20.0);
            assert!(v.is_finite());
            non_zero += (v != 0.0) as usize;
        }
    }
    assert_eq!(non_zero, 0);
    assert!(Form::Eq56Corrected.parameters().is_empty());
    for form in ALL_FORMS {
        assert_eq!(Form::from_name(form.name()), Some(form));
        // Finite everywhere on the domain, edges included.
        for &(mu, alpha, eta) in &[(0.0f32, 0.0f32, 0.0f32), (1.0, 1.0, 1.0), (0.0, 1.0, 1.0), (1.0, 0.0, 0.0)] {
            let (p, _, _) = form.start_and_bounds();
            let p: Vec<f32> = p.iter().map(|&v| v as f32).collect();
            assert!(form.eval(&p, mu, alpha, eta).is_finite(), "{form:?} at {mu} {alpha} {eta}");
        }
    }
}

/// Every number after `c0 =`-style placement: the coefficients in the text, in order.
fn baked_coefficients(text: &str) -> Vec<f32> {
    let width = text.lines().find(|l| l.contains("width = alpha * max(")).unwrap();
    let shift = text.lines().find(|l| l.contains("shift = alpha * (")).unwrap();
    let numbers = |line: &str| -> Vec<f32> {
        line.split(['(', ')', '*', '+', ',']).filter_map(|s| s.trim().parse::<f32>().ok()).collect::<Vec<_>>()
    };
    let w = numbers(width); // c0, c1, c2, 0.0 (max), floor
    let s = numbers(shift); // c3, c4, c5
    let t_line = text.lines().find(|l| l.contains(" t = (mu * mu")).unwrap();
    let e = numbers(t_line.rsplit_once("width").unwrap().1); // c6 ("edge_logit" is not a number)
    vec![w[0], w[1], w[2], s[0], s[1], s[2], e[0]]
}

/// The Cauchy forms' shaders' named constants `c0..c9` (`float c3 = ...;` or `let c3: f32 = ...;`).
fn baked_constants(text: &str) -> Vec<f32> {
    (0..10)
        .map(|k| {
            let declares = |l: &&str| l.contains(&format!(" c{k} = ")) || l.contains(&format!(" c{k}: f32 = "));
            let line = text.lines().find(declares).unwrap_or_else(|| panic!("no c{k} in\n{text}"));
            line.rsplit_once('=').unwrap().1.trim().trim_end_matches(';').parse::<f32>().unwrap()
        })
        .collect()
}

#[test]
fn shader_coefficients_match_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let table = synthetic(Form::Algebraic, &KNOWN);
    let request = FitRequest {
        table_path: "synthetic".into(),
        forms: vec![Form::Eq56, Form::Logistic, Form::Algebraic, Form::CauchyCap, Form::CauchySlope],
        out: dir.path().to_path_buf(),
        settings: FitSettings { starts: 2, ..FitSettings::default() },
        timing_runs: 3,
        timing_queries: 256,
    };
    let manifest = fit_tir(&table, &request).unwrap();
    let read: FitManifest = serde_json::from_slice(&std::fs::read(dir.path().join("fit.json")).unwrap()).unwrap();
    assert_eq!(read, manifest);
    assert!(dir.path().join("error_vs_cost.png").is_file());
    for form in ["eq56", "logistic", "algebraic", "cauchy-cap", "cauchy-slope"] {
        assert!(dir.path().join(format!("tir_error_{form}.png")).is_file());
        let map = crate::formats::exr::read_exr(&dir.path().join(format!("tir_error_{form}.exr"))).unwrap();
        let reported = read.forms.iter().find(|f| f.name == form).unwrap().figures.max_abs_error;
        let max = map.data.iter().fold(0.0f32, |m, &v| m.max(v));
        assert_eq!(max, reported as f32, "{form}: the map and the manifest agree");
    }
    assert!(read.table_fetch_cost_ns_f32 > 0.0);
    for form in &read.forms {
        assert!(form.cost_ns_per_evaluation_f32 > 0.0);
        if form.parameters.is_empty() {
            assert!(form.shaders.is_empty());
            continue;
        }
        assert_eq!(form.shaders.len(), 2);
        for shader in &form.shaders {
            let text = std::fs::read_to_string(dir.path().join(shader)).unwrap();
            let manifest_f32: Vec<f32> = form.parameters.iter().map(|&v| v as f32).collect();
            let baked =
                if form.name.starts_with("cauchy") { baked_constants(&text) } else { baked_coefficients(&text) };
            assert_eq!(baked, manifest_f32, "{shader}");
        }
    }
    let algebraic = read.forms.iter().find(|f| f.name == "algebraic").unwrap();
    assert!(algebraic.figures.rmse < 1e-4, "{:?}", algebraic.figures);
}

#[test]
fn the_most_accurate_form_is_chosen_by_its_worst_node_within_the_cost() {
    let report = |name: &str, rmse: f64, max_abs_error: f64, cost: f64, parameters: usize| FormReport {
        name: name.into(),
        formula: String::new(),
        definition: vec![],
        parameter_names: vec![],
        parameters: vec![0.0; parameters],
        figures: ErrorFigures { rmse, mse: rmse * rmse, max_abs_error, max_at: [0.0; 3], nodes: 1 },
        cost_ns_per_evaluation_f32: cost,
        search: None,
        shaders: vec![],
    };
    let forms = [
        report("baseline", 0.5, 1.0, 10.0, 0),
        report("low-rmse", 0.007, 0.13, 50.0, 10),
        report("low-max", 0.008, 0.06, 42.0, 10),
        report("costly", 0.001, 0.01, 60.0, 10),
        report("tie-worse-rmse", 0.009, 0.06, 40.0, 7),
    ];
    assert_eq!(most_accurate_within(&forms, 54.0).as_deref(), Some("low-max"));
    assert_eq!(most_accurate_within(&forms, 61.0).as_deref(), Some("costly"));
    assert_eq!(most_accurate_within(&forms, 41.0).as_deref(), Some("tie-worse-rmse"));
    assert_eq!(most_accurate_within(&forms, 5.0), None, "the parameter-free baseline is never chosen");
}

/// A small TIR build with `tir.fit` as given, into `out`.
fn build_small_tir(out: &Path, fit: crate::recipes::tir::TirFit) -> crate::formats::manifest::Manifest {
    let mut config = crate::config::Config::default();
    config.tir.mu_count = 17;
    config.tir.alpha_count = 9;
    config.tir.eta_count = 17;
    config.tir.sampling.samples = 1024;
    config.tir.reference.cells = 0;
    config.tir.interpolation.points = 0;
    config.tir.fit = fit;
    let request =
        crate::pipeline::BuildRequest { config, only: Some(vec!["tir".into()]), out: out.into(), error_maps: false };
    crate::pipeline::build(&request, &()).unwrap();
    crate::formats::manifest::Manifest::read_or_default(out).unwrap()
}

#[test]
fn the_build_writes_the_best_form_reproducibly_and_only_when_asked() {
    use crate::recipes::tir::TirFit;
    let (first, second, off) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let manifest = build_small_tir(first.path(), TirFit::Best);
    let fit = manifest.files["tir.dds"].fit.clone().expect("tir.fit = \"best\" records the fit");
    assert_eq!(fit.form, BUILD_FORM.name());
    assert_eq!(fit.parameters.len(), fit.parameter_names.len());
    let search = fit.search.as_ref().unwrap();
    assert_eq!(search.starts.len(), BUILD_STARTS);
    assert!(search.starts.iter().all(|s| !s.status.is_empty()));
    // The recorded figures are those of the recorded coefficients on the built table, read back
    // and interpolated at the nodes of the uniform fit grid.
    let table = crate::loader::load_table(first.path().join("tir.dds")).unwrap();
    let data = FitData::from_table(&fit_grid(&table).unwrap()).unwrap();
    let refitted = FittedForm { form: BUILD_FORM, parameters: fit.parameters.clone(), search: None };
    assert_eq!(figures(&refitted, &data), fit.figures);
    let manifest_f32: Vec<f32> = fit.parameters.iter().map(|&v| v as f32).collect();
    // The manifest's definition, with its parameters as the shaders take them (f32), computes what
    // the shader files written beside it compute.
    assert_eq!(fit.definition, BUILD_FORM.definition());
    let as_f32: Vec<f64> = manifest_f32.iter().map(|&v| format!("{v:?}").parse().unwrap()).collect();
    for shader in &fit.shaders {
        let text = std::fs::read_to_string(first.path().join(&shader.file)).unwrap();
        assert_eq!(baked_constants(&text), manifest_f32, "{}", shader.file);
        assert_eq!(crate::pipeline::sha256_hex(text.as_bytes()), shader.sha256);
        for point in [[0.3, 0.02, 0.9], [0.9, 0.3, 0.2], [0.05, 0.001, 0.99], [1.0, 0.0, 0.0]] {
            let from_manifest = crate::fit::forms::definition_tests::run_definition(&fit.definition, &as_f32, point);
            let from_shader = crate::fit::forms::definition_tests::run_shader(&text, point);
            assert!(
                (from_manifest - from_shader).abs() <= 1e-9,
                "{} at {point:?}: {from_manifest} vs {from_shader}",
                shader.file
            );
        }
    }
    // Same table and seed: same coefficients and shader bytes.
    let again = build_small_tir(second.path(), TirFit::Best);
    assert_eq!(again.files["tir.dds"].fit.as_ref().unwrap().parameters, fit.parameters);
    for name in ["tir_fit.hlsl", "tir_fit.wgsl"] {
        assert_eq!(std::fs::read(first.path().join(name)).unwrap(), std::fs::read(second.path().join(name)).unwrap());
    }
    let none = build_small_tir(off.path(), TirFit::Off);
    assert!(none.files["tir.dds"].fit.is_none());
    assert!(!off.path().join("tir_fit.hlsl").exists());
}
