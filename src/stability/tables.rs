//! The matrix over the table recipes: every table evaluated at the stiff `(mu, alpha, eta, kappa)`
//! points by both of its paths — the per-cell f64 estimator
//! ([`crate::recipes::driver::Kernel::estimate_node`]) and the fast f32 kernel the build uses — on
//! the same points, and held to its limits; then what half-float storage does to the values.
//! TIR's fast path is a deterministic quadrature over the reflected lobe: it is held to the
//! quadrature over microfacet normals, and Monte Carlo to it.
//!
//! Both paths evaluate `mu = 0` as the limit `mu -> 0+` at [`GRAZING_COSINE`], by design, so the
//! limits below are taken at `max(mu, GRAZING_COSINE)`.

use glam::DVec3;

use super::matrix::{ALPHAS, COSINES, ETAS, KAPPAS, label};
use super::properties::{self as p, Check};
use super::{Case, PrecisionDifference, Report};
use crate::config::TableKind;
use crate::error::Result;
use crate::formats::Precision;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, GRAZING_COSINE};
use crate::physics::{
    MaskingShadowing, critical_cosine, direction_from_cosine, fresnel_reflectance, reflect, schlick_weight,
};
use crate::recipes::belcour::{self, BelcourSettings};
use crate::recipes::fgd::FgdSettings;
use crate::recipes::fgd_rarer::FgdRarerSettings;
use crate::recipes::gd::GdSettings;
use crate::recipes::ggx_e::GgxESettings;
use crate::recipes::ggx_e_avg::GgxEAvgSettings;
use crate::recipes::karis::KarisSettings;
use crate::recipes::karis_multiscatter::KarisMultiscatterSettings;
use crate::recipes::tir::{TirSettings, tir_by_quadrature};
use crate::recipes::{Kernel, TableRecipe};
use crate::sampling::sequence::{PointSet, SamplePlan};
use crate::table::PerKind;

/// Samples per stiff node: 4 replicates of 1024 Owen-scrambled Sobol points, shared by both paths.
pub const SAMPLES: u64 = 1 << 12;
const REPLICATES: u32 = 4;
const SEED: u64 = 8;

/// The f32 kernel and the f64 estimator see the same points, so they differ only by rounding, by
/// the hat projection of the fast path, and (where the view direction is the normal) by the
/// rotated disk frame of the f32 warp. Allowed: this many combined replicate standard errors plus
/// [`PATH_ABSOLUTE_TOLERANCE`].
pub const PATH_STANDARD_ERRORS: f64 = 4.0;
pub const PATH_ABSOLUTE_TOLERANCE: f64 = 2e-4;

/// Monte Carlo estimates of an albedo may leave [0, 1] by rounding of the weights only.
const RANGE_SLACK: f64 = 1e-6;

/// The fast path's estimates may leave [0, 1] by as much as they may differ from the per-cell
/// path's: next to a critical angle its L2 projection of Fresnel on the hat basis overshoots
/// (FGD at `eta` 0.999999 and grazing views: down to -9.4e-6), which the tables clamp when they
/// store a value.
pub const FAST_PATH_RANGE_SLACK: f64 = PATH_ABSOLUTE_TOLERANCE;

/// Settings and points shared by every table's cases.
pub struct Evaluation {
    pub points: PointSet,
    /// The exact integrals the deterministic fast paths are held to.
    quadrature: VisibleNormalQuadrature,
    fgd: FgdSettings,
    fgd_rarer: FgdRarerSettings,
    gd: GdSettings,
    tir: TirSettings,
    belcour: BelcourSettings,
    karis: KarisSettings,
    ggx_e: GgxESettings,
    ggx_e_avg: GgxEAvgSettings,
    karis_multiscatter: KarisMultiscatterSettings,
}

impl Evaluation {
    pub fn new() -> Result<Self> {
        Ok(Evaluation {
            points: PointSet::new(SamplePlan::new(SAMPLES, REPLICATES)?, SEED),
            quadrature: VisibleNormalQuadrature::new(16)?,
            fgd: FgdSettings::default(),
            fgd_rarer: FgdRarerSettings::default(),
            gd: GdSettings::default(),
            // The cases are at (mu, alpha, eta) themselves, whatever axis the table stores.
            tir: TirSettings { eta_axis: crate::recipes::tir::EtaAxis::Eta, ..TirSettings::default() },
            belcour: BelcourSettings::default(),
            karis: KarisSettings::default(),
            ggx_e: GgxESettings::default(),
            ggx_e_avg: GgxEAvgSettings::default(),
            karis_multiscatter: KarisMultiscatterSettings::default(),
        })
    }
}

