//! Candidate analytic forms for the TIR table, each a small function of `(mu, alpha, eta)` and a
//! parameter vector, evaluated in f64 (fitting) or f32 (what a shader runs, and what is timed).
//!
//! - [`Form::Eq56`]: the thesis's equation 5.6 as published (`notes/tables.md`, "The analytic TIR
//!   approximation"): no fitted parameters, a `step()` of inverted polarity and a mean direction
//!   `theta_o = pi/4 (1 + mu)`.
//! - [`Form::Eq56Corrected`]: the same with the step kept where `w_s.z > 0` and the mean direction the
//!   lobe's own mirror direction `(sqrt(1 - mu^2), 0, mu)`. Both are baselines (no parameters).
//! - Step forms: the table is a hard step at the critical cosine `c = sqrt(1 - eta^2)` when
//!   `alpha -> 0` (`notes/tables.md`, TIR), smeared by the lobe's width as `alpha` grows. Each is
//!   `S(t)` with `t = (mu^2 - c^2 - shift) / width`, a decreasing step `S` (1 past the critical
//!   angle, `mu < c`), and a width and shift that depend on roughness and angle:
//!   `width = alpha (p0 + p1 alpha + p2 mu) + WIDTH_FLOOR`, `shift = alpha (p3 + p4 alpha + p5 mu^2)`.
//!   The step is in squared cosines because a direction is past the critical angle when
//!   `w.z^2 < 1 - eta^2 = c^2`, and because at `alpha = 1` the table is close to `c^2` whatever `mu`
//!   (a cosine-like lobe has `P(w.z^2 < c^2) = c^2`): a step of width about 1 whose `mu^2` is
//!   cancelled by the shift's `alpha mu^2` term. A first version stepped in `mu - c` with a shift in
//!   `alpha mu`; it could not lose its `mu` dependence at high roughness (RMSE 0.090 on `tm_TIR.bin`).
//!   `S` is the logistic `1 / (1 + e^t)`, the smoothstep `1 - smoothstep(-1, 1, t)`, the
//!   error-function-like algebraic sigmoid `(1 - t / sqrt(1 + t^2)) / 2`, or the rational
//!   `(1 - t / (1 + |t|)) / 2`.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

/// The narrowest step a step form can take, so that `t` stays finite at `alpha = 0`
/// (a hard step at the table's resolution).
pub const WIDTH_FLOOR: f64 = 1e-4;

/// Relative index of the thesis's last factor `1 - F(w_o.z; eta10)` (`eta10 = 1 / 1.5`).
const ETA10: f64 = 1.0 / 1.5;

/// The arithmetic the forms need, for f32 and f64 alike.
pub trait Real: Copy + PartialOrd + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> {
    fn of(v: f64) -> Self;
    fn to_f64(self) -> f64;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn powf(self, e: Self) -> Self;
    fn abs(self) -> Self;
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
}

macro_rules! real {
    ($t:ty) => {
        impl Real for $t {
            fn of(v: f64) -> Self {
                v as $t
            }
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn mul(self, o: Self) -> Self {
                self * o
            }
            fn div(self, o: Self) -> Self {
                self / o
            }
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            fn powf(self, e: Self) -> Self {
                <$t>::powf(self, e)
            }
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
        }
    };
}
real!(f32);
real!(f64);

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Form {
    Eq56,
    Eq56Corrected,
    Logistic,
    Smoothstep,
    Algebraic,
    Rational,
}

pub const ALL_FORMS: [Form; 6] =
    [Form::Eq56, Form::Eq56Corrected, Form::Logistic, Form::Smoothstep, Form::Algebraic, Form::Rational];

/// Names of the step forms' parameters (see the module docs).
pub const STEP_PARAMETERS: [&str; 7] =
    ["width_alpha", "width_alpha2", "width_alpha_mu", "shift_alpha", "shift_alpha2", "shift_alpha_mu2", "edge_logit"];

/// `logit(eta^2)` is clamped to this magnitude so that it stays finite at `eta = 0` and `eta = 1`.
pub const EDGE_LOGIT_LIMIT: f64 = 40.0;

