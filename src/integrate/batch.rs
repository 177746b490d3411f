//! The fast path's inner loop: the visible-normal samples of one `(mu, alpha)` cell, computed in
//! f32 over structure-of-arrays point sets so that the compiler vectorises them.
//!
//! For a view direction in the xz-plane the frame of Heitz 2018 (Listing 1) is fixed:
//! `vh = (vx, 0, vz)`, `t1 = (0, 1, 0)`, `t2 = vh x t1 = (-vz, 0, vx)`, so a disk point `(x, y)`
//! with half chord `sqrt(1 - x^2)` becomes, with `p2 = (1 - s) sqrt(1 - x^2) + s y`,
//! `n3 = sqrt(1 - x^2 - p2^2)`:
//!
//! ```text
//! nh = (n3 vx - p2 vz,  x,  p2 vx + n3 vz),   h = normalise(alpha nh.x, alpha nh.y, max(0, nh.z))
//! ```
//!
//! When `vh = n` (smooth surface or normal view) that frame is a rotation of Heitz's, which
//! leaves the isotropic distribution unchanged. Every quantity is an element-wise IEEE operation
//! (no fused multiply-add), so the AVX2 and the baseline versions give the same bits.

use crate::physics::{MaskingShadowing, direction_from_cosine, smith_lambda};

/// Points per block: small enough for the block's arrays to stay in the L1 cache.
pub const BLOCK: usize = 512;

pub use crate::sampling::sequence::DiskPointsF32;

/// The per-cell constants of the warp.
#[derive(Debug, Clone, Copy)]
pub struct CellWarp {
    mu: f64,
    alpha: f64,
    vx: f32,
    vz: f32,
    s: f32,
    alpha32: f32,
    wi_x: f32,
    wi_z: f32,
    /// Whether the kernel fills [`SampleArrays::cos_offset`] (FGD's narrow lobes): it costs a
    /// division per sample, so only a cell that reads it asks for it.
    cosine_offset: bool,
}

impl CellWarp {
    /// The warp for the direction with cosine `mu` (already floored at the grazing cosine by the
    /// caller) and roughness `alpha`.
    pub fn new(mu: f64, alpha: f64) -> Self {
        let wi = direction_from_cosine(mu);
        let stretched = glam::DVec3::new(alpha * wi.x, 0.0, wi.z);
        let vh = stretched.normalize_or(glam::DVec3::Z);
        CellWarp {
            mu,
            alpha,
            vx: vh.x as f32,
            vz: vh.z as f32,
            s: (0.5 * (1.0 + vh.z)) as f32,
            alpha32: alpha as f32,
            wi_x: wi.x as f32,
            wi_z: wi.z as f32,
            cosine_offset: false,
        }
    }

    /// [`CellWarp::new`], also filling [`SampleArrays::cos_offset`].
    pub fn with_offsets(mu: f64, alpha: f64) -> Self {
        CellWarp { cosine_offset: true, ..Self::new(mu, alpha) }
    }

    avx2_dispatch! {
        /// `wi.h` and `wo.z` of each point, `wo = reflect(wi, h)`, and `wi.h - mu` where the warp was
        /// made for it ([`CellWarp::with_offsets`]).
        pub fn warp(&self, points: &DiskPointsF32, range: std::ops::Range<usize>, out: &mut SampleArrays)
            => warp_avx2, warp_portable
    }

    #[inline(always)]
    fn warp_portable(&self, points: &DiskPointsF32, range: std::ops::Range<usize>, out: &mut SampleArrays) {
        // One loop with the offset and one without, so that each is vectorised without a branch inside.
        if self.cosine_offset {
            self.warp_loop::<true>(points, range, out)
        } else {
            self.warp_loop::<false>(points, range, out)
        }
    }

