//! Deterministic quadrature over the visible normals of a `(mu, alpha)` cell: a product
//! Gauss–Legendre rule in the polar angles `(theta, phi)` of the microfacet normal `h`, with every
//! place where the integrand jumps or kinks located in closed form and made a panel edge.
//!
//! The integral is the one the Monte Carlo estimators of [`super`] average,
//! `E_{h ~ D_wi}[f(h)]` with the visible-normal density `D_wi(h) = G1(wi) max(0, wi.h) D(h) / mu`
//! (Heitz 2018, eq. 2), written as
//!
//! ```text
//! E[f] = ∫ f(h) max(0, wi.h) D(h) dω_h / ∫ max(0, wi.h) D(h) dω_h,
//! D(h) ∝ alpha^2 / (alpha^2 cos^2(theta) + sin^2(theta))^2    (GGX, Walter et al. 2007, eq. 33),
//! ```
//!
//! so that the normalisation `G1(wi) / mu` (which vanishes with `mu`) never enters, and a constant
//! integrates to exactly 1. With `wi = (sin(theta_i), 0, cos(theta_i))`, everything the tables'
//! integrands cut on is linear in `cos(phi)` at a fixed `theta`:
//!
//! - `wi.h = sin(theta) sin(theta_i) cos(phi) + cos(theta) cos(theta_i)`: the visible half
//!   (`wi.h >= 0`) and the cosine at which Fresnel has its critical-angle kink;
//! - `wo.z = 2 (wi.h) cos(theta) - cos(theta_i)` for the mirror direction `wo = reflect(wi, h)`: the
//!   horizon (`wo.z = 0`) and TIR's critical cosine.
//!
//! So each inner `phi` interval is split at `acos` of a closed-form value, and each line of
//! constant `theta` integrates only smooth pieces. The split points change in kind (appear,
//! vanish, reach `phi = pi`) where the cut meets the plane of incidence, at `theta` solving
//! `cos(2 theta ∓ theta_i) = z` (`wo.z = z` at `phi = 0, pi`: the mirror angle is `2 theta ∓
//! theta_i`), `cos(theta ∓ theta_i) = c` (`wi.h = c`) and `cos(theta + theta_i) = 0` (the visible
//! half reaches `phi = pi`); those `theta` are panel edges of the outer rule. At each edge the
//! inner integral behaves like a square root (`acos` near ±1), and both rules map every panel
//! through `x = a + (b - a)(3u^2 - 2u^3)`, whose derivative vanishes at both ends, so that such an
//! endpoint is smooth in `u` (the same substitution smooths Fresnel's `sqrt(c - c_crit)` cusp at a
//! split).
//!
//! The outer panels also follow the roughness: `D` has its scale `alpha` in `theta`, the integrands
//! theirs at angles of order 1, so the `theta` panels grow geometrically from `alpha / 2` and no
//! panel is wider than [`MAX_PANEL_WIDTH`].
//!
//! The answer depends only on the cell, the cuts, the integrand and the rule, evaluated in one
//! fixed order: the same bits on every thread and in every batch.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

use super::{GRAZING_COSINE, MicrofacetSample};
use crate::error::{Error, Result};
use crate::physics::{MaskingShadowing, direction_from_cosine, reflect};

/// The widest outer (`theta`) panel, in radians.
const MAX_PANEL_WIDTH: f64 = 0.4;
/// The widest inner (`phi`) panel, in radians.
const MAX_INNER_PANEL_WIDTH: f64 = 0.8;

/// Gauss–Legendre nodes per panel of the exact integrals by default (`docs/furnace.md`,
/// "Libraries", measures what more would change).
pub const DEFAULT_NODES: usize = 8;

/// The fewest and most Gauss–Legendre nodes per panel a rule accepts.
pub const NODES: std::ops::RangeInclusive<usize> = 2..=64;

