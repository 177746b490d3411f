use std::path::Path;

use super::*;
use crate::fit::forms::fitted::tir_shape;
use crate::fit::forms::form::Form;
use crate::ir::compile::FormEvaluator;

/// splitmix64 numbers uniform in [0, 1).
fn uniform(mut state: u64) -> impl FnMut() -> f64 {
    move || (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64
}

/// A TIR form file of `luts/forms/` read against the TIR table's shape.
fn form_file(file: &str) -> Form {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms").join(file);
    Form::parse_for(&path, &std::fs::read_to_string(&path).unwrap(), &tir_shape()).unwrap()
}

/// Some of `form`'s `let` bindings as a definition over `variables`, its channel `channel`: the
/// form file's own text of a closed form, to check that text against sampling.
fn part_of(form: &Form, variables: &str, lets: &[&str], channel: &str) -> FormEvaluator {
    let mut definition = vec![format!("table = part, variables: {variables}")];
    for name in lets {
        let binding = form.lets.iter().find(|b| b.name == *name).unwrap_or_else(|| panic!("no `{name}`"));
        definition.push(format!("{} = {}", binding.name, binding.text));
    }
    definition.push(format!("channel value = {channel}"));
    FormEvaluator::from_definition(&definition, &[], &[]).unwrap()
}

/// The slope lobe's share above a cosine, as `tir-cauchy-slope.toml` writes it, against sampling:
/// in-plane GGX slopes of scale `s` (a Student t with two degrees of freedom, inverse CDF
/// `t = s x / sqrt(1 - x^2)`, `x = 2U - 1`), each weighted by its projected area `mu + t` where
/// positive, reflected to cosine `mu + 2 t`.
#[test]
fn the_slope_lobe_share_matches_sampled_visible_slopes() {
    let form = form_file("tir-cauchy-slope.toml");
    let above = part_of(
        &form,
        "slope_s, cb, mu",
        &["crit_t", "crit_r", "crit_e", "crit_num", "crit_den"],
        "crit_num / crit_den",
    );
    let mut uniform = uniform(11);
    for &(mu, scale, cosine) in &[(0.03, 0.03, 0.18), (0.0, 0.05, 0.1), (0.2, 0.02, 0.15), (0.1, 0.1, 0.5)] {
        let samples = 400_000;
        let (mut sum_above, mut total) = (0.0, 0.0);
        for _ in 0..samples {
            let x = 2.0 * uniform() - 1.0;
            let t = scale * x / (1.0 - x * x).sqrt();
            let weight = (mu + t).max(0.0);
            total += weight;
            if mu + 2.0 * t > cosine {
                sum_above += weight;
            }
        }
        let sampled = sum_above / total;
        // The closed form up to a common factor: normalised by its value at the lowest cosine a
        // seen facet reflects to, `mu - 2 mu = -mu`, where the whole lobe is above.
        let closed = above.eval_f64(&[scale, cosine, mu]) / above.eval_f64(&[scale, -mu, mu]);
        assert!((sampled - closed).abs() < 3e-3, "{mu} {scale} {cosine}: {sampled} vs {closed}");
    }
}

/// A spherical Cauchy lobe's share in a cap, as `tir-cauchy-slope.toml` and
/// `tir-cauchy-cap.toml` write it, against sampling: GGX slopes of scale `l` (density
/// `1 / (pi l^2 (1 + r^2 / l^2)^2)`, inverse CDF `r^2 = l^2 U / (1 - U)`) lifted to the sphere by
/// the inverse stereographic projection `tan(theta / 2) = r` around the lobe's centre.
#[test]
fn the_cap_share_matches_a_sampled_spherical_cauchy_lobe() {
    for file in ["tir-cauchy-slope.toml", "tir-cauchy-cap.toml"] {
        let form = form_file(file);
        let lets = ["cone_u", "cone_w", "cone_s", "cone_num", "cone_den"];
        // The cone of cosine cb and sine eta.
        let share = part_of(&form, "scale, centre, cb, eta", &lets, "cone_num / cone_den");
        let mut uniform = uniform(7);
        for &(centre_cosine, scale, cap_cosine) in
            &[(0.9, 0.1, 0.95), (0.3, 0.4, 0.6), (1.0, 0.05, 0.99), (0.0, 1.0, 0.0)]
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
            let closed = share.eval_f64(&[scale, centre_cosine, cap_cosine, cap_sine]);
            assert!(
                (sampled - closed).abs() < 4e-3,
                "{file}: {centre_cosine} {scale} {cap_cosine}: {sampled} vs {closed}"
            );
        }
    }
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

/// Thesis eq. 5.6 as published keeps only `w_s.z <= 0`, where its G1 factor is 0: the form file
/// is 0 everywhere. The corrected one is not, and neither has a parameter; both are finite on the
/// whole domain, its edges included.
#[test]
fn eq56_as_published_is_zero_and_the_baselines_have_no_parameters() {
    let (published, corrected) = (form_file("tir-eq56.toml"), form_file("tir-eq56-corrected.toml"));
    assert!(published.parameters.is_empty() && corrected.parameters.is_empty());
    let evaluate = |form: &Form| FormEvaluator::new(form.tape.clone(), form.variables.clone(), &[]);
    let (published, corrected) = (evaluate(&published), evaluate(&corrected));
    let mut corrected_non_zero = 0;
    for i in 0..=20 {
        for j in 0..=20 {
            for k in 0..=20 {
                let (mu, alpha, eta) = (i as f64 / 20.0, j as f64 / 20.0, k as f64 / 20.0);
                assert_eq!(published.tir(mu, alpha, eta), 0.0, "at {mu} {alpha} {eta}");
                let v = corrected.tir(mu, alpha, eta);
                assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{v} at {mu} {alpha} {eta}");
                corrected_non_zero += (v != 0.0) as usize;
            }
        }
    }
    assert!(corrected_non_zero > 1000, "{corrected_non_zero}");
}

/// A small TIR build with `tir.fit` as given, into `out`.
fn build_small_tir(out: &Path, fit: crate::recipes::tir::TirFit) -> crate::formats::manifest::Manifest {
    let mut config = crate::config::Config::default();
    config.tir.mu_count = 17;
    config.tir.alpha_count = 9;
    config.tir.eta_count = 17;
    config.tir.shared.sampling.samples = 1024;
    config.tir.shared.reference.cells = 0;
    config.tir.shared.interpolation.points = 0;
    config.tir.fit = fit;
    let request =
        crate::pipeline::BuildRequest { config, only: Some(vec!["tir".into()]), out: out.into(), error_maps: false };
    crate::pipeline::build(&request, &()).unwrap();
    crate::formats::manifest::Manifest::read_or_default(out).unwrap()
}

/// The build fits the form file `tir-cauchy-slope.toml`, records its text, definition and
/// parameters, and writes `tmlut_tir` as its shaders print it; the manifest's definition alone
/// (what the loader-side model evaluates) computes what the form file computes, and the figures
/// are those of the recorded parameters. Same table and seed, same files; `fit = "off"`, none.
#[test]
fn the_build_fits_its_form_file_reproducibly_and_only_when_asked() {
    use crate::fit::forms::build::{BUILD_FORM_TEXT, BUILD_STARTS, build_form};
    use crate::fit::forms::data::FormData;
    use crate::fit::forms::figures::figures;
    use crate::recipes::tir::TirFit;
    let (first, second, off) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let manifest = build_small_tir(first.path(), TirFit::Best);
    let fit = manifest.files["tir.dds"].fit.clone().expect("tir.fit = \"best\" records the fit");
    assert_eq!(fit.form, "tir-cauchy-slope");
    assert_eq!(fit.form_text, BUILD_FORM_TEXT);
    let form = build_form().unwrap();
    assert_eq!(fit.parameter_names, form.parameter_names());
    assert_eq!(fit.definition, form.definition());
    let search = fit.search.as_ref().unwrap();
    assert_eq!(search.starts.len(), BUILD_STARTS);
    assert!(search.starts.iter().all(|s| !s.status.is_empty()));
    // The recorded figures are those of the recorded parameters on the built table, read back.
    let table = crate::loader::load_table(first.path().join("tir.dds")).unwrap();
    let read = Form::parse(Path::new("tir.toml"), BUILD_FORM_TEXT, &table).unwrap();
    let data = FormData::from_table(&table, &read).unwrap();
    let set = figures(&read, &data, &fit.parameters).unwrap();
    assert_eq!(
        (set.together.rms, set.together.max, data.len()),
        (fit.figures.rmse, fit.figures.max_abs_error, fit.figures.nodes)
    );
    // The manifest's definition, compiled alone, is the form file's form.
    let from_manifest = FormEvaluator::from_definition(&fit.definition, &fit.parameter_names, &fit.parameters).unwrap();
    let from_file = FormEvaluator::new(form.tape.clone(), form.variables.clone(), &fit.parameters);
    let mut unit = uniform(3);
    for _ in 0..1000 {
        let (mu, alpha, eta) = (unit(), unit(), unit());
        assert_eq!(from_manifest.tir(mu, alpha, eta).to_bits(), from_file.tir(mu, alpha, eta).to_bits());
    }
    for shader in &fit.shaders {
        let text = std::fs::read_to_string(first.path().join(&shader.file)).unwrap();
        assert_eq!(shader.function, "tmlut_tir");
        assert!(text.contains("tmlut_tir("), "{}", shader.file);
        assert_eq!(crate::pipeline::sha256_hex(text.as_bytes()), shader.sha256);
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

/// A manifest's definition that is not one the form language states is refused, naming what is
/// wrong, so that the model never evaluates a form other than the one recorded.
#[test]
fn a_definition_the_language_cannot_read_is_refused_naming_the_statement() {
    let lines = |l: &[&str]| l.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let names = lines(&["a"]);
    let good = lines(&["table = tir, variables: mu, alpha, eta", "x = a * mu", "channel tir = x + alpha"]);
    let form = FormEvaluator::from_definition(&good, &names, &[0.5]).unwrap();
    assert_eq!(form.tir(0.5, 0.25, 0.0), 0.5);
    let refused = |definition: &[&str], names: &[String], parameters: &[f64], says: &str| {
        let e = FormEvaluator::from_definition(&lines(definition), names, parameters).unwrap_err();
        assert!(e.contains(says), "expected `{says}` in: {e}");
    };
    refused(&[], &names, &[0.5], "empty");
    refused(&["TIR = c0 * mu"], &names, &[0.5], "table = NAME, variables");
    refused(
        &[good[0].as_str(), "x = c0 * mu", "channel tir = x"],
        &names,
        &[0.5],
        "statement `x = c0 * mu`: unknown name `c0`",
    );
    refused(&[good[0].as_str(), "x = a ? mu : 1", "channel tir = x"], &names, &[0.5], "statement `x = a ? mu : 1`");
    refused(&[good[0].as_str(), "mu = a", "channel tir = mu"], &names, &[0.5], "`mu` is defined twice");
    refused(&[good[0].as_str(), "x = a"], &names, &[0.5], "no channel");
    refused(&good.iter().map(String::as_str).collect::<Vec<_>>(), &names, &[], "1 parameter names for 0 parameters");
}