/// Run the cases of one table. Every table has its own, named in a `PerKind` whose literal names
/// every kind: a table added to the loader's list does not compile until its cases are written here.
pub fn run(kind: TableKind, evaluation: &Evaluation, report: &mut Report) {
    let cases: PerKind<fn(&Evaluation, &mut Report)> =
        PerKind { fgd, gd, tir, belcour, karis, fgd_rarer, ggx_e, ggx_e_avg, karis_multiscatter };
    cases.take(kind)(evaluation, report)
}

/// The view cosine both paths actually evaluate.
fn evaluated_cosine(mu: f64) -> f64 {
    mu.max(GRAZING_COSINE)
}

/// Both paths at one node, the checks every table shares (finite, in range, paths agree), and the
/// path difference recorded.
struct NodeResult {
    per_cell: Estimate,
    fast: Estimate,
    /// How far the two paths may differ.
    agreement: Agreement,
}

/// How far a node's two paths may differ.
enum Agreement {
    /// Monte Carlo on the same points: [`PATH_STANDARD_ERRORS`] combined replicate standard errors
    /// plus [`PATH_ABSOLUTE_TOLERANCE`].
    SamePoints,
    /// A deterministic fast path against Monte Carlo: this much, whatever the replicates' spread.
    Absolute(f64),
}

fn both_paths(
    recipe: &dyn TableRecipe,
    fast: impl Fn(&PointSet, &[f64]) -> Estimate,
    points: &PointSet,
    position: &[f64],
) -> NodeResult {
    NodeResult {
        per_cell: recipe.estimate_node(points, position),
        fast: fast(points, position),
        agreement: Agreement::SamePoints,
    }
}

/// Checks that hold for every channel of every table, and the path comparison.
fn common_checks(
    node: &NodeResult,
    channel_names: &[&str],
    in_unit_interval: &[bool],
    paths: &mut PrecisionDifference,
    at: &str,
) -> Vec<Check> {
    let mut checks = Vec::new();
    for (j, name) in channel_names.iter().enumerate() {
        let (v64, v32) = (node.per_cell.mean[j], node.fast.mean[j]);
        checks.push(named(p::finite(v64), name, "f64"));
        checks.push(named(p::finite(v32), name, "f32"));
        if in_unit_interval[j] {
            checks.push(named(p::unit_interval(v64, RANGE_SLACK), name, "f64"));
            checks.push(named(p::unit_interval(v32, FAST_PATH_RANGE_SLACK), name, "f32"));
        }
        let (property, tolerance) = match node.agreement {
            Agreement::SamePoints => {
                let combined = node.per_cell.standard_error[j].hypot(node.fast.standard_error[j]);
                ("f32 fast path agrees with f64 per-cell", PATH_STANDARD_ERRORS * combined + PATH_ABSOLUTE_TOLERANCE)
            }
            Agreement::Absolute(tolerance) => ("fast path agrees with f64 per-cell Monte Carlo", tolerance),
        };
        let agreement = named(p::close(property, v32, v64, tolerance), name, "");
        checks.push(agreement);
        paths.record(v32, v64, &format!("{at} {name}"));
    }
    checks
}

/// Prefix a check's detail with the channel and path it is about.
fn named(mut check: Check, channel: &str, path: &str) -> Check {
    check.detail = if path.is_empty() {
        format!("[{channel}] {}", check.detail)
    } else {
        format!("[{channel}, {path}] {}", check.detail)
    };
    check
}

fn values(node: &NodeResult) -> String {
    let f = |e: &Estimate| e.mean.iter().map(|v| format!("{v:.6e}")).collect::<Vec<_>>().join(", ");
    format!("f64 [{}], f32 [{}]", f(&node.per_cell), f(&node.fast))
}