/// A surface in the space of microfacet normals across which an integrand jumps or kinks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cut {
    /// `wo.z = z` for the mirror direction `wo` of `wi` about `h`, `0 <= z < 1`: the horizon
    /// (`z = 0`), or the critical cosine of total internal reflection.
    MirrorCosine(f64),
    /// `wi.h = c`, `0 < c < 1`: the cosine at which Fresnel reaches total internal reflection.
    HalfCosine(f64),
}

/// A Gauss–Legendre rule of a fixed number of nodes per panel, with the endpoint-smoothing map.
#[derive(Debug, Clone)]
pub struct VisibleNormalQuadrature {
    /// Per node of the unit panel: the position `S(u)` and the weight `w(u) S'(u)`.
    unit_panel: Vec<(f64, f64)>,
    /// The plain rule, per node `(u, w(u))`: for [`ReflectedLobe`], whose panels hold no endpoint
    /// singularity to smooth.
    plain_panel: Vec<(f64, f64)>,
    /// Per node of the plain rule, `P_k(2u - 1)` for `k` below the node count: a panel's terms
    /// projected on the Legendre polynomials ([`ReflectedLobe::share_beyond`]).
    legendre_at_nodes: Vec<Vec<f64>>,
    /// The inner nodes over the whole half circle `[0, pi]`: the piece of every line of constant
    /// `theta` that no cut crosses and that sees the whole visible half, common near the normal
    /// and the same at each, so that its sines and cosines are computed once.
    half_circle: InnerNodes,
}

/// Whether an integrand reads the components of `h` and `wo` across the plane of incidence, which
/// need the sine of each azimuth node.
#[derive(Debug, Clone, Copy, PartialEq)]
enum AzimuthSine {
    Used,
    Unused,
}

/// The inner (`phi`) nodes of one piece between split points: its panels' width, and per node in
/// order `(sin(phi), cos(phi), w(u) S'(u))`.
#[derive(Debug, Clone, Default)]
struct InnerNodes {
    width: f64,
    nodes: Vec<(f64, f64, f64)>,
}

impl VisibleNormalQuadrature {
    /// The rule with `nodes` Gauss–Legendre nodes per panel (in [`NODES`]).
    pub fn new(nodes: usize) -> Result<Self> {
        if !NODES.contains(&nodes) {
            return Err(Error::invalid(
                "quadrature nodes",
                format!("{nodes}: must be from {} to {}", NODES.start(), NODES.end()),
            ));
        }
        let plain_panel = gauss_legendre_unit(nodes);
        let unit_panel = plain_panel.iter().map(|&(u, w)| (u * u * (3.0 - 2.0 * u), w * 6.0 * u * (1.0 - u))).collect();
        let legendre_at_nodes = plain_panel.iter().map(|&(u, _)| legendre_polynomials(2.0 * u - 1.0, nodes)).collect();
        let mut quadrature =
            VisibleNormalQuadrature { unit_panel, plain_panel, legendre_at_nodes, half_circle: InnerNodes::default() };
        let mut half_circle = InnerNodes::default();
        quadrature.inner_nodes(0.0, PI, AzimuthSine::Used, &mut half_circle);
        quadrature.half_circle = half_circle;
        Ok(quadrature)
    }

    /// The inner nodes of the piece `[c, d]`, in panels no wider than [`MAX_INNER_PANEL_WIDTH`],
    /// into `out`; with `sine` [`AzimuthSine::Unused`], every node's `sin(phi)` is left 0.
    fn inner_nodes(&self, c: f64, d: f64, sine: AzimuthSine, out: &mut InnerNodes) {
        let panels = ((d - c) / MAX_INNER_PANEL_WIDTH).ceil().max(1.0);
        out.width = (d - c) / panels;
        out.nodes.clear();
        for p in 0..panels as usize {
            let start = c + out.width * p as f64;
            let width = out.width;
            // Two loops, not a choice per node: within one, the compiler computes both anyway.
            match sine {
                AzimuthSine::Used => out.nodes.extend(self.unit_panel.iter().map(|&(s, v)| {
                    let (sin_p, cos_p) = (start + width * s).sin_cos();
                    (sin_p, cos_p, v)
                })),
                AzimuthSine::Unused => {
                    out.nodes.extend(self.unit_panel.iter().map(|&(s, v)| (0.0, (start + width * s).cos(), v)))
                }
            }
        }
    }

