//! The ground truth of the furnace test: the directional albedo `A(mu)` of an explicit layer stack
//! by a position-free random walk (Guo, Hašan, Yan & Zhao 2018, "Position-free Monte Carlo
//! simulation for arbitrary layered BSDFs"; `docs/random-walk.md`), sharing none of the
//! transfer-matrix model's approximations.
//!
//! One path is one light path entering from air against the view direction (cosine `mu`, in the
//! x–z plane); `A(mu)` is the expected weight of the paths that leave the top into air
//! (reciprocity: the albedo seen from `mu` under a uniform environment). The stack is walked as it
//! is written:
//! - an interface is a single-scattering GGX microfacet boundary: a normal drawn from the visible
//!   normals of the arrival direction (Heitz 2018), reflection with the exact Fresnel reflectance
//!   of that normal, else refraction about it; the weight is multiplied by the masking of the
//!   outgoing direction, `G2 / G1(wi)`, and a sample whose outgoing direction lies in the wrong
//!   hemisphere is lost. At the first event, where light from air meets the top interface, both
//!   branches are taken: the reflected one leaves into air at once, so its expected weight is added
//!   to the albedo and the path goes on refracted (the same mean, less variance);
//! - the first conductor reflects about the visible normal with its exact Fresnel reflectance, per
//!   channel, and ends the stack;
//! - a medium is a plane-parallel slab: free flights sampled from the scattering coefficient alone,
//!   absorption applied as the weight `exp(-sigma_k s)`, Henyey–Greenstein scattering; only the
//!   depth is tracked.
//!
//! [`modelling_choices`] states every choice in words; `docs/random-walk.md` lists the ones two
//! random walks must share to agree.
//!
//! Determinism: path `i` at view cosine `mu` draws from its own PCG stream, seeded from
//! `(seed, mu, i)` alone; paths run in fixed-size batches whose tallies are merged in batch order,
//! and the adaptive stop looks only at those tallies. The result is bit-identical for any thread
//! count.

use glam::DVec3;
use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::RngCore;
use rayon::prelude::*;

use crate::integrate::{GRAZING_COSINE, Progress};
use crate::model::{Layer, Rgb, Stack};
use crate::physics::{
    MaskingShadowing, direction_from_cosine, fresnel_reflectance, reflect, refract, sample_henyey_greenstein,
};
use crate::sampling::{DiskPoint, VisibleNormalSampler};

#[cfg(test)]
mod tests;

/// Paths per batch: the unit of parallel work and of the stopping rule. Fixed, so that the batches
/// and their merge order do not depend on the thread count.
pub const BATCH_PATHS: u64 = 1024;

/// The Smith masking-shadowing model of the microfacet interfaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Masking {
    /// `G2 = G1(wi) G1(wo)` (Heitz 2014, eq. 98): the weight of a visible-normal sample is
    /// `G1(wo)`, for reflection and transmission alike. The choice `docs/random-walk.md` asks two
    /// random walks to share.
    #[default]
    Separable,
    /// Height-correlated Smith: reflection weight `(1 + Lambda(wi)) / (1 + Lambda(wi) +
    /// Lambda(wo))` (Heitz 2014, eq. 99), transmission weight `(1 + Lambda(wi)) B(1 + Lambda(wi),
    /// 1 + Lambda(wt))` (Heitz 2014, §6).
    HeightCorrelated,
}

impl Masking {
    pub fn name(self) -> &'static str {
        match self {
            Masking::Separable => "smith-separable",
            Masking::HeightCorrelated => "smith-height-correlated",
        }
    }

    fn masking_shadowing(self) -> MaskingShadowing {
        match self {
            Masking::Separable => MaskingShadowing::SmithSeparable,
            Masking::HeightCorrelated => MaskingShadowing::SmithHeightCorrelated,
        }
    }
}

/// The most paths a walk traces per view: 2^30, hours per view already. A round's batches are
/// tallied at once (about 240 bytes per batch of [`BATCH_PATHS`]), so the bound also bounds that
/// memory (256 MiB).
pub const MAX_PATHS: u64 = 1 << 30;

