//! Sampling the GGX distribution of visible normals (Heitz 2018, "Sampling the GGX distribution
//! of visible normals", JCGT 7(4), §3 and its Listing 1): map the view direction into the
//! configuration where the surface has roughness 1, sample the projected hemisphere there, and
//! map the normal back. The density of the result is
//! [`visible_normal_density`](crate::physics::visible_normal_density).

use glam::DVec3;

/// A point of the unit disk in the form the visible-normal warp consumes: `(x, y)` and the half
/// chord `sqrt(1 - x^2)`. Computing these (a square root, a sine and a cosine) does not depend on
/// the view direction, so a point set shared by every cell of a table pays for them once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskPoint {
    pub x: f64,
    pub y: f64,
    pub half_chord: f64,
}

impl DiskPoint {
    /// The polar map of the unit square onto the disk, `r = sqrt(u0)`, `phi = 2 pi u1`
    /// (Heitz 2018, Listing 1, l. 9-11).
    pub fn from_unit_square(u: [f64; 2]) -> Self {
        let r = u[0].sqrt();
        let (sin, cos) = (2.0 * std::f64::consts::PI * u[1]).sin_cos();
        let x = r * cos;
        DiskPoint { x, y: r * sin, half_chord: (1.0 - x * x).max(0.0).sqrt() }
    }
}

/// The visible-normal warp for one view direction and roughness, with its frame built once.
#[derive(Debug, Clone, Copy)]
pub struct VisibleNormalSampler {
    alpha: f64,
    /// The stretched view direction and a frame around it; `None` for a Dirac at the normal.
    frame: Option<[DVec3; 3]>,
    /// Weight of the disk's own second coordinate against the half chord (Listing 1, l. 12).
    s: f64,
}

impl VisibleNormalSampler {
    /// The sampler for `wi` (with `wi.z >= 0`) on a GGX surface of roughness `alpha`.
    pub fn new(wi: DVec3, alpha: f64) -> Self {
        // Stretch the view direction into the roughness-1 configuration (Listing 1, l. 3).
        let stretched = DVec3::new(alpha * wi.x, alpha * wi.y, wi.z);
        let length = stretched.length();
        // A smooth surface, or a rough one seen exactly edge-on with vanishing roughness, has all
        // its visible normals at n: the distribution is a Dirac there.
        if length.is_nan() || length <= 1e-150 {
            return VisibleNormalSampler { alpha, frame: None, s: 0.0 };
        }
        let vh = stretched / length;
        // An orthonormal basis around vh (Listing 1, l. 5-7).
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 { DVec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { DVec3::X };
        let t2 = vh.cross(t1);
        VisibleNormalSampler { alpha, frame: Some([vh, t1, t2]), s: 0.5 * (1.0 + vh.z) }
    }

    /// The microfacet normal for a disk point.
    #[inline]
    pub fn sample(&self, p: &DiskPoint) -> DVec3 {
        const NORMAL: DVec3 = DVec3::Z;
        let Some([vh, t1, t2]) = self.frame else { return NORMAL };
        // Warp the disk toward the visible half, reproject onto the hemisphere, unstretch
        // (Listing 1, l. 12-17).
        let p2 = (1.0 - self.s) * p.half_chord + self.s * p.y;
        let nh = p.x * t1 + p2 * t2 + (1.0 - p.x * p.x - p2 * p2).max(0.0).sqrt() * vh;
        let h = DVec3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(0.0));
        let h_length = h.length();
        if h_length.is_nan() || h_length <= 1e-150 { NORMAL } else { h / h_length }
    }
}

/// A microfacet normal `h` drawn from the visible normals of `wi` (which must have `wi.z >= 0`)
/// for a GGX surface of roughness `alpha`, from a point `u` of the unit square.
pub fn sample_visible_normal(wi: DVec3, alpha: f64, u: [f64; 2]) -> DVec3 {
    VisibleNormalSampler::new(wi, alpha).sample(&DiskPoint::from_unit_square(u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{direction_from_cosine, visible_normal_density};
    use std::f64::consts::PI;

    /// Bin `h` by (cos theta, phi): 8 bins in cos theta, 8 in phi over the full circle.
    fn bin_of(h: DVec3) -> usize {
        let c = ((h.z.clamp(0.0, 1.0) * 8.0) as usize).min(7);
        let phi = h.y.atan2(h.x).rem_euclid(2.0 * PI);
        let p = ((phi / (2.0 * PI) * 8.0) as usize).min(7);
        c * 8 + p
    }

    #[test]
    fn sampled_histogram_matches_the_analytic_density() {
        for (alpha, mu) in [(0.3, 0.8), (0.7, 0.25), (1.0, 0.05), (0.15, 0.5)] {
            let wi = direction_from_cosine(mu);
            // Warp a fine midpoint grid of the unit square: each point carries equal probability.
            let n = 600;
            let mut sampled = [0.0f64; 64];
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                    let h = sample_visible_normal(wi, alpha, u);
                    assert!((h.length() - 1.0).abs() < 1e-12 && h.z >= 0.0 && wi.dot(h) >= -1e-12);
                    sampled[bin_of(h)] += 1.0 / (n * n) as f64;
                }
            }
            // Integrate the analytic density over the same bins (midpoint rule in cos theta, phi).
            let mut analytic = [0.0f64; 64];
            let (nc, np) = (800, 800);
            for a in 0..nc {
                let cos = (a as f64 + 0.5) / nc as f64;
                let sin = (1.0 - cos * cos).sqrt();
                for b in 0..np {
                    let phi = 2.0 * PI * (b as f64 + 0.5) / np as f64;
                    let h = DVec3::new(sin * phi.cos(), sin * phi.sin(), cos);
                    analytic[bin_of(h)] += visible_normal_density(wi, h, alpha) * (2.0 * PI / np as f64) / nc as f64;
                }
            }
            for k in 0..64 {
                assert!(
                    (sampled[k] - analytic[k]).abs() < 2e-3,
                    "alpha {alpha} mu {mu} bin {k}: sampled {} analytic {}",
                    sampled[k],
                    analytic[k]
                );
            }
        }
    }

    #[test]
    fn smooth_and_edge_on_cases_return_the_normal() {
        assert_eq!(sample_visible_normal(direction_from_cosine(0.5), 0.0, [0.3, 0.9]), DVec3::Z);
        assert_eq!(sample_visible_normal(direction_from_cosine(0.0), 0.0, [0.3, 0.9]), DVec3::Z);
        let h = sample_visible_normal(direction_from_cosine(0.0), 0.5, [0.3, 0.9]);
        assert!(h.is_finite() && (h.length() - 1.0).abs() < 1e-12);
    }
}