/// The view cosines of a table's cases: the matrix, plus the critical cosines of `etas` (the
/// direction exactly at the critical angle).
fn view_cosines(etas: &[f64]) -> Vec<(f64, Option<f64>)> {
    let mut cosines: Vec<(f64, Option<f64>)> = COSINES.iter().map(|&mu| (mu, None)).collect();
    for &eta in etas {
        if let Some(critical) = critical_cosine(eta).filter(|&c| c > 0.0 && c < 1.0) {
            cosines.push((critical, Some(eta)));
        }
    }
    cosines
}

/// The indices probed at a view of [`view_cosines`]: a critical-angle cosine with its own `eta`
/// only, any other view with every one of `etas`.
fn etas_at_view(critical_of: Option<f64>, etas: &[f64]) -> impl Iterator<Item = f64> + '_ {
    etas.iter().copied().filter(move |&eta| critical_of.is_none_or(|e| e == eta))
}

/// A case at `(mu, alpha, eta)`, `mu` marked where it is the critical cosine of `eta`.
fn view_label(mu: f64, critical_of: Option<f64>, alpha: f64, eta: f64) -> String {
    let critical = if critical_of.is_some() { " (critical)" } else { "" };
    format!("mu={}{critical} alpha={} eta={}", label(mu), label(alpha), label(eta))
}

fn fgd(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.fgd;
    let points = &evaluation.points;
    let mut paths = PrecisionDifference::new("fgd: fast f32 kernel vs per-cell f64", 1e-3);
    for &alpha in &ALPHAS {
        for (mu, critical_of) in view_cosines(&ETAS) {
            let gd = evaluation.gd.estimate_node(points, &[mu, alpha]).mean[0];
            for eta in etas_at_view(critical_of, &ETAS) {
                for &kappa in &KAPPAS {
                    let position = [mu, alpha, eta, kappa];
                    let node =
                        both_paths(settings, |pts, pos| settings.estimate_node_fast(pts, pos), points, &position);
                    let at = format!("{} kappa={}", view_label(mu, critical_of, alpha, eta), label(kappa));
                    let mut case = Case::new("fgd", &at, values(&node));
                    case.checks = common_checks(&node, &["fgd"], &[true], &mut paths, &at);
                    let (v64, v32) = (node.per_cell.mean[0], node.fast.mean[0]);
                    case.checks.push(p::at_most("FGD <= GD (F <= 1), same points", v64, gd, 1e-12));
                    let mirror = fresnel_reflectance(evaluated_cosine(mu), eta, kappa);
                    if alpha == 0.0 {
                        case.checks.push(named(
                            p::close("alpha = 0: the mirror value F(mu)", v64, mirror, 1e-12),
                            "fgd",
                            "f64",
                        ));
                        case.checks.push(named(
                            p::close("alpha = 0: the mirror value F(mu)", v32, mirror, 1e-12),
                            "fgd",
                            "f32",
                        ));
                    } else if alpha == 1e-7 && critical_of.is_some() {
                        case.checks.push(Check::limitation(
                            "alpha -> 0: near the mirror value",
                            format!("at the critical angle F has a square-root kink, so the lobe's average converges to F(mu) only like sqrt(alpha): {v64:.4e} vs {mirror:.4e}"),
                        ));
                    } else if alpha == 1e-7 {
                        case.checks.push(near_mirror(mu, alpha, v64, mirror));
                    }
                    if eta == 1.0 && kappa == 0.0 {
                        case.checks.push(named(p::exact("no interface: FGD = 0", v64, 0.0), "fgd", "f64"));
                        case.checks.push(named(p::close("no interface: FGD = 0", v32, 0.0, 1e-12), "fgd", "f32"));
                    }
                    if kappa == 100.0 {
                        // Not 0.99: near grazing the pseudo-Brewster dip of Rp keeps
                        // 1 - F ~ 4 eta / (kappa^2 c) (see the Fresnel cases).
                        case.checks.push(p::within("kappa -> inf: FGD -> GD (>= 0.9 GD)", v64, 0.9 * gd, gd + 1e-12));
                    }
                    report.cases.push(case);
                }
            }
        }
    }
    report.precision.push(paths);
}