/// How many paths a random walk traces and how each one ends.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WalkSettings {
    /// Seed of every path's stream.
    pub seed: u64,
    /// Stop once the standard error of the reflected albedo is at most this in every channel.
    pub target_standard_error: f64,
    /// Paths traced before the standard error is first trusted (rounded up to whole batches).
    pub min_paths: u64,
    /// Paths after which the walk stops whatever its standard error (rounded up to whole batches).
    pub max_paths: u64,
    pub masking: Masking,
    /// Events (interface events and scatterings) after which Russian roulette may end a path.
    pub roulette_after_events: u32,
    /// Events after which a path is ended and counted in [`WalkEstimate::truncated_paths`].
    pub max_events: u32,
}

impl Default for WalkSettings {
    fn default() -> Self {
        WalkSettings {
            seed: 1,
            // Below 1e-3 with room for the scatter of the estimated standard error itself.
            target_standard_error: 8e-4,
            // Enough paths that the standard error estimated from them is itself reliable.
            min_paths: 1 << 14,
            max_paths: 1 << 24,
            masking: Masking::Separable,
            // Paths of ordinary stacks end well before this (a clear coat over a conductor: a few
            // events), so roulette only thins long paths in scattering media.
            roulette_after_events: 64,
            // A conservative semi-infinite medium returns light after arbitrarily many events (the
            // chance to need more than n falls like n^-1/2); the cap bounds the cost of such paths.
            max_events: 1 << 16,
        }
    }
}

/// The directional albedo at one view cosine, split by where the light leaves, with the standard
/// errors of the means.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WalkEstimate {
    /// The view cosine as asked for; the walk evaluates it clamped to `[GRAZING_COSINE, 1]`.
    pub mu: f64,
    /// `A(mu)`: the mean weight leaving the top into air, per channel.
    pub reflected: [f64; 3],
    pub reflected_standard_error: [f64; 3],
    /// The mean weight leaving the bottom of a stack without a conductor.
    pub transmitted: [f64; 3],
    pub transmitted_standard_error: [f64; 3],
    /// The mean weight the single-scattering microfacet interfaces drop: masked outgoing
    /// directions (`1 - G2 / G1(wi)`) and samples leaving into the wrong hemisphere. What is left,
    /// `1 - reflected - transmitted - lost`, was absorbed (by media and conductors).
    pub lost: [f64; 3],
    pub paths: u64,
    /// Paths ended at `max_events` (their weight counts nowhere). With per-channel walks, a path
    /// counts when any of its channel walks was ended.
    pub truncated_paths: u64,
    /// Whether each channel was walked on its own (a dielectric's index or a medium's scattering
    /// coefficient differs between channels), or one walk carried all three.
    pub per_channel_walks: bool,
}

/// The directional albedo at one view cosine (`mu` clamped below at [`GRAZING_COSINE`], as the
/// tables take `mu = 0`, and above at 1), traced in batches in parallel over rayon.
///
/// Panics when `mu` is NaN.
pub fn directional_albedo(stack: &Stack, mu: f64, settings: &WalkSettings) -> WalkEstimate {
    estimate_view(&WalkPlan::new(stack), mu, settings)
}

/// [`directional_albedo`] at many view cosines, in parallel over rayon, reporting one step of
/// `progress` per view; results are in the order of `mus` and each equals what
/// [`directional_albedo`] returns for its cosine.
pub fn directional_albedo_curve(
    stack: &Stack,
    mus: &[f64],
    settings: &WalkSettings,
    progress: &dyn Progress,
) -> Vec<WalkEstimate> {
    let plan = WalkPlan::new(stack);
    progress.start("random walk", mus.len() as u64);
    let estimates = mus
        .par_iter()
        .map(|&mu| {
            let estimate = estimate_view(&plan, mu, settings);
            progress.advance(1);
            estimate
        })
        .collect();
    progress.finish();
    estimates
}

