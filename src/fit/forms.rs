//! Candidate analytic forms for the TIR table, each a small function of `(mu, alpha, eta)` and a
//! parameter vector, evaluated in f64 (fitting) or f32 (what a shader runs, and what is timed).
//!
//! - [`Form::Eq56`]: the thesis's equation 5.6 as published (`docs/fit.md`, "Forms"): no fitted
//!   parameters, a `step()` of inverted polarity and a mean direction `theta_o = pi/4 (1 + mu)`.
//! - [`Form::Eq56Corrected`]: the same with the step kept where `w_s.z > 0` and the mean direction the
//!   lobe's own mirror direction `(sqrt(1 - mu^2), 0, mu)`. Both are baselines (no parameters).
//! - Step forms: the table is a hard step at the critical cosine `c = sqrt(1 - eta^2)` when
//!   `alpha -> 0` (`docs/tables.md`, TIR), smeared by the lobe's width as `alpha` grows. Each is
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
//! - [`Form::CauchyCap`]: the lobe as a spherical Cauchy distribution and TIR as the share of it
//!   outside the critical cone, in closed form (see [`cauchy_cap`]).
//! - [`Form::CauchySlope`]: the same lobe, blended toward grazing incidence with the in-plane
//!   lobe of visible slopes, whose share above a cosine is also closed-form (see [`cauchy_slope`]);
//!   no `pow`, no `exp`.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

use super::dual::Dual;
use crate::shader::{Builtin, Expr, Module, Parens, Stmt, Ty, call, f, func, name, select};

/// The narrowest step a step form can take, so that `t` stays finite at `alpha = 0`
/// (a hard step at the table's resolution).
pub const WIDTH_FLOOR: f64 = 1e-4;

/// Relative index of the thesis's last factor `1 - F(w_o.z; eta10)` (`eta10 = 1 / 1.5`).
const ETA10: f64 = 1.0 / 1.5;

pub use super::real::Real;

/// One fitted coefficient: its name (in manifests), the value the fit starts from, and its bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameter {
    pub name: &'static str,
    pub start: f64,
    pub lower: f64,
    pub upper: f64,
}

const fn parameter(name: &'static str, start: f64, lower: f64, upper: f64) -> Parameter {
    Parameter { name, start, lower, upper }
}

/// The forms, one line each: `Variant: "name", parameters, formula in words`. The name is the
/// form's `--forms` name, its serialised name and its files' stem. From this list come [`Form`],
/// [`ALL_FORMS`] (and so the `fit` help), [`Form::name`], [`Form::parameters`] and
/// [`Form::formula`]. What a form computes (its value, its gradient, its definition statement by
/// statement, its shader) is in the matches of [`Form`]'s methods, none of which has a `_` arm: a
/// form added here and not there does not compile.
macro_rules! form_registry {
    ($($variant:ident: $name:literal, $parameters:expr, $formula:expr;)+) => {
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
        pub enum Form {
            $(#[serde(rename = $name)] $variant,)+
        }

        /// Every form, in the order `tmlut fit` fits and reports them.
        pub const ALL_FORMS: [Form; [$(Form::$variant),+].len()] = [$(Form::$variant),+];

        impl Form {
            pub fn name(self) -> &'static str {
                match self {
                    $(Form::$variant => $name,)+
                }
            }

            /// The fitted coefficients `c0, c1, ...`, in order (none for the baselines).
            pub fn parameters(self) -> &'static [Parameter] {
                match self {
                    $(Form::$variant => &$parameters,)+
                }
            }

            /// The formula in words, for the manifest.
            pub fn formula(self) -> &'static str {
                match self {
                    $(Form::$variant => $formula,)+
                }
            }
        }
    };
}

form_registry! {
    Eq56: "eq56", NO_PARAMETERS,
        "thesis eq. 5.6 as published: F(w_o.s; eta) G1(w_s; alpha') (1 - F(w_o.z; 1/1.5)) step(w_s.z <= 0), w_o at theta = pi/4 (1 + mu), s = normalize(lerp(N, w_o, f_Frostbite))";
    Eq56Corrected: "eq56-corrected", NO_PARAMETERS,
        "thesis eq. 5.6 with the step kept where w_s.z > 0 and w_o = (sqrt(1 - mu^2), 0, mu)";
    Logistic: "logistic", STEP_PARAMETERS,
        "1 / (1 + exp(t)), t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)";
    Smoothstep: "smoothstep", STEP_PARAMETERS,
        "1 - smoothstep(-1, 1, t), t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)";
    Algebraic: "algebraic", STEP_PARAMETERS,
        "(1 - t / sqrt(1 + t^2)) / 2, t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)";
    Rational: "rational", STEP_PARAMETERS,
        "(1 - t / (1 + |t|)) / 2, t = (mu^2 + eta^2 - 1 - shift) / width + c6 logit(eta^2)";
    CauchyCap: "cauchy-cap", CAUCHY_CAP_PARAMETERS, CAUCHY_CAP_FORMULA;
    CauchySlope: "cauchy-slope", CAUCHY_SLOPE_PARAMETERS, CAUCHY_SLOPE_FORMULA;
}

/// The baselines fit nothing.
const NO_PARAMETERS: [Parameter; 0] = [];