/// The limit alpha -> 0 (the mirror value) at a small alpha: reached where `alpha tan(theta) << 1`,
/// i.e. `alpha <= 1e-3 mu`, within 1e-3. Closer to the horizon masking still acts however small
/// alpha is (G1 -> 0 at mu -> 0 for every alpha > 0, 1 at alpha = 0): the limit is not uniform in
/// mu, and the point is stated as a limitation.
fn near_mirror(mu: f64, alpha: f64, value: f64, mirror: f64) -> Check {
    const PROPERTY: &str = "alpha -> 0: near the mirror value";
    let mu = evaluated_cosine(mu);
    if alpha <= 1e-3 * mu {
        p::close(PROPERTY, value, mirror, 1e-3)
    } else {
        Check::limitation(
            PROPERTY,
            format!(
                "alpha tan(theta) = {:.1e} is not small at mu = {mu:e}: masking acts (value {value:.4e}, mirror {mirror:.4e}); the limit alpha -> 0 is not uniform near the horizon",
                alpha * ((1.0 - mu) * (1.0 + mu)).sqrt() / mu
            ),
        )
    }
}

/// The cases of a table of the GGX albedo without Fresnel (GD, `ggx_e`; channel `channel`) at every
/// stiff `(mu, alpha)`: both paths (`fast` the f32 kernel), the checks every table has, a mirror's
/// 1 and its limit, and the table's own (`own_checks(case, node, position)`).
fn albedo_cases(
    evaluation: &Evaluation,
    report: &mut Report,
    recipe: &dyn TableRecipe,
    fast: impl Fn(&PointSet, &[f64]) -> Estimate,
    channel: &str,
    own_checks: impl Fn(&mut Case, &NodeResult, &[f64]),
) {
    let table = recipe.name();
    let mut paths = PrecisionDifference::new(format!("{table}: fast f32 kernel vs per-cell f64"), 1e-3);
    for &alpha in &ALPHAS {
        for &mu in &COSINES {
            let position = [mu, alpha];
            let node = both_paths(recipe, &fast, &evaluation.points, &position);
            let at = format!("mu={} alpha={}", label(mu), label(alpha));
            let mut case = Case::new(table, &at, values(&node));
            case.checks = common_checks(&node, &[channel], &[true], &mut paths, &at);
            own_checks(&mut case, &node, &position);
            if alpha == 0.0 {
                for (path, estimate) in [("f64", &node.per_cell), ("f32", &node.fast)] {
                    let check = p::exact("alpha = 0: a mirror loses nothing", estimate.mean[0], 1.0);
                    case.checks.push(named(check, channel, path));
                }
            } else if alpha <= 1e-4 {
                case.checks.push(near_mirror(mu, alpha, node.per_cell.mean[0], 1.0));
            }
            report.cases.push(case);
        }
    }
    report.precision.push(paths);
}

fn gd(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.gd;
    let fast = |pts: &PointSet, pos: &[f64]| settings.estimate_node_fast(pts, pos);
    albedo_cases(evaluation, report, settings, fast, "gd", |_, _, _| {});
}

/// E with F = 1: GD's cases, and never below GD on the same points where it is height-correlated
/// (that masking hides less than separable: `1 / (1 + Λ(wi) + Λ(wo)) >= 1 / ((1 + Λ(wi)) (1 +
/// Λ(wo)))` sample by sample).
fn ggx_e(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.ggx_e;
    let fast = |pts: &PointSet, pos: &[f64]| settings.estimate_node_fast(pts, pos);
    albedo_cases(evaluation, report, settings, fast, "e", |case, node, position| {
        if settings.masking == MaskingShadowing::SmithHeightCorrelated {
            let gd = evaluation.gd.estimate_node(&evaluation.points, position).mean[0];
            let check =
                p::at_most("height-correlated E >= separable GD, same points", gd, node.per_cell.mean[0], 1e-12);
            case.checks.push(named(check, "e", "f64"));
        }
    });
}

/// How close to 1 the average over the hemisphere of a lobe of `alpha <= 1e-4` must be: only views
/// within `mu ~ alpha` of grazing lose energy, and they weigh `alpha^2` in the average.
const SMOOTH_AVERAGE_TOLERANCE: f64 = 1e-6;