/// The modelling choices of the walk in words, for the furnace's output.
pub fn modelling_choices(settings: &WalkSettings) -> Vec<String> {
    let masking = match settings.masking {
        Masking::Separable => "Smith masking separable (Heitz 2014, eq. 98): after sampling a visible normal of the \
             arrival direction, the weight is G1 of the outgoing direction, for reflection and transmission alike"
            .to_string(),
        Masking::HeightCorrelated => "Smith masking height-correlated: reflection weight (1 + Lambda(wi)) / (1 + \
             Lambda(wi) + Lambda(wo)) (Heitz 2014, eq. 99); transmission weight (1 + Lambda(wi)) B(1 + Lambda(wi), \
             1 + Lambda(wt)), the Beta-function form of Heitz 2014, §6"
            .to_string(),
    };
    vec![
        format!(
            "Position-free random walk through the explicit stack (Guo et al. 2018); light enters from air at the view \
             cosine, A(mu) is the mean weight leaving the top into air; mu is clamped below at {GRAZING_COSINE:e}"
        ),
        "Interfaces are single-scattering GGX microfacet boundaries: a normal from the visible normals of the arrival \
         direction (Heitz 2018), reflection with probability equal to the exact unpolarised Fresnel reflectance at \
         that normal, else refraction about it; total internal reflection where refraction is impossible"
            .to_string(),
        masking,
        "At the first event (light from air meeting a dielectric top interface) both branches are taken: the reflected \
         branch leaves into air at once, so its expected weight F * G2/G1 is added to the albedo and the path goes \
         on refracted with weight (1 - F) * G2/G1 (an expected value over the Fresnel choice: the same mean, less \
         variance); every later interface event chooses one branch with probability F"
            .to_string(),
        "A sample whose outgoing direction lies in the wrong hemisphere (or exactly at the horizon) for its event is \
         lost (weight 0), not resampled; the weight dropped by masking and by lost samples is reported as `lost`"
            .to_string(),
        "An interface seen from below is the same GGX surface (same alpha) with the frame mirrored; the relative \
         index is that of the medium beyond over the medium of arrival"
            .to_string(),
        "An interface with the same index as the medium above it (relative index exactly 1, kappa 0) is no interface: \
         light passes straight through without an event"
            .to_string(),
        "The first conductor (any kappa > 0) ends the stack: reflection about the visible normal weighted per channel \
         by its exact Fresnel reflectance at the microfacet cosine, with its index relative to the medium above \
         (eta / eta_above, kappa / eta_above), times the masking weight"
            .to_string(),
        "Weights carry energy: no eta^2 radiance factor at refraction".to_string(),
        "Media are plane-parallel slabs, depth tracked only (distances along the ray, depth vertical); free flights \
         are sampled from sigma_s alone and absorption is applied as the weight exp(-sigma_k * distance) per \
         channel; Henyey–Greenstein phase function (g = 1 is no scattering, g = -1 exact reversal); consecutive \
         media are consecutive slabs; a path exactly parallel to a non-scattering slab never leaves it and counts \
         as lost"
            .to_string(),
        "Light leaving the bottom of a stack without a conductor is transmitted, reported apart from the albedo"
            .to_string(),
        format!(
            "Russian roulette only after {} events: survive with probability min(1, largest channel weight), weights \
             divided by it; paths are ended after {} events and counted as truncated",
            settings.roulette_after_events, settings.max_events
        ),
        "RGB: one walk carries all three channels (per-channel weights for conductor Fresnel and absorption) when no \
         sampling decision depends on the channel; when a dielectric's index or a medium's sigma_s differs between \
         channels, each channel is walked on its own, on the same random streams"
            .to_string(),
        format!(
            "Random numbers: PCG-64 MCG (rand_pcg), one stream per path seeded from (seed {}, mu, path index) by \
             SplitMix64; batches of {BATCH_PATHS} paths merged in order: bit-identical for any thread count",
            settings.seed
        ),
        format!(
            "Stopping: rounds of whole batches until the standard error of the reflected albedo (from the i.i.d. path \
             weights) is at most {:e} in every channel, between {} and {} paths; the next round is sized from the \
             current error, at most doubling the paths",
            settings.target_standard_error, settings.min_paths, settings.max_paths
        ),
    ]
}

/// A stack compiled for walks: one walk for all channels, or one per channel.
enum WalkPlan {
    Shared(WalkStack<3>),
    PerChannel([WalkStack<1>; 3]),
}

/// The layers a walk steps through, top first, down to and including the first conductor, with
/// index-matched interfaces left out. Weights and per-channel values have `N` channels.
struct WalkStack<const N: usize> {
    steps: Vec<Step<N>>,
}

