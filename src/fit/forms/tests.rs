use std::path::Path;

use super::data::FormData;
use super::figures::figures;
use super::fitting::fit;
use super::form::ShaderArgument;
use super::identifiability::identifiability;
use super::prepared::SearchData;
use super::shader::{lookup_module, module, sources};
use super::*;
use crate::fit::FitSettings;
use crate::table::{Axis, Channel, Table};

/// A two-channel table named `karis` over (mu, alpha), filled with a known function.
fn karis_like(n: usize, value: impl Fn(f64, f64) -> [f64; 2]) -> Table {
    let axes = vec![Axis::node_aligned("mu", 0.0, 1.0, n).unwrap(), Axis::node_aligned("alpha", 0.0, 1.0, n).unwrap()];
    let channels = vec![Channel::new("scale", "test"), Channel::new("bias", "test")];
    let mut table = Table::zeros("karis", axes, channels).unwrap();
    for node in 0..table.node_count() {
        let p = table.node_position(&table.node_index(node));
        let v = value(p[0], p[1]);
        table.data[2 * node] = v[0] as f32;
        table.data[2 * node + 1] = v[1] as f32;
    }
    table
}

fn table() -> Table {
    karis_like(8, |mu, alpha| [1.0 - 0.5 * alpha.sqrt() * mu, 0.1 * (1.0 - mu).powi(5)])
}

const GOOD: &str = r#"table = "karis"
[parameters]
p = { start = 0.5, min = -2.0, max = 2.0 }
q = { start = 1.0, min = 0.0, max = 10.0 }
[let]
t = "1 - mu"
[channels]
scale = "1 - p * roughness * mu"
bias = "0.1 * t ^ q"
"#;

fn parse(text: &str) -> crate::error::Result<Form> {
    Form::parse(Path::new("forms/test-form.toml"), text, &table())
}

/// The error's text, which must name the file, line and column.
fn error_at(text: &str, line: usize, column: usize, says: &str) {
    let e = parse(text).expect_err("refused").to_string();
    let place = format!("forms/test-form.toml:{line}:{column}: ");
    assert!(e.starts_with(&place), "expected {place}..., got: {e}");
    assert!(e.contains(says), "expected `{says}` in: {e}");
}

#[test]
fn a_good_form_reads_with_its_variables_bindings_and_channels_in_order() {
    let form = parse(GOOD).unwrap();
    assert_eq!(form.name, "test_form");
    assert_eq!(form.variables, ["mu", "alpha"]);
    assert_eq!(form.derived.iter().map(|d| d.name.as_str()).collect::<Vec<_>>(), ["roughness"]);
    assert_eq!(form.parameter_names(), ["p", "q"]);
    assert_eq!(form.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), ["scale", "bias"]);
    let mut scratch = Vec::new();
    let mut out = [0.0; 2];
    form.tape.eval(&[0.5, 0.25], &[0.5, 2.0], &mut scratch, &mut out);
    assert_eq!(out, [1.0 - 0.5 * 0.5 * 0.5, 0.1 * 0.25]);
}

#[test]
fn each_kind_of_mistake_names_file_line_and_column() {
    // Syntax: the `*` after `+` on line 8, column 14 (the expression starts at column 10).
    error_at(&GOOD.replace("1 - p * roughness", "1 + * p roughness"), 8, 14, "expected a number");
    error_at(&GOOD.replace("roughness * mu", "roughness * nu"), 8, 30, "unknown name `nu`");
    error_at(&GOOD.replace("t ^ q", "tt(q)"), 9, 15, "unknown function `tt`");
    error_at(&GOOD.replace("0.1 * t ^ q", "pow(t) * q"), 9, 9, "`pow` called with 1 arguments");
    error_at(&GOOD.replace("0.1 * t ^ q", "0.1 * t"), 4, 1, "parameter `q` is never used");
    error_at(&GOOD.replace("t = \"1 - mu\"", "t = \"1 - mu\"\nu = \"t * t\""), 7, 1, "`u` in [let] is never used");
    error_at(&GOOD.replace("start = 1.0, min = 0.0", "start = -1.0, min = 0.0"), 4, 15, "exclude its start -1");
    error_at(&GOOD.replace("min = -2.0, max = 2.0", "min = 2.0, max = 2.0"), 3, 26, "min 2 is not below max 2");
    error_at(&GOOD.replace("bias =", "offset ="), 9, 1, "has no channel `offset`; its channels: scale, bias");
    error_at(&GOOD.replace("\"karis\"", "\"tir\""), 1, 9, "the form is for table `tir`");
    error_at(&GOOD.replace("t = \"1 - mu\"", "mu = \"1\""), 6, 1, "`mu` is already defined");
    error_at(&GOOD.replace("t = \"1 - mu\"", "let = \"1\""), 6, 1, "reserved");
    error_at(&GOOD.replace("[let]", "[lets]"), 5, 2, "unknown field");
    error_at(&GOOD.replace("min = 0.0, max", "min = 0.0, maximum"), 4, 31, "unknown field");
    // A binding reads only those before it.
    error_at(&GOOD.replace("t = \"1 - mu\"", "t = \"u\"\nu = \"1 - mu\""), 6, 6, "unknown name `u`");
    // Comparisons outside select.
    error_at(&GOOD.replace("0.1 * t ^ q", "t ^ q < 1"), 9, 15, "only allowed as the condition of select");
}

/// A form over the Karis table that reads both `alpha` and `roughness`, for its function's
/// signatures.
const BOTH: &str = r#"table = "karis"
[parameters]
p = { start = 0.5, min = -2.0, max = 2.0 }
[channels]
scale = "1 - p * alpha * mu"
bias = "0.1 * sqrt(1 - mu) + p * roughness"
"#;

/// `text`'s line and column (1-based, in characters) of the first `needle`: where an error about
/// the key or value that starts with it points.
fn place_of(text: &str, needle: &str) -> (usize, usize) {
    let offset = text.find(needle).unwrap_or_else(|| panic!("`{needle}` in {text}"));
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or_default().chars().count() + 1;
    (line, column)
}

/// The function of `form` at `parameters`, run on the CPU as a shader computes it (the IR's
/// evaluator, with WGSL's meaning), at `arguments`.
fn run_function(form: &Form, parameters: &[f64], arguments: &[f32]) -> Vec<f32> {
    let m = module(form, parameters).unwrap();
    let machine = crate::shader::eval::Machine::new(&m).unwrap();
    let arguments = arguments.iter().map(|&v| crate::shader::eval::Value::F32(v)).collect();
    let run = machine.call(&form.function_name(), arguments, &crate::shader::eval::NoTexels).unwrap();
    run.value.components().unwrap()
}