    /// Nodes per panel.
    pub fn nodes(&self) -> usize {
        self.unit_panel.len()
    }

    /// `E_{h ~ D_wi}[f]` for each of `N` channels, at the view of cosine `mu` (taken at least
    /// [`GRAZING_COSINE`], as the Monte Carlo estimators do) on GGX of roughness `alpha`, with the
    /// integrand's jumps and kinks at `cuts` (the horizon is not implied: pass it). At
    /// `alpha = 0` the visible normals are all `n`.
    pub fn integrate<const N: usize>(
        &self,
        mu: f64,
        alpha: f64,
        cuts: &[Cut],
        f: impl Fn(&MicrofacetSample) -> [f64; N],
    ) -> [f64; N] {
        self.integrate_with(mu, alpha, cuts, AzimuthSine::Used, f)
    }

    /// [`VisibleNormalQuadrature::integrate`], where with `sine` [`AzimuthSine::Unused`] the
    /// samples' `h.y` and `wo.y` are 0 instead of their values: for an integrand of `wi.h`, `h.z`,
    /// `wo.z` alone, which then has the same bits while no node of a cut piece computes its sine.
    /// (`wi.y` is 0, so `wi.h` and everything built from it but those two components are the same.)
    fn integrate_with<const N: usize>(
        &self,
        mu: f64,
        alpha: f64,
        cuts: &[Cut],
        sine: AzimuthSine,
        f: impl Fn(&MicrofacetSample) -> [f64; N],
    ) -> [f64; N] {
        let wi = direction_from_cosine(mu.max(GRAZING_COSINE));
        let sample = |h: DVec3| {
            let wo = reflect(wi, h);
            MicrofacetSample { wi, h, wo, cos_wi_h: wi.dot(h).clamp(0.0, 1.0) }
        };
        if alpha <= 0.0 {
            return f(&sample(DVec3::Z));
        }
        let (sin_i, cos_i) = (wi.x, wi.z);
        let theta_i = sin_i.atan2(cos_i);
        let outer = outer_edges(alpha, theta_i, cuts);
        let alpha2 = alpha * alpha;
        let mut sums = [0.0; N];
        let mut total = 0.0;
        let mut inner = Vec::with_capacity(8);
        let mut piece_nodes = InnerNodes::default();
        for edges in outer.windows(2) {
            let (a, b) = (edges[0], edges[1]);
            for &(s, w) in &self.unit_panel {
                let theta = a + (b - a) * s;
                let (sin_t, cos_t) = theta.sin_cos();
                // GGX's D up to its constant factor alpha^2 / pi, as the ratio cancels it; sin(theta)
                // is the solid angle's Jacobian.
                let denominator = alpha2 * cos_t * cos_t + sin_t * sin_t;
                let theta_weight = w * (b - a) * sin_t / (denominator * denominator);
                inner_edges(sin_t, cos_t, sin_i, cos_i, cuts, &mut inner);
                for piece in inner.windows(2) {
                    let (c, d) = (piece[0], piece[1]);
                    let nodes = if c == 0.0 && d == PI {
                        &self.half_circle
                    } else {
                        self.inner_nodes(c, d, sine, &mut piece_nodes);
                        &piece_nodes
                    };
                    let width = nodes.width;
                    for &(sin_p, cos_p, v) in &nodes.nodes {
                        let h = DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
                        let visible = wi.dot(h).max(0.0);
                        let weight = theta_weight * v * width * visible;
                        if weight == 0.0 {
                            continue;
                        }
                        total += weight;
                        for (sum, value) in sums.iter_mut().zip(f(&sample(h))) {
                            *sum += weight * value;
                        }
                    }
                }
            }
        }
        // Mirror symmetry about the plane of incidence: phi in [0, pi] stands for the whole circle,
        // and the factor 2 cancels in the ratio.
        sums.map(|s| if total > 0.0 { s / total } else { 0.0 })
    }