    #[inline(always)]
    fn warp_loop<const COSINE_OFFSET: bool>(
        &self,
        points: &DiskPointsF32,
        range: std::ops::Range<usize>,
        out: &mut SampleArrays,
    ) {
        let n = range.len();
        let (x, y, half_chord) = (&points.x[range.clone()], &points.y[range.clone()], &points.half_chord[range]);
        let (cos_wi_h, wo_z) = (&mut out.cos_wi_h[..n], &mut out.wo_z[..n]);
        let cos_offset = &mut out.cos_offset[..n];
        let one_minus_s = 1.0 - self.s;
        for i in 0..n {
            let p2 = one_minus_s * half_chord[i] + self.s * y[i];
            let n3 = (1.0 - x[i] * x[i] - p2 * p2).max(0.0).sqrt();
            let hx = self.alpha32 * (n3 * self.vx - p2 * self.vz);
            let hy = self.alpha32 * x[i];
            let hz = (p2 * self.vx + n3 * self.vz).max(0.0);
            // A zero-length h (measure zero, at the disk's rim) scores below the horizon.
            let tangential2 = hx * hx + hy * hy;
            let length = (tangential2 + hz * hz).max(1e-30).sqrt();
            let inverse_length = 1.0 / length;
            let (unit_hx, unit_hz) = (hx * inverse_length, hz * inverse_length);
            let c = (self.wi_x * unit_hx + self.wi_z * unit_hz).clamp(0.0, 1.0);
            cos_wi_h[i] = c;
            wo_z[i] = 2.0 * c * unit_hz - self.wi_z;
            // The offset from the view without forming wi.h itself: hz - |h| =
            // -(hx^2 + hy^2) / (hz + |h|), and with wi.z = mu, wi.h - mu = (wi.x hx + mu (hz - |h|)) / |h|.
            // Every term keeps its relative precision, so a lobe narrower than the f32 spacing of c
            // (6e-8 near 1) keeps its shape.
            if COSINE_OFFSET {
                cos_offset[i] = (self.wi_x * hx - self.wi_z * tangential2 / (hz + length)) * inverse_length;
            }
        }
    }

    avx2_dispatch! {
        /// The visible-normal weight `G2(wi, wo) / G1(wi)` of each sample (see
        /// [`MaskingShadowing::visible_normal_weight`]), from `wo.z` alone: the tables' integrands are
        /// isotropic, so the weight depends on the direction only through its cosine.
        pub fn weights(&self, masking: MaskingShadowing, wo_z: &[f32], weight: &mut [f32])
            => weights_avx2, weights_portable
    }

    #[inline(always)]
    fn weights_portable(&self, masking: MaskingShadowing, wo_z: &[f32], weight: &mut [f32]) {
        let n = wo_z.len();
        let weight = &mut weight[..n];
        let a2 = (self.alpha * self.alpha) as f32;
        // alpha^2 tan^2(theta_o), finite: the ratio is capped so that alpha = 0 gives 0, not 0 * inf.
        let a2_tan2 = |z: f32| a2 * ((1.0 - z * z).max(0.0) / (z * z).max(1e-30)).min(1e30);
        match masking {
            // G1(wo) = 2 / (1 + sqrt(1 + alpha^2 tan^2)).
            MaskingShadowing::SmithSeparable => {
                for i in 0..n {
                    let z = wo_z[i];
                    let g1 = 2.0 / (1.0 + (1.0 + a2_tan2(z)).sqrt());
                    weight[i] = if z > 0.0 { g1 } else { 0.0 };
                }
            }
            // 1 / (1 + Lambda_o / (1 + Lambda_i)), Lambda = x / (2 (1 + sqrt(1 + x))).
            MaskingShadowing::SmithHeightCorrelated => {
                let lambda_i = smith_lambda(direction_from_cosine(self.mu), self.alpha);
                let inverse_one_plus_lambda_i = (1.0 / (1.0 + lambda_i)) as f32;
                for i in 0..n {
                    let z = wo_z[i];
                    let x = a2_tan2(z);
                    let lambda_o = x / (2.0 * (1.0 + (1.0 + x).sqrt()));
                    let w = 1.0 / (1.0 + lambda_o * inverse_one_plus_lambda_i);
                    weight[i] = if z > 0.0 { w } else { 0.0 };
                }
            }
            // G1s(wi) (1 + Lambda_i) G1s(wo), the first factor a per-cell constant.
            MaskingShadowing::SchlickSmith => {
                // G1s(n) = 1, so the weight toward the normal is the per-cell factor alone.
                let ratio =
                    masking.visible_normal_weight(direction_from_cosine(self.mu), glam::DVec3::Z, self.alpha) as f32;
                let k = (self.alpha / 2.0) as f32;
                for i in 0..n {
                    let z = wo_z[i].max(0.0);
                    let g1 = z / (z * (1.0 - k) + k).max(1e-30);
                    weight[i] = if wo_z[i] > 0.0 { ratio * g1 } else { 0.0 };
                }
            }
        }
    }
}