impl Form {
    pub fn name(self) -> &'static str {
        match self {
            Form::Eq56 => "eq56",
            Form::Eq56Corrected => "eq56-corrected",
            Form::Logistic => "logistic",
            Form::Smoothstep => "smoothstep",
            Form::Algebraic => "algebraic",
            Form::Rational => "rational",
        }
    }

    pub fn from_name(name: &str) -> Option<Form> {
        ALL_FORMS.into_iter().find(|f| f.name() == name)
    }

    pub fn parameter_names(self) -> &'static [&'static str] {
        match self {
            Form::Eq56 | Form::Eq56Corrected => &[],
            _ => &STEP_PARAMETERS,
        }
    }

    /// The formula in words, for the manifest.
    pub fn formula(self) -> &'static str {
        match self {
            Form::Eq56 => {
                "thesis eq. 5.6 as published: F(w_o.s; eta) G1(w_s; alpha') (1 - F(w_o.z; 1/1.5)) step(w_s.z <= 0), w_o at theta = pi/4 (1 + mu), s = normalize(lerp(N, w_o, f_Frostbite))"
            }
            Form::Eq56Corrected => {
                "thesis eq. 5.6 with the step kept where w_s.z > 0 and w_o = (sqrt(1 - mu^2), 0, mu)"
            }
            Form::Logistic => "1 / (1 + exp(t)), t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)",
            Form::Smoothstep => "1 - smoothstep(-1, 1, t), t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)",
            Form::Algebraic => "(1 - t / sqrt(1 + t^2)) / 2, t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)",
            Form::Rational => "(1 - t / (1 + |t|)) / 2, t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)",
        }
    }

    /// A starting point and bounds per parameter.
    pub fn start_and_bounds(self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        match self {
            Form::Eq56 | Form::Eq56Corrected => (vec![], vec![], vec![]),
            _ => (
                vec![0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                vec![0.0, -2.0, -2.0, -2.0, -2.0, -2.0, 0.0],
                vec![3.0, 2.0, 2.0, 2.0, 2.0, 2.0, 1.0],
            ),
        }
    }

    /// The form's value at one point.
    pub fn eval<R: Real>(self, p: &[R], mu: R, alpha: R, eta: R) -> R {
        match self {
            Form::Eq56 => eq56(mu, alpha, eta, false),
            Form::Eq56Corrected => eq56(mu, alpha, eta, true),
            _ => {
                let t = step_argument(p, mu, alpha, eta).0;
                self.step(t)
            }
        }
    }

    /// `S(t)` and `dS/dt` of a step form.
    fn step<R: Real>(self, t: R) -> R {
        let (half, one) = (R::of(0.5), R::of(1.0));
        match self {
            Form::Logistic => one.div(one + t.min(R::of(80.0)).exp()),
            Form::Smoothstep => {
                let x = (t.mul(half) + half).max(R::of(0.0)).min(one);
                one - x.mul(x).mul(R::of(3.0) - R::of(2.0).mul(x))
            }
            Form::Algebraic => half - half.mul(t).div((one + t.mul(t)).sqrt()),
            Form::Rational => half - half.mul(t).div(one + t.abs()),
            Form::Eq56 | Form::Eq56Corrected => R::of(0.0),
        }
    }

    fn step_derivative(self, t: f64) -> f64 {
        match self {
            Form::Logistic => {
                let s = 1.0 / (1.0 + t.min(80.0).exp());
                -s * (1.0 - s)
            }
            Form::Smoothstep => {
                let x = 0.5 * t + 0.5;
                if (0.0..=1.0).contains(&x) { -3.0 * x * (1.0 - x) } else { 0.0 }
            }
            Form::Algebraic => -0.5 / (1.0 + t * t).powf(1.5),
            Form::Rational => -0.5 / ((1.0 + t.abs()) * (1.0 + t.abs())),
            Form::Eq56 | Form::Eq56Corrected => 0.0,
        }
    }

    /// The value and its gradient with respect to the parameters (step forms; `None` for the
    /// parameter-free baselines).
    pub fn value_and_gradient(self, p: &[f64], mu: f64, alpha: f64, eta: f64, gradient: &mut [f64]) -> Option<f64> {
        if p.is_empty() {
            return None;
        }
        let (t, width, clamped) = step_argument(p, mu, alpha, eta);
        let dv_dt = self.step_derivative(t);
        // t = (mu^2 - c^2 - shift) / width + c6 logit: dt/dwidth = -(t - c6 logit) / width,
        // dt/dshift = -1 / width, dt/dc6 = logit.
        let logit = edge_logit(eta);
        let step_part = t - p[6] * logit;
        let width_basis = [alpha, alpha * alpha, alpha * mu];
        let shift_basis = [alpha, alpha * alpha, alpha * mu * mu];
        for k in 0..3 {
            gradient[k] = if clamped { 0.0 } else { dv_dt * (-step_part / width) * width_basis[k] };
            gradient[k + 3] = dv_dt * (-1.0 / width) * shift_basis[k];
        }
        gradient[6] = dv_dt * logit;
        Some(self.step(t))
    }
}