    /// `E_{h ~ D_wi}[f_j(wi.h) W]` with `W = G2 / G1(wi)` of `masking`: the integral that
    /// [`super::estimate_cosine_functions`] estimates, cut at the horizon and at each cosine of
    /// `kinks` (each in (0, 1)) where `wi.h` crosses a kink of `f`.
    pub fn cosine_functions<const N: usize>(
        &self,
        mu: f64,
        alpha: f64,
        masking: MaskingShadowing,
        kinks: &[f64],
        f: impl Fn(f64) -> [f64; N],
    ) -> [f64; N] {
        let mut cuts = vec![Cut::MirrorCosine(0.0)];
        cuts.extend(kinks.iter().map(|&c| Cut::HalfCosine(c)));
        // Every masking model's weight reads `wo.z` alone (the `tan^2` of Smith's Lambda, or the
        // cosine of Schlick's G1), and `f` reads `wi.h`: the sines of `phi` go unused. Below the
        // horizon the weight is 0 and so is every term (`f` is finite there), whatever `f` says.
        self.integrate_with(mu, alpha, &cuts, AzimuthSine::Unused, |s| {
            let weight = masking.visible_normal_weight(s.wi, s.wo, alpha);
            if weight == 0.0 {
                return [0.0; N];
            }
            f(s.cos_wi_h).map(|v| weight * v)
        })
    }
}

/// The lobe of directions `wo = reflect(wi, h)`, `h` drawn from the visible normals of a
/// `(mu, alpha)` cell, weighted by `weight(wi, wo)` (zero below the horizon), integrated in the
/// polar angle of `wo` itself: [`ReflectedLobe::share_beyond`] is the weighted share of the lobe
/// past a polar angle, such as the critical angle of total internal reflection, for any number
/// of angles from one integration over the lobe.
///
/// The density of `wo` is that of `h` times `dω_h / dω_o = 1 / (4 wo.h)` (Walter et al. 2007,
/// eq. 14), and the visible-normal density is `G1(wi) (wi.h) D(h) / mu` (Heitz 2018, eq. 2); with
/// `wi.h = wo.h` the two cosines cancel, so that `wo` is distributed as `D(h(wo))`, `h(wo) =
/// normalize(wi + wo)`, over the upper hemisphere. In the polar angles `(theta, phi)` of `wo`
/// (`phi = 0` towards `wi`) that integrand peaks at the mirror direction `(theta_i, pi)` with the
/// scale `alpha`; the `theta` panels grow geometrically from `alpha / 2` on both sides of `theta_i`
/// and the `phi` panels from `pi`, from the width that tilts the half vector by the larger of
/// `alpha` and its tilt in the plane of incidence ([`ReflectedLobe::azimuthal`]); plain
/// Gauss–Legendre rules, since no panel ends at a singularity. The panels depend on the cell alone: a share past one angle is the
/// sum of the whole panels beyond it plus the part of its own panel, from the polynomial through
/// that panel's nodes, so it has the same bits whatever other angles are asked, and costs no
/// evaluation of the integrand.
pub struct ReflectedLobe<'a, W> {
    quadrature: &'a VisibleNormalQuadrature,
    wi: DVec3,
    alpha: f64,
    weight: W,
    /// Panel edges in `theta` over `[0, pi / 2]`.
    edges: Vec<f64>,
    /// `beyond[p]`: the integral over the panels from `p` on (`beyond[0]` is the whole lobe).
    beyond: Vec<f64>,
    /// Per panel, its quadrature terms projected on `P_k(2u - 1)`, `k` below the node count, with
    /// `u` the panel mapped onto `[0, 1]`.
    moments: Vec<Vec<f64>>,
}