#[derive(Debug, Clone, Copy)]
enum Step<const N: usize> {
    /// A dielectric interface with the index of the medium below over that of the medium above.
    Dielectric { eta: f64, alpha: f64 },
    /// The base: index relative to the medium above, per channel.
    Conductor { eta: [f64; N], kappa: [f64; N], alpha: f64 },
    /// A medium between interfaces.
    Slab { sigma_s: f64, sigma_k: [f64; N], depth: f64, g: f64 },
}

impl WalkPlan {
    fn new(stack: &Stack) -> Self {
        let layers = stack.reachable_layers();
        let grey = |v: &Rgb| v[0] == v[1] && v[1] == v[2];
        // Sampling decisions read the dielectrics' indices (Fresnel chooses reflection or
        // refraction) and the media's scattering coefficients (free flights); everything else is
        // a per-channel weight.
        let shared = layers.iter().all(|layer| match layer {
            Layer::Interface(i) => i.is_conductor() || grey(&i.eta),
            Layer::Medium(m) => grey(&scattering_coefficient(m.sigma_s, m.g)),
        });
        if shared {
            WalkPlan::Shared(WalkStack::new(layers, |v| v[0], |v| *v))
        } else {
            WalkPlan::PerChannel(std::array::from_fn(|c| WalkStack::new(layers, |v| v[c], |v| [v[c]])))
        }
    }
}

/// The scattering coefficient a walk samples: none when `g = 1`, where scattering leaves the
/// direction as it was and the medium is the same as one that does not scatter.
fn scattering_coefficient(sigma_s: Rgb, g: f64) -> Rgb {
    if g == 1.0 { [0.0; 3] } else { sigma_s }
}

impl<const N: usize> WalkStack<N> {
    /// `scalar` reads the value a sampling decision uses, `channels` the per-channel values.
    fn new(layers: &[Layer], scalar: impl Fn(&Rgb) -> f64, channels: impl Fn(&Rgb) -> [f64; N]) -> Self {
        let mut steps = Vec::with_capacity(layers.len());
        let mut eta_above = 1.0;
        for layer in layers {
            match layer {
                Layer::Interface(i) if i.is_conductor() => {
                    let (eta, kappa) = (channels(&i.eta), channels(&i.kappa));
                    steps.push(Step::Conductor {
                        eta: eta.map(|e| e / eta_above),
                        kappa: kappa.map(|k| k / eta_above),
                        alpha: i.alpha,
                    });
                    break;
                }
                Layer::Interface(i) => {
                    let eta = scalar(&i.eta);
                    if eta != eta_above {
                        steps.push(Step::Dielectric { eta: eta / eta_above, alpha: i.alpha });
                    }
                    eta_above = eta;
                }
                Layer::Medium(m) => steps.push(Step::Slab {
                    sigma_s: scalar(&scattering_coefficient(m.sigma_s, m.g)),
                    sigma_k: channels(&m.sigma_k),
                    depth: m.depth,
                    g: m.g,
                }),
            }
        }
        WalkStack { steps }
    }
}

/// One view: rounds of whole batches until the reflected albedo's standard error reaches the target
/// in every channel, or the paths reach the maximum.
fn estimate_view(plan: &WalkPlan, mu: f64, settings: &WalkSettings) -> WalkEstimate {
    assert!(!mu.is_nan(), "directional_albedo: the view cosine is NaN");
    let mu_walked = mu.clamp(GRAZING_COSINE, 1.0);
    let view = ViewStreams::new(settings.seed, mu_walked);
    let batches_for = |paths: u64| paths.div_ceil(BATCH_PATHS).max(1);
    // Held to [`MAX_PATHS`] here too, so that no caller's settings size a round past memory (the
    // furnace refuses larger ones before it starts).
    let (min_batches, max_batches) =
        (batches_for(settings.min_paths.min(MAX_PATHS)), batches_for(settings.max_paths.clamp(1, MAX_PATHS)));
    let mut tally = Tally::default();
    let mut done = 0u64;
    let mut round = min_batches.min(max_batches);
    loop {
        let batches: Vec<Tally> = (done..done + round)
            .into_par_iter()
            .map(|batch| trace_batch(plan, mu_walked, settings, &view, batch))
            .collect();
        for batch in &batches {
            tally.merge(batch);
        }
        done += round;
        let worst = tally.standard_errors(&tally.reflected).into_iter().fold(0.0, f64::max);
        if done >= max_batches || (done >= min_batches && worst <= settings.target_standard_error) {
            break;
        }
        // Size the next round from the error so far (it falls as 1 / sqrt(paths)), with a tenth
        // more for the scatter of the error itself, but never more than doubling the paths.
        let needed = done as f64 * (worst / settings.target_standard_error).powi(2) * 1.1;
        round = ((needed - done as f64).ceil() as u64).clamp(1, done).min(max_batches - done);
    }
    tally.estimate(mu, matches!(plan, WalkPlan::PerChannel(_)))
}