/// E_avg at every stiff `alpha`: both paths (each the rule over views of E estimated on the same
/// points), a mirror's 1 and its limit, and the exact average.
fn ggx_e_avg(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.ggx_e_avg;
    let points = &evaluation.points;
    let mut paths = PrecisionDifference::new("ggx_e_avg: fast f32 kernel vs per-cell f64", 1e-3);
    // Within 3e-7 of 16 nodes per panel (`ggx_e_avg::tests`), at an eighth of their cost: the rule
    // over views has panels down to alpha / 2, some 200 views at alpha = 1e-7.
    let quadrature = VisibleNormalQuadrature::new(8).expect("8 nodes per panel");
    for &alpha in &ALPHAS {
        let position = [alpha];
        let node = both_paths(settings, |pts, pos| settings.estimate_node_fast(pts, pos), points, &position);
        let at = format!("alpha={}", label(alpha));
        let mut case = Case::new("ggx_e_avg", &at, values(&node));
        case.checks = common_checks(&node, &["e_avg"], &[true], &mut paths, &at);
        let (v64, v32) = (node.per_cell.mean[0], node.fast.mean[0]);
        let exact = settings.exact_value(&quadrature, &position)[0];
        let tolerance = PATH_STANDARD_ERRORS * node.per_cell.standard_error[0] + PATH_ABSOLUTE_TOLERANCE;
        case.checks.push(named(p::close("the exact average (quadrature)", v64, exact, tolerance), "e_avg", "f64"));
        if alpha == 0.0 {
            for (path, value) in [("f64", v64), ("f32", v32)] {
                case.checks.push(named(
                    p::close("alpha = 0: a mirror loses nothing", value, 1.0, 1e-12),
                    "e_avg",
                    path,
                ));
            }
        } else if alpha <= 1e-4 {
            case.checks.push(named(p::close("alpha -> 0: near 1", v64, 1.0, SMOOTH_AVERAGE_TOLERANCE), "e_avg", "f64"));
        }
        report.cases.push(case);
    }
    report.precision.push(paths);
}

/// How close to 1/2 a lobe of `tir::LIMIT_ROUGHNESS` seen at a critical angle must be: its
/// deviation is O(alpha) plus the sampling error of a half-split (4 standard errors of 2^12 samples).
const LIMIT_HALF_TOLERANCE: f64 = 0.01;

/// The fast path (exact to 2e-6) against Monte Carlo with [`SAMPLES`] points: up to 1.8e-3 at the
/// normal view of the roughest lobe, where the replicates' spread (6e-6) understates the error.
const TIR_MONTE_CARLO_TOLERANCE: f64 = 5e-3;
/// The lobe quadrature against the quadrature over microfacet normals (16 nodes per panel): two
/// deterministic rules for one integral (`tir::the_lobe_column_agrees_with_the_quadrature_over_normals`).
const TIR_QUADRATURE_TOLERANCE: f64 = 1e-5;

/// How close to the mirror step the fast path's lobe of `tir::LIMIT_ROUGHNESS` must be away from a
/// critical view: GGX's tails reach back over the critical angle, 7.1e-6 of the lobe at a grazing
/// view 0.0014 rad from it (which the quadrature over normals confirms).
const LIMIT_TAIL_TOLERANCE: f64 = 1e-5;