/// The step forms' parameters (see the module docs). The start is a plain step widening with
/// roughness.
pub const STEP_PARAMETERS: [Parameter; 7] = [
    parameter("width_alpha", 0.3, 0.0, 3.0),
    parameter("width_alpha2", 0.0, -2.0, 2.0),
    parameter("width_alpha_mu", 0.0, -2.0, 2.0),
    parameter("shift_alpha", 0.0, -2.0, 2.0),
    parameter("shift_alpha2", 0.0, -2.0, 2.0),
    parameter("shift_alpha_mu2", 0.0, -2.0, 2.0),
    parameter("edge_logit", 0.0, 0.0, 1.0),
];

/// The coefficients of the spherical Cauchy lobe both Cauchy forms share ([`CauchyLobe::new`]),
/// and of their blend into the rough limit. Their start is the plain model: scale alpha (exact at
/// mu = 1 without G1), the true horizon, the centre at the view, no grazing term, the rough limit
/// reached linearly.
const SCALE_ALPHA: Parameter = parameter("scale_alpha", 1.0, 0.0, 4.0);
const SCALE_ALPHA2: Parameter = parameter("scale_alpha2", 0.0, -2.0, 2.0);
const SCALE_ALPHA_MU: Parameter = parameter("scale_alpha_mu", 0.0, -2.0, 2.0);
const HORIZON_ALPHA: Parameter = parameter("horizon_alpha", 0.0, 0.0, 2.0);
const HORIZON_ALPHA2: Parameter = parameter("horizon_alpha2", 0.0, -2.0, 2.0);
const CENTRE_ALPHA: Parameter = parameter("centre_alpha", 0.0, -1.0, 2.0);
const SCALE_GRAZING: Parameter = parameter("scale_grazing", 0.0, 0.0, 2.0);
const ROUGH_BLEND: Parameter = parameter("rough_blend", 1.0, 0.0, 4.0);

/// [`Form::CauchyCap`]'s parameters (see [`cauchy_cap`]): the lobe's, and a cosine-like rough
/// limit `1 - eta^2` to start from.
pub const CAUCHY_CAP_PARAMETERS: [Parameter; 10] = [
    SCALE_ALPHA,
    SCALE_ALPHA2,
    SCALE_ALPHA_MU,
    HORIZON_ALPHA,
    HORIZON_ALPHA2,
    parameter("rough_exponent", 2.0, 0.5, 4.0),
    ROUGH_BLEND,
    parameter("rough_blend_exponent", 1.0, 0.5, 4.0),
    CENTRE_ALPHA,
    SCALE_GRAZING,
];

/// [`Form::CauchySlope`]'s parameters (see [`cauchy_slope`]): the lobe's, and the slope lobe at its
/// derived scale `alpha` fading out by `alpha = 0.3` to start from.
pub const CAUCHY_SLOPE_PARAMETERS: [Parameter; 10] = [
    SCALE_ALPHA,
    SCALE_ALPHA2,
    SCALE_ALPHA_MU,
    HORIZON_ALPHA,
    HORIZON_ALPHA2,
    ROUGH_BLEND,
    CENTRE_ALPHA,
    SCALE_GRAZING,
    parameter("slope_scale", 1.0, 0.1, 4.0),
    parameter("slope_fade_alpha", 10.0, 0.0, 200.0),
];

/// `logit(eta^2)` is clamped to this magnitude so that it stays finite at `eta = 0` and `eta = 1`.
pub const EDGE_LOGIT_LIMIT: f64 = 40.0;

impl Form {
    pub fn from_name(name: &str) -> Option<Form> {
        ALL_FORMS.into_iter().find(|f| f.name() == name)
    }