#[test]
fn a_function_of_roughness_or_alpha_is_the_form_at_the_alpha_it_converts_to() {
    let parameters = [0.7];
    let cpu = |form: &Form, mu: f32, alpha: f32| {
        FormEvaluator::new(form.tape.clone(), form.variables.clone(), &parameters).channels(&[mu, alpha])
    };
    let views: Vec<f32> = (0..=16).map(|k| k as f32 / 16.0).collect();
    let mut next = uniform(7);
    let roughnesses: Vec<f32> = (0..=16).map(|k| k as f32 / 16.0).chain((0..64).map(|_| next() as f32)).collect();

    // Passed roughness, the form reading alpha too: `alpha` is its square, at the top.
    let declared = format!(
        "{BOTH}[function]\nname = \"EnvBRDFApprox\"\n\
         arguments = [{{ name = \"NoV\", axis = \"mu\" }}, {{ name = \"Roughness\", axis = \"roughness\" }}]\n"
    );
    let form = parse(&declared).unwrap();
    assert_eq!(form.arguments, [ShaderArgument::new("NoV", "mu"), ShaderArgument::new("Roughness", "roughness")]);
    let texts = sources(&form, &parameters).unwrap();
    let wgsl = &texts.wgsl;
    assert!(wgsl.contains("fn EnvBRDFApprox(NoV: f32, Roughness: f32) -> vec2<f32> {\n"), "{wgsl}");
    assert!(wgsl.contains("    let alpha: f32 = Roughness * Roughness;\n"), "{wgsl}");
    assert!(!wgsl.contains("let roughness") && wgsl.contains("p * Roughness"), "{wgsl}");
    assert!(wgsl.contains("// Arguments: NoV is mu, Roughness is sqrt(alpha).\n"), "{wgsl}");
    assert!(texts.glsl.contains("vec2 EnvBRDFApprox(float NoV, float Roughness) {\n"), "{}", texts.glsl);
    crate::shader::validate::glsl(&texts.glsl_harness, naga::ShaderStage::Compute).unwrap();
    for &mu in &views {
        for &r in &roughnesses {
            // The f32 square root of an f32 square is the number squared: the form's own
            // `roughness = sqrt(alpha)` is `r` there, as the function is passed.
            let alpha = r * r;
            assert_eq!(alpha.sqrt(), r);
            assert_eq!(run_function(&form, &parameters, &[mu, r]), cpu(&form, mu, alpha), "mu {mu}, roughness {r}");
        }
    }

    // Passed alpha, the form reading roughness too: `roughness = sqrt(alpha)` at the top.
    let form = parse(&format!(
        "{BOTH}[function]\narguments = [{{ name = \"NoV\", axis = \"mu\" }}, {{ name = \"a\", axis = \"alpha\" }}]\n"
    ))
    .unwrap();
    assert_eq!(form.function_name(), "tmlut_test_form");
    let wgsl = module(&form, &parameters).unwrap().print(crate::shader::Lang::Wgsl);
    assert!(
        wgsl.contains("fn tmlut_test_form(NoV: f32, a: f32) -> vec2<f32> {\n    let roughness: f32 = sqrt(a);\n"),
        "{wgsl}"
    );
    for &mu in &views {
        for &a in &roughnesses {
            assert_eq!(run_function(&form, &parameters, &[mu, a]), cpu(&form, mu, a), "mu {mu}, alpha {a}");
        }
    }
}

#[test]
fn without_a_signature_the_function_takes_what_the_table_is_sampled_at() {
    // The Karis table as built: rows spaced evenly in roughness = sqrt(alpha), sampled at
    // (NoV, roughness); spaced in alpha, at (NoV, alpha).
    let axes = |mapping| {
        vec![
            Axis::cell_centred("mu", 0.0, 1.0, 8).unwrap(),
            Axis::cell_centred("alpha", 0.0, 1.0, 8).unwrap().with_mapping(mapping).unwrap(),
        ]
    };
    let channels = || vec![Channel::new("scale", "test"), Channel::new("bias", "test")];
    let perceptual = Table::zeros("karis", axes(crate::table::Mapping::Sqrt), channels()).unwrap();
    let form = Form::parse(Path::new("karis-form.toml"), BOTH, &perceptual).unwrap();
    assert_eq!(form.arguments, [ShaderArgument::new("NoV", "mu"), ShaderArgument::new("roughness", "roughness")]);
    let wgsl = module(&form, &[0.7]).unwrap().print(crate::shader::Lang::Wgsl);
    assert!(wgsl.contains("fn tmlut_karis_form(NoV: f32, roughness: f32) -> vec2<f32> {\n"), "{wgsl}");
    assert!(wgsl.contains("let alpha: f32 = roughness * roughness;") && !wgsl.contains("let roughness"), "{wgsl}");
    let linear = Table::zeros("karis", axes(crate::table::Mapping::Identity), channels()).unwrap();
    let form = Form::parse(Path::new("karis-form.toml"), BOTH, &linear).unwrap();
    assert_eq!(form.arguments, [ShaderArgument::new("NoV", "mu"), ShaderArgument::new("alpha", "alpha")]);
    // A table read through a lookup of its variables (GD here) keeps them, named as they are.
    let gd = Table::zeros("gd", axes(crate::table::Mapping::Sqrt), vec![Channel::new("gd", "test")]).unwrap();
    let text = "table = \"gd\"\n[parameters]\n[channels]\ngd = \"mu * roughness\"\n";
    let form = Form::parse(Path::new("gd-form.toml"), text, &gd).unwrap();
    assert_eq!(form.arguments, [ShaderArgument::new("mu", "mu"), ShaderArgument::new("alpha", "alpha")]);
    // A scene shader calls a form by the lookup's variables whatever it declares.
    let form = parse(&format!("{BOTH}[function]\nname = \"EnvBRDFApprox\"\n")).unwrap();
    let scene = lookup_module(&form, &[0.7]).unwrap().print(crate::shader::Lang::Wgsl);
    let lookup = "fn tmlut_test_form(mu: f32, alpha: f32) -> vec2<f32> {\n    let roughness: f32 = sqrt(alpha);";
    assert!(scene.contains(lookup), "{scene}");
}

