//! Estimators the tests hold the tables to that share nothing with the tables' own paths (no
//! visible normals, no Sobol points, no quadrature): microfacet normals drawn from `D(h) h.z` with
//! pseudo-random points, as Karis (2013, p. 7) integrates his split-sum table.

use glam::DVec3;

use crate::physics::{MaskingShadowing, direction_from_cosine, reflect, schlick_weight};

/// xorshift64*: enough for a test, and unrelated to the Sobol points of the tables.
struct PseudoRandom(u64);

impl PseudoRandom {
    fn new() -> Self {
        PseudoRandom(0x853c_49e6_748f_ea9b)
    }

    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One normal drawn from `D(h) h.z` at the view `v`: its weight `G2 (v.h) / ((n.h)(n.v))` (zero
/// below the horizon) and `v.h`.
fn d_sample(masking: MaskingShadowing, v: DVec3, alpha: f64, random: &mut PseudoRandom) -> (f64, f64) {
    let (u1, u2) = (random.uniform(), random.uniform());
    let cos_h = ((1.0 - u1) / (1.0 + (alpha * alpha - 1.0) * u1)).sqrt();
    let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
    let l = reflect(v, h);
    let v_h = v.dot(h);
    if l.z <= 0.0 || v_h <= 0.0 {
        return (0.0, v_h);
    }
    (masking.g2(v, l, alpha) * v_h / (h.z * v.z), v_h)
}

/// The split sum at `(mu, alpha)`: `[∫ (1 - Fc) f cos, ∫ Fc f cos]` with `Fc = (1 - v.h)^5`, whose
/// sum is the albedo with `F = 1`.
pub fn d_importance_sampled(masking: MaskingShadowing, mu: f64, alpha: f64, samples: u32) -> [f64; 2] {
    let v = direction_from_cosine(mu);
    let mut random = PseudoRandom::new();
    let (mut scale, mut bias) = (0.0, 0.0);
    for _ in 0..samples {
        let (weight, v_h) = d_sample(masking, v, alpha, &mut random);
        let fc = schlick_weight(v_h.max(0.0));
        scale += (1.0 - fc) * weight;
        bias += fc * weight;
    }
    [scale / samples as f64, bias / samples as f64]
}

/// `E_avg(alpha) = 2 ∫ E(mu) mu dmu` with `F = 1`: each sample's view drawn with density `2 mu`
/// (`mu = sqrt(u)`), its normal from `D(h) h.z`.
pub fn average_albedo_d_sampled(masking: MaskingShadowing, alpha: f64, samples: u32) -> f64 {
    let mut random = PseudoRandom::new();
    let mut sum = 0.0;
    for _ in 0..samples {
        let mu = random.uniform().sqrt().max(1e-9);
        sum += d_sample(masking, direction_from_cosine(mu), alpha, &mut random).0;
    }
    sum / samples as f64
}
