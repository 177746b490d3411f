//! Monte Carlo estimators over the visible-normal measure of a `(mu, alpha)` cell.
//!
//! Every table tmlut integrates is an expectation over microfacet normals drawn from the visible
//! normals of the incident direction (Heitz 2018): for a function `f` of the sample,
//! `∫ f D G2 / (4 mu) dwo = E_{h ~ D_wi}[ f * G2 / G1(wi) ]`. This module draws the samples and
//! averages whatever the caller accumulates from them; the table recipes
//! ([`crate::recipes`]) say what is accumulated. Integrands stay out of here, as pbrt keeps
//! integrators apart from BxDFs.
//!
//! Determinism: every cell uses the same [`PointSet`], which depends only on the seed, and each
//! cell's sums run in a fixed order, so the result is bit-identical whatever the thread count.

/// A function that runs `$portable`, an `#[inline(always)]` loop, compiled for AVX2 where the CPU
/// has it (in `$avx2`, which the loop is inlined into and vectorised for) and as it is elsewhere.
/// `fn name(&self, ...)` for a method, `fn name(...)` for a free function.
macro_rules! avx2_dispatch {
    ($(#[$attr:meta])* $vis:vis fn $name:ident(&self $(, $arg:ident: $ty:ty)*) => $avx2:ident, $portable:ident) => {
        $(#[$attr])*
        $vis fn $name(&self $(, $arg: $ty)*) {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2, checked just above.
                    unsafe { self.$avx2($($arg),*) };
                    return;
                }
            }
            self.$portable($($arg),*);
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx2(&self $(, $arg: $ty)*) {
            self.$portable($($arg),*);
        }
    };
    ($(#[$attr:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),*) => $avx2:ident, $portable:ident) => {
        $(#[$attr])*
        $vis fn $name($($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2, checked just above.
                    unsafe { $avx2($($arg),*) };
                    return;
                }
            }
            $portable($($arg),*);
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx2($($arg: $ty),*) {
            $portable($($arg),*);
        }
    };
}

pub mod batch;
pub mod measure;
pub mod quadrature;

use glam::DVec3;
use rayon::prelude::*;

use crate::physics::{MaskingShadowing, direction_from_cosine, reflect};
use crate::sampling::sequence::PointSet;
use crate::sampling::{DiskPoint, VisibleNormalSampler};

/// The grazing node `mu = 0` is evaluated as the limit `mu -> 0+`, taken at this cosine: at exactly
/// 0 the incident direction lies in the surface and, for a smooth surface, so does its mirror
/// direction, where the integrand is `0 / 0`. For `alpha > 0` the difference to `mu = 0` is below
/// the tables' Monte Carlo noise.
pub const GRAZING_COSINE: f64 = 1e-6;

/// How a table's cells are integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// One visible-normal measure per `(mu, alpha)`, shared by every other parameter, in f32
    /// vectorised batches (`docs/integration.md`).
    #[default]
    Fast,
    /// Every cell on its own, in scalar f64: the way other generators work, kept as an independent
    /// cross-check of the fast path.
    PerCell,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Fast => "fast",
            Method::PerCell => "per-cell",
        }
    }
}

/// One visible-normal sample of a cell.
#[derive(Debug, Clone, Copy)]
pub struct MicrofacetSample {
    /// Incident (view) direction, `wi.z = mu`.
    pub wi: DVec3,
    /// Microfacet normal drawn from the visible normals of `wi`.
    pub h: DVec3,
    /// Mirror direction of `wi` about `h`; may lie below the horizon.
    pub wo: DVec3,
    /// `wi.h`, the cosine Fresnel is evaluated at.
    pub cos_wi_h: f64,
}

/// A Monte Carlo estimate per channel: the mean over replicates and the standard error of that
/// mean from the spread of the independently scrambled replicates (0 when there is only one).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    pub mean: Vec<f64>,
    pub standard_error: Vec<f64>,
}

impl Estimate {
    /// One estimate whose channels are the first channels of `per_channel`, in order.
    pub fn from_channels(per_channel: &[Estimate]) -> Estimate {
        Estimate {
            mean: per_channel.iter().map(|e| e.mean[0]).collect(),
            standard_error: per_channel.iter().map(|e| e.standard_error[0]).collect(),
        }
    }

    /// One single-channel estimate per channel: the inverse of [`Estimate::from_channels`].
    pub fn into_channels(self) -> Vec<Estimate> {
        self.mean
            .into_iter()
            .zip(self.standard_error)
            .map(|(mean, standard_error)| Estimate { mean: vec![mean], standard_error: vec![standard_error] })
            .collect()
    }
}