fn trace_batch(plan: &WalkPlan, mu: f64, settings: &WalkSettings, view: &ViewStreams, batch: u64) -> Tally {
    let masking = settings.masking.masking_shadowing();
    let limits = EventLimits { roulette_after: settings.roulette_after_events, max: settings.max_events };
    let mut tally = Tally::default();
    for path in batch * BATCH_PATHS..(batch + 1) * BATCH_PATHS {
        let outcome = match plan {
            WalkPlan::Shared(stack) => trace_path(stack, mu, masking, limits, &mut view.path_rng(path)),
            WalkPlan::PerChannel(stacks) => {
                // The same stream for each channel (common random numbers): the channels' errors are
                // correlated, so colour differences are less noisy than the values themselves.
                let mut outcome = PathOutcome::<3>::default();
                for (c, stack) in stacks.iter().enumerate() {
                    let one = trace_path(stack, mu, masking, limits, &mut view.path_rng(path));
                    outcome.reflected[c] = one.reflected[0];
                    outcome.transmitted[c] = one.transmitted[0];
                    outcome.lost[c] = one.lost[0];
                    outcome.truncated |= one.truncated;
                }
                outcome
            }
        };
        tally.add(&outcome);
    }
    tally
}

/// The streams of one view: SplitMix64 (Steele, Lea & Flood 2014) mixes the seed, the view cosine
/// and the path index into the 128-bit state of a PCG-64 MCG (O'Neill 2014).
struct ViewStreams {
    key: u64,
}

impl ViewStreams {
    fn new(seed: u64, mu: f64) -> Self {
        ViewStreams { key: mix(seed, mu.to_bits()) }
    }

    fn path_rng(&self, path: u64) -> Pcg64Mcg {
        let high = mix(self.key, path);
        let low = mix(high, !path);
        Pcg64Mcg::new(((high as u128) << 64) | low as u128)
    }
}

/// The SplitMix64 finaliser.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn mix(a: u64, b: u64) -> u64 {
    splitmix64(a ^ splitmix64(b))
}

/// A uniform number in [0, 1) with 53 random bits.
#[inline]
fn uniform(rng: &mut Pcg64Mcg) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[derive(Debug, Clone, Copy)]
struct EventLimits {
    roulette_after: u32,
    max: u32,
}

/// Where one path's weight went, per channel.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PathOutcome<const N: usize> {
    reflected: [f64; N],
    transmitted: [f64; N],
    lost: [f64; N],
    truncated: bool,
}

impl<const N: usize> Default for PathOutcome<N> {
    fn default() -> Self {
        PathOutcome { reflected: [0.0; N], transmitted: [0.0; N], lost: [0.0; N], truncated: false }
    }
}

/// A path in flight.
struct Path<'a, const N: usize> {
    rng: &'a mut Pcg64Mcg,
    limits: EventLimits,
    /// Propagation direction (z up: `w.z < 0` moves down the stack).
    w: DVec3,
    weight: [f64; N],
    events: u32,
    outcome: PathOutcome<N>,
}

/// Whether a path goes on after an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fate {
    Continues,
    Ends,
}