/// `(t, width, width clamped to its floor)` of the step forms.
fn step_argument<R: Real>(p: &[R], mu: R, alpha: R, eta: R) -> (R, R, bool) {
    // mu^2 - c^2 = mu^2 + eta^2 - 1: no square root, and exact at the step.
    let squared_cosine_gap = mu.mul(mu) + eta.mul(eta) - R::of(1.0);
    let raw_width = alpha.mul(p[0] + p[1].mul(alpha) + p[2].mul(mu));
    let clamped = raw_width < R::of(0.0);
    let width = raw_width.max(R::of(0.0)) + R::of(WIDTH_FLOOR);
    let shift = alpha.mul(p[3] + p[4].mul(alpha) + p[5].mul(mu.mul(mu)));
    ((squared_cosine_gap - shift).div(width) + p[6].mul(edge_logit(eta)), width, clamped)
}

/// `logit(eta^2) = ln(eta^2 / (1 - eta^2))`, clamped to `±EDGE_LOGIT_LIMIT`: with a non-negative
/// weight it drives `t` to `-inf` at `eta = 0` (TIR = 1: every direction off the normal is past the
/// critical angle) and to `+inf` at `eta = 1` (TIR = 0: no critical angle), the table's two exact
/// edges, which a step in `mu^2 + eta^2 - 1` alone misses at high roughness.
fn edge_logit<R: Real>(eta: R) -> R {
    let eta2 = eta.mul(eta);
    let tiny = R::of(1e-30);
    let logit = eta2.max(tiny).ln() - (R::of(1.0) - eta2).max(tiny).ln();
    logit.max(R::of(-EDGE_LOGIT_LIMIT)).min(R::of(EDGE_LOGIT_LIMIT))
}

/// Unpolarised Fresnel reflectance of a dielectric interface of relative index `eta` at incident
/// cosine `c`; 1 past the critical angle.
fn fresnel_dielectric<R: Real>(c: R, eta: R) -> R {
    let (zero, one) = (R::of(0.0), R::of(1.0));
    let c = c.abs().min(one);
    let sin2_t = (one - c.mul(c)).div(eta.mul(eta).max(R::of(1e-12)));
    if sin2_t.partial_cmp(&one) != Some(Ordering::Less) {
        return one;
    }
    let cos_t = (one - sin2_t).max(zero).sqrt();
    let rs = (c - eta.mul(cos_t)).div((c + eta.mul(cos_t)).max(R::of(1e-12)));
    let rp = (eta.mul(c) - cos_t).div((eta.mul(c) + cos_t).max(R::of(1e-12)));
    R::of(0.5).mul(rs.mul(rs) + rp.mul(rp))
}