/// Estimate `E[f]` over the visible normals of the direction with cosine `mu` on a GGX surface of
/// roughness `alpha`. `accumulate` adds the sample's contribution to each of `channels` sums.
pub fn estimate_visible_normal_integral(
    mu: f64,
    alpha: f64,
    points: &PointSet,
    channels: usize,
    accumulate: impl FnMut(&MicrofacetSample, &mut [f64]),
) -> Estimate {
    combine_replicates(&visible_normal_replicate_means(mu, alpha, points, channels, accumulate), channels)
}

/// The per-replicate means behind [`estimate_visible_normal_integral`], for estimators that are
/// not plain means (a ratio of two means, say) and combine the replicates themselves.
pub fn visible_normal_replicate_means(
    mu: f64,
    alpha: f64,
    points: &PointSet,
    channels: usize,
    mut accumulate: impl FnMut(&MicrofacetSample, &mut [f64]),
) -> Vec<Vec<f64>> {
    let wi = direction_from_cosine(mu.max(GRAZING_COSINE));
    let sampler = VisibleNormalSampler::new(wi, alpha);
    let mut means = Vec::with_capacity(points.plan().replicates as usize);
    for replicate in points.replicates() {
        let mut sums = vec![0.0; channels];
        for point in replicate {
            accumulate(&MicrofacetSample::new(wi, &sampler, point), &mut sums);
        }
        means.push(sums.iter().map(|s| s / replicate.len() as f64).collect());
    }
    means
}

impl MicrofacetSample {
    /// The sample of `wi` (with `sampler` built for it) at a disk point.
    #[inline(always)]
    fn new(wi: DVec3, sampler: &VisibleNormalSampler, point: &DiskPoint) -> Self {
        let h = sampler.sample(point);
        MicrofacetSample { wi, h, wo: reflect(wi, h), cos_wi_h: wi.dot(h).clamp(0.0, 1.0) }
    }
}

/// Samples per block of the per-cell path: the block's cosines and weights stay in the L1 cache.
const PER_CELL_BLOCK: usize = 256;

/// The per-cell (scalar f64) estimate of `channels` integrals `E[f_j(wi.h) W]`, `W = G2 / G1(wi)`
/// of `masking`, a block of samples at a time: `accumulate(cos_wi_h, weight, sums)` adds a block's
/// contributions. The samples and weights are those of [`estimate_visible_normal_integral`] with
/// [`MaskingShadowing::visible_normal_weight`], in the same order, so a plain sum per channel gives
/// the same bits; splitting the sampling from the integrand lets several integrands share one pass
/// (and keeps each loop short enough for the CPU to overlap its iterations).
pub fn estimate_per_cell_blocks(
    mu: f64,
    alpha: f64,
    masking: MaskingShadowing,
    points: &PointSet,
    channels: usize,
    accumulate: impl FnMut(&[f64], &[f64], &mut [f64]),
) -> Estimate {
    combine_replicates(&per_cell_block_replicates(mu, alpha, masking, points, channels, accumulate), channels)
}

/// The per-replicate means behind [`estimate_per_cell_blocks`].
fn per_cell_block_replicates(
    mu: f64,
    alpha: f64,
    masking: MaskingShadowing,
    points: &PointSet,
    channels: usize,
    mut accumulate: impl FnMut(&[f64], &[f64], &mut [f64]),
) -> Vec<Vec<f64>> {
    let wi = direction_from_cosine(mu.max(GRAZING_COSINE));
    let sampler = VisibleNormalSampler::new(wi, alpha);
    let lobe = CellLobe { wi, sampler: &sampler, alpha, masking };
    let (mut cos_wi_h, mut weight) = ([0.0; PER_CELL_BLOCK], [0.0; PER_CELL_BLOCK]);
    let mut means = Vec::with_capacity(points.plan().replicates as usize);
    for replicate in points.replicates() {
        let mut sums = vec![0.0; channels];
        for block in replicate.chunks(PER_CELL_BLOCK) {
            let n = block.len();
            cosines_and_weights(&lobe, block, &mut cos_wi_h[..n], &mut weight[..n]);
            accumulate(&cos_wi_h[..n], &weight[..n], &mut sums);
        }
        means.push(sums.iter().map(|s| s / replicate.len() as f64).collect());
    }
    means
}

/// What every sample of one cell shares: its view direction, the sampler of its visible normals,
/// its roughness and its masking model.
struct CellLobe<'a> {
    wi: DVec3,
    sampler: &'a VisibleNormalSampler,
    alpha: f64,
    masking: MaskingShadowing,
}

