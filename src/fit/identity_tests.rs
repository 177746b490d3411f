//! Temporary: the format-string shaders of the fitted forms as they were before the emitter,
//! to prove the emitter prints them byte for byte.
use super::forms::*;
use crate::shader::Lang;

/// Shader source of a fitted form with its coefficients baked in (`None` for the baselines, whose
/// shader is the thesis's own).
fn shader(form: Form, parameters: &[f64], language: Lang) -> Option<String> {
    if parameters.is_empty() || parameters.len() != form.parameter_names().len() {
        return None;
    }
    // `{:?}` of an f32 is the shortest text that reads back to the same f32.
    let c: Vec<String> = parameters.iter().map(|&v| format!("{:?}", v as f32)).collect();
    if matches!(form, Form::CauchyCap | Form::CauchySlope) {
        return Some(cauchy_shader(form, &c, language));
    }
    let (signature, binding) = match language {
        Lang::Hlsl => ("float tmlut_tir(float mu, float alpha, float eta)", "float"),
        Lang::Wgsl => ("fn tmlut_tir(mu: f32, alpha: f32, eta: f32) -> f32", "let"),
    };
    let step = match form {
        Form::Logistic => "1.0 / (1.0 + exp(min(t, 80.0)))",
        Form::Smoothstep => "1.0 - smoothstep(-1.0, 1.0, t)",
        Form::Algebraic => "0.5 - 0.5 * t / sqrt(1.0 + t * t)",
        Form::Rational => "0.5 - 0.5 * t / (1.0 + abs(t))",
        Form::Eq56 | Form::Eq56Corrected | Form::CauchyCap | Form::CauchySlope => return None,
    };
    Some(format!(
        "// tmlut fit tir: form '{name}', {formula}\n\
         // width = alpha (c0 + c1 alpha + c2 mu) + {floor:?}, shift = alpha (c3 + c4 alpha + c5 mu^2),\n\
         // plus c6 logit(eta^2) clamped to +-{limit:?}. c0..c6: the fit's `parameters`, in order\n\
         // (manifest.json `fit` of the build; fit.json of `tmlut fit tir`), as f32.\n\
         {signature} {{\n\
         \x20   {binding} width = alpha * max({c0} + {c1} * alpha + {c2} * mu, 0.0) + {floor:?};\n\
         \x20   {binding} shift = alpha * ({c3} + {c4} * alpha + {c5} * mu * mu);\n\
         \x20   {binding} eta2 = eta * eta;\n\
         \x20   {binding} edge_logit = clamp(log(max(eta2, 1e-30)) - log(max(1.0 - eta2, 1e-30)), -{limit:?}, {limit:?});\n\
         \x20   {binding} t = (mu * mu + eta2 - 1.0 - shift) / width + {c6} * edge_logit;\n\
         \x20   return {step};\n\
         }}\n",
        name = form.name(),
        formula = form.formula(),
        floor = WIDTH_FLOOR as f32,
        c0 = c[0],
        c1 = c[1],
        c2 = c[2],
        c3 = c[3],
        c4 = c[4],
        c5 = c[5],
        c6 = c[6],
        limit = EDGE_LOGIT_LIMIT as f32,
    ))
}