#[test]
fn a_signature_s_mistakes_name_the_key_and_what_is_allowed() {
    let refused = |function: &str, needle: &str, says: &str| {
        let text = format!("{BOTH}[function]\n{function}\n");
        let (line, column) = place_of(&text, needle);
        let e = parse(&text).expect_err("refused").to_string();
        let place = format!("forms/test-form.toml:{line}:{column}: ");
        assert!(e.starts_with(&place) && e.contains(says), "expected {place}... {says}, got: {e}");
    };
    let args = |list: &str| format!("arguments = [{list}]");
    let (nov, r) = (r#"{ name = "NoV", axis = "mu" }"#, r#"{ name = "r", axis = "roughness" }"#);
    let bad_names =
        ["2x", "float", "gl_x", "x__y"].map(|bad| (format!(r#"{{ name = "{bad}", axis = "mu" }}, {r}"#), bad));
    let bad_names =
        bad_names.iter().map(|(list, bad)| (list.clone(), format!("\"{bad}\""), "`name` of [function] argument 1: "));
    let cases = [
        (
            format!(r#"{nov}, {{ name = "r", axis = "rough" }}"#),
            r#""rough""#.to_string(),
            "`axis` of [function] argument 2: unknown axis `rough`; allowed for table `karis`: mu, alpha, roughness",
        ),
        (
            format!(r#"{nov}, {{ name = "NoV", axis = "roughness" }}"#),
            r#""NoV", axis = "roughness""#.to_string(),
            "`name` of [function] argument 2: `NoV` names argument 1 too",
        ),
        (
            nov.to_string(),
            "[{".to_string(),
            "no argument carries `alpha`; every variable of table `karis` needs one: mu, alpha (alpha may be passed as \
             roughness)",
        ),
        (r.to_string(), "[{".to_string(), "no argument carries `mu`"),
        (
            format!(r#"{nov}, {{ name = "a", axis = "alpha" }}, {r}"#),
            r#""roughness" }]"#.to_string(),
            "`axis` of [function] argument 3: `roughness` is what argument 2 (`a`) carries as `alpha`",
        ),
        (
            format!(r#"{{ name = "p", axis = "mu" }}, {r}"#),
            r#""p""#.to_string(),
            "`name` of [function] argument 1: `p` is a variable, parameter or binding of the form",
        ),
        (
            format!(r#"{{ name = "alpha", axis = "mu" }}, {r}"#),
            r#""alpha""#.to_string(),
            "named after its own axis (`mu`)",
        ),
    ];
    for (list, needle, says) in cases.into_iter().chain(bad_names) {
        refused(&args(&list), &needle, says);
    }
    refused("name = \"main\"", "\"main\"", "`name` of [function]: `main` is reserved");
    refused("name = \"p\"", "\"p\"", "`name` of [function]: `p` is already a variable, parameter, binding or argument");
    refused("name = \"f\"\nargs = []", "args", "unknown field `args`");
    refused(&args(r#"{ name = "NoV", axis = "mu", type = "f32" }"#), "type", "unknown field `type`");
}

/// A form that calls every function of the language and every operator.
const ALL_FUNCTIONS: &str = r#"table = "karis"
[parameters]
a = { start = 0.3, min = -2.0, max = 2.0 }
b = { start = 0.7, min = -2.0, max = 2.0 }
c = { start = 1.3, min = -2.0, max = 2.0 }
[let]
u = "a * mu + b * alpha + 0.2"
w = "abs(u - c) + sign(c) * floor(c) + fract(c * 3.7) + sqrt(u * u + 1) + rsqrt(c + 2) + exp(a) + exp2(b) + log(c + 3) + log2(c + 3) + pow(c + 2, a) + (c + 2) ^ b + u ^ 3 + u ^ -2"
z = "sin(a) + cos(b) + tan(u) + asin(u / 3) + acos(b / 3) + atan(c) + atan2(a, c) + sinh(u) + cosh(b) + tanh(c) + asinh(u - 1)"
y = "min(a, b) + max(u, c) + clamp(u, b, c) + saturate(u) + smoothstep(b, c + 1, u) + step(b, u) + mix(a, c, u) + select(a, b * c, u < 0.5)"
[channels]
scale = "w * z"
bias = "y - w / (z * z + 1)"
"#;

#[test]
fn the_gradient_is_the_finite_difference_of_the_value_for_every_function() {
    let table = karis_like(4, |_, _| [0.0, 0.0]);
    let text = ALL_FUNCTIONS;
    let form = Form::parse(Path::new("all.toml"), text, &table).unwrap();
    let mut work = crate::ir::tape::EvaluationBuffers::default();
    let mut scratch = Vec::new();
    for (point, params) in
        [([0.3, 0.6], [0.3, 0.7, 1.3]), ([0.9, 0.1], [-0.4, 0.2, 0.6]), ([0.5, 0.5], [1.1, -0.3, 1.7])]
    {
        for channel in 0..2 {
            let mut seeds = [0.0; 2];
            seeds[channel] = 1.0;
            let mut gradient = [0.0; 3];
            form.tape.forward(&point, &params, &mut work);
            form.tape.backward(&mut work, &seeds, &mut gradient);
            for k in 0..3 {
                let h = 1e-6;
                let mut value = |delta: f64| {
                    let mut p = params;
                    p[k] += delta;
                    let mut out = [0.0; 2];
                    form.tape.eval(&point, &p, &mut scratch, &mut out);
                    out[channel]
                };
                let numeric = (value(h) - value(-h)) / (2.0 * h);
                assert!(
                    (numeric - gradient[k]).abs() <= 1e-5 * (1.0 + numeric.abs()),
                    "channel {channel} parameter {k} at {point:?} {params:?}: exact {} numeric {numeric}",
                    gradient[k]
                );
            }
        }
    }
    // Every language: the WGSL and the GLSL (in its harness) validate with naga, MSL is naga's.
    let texts = sources(&form, &[0.3, 0.7, 1.3]).unwrap();
    assert!(texts.wgsl.contains("fn tmlut_asinh") && texts.wgsl.contains("fn tmlut_pow_m2"), "{}", texts.wgsl);
    assert!(
        texts.hlsl.contains("frac(") && texts.hlsl.contains("lerp(") && texts.hlsl.contains("rsqrt("),
        "{}",
        texts.hlsl
    );
    // The GLSL is the functions alone, named as the form names them (the table's default
    // arguments: `karis_like`'s alpha axis is spaced in alpha), in GLSL's own spellings.
    let glsl = &texts.glsl;
    assert!(glsl.contains("vec2 tmlut_all(float NoV, float alpha) {"), "{glsl}");
    assert!(
        glsl.contains("inversesqrt(") && glsl.contains("clamp(u, 0.0, 1.0)") && glsl.contains("atan(a, c)"),
        "{glsl}"
    );
    assert!(!glsl.contains("#version") && !glsl.contains("main"), "{glsl}");
    let harness = &texts.glsl_harness;
    assert!(harness.starts_with("#version 450\n") && harness.contains(glsl.as_str()), "{harness}");
    assert!(harness.contains("void main() {\n    vec2 value = tmlut_all(0.5, 0.5);\n}"), "{harness}");
    assert!(texts.msl.contains("tmlut_all("), "{}", texts.msl);
    crate::shader::validate::wgsl(&texts.wgsl).unwrap();
    crate::shader::validate::glsl(harness, naga::ShaderStage::Compute).unwrap();
}

#[test]
fn a_builtin_of_literals_alone_prints_as_wgsl_naga_accepts() {
    // WGSL types `mix(3.0, 4.0, 0.5)` as an abstract float, which naga refuses outside a constant
    // expression: the printer makes the first argument an f32.
    let table = karis_like(4, |_, _| [0.0, 0.0]);
    let text = "table = \"karis\"\n[parameters]\na = { start = 0.1, min = -4.0, max = 4.0 }\n[channels]\n\
                scale = \"a + mix(3, 4, 0.5) + pow(2, 0.5) + atan2(1, 2 ^ 3)\"\nbias = \"a * max(1, min(2, 3))\"\n";
    let form = Form::parse(Path::new("literals.toml"), text, &table).unwrap();
    let texts = sources(&form, &[0.1]).unwrap();
    assert!(texts.wgsl.contains("mix(f32(3.0), 4.0, 0.5)"), "{}", texts.wgsl);
    crate::shader::validate::wgsl(&texts.wgsl).unwrap();
}

#[test]
fn the_mean_squared_residual_s_gradient_matches_finite_differences() {
    let form = parse(GOOD).unwrap();
    let data = FormData::from_table(&table(), &form).unwrap();
    let prepared = SearchData::new(&form, &data);
    let objective = |p: &[f64], g: Option<&mut [f64]>| prepared.objective(p, g);
    let p = [0.3, 2.5];
    let mut g = [0.0; 2];
    let f0 = objective(&p, Some(&mut g));
    assert_eq!(f0, objective(&p, None));
    // The split tape computes what the whole one does, to the bit.
    let mut direct = 0.0;
    let (mut scratch, mut out) = (Vec::new(), [0.0; 2]);
    for n in 0..data.len() {
        form.tape.eval(&data.coordinates[2 * n..2 * n + 2], &p, &mut scratch, &mut out);
        for (v, t) in out.iter().zip(&data.values[2 * n..2 * n + 2]) {
            direct += (v - t) * (v - t);
        }
    }
    assert_eq!(f0, direct / (2 * data.len()) as f64);
    for k in 0..2 {
        let h = 1e-6;
        let (mut up, mut down) = (p, p);
        up[k] += h;
        down[k] -= h;
        let numeric = (objective(&up, None) - objective(&down, None)) / (2.0 * h);
        assert!((numeric - g[k]).abs() < 1e-6 * (1.0 + numeric.abs()), "{k}: {numeric} against {}", g[k]);
    }
}

#[test]
fn a_fit_recovers_the_parameters_the_table_was_made_with_and_reports_redundancy() {
    let form = parse(GOOD).unwrap();
    let data = FormData::from_table(&table(), &form).unwrap();
    let settings = FitSettings { starts: 3, ..FitSettings::default() };
    let fitted = fit(&form, &SearchData::new(&form, &data), &settings).unwrap();
    assert!(
        (fitted.parameters[0] - 0.5).abs() < 1e-3 && (fitted.parameters[1] - 5.0).abs() < 1e-2,
        "{:?}",
        fitted.parameters
    );
    let f = figures(&form, &data, &fitted.parameters).unwrap();
    assert!(f.together.rms < 1e-5 && f.channels["bias"].max < 1e-5, "{f:?}");
    assert!(identifiability(&form, &SearchData::new(&form, &data), &fitted.parameters).ill_determined.is_empty());
    // The same seed gives the same bits, whatever the number of threads.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let again = one.install(|| fit(&form, &SearchData::new(&form, &data), &settings).unwrap());
    assert_eq!(again.parameters, fitted.parameters);
    // Two parameters that only enter as a sum are one direction of no information.
    let redundant = GOOD
        .replace("1 - p * roughness * mu", "1 - (p + r) * roughness * mu")
        .replace("[let]", "r = { start = 0.0, min = -1.0, max = 1.0 }\n[let]");
    let form = parse(&redundant).unwrap();
    let prepared = SearchData::new(&form, &data);
    let fitted = fit(&form, &prepared, &settings).unwrap();
    let id = identifiability(&form, &prepared, &fitted.parameters);
    assert_eq!(id.ill_determined.len(), 1, "{id:?}");
    assert_eq!(id.ill_determined[0].parameters, ["p", "r"]);
    assert_eq!(id.ill_determined_parameters, ["p", "r"]);
}

#[test]
fn tables_with_a_derived_axis_are_fitted_on_a_uniform_grid_of_the_lookup_variables() {
    let axes = vec![
        Axis::node_aligned("mu", 0.0, 1.0, 5).unwrap(),
        Axis::node_aligned("alpha", 0.0, 1.0, 5).unwrap(),
        Axis::node_aligned(crate::table::derived::CRITICAL_ANGLE_OFFSET, -1.6, 1.6, 9).unwrap(),
    ];
    let mut tir = Table::zeros("tir", axes, vec![Channel::new("tir", "test")]).unwrap();
    for node in 0..tir.node_count() {
        let p = tir.node_position(&tir.node_index(node));
        tir.data[node] = (0.5 - 0.25 * p[2]) as f32;
    }
    let text = "table = \"tir\"\n[parameters]\nk = { start = 0.1, min = -1.0, max = 1.0 }\n[channels]\ntir = \"0.5 - k * critical_angle_offset\"\n";
    let form = Form::parse(Path::new("tir-line.toml"), text, &tir).unwrap();
    assert_eq!(form.variables, ["mu", "alpha", "eta"]);
    let data = FormData::from_table(&tir, &form).unwrap();
    assert_eq!(data.len(), crate::fit::FIT_GRID_NODES.pow(3));
    let fitted =
        fit(&form, &SearchData::new(&form, &data), &FitSettings { starts: 1, ..FitSettings::default() }).unwrap();
    assert!((fitted.parameters[0] - 0.25).abs() < 1e-4, "{:?}", fitted.parameters);
    let wgsl = module(&form, &fitted.parameters).unwrap().print(crate::shader::Lang::Wgsl);
    assert!(wgsl.contains("fn tmlut_tir_line(mu: f32, alpha: f32, eta: f32) -> f32"), "{wgsl}");
    crate::shader::validate::wgsl(&wgsl).unwrap();
}

/// The TIR form files of `luts/forms/` (`tir-*.toml`), in name order: a form added there is
/// tested with no list to update.
fn tir_form_files() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms");
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("tir-") && n.ends_with(".toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 8, "{files:?}");
    files
}

fn read_form_file(file: &str, table: &Table) -> Form {
    Form::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms").join(file), table).unwrap()
}

/// Numbers uniform in [0, 1) from a 64-bit linear congruential stream started at `state`.
fn uniform(mut state: u64) -> impl FnMut() -> f64 {
    move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A TIR-shaped table on a uniform `(mu, alpha, eta)` grid: `tir-cauchy-slope.toml` at the
/// coefficients docs/fit.md reports for the TIR table.
fn tir_shaped(nodes: usize) -> Table {
    let axes = ["mu", "alpha", "eta"].map(|a| Axis::node_aligned(a, 0.0, 1.0, nodes).unwrap()).to_vec();
    let mut tir = Table::zeros("tir", axes, vec![Channel::new("tir", "test")]).unwrap();
    let form = read_form_file("tir-cauchy-slope.toml", &tir);
    let c = [1.3606, -0.0525, -0.4440, 0.7608, -0.6821, 0.8040, 0.6046, 0.4777, 0.5700, 15.8816];
    let (mut scratch, mut out) = (Vec::new(), [0.0]);
    for node in 0..tir.node_count() {
        let p = tir.node_position(&tir.node_index(node));
        form.tape.eval(&p, &c, &mut scratch, &mut out);
        tir.data[node] = out[0] as f32;
    }
    tir
}

/// Every TIR form file of `luts/forms/` reads, is finite at the domain's corners at its start, and
/// fitted to a TIR-shaped table from two starts ends no worse than it started (the baselines,
/// with no parameter, at their definition); the build's form recovers the table it made to 1e-3.
#[test]
fn every_tir_form_file_fits_a_tir_shaped_table() {
    let tir = tir_shaped(12);
    let settings = FitSettings { starts: 2, ..FitSettings::default() };
    for file in tir_form_files() {
        let form = read_form_file(&file, &tir);
        let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
        let (mut scratch, mut out) = (Vec::new(), [0.0]);
        for corner in [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, 0.0]] {
            form.tape.eval(&corner, &start, &mut scratch, &mut out);
            assert!(out[0].is_finite(), "{file} at {corner:?}: {}", out[0]);
        }
        let data = FormData::from_table(&tir, &form).unwrap();
        let fitted = fit(&form, &SearchData::new(&form, &data), &settings).unwrap();
        assert_eq!(fitted.search.is_none(), form.parameters.is_empty(), "{file}");
        let (at_start, at_end) = (
            figures(&form, &data, &start).unwrap().together.rms,
            figures(&form, &data, &fitted.parameters).unwrap().together.rms,
        );
        assert!(at_end.is_finite() && at_end <= at_start * (1.0 + 1e-6), "{file}: {at_start} to {at_end}");
        if file == "tir-cauchy-slope.toml" {
            assert!(at_end < 1e-3, "{file}: {at_end}");
        }
    }
}

/// A parameter read only by a `select`'s condition is used, and the split tape keeps the
/// condition's dependence on it.
#[test]
fn a_parameter_in_a_select_condition_is_used_and_kept_by_the_split() {
    let text = "table = \"karis\"\n[parameters]\nk = { start = 0.5, min = 0.0, max = 1.0 }\n[channels]\nscale = \"select(0.0, 1.0, mu < k)\"\nbias = \"mu * mu\"\n";
    let form = parse(text).unwrap();
    let data = FormData::from_table(&table(), &form).unwrap();
    let prepared = SearchData::new(&form, &data);
    // Where the step sits changes the objective: the condition was not split off as a constant.
    assert_ne!(prepared.objective(&[0.2], None), prepared.objective(&[0.8], None));
}

/// The evaluation over rows of points ([`batch::Batch`]) computes the same values and gradients,
/// to the bit, as the tape point by point, for a form calling every function and for each TIR
/// form file, at random points (some outside the tables' ranges, where clamps and selects take
/// their other side) and random parameters, over full rows and a partial one.
#[test]
fn the_batch_evaluation_is_the_point_by_point_one_to_the_bit() {
    let mut unit = uniform(11);
    let karis = karis_like(4, |_, _| [0.0, 0.0]);
    let tir = tir_shaped(4);
    let mut forms = vec![Form::parse(Path::new("all.toml"), ALL_FUNCTIONS, &karis).unwrap()];
    for file in tir_form_files() {
        forms.push(read_form_file(&file, &tir));
    }
    let count = 2 * batch::LANES + 44;
    for form in &forms {
        let (d, channels, p) = (form.variables.len(), form.tape.outputs.len(), form.parameters.len());
        let columns: Vec<Vec<f64>> = (0..d).map(|_| (0..count).map(|_| 1.4 * unit() - 0.2).collect()).collect();
        let params: Vec<f64> = form.parameters.iter().map(|q| q.min + unit() * (q.max - q.min)).collect();
        let seeds: Vec<Vec<f64>> = (0..count).map(|_| (0..channels).map(|_| unit() - 0.5).collect()).collect();
        let (mut work, mut expected) = (crate::ir::tape::EvaluationBuffers::default(), vec![0.0; p]);
        let (mut batch, mut gradient) = (batch::Batch::default(), vec![0.0; p]);
        for first in (0..count).step_by(batch::LANES) {
            let len = batch::LANES.min(count - first);
            batch.forward(&form.tape, |k| &columns[k][first..], &params, len);
            batch.clear_adjoints(&form.tape);
            for l in 0..len {
                let point: Vec<f64> = columns.iter().map(|c| c[first + l]).collect();
                form.tape.forward(&point, &params, &mut work);
                for k in 0..form.tape.ins.len() {
                    let (a, b) = (work.value(k), batch.value(k, l));
                    assert!(a.to_bits() == b.to_bits(), "{}: instruction {k} at {point:?}: {a} against {b}", form.name);
                }
                for (&k, &s) in form.tape.outputs.iter().zip(&seeds[first + l]) {
                    batch.seed(k, l, s);
                }
                form.tape.backward(&mut work, &seeds[first + l], &mut expected);
            }
            batch.backward(&form.tape, &mut gradient);
            let bits = |g: &[f64]| g.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&gradient), bits(&expected), "{}: {gradient:?} against {expected:?}", form.name);
        }
        assert!(p == 0 || expected.iter().any(|g| *g != 0.0), "{}: the gradient is not all 0", form.name);
    }
}

#[test]
fn the_histogram_counts_every_residual_once() {
    use super::pictures::histogram;
    let mut next = uniform(7);
    let spread: Vec<f64> = (0..10_000).map(|_| (next() - 0.5).powi(3)).collect();
    for (values, bins) in [
        (spread.clone(), 80),
        (spread, 1),
        (vec![0.25; 17], 80),
        (vec![-3.0, 0.0, 5.0], 4),
        (vec![1e-9], 10),
        (Vec::new(), 80),
    ] {
        let ((lo, hi), counts) = histogram(&values, bins);
        assert_eq!(counts.len(), bins);
        assert_eq!(counts.iter().sum::<usize>(), values.len(), "{bins} bins");
        assert!(lo < hi && values.iter().all(|v| (lo..=hi).contains(v)));
    }
    // The ends land in the first and last bins.
    let (_, counts) = histogram(&[-3.0, 0.0, 5.0], 4);
    assert_eq!(counts, [1, 1, 0, 1]);
}

/// Fits from `starts` starts over the whole table, uniform weights, untimed, uncertified.
fn whole_table_options(table: std::path::PathBuf, starts: usize) -> FitOptions {
    FitOptions {
        table,
        settings: FitSettings { starts, ..FitSettings::default() },
        certify: None,
        ranges: Vec::new(),
        weights: WeightsSpec::Uniform,
        scene: None,
        timing_runs: 0,
    }
}

/// GOOD written into `dir`, fitted from 2 starts into `dir/out`, over the whole table, untimed.
fn good_request(dir: &Path) -> FormFitRequest {
    let form = dir.join("form.toml");
    std::fs::write(&form, GOOD).unwrap();
    FormFitRequest { form, out: dir.join("out"), options: whole_table_options(dir.join("karis.dds"), 2) }
}

#[test]
fn a_fit_writes_the_error_map_and_the_residual_histogram_in_its_set() {
    let dir = tempfile::tempdir().unwrap();
    let table = table();
    let request = good_request(dir.path());
    let report = fit_form_file(&table, &request).unwrap();
    for file in [pictures::ERROR_MAP_FILE, pictures::RESIDUALS_FILE] {
        assert!(report.files.iter().any(|f| f == file), "{:?}", report.files);
        let image = image::open(request.out.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(image.width() >= 400 && image.height() >= 300, "{file}: {:?}", (image.width(), image.height()));
        assert!(image.width() <= 4000 && image.height() <= 4000, "{file}");
        let colours: std::collections::HashSet<[u8; 3]> = image.to_rgb8().pixels().map(|p| p.0).collect();
        assert!(colours.len() > 10, "{file}: {} colours", colours.len());
    }
    let markdown = std::fs::read_to_string(request.out.join("report.md")).unwrap();
    assert!(markdown.contains("(error_map.png)") && markdown.contains("(residuals.png)"), "{markdown}");
    // Nothing staged is left behind: the folder holds exactly the set (and no staging folder).
    let mut listed: Vec<String> = std::fs::read_dir(&request.out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| !f.starts_with('.'))
        .collect();
    listed.sort();
    let mut files = report.files.clone();
    files.sort();
    assert_eq!(listed, files);
}

#[test]
fn the_error_map_is_the_largest_error_at_each_node_of_the_first_two_axes() {
    let table = table();
    let form = parse(GOOD).unwrap();
    let data = FormData::from_table(&table, &form).unwrap();
    assert!(data.on_table_nodes);
    let residuals = super::figures::residuals(&form, &data, &[0.5, 1.0]).unwrap();
    let panel = pictures::error_panel(&table, &data, &residuals, 1);
    assert_eq!((panel.nx, panel.ny), (8, 8));
    for n in 0..data.len() {
        let index = table.node_index(n);
        assert_eq!(panel.values[index[0] + 8 * index[1]], residuals[2 * n + 1].abs());
    }
    assert!(panel.x.0.starts_with("mu") && panel.y.0.starts_with("alpha"), "{:?}", (&panel.x, &panel.y));
    // With a range, the nodes outside it have no value (not an exact 0).
    let region = region(&["mu=0:0.5"], WeightsSpec::Uniform, &table, &form).unwrap();
    let kept = FormData::from_table_in(&table, &form, &region).unwrap();
    let residuals = super::figures::residuals(&form, &kept, &[0.5, 1.0]).unwrap();
    let panel = pictures::error_panel(&table, &kept, &residuals, 1);
    for j in 0..8 {
        for i in 0..8 {
            let mu = table.axes[0].node_value(i);
            let value = panel.values[i + 8 * j];
            assert_eq!(value.is_nan(), mu > 0.5, "mu {mu}: {value}");
        }
    }
}

/// One constant per channel, for fits whose optimum is a (weighted) mean.
const CONSTANT: &str = r#"table = "karis"
[parameters]
s = { start = 0.5, min = -2.0, max = 2.0 }
b = { start = 0.0, min = -2.0, max = 2.0 }
[channels]
scale = "s + 0 * mu"
bias = "b"
"#;

fn region(ranges: &[&str], weights: WeightsSpec, table: &Table, form: &Form) -> crate::error::Result<Region> {
    let ranges: Vec<Range> = ranges.iter().map(|r| Range::parse(r).unwrap()).collect();
    Region::new(&ranges, &weights, None, table, &form.variables)
}

#[test]
fn a_range_keeps_only_its_points_and_fits_the_form_where_it_holds() {
    // GOOD's table below mu = 0.5; above it, scale departs from the form.
    let exact = table();
    let bent = karis_like(9, |mu, alpha| {
        [1.0 - 0.5 * alpha.sqrt() * mu + 0.3 * (mu - 0.5).max(0.0), 0.1 * (1.0 - mu).powi(5)]
    });
    let form = parse(GOOD).unwrap();
    let settings = FitSettings { starts: 3, ..FitSettings::default() };
    let rms = |ranges: &[&str]| {
        let region = region(ranges, WeightsSpec::Uniform, &bent, &form).unwrap();
        let data = FormData::from_table_in(&bent, &form, &region).unwrap();
        let fitted = fit(&form, &SearchData::new(&form, &data), &settings).unwrap();
        let rms = figures(&form, &data, &fitted.parameters).unwrap().together.rms;
        (data, rms, fitted.parameters)
    };
    let (all, rms_all, _) = rms(&[]);
    let (lower, rms_lower, parameters) = rms(&["mu=0:0.5"]);
    assert_eq!(all.len(), 81);
    // Nodes at mu = k / 8: k = 0..=4 of 9, every alpha.
    assert_eq!(lower.len(), 45);
    assert!(lower.index.iter().all(|&n| n % 9 <= 4), "{:?}", lower.index);
    assert!(rms_all > 1e-2 && rms_lower < 1e-5, "{rms_all} {rms_lower}");
    assert!((parameters[0] - 0.5).abs() < 1e-3 && (parameters[1] - 5.0).abs() < 1e-2, "{parameters:?}");
    // roughness = sqrt(alpha): alpha in [0, 0.25] keeps the nodes alpha = 0 and 1/7 of 8.
    let region = region(&["roughness=0:0.5"], WeightsSpec::Uniform, &exact, &form).unwrap();
    let data = FormData::from_table_in(&exact, &form, &region).unwrap();
    assert_eq!(data.len(), 8 * 2);
    assert!(data.coordinates.chunks(2).all(|p| p[1] <= 0.25));
}

#[test]
fn cosine_weights_pull_a_constant_toward_the_views_near_the_normal() {
    // scale = mu^2 at mu = k / 8: a constant fitted to it is its mean, uniform (204 / 576) or
    // weighted by mu (sum mu^3 / sum mu = 0.5625).
    let table = karis_like(9, |mu, _| [mu * mu, 0.0]);
    let form = parse(CONSTANT).unwrap();
    let settings = FitSettings { starts: 2, ..FitSettings::default() };
    let fitted = |weights: WeightsSpec| {
        let region = region(&[], weights, &table, &form).unwrap();
        let data = FormData::from_table_in(&table, &form, &region).unwrap();
        let prepared = SearchData::new(&form, &data);
        let fitted = fit(&form, &prepared, &settings).unwrap().parameters;
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert_eq!(one.install(|| fit(&form, &prepared, &settings).unwrap().parameters), fitted);
        fitted[0]
    };
    let (uniform, cosine) = (fitted(WeightsSpec::Uniform), fitted(WeightsSpec::Cosine));
    assert!((uniform - 204.0 / 576.0).abs() < 1e-6, "{uniform}");
    assert!((cosine - 0.5625).abs() < 1e-6, "{cosine}");
}

#[test]
fn a_bad_range_or_weighting_is_refused_naming_what_is_allowed() {
    let e = Range::parse("mu=0.5:0.2").unwrap_err().to_string();
    assert!(e.contains("LO 0.5 must be below HI 0.2"), "{e}");
    let e = Range::parse("mu0.2:1").unwrap_err().to_string();
    assert!(e.contains("expected VAR=LO:HI"), "{e}");
    let (table, form) = (table(), parse(GOOD).unwrap());
    let e = region(&["rougness=0:0.5"], WeightsSpec::Uniform, &table, &form).unwrap_err().to_string();
    assert!(e.contains("unknown variable `rougness`; allowed for table `karis`: mu, alpha, roughness"), "{e}");
    let e = region(&["mu=0.5:1.5"], WeightsSpec::Uniform, &table, &form).unwrap_err().to_string();
    assert!(e.contains("outside the table's range [0, 1] of mu"), "{e}");
    let e = region(&["mu=0:0.5", "mu=0.6:1"], WeightsSpec::Uniform, &table, &form).unwrap_err().to_string();
    assert!(e.contains("`mu` given twice"), "{e}");
    let e = WeightsSpec::parse("cosin").unwrap_err().to_string();
    assert!(e.contains("allowed: uniform, cosine, or a scene file SCENE.toml"), "{e}");
    // A range between the nodes holds no point.
    let region = region(&["mu=0.01:0.02"], WeightsSpec::Uniform, &table, &form).unwrap();
    let e = FormData::from_table_in(&table, &form, &region).unwrap_err().to_string();
    assert!(e.contains("no point of the data"), "{e}");
}

#[test]
fn the_report_records_the_region_the_weights_and_the_cost() {
    let dir = tempfile::tempdir().unwrap();
    let mut request = good_request(dir.path());
    request.options.ranges = vec![Range::parse("mu=0:0.5").unwrap()];
    request.options.weights = WeightsSpec::Cosine;
    request.options.timing_runs = 3;
    // A table the form does not fit, so that weighting changes the figures.
    let report = fit_form_file(&karis_like(8, |mu, alpha| [mu * mu, 0.2 * alpha]), &request).unwrap();
    assert_eq!(report.ranges, request.options.ranges);
    assert_eq!(report.points, 8 * 4);
    let weighted = report.weighted_figures.as_ref().expect("weighted figures");
    assert_ne!(weighted.together.rms, report.figures.together.rms);
    // scale: sqrt (roughness), two products and a difference; bias: 1 - mu, a product and a
    // power with a parameter for exponent.
    let cost = report.cost.as_ref().unwrap();
    assert_eq!(cost.operations, cost::Operations { arithmetic: 5, transcendental: 2, select: 0 });
    // Timed (the values are not asserted: they depend on the machine).
    let timing = cost.timing.as_ref().unwrap();
    assert_eq!((timing.runs, timing.batch), (3, 32));
    let text = markdown::markdown(&report);
    assert!(text.contains("Region: mu in [0, 0.5]; weights: cosine"), "{text}");
    assert!(text.contains("| together, weighted |") && text.contains("Cost: 5 arithmetic"), "{text}");
    let json: FormReport =
        serde_json::from_str(&std::fs::read_to_string(request.out.join(fitting::FIT_FILE)).unwrap()).unwrap();
    assert_eq!(json.weights, WeightsSpec::Cosine);
}

#[test]
fn the_timed_lookup_reads_the_table_as_its_interpolation_does() {
    let table = table();
    let texture = cost::TableTexture::new(&table, &["mu".to_string(), "alpha".to_string()]).unwrap();
    let mut next = uniform(7);
    let mut read = [0.0f32; 2];
    for _ in 0..500 {
        let (mu, alpha) = (next(), next());
        texture.sample(&[mu as f32, alpha as f32], &mut read);
        let exact = table.interpolate(&[mu, alpha]);
        for c in 0..2 {
            assert!((f64::from(read[c]) - exact[c]).abs() < 1e-5, "{mu} {alpha} {c}: {} {}", read[c], exact[c]);
        }
    }
}

/// `tmlut fit --form DIR`: every form file given is fitted into its own folder, and `forms.json`
/// ranks them by max error, then RMS; a form without parameters is measured, not searched.
#[test]
fn a_folder_of_forms_is_fitted_form_by_form_and_ranked_by_max_error() {
    let dir = tempfile::tempdir().unwrap();
    let table = table();
    let fixed = "table = \"karis\"\n[parameters]\n[channels]\nscale = \"1 - 0.4 * roughness * mu\"\nbias = \"0.0\"\n";
    let files = [("good.toml", GOOD), ("fixed.toml", fixed)].map(|(name, text)| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    });
    let request = folder_request(dir.path(), files.to_vec());
    let out = request.out.clone();
    let ranking = fitting::fit_form_files(&table, &request).unwrap();
    let names: Vec<&str> = ranking.forms.iter().map(|f| f.form.as_str()).collect();
    assert_eq!(names, ["good", "fixed"], "the fitted form has the lower max error");
    assert!(ranking.forms[0].figures.max <= ranking.forms[1].figures.max);
    assert_eq!(ranking.forms[1].parameters, 0);
    assert!(ranking.ranges.is_empty() && ranking.weights == WeightsSpec::Uniform);
    assert!(ranking.forms.iter().all(|f| f.weighted_figures.is_none() && f.cost.as_ref().unwrap().timing.is_none()));
    for form in &ranking.forms {
        let report: FormReport =
            serde_json::from_slice(&std::fs::read(out.join(&form.folder).join(fitting::FIT_FILE)).unwrap()).unwrap();
        assert_eq!(report.figures.together, form.figures);
        assert_eq!(report.search.is_none(), form.parameters == 0);
    }
    let written: fitting::FolderFits =
        serde_json::from_slice(&std::fs::read(out.join(fitting::FORMS_FILE)).unwrap()).unwrap();
    assert_eq!(written, ranking);
}

/// A folder request for the forms `files` into `dir/out`: one start, whole table, uniform
/// weights, no timing.
fn folder_request(dir: &Path, files: Vec<std::path::PathBuf>) -> FolderFitRequest {
    FolderFitRequest { files, out: dir.join("out"), options: whole_table_options("karis.dds".into(), 1) }
}

/// `--form DIR` with `--range`, `--weights` and `--timing-runs`: every form of the folder is
/// fitted over the region with the weights and timed, its report records them, and the ranking
/// reads the weighted figures.
#[test]
fn a_folder_of_forms_is_fitted_over_a_region_with_weights_and_timed() {
    let dir = tempfile::tempdir().unwrap();
    // A table neither form fits, so that the weights change the figures.
    let table = karis_like(8, |mu, alpha| [mu * mu, 0.2 * alpha]);
    let files = [("good.toml", GOOD), ("constant.toml", CONSTANT)].map(|(name, text)| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    });
    let mut request = folder_request(dir.path(), files.to_vec());
    request.options.ranges = vec![Range::parse("mu=0:0.5").unwrap()];
    request.options.weights = WeightsSpec::Cosine;
    request.options.timing_runs = 2;
    let ranking = fitting::fit_form_files(&table, &request).unwrap();
    assert_eq!(
        (&ranking.ranges, &ranking.weights, ranking.timing_runs),
        (&request.options.ranges, &request.options.weights, 2)
    );
    assert!(ranking.rule.contains("weighted"), "{}", ranking.rule);
    let weighted: Vec<&figures::ErrorFigures> = ranking.forms.iter().map(|f| f.ranked_by()).collect();
    assert!(weighted[0].max <= weighted[1].max, "{weighted:?}");
    for form in &ranking.forms {
        let report: FormReport =
            serde_json::from_slice(&std::fs::read(request.out.join(&form.folder).join(fitting::FIT_FILE)).unwrap())
                .unwrap();
        assert_eq!((&report.ranges, &report.weights), (&request.options.ranges, &request.options.weights));
        assert_eq!(report.points, 8 * 4);
        assert_eq!(report.weighted_figures.as_ref().map(|w| &w.together), form.weighted_figures.as_ref());
        assert_eq!(report.cost, form.cost);
        assert_eq!(report.cost.as_ref().and_then(|c| c.timing.as_ref()).map(|t| t.runs), Some(2));
    }
    let text = markdown::ranking_markdown(&ranking);
    assert!(text.contains("Region: mu in [0, 0.5]; weights: cosine"), "{text}");
    assert!(text.contains("weighted RMS") && text.contains("ns, form / lookup"), "{text}");
}

#[test]
fn every_channel_evaluates_in_f32_as_the_shader_orders_it_and_in_f64() {
    let form = parse(GOOD).unwrap();
    let evaluator = FormEvaluator::new(form.tape.clone(), form.variables.clone(), &[0.5, 2.0]);
    let (mu, alpha) = (0.3f32, 0.7f32);
    let in_f32 = evaluator.channels(&[mu, alpha]);
    assert_eq!(in_f32, vec![1.0 - 0.5 * alpha.sqrt() * mu, 0.1 * (1.0 - mu).powf(2.0)]);
    let (mu, alpha) = (f64::from(mu), f64::from(alpha));
    let in_f64 = evaluator.channels(&[mu, alpha]);
    assert_eq!(in_f64, vec![1.0 - 0.5 * alpha.sqrt() * mu, 0.1 * (1.0 - mu).powf(2.0)]);
    assert_eq!((evaluator.eval(&[mu, alpha]), evaluator.eval_f64(&[mu, alpha])), (f64::from(in_f32[0]), in_f64[0]));
}

#[test]
fn a_region_s_extent_is_the_table_s_ranges_narrowed_by_its_own() {
    let (exact, form) = (table(), parse(GOOD).unwrap());
    let extent =
        |ranges: &[&str]| region(ranges, WeightsSpec::Uniform, &exact, &form).unwrap().extent(&exact, &form.variables);
    assert_eq!(form.variables, ["mu", "alpha"]);
    assert_eq!(extent(&[]), [(0.0, 1.0), (0.0, 1.0)]);
    // roughness = sqrt(alpha): its range bounds alpha by the squares.
    assert_eq!(extent(&["mu=0.25:1", "roughness=0.5:0.75"]), [(0.25, 1.0), (0.25, 0.5625)]);
}

#[test]
fn two_form_files_of_one_form_name_are_refused_before_either_is_fitted() {
    use std::path::PathBuf;
    let names = super::form::distinct_form_names(&[PathBuf::from("d/a-b.toml"), PathBuf::from("d/c.toml")]).unwrap();
    assert_eq!(names, ["a_b", "c"]);
    for clash in [["d/a-b.toml", "d/a_b.toml"], ["d/Karis.toml", "e/karis.toml"]] {
        let files: Vec<PathBuf> = clash.iter().map(PathBuf::from).collect();
        let refused = super::form::distinct_form_names(&files).unwrap_err().to_string();
        assert!(
            refused.contains(clash[0]) && refused.contains(clash[1]) && refused.contains("rename one"),
            "{refused}"
        );
    }
}

#[test]
fn a_form_of_more_parameters_than_any_fit_needs_is_refused_naming_the_limit() {
    use super::form::MAX_PARAMETERS;
    let table = karis_like(4, |_, _| [0.0, 0.0]);
    let form_of = |n: usize| {
        let parameters: String = (0..n).map(|k| format!("p{k} = {{ start = 0.0, min = -1.0, max = 1.0 }}\n")).collect();
        let sum: Vec<String> = (0..n).map(|k| format!("p{k} * mu")).collect();
        format!(
            "table = \"karis\"\n[parameters]\n{parameters}[channels]\nscale = \"{}\"\nbias = \"p0\"\n",
            sum.join(" + ")
        )
    };
    assert!(Form::parse(Path::new("most.toml"), &form_of(MAX_PARAMETERS), &table).is_ok());
    let refused = Form::parse(Path::new("more.toml"), &form_of(MAX_PARAMETERS + 1), &table).unwrap_err().to_string();
    assert!(refused.contains(&format!("allowed: at most {MAX_PARAMETERS}")), "{refused}");
}
