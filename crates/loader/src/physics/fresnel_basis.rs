//! The Fresnel basis of Belcour, Bati & Barla 2020 ("Bringing an accurate Fresnel to real-time
//! rendering: a preintegrable decomposition", SIGGRAPH 2020 course notes): Fresnel reflectance for
//! any complex index is written `F(c) ≈ c0 + c1 b1(c) + c2 b2(c) + c3 b3(c)` with three tabulated
//! curves, so that a split-sum table storing `∫ b_k D G2 / (4 mu)` gives the albedo with one fetch.
//!
//! This module holds what a renderer needs at run time: the tabulated curves, their evaluation and
//! the projection of `(eta, kappa)` onto coefficients. Building the curves (by singular value
//! decomposition of many Fresnel curves) is the generator's job, in `recipes::belcour`.

use serde::{Deserialize, Serialize};

use super::fresnel_reflectance;

/// Three basis curves tabulated on uniform cosines over [0, 1] (`b0 = 1` is implicit), and the two
/// probe cosines where the coefficients of `b2` and `b3` are fitted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct FresnelBasis {
    /// Number of uniform samples `c_i = i / (samples - 1)` of each curve.
    pub samples: usize,
    /// Where the samples lie, in words: [`SAMPLE_COSINES`].
    #[serde(default)]
    pub sample_cosines: String,
    /// Curve `b1` at the `samples` cosines: its coefficient is `c1 = 1 - F(1)`.
    pub b1: Vec<f64>,
    /// Curve `b2` at the `samples` cosines, its coefficient fitted at the probe cosines.
    pub b2: Vec<f64>,
    /// Curve `b3` at the `samples` cosines, its coefficient fitted at the probe cosines.
    pub b3: Vec<f64>,
    /// `[ct1, ct2]`: the cosine of the maximum of `b2`, and the extremum of `b3` farthest from it.
    pub probe_cosines: [f64; 2],
    /// How a shader computes `c0..c3` and which Fresnel defines them: [`COEFFICIENTS`].
    #[serde(default)]
    pub coefficients: String,
}

/// [`FresnelBasis::sample_cosines`].
pub const SAMPLE_COSINES: &str = "sample i of a curve (i = 0 .. samples - 1) is at cosine c_i = i / (samples - 1): c_0 = 0 and \
     the last at 1; between samples a curve is interpolated linearly in c, and c is clamped to [0, 1]";

/// [`FresnelBasis::coefficients`]: [`FresnelBasis::coefficients`] and [`fresnel_reflectance`] in words.
pub const COEFFICIENTS: &str = "c0 = F(1), c1 = 1 - c0, and (c2, c3) solve c2 b2(ct_j) + c3 b3(ct_j) = F(ct_j) - c0 - c1 b1(ct_j) \
     at the two probe cosines ct_1, ct_2 (c2 = c3 = 0 where the 2 x 2 determinant is below 1e-12); b_k(c) as \
     sample_cosines says. F(c) is the exact unpolarised Fresnel reflectance at incident cosine c of the relative \
     complex index eta + i kappa: s^2 = 1 - c^2, t0 = eta^2 - kappa^2 - s^2, a^2 + b^2 = sqrt(t0^2 + 4 eta^2 kappa^2), \
     a^2 = (a^2 + b^2 + t0) / 2, b^2 = (a^2 + b^2 - t0) / 2, Rs = ((a - c)^2 + b^2) / ((a + c)^2 + b^2), \
     Rp = Rs ((a c - s^2)^2 + (b c)^2) / ((a c + s^2)^2 + (b c)^2), F = (Rs + Rp) / 2; 1 past the critical angle of \
     a dielectric with eta < 1";

impl FresnelBasis {
    /// A basis of curves tabulated at `c_i = i / (samples - 1)`.
    pub fn new(b1: Vec<f64>, b2: Vec<f64>, b3: Vec<f64>, probe_cosines: [f64; 2]) -> Self {
        FresnelBasis {
            samples: b1.len(),
            sample_cosines: SAMPLE_COSINES.into(),
            b1,
            b2,
            b3,
            probe_cosines,
            coefficients: COEFFICIENTS.into(),
        }
    }

    /// Basis curve `k` (0 to 3; `b0 = 1`) at cosine `c`, linearly interpolated between samples.
    pub fn evaluate(&self, k: usize, c: f64) -> f64 {
        let curve = match k {
            0 => return 1.0,
            1 => &self.b1,
            2 => &self.b2,
            3 => &self.b3,
            _ => panic!("the Fresnel basis has curves 0 to 3, not {k}"),
        };
        let u = c.clamp(0.0, 1.0) * (self.samples - 1) as f64;
        let i = (u as usize).min(self.samples - 2);
        let t = u - i as f64;
        curve[i] * (1.0 - t) + curve[i + 1] * t
    }

    /// The coefficients `[c0, c1, c2, c3]` of `F(.; eta, kappa)`: `c0 = F(1)`, `c1 = 1 - c0`, and
    /// `(c2, c3)` solving `c2 b2(ct_j) + c3 b3(ct_j) = F(ct_j) - c0 - c1 b1(ct_j)` at the two probes.
    /// (The thesis shader left this last step out, so its `c2` and `c3` were always 0.)
    pub fn coefficients(&self, eta: f64, kappa: f64) -> [f64; 4] {
        let c0 = fresnel_reflectance(1.0, eta, kappa);
        let c1 = 1.0 - c0;
        let [p, q] = self.probe_cosines;
        let residual = |c: f64| fresnel_reflectance(c, eta, kappa) - c0 - c1 * self.evaluate(1, c);
        let (a11, a12, a21, a22) = (self.evaluate(2, p), self.evaluate(3, p), self.evaluate(2, q), self.evaluate(3, q));
        let determinant = a11 * a22 - a12 * a21;
        if determinant.abs() < 1e-12 {
            return [c0, c1, 0.0, 0.0];
        }
        let (d1, d2) = (residual(p), residual(q));
        [c0, c1, (d1 * a22 - a12 * d2) / determinant, (a11 * d2 - a21 * d1) / determinant]
    }

    /// The approximation `Σ c_k b_k(c)` of Fresnel at cosine `c`.
    pub fn approximate(&self, coefficients: &[f64; 4], c: f64) -> f64 {
        (0..4).map(|k| coefficients[k] * self.evaluate(k, c)).sum()
    }
}