impl VisibleNormalQuadrature {
    /// The reflected lobe at the view of cosine `mu` (taken at least [`GRAZING_COSINE`]) on GGX of
    /// roughness `alpha > 0`, integrated once over its panels (see [`ReflectedLobe`]).
    pub fn reflected_lobe<W: Fn(DVec3, DVec3) -> f64>(&self, mu: f64, alpha: f64, weight: W) -> ReflectedLobe<'_, W> {
        debug_assert!(alpha > 0.0, "a lobe of roughness 0 is the mirror direction alone");
        let wi = direction_from_cosine(mu.max(GRAZING_COSINE));
        let theta_i = wi.x.atan2(wi.z);
        let mut edges = vec![0.0, FRAC_PI_2, theta_i];
        let mut offset = (0.5 * alpha).min(MAX_PANEL_WIDTH);
        while offset < FRAC_PI_2 {
            edges.extend([theta_i - offset, theta_i + offset]);
            offset = (2.0 * offset).min(offset + MAX_PANEL_WIDTH);
        }
        edges.retain(|&e| (0.0..=FRAC_PI_2).contains(&e));
        edges.sort_by(f64::total_cmp);
        edges.dedup();
        let mut lobe =
            ReflectedLobe { quadrature: self, wi, alpha, weight, edges, beyond: Vec::new(), moments: Vec::new() };
        let panels = lobe.edges.len() - 1;
        lobe.beyond = vec![0.0; panels + 1];
        lobe.moments = Vec::with_capacity(panels);
        for p in (0..panels).rev() {
            let terms = lobe.polar_panel(lobe.edges[p], lobe.edges[p + 1]);
            lobe.beyond[p] = lobe.beyond[p + 1] + terms.iter().sum::<f64>();
            let moments = (0..terms.len())
                .map(|k| terms.iter().zip(&self.legendre_at_nodes).map(|(t, legendre)| t * legendre[k]).sum())
                .collect();
            lobe.moments.push(moments);
        }
        lobe.moments.reverse();
        lobe
    }
}

