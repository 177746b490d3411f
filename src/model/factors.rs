//! Transfer factors: what each component of a stack does to a lobe arriving at it, as energy per
//! colour channel and Henyey–Greenstein asymmetry, before the transfer matrices combine them
//! (Randrianandrasana et al. 2021, §4.2–4.3; the reference implementation's
//! `dielectric_transfer_factors`, `conductor_transfer_factors`, `medium_transfer_factors`, which
//! `docs/furnace.md` pairs with the functions here).
//!
//! Only the cosines of lobe directions ever enter a lookup or a factor, so directions are carried
//! as cosines: the reference's `r.mean.z`, `-t.mean.z` and the propagated `w.z`.

use super::lookup::{Lookup, Quantity, Site, Tables};
use super::stack::{Interface, Layer, Medium, Rgb, Stack};
use crate::ir::real::{Compare, Real};
use crate::physics::{ggx_to_hg, hg_backward_share};

/// Relative indices closer to 1 than this are no interface at all (the reference's `dielectric_transfer_factors`).
pub const INDEX_MATCHED: f64 = 1e-5;
/// Relative indices closer to 1 than this reflect nothing: albedo 0 without a lookup (the reference's `albedos`).
pub const NEARLY_INDEX_MATCHED: f64 = 1e-3;
/// The largest exponent a medium's factors evaluate: the optical depth is cut where
/// `gamma tau` or `sigma_ext tau` would pass it (the reference's `TM_EXP_ARG_MAX`), which keeps
/// `sinh^2` below the f32 maximum in a shader and changes no factor by more than `e^-45`.
pub const EXPONENT_LIMIT: f64 = 45.0;

/// One transfer statistic: energy per channel and asymmetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flux<R = f64> {
    pub energy: [R; 3],
    pub g: R,
}

impl<R: Real> Flux<R> {
    pub fn of(energy: R, g: R) -> Self {
        Flux { energy: [energy; 3], g }
    }

    /// The asymmetry weighted by the mean energy, the entries of the asymmetry matrices
    /// (the reference's `asymmetry_matrix`).
    pub fn weighted_g(&self) -> R {
        self.g * average(&self.energy)
    }
}

pub fn average<R: Real>(v: &[R; 3]) -> R {
    (v[0] + v[1] + v[2]) / 3.0
}

/// A dielectric interface seen by a lobe of cosine `cos_in` arriving from above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DielectricFactors<R = f64> {
    /// Relative index below over above, averaged over the channels (the reference's
    /// `components_transfer_factors`: a dielectric interface is evaluated at one index).
    pub eta: f64,
    /// Cosine of the incident lobe's mean direction (and of the reflected one).
    pub cos_in: R,
    /// Cosine of the refracted mean direction below; 0 where the mean direction is totally
    /// reflected (its limit: the refracted direction reaches the horizon at the critical angle).
    pub cos_below: R,
    /// Downward reflection, downward transmission, upward reflection, upward transmission.
    pub r: Flux<R>,
    pub t: Flux<R>,
    pub rp: Flux<R>,
    pub tp: Flux<R>,
}

/// A participating medium's factors: the primary (unscattered) flux's transmission, and the
/// secondary (scattered) flux's backward reflection and forward transmission.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MediumFactors<R = f64> {
    pub t: Flux<R>,
    pub r_fb: Flux<R>,
    pub t_ff: Flux<R>,
    /// Whether it scatters backward in some channel (`sigma_s` times the backward share of its
    /// phase function above 0), so that `r_fb` is above 0: a property of the medium, not the view.
    pub scatters_back: bool,
}

/// What one layer of the stack is to the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Component<R = f64> {
    /// Light passes unchanged: an index-matched interface, or a medium that neither absorbs nor
    /// scatters, or has no depth.
    Pass,
    Dielectric(DielectricFactors<R>),
    /// An opaque conductor: only its reflection.
    Conductor {
        r: Flux<R>,
    },
    Medium(MediumFactors<R>),
}

/// Cosine of a direction of cosine `cos_in` refracted into a medium of relative index `eta`
/// (Snell's law), or 0 where it is totally reflected.
pub fn refracted_cosine<R: Real>(cos_in: R, eta: f64) -> R {
    if eta == 1.0 {
        return cos_in;
    }
    // 1 - (1 - c^2) / eta^2 without cancelling near c = 1.
    let sin2_in = (R::of(1.0) - cos_in) * (cos_in + 1.0);
    let cos2 = R::of(1.0) - sin2_in / (eta * eta);
    R::choose(Compare::Gt, cos2, R::of(0.0), || cos2.sqrt(), || R::of(0.0))
}