/// One light path entering from air against the view direction of cosine `mu`.
fn trace_path<const N: usize>(
    stack: &WalkStack<N>,
    mu: f64,
    masking: MaskingShadowing,
    limits: EventLimits,
    rng: &mut Pcg64Mcg,
) -> PathOutcome<N> {
    let mut path = Path {
        rng,
        limits,
        w: -direction_from_cosine(mu),
        weight: [1.0; N],
        events: 0,
        outcome: PathOutcome::default(),
    };
    // The step the path is in; moving down enters the next one, moving up the previous one.
    let mut k = 0usize;
    if let Some(&Step::Dielectric { eta, alpha }) = stack.steps.first() {
        if path.enter_through_top(eta, alpha, masking) == Fate::Ends {
            return path.outcome;
        }
        k = 1;
    }
    loop {
        let Some(step) = stack.steps.get(k) else {
            add(&mut path.outcome.transmitted, &path.weight);
            return path.outcome;
        };
        let fate = match *step {
            Step::Dielectric { eta, alpha } => path.cross_dielectric(eta, alpha, masking),
            Step::Conductor { eta, kappa, alpha } => path.reflect_off_conductor(&eta, &kappa, alpha, masking),
            Step::Slab { sigma_s, sigma_k, depth, g } => path.cross_slab(sigma_s, &sigma_k, depth, g),
        };
        if fate == Fate::Ends {
            return path.outcome;
        }
        // Every event leaves the path moving strictly up or down (the horizon is lost).
        if path.w.z > 0.0 {
            if k == 0 {
                add(&mut path.outcome.reflected, &path.weight);
                return path.outcome;
            }
            k -= 1;
        } else {
            k += 1;
        }
    }
}

fn add<const N: usize>(sum: &mut [f64; N], values: &[f64; N]) {
    for (s, v) in sum.iter_mut().zip(values) {
        *s += v;
    }
}