impl DiskPointsF32 {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}

/// The samples of one block, one array per quantity.
#[derive(Debug, Clone)]
pub struct SampleArrays {
    /// `wi.h`, the cosine Fresnel is evaluated at.
    pub cos_wi_h: [f32; BLOCK],
    /// `wi.h - mu`, computed without cancellation (for lobes narrower than the f32 spacing of
    /// `wi.h`; see [`CellWarp::warp`]); only from a [`CellWarp::with_offsets`].
    pub cos_offset: [f32; BLOCK],
    /// `wo.z` of the reflected direction (may be negative).
    pub wo_z: [f32; BLOCK],
    /// `G2 / G1(wi)` of the chosen masking-shadowing model; 0 below the horizon.
    pub weight: [f32; BLOCK],
}

impl SampleArrays {
    pub fn new() -> Self {
        SampleArrays { cos_wi_h: [0.0; BLOCK], cos_offset: [0.0; BLOCK], wo_z: [0.0; BLOCK], weight: [0.0; BLOCK] }
    }
}

impl Default for SampleArrays {
    fn default() -> Self {
        Self::new()
    }
}

/// A view of the first `len` samples of a block.
#[derive(Debug, Clone, Copy)]
pub struct SampleBlock<'a> {
    pub cos_wi_h: &'a [f32],
    pub cos_offset: &'a [f32],
    pub wo_z: &'a [f32],
    pub weight: &'a [f32],
}