fn tir(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.tir;
    let points = &evaluation.points;
    let etas: Vec<f64> = ETAS.iter().copied().filter(|&e| e <= 1.0).collect();
    let mut paths = PrecisionDifference::new("tir: fast lobe quadrature vs per-cell f64 Monte Carlo", 1e-3);
    for &alpha in &ALPHAS {
        for (mu, critical_of) in view_cosines(&etas) {
            for eta in etas_at_view(critical_of, &etas) {
                let position = [mu, alpha, eta];
                let node = NodeResult {
                    per_cell: settings.estimate_node(points, &position),
                    fast: settings.estimate_node_fast(&position),
                    agreement: Agreement::Absolute(TIR_MONTE_CARLO_TOLERANCE),
                };
                let at = view_label(mu, critical_of, alpha, eta);
                let mut case = Case::new("tir", &at, values(&node));
                case.checks = common_checks(&node, &["tir"], &[true], &mut paths, &at);
                let (v64, v32) = (node.per_cell.mean[0], node.fast.mean[0]);
                // The fast path against the other quadrature, over the microfacet normals.
                let (evaluated_mu, evaluated_eta) = (evaluated_cosine(mu), settings.evaluated_eta(eta));
                let normals = tir_by_quadrature(&evaluation.quadrature, evaluated_mu, alpha, evaluated_eta);
                case.checks.push(named(
                    p::close(
                        "fast lobe quadrature agrees with the quadrature over normals",
                        v32,
                        normals,
                        TIR_QUADRATURE_TOLERANCE,
                    ),
                    "tir",
                    "fast",
                ));
                if eta == 1.0 {
                    case.checks.push(named(p::exact("eta = 1: no critical angle, TIR = 0", v64, 0.0), "tir", "f64"));
                    case.checks.push(named(p::exact("eta = 1: no critical angle, TIR = 0", v32, 0.0), "tir", "f32"));
                }
                if alpha == 0.0 {
                    // The limit alpha -> 0+ (`tir::LIMIT_ROUGHNESS`): half the lobe is past a critical
                    // view; elsewhere the mirror step, and 1 at the normal for eta = 0, whose
                    // critical cone is the normal alone.
                    let wi = direction_from_cosine(evaluated_cosine(mu));
                    let wo = reflect(wi, DVec3::Z);
                    let past = wo.x * wo.x + wo.y * wo.y > eta * eta || eta == 0.0;
                    let property = "alpha = 0: the limit of narrow lobes (the step [mu < mu*]; 1/2 at a critical view)";
                    // The Monte Carlo path sees none of GGX's tails; the quadrature sees them whole.
                    for (path, value, off_step) in [("f64", v64, 0.0), ("fast", v32, LIMIT_TAIL_TOLERANCE)] {
                        let check = if critical_of.is_some() {
                            p::close(property, value, 0.5, LIMIT_HALF_TOLERANCE)
                        } else if off_step == 0.0 {
                            p::exact(property, value, if past { 1.0 } else { 0.0 })
                        } else {
                            p::close(property, value, if past { 1.0 } else { 0.0 }, off_step)
                        };
                        case.checks.push(named(check, "tir", path));
                    }
                }
                report.cases.push(case);
            }
        }
    }
    report.precision.push(paths);
}

/// FGD onto a rarer medium at the stiff `(mu, alpha, eta < 1)` points, the critical views
/// included: both paths, and the same integral as the 4D table's at `kappa = 0`.
fn fgd_rarer(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.fgd_rarer;
    let points = &evaluation.points;
    let etas: Vec<f64> = ETAS.iter().copied().filter(|&e| e < 1.0).collect();
    let mut paths = PrecisionDifference::new("fgd_rarer: fast f32 kernel vs per-cell f64", 1e-3);
    for &alpha in &ALPHAS {
        for (mu, critical_of) in view_cosines(&etas) {
            for eta in etas_at_view(critical_of, &etas) {
                let position = [mu, alpha, crate::table::derived::critical_angle_fraction(evaluated_cosine(mu), eta)];
                let node = both_paths(settings, |pts, pos| settings.estimate_node_fast(pts, pos), points, &position);
                let at = view_label(mu, critical_of, alpha, eta);
                let mut case = Case::new("fgd_rarer", &at, values(&node));
                case.checks = common_checks(&node, &["fgd"], &[true], &mut paths, &at);
                let four_d = evaluation.fgd.estimate_node(points, &[mu, alpha, eta, 0.0]).mean[0];
                case.checks.push(named(
                    p::close(
                        "the 4D FGD table's integral at kappa = 0, same points",
                        node.per_cell.mean[0],
                        four_d,
                        1e-9,
                    ),
                    "fgd",
                    "f64",
                ));
                report.cases.push(case);
            }
        }
    }
    report.precision.push(paths);
}

/// The cases of a split-sum table stored in f16 (`table`, channels `names`, those in [0, 1]
/// marked in `in_unit_interval`) at every `(mu, alpha)`: both paths (`fast` the f32 kernel), the
/// checks every table has, the table's own (`own_checks(case, node, mu, alpha)`) and those of its
/// half-float storage.
fn split_sum_cases(
    evaluation: &Evaluation,
    report: &mut Report,
    recipe: &dyn TableRecipe,
    fast: impl Fn(&PointSet, &[f64]) -> Estimate,
    names: &[&str],
    in_unit_interval: &[bool],
    own_checks: impl Fn(&mut Case, &NodeResult, f64, f64),
) {
    let table = recipe.name();
    let mut paths = PrecisionDifference::new(format!("{table}: fast f32 kernel vs per-cell f64"), 1e-3);
    let mut storage = PrecisionDifference::new(format!("{table}: f16 storage vs f32 values"), 6.1e-5);
    for &alpha in &ALPHAS {
        for &mu in &COSINES {
            let node = both_paths(recipe, &fast, &evaluation.points, &[mu, alpha]);
            let at = format!("mu={} alpha={}", label(mu), label(alpha));
            let mut case = Case::new(table, &at, values(&node));
            case.checks = common_checks(&node, names, in_unit_interval, &mut paths, &at);
            own_checks(&mut case, &node, mu, alpha);
            case.checks.extend(half_float_checks(&node.fast.mean, names, &mut storage, &at));
            report.cases.push(case);
        }
    }
    report.precision.push(paths);
    report.precision.push(storage);
}