/// [`cauchy_cap`] or [`cauchy_slope`] as shader text, statement for statement, with coefficients
/// `c` (f32 text) baked in as named constants `c0..c9`.
fn cauchy_shader(form: Form, c: &[String], language: Lang) -> String {
    let hlsl = language == Lang::Hlsl;
    let (binding, constant_type, pair) = if hlsl { ("float", "", "float2") } else { ("let", ": f32", "vec2<f32>") };
    let function = |name: &str, arguments: &[(&str, &str)], returns: &str| -> String {
        if hlsl {
            let list: Vec<String> = arguments.iter().map(|(a, ty)| format!("{ty} {a}")).collect();
            format!("{returns} {name}({})", list.join(", "))
        } else {
            let list: Vec<String> = arguments.iter().map(|(a, ty)| format!("{a}: {ty}")).collect();
            format!("fn {name}({}) -> {returns}", list.join(", "))
        }
    };
    let scalar = if hlsl { "float" } else { "f32" };
    let choose = |condition: &str, then: &str, otherwise: &str| {
        if hlsl {
            format!("{condition} ? {then} : {otherwise}")
        } else {
            format!("select({otherwise}, {then}, {condition})")
        }
    };
    let mut text = format!(
        "// tmlut fit tir: form '{name}', {formula}\n\
         // c0..c9: the fit's `parameters`, in order (manifest.json `fit` of the build; fit.json of\n\
         // `tmlut fit tir`), as f32; the manifest's `definition` states every statement below.\n\
         // Shares are (numerator, denominator) pairs, so that a ratio of two shares costs one division.\n\
         {ratio_signature} {{\n\
         \x20   return a.x * b.y / max(a.y * b.x, 1e-37);\n\
         }}\n\
         // Share of a spherical Cauchy lobe in a cap: (1 - u / s) / 2, written without cancellation\n\
         // for u > 0 as w^2 / (2 s d), d = s + |u|, and as d^2 / (2 s d) otherwise.\n\
         {share_signature} {{\n\
         \x20   {binding} s = max(sqrt(u * u + w * w), 1e-30);\n\
         \x20   {binding} d = s + abs(u);\n\
         \x20   return {pair}({share}, 2.0 * s * d);\n\
         }}\n",
        name = form.name(),
        formula = form.formula(),
        ratio_signature = function("tmlut_ratio", &[("a", pair), ("b", pair)], scalar),
        share_signature = function("tmlut_cap_share", &[("u", scalar), ("w", scalar)], pair),
        share = choose("u > 0.0", "w * w", "d * d"),
    );
    if form == Form::CauchySlope {
        text += &format!(
            "// Weight of the in-plane visible-slope lobe reflected above cosine c (up to a common factor):\n\
             // (mu (r - t) + s^2) / r, with r - t written as s^2 / e for t > 0, e = r + |t|.\n\
             {signature} {{\n\
             \x20   {binding} t = 0.5 * (c - mu);\n\
             \x20   {binding} s2 = s * s;\n\
             \x20   {binding} r = sqrt(s2 + t * t);\n\
             \x20   {binding} e = r + abs(t);\n\
             \x20   return {pair}({above}, e * r);\n\
             }}\n",
            signature = function("tmlut_slope_above", &[("c", scalar), ("mu", scalar), ("s", scalar)], pair),
            above = choose("t > 0.0", "s2 * (mu + e)", "(mu * e + s2) * e"),
        );
    }
    let (centre, grazing) = if form == Form::CauchySlope { ("c6", "c7") } else { ("c8", "c9") };
    let constants: String =
        c.iter().enumerate().map(|(k, v)| format!("    {binding} c{k}{constant_type} = {v};\n")).collect();
    text += &format!(
        "{signature} {{\n\
         {constants}\
         \x20   {binding} sqrt_alpha = sqrt(alpha);\n\
         \x20   {binding} g2 = (1.0 - mu) * (1.0 - mu);\n\
         \x20   {binding} g4 = g2 * g2;\n\
         \x20   {binding} g8 = g4 * g4;\n\
         \x20   {binding} scale = max(alpha * (c0 + c1 * alpha + c2 * mu), 0.0) + {grazing} * sqrt_alpha * (g8 * g8) + {floor:?};\n\
         \x20   {binding} centre = clamp(mu + {centre} * alpha * (1.0 - mu), 0.0, 1.0);\n\
         \x20   {binding} critical_cosine_squared = max(1.0 - eta * eta, 0.0);\n\
         \x20   {binding} critical_cosine = sqrt(critical_cosine_squared);\n\
         \x20   {binding} k = clamp(1.0 - alpha * (c3 + c4 * alpha), 0.0, 1.0);\n\
         \x20   {binding} k2 = k * k;\n\
         \x20   {binding} upper_centre = centre * (1.0 + k2);\n\
         \x20   {binding} scale2 = scale * scale;\n\
         \x20   {pair_binding} cone = tmlut_cap_share(scale2 * (centre + critical_cosine) + (critical_cosine - centre), 2.0 * scale * eta);\n\
         \x20   {pair_binding} upper = tmlut_cap_share(scale2 * (upper_centre + (1.0 - k2)) + ((1.0 - k2) - upper_centre), 2.0 * scale * (2.0 * k));\n\
         \x20   {binding} cauchy_inside = tmlut_ratio(cone, upper);\n",
        signature = function("tmlut_tir", &[("mu", scalar), ("alpha", scalar), ("eta", scalar)], scalar),
        pair_binding = if hlsl { pair } else { "let" },
        floor = CAUCHY_SCALE_FLOOR as f32,
    );
    text += &if form == Form::CauchySlope {
        format!(
            "\x20   {binding} slope_scale = c8 * alpha + {floor:?};\n\
             \x20   {binding} slope_inside = tmlut_ratio(tmlut_slope_above(critical_cosine, mu, slope_scale), tmlut_slope_above(0.0, mu, slope_scale));\n\
             \x20   {binding} fade_denominator = 1.0 + c9 * alpha;\n\
             \x20   {binding} fade = (1.0 - mu) / (fade_denominator * fade_denominator);\n\
             \x20   {binding} narrow = clamp(1.0 - (cauchy_inside + fade * (slope_inside - cauchy_inside)), 0.0, 1.0);\n\
             \x20   {binding} rough = critical_cosine_squared;\n\
             \x20   {binding} blend = min(c5 * alpha * sqrt_alpha, 1.0);\n",
            floor = SLOPE_SCALE_FLOOR as f32,
        )
    } else {
        format!(
            "\x20   {binding} narrow = clamp(1.0 - cauchy_inside, 0.0, 1.0);\n\
             \x20   {binding} rough = pow(critical_cosine, c5);\n\
             \x20   {binding} blend = min(c6 * pow(alpha, c7), 1.0);\n"
        )
    };
    text += "    return narrow + blend * (rough - narrow);\n}\n";
    text
}

#[test]
fn the_emitter_prints_the_fitted_forms_byte_for_byte() {
    for form in &ALL_FORMS {
        let n = form.parameter_names().len();
        for seed in 0..20u32 {
            let parameters: Vec<f64> =
                (0..n).map(|k| ((seed * 7 + k as u32 * 13) as f64).sin() * 10f64.powi(k as i32 % 5 - 2)).collect();
            for lang in [Lang::Hlsl, Lang::Wgsl] {
                assert_eq!(
                    shader(*form, &parameters, lang),
                    super::forms::shader(*form, &parameters, lang),
                    "{form:?}"
                );
            }
        }
    }
}
