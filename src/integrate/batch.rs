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

/// The disk points of one replicate in structure-of-arrays form, f32.
#[derive(Debug, Clone, Default)]
pub struct DiskPointsF32 {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub half_chord: Vec<f32>,
}

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
        }
    }

    /// `wi.h` and `wo.z` of each point, `wo = reflect(wi, h)`. All slices have the same length.
    pub fn warp(&self, x: &[f32], y: &[f32], half_chord: &[f32], cos_wi_h: &mut [f32], wo_z: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { self.warp_avx2(x, y, half_chord, cos_wi_h, wo_z) };
                return;
            }
        }
        self.warp_portable(x, y, half_chord, cos_wi_h, wo_z);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn warp_avx2(&self, x: &[f32], y: &[f32], half_chord: &[f32], cos_wi_h: &mut [f32], wo_z: &mut [f32]) {
        self.warp_portable(x, y, half_chord, cos_wi_h, wo_z);
    }

    #[inline(always)]
    fn warp_portable(&self, x: &[f32], y: &[f32], half_chord: &[f32], cos_wi_h: &mut [f32], wo_z: &mut [f32]) {
        let n = x.len();
        let (y, half_chord, cos_wi_h, wo_z) = (&y[..n], &half_chord[..n], &mut cos_wi_h[..n], &mut wo_z[..n]);
        let one_minus_s = 1.0 - self.s;
        for i in 0..n {
            let p2 = one_minus_s * half_chord[i] + self.s * y[i];
            let n3 = (1.0 - x[i] * x[i] - p2 * p2).max(0.0).sqrt();
            let hx = self.alpha32 * (n3 * self.vx - p2 * self.vz);
            let hy = self.alpha32 * x[i];
            let hz = (p2 * self.vx + n3 * self.vz).max(0.0);
            // A zero-length h (measure zero, at the disk's rim) scores below the horizon.
            let inverse_length = 1.0 / (hx * hx + hy * hy + hz * hz).max(1e-30).sqrt();
            let hz = hz * inverse_length;
            let c = (self.wi_x * hx * inverse_length + self.wi_z * hz).clamp(0.0, 1.0);
            cos_wi_h[i] = c;
            wo_z[i] = 2.0 * c * hz - self.wi_z;
        }
    }

    /// The visible-normal weight `G2(wi, wo) / G1(wi)` of each sample (see
    /// [`MaskingShadowing::visible_normal_weight`]), from `wo.z` alone: the tables' integrands are
    /// isotropic, so the weight depends on the direction only through its cosine.
    pub fn weights(&self, masking: MaskingShadowing, wo_z: &[f32], weight: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { self.weights_avx2(masking, wo_z, weight) };
                return;
            }
        }
        self.weights_portable(masking, wo_z, weight);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn weights_avx2(&self, masking: MaskingShadowing, wo_z: &[f32], weight: &mut [f32]) {
        self.weights_portable(masking, wo_z, weight);
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

/// Walk a cell's samples block by block: for each block, `visit(cos_wi_h, wo_z, weight)` with
/// equal-length slices. `masking` chooses the weight.
pub fn for_each_block(
    warp: &CellWarp,
    masking: MaskingShadowing,
    points: &DiskPointsF32,
    mut visit: impl FnMut(&[f32], &[f32], &[f32]),
) {
    let mut cos_wi_h = [0.0f32; BLOCK];
    let mut wo_z = [0.0f32; BLOCK];
    let mut weight = [0.0f32; BLOCK];
    let mut start = 0;
    while start < points.len() {
        let end = (start + BLOCK).min(points.len());
        let n = end - start;
        warp.warp(
            &points.x[start..end],
            &points.y[start..end],
            &points.half_chord[start..end],
            &mut cos_wi_h[..n],
            &mut wo_z[..n],
        );
        warp.weights(masking, &wo_z[..n], &mut weight[..n]);
        visit(&cos_wi_h[..n], &wo_z[..n], &weight[..n]);
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
                for_each_block(&CellWarp::new(mu, alpha), masking, &soa, |c, _, w| {
                    for i in 0..c.len() {
                        sum32 += w[i] as f64;
                        sum_c32 += (w[i] * c[i]) as f64;
                    }
                });
                let n = f64_points.len() as f64;
                assert!((sum64 / n - sum32 / n).abs() < 2e-4, "{masking:?} mu {mu} alpha {alpha}: {} vs {}", sum64 / n, sum32 / n);
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
        let mut cos = vec![0.0; 1000];
        let mut woz = vec![0.0; 1000];
        CellWarp::new(mu, alpha).warp(&soa.x, &soa.y, &soa.half_chord, &mut cos, &mut woz);
        for (i, p) in f64_points.iter().enumerate() {
            let h = sampler.sample(p);
            assert!((wi.dot(h) - cos[i] as f64).abs() < 1e-5, "sample {i}");
            assert!((reflect(wi, h).z - woz[i] as f64).abs() < 1e-5, "sample {i}");
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
                    assert!(w.is_finite() && (0.0..=1.0 + 1e-6).contains(&w), "{masking:?} mu {mu} alpha {alpha} z {z}: {w}");
                    if *z <= 0.0 {
                        assert_eq!(w, 0.0);
                    }
                }
            }
        }
    }
}