/// Separable Smith G1 of GGX at direction cosine `z`: `2 / (1 + sqrt(1 + alpha^2 tan^2))`.
fn smith_g1<R: Real>(z: R, alpha: R) -> R {
    let one = R::of(1.0);
    if z.partial_cmp(&R::of(0.0)) != Some(Ordering::Greater) {
        return R::of(0.0);
    }
    let z2 = z.mul(z);
    let tan2 = (one - z2).max(R::of(0.0)).div(z2);
    R::of(2.0).div(one + (one + alpha.mul(alpha).mul(tan2)).sqrt())
}

/// Thesis equation 5.6 (`notes/tables.md`), published or with its step and mean direction corrected.
/// The dominant direction `s` is Frostbite's "specular dominant direction" (Lagarde & de Rousiers
/// 2014), normalised here because `reflect` needs a unit normal.
fn eq56<R: Real>(mu: R, alpha: R, eta: R, corrected: bool) -> R {
    let (zero, one) = (R::of(0.0), R::of(1.0));
    let (ox, oz) = if corrected {
        ((one - mu.mul(mu)).max(zero).sqrt(), mu)
    } else {
        let theta = R::of(std::f64::consts::FRAC_PI_4).mul(one + mu);
        (theta.sin(), theta.cos())
    };
    let alpha = alpha.max(R::of(0.01));
    let lerp_factor = R::of(0.298475).mul((R::of(39.4115) - R::of(39.0029).mul(alpha)).ln());
    let f = (one - mu).max(zero).powf(R::of(10.8649)).mul(one - lerp_factor) + lerp_factor;
    // s = normalize(lerp(N, w_o, f)), N = (0, 0, 1).
    let (sx, sz) = (f.mul(ox), one - f + f.mul(oz));
    let norm = (sx.mul(sx) + sz.mul(sz)).sqrt().max(R::of(1e-12));
    let (sx, sz) = (sx.div(norm), sz.div(norm));
    let o_dot_s = ox.mul(sx) + oz.mul(sz);
    // w_s = -reflect(w_o, s) = 2 (w_o.s) s - w_o.
    let ws_z = R::of(2.0).mul(o_dot_s).mul(sz) - oz;
    let kept = if corrected { ws_z > zero } else { ws_z.partial_cmp(&zero) != Some(Ordering::Greater) };
    if !kept {
        return zero;
    }
    fresnel_dielectric(o_dot_s, eta).mul(smith_g1(ws_z, alpha)).mul(one - fresnel_dielectric(oz, R::of(ETA10)))
}

/// Shader source of a step form with its coefficients baked in (`None` for the baselines, whose
/// shader is the thesis's own).
pub fn shader(form: Form, parameters: &[f64], language: ShaderLanguage) -> Option<String> {
    if parameters.len() != STEP_PARAMETERS.len() {
        return None;
    }
    // `{:?}` of an f32 is the shortest text that reads back to the same f32.
    let c: Vec<String> = parameters.iter().map(|&v| format!("{:?}", v as f32)).collect();
    let (signature, binding) = match language {
        ShaderLanguage::Hlsl => ("float tmlut_tir(float mu, float alpha, float eta)", "float"),
        ShaderLanguage::Wgsl => ("fn tmlut_tir(mu: f32, alpha: f32, eta: f32) -> f32", "let"),
    };
    let step = match form {
        Form::Logistic => "1.0 / (1.0 + exp(min(t, 80.0)))",
        Form::Smoothstep => "1.0 - smoothstep(-1.0, 1.0, t)",
        Form::Algebraic => "0.5 - 0.5 * t / sqrt(1.0 + t * t)",
        Form::Rational => "0.5 - 0.5 * t / (1.0 + abs(t))",
        Form::Eq56 | Form::Eq56Corrected => return None,
    };
    Some(format!(
        "// tmlut fit tir: form '{name}', {formula}\n\
         // width = alpha (c0 + c1 alpha + c2 mu) + {floor:?}, shift = alpha (c3 + c4 alpha + c5 mu^2),\n\
         // plus c6 logit(eta^2) clamped to +-{limit:?}; coefficients as in fit.json.\n\
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

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShaderLanguage {
    Hlsl,
    Wgsl,
}