    /// The parameters' names, in order.
    pub fn parameter_names(self) -> impl ExactSizeIterator<Item = &'static str> {
        self.parameters().iter().map(|p| p.name)
    }

    /// The form statement by statement, complete (every floor, clamp and guard the shader has),
    /// for a reader who implements it without the shader: `name = expression` in order, helper
    /// functions as `name(arguments) = expression`, the result last as `TIR = ...`. `c0, c1, ...`
    /// are the fitted `parameters` in order; `^` is a power, `a ? b : c` a select, `ln` the natural
    /// logarithm. Empty for the parameter-free baselines (their definition is the thesis's).
    pub fn definition(self) -> Vec<String> {
        let lines: &[&str] = match self {
            Form::Eq56 | Form::Eq56Corrected => &[],
            Form::Logistic | Form::Smoothstep | Form::Algebraic | Form::Rational => &STEP_DEFINITION,
            Form::CauchyCap | Form::CauchySlope => &CAUCHY_DEFINITION,
        };
        let mut lines: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        let (width_floor, scale_floor, slope_floor) = (WIDTH_FLOOR, CAUCHY_SCALE_FLOOR, SLOPE_SCALE_FLOOR);
        for line in &mut lines {
            *line = line
                .replace("WIDTH_FLOOR", &format!("{width_floor:?}"))
                .replace("SCALE_FLOOR", &format!("{scale_floor:?}"))
                .replace("EDGE_LOGIT_LIMIT", &format!("{EDGE_LOGIT_LIMIT:?}"));
        }
        let (centre, grazing) = if self == Form::CauchySlope { ("c6", "c7") } else { ("c8", "c9") };
        let tail: Vec<String> = match self {
            Form::Eq56 | Form::Eq56Corrected => vec![],
            Form::Logistic => vec!["TIR = 1 / (1 + exp(min(t, 80)))".into()],
            Form::Smoothstep => {
                vec!["x = clamp((t + 1) / 2, 0, 1)".into(), "TIR = 1 - x^2 * (3 - 2 * x)".into()]
            }
            Form::Algebraic => vec!["TIR = 0.5 - 0.5 * t / sqrt(1 + t^2)".into()],
            Form::Rational => vec!["TIR = 0.5 - 0.5 * t / (1 + abs(t))".into()],
            Form::CauchyCap => vec![
                "narrow = clamp(1 - cauchy_inside, 0, 1)".into(),
                "rough = cb^c5".into(),
                "blend = min(c6 * alpha^c7, 1)".into(),
                "TIR = narrow + blend * (rough - narrow)".into(),
            ],
            Form::CauchySlope => vec![
                format!("slope_scale = c8 * alpha + {slope_floor:?}"),
                "slope_t(c) = 0.5 * (c - mu)".into(),
                "slope_r(c) = sqrt(slope_scale^2 + slope_t(c)^2)".into(),
                "slope_e(c) = slope_r(c) + abs(slope_t(c))".into(),
                "slope_num(c) = slope_t(c) > 0 ? slope_scale^2 * (mu + slope_e(c)) : (mu * slope_e(c) + slope_scale^2) * slope_e(c)".into(),
                "slope_den(c) = slope_e(c) * slope_r(c)".into(),
                "slope_inside = slope_num(cb) * slope_den(0) / max(slope_den(cb) * slope_num(0), 1e-37)".into(),
                "fade = (1 - mu) / (1 + c9 * alpha)^2".into(),
                "narrow = clamp(1 - (cauchy_inside + fade * (slope_inside - cauchy_inside)), 0, 1)".into(),
                "rough = cb^2".into(),
                "blend = min(c5 * alpha * sqrt(alpha), 1)".into(),
                "TIR = narrow + blend * (rough - narrow)".into(),
            ],
        };
        for line in &mut lines {
            *line = line.replace("CENTRE", centre).replace("GRAZING", grazing);
        }
        lines.extend(tail);
        lines
    }

    /// The fit's start, lower bounds and upper bounds, one entry per parameter (the vectors an
    /// optimiser takes).
    pub fn start_and_bounds(self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let parameters = self.parameters();
        (
            parameters.iter().map(|p| p.start).collect(),
            parameters.iter().map(|p| p.lower).collect(),
            parameters.iter().map(|p| p.upper).collect(),
        )
    }

    /// The form's value at one point.
    pub fn eval<R: Real>(self, p: &[R], mu: R, alpha: R, eta: R) -> R {
        match self {
            Form::Eq56 => eq56(mu, alpha, eta, false),
            Form::Eq56Corrected => eq56(mu, alpha, eta, true),
            Form::CauchyCap => cauchy_cap(p, mu, alpha, eta),
            Form::CauchySlope => cauchy_slope(p, mu, alpha, eta),
            Form::Logistic | Form::Smoothstep | Form::Algebraic | Form::Rational => {
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
            Form::Eq56 | Form::Eq56Corrected | Form::CauchyCap | Form::CauchySlope => R::of(0.0),
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
            Form::Eq56 | Form::Eq56Corrected | Form::CauchyCap | Form::CauchySlope => 0.0,
        }
    }

    /// The value and its gradient with respect to the parameters (step forms; `None` for the
    /// parameter-free baselines).
    pub fn value_and_gradient(self, p: &[f64], mu: f64, alpha: f64, eta: f64, gradient: &mut [f64]) -> Option<f64> {
        if p.is_empty() {
            return None;
        }
        match self {
            Form::Eq56 | Form::Eq56Corrected => return None,
            Form::CauchyCap | Form::CauchySlope => {
                // Exact gradient by forward-mode dual numbers through the same generic code.
                let dual: Vec<Dual> = p.iter().enumerate().map(|(k, &v)| Dual::parameter(v, k)).collect();
                let value = self.eval(&dual, Dual::of(mu), Dual::of(alpha), Dual::of(eta));
                gradient.copy_from_slice(&value.gradient[..p.len()]);
                return Some(value.value);
            }
            Form::Logistic | Form::Smoothstep | Form::Algebraic | Form::Rational => {}
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

/// The step forms' argument `t`, statement by statement ([`Form::definition`]).
const STEP_DEFINITION: [&str; 4] = [
    "width = alpha * max(c0 + c1 * alpha + c2 * mu, 0) + WIDTH_FLOOR",
    "shift = alpha * (c3 + c4 * alpha + c5 * mu^2)",
    "edge_logit = clamp(ln(max(eta^2, 1e-30)) - ln(max(1 - eta^2, 1e-30)), -EDGE_LOGIT_LIMIT, EDGE_LOGIT_LIMIT)",
    "t = (mu^2 + eta^2 - 1 - shift) / width + c6 * edge_logit",
];

/// The Cauchy forms' spherical Cauchy lobe and its share inside the critical cone, statement by
/// statement ([`Form::definition`]; `CENTRE` and `GRAZING` name the form's coefficients). A cap's
/// share `(1 - u / sqrt(u^2 + w^2)) / 2` is kept as a numerator and a denominator without
/// cancellation (`cap_num / cap_den`), and the ratio of two shares takes one division with a floor:
/// `cauchy_inside` is the lobe's share inside the critical cone over its share inside the upper cap.
const CAUCHY_DEFINITION: [&str; 13] = [
    "scale = max(alpha * (c0 + c1 * alpha + c2 * mu), 0) + GRAZING * sqrt(max(alpha, 0)) * (1 - mu)^16 + SCALE_FLOOR",
    "centre = clamp(mu + CENTRE * alpha * (1 - mu), 0, 1)",
    "cb = sqrt(max(1 - eta^2, 0))",
    "k = clamp(1 - alpha * (c3 + c4 * alpha), 0, 1)",
    "cap_s(u, w) = max(sqrt(u^2 + w^2), 1e-30)",
    "cap_num(u, w) = u > 0 ? w^2 : (cap_s(u, w) + abs(u))^2",
    "cap_den(u, w) = 2 * cap_s(u, w) * (cap_s(u, w) + abs(u))",
    "cone_u = scale^2 * (centre + cb) + (cb - centre)",
    "cone_w = 2 * scale * eta",
    "upper_centre = centre * (1 + k^2)",
    "upper_u = scale^2 * (upper_centre + (1 - k^2)) + ((1 - k^2) - upper_centre)",
    "upper_w = 2 * scale * (2 * k)",
    "cauchy_inside = cap_num(cone_u, cone_w) * cap_den(upper_u, upper_w) / max(cap_den(cone_u, cone_w) * cap_num(upper_u, upper_w), 1e-37)",
];

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

/// The floor of the lobe's stereographic scale, so that the cap shares stay defined at `alpha = 0`
/// (a hard step there).
pub const CAUCHY_SCALE_FLOOR: f64 = 1e-6;

pub const CAUCHY_CAP_FORMULA: &str = "C + h (A - C): C = 1 - P(critical cone) / P(upper cap) of a spherical Cauchy lobe \
     at cosine m = clamp(mu + c8 alpha (1 - mu), 0, 1), stereographic scale \
     l = alpha (c0 + c1 alpha + c2 mu) + c9 sqrt(alpha) (1 - mu)^16 + 1e-6; P(cap of cosine cb, sine sb) = \
     (1 - u / sqrt(u^2 + w^2)) / 2, u = l^2 (m + cb) + cb - m, w = 2 l sb; critical cone cb = sqrt(1 - eta^2), \
     sb = eta; upper cap of half-angle tangent k = clamp(1 - alpha (c3 + c4 alpha), 0, 1): cb = (1 - k^2) / (1 + k^2), \
     sb = 2 k / (1 + k^2), u and w scaled by 1 + k^2; A = sqrt(1 - eta^2)^c5, h = min(c6 alpha^c7, 1)";

/// A share kept as `numerator / denominator`, so that the ratio of two shares costs one division.
#[derive(Clone, Copy)]
struct Fraction<R> {
    numerator: R,
    denominator: R,
}

impl<R: Real> Fraction<R> {
    fn value(self) -> R {
        self.numerator.div(self.denominator)
    }

    /// `self / other`; a vanishing `other` (an empty cap) gives a finite value, never 0/0.
    fn over(self, other: Fraction<R>) -> R {
        self.numerator.mul(other.denominator).div(self.denominator.mul(other.numerator).max(R::of(1e-37)))
    }
}

/// The share `(1 - u / sqrt(u^2 + w^2)) / 2` of a cap.
pub fn cap_share<R: Real>(u: R, w: R) -> R {
    cap_share_fraction(u, w).value()
}

/// [`cap_share`] as a fraction, without cancellation when `u > 0` (a cap far from the lobe) and
/// without a branch: with `s = sqrt(u^2 + w^2)` and `d = s + |u|`, `1 - u / s` is `d / s` for
/// `u <= 0` and `w^2 / (s d)` for `u > 0`, so the share is `(u > 0 ? w^2 : d^2) / (2 s d)`.
fn cap_share_fraction<R: Real>(u: R, w: R) -> Fraction<R> {
    // `u = w = 0` only for an empty cap on a zero-width lobe, which the scale floor excludes;
    // the floor on `s` keeps even that finite (share 1/2).
    let s = (u.mul(u) + w.mul(w)).sqrt().max(R::of(1e-30));
    let d = s + u.abs();
    Fraction { numerator: R::select(u > R::of(0.0), w.mul(w), d.mul(d)), denominator: R::of(2.0).mul(s).mul(d) }
}

/// TIR as the share of a spherical Cauchy lobe lying outside the critical cone.
///
/// Why this shape: GGX slopes have the density `1 / (pi l^2 (1 + r^2 / l^2)^2)`, which is the
/// stereographic image of the uniform distribution on the sphere scaled by `l`. At normal
/// incidence a half vector of slope `r` reflects the normal into a direction whose stereographic
/// radius `tan(theta_w / 2)` is `r` again, so the reflected lobe is exactly a spherical Cauchy
/// distribution (Kato & McCullagh 2020) of scale `l = alpha` (before the G1 weight). A stereographic
/// projection maps caps to disks, so the share of such a lobe in any cap is a closed form: for a
/// lobe centred at cosine `m` and a cap around the normal of cosine `cb` and sine `sb`, it is
/// `(1 - u / sqrt(u^2 + w^2)) / 2` with `u = l^2 (m + cb) + cb - m`, `w = 2 l sb` (the image cap's
/// angular radius `atan(r2 / l) - atan(r1 / l)`, with `r1,2 = tan((theta_m -+ theta_b) / 2)`,
/// after clearing denominators). TIR is `1 - P(critical cone) / P(upper cap)`, the critical cone
/// having `cb = sqrt(1 - eta^2)`, `sb = eta`. At `alpha = 0` this is the table's hard step; at
/// `eta = 0` the cone is empty (TIR = 1) and at `eta = 1` it is the upper cap (TIR = 0), the
/// table's exact edges, without a logit term.
///
/// Fitted corrections, each for a measured departure from the plain model (docs/fit.md):
/// - the scale grows with roughness and angle (`c0..c2`), and as `sqrt(alpha)` at grazing
///   incidence (`c9 (1 - mu)^16`): there the visible normals face the viewer and the reflected
///   lobe's tail toward the normal is one-dimensional (`~ alpha / r`), heavier than the model's;
/// - the lobe's centre moves toward the normal (`c8`): reflected directions below the horizon
///   have no weight, and visible normals tilt toward the viewer;
/// - the upper cap shrinks from the horizon, to the half-angle tangent `k = 1 - alpha (c3 + c4 alpha)`
///   of its angle to the normal (cosine `(1 - k^2) / (1 + k^2)`, sine `2 k / (1 + k^2)`): the G1
///   weight removes grazing directions, as a horizon raised by roughness would;
/// - rough lobes blend into the rough limit `(1 - eta^2)^(c5 / 2)`, independent of `mu` in the
///   table at `alpha = 1`, with weight `min(c6 alpha^c7, 1)`.
pub fn cauchy_cap<R: Real>(p: &[R], mu: R, alpha: R, eta: R) -> R {
    let (zero, one) = (R::of(0.0), R::of(1.0));
    let sqrt_alpha = alpha.max(zero).sqrt();
    let lobe = CauchyLobe::new([p[0], p[1], p[2], p[3], p[4], p[8], p[9]], mu, alpha, sqrt_alpha);
    let critical_cosine = (one - eta.mul(eta)).max(zero).sqrt();
    let narrow = (one - lobe.inside_share(critical_cosine, eta)).max(zero).min(one);
    let rough = critical_cosine.powf(p[5]);
    let blend = p[6].mul(alpha.powf(p[7])).min(one);
    narrow + blend.mul(rough - narrow)
}

/// The spherical Cauchy lobe of [`cauchy_cap`] and [`cauchy_slope`] at one `(mu, alpha)`, from its
/// coefficients `[scale_alpha, scale_alpha2, scale_alpha_mu, horizon_alpha, horizon_alpha2,
/// centre_alpha, scale_grazing]`.
struct CauchyLobe<R> {
    scale: R,
    centre: R,
    /// Half-angle tangent of the upper cap's angle to the normal (1 at the horizon).
    upper_cap_tangent: R,
}

impl<R: Real> CauchyLobe<R> {
    fn new(c: [R; 7], mu: R, alpha: R, sqrt_alpha: R) -> Self {
        let (zero, one) = (R::of(0.0), R::of(1.0));
        let grazing = {
            let g = one - mu;
            let g = g.mul(g);
            let g = g.mul(g);
            let g = g.mul(g);
            g.mul(g)
        };
        let scale = alpha.mul(c[0] + c[1].mul(alpha) + c[2].mul(mu)).max(zero)
            + c[6].mul(sqrt_alpha).mul(grazing)
            + R::of(CAUCHY_SCALE_FLOOR);
        let centre = (mu + c[5].mul(alpha).mul(one - mu)).max(zero).min(one);
        let upper_cap_tangent = (one - alpha.mul(c[3] + c[4].mul(alpha))).max(zero).min(one);
        CauchyLobe { scale, centre, upper_cap_tangent }
    }

    /// The lobe's share in a cap around the normal of cosine `cosine / norm` and sine
    /// `sine / norm`. [`cap_share`] depends on `u` and `w` only through their ratio, so a cap given
    /// this way (by its half-angle tangent, say) needs no square root and no division.
    fn share(&self, cosine: R, sine: R, norm: R) -> Fraction<R> {
        // `cosine - centre` first: it is exact where the two are equal, where adding the tiny
        // `scale^2` term first would round it away in f32 and leave `u = w = 0`.
        let centre = self.centre.mul(norm);
        let u = self.scale.mul(self.scale).mul(centre + cosine) + (cosine - centre);
        cap_share_fraction(u, R::of(2.0).mul(self.scale).mul(sine))
    }

    /// `P(critical cone) / P(upper cap)`: the share of the lobe's weight that is not past the
    /// critical angle.
    fn inside_share(&self, critical_cosine: R, eta: R) -> R {
        let (one, k) = (R::of(1.0), self.upper_cap_tangent);
        let k2 = k.mul(k);
        let upper = self.share(one - k2, R::of(2.0).mul(k), one + k2);
        self.share(critical_cosine, eta, one).over(upper)
    }
}

pub const CAUCHY_SLOPE_FORMULA: &str = "C + h (A - C): C = 1 - ((1 - f) Pc + f Ps), the shares inside the critical cone \
     (cosine cb = sqrt(1 - eta^2), sine eta) of a spherical Cauchy lobe (Pc, as in cauchy-cap with c0..c4, \
     centre c6, scale_grazing c7, no fitted exponents) and of the in-plane visible-slope lobe (Ps = S(cb) / S(0), \
     S(c) = (mu (r - t) + s^2) / r, t = (c - mu) / 2, r = sqrt(s^2 + t^2), s = c8 alpha + 1e-6); \
     f = (1 - mu) / (1 + c9 alpha)^2; A = cb^2 = 1 - eta^2, h = min(c5 alpha^(3/2), 1)";

/// The share of the in-plane lobe of visible slopes reflected above the cosine `cosine`, up to a
/// factor that does not depend on `cosine` (it cancels in [`cauchy_slope`]'s ratio).
///
/// At grazing incidence the microfacets seen are those tilted toward the viewer, and a facet
/// tilted by the in-plane slope `t` reflects the view to cosine `mu + 2 t` (small angles). GGX's
/// in-plane slope marginal is `p(t) = s^2 / (2 (s^2 + t^2)^(3/2))` (a Student t with two degrees
/// of freedom, the marginal of the slope density of Walter et al. 2007, eq. 33), and a facet is
/// seen in proportion to its projected area, `mu + t` in slope units (the distribution of visible
/// normals, Heitz 2014). So the weight reflected above `c` is `∫_{t0}^∞ (mu + t) p(t) dt =
/// (mu (r - t0) + s^2) / (2 r)`, with `t0 = (c - mu) / 2` and `r = sqrt(s^2 + t0^2)`: a tail
/// `~ s / (c - mu)`, heavier than the spherical Cauchy lobe's `~ s^2 / (c - mu)^2`, which is what
/// the table shows at grazing incidence just below `eta = 1`. Scaling `mu`, `t` and `s` by
/// `sin(theta_i)` turns the exact-angle version into this one with `s = alpha sin(theta_i)`.
pub fn slope_lobe_above<R: Real>(cosine: R, mu: R, scale: R) -> R {
    slope_lobe_above_fraction(cosine, mu, scale).value()
}

/// [`slope_lobe_above`] as a fraction, without cancellation in a far tail (`t > 0`) and without a
/// branch: with `e = r + |t|`, `r - t` is `e` for `t <= 0` and `s^2 / e` for `t > 0`, so the value is
/// `(t > 0 ? s^2 (mu + e) : (mu e + s^2) e) / (e r)`.
fn slope_lobe_above_fraction<R: Real>(cosine: R, mu: R, scale: R) -> Fraction<R> {
    let t = (cosine - mu).mul(R::of(0.5));
    let s2 = scale.mul(scale);
    let r = (s2 + t.mul(t)).sqrt();
    let e = r + t.abs();
    let numerator = R::select(t > R::of(0.0), s2.mul(mu + e), (mu.mul(e) + s2).mul(e));
    Fraction { numerator, denominator: e.mul(r) }
}

/// The floor of the slope lobe's scale, so that its shares stay defined at `alpha = 0`.
pub const SLOPE_SCALE_FLOOR: f64 = 1e-6;

/// TIR as the share of the reflected lobe past the critical angle, the lobe being the spherical
/// Cauchy lobe of [`cauchy_cap`] blended, toward grazing incidence and low roughness, with the
/// in-plane lobe of visible slopes ([`slope_lobe_above`]).
///
/// Why: [`cauchy_cap`]'s worst nodes (max error 0.13) were all at grazing views just below
/// `eta = 1` (critical cosines 0.1-0.4) with `alpha <= 0.05`, where the table exceeds the model by
/// up to 0.13: the reflected weight above the critical cosine falls off like `alpha / (c - mu)`
/// there, as the visible-slope lobe does, with no fitted shape. Each lobe's share is normalised by
/// its share above its horizon, so TIR stays exactly 0 at `eta = 1`. Rough lobes blend into the
/// limit of a cosine-like lobe, `P(w.z^2 < cb^2) = cb^2 = 1 - eta^2`, with weight
/// `h = c5 alpha^(3/2)`, where [`cauchy_cap`] fits both exponents (1.74 on `cb`, 1.35 on `alpha`):
/// fixed, they cost no `pow`, and the max error is lower (0.058 against 0.082 with `cb^(7/4)`, at
/// RMSE 0.0084 against 0.0063, SciPy prototype), which is what keeps the form cheaper than eq. 5.6
/// with the slope lobe added. For the same reason the slope scale is `c8 alpha` without the
/// `sin(theta_i)` of the exact-angle version (the fade leaves that lobe to grazing views, where
/// `sin(theta_i)` is near 1; max error 0.0588 without it against 0.0578 with it, SciPy), and the upper
/// cap is given by its half-angle tangent (no square root).
pub fn cauchy_slope<R: Real>(p: &[R], mu: R, alpha: R, eta: R) -> R {
    let (zero, one) = (R::of(0.0), R::of(1.0));
    let sqrt_alpha = alpha.max(zero).sqrt();
    let lobe = CauchyLobe::new([p[0], p[1], p[2], p[3], p[4], p[6], p[7]], mu, alpha, sqrt_alpha);
    let critical_cosine_squared = (one - eta.mul(eta)).max(zero);
    let critical_cosine = critical_cosine_squared.sqrt();
    let cauchy_inside = lobe.inside_share(critical_cosine, eta);
    let slope_scale = p[8].mul(alpha) + R::of(SLOPE_SCALE_FLOOR);
    let slope_inside = slope_lobe_above(critical_cosine, mu, slope_scale).div(slope_lobe_above(zero, mu, slope_scale));
    let fade = {
        let d = one + p[9].mul(alpha);
        (one - mu).div(d.mul(d))
    };
    let inside = cauchy_inside + fade.mul(slope_inside - cauchy_inside);
    let narrow = (one - inside).max(zero).min(one);
    let rough = critical_cosine_squared;
    let blend = p[5].mul(alpha).mul(sqrt_alpha).min(one);
    narrow + blend.mul(rough - narrow)
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

/// Thesis equation 5.6 (`docs/fit.md`), published or with its step and mean direction corrected.
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

/// Shader source of a fitted form with its coefficients baked in (`None` for the baselines, whose
/// shader is the thesis's own).
pub fn shader(form: Form, parameters: &[f64], language: ShaderLanguage) -> Option<String> {
    module(form, parameters).map(|m| m.print(language))
}

/// The fitted form as a module of the shader emitter: one description printed as HLSL and WGSL.
/// Coefficients are baked in as f32 literals (Rust's shortest text that reads back to the same f32).
pub fn module(form: Form, parameters: &[f64]) -> Option<Module> {
    if parameters.is_empty() || parameters.len() != form.parameter_names().len() {
        return None;
    }
    let c: Vec<f32> = parameters.iter().map(|&v| v as f32).collect();
    if matches!(form, Form::CauchyCap | Form::CauchySlope) {
        return Some(cauchy_module(form, &c));
    }
    let (mu, alpha, eta, t) = (name("mu"), name("alpha"), name("eta"), name("t"));
    let step = match form {
        Form::Logistic => f(1.0) / (f(1.0) + call(Builtin::Exp, vec![t.min(f(80.0))])),
        Form::Smoothstep => f(1.0) - call(Builtin::Smoothstep, vec![f(-1.0), f(1.0), t]),
        Form::Algebraic => f(0.5) - f(0.5) * t.clone() / (f(1.0) + t.clone() * t).sqrt(),
        Form::Rational => f(0.5) - f(0.5) * t.clone() / (f(1.0) + t.abs()),
        Form::Eq56 | Form::Eq56Corrected | Form::CauchyCap | Form::CauchySlope => return None,
    };
    let (floor, limit) = (WIDTH_FLOOR as f32, EDGE_LOGIT_LIMIT as f32);
    let mut m = Module::new(Parens::Minimal);
    m.comment(&format!(
        "tmlut fit tir: form '{name}', {formula}\n\
         width = alpha (c0 + c1 alpha + c2 mu) + {floor:?}, shift = alpha (c3 + c4 alpha + c5 mu^2),\n\
         plus c6 logit(eta^2) clamped to +-{limit:?}. c0..c6: the fit's `parameters`, in order\n\
         (manifest.json `fit` of the build; fit.json of `tmlut fit tir`), as f32.",
        name = form.name(),
        formula = form.formula(),
    ));
    let log = |e: Expr| call(Builtin::Log, vec![e]);
    let (eta2, shift, width) = (name("eta2"), name("shift"), name("width"));
    m.function(
        "tmlut_tir",
        vec![("mu", Ty::F32), ("alpha", Ty::F32), ("eta", Ty::F32)],
        Ty::F32,
        vec![
            local(
                "width",
                alpha.clone() * (f(c[0]) + f(c[1]) * alpha.clone() + f(c[2]) * mu.clone()).max(f(0.0)) + f(floor),
            ),
            local("shift", alpha.clone() * (f(c[3]) + f(c[4]) * alpha + f(c[5]) * mu.clone() * mu.clone())),
            local("eta2", eta.clone() * eta),
            local(
                "edge_logit",
                (log(eta2.clone().max(f(1e-30))) - log((f(1.0) - eta2.clone()).max(f(1e-30))))
                    .clamp(f(-limit), f(limit)),
            ),
            local("t", (mu.clone() * mu + eta2 - f(1.0) - shift) / width + f(c[6]) * name("edge_logit")),
            Stmt::Return(step),
        ],
    );
    Some(m)
}

/// An untyped scalar local (`float x = ...;` / `let x = ...;`), as the fitted forms print them.
fn local(n: &str, value: Expr) -> Stmt {
    Stmt::Let { name: n.to_string(), ty: Ty::F32, value, typed: false, precise: false }
}

/// [`cauchy_cap`] or [`cauchy_slope`] as a module, statement for statement, with coefficients `c`
/// baked in as named constants `c0..c9`.
fn cauchy_module(form: Form, c: &[f32]) -> Module {
    let pair = Ty::Vec(2);
    let pair_local =
        |n: &str, value: Expr| Stmt::Let { name: n.to_string(), ty: Ty::Vec(2), value, typed: false, precise: false };
    let n = name;
    let mut m = Module::new(Parens::Minimal);
    m.comment(&format!(
        "tmlut fit tir: form '{name}', {formula}\n\
         c0..c9: the fit's `parameters`, in order (manifest.json `fit` of the build; fit.json of\n\
         `tmlut fit tir`), as f32; the manifest's `definition` states every statement below.\n\
         Shares are (numerator, denominator) pairs, so that a ratio of two shares costs one division.",
        name = form.name(),
        formula = form.formula(),
    ));
    m.function(
        "tmlut_ratio",
        vec![("a", pair.clone()), ("b", pair.clone())],
        Ty::F32,
        vec![Stmt::Return(
            n("a").member("x") * n("b").member("y") / (n("a").member("y") * n("b").member("x")).max(f(1e-37)),
        )],
    );
    m.comment(
        "Share of a spherical Cauchy lobe in a cap: (1 - u / s) / 2, written without cancellation\n\
         for u > 0 as w^2 / (2 s d), d = s + |u|, and as d^2 / (2 s d) otherwise.",
    );
    m.function(
        "tmlut_cap_share",
        vec![("u", Ty::F32), ("w", Ty::F32)],
        pair.clone(),
        vec![
            local("s", (n("u") * n("u") + n("w") * n("w")).sqrt().max(f(1e-30))),
            local("d", n("s") + n("u").abs()),
            Stmt::Return(Expr::Construct(
                pair.clone(),
                vec![select(n("u").gt(f(0.0)), n("w") * n("w"), n("d") * n("d")), f(2.0) * n("s") * n("d")],
            )),
        ],
    );
    if form == Form::CauchySlope {
        m.comment(
            "Weight of the in-plane visible-slope lobe reflected above cosine c (up to a common factor):\n\
             (mu (r - t) + s^2) / r, with r - t written as s^2 / e for t > 0, e = r + |t|.",
        );
        m.function(
            "tmlut_slope_above",
            vec![("c", Ty::F32), ("mu", Ty::F32), ("s", Ty::F32)],
            pair.clone(),
            vec![
                local("t", f(0.5) * (n("c") - n("mu"))),
                local("s2", n("s") * n("s")),
                local("r", (n("s2") + n("t") * n("t")).sqrt()),
                local("e", n("r") + n("t").abs()),
                Stmt::Return(Expr::Construct(
                    pair.clone(),
                    vec![
                        select(n("t").gt(f(0.0)), n("s2") * (n("mu") + n("e")), (n("mu") * n("e") + n("s2")) * n("e")),
                        n("e") * n("r"),
                    ],
                )),
            ],
        );
    }
    let (centre, grazing) = if form == Form::CauchySlope { ("c6", "c7") } else { ("c8", "c9") };
    let mut body: Vec<Stmt> = c
        .iter()
        .enumerate()
        .map(|(k, &v)| Stmt::Let { name: format!("c{k}"), ty: Ty::F32, value: f(v), typed: true, precise: false })
        .collect();
    let (mu, alpha, eta) = (n("mu"), n("alpha"), n("eta"));
    let one_minus = |e: Expr| f(1.0) - e;
    let paren = |e: Expr| Expr::Paren(Box::new(e));
    body.extend([
        local("sqrt_alpha", alpha.clone().sqrt()),
        local("g2", one_minus(mu.clone()) * one_minus(mu.clone())),
        local("g4", n("g2") * n("g2")),
        local("g8", n("g4") * n("g4")),
        local(
            "scale",
            (alpha.clone() * (n("c0") + n("c1") * alpha.clone() + n("c2") * mu.clone())).max(f(0.0))
                + n(grazing) * n("sqrt_alpha") * (n("g8") * n("g8"))
                + f(CAUCHY_SCALE_FLOOR as f32),
        ),
        local("centre", (mu.clone() + n(centre) * alpha.clone() * one_minus(mu.clone())).clamp(f(0.0), f(1.0))),
        local("critical_cosine_squared", one_minus(eta.clone() * eta.clone()).max(f(0.0))),
        local("critical_cosine", n("critical_cosine_squared").sqrt()),
        local("k", one_minus(alpha.clone() * (n("c3") + n("c4") * alpha.clone())).clamp(f(0.0), f(1.0))),
        local("k2", n("k") * n("k")),
        local("upper_centre", n("centre") * (f(1.0) + n("k2"))),
        local("scale2", n("scale") * n("scale")),
        pair_local(
            "cone",
            func(
                "tmlut_cap_share",
                vec![
                    n("scale2") * (n("centre") + n("critical_cosine")) + (n("critical_cosine") - n("centre")),
                    f(2.0) * n("scale") * eta,
                ],
            ),
        ),
        pair_local(
            "upper",
            func(
                "tmlut_cap_share",
                vec![
                    n("scale2") * (n("upper_centre") + one_minus(n("k2")))
                        + (paren(one_minus(n("k2"))) - n("upper_centre")),
                    f(2.0) * n("scale") * (f(2.0) * n("k")),
                ],
            ),
        ),
        local("cauchy_inside", func("tmlut_ratio", vec![n("cone"), n("upper")])),
    ]);
    if form == Form::CauchySlope {
        let above = |c: Expr| func("tmlut_slope_above", vec![c, mu.clone(), n("slope_scale")]);
        body.extend([
            local("slope_scale", n("c8") * alpha.clone() + f(SLOPE_SCALE_FLOOR as f32)),
            local("slope_inside", func("tmlut_ratio", vec![above(n("critical_cosine")), above(f(0.0))])),
            local("fade_denominator", f(1.0) + n("c9") * alpha.clone()),
            local("fade", one_minus(mu.clone()) / (n("fade_denominator") * n("fade_denominator"))),
            local(
                "narrow",
                one_minus(n("cauchy_inside") + n("fade") * (n("slope_inside") - n("cauchy_inside")))
                    .clamp(f(0.0), f(1.0)),
            ),
            local("rough", n("critical_cosine_squared")),
            local("blend", (n("c5") * alpha * n("sqrt_alpha")).min(f(1.0))),
        ]);
    } else {
        let pow = |a: Expr, b: Expr| call(Builtin::Pow, vec![a, b]);
        body.extend([
            local("narrow", one_minus(n("cauchy_inside")).clamp(f(0.0), f(1.0))),
            local("rough", pow(n("critical_cosine"), n("c5"))),
            local("blend", (n("c6") * pow(alpha, n("c7"))).min(f(1.0))),
        ]);
    }
    body.push(Stmt::Return(n("narrow") + n("blend") * (n("rough") - n("narrow"))));
    m.function("tmlut_tir", vec![("mu", Ty::F32), ("alpha", Ty::F32), ("eta", Ty::F32)], Ty::F32, body);
    m
}

/// The language a fitted form's shader is printed in.
pub type ShaderLanguage = crate::shader::Lang;

#[cfg(test)]
#[path = "definition_tests.rs"]
pub(crate) mod definition_tests;
