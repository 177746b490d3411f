//! A GPU texture sampler in software: cell-centred linear filtering with clamp addressing, in f32,
//! reading texels as stored (f16 values widened exactly to f32), as Direct3D 11/12 and Vulkan
//! define it (D3D11 functional spec §7.18.8 "Linear Sample Addressing"; Vulkan spec, "Texel
//! Filtering"):
//!
//! ```text
//! a = u * N - 0.5,   i0 = floor(a),   f = a - i0,
//! value = (1 - f) * T[clamp(i0)] + f * T[clamp(i0 + 1)]     (per axis, x first, then y, then z)
//! ```
//!
//! Real hardware does not filter in f32: the fractional position `f` need only carry a few bits
//! (Direct3D 11 and 12: `D3D12_SUBTEXEL_FRACTIONAL_BIT_COUNT` = 8, Direct3D 10: 6; Vulkan:
//! `subTexelPrecisionBits`, required at least 4, commonly 8 on desktop GPUs). [`Filter::Exact`]
//! computes `f` in f32 as written above, the best a GPU could do; it isolates a lookup's own
//! error (its f32 coordinate arithmetic). [`Filter::QuantisedWeights`] rounds `f` to `bits`
//! fractional bits, the error a real GPU adds on top, reported separately. Neither touches
//! [`Texture3D::load`]: a lookup that loads texels and computes its weights itself gets the same
//! result on any GPU.

/// How the filter weight `f` is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    /// `f` in full f32.
    Exact,
    /// `f` rounded to this many fractional bits (8 on current hardware).
    QuantisedWeights { bits: u32 },
}

impl Filter {
    fn weight(self, f: f32) -> f32 {
        match self {
            Filter::Exact => f,
            Filter::QuantisedWeights { bits } => {
                let scale = (1u32 << bits.min(23)) as f32;
                (f * scale).round() / scale
            }
        }
    }
}

/// A single-channel volume texture as a shader reads it: `width * height * depth` texels, x
/// fastest, values already rounded to the storage precision.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture3D {
    pub width: usize,
    pub height: usize,
    pub depth: usize,
    pub texels: Vec<f32>,
}

/// Texel-space position along one axis of `n` texels: the two texels clamp addressing reads and
/// the weight of the second.
pub fn linear_taps(u: f32, n: usize, filter: Filter) -> (usize, usize, f32) {
    let a = u * n as f32 - 0.5;
    // A NaN coordinate reads texel 0 (clamp of an undefined address); never a NaN weight.
    let a = if a.is_nan() { 0.0 } else { a };
    let i0 = a.floor();
    let f = filter.weight(a - i0);
    let last = (n - 1) as f32;
    let lower = i0.clamp(0.0, last) as usize;
    let upper = (i0 + 1.0).clamp(0.0, last) as usize;
    (lower, upper, f)
}

/// `a` to `b` by `f`, in f32 as a GPU's linear filter blends two texels.
pub fn lerp(a: f32, b: f32, f: f32) -> f32 {
    (1.0 - f) * a + f * b
}

impl Texture3D {
    pub fn texel(&self, x: usize, y: usize, z: usize) -> f32 {
        self.texels[x + self.width * (y + self.height * z)]
    }

    /// `Load(int4(int(x), int(y), int(z), 0))`: the texel at integer indices given as f32 (converted
    /// toward zero, as HLSL `int()` and WGSL `i32()` do; NaN as 0). Out of range reads 0, as
    /// Direct3D specifies for `Load`; the lookups here never read out of range.
    pub fn load(&self, x: f32, y: f32, z: f32) -> f32 {
        let index = |v: f32, n: usize| {
            let i = v as i64; // saturating, toward zero, NaN -> 0
            (0..n as i64).contains(&i).then_some(i as usize)
        };
        match (index(x, self.width), index(y, self.height), index(z, self.depth)) {
            (Some(x), Some(y), Some(z)) => self.texel(x, y, z),
            _ => 0.0,
        }
    }

    /// `SampleLevel(sampler, float3(u, v, w), 0)` with a linear, clamp-addressed sampler.
    pub fn sample_trilinear(&self, u: f32, v: f32, w: f32, filter: Filter) -> f32 {
        let (x0, x1, fx) = linear_taps(u, self.width, filter);
        let (y0, y1, fy) = linear_taps(v, self.height, filter);
        let (z0, z1, fz) = linear_taps(w, self.depth, filter);
        let plane = |z| {
            let row = |y| lerp(self.texel(x0, y, z), self.texel(x1, y, z), fx);
            lerp(row(y0), row(y1), fy)
        };
        lerp(plane(z0), plane(z1), fz)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Texture3D {
        // T(x, y, z) = x + 10 y + 100 z: trilinear filtering reproduces it exactly between centres.
        let (w, h, d) = (4, 3, 2);
        let texels = (0..w * h * d).map(|i| ((i % w) + 10 * ((i / w) % h) + 100 * (i / (w * h))) as f32).collect();
        Texture3D { width: w, height: h, depth: d, texels }
    }

    #[test]
    fn texel_centres_read_their_texel_and_filtering_is_linear_between_them() {
        let t = ramp();
        assert_eq!(t.sample_trilinear(2.5 / 4.0, 1.5 / 3.0, 0.5 / 2.0, Filter::Exact), 12.0);
        let v = t.sample_trilinear(1.25 / 4.0, 1.0 / 3.0, 1.0 / 2.0, Filter::Exact);
        assert!((v - (0.75 + 5.0 + 50.0)).abs() < 1e-5, "{v}");
    }

    #[test]
    fn clamp_addressing_holds_the_edge_texels() {
        let t = ramp();
        assert_eq!(t.sample_trilinear(0.0, 0.0, 0.0, Filter::Exact), 0.0);
        assert_eq!(t.sample_trilinear(-3.0, 7.0, 2.0, Filter::Exact), 120.0);
        assert_eq!(t.sample_trilinear(f32::NAN, 0.0, 0.0, Filter::Exact), 0.0);
    }

    #[test]
    fn load_reads_one_texel_as_stored_and_zero_out_of_range() {
        let t = ramp();
        assert_eq!(t.load(3.0, 2.0, 1.0), 123.0);
        assert_eq!(t.load(1.9, 0.0, 0.0), 1.0);
        assert_eq!(t.load(4.0, 0.0, 0.0), 0.0);
        assert_eq!(t.load(-1.0, 0.0, 1.0), 0.0);
    }

    #[test]
    fn quantised_weights_round_to_the_given_bits() {
        let t = ramp();
        // x at a third of the way between texels 0 and 1: 8-bit weight 85/256 instead of 1/3.
        let v = t.sample_trilinear((0.5 + 1.0 / 3.0) / 4.0, 0.5 / 3.0, 0.5 / 2.0, Filter::QuantisedWeights { bits: 8 });
        assert!((v - 85.0 / 256.0).abs() < 1e-6, "{v}");
    }
}