impl<const N: usize> Path<'_, N> {
    /// A visible normal of `wi` (arrival side up) on a GGX surface of roughness `alpha`.
    fn sample_normal(&mut self, wi: DVec3, alpha: f64) -> DVec3 {
        VisibleNormalSampler::new(wi, alpha).sample(&self.sample_disk())
    }

    /// A uniform point of the unit disk, by rejection from the square around it (4 / pi tries on
    /// average): the same distribution as the polar map of [`DiskPoint::from_unit_square`] without
    /// its sine and cosine (sine and cosine were a tenth of the walk's time, measured with perf).
    fn sample_disk(&mut self) -> DiskPoint {
        loop {
            let (x, y) = (2.0 * uniform(self.rng) - 1.0, 2.0 * uniform(self.rng) - 1.0);
            if x * x + y * y <= 1.0 {
                return DiskPoint { x, y, half_chord: ((1.0 - x) * (1.0 + x)).sqrt() };
            }
        }
    }

    /// The first event, at the top interface from air. Its reflected branch leaves into air at
    /// once, so instead of choosing a branch with probability `F`, the expected weight of the
    /// reflected branch, `F G2/G1` of the reflection, is added to the albedo and the path goes on
    /// into the stack with `(1 - F) G2/G1` of the refraction: the same mean, without the variance
    /// of the choice (at grazing views, where `F` of a rough coat is near 1/2, most of it).
    fn enter_through_top(&mut self, eta: f64, alpha: f64, masking: MaskingShadowing) -> Fate {
        let wi = -self.w;
        let h = self.sample_normal(wi, alpha);
        let cos_wi_h = wi.dot(h).clamp(0.0, 1.0);
        let reflected = reflect(wi, h);
        let reflected_masking = masking.visible_normal_weight(wi, reflected, alpha);
        // Where rounding makes refraction impossible just past the critical angle, everything is
        // reflected, as in `cross_dielectric`.
        let (transmitted, reflectance, transmitted_masking) = match refract(wi, h, eta) {
            Some(wt) => {
                (wt, fresnel_reflectance(cos_wi_h, eta, 0.0), masking.visible_normal_transmission_weight(wi, wt, alpha))
            }
            None => (reflected, 1.0, 0.0),
        };
        let transmittance = 1.0 - reflectance;
        for ((w, r), lost) in self.weight.iter_mut().zip(&mut self.outcome.reflected).zip(&mut self.outcome.lost) {
            *r += *w * reflectance * reflected_masking;
            *lost += *w * (reflectance * (1.0 - reflected_masking) + transmittance * (1.0 - transmitted_masking));
            *w *= transmittance * transmitted_masking;
        }
        self.w = transmitted;
        if transmittance * transmitted_masking == 0.0 {
            return Fate::Ends;
        }
        self.event()
    }

    /// Multiply the weight by a masking weight, counting what it drops as lost; a weight of 0 (the
    /// outgoing direction in the wrong hemisphere) loses the path.
    fn mask(&mut self, masking_weight: f64) -> Fate {
        for (w, lost) in self.weight.iter_mut().zip(self.outcome.lost.iter_mut()) {
            *lost += *w * (1.0 - masking_weight);
            *w *= masking_weight;
        }
        if masking_weight > 0.0 { Fate::Continues } else { Fate::Ends }
    }

    /// A dielectric interface with relative index `eta` (below over above).
    fn cross_dielectric(&mut self, eta: f64, alpha: f64, masking: MaskingShadowing) -> Fate {
        // The frame where the arrival side is +z: as it is from above, mirrored from below.
        let from_above = self.w.z < 0.0;
        let mirror = |v: DVec3| if from_above { v } else { DVec3::new(v.x, v.y, -v.z) };
        let wi = mirror(-self.w);
        let eta = if from_above { eta } else { 1.0 / eta };
        let h = self.sample_normal(wi, alpha);
        let cos_wi_h = wi.dot(h).clamp(0.0, 1.0);
        let reflects = uniform(self.rng) < fresnel_reflectance(cos_wi_h, eta, 0.0);
        // Refraction that rounding makes impossible just past the critical angle is reflection, as
        // Fresnel is 1 there.
        let transmitted = if reflects { None } else { refract(wi, h, eta) };
        let (wo, masking_weight) = match transmitted {
            Some(wt) => (wt, masking.visible_normal_transmission_weight(wi, wt, alpha)),
            None => {
                let wo = reflect(wi, h);
                (wo, masking.visible_normal_weight(wi, wo, alpha))
            }
        };
        self.w = mirror(wo);
        if self.mask(masking_weight) == Fate::Ends {
            return Fate::Ends;
        }
        self.event()
    }

    /// The conductor base, reached from above only.
    fn reflect_off_conductor(
        &mut self,
        eta: &[f64; N],
        kappa: &[f64; N],
        alpha: f64,
        masking: MaskingShadowing,
    ) -> Fate {
        let wi = -self.w;
        let h = self.sample_normal(wi, alpha);
        let cos_wi_h = wi.dot(h).clamp(0.0, 1.0);
        let wo = reflect(wi, h);
        self.w = wo;
        if self.mask(masking.visible_normal_weight(wi, wo, alpha)) == Fate::Ends {
            return Fate::Ends;
        }
        for c in 0..N {
            self.weight[c] *= fresnel_reflectance(cos_wi_h, eta[c], kappa[c]);
        }
        self.event()
    }

    /// A slab of thickness `depth`, entered at its top when moving down and at its bottom when
    /// moving up; returns once the path leaves it (or ends in it).
    fn cross_slab(&mut self, sigma_s: f64, sigma_k: &[f64; N], depth: f64, g: f64) -> Fate {
        // Depth below the slab's top.
        let mut z = if self.w.z < 0.0 { 0.0 } else { depth };
        loop {
            let to_boundary = if self.w.z < 0.0 {
                (depth - z) / -self.w.z
            } else if self.w.z > 0.0 {
                z / self.w.z
            } else {
                f64::INFINITY
            };
            let to_scattering = if sigma_s > 0.0 { -(1.0 - uniform(self.rng)).ln() / sigma_s } else { f64::INFINITY };
            if to_scattering < to_boundary {
                self.absorb(sigma_k, to_scattering);
                z = (z - self.w.z * to_scattering).clamp(0.0, depth);
                let u = [uniform(self.rng), uniform(self.rng)];
                self.w = sample_henyey_greenstein(self.w, g, u);
                if self.event() == Fate::Ends {
                    return Fate::Ends;
                }
            } else if to_boundary.is_infinite() {
                // Parallel to a slab that does not scatter: the path never leaves.
                for (lost, w) in self.outcome.lost.iter_mut().zip(self.weight) {
                    *lost += w;
                }
                return Fate::Ends;
            } else {
                self.absorb(sigma_k, to_boundary);
                return if self.weight.iter().all(|&w| w == 0.0) { Fate::Ends } else { Fate::Continues };
            }
        }
    }

    /// Absorption along `distance`: the weight `exp(-sigma_k distance)` per channel.
    fn absorb(&mut self, sigma_k: &[f64; N], distance: f64) {
        for (w, &k) in self.weight.iter_mut().zip(sigma_k) {
            if k > 0.0 {
                *w *= (-k * distance).exp();
            }
        }
    }

    /// Count an event; past the roulette threshold play Russian roulette, at the cap truncate.
    fn event(&mut self) -> Fate {
        self.events += 1;
        if self.events >= self.limits.max {
            self.outcome.truncated = true;
            return Fate::Ends;
        }
        let survival = self.weight.iter().fold(0.0f64, |m, &w| m.max(w)).min(1.0);
        if survival == 0.0 {
            return Fate::Ends;
        }
        if self.events > self.limits.roulette_after && survival < 1.0 {
            if uniform(self.rng) >= survival {
                return Fate::Ends;
            }
            for w in &mut self.weight {
                *w /= survival;
            }
        }
        Fate::Continues
    }
}