/// Asymmetry of a transmission lobe of an interface of roughness `alpha` whose roughness the
/// refraction scales by `|numerator / denominator|` (the reference's `hg_from_ggx(0.5 s alpha)`); an
/// infinite scale (a mean direction at the horizon, `denominator = 0`) gives the roughest lobe
/// unless the interface is smooth.
fn transmission_asymmetry<R: Real>(numerator: R, denominator: R, alpha: f64) -> R {
    if alpha == 0.0 {
        return ggx_to_hg(R::of(0.0));
    }
    R::choose(
        Compare::Eq,
        denominator,
        R::of(0.0),
        || ggx_to_hg(R::of(0.5 * f64::INFINITY * alpha)),
        || ggx_to_hg((numerator / denominator).abs() * 0.5 * alpha),
    )
}

/// The factors of a dielectric interface of layer `layer` (1-based) with relative index `eta`
/// (scalar) and roughness `alpha`, for a lobe of cosine `cos_in` from above (the
/// reference's `dielectric_transfer_factors` and `albedos`). `None` for an index-matched interface.
pub fn dielectric<R: Real>(
    layer: usize,
    eta: f64,
    alpha: f64,
    cos_in: R,
    tables: &dyn Tables<R>,
) -> Option<DielectricFactors<R>> {
    if (eta - 1.0).abs() < INDEX_MATCHED {
        return None;
    }
    let cos_below = refracted_cosine(cos_in, eta);
    let g = ggx_to_hg(R::of(alpha));
    // Fake rough transmissions: the lobe's roughness scaled as a refracted ray's angular spread
    // (the reference's s_ij = |(eta_ji r.z + rp.z) / rp.z|, s_ji = |(eta_ij rp.z + r.z) / r.z| with
    // r.z = cos_in and rp.z = -cos_below).
    let t_g = transmission_asymmetry(cos_in / eta - cos_below, cos_below, alpha);
    let tp_g = transmission_asymmetry(cos_in - cos_below * eta, cos_in, alpha);
    let albedo = if (eta - 1.0).abs() < NEARLY_INDEX_MATCHED {
        R::of(0.0)
    } else {
        tables.value(&Lookup {
            quantity: Quantity::Albedo,
            site: Site::FromAbove,
            layer,
            channel: None,
            mu: cos_in,
            alpha: R::of(alpha),
            eta: R::of(eta),
            kappa: R::of(0.0),
        })
    };
    // The reference reads one albedo for both sides: r_ji = r_ij, t_ji = t_ij.
    let (r, t) = (albedo, R::of(1.0) - albedo);
    Some(DielectricFactors {
        eta,
        cos_in,
        cos_below,
        r: Flux::of(r, g),
        t: Flux::of(t, t_g),
        rp: Flux::of(r, g),
        tp: Flux::of(t, tp_g),
    })
}

/// The reflection of a conductor of layer `layer` with relative indices `eta`, `kappa` per
/// channel (the reference's `conductor_transfer_factors`).
pub fn conductor<R: Real>(
    layer: usize,
    eta: Rgb,
    kappa: Rgb,
    alpha: f64,
    cos_in: R,
    tables: &dyn Tables<R>,
) -> Flux<R> {
    let energy = std::array::from_fn(|c| {
        tables.value(&Lookup {
            quantity: Quantity::Albedo,
            site: Site::FromAbove,
            layer,
            channel: Some(c),
            mu: cos_in,
            alpha: R::of(alpha),
            eta: R::of(eta[c]),
            kappa: R::of(kappa[c]),
        })
    });
    Flux { energy, g: ggx_to_hg(R::of(alpha)) }
}

/// `sinh(x) / x`, 1 at 0 without dividing.
fn sinhc<R: Real>(x: R) -> R {
    R::choose(Compare::Lt, x.abs(), R::of(1e-4), || R::of(1.0) + x * x / 6.0, || x.sinh() / x)
}