avx2_dispatch! {
    /// `wi.h` and `G2 / G1(wi)` of each point of a block, by the scalar sampler.
    fn cosines_and_weights(lobe: &CellLobe, points: &[DiskPoint], cos_wi_h: &mut [f64], weight: &mut [f64])
        => cosines_and_weights_avx2, cosines_and_weights_portable
}

/// [`cosines_and_weights`] with the masking model fixed outside the loop, so that the loop body
/// has no branch left the compiler cannot turn into a select (and vectorises). The arithmetic is
/// that of the scalar functions, element by element: the same bits.
#[inline(always)]
fn cosines_and_weights_portable(lobe: &CellLobe, points: &[DiskPoint], cos_wi_h: &mut [f64], weight: &mut [f64]) {
    #[inline(always)]
    fn fill(
        lobe: &CellLobe,
        points: &[DiskPoint],
        cos_wi_h: &mut [f64],
        weight: &mut [f64],
        weight_of: impl Fn(DVec3) -> f64,
    ) {
        for ((point, c), w) in points.iter().zip(cos_wi_h.iter_mut()).zip(weight.iter_mut()) {
            let sample = MicrofacetSample::new(lobe.wi, lobe.sampler, point);
            *c = sample.cos_wi_h;
            *w = weight_of(sample.wo);
        }
    }
    let &CellLobe { wi, alpha, masking, .. } = lobe;
    use MaskingShadowing::*;
    match masking {
        SmithSeparable => {
            fill(lobe, points, cos_wi_h, weight, |wo| SmithSeparable.visible_normal_weight(wi, wo, alpha))
        }
        SmithHeightCorrelated => {
            fill(lobe, points, cos_wi_h, weight, |wo| SmithHeightCorrelated.visible_normal_weight(wi, wo, alpha))
        }
        SchlickSmith => fill(lobe, points, cos_wi_h, weight, |wo| SchlickSmith.visible_normal_weight(wi, wo, alpha)),
    }
}

/// Estimate `E[f_j(wi.h) W]` for the `N` channel functions `f` with `W = G2 / G1(wi)` of
/// `masking`, by either method. The fast method runs the f32 batch kernel; the per-cell method the
/// scalar f64 sampler. Both see the same points.
pub fn estimate_cosine_functions<const N: usize>(
    mu: f64,
    alpha: f64,
    masking: MaskingShadowing,
    method: Method,
    points: &PointSet,
    f: impl Fn(f64) -> [f64; N],
) -> Estimate {
    combine_replicates(&cosine_function_replicates(mu, alpha, masking, method, points, f), N)
}

/// The per-replicate means behind [`estimate_cosine_functions`], for an estimate that adds up
/// several of them (an average over view cosines) and takes its spread from the replicates' sums.
pub fn cosine_function_replicates<const N: usize>(
    mu: f64,
    alpha: f64,
    masking: MaskingShadowing,
    method: Method,
    points: &PointSet,
    f: impl Fn(f64) -> [f64; N],
) -> Vec<Vec<f64>> {
    match method {
        Method::PerCell => per_cell_block_replicates(mu, alpha, masking, points, N, |cos_wi_h, weight, sums| {
            for (&c, &w) in cos_wi_h.iter().zip(weight) {
                for (s, v) in sums.iter_mut().zip(f(c)) {
                    *s += w * v;
                }
            }
        }),
        Method::Fast => {
            let warp = batch::CellWarp::new(mu.max(GRAZING_COSINE), alpha);
            fast_cosine_function_replicates(&warp, masking, points, &f)
        }
    }
}

/// The fast method of [`cosine_function_replicates`].
fn fast_cosine_function_replicates<const N: usize>(
    warp: &batch::CellWarp,
    masking: MaskingShadowing,
    points: &PointSet,
    f: &impl Fn(f64) -> [f64; N],
) -> Vec<Vec<f64>> {
    points
        .replicates_f32()
        .iter()
        .map(|replicate| {
            // Eight interleaved partial sums, added up in a fixed order at the end: the compiler can
            // vectorise them, and the result does not depend on the CPU.
            const LANES: usize = 8;
            let mut lanes = [[0.0f64; N]; LANES];
            batch::for_each_block(warp, masking, replicate, |block| {
                for (chunk_c, chunk_w) in block.cos_wi_h.chunks(LANES).zip(block.weight.chunks(LANES)) {
                    for (lane, (&c, &w)) in chunk_c.iter().zip(chunk_w).enumerate() {
                        let values = f(c as f64);
                        for j in 0..N {
                            lanes[lane][j] += w as f64 * values[j];
                        }
                    }
                }
            });
            (0..N).map(|j| lanes.iter().map(|l| l[j]).sum::<f64>() / replicate.len() as f64).collect()
        })
        .collect()
}