impl<W: Fn(DVec3, DVec3) -> f64> ReflectedLobe<'_, W> {
    /// The weighted share of the lobe whose polar angle exceeds `polar_angle` (radians): 1 at or
    /// below 0, 0 at or beyond `pi / 2`, 0 for a lobe of no weight.
    ///
    /// The part of the panel holding the angle is the integral of the polynomial through the
    /// panel's terms, `G(u) = sum_k (2k + 1) m_k P_k(2u - 1)` over the panel as `[0, 1]`, with the
    /// moments `m_k = sum_j w_j G(u_j) P_k(2 u_j - 1)` (Gauss–Legendre is exact for their products),
    /// from `u_c` to 1: with `t = 2u - 1`, `∫ P_0 = (1 - t_c) / 2` and `∫ (2k + 1) P_k = (P_{k-1}(t_c) -
    /// P_{k+1}(t_c)) / 2` by `(2k + 1) P_k = P'_{k+1} - P'_{k-1}` and `P_k(1) = 1` (Abramowitz and
    /// Stegun, ch. 22, the recurrences of the Legendre polynomials).
    pub fn share_beyond(&self, polar_angle: f64) -> f64 {
        let total = self.beyond[0];
        if total <= 0.0 || polar_angle >= FRAC_PI_2 {
            return 0.0;
        }
        if polar_angle <= 0.0 {
            return 1.0;
        }
        // The panel holding the angle: edges[p] <= polar_angle < edges[p + 1].
        let p = self.edges.partition_point(|&e| e <= polar_angle) - 1;
        let (a, b) = (self.edges[p], self.edges[p + 1]);
        let t = (2.0 * (polar_angle - a) / (b - a) - 1.0).clamp(-1.0, 1.0);
        let moments = &self.moments[p];
        let legendre = legendre_polynomials(t, moments.len() + 1);
        let mut part = moments[0] * 0.5 * (1.0 - t);
        for k in 1..moments.len() {
            part += moments[k] * 0.5 * (legendre[k - 1] - legendre[k + 1]);
        }
        ((part + self.beyond[p + 1]) / total).clamp(0.0, 1.0)
    }

    /// The lobe's quadrature terms over `theta` in `[a, b]`, one per node: their sum is the integral.
    fn polar_panel(&self, a: f64, b: f64) -> Vec<f64> {
        self.quadrature
            .plain_panel
            .iter()
            .map(|&(s, w)| {
                let theta = a + (b - a) * s;
                let (sin_t, cos_t) = theta.sin_cos();
                // sin(theta): the solid angle's Jacobian.
                w * (b - a) * sin_t * self.azimuthal(sin_t, cos_t)
            })
            .collect()
    }

    /// The lobe's integral over `phi` in `[0, pi]` at one `theta` (the half `[pi, 2 pi]` is its
    /// mirror image and cancels in every share).
    fn azimuthal(&self, sin_t: f64, cos_t: f64) -> f64 {
        // D varies with the half vector's tilt, on the scale alpha: at phi = pi (the plane of
        // incidence) h0 = wi + wo is tilted in the plane by `tilt`, and a step dphi tilts it out
        // of the plane by sin(theta) dphi / |h0|. A grazing view's |h0| is about 2 mu, where the
        // lobe of wo is that much narrower across the plane.
        let h0 = self.wi + DVec3::new(-sin_t, 0.0, cos_t);
        let tilt = h0.x.abs().atan2(h0.z);
        let across = self.alpha.max(tilt) * h0.length();
        let mut width = if sin_t > 0.0 { (0.5 * across / sin_t).min(PI) } else { PI };
        let alpha2 = self.alpha * self.alpha;
        let mut sum = 0.0;
        let mut high = PI;
        while high > 0.0 {
            let low = (high - width.min(MAX_INNER_PANEL_WIDTH)).max(0.0);
            for &(s, v) in &self.quadrature.plain_panel {
                let (sin_p, cos_p) = (low + (high - low) * s).sin_cos();
                let wo = DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
                let weight = (self.weight)(self.wi, wo);
                if weight == 0.0 {
                    continue;
                }
                // GGX's D(h) for the unnormalised h = wi + wo, up to the constant 1 / pi (Walter et
                // al. 2007, eq. 33, with cos^2 and sin^2 of h as h.z^2 / |h|^2 and (h.x^2 + h.y^2) / |h|^2).
                let h = self.wi + wo;
                let length2 = h.length_squared();
                let denominator = alpha2 * h.z * h.z + h.x * h.x + h.y * h.y;
                let d = alpha2 * length2 * length2 / (denominator * denominator);
                sum += v * (high - low) * weight * d;
            }
            high = low;
            width *= 2.0;
        }
        sum
    }
}

/// The outer panel edges in `theta` over `[0, pi / 2]`: geometric from `alpha / 2`, no wider than
/// [`MAX_PANEL_WIDTH`], and every `theta` where an inner split point changes in kind (module
/// documentation).
fn outer_edges(alpha: f64, theta_i: f64, cuts: &[Cut]) -> Vec<f64> {
    let mut edges = vec![0.0, FRAC_PI_2];
    let mut edge = (0.5 * alpha).min(MAX_PANEL_WIDTH);
    while edge < FRAC_PI_2 {
        edges.push(edge);
        edge = (2.0 * edge).min(edge + MAX_PANEL_WIDTH);
    }
    // The visible half reaches phi = pi: cos(theta + theta_i) = 0.
    edges.push(FRAC_PI_2 - theta_i);
    for cut in cuts {
        match *cut {
            Cut::MirrorCosine(z) => {
                let angle = z.clamp(-1.0, 1.0).acos();
                edges.extend([0.5 * (theta_i + angle), 0.5 * (theta_i - angle), 0.5 * (angle - theta_i)]);
            }
            Cut::HalfCosine(c) => {
                let angle = c.clamp(-1.0, 1.0).acos();
                edges.extend([theta_i + angle, theta_i - angle, angle - theta_i]);
            }
        }
    }
    edges.retain(|&e| (0.0..=FRAC_PI_2).contains(&e));
    edges.sort_by(f64::total_cmp);
    edges.dedup();
    edges
}