/// Mean and spread of one quantity over paths (Welford 1962), mergeable in a fixed order (Chan,
/// Golub & LeVeque 1979).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Moments {
    mean: f64,
    /// Sum of squared deviations from the mean.
    m2: f64,
}

impl Moments {
    fn add(&mut self, x: f64, inverse_count: f64) {
        let delta = x - self.mean;
        self.mean += delta * inverse_count;
        self.m2 += delta * (x - self.mean);
    }

    fn merge(&mut self, other: &Moments, count: u64, other_count: u64) {
        let total = (count + other_count) as f64;
        let delta = other.mean - self.mean;
        self.mean += delta * (other_count as f64 / total);
        self.m2 += other.m2 + delta * delta * (count as f64 * other_count as f64 / total);
    }
}

/// The paths of a batch, or of a view so far.
#[derive(Debug, Clone, Default, PartialEq)]
struct Tally {
    paths: u64,
    truncated: u64,
    reflected: [Moments; 3],
    transmitted: [Moments; 3],
    lost: [Moments; 3],
}

impl Tally {
    fn add(&mut self, outcome: &PathOutcome<3>) {
        self.paths += 1;
        self.truncated += outcome.truncated as u64;
        let inverse_count = 1.0 / self.paths as f64;
        for (moments, values) in [
            (&mut self.reflected, &outcome.reflected),
            (&mut self.transmitted, &outcome.transmitted),
            (&mut self.lost, &outcome.lost),
        ] {
            for (m, &x) in moments.iter_mut().zip(values) {
                m.add(x, inverse_count);
            }
        }
    }

    fn merge(&mut self, other: &Tally) {
        for (moments, others) in [
            (&mut self.reflected, &other.reflected),
            (&mut self.transmitted, &other.transmitted),
            (&mut self.lost, &other.lost),
        ] {
            for (m, o) in moments.iter_mut().zip(others) {
                m.merge(o, self.paths, other.paths);
            }
        }
        self.paths += other.paths;
        self.truncated += other.truncated;
    }

    /// Standard errors of the means from the sample variance of the i.i.d. path weights.
    fn standard_errors(&self, moments: &[Moments; 3]) -> [f64; 3] {
        let n = self.paths as f64;
        moments.map(|m| if self.paths < 2 { f64::INFINITY } else { (m.m2.max(0.0) / (n - 1.0) / n).sqrt() })
    }

    fn estimate(&self, mu: f64, per_channel_walks: bool) -> WalkEstimate {
        WalkEstimate {
            mu,
            reflected: self.reflected.map(|m| m.mean),
            reflected_standard_error: self.standard_errors(&self.reflected),
            transmitted: self.transmitted.map(|m| m.mean),
            transmitted_standard_error: self.standard_errors(&self.transmitted),
            lost: self.lost.map(|m| m.mean),
            paths: self.paths,
            truncated_paths: self.truncated,
            per_channel_walks,
        }
    }
}