/// The two-flux solution of a slab for coefficients `a` (attenuation of a flux), `b` (its
/// coupling to the opposite flux) over optical path `tau`, as `(reflected, transmitted)`:
/// `r = S b / (C gamma + S a)`, `t = gamma / (C gamma + S a)` with `gamma = sqrt(a^2 - b^2)`,
/// `S = sinh(gamma tau)`, `C = sqrt(1 + S^2)` (Kubelka–Munk in the form of the
/// reference's `medium_transfer_factors`). Written with `sinh(gamma tau) / gamma` so that a non-absorbing
/// slab (`gamma = 0`, where the reference divides `0 / 0` and so forces `sigma_k >= 1e-7`) gets its
/// limit `r = tau b / (1 + tau a)`, `t = 1 / (1 + tau a)`. `a^2 - b^2` is given factored, as
/// `(a - b)(a + b)`, both non-negative, so that it cannot round below zero.
///
/// From `gamma tau = 40` on, the same solution divided through by `S / gamma`: with
/// `q = gamma / S = 2 gamma e^-x / (1 - e^-2x)`, `r = b / (sqrt(q^2 + gamma^2) + a)` and
/// `t = q / (sqrt(q^2 + gamma^2) + a)`, since `S^2` passes the f32 maximum at `x = 44.4` and the
/// asymmetry's slab reaches `x = 48` (its `gamma` is up to 1.066 `sigma_ext`, at `g = -0.26`, and
/// the exponent limit holds `sigma_ext tau` to 45).
fn slab<R: Real>(a: f64, b: f64, a_minus_b_times_a_plus_b: f64, tau: R) -> (R, R) {
    let gamma = a_minus_b_times_a_plus_b.max(0.0).sqrt();
    let x = tau * gamma;
    let direct = || {
        let sinh_over_gamma = tau * sinhc(x);
        let sinh = sinh_over_gamma * gamma;
        let cosh = (sinh * sinh + 1.0).sqrt();
        let denominator = cosh + sinh_over_gamma * a;
        (sinh_over_gamma * b / denominator, R::of(1.0) / denominator)
    };
    let divided = || {
        let e = (-x).exp();
        let q = e * (2.0 * gamma) / (R::of(1.0) - e * e);
        let denominator = (q * q + gamma * gamma).sqrt() + a;
        (R::of(b) / denominator, q / denominator)
    };
    const DIVIDED_FROM: f64 = 40.0;
    R::choose_pair(Compare::Lt, x, R::of(DIVIDED_FROM), direct, divided)
}