/// Walk a cell's samples block by block, calling `visit` with each block. `masking` chooses the
/// weight.
pub fn for_each_block(
    warp: &CellWarp,
    masking: MaskingShadowing,
    points: &DiskPointsF32,
    mut visit: impl FnMut(SampleBlock),
) {
    let mut arrays = SampleArrays::new();
    let mut start = 0;
    while start < points.len() {
        let end = (start + BLOCK).min(points.len());
        let n = end - start;
        warp.warp(points, start..end, &mut arrays);
        warp.weights(masking, &arrays.wo_z[..n], &mut arrays.weight[..n]);
        visit(SampleBlock {
            cos_wi_h: &arrays.cos_wi_h[..n],
            cos_offset: &arrays.cos_offset[..n],
            wo_z: &arrays.wo_z[..n],
            weight: &arrays.weight[..n],
        });
        start = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::reflect;
    use crate::sampling::{DiskPoint, VisibleNormalSampler};

    fn points(n: usize) -> (Vec<DiskPoint>, DiskPointsF32) {
        let mut f64_points = Vec::new();
        let mut soa = DiskPointsF32::default();
        for i in 0..n {
            // A deterministic spread over the square, golden-ratio in the second coordinate.
            let u = [(i as f64 + 0.5) / n as f64, (i as f64 * 0.618_033_988_749_895) % 1.0];
            let p = DiskPoint::from_unit_square(u);
            soa.x.push(p.x as f32);
            soa.y.push(p.y as f32);
            soa.half_chord.push(p.half_chord as f32);
            f64_points.push(p);
        }
        (f64_points, soa)
    }

    #[test]
    fn f32_warp_and_weights_match_the_f64_sampler_in_distribution() {
        // The f32 kernel uses a rotated disk frame when vh = n, so compare estimates, not samples:
        // with the same points the means of smooth functions must agree to f32 rounding plus the
        // (small) effect of the rotation.
        let (f64_points, soa) = points(4096);
        for (mu, alpha) in [(0.7, 0.3), (0.05, 0.8), (1.0, 0.5), (0.4, 0.0), (1e-6, 0.2)] {
            let wi = direction_from_cosine(mu);
            let sampler = VisibleNormalSampler::new(wi, alpha);
            for masking in MaskingShadowing::ALL {
                let (mut sum64, mut sum_c64) = (0.0, 0.0);
                for p in &f64_points {
                    let h = sampler.sample(p);
                    let w = masking.visible_normal_weight(wi, reflect(wi, h), alpha);
                    sum64 += w;
                    sum_c64 += w * wi.dot(h);
                }
                let (mut sum32, mut sum_c32) = (0.0f64, 0.0f64);
                for_each_block(&CellWarp::new(mu, alpha), masking, &soa, |block| {
                    for (&c, &w) in block.cos_wi_h.iter().zip(block.weight) {
                        sum32 += w as f64;
                        sum_c32 += (w * c) as f64;
                    }
                });
                let n = f64_points.len() as f64;
                assert!(
                    (sum64 / n - sum32 / n).abs() < 2e-4,
                    "{masking:?} mu {mu} alpha {alpha}: {} vs {}",
                    sum64 / n,
                    sum32 / n
                );
                assert!((sum_c64 / n - sum_c32 / n).abs() < 2e-4, "{masking:?} mu {mu} alpha {alpha}");
            }
        }
    }

    #[test]
    fn samples_match_the_f64_sampler_off_the_normal() {
        // Away from vh = n the two frames coincide, so each sample must agree to f32 precision.
        let (f64_points, soa) = points(1000);
        let (mu, alpha) = (0.6, 0.4);
        let wi = direction_from_cosine(mu);
        let sampler = VisibleNormalSampler::new(wi, alpha);
        let mut out = SampleArrays::new();
        let warp = CellWarp::new(mu, alpha);
        for start in (0..1000).step_by(BLOCK) {
            let end = (start + BLOCK).min(1000);
            warp.warp(&soa, start..end, &mut out);
            for (i, point) in f64_points.iter().enumerate().take(end).skip(start) {
                let h = sampler.sample(point);
                let wo = reflect(wi, h);
                assert!((wi.dot(h) - out.cos_wi_h[i - start] as f64).abs() < 1e-5, "sample {i}");
                assert!((wo.z - out.wo_z[i - start] as f64).abs() < 1e-5, "sample {i}");
            }
        }
    }

    #[test]
    fn the_cosine_offset_keeps_its_precision_in_a_narrow_lobe() {
        // alpha = 1e-7: wi.h - mu is of order 1e-7, below the f32 spacing of wi.h near 1; the
        // offset must still match the f64 sampler's to a small fraction of itself.
        let (f64_points, soa) = points(256);
        for mu in [0.5, 1.0 - 5e-7, 1e-6] {
            let alpha = 1e-7;
            let wi = direction_from_cosine(mu);
            let sampler = VisibleNormalSampler::new(wi, alpha);
            let mut out = SampleArrays::new();
            CellWarp::with_offsets(mu, alpha).warp(&soa, 0..256, &mut out);
            let (mut f64_offsets, mut f32_offsets): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
            for (i, point) in f64_points.iter().enumerate() {
                f64_offsets.push(wi.dot(sampler.sample(point)) - mu);
                f32_offsets.push(out.cos_offset[i] as f64);
            }
            // The f32 frame is a rotation of the f64 one when vh = n, so compare the spread.
            let spread = |v: &[f64]| {
                let mean = v.iter().sum::<f64>() / v.len() as f64;
                (mean, (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt())
            };
            let ((m64, s64), (m32, s32)) = (spread(&f64_offsets), spread(&f32_offsets));
            assert!(s64 > 0.0 && (s32 - s64).abs() < 0.05 * s64, "mu {mu}: spread {s32:e} vs {s64:e}");
            assert!((m32 - m64).abs() < 0.05 * s64, "mu {mu}: mean {m32:e} vs {m64:e}");
        }
    }

    #[test]
    fn weights_are_finite_and_bounded_at_the_edges() {
        let wo_z = [-1.0, -1e-7, 0.0, 1e-30, 1e-7, 1e-3, 0.5, 1.0];
        for (mu, alpha) in [(1e-6, 0.0), (1e-6, 1.0), (1.0, 0.0), (0.5, 1e-7), (0.3, 1.0)] {
            for masking in MaskingShadowing::ALL {
                let mut w = [0.0f32; 8];
                CellWarp::new(mu, alpha).weights(masking, &wo_z, &mut w);
                for (z, w) in wo_z.iter().zip(w) {
                    assert!(
                        w.is_finite() && (0.0..=1.0 + 1e-6).contains(&w),
                        "{masking:?} mu {mu} alpha {alpha} z {z}: {w}"
                    );
                    if *z <= 0.0 {
                        assert_eq!(w, 0.0);
                    }
                }
            }
        }
    }
}