/// The inner split points in `phi` over `[0, phi_max]` at one `theta`: 0, the roots of each cut
/// inside the visible half, and `phi_max`, the edge of the visible half (`wi.h = 0`), in order.
fn inner_edges(sin_t: f64, cos_t: f64, sin_i: f64, cos_i: f64, cuts: &[Cut], edges: &mut Vec<f64>) {
    edges.clear();
    // wi.h = A cos(phi) + B.
    let (a, b) = (sin_t * sin_i, cos_t * cos_i);
    let phi_of = |cos_phi: f64| -> Option<f64> { (cos_phi > -1.0 && cos_phi < 1.0).then(|| cos_phi.acos()) };
    let phi_max = if a > 0.0 {
        if b >= a { PI } else { phi_of(-b / a).unwrap_or(0.0) }
    } else if b > 0.0 {
        PI
    } else {
        0.0
    };
    edges.push(0.0);
    if a > 0.0 {
        for cut in cuts {
            let cos_phi = match *cut {
                // wo.z = 2 cos(theta) (A cos(phi) + B) - cos(theta_i) = z.
                Cut::MirrorCosine(z) => (0.5 * (z + cos_i) / cos_t - b) / a,
                // A cos(phi) + B = c.
                Cut::HalfCosine(c) => (c - b) / a,
            };
            if let Some(phi) = phi_of(cos_phi).filter(|&phi| phi > 0.0 && phi < phi_max) {
                edges.push(phi);
            }
        }
    }
    edges.push(phi_max);
    edges.sort_by(f64::total_cmp);
    edges.dedup();
}

/// `P_0(t) .. P_{count-1}(t)`, the Legendre polynomials by their three-term recurrence
/// `(k + 1) P_{k+1} = (2k + 1) t P_k - k P_{k-1}`.
fn legendre_polynomials(t: f64, count: usize) -> Vec<f64> {
    let mut values = Vec::with_capacity(count.max(2));
    values.extend([1.0, t]);
    for k in 1..count.saturating_sub(1) {
        values.push(((2 * k + 1) as f64 * t * values[k] - k as f64 * values[k - 1]) / (k + 1) as f64);
    }
    values.truncate(count);
    values
}