fn belcour(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.belcour;
    let basis = belcour::basis();
    let names = ["b0", "b1", "b2", "b3"];
    let fast = |pts: &PointSet, pos: &[f64]| settings.estimate_node_fast(pts, pos);
    split_sum_cases(
        evaluation,
        report,
        settings,
        fast,
        &names,
        &[true, true, false, false],
        |case, node, mu, alpha| {
            let b0 = node.per_cell.mean[0];
            for (k, name) in names.iter().enumerate().skip(1) {
                // |b_k| <= 1 pointwise, so each channel is bounded by the albedo b0.
                case.checks.push(named(
                    p::at_most("|LUT_k| <= LUT_0", node.per_cell.mean[k].abs(), b0, 1e-12),
                    name,
                    "f64",
                ));
            }
            if alpha == 0.0 {
                for (k, name) in names.iter().enumerate() {
                    let mirror = basis.evaluate(k, evaluated_cosine(mu));
                    case.checks.push(named(
                        p::close("alpha = 0: the mirror value b_k(mu)", node.per_cell.mean[k], mirror, 1e-12),
                        name,
                        "f64",
                    ));
                    // The f32 kernel rounds c = wi.h to f32: 1e-6 is what that allows.
                    case.checks.push(named(
                        p::close("alpha = 0: the mirror value b_k(mu)", node.fast.mean[k], mirror, 1e-6),
                        name,
                        "f32",
                    ));
                }
            }
        },
    );
}

fn karis(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.karis;
    let fast = |pts: &PointSet, pos: &[f64]| settings.estimate_node_fast(pts, pos);
    // Schlick–Smith is an approximation of Smith, and its albedo scale + bias may exceed 1
    // slightly; each term on its own is in [0, 1] only up to that.
    split_sum_cases(evaluation, report, settings, fast, &["scale", "bias"], &[false, true], |case, node, mu, alpha| {
        let total = node.per_cell.mean[0] + node.per_cell.mean[1];
        case.checks.push(p::within("scale + bias in [0, 1.05] (Schlick–Smith albedo)", total, 0.0, 1.05));
        if alpha == 0.0 {
            let fc = schlick_weight(evaluated_cosine(mu));
            // The f32 kernel rounds c = wi.h to f32: 1e-6 is what that allows.
            for (path, estimate, tolerance) in [("f64", &node.per_cell, 1e-12), ("f32", &node.fast, 1e-6)] {
                case.checks.push(named(
                    p::close("alpha = 0: 1 - Fc(mu)", estimate.mean[0], 1.0 - fc, tolerance),
                    "scale",
                    path,
                ));
                case.checks.push(named(p::close("alpha = 0: Fc(mu)", estimate.mean[1], fc, tolerance), "bias", path));
            }
        }
    });
}

/// The multiple-scattering split sum: the split-sum cases, `bias <= albedo` (`Fc <= 1` sample by
/// sample), and at `alpha = 0` the mirror's `(Fc(mu), 1)`.
fn karis_multiscatter(evaluation: &Evaluation, report: &mut Report) {
    let settings = &evaluation.karis_multiscatter;
    let fast = |pts: &PointSet, pos: &[f64]| settings.estimate_node_fast(pts, pos);
    let names = ["bias", "albedo"];
    split_sum_cases(evaluation, report, settings, fast, &names, &[true, true], |case, node, mu, alpha| {
        let (bias, albedo) = (node.per_cell.mean[0], node.per_cell.mean[1]);
        case.checks.push(named(p::at_most("bias <= albedo (Fc <= 1)", bias, albedo, 1e-12), "bias", "f64"));
        if alpha == 0.0 {
            let fc = schlick_weight(evaluated_cosine(mu));
            // The f32 kernel rounds c = wi.h to f32: 1e-6 is what that allows.
            for (path, estimate, tolerance) in [("f64", &node.per_cell, 1e-12), ("f32", &node.fast, 1e-6)] {
                let bias = p::close("alpha = 0: Fc(mu)", estimate.mean[0], fc, tolerance);
                case.checks.push(named(bias, "bias", path));
                let albedo = p::close("alpha = 0: a mirror loses nothing", estimate.mean[1], 1.0, tolerance);
                case.checks.push(named(albedo, "albedo", path));
            }
        }
    });
}