/// The factors of a medium crossed by a lobe of cosine `cos` (the reference's `medium_transfer_factors`),
/// or `None` where it changes nothing (no depth, or neither absorption nor scattering). In the
/// 2-flux model (`scatters == false`) a medium only absorbs: `t = exp(-sigma_k tau)`.
pub fn medium<R: Real>(medium: &Medium, cos: R, scatters: bool) -> Option<MediumFactors<R>> {
    let sigma_s = if scatters { medium.sigma_s } else { [0.0; 3] };
    let sigma_k = medium.sigma_k;
    if medium.depth == 0.0 || (sigma_s.iter().all(|&s| s == 0.0) && sigma_k.iter().all(|&k| k == 0.0)) {
        return None;
    }
    let g = medium.g;
    let backward = hg_backward_share(g);
    let sigma_sb: Rgb = std::array::from_fn(|c| sigma_s[c] * backward);
    let sigma_sf: Rgb = std::array::from_fn(|c| sigma_s[c] - sigma_sb[c]);
    let sigma_ext: Rgb = std::array::from_fn(|c| sigma_s[c] + sigma_k[c]);
    // Energy: a = sigma_ext - sigma_sf = sigma_sb + sigma_k, b = sigma_sb, so a - b = sigma_k and
    // a + b = 2 sigma_sb + sigma_k.
    let gamma: Rgb = std::array::from_fn(|c| (sigma_k[c] * (2.0 * sigma_sb[c] + sigma_k[c])).sqrt());
    let largest = |v: &Rgb| v.iter().copied().fold(0.0, f64::max);
    // The optical path is cut where an exponent would pass the limit; `sigma_ext > 0` in some
    // channel (the medium is not empty), so the cut is finite.
    let mut limit = f64::INFINITY;
    if largest(&gamma) > 0.0 {
        limit = limit.min(EXPONENT_LIMIT / largest(&gamma));
    }
    if largest(&sigma_ext) > 0.0 {
        limit = limit.min(EXPONENT_LIMIT / largest(&sigma_ext));
    }
    // Path length through the slab along the mean direction; a horizontal direction (cos = 0)
    // has an infinite one, which the limit cuts.
    let tau =
        R::choose(Compare::Gt, cos, R::of(0.0), || (R::of(medium.depth) / cos).min(R::of(limit)), || R::of(limit));
    let zero = [R::of(0.0); 3];
    let (mut t, mut r_fb, mut t_ff, mut r_fb_g, mut t_ff_g) = (zero, zero, zero, zero, zero);
    for c in 0..3 {
        t[c] = (tau * -sigma_ext[c]).exp();
        let a = sigma_sb[c] + sigma_k[c];
        let (r, tf) = slab(a, sigma_sb[c], sigma_k[c] * (2.0 * sigma_sb[c] + sigma_k[c]), tau);
        r_fb[c] = r;
        t_ff[c] = tf;
        // Asymmetry: the same solution with a_g = sigma_ext - sigma_sf g and b_g = -sigma_sb g,
        // where a_g - b_g = sigma_ext - g (sigma_sf - sigma_sb) and a_g + b_g = sigma_ext - g sigma_s
        // are both at least sigma_k.
        let a_g = sigma_ext[c] - sigma_sf[c] * g;
        let b_g = -sigma_sb[c] * g;
        let product = (sigma_ext[c] - g * (sigma_sf[c] - sigma_sb[c])) * (sigma_ext[c] - g * sigma_s[c]);
        let (rg, tg) = slab(a_g, b_g, product, tau);
        // As the reference: g_fb = avg(safe_div(S b_g x0, r_fb)), g_ff = avg(safe_div(gamma_g x0, t_ff)).
        r_fb_g[c] = safe_ratio(rg, r);
        t_ff_g[c] = safe_ratio(tg, tf);
    }
    Some(MediumFactors {
        t: Flux { energy: t, g: R::of(1.0) },
        r_fb: Flux { energy: r_fb, g: average(&r_fb_g) },
        t_ff: Flux { energy: t_ff, g: average(&t_ff_g) },
        scatters_back: sigma_sb.iter().any(|&s| s > 0.0),
    })
}

/// `n / d`, or 0 where `|d| <= 1e-7` (the reference's `safe_div`).
pub fn safe_ratio<R: Real>(n: R, d: R) -> R {
    R::choose(Compare::Gt, d.abs(), R::of(1e-7), || n / d, || R::of(0.0))
}

/// The components of `stack` for a view of cosine `mu`, top first, one per reachable layer, with
/// the layer numbers their lookups carry. `scattering` selects the 6-flux medium factors; the
/// 2-flux model's media only absorb.
pub fn components<R: Real>(
    stack: &Stack,
    mu: R,
    scattering: bool,
    tables: &dyn Tables<R>,
) -> Vec<(usize, Component<R>)> {
    let layers = stack.reachable_layers();
    let mut out = Vec::with_capacity(layers.len());
    let mut eta_above: Rgb = [1.0; 3];
    // Cosine of the lobe propagating down into the current layer.
    let mut cos = mu;
    for (k, layer) in layers.iter().enumerate() {
        let number = k + 1;
        let component = match layer {
            Layer::Interface(interface) => interface_component(number, interface, &mut eta_above, &mut cos, tables),
            Layer::Medium(m) => medium(m, cos, scattering).map_or(Component::Pass, Component::Medium),
        };
        out.push((number, component));
    }
    out
}

fn interface_component<R: Real>(
    number: usize,
    interface: &Interface,
    eta_above: &mut Rgb,
    cos: &mut R,
    tables: &dyn Tables<R>,
) -> Component<R> {
    let eta: Rgb = std::array::from_fn(|c| interface.eta[c] / eta_above[c]);
    if interface.is_conductor() {
        let kappa: Rgb = std::array::from_fn(|c| interface.kappa[c] / eta_above[c]);
        return Component::Conductor { r: conductor(number, eta, kappa, interface.alpha, *cos, tables) };
    }
    *eta_above = interface.eta;
    match dielectric(number, average(&eta), interface.alpha, *cos, tables) {
        Some(factors) => {
            *cos = factors.cos_below;
            Component::Dielectric(factors)
        }
        None => Component::Pass,
    }
}