/// The Gauss–Legendre nodes and weights of `n` points on `[0, 1]`: the roots of the Legendre
/// polynomial `P_n` by Newton's method from `cos(pi (k - 1/4) / (n + 1/2))`, weights
/// `2 / ((1 - x^2) P_n'(x)^2)` on `[-1, 1]` (Press et al., Numerical Recipes, 3rd ed., §4.6.1,
/// `gauleg`), halved for the unit interval.
pub fn gauss_legendre_unit(n: usize) -> Vec<(f64, f64)> {
    let mut nodes = Vec::with_capacity(n);
    for k in 1..=n {
        let mut x = (PI * (k as f64 - 0.25) / (n as f64 + 0.5)).cos();
        let mut derivative = 0.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for j in 2..=n {
                let p2 = ((2 * j - 1) as f64 * x * p1 - (j - 1) as f64 * p0) / j as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 1 { x } else { p1 };
            let p_previous = if n == 1 { 1.0 } else { p0 };
            derivative = n as f64 * (x * p - p_previous) / (x * x - 1.0);
            let step = p / derivative;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        let weight = 2.0 / ((1.0 - x * x) * derivative * derivative);
        nodes.push((0.5 * (1.0 - x), 0.5 * weight));
    }
    nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::estimate_visible_normal_integral;
    use crate::physics::MaskingShadowing;
    use crate::sampling::sequence::{PointSet, SamplePlan};

    #[test]
    fn cosine_functions_have_the_bits_of_the_integral_with_every_sine_and_term() {
        // `cosine_functions` leaves the azimuths' sines out and skips the terms below the horizon;
        // the exact integrals (and every table built from them) rely on that changing no bit.
        let rule = VisibleNormalQuadrature::new(8).unwrap();
        let fresnel = |c: f64| [crate::physics::fresnel_reflectance(c, 0.66, 0.0), c * c];
        for masking in MaskingShadowing::ALL {
            for (mu, alpha) in [(0.02, 0.3), (0.3, 0.05), (0.75, 0.6), (1.0, 0.2), (0.0, 1.0)] {
                let kinks = [(1.0f64 - 0.66 * 0.66).sqrt()];
                let mut cuts = vec![Cut::MirrorCosine(0.0)];
                cuts.extend(kinks.iter().map(|&c| Cut::HalfCosine(c)));
                let every_term = rule.integrate(mu, alpha, &cuts, |s| {
                    let weight = masking.visible_normal_weight(s.wi, s.wo, alpha);
                    fresnel(s.cos_wi_h).map(|v| weight * v)
                });
                let fast = rule.cosine_functions(mu, alpha, masking, &kinks, fresnel);
                assert_eq!(
                    fast.map(f64::to_bits),
                    every_term.map(f64::to_bits),
                    "{masking:?} at mu {mu}, alpha {alpha}"
                );
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_2n_minus_1_exactly() {
        for n in [2, 5, 8, 16] {
            let rule = gauss_legendre_unit(n);
            assert!((rule.iter().map(|r| r.1).sum::<f64>() - 1.0).abs() < 1e-14);
            let degree = 2 * n - 1;
            let integral: f64 = rule.iter().map(|&(x, w)| w * x.powi(degree as i32)).sum();
            assert!((integral - 1.0 / (degree as f64 + 1.0)).abs() < 1e-14, "n {n}: {integral}");
        }
    }

    #[test]
    fn rejects_node_counts_out_of_range() {
        assert!(VisibleNormalQuadrature::new(1).is_err());
        assert!(VisibleNormalQuadrature::new(65).is_err());
    }

    #[test]
    fn agrees_with_monte_carlo_on_the_mean_of_the_half_cosine_and_the_weight() {
        // E[wi.h] and E[G1(wo)] over the visible normals, against 2^18 Sobol samples in 16
        // replicates: within 5 standard errors, at a low, a middle and a grazing view.
        let quadrature = VisibleNormalQuadrature::new(8).unwrap();
        let points = PointSet::new(SamplePlan::new(1 << 18, 16).unwrap(), 5);
        for (mu, alpha) in [(0.9, 0.05), (0.5, 0.4), (0.02, 0.8)] {
            let weight =
                |s: &MicrofacetSample| MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, alpha);
            let quadrature_values =
                quadrature.integrate(mu, alpha, &[Cut::MirrorCosine(0.0)], |s| [s.cos_wi_h, weight(s)]);
            let monte_carlo = estimate_visible_normal_integral(mu, alpha, &points, 2, |s, sums| {
                sums[0] += s.cos_wi_h;
                sums[1] += weight(s);
            });
            for (k, value) in quadrature_values.into_iter().enumerate() {
                let difference = (value - monte_carlo.mean[k]).abs();
                assert!(
                    difference < 5.0 * monte_carlo.standard_error[k] + 1e-9,
                    "mu {mu} alpha {alpha} channel {k}: {value} vs {monte_carlo:?}"
                );
            }
        }
    }

    #[test]
    fn a_smooth_surface_is_the_mirror_and_constants_integrate_to_themselves() {
        let quadrature = VisibleNormalQuadrature::new(6).unwrap();
        let [c] = quadrature.integrate(0.6, 0.0, &[], |s| [s.cos_wi_h]);
        assert!((c - 0.6).abs() < 1e-15);
        for (mu, alpha) in [(1.0, 0.3), (1e-9, 1e-7), (0.3, 1.0)] {
            let [one] = quadrature.integrate(mu, alpha, &[Cut::MirrorCosine(0.0)], |_| [1.0]);
            assert!((one - 1.0).abs() < 1e-14, "mu {mu} alpha {alpha}: {one}");
        }
    }
}