/// What storing values as half floats does to them: still finite, never moved out of [0, 1] if
/// they were in it, and within half a step of the value (2^-11 relative for normal half floats,
/// 2^-25 absolute in the subnormal range below 6.1e-5).
fn half_float_checks(values: &[f64], names: &[&str], storage: &mut PrecisionDifference, at: &str) -> Vec<Check> {
    let mut checks = Vec::new();
    for (&v, name) in values.iter().zip(names) {
        let stored_f32 = v as f32;
        let stored = Precision::F16.round(stored_f32) as f64;
        storage.record(stored, stored_f32 as f64, &format!("{at} {name}"));
        checks.push(named(Check::new("f16: finite", stored.is_finite(), format!("{v:e} -> {stored:e}")), name, "f16"));
        if (0.0..=1.0).contains(&v) {
            checks.push(named(p::unit_interval(stored, 0.0), name, "f16"));
        }
        let bound = (stored_f32 as f64).abs() * 2f64.powi(-11) + 2f64.powi(-25);
        checks.push(named(p::close("f16: within half a step", stored, stored_f32 as f64, bound), name, "f16"));
    }
    checks
}

/// Half-float storage at its own stiff points: zero, the subnormal range, the smallest normal,
/// the last steps below 1, 1, the largest finite half, and past it.
pub fn half_float(report: &mut Report) {
    const SMALLEST_NORMAL: f32 = 6.103_515_6e-5;
    let stiff: [f32; 12] =
        [0.0, 1e-8, 2.9e-8, 6.0e-8, 3.0e-5, SMALLEST_NORMAL, 0.5, 1.0 - 2.4e-4, 1.0 - 2.5e-4, 1.0 - 1e-7, 1.0, 65504.0];
    let mut largest_change_near_one = 0.0f64;
    for v in stiff {
        let stored = Precision::F16.round(v);
        let change = (stored as f64 - v as f64).abs();
        if (0.5..=1.0).contains(&v) {
            largest_change_near_one = largest_change_near_one.max(change);
        }
        let kind = if stored == 0.0 && v != 0.0 {
            "flushed to 0 (below half the smallest subnormal, 2^-25)"
        } else if stored != 0.0 && (stored.abs()) < SMALLEST_NORMAL {
            "subnormal (kept, 2^-24 steps)"
        } else {
            "normal"
        };
        let bound = (v as f64).abs() * 2f64.powi(-11) + 2f64.powi(-25);
        let mut case = Case::new("Precision::F16.round", format!("v={v:e}"), format!("{stored:e}, {kind}"))
            .with(Check::new("finite", stored.is_finite(), format!("{stored:e}")))
            .with(p::close("within half a step", stored as f64, v as f64, bound));
        if (0.0..=1.0).contains(&v) {
            case = case.with(p::unit_interval(stored as f64, 0.0));
        }
        report.cases.push(case);
    }
    let beyond = Precision::F16.round(65520.0);
    report.cases.push(
        Case::new("Precision::F16.round", "v=65520 (past the largest half)", format!("{beyond:e}")).with(
            Check::limitation(
                "finite",
                format!(
                    "half floats end at 65504: larger values round to {beyond}; no table stores values above 1 (every table value is checked finite after rounding)"
                ),
            ),
        ),
    );
    report.notes.push(format!(
        "f16: the largest change of a value in [0.5, 1] is {largest_change_near_one:.2e} (half a step of 4.9e-4); values within 2.4e-4 of 1 are stored as 1.0. Values below 6.1e-5 are stored as subnormals (steps of 6.0e-8), not flushed; below 3.0e-8 they round to 0."
    ));
}