/// Mean and standard error over replicate means.
pub fn combine_replicates(replicate_means: &[Vec<f64>], channels: usize) -> Estimate {
    let r = replicate_means.len() as f64;
    let mean: Vec<f64> = (0..channels).map(|c| replicate_means.iter().map(|m| m[c]).sum::<f64>() / r).collect();
    let standard_error = (0..channels)
        .map(|c| {
            if replicate_means.len() < 2 {
                return 0.0;
            }
            let variance = replicate_means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (r - 1.0);
            (variance / r).sqrt()
        })
        .collect();
    Estimate { mean, standard_error }
}

/// Something that shows how far a long computation has come. The CLI shows a progress bar;
/// library callers and tests pass `&()`, which shows nothing.
pub trait Progress: Sync {
    fn start(&self, _label: &str, _total: u64) {}
    fn advance(&self, _done: u64) {}
    fn finish(&self) {}
    /// Something the person waiting should know, such as a lock being waited for.
    fn note(&self, _message: &str) {}
}

impl Progress for () {}

/// Evaluate `estimate_cell` for every cell number in `cells`, in parallel, reporting progress.
/// The result is in the order of `cells`, independent of scheduling.
pub fn estimate_cells<T: Send>(
    cells: &[u64],
    label: &str,
    progress: &dyn Progress,
    estimate_cell: impl Fn(u64) -> T + Sync,
) -> Vec<T> {
    progress.start(label, cells.len() as u64);
    // Chunks keep progress updates cheap next to the per-cell work, yet are small enough that a
    // short list (a few dozen reference cells) still spreads over every thread.
    let chunk = (cells.len() / (8 * rayon::current_num_threads())).clamp(1, 64);
    let results: Vec<T> = cells
        .par_chunks(chunk)
        .flat_map_iter(|chunk| {
            let out: Vec<T> = chunk.iter().map(|&c| estimate_cell(c)).collect();
            progress.advance(chunk.len() as u64);
            out
        })
        .collect();
    progress.finish();
    results
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sequence::SamplePlan;

    #[test]
    fn smooth_surface_reflects_into_the_mirror_direction() {
        let points = PointSet::new(SamplePlan::new(64, 2).unwrap(), 1);
        let estimate = estimate_visible_normal_integral(0.6, 0.0, &points, 2, |s, sums| {
            sums[0] += s.cos_wi_h;
            sums[1] += MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, 0.0);
        });
        assert!((estimate.mean[0] - 0.6).abs() < 1e-12);
        assert_eq!(estimate.mean[1], 1.0);
        assert_eq!(estimate.standard_error, vec![0.0, 0.0]);
    }

    #[test]
    fn replicates_give_a_standard_error_that_covers_the_true_value() {
        // E[1] over a rough surface with the separable weight is the GD albedo; its error bars from
        // 16 replicates must be small and positive, and a 16x larger run must agree within them.
        let weight = |s: &MicrofacetSample, sums: &mut [f64]| {
            sums[0] += MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, 0.7)
        };
        let small_points = PointSet::new(SamplePlan::new(1 << 12, 16).unwrap(), 3);
        let large_points = PointSet::new(SamplePlan::new(1 << 18, 16).unwrap(), 4);
        let small = estimate_visible_normal_integral(0.3, 0.7, &small_points, 1, weight);
        let large = estimate_visible_normal_integral(0.3, 0.7, &large_points, 1, weight);
        let se = small.standard_error[0];
        assert!(se > 0.0 && se < 1e-3, "{se}");
        assert!((small.mean[0] - large.mean[0]).abs() < 5.0 * se, "{small:?} vs {large:?}");
    }

    #[test]
    fn cell_results_do_not_depend_on_the_thread_count() {
        let cells: Vec<u64> = (0..200).collect();
        let points = PointSet::new(SamplePlan::new(256, 4).unwrap(), 9);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                estimate_cells(&cells, "test", &(), |c| {
                    let mu = (c % 20) as f64 / 19.0;
                    estimate_visible_normal_integral(mu, 0.5, &points, 1, |s, sums| sums[0] += s.cos_wi_h).mean[0]
                })
            })
        };
        let one: Vec<u64> = run(1).iter().map(|v| v.to_bits()).collect();
        let three: Vec<u64> = run(3).iter().map(|v| v.to_bits()).collect();
        assert_eq!(one, three);
    }
}
