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

use crate::table::Arithmetic;

/// How the filter weight `f` is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    /// `f` in full f32.
    Exact,
    /// `f` rounded to this many fractional bits (8 on current hardware).
    QuantisedWeights {
        /// Fractional bits kept in `f` (a GPU's sub-texel precision); more than 23 counts as 23.
        bits: u32,
    },
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
    /// Texels along x.
    pub width: usize,
    /// Texels along y.
    pub height: usize,
    /// Texels along z.
    pub depth: usize,
    /// `width * height * depth` values, x fastest, then y, then z.
    pub texels: Vec<f32>,
}

/// One axis of the linear filter, over any arithmetic: the texel-space position `a = u N - 0.5`,
/// the lower and upper texels clamp addressing reads (`floor(a)` and `floor(a) + 1` clamped to
/// `[0, N - 1]`, as values of the arithmetic) and the upper one's weight `a - floor(a)`. Written
/// once: the CPU's sampler computes it in f32 ([`linear_taps`]) and the scene shader prints it, its
/// intermediate values named through `bind` (the CPU's binds nothing).
pub fn linear_taps_in<A: Arithmetic>(u: A, n: A, mut bind: impl FnMut(&'static str, A) -> A) -> (A, A, A) {
    let a = bind("a", u * n.clone() - A::of(0.5));
    let i0 = bind("i", a.clone().floor());
    let weight = bind("f", a - i0.clone());
    let last = n - A::of(1.0);
    let lower = i0.clone().clamp(A::of(0.0), last.clone());
    let upper = (i0 + A::of(1.0)).clamp(A::of(0.0), last);
    (lower, upper, weight)
}

/// Texel-space position along one axis of `n` texels: the two texels clamp addressing reads and
/// the weight of the second ([`linear_taps_in`] in f32).
pub fn linear_taps(u: f32, n: usize, filter: Filter) -> (usize, usize, f32) {
    if u.is_nan() {
        // A NaN coordinate reads texel 0 (clamp of an undefined address); never a NaN weight.
        return (0, 1.min(n - 1), 0.0);
    }
    let (lower, upper, f) = linear_taps_in(u, n as f32, |_, value| value);
    (lower as usize, upper as usize, filter.weight(f))
}

/// `a` to `b` by `f`, in the arithmetic a GPU's linear filter blends two texels in: `(1 - f) a + f b`.
pub fn lerp<A: Arithmetic>(a: A, b: A, f: A) -> A {
    (A::of(1.0) - f.clone()) * a + f * b
}

/// The texels `texel(x, y)` around a point, weighed bilinearly by its taps along each axis
/// ([`linear_taps_in`]), x first: the filter of a 2D texture, over any arithmetic.
pub fn bilinear<A: Arithmetic, I: Clone>(taps: [(I, I, A); 2], texel: impl Fn(I, I) -> A) -> A {
    let [(x0, x1, fx), (y0, y1, fy)] = taps;
    let row = |y: I| lerp(texel(x0.clone(), y.clone()), texel(x1.clone(), y), fx.clone());
    lerp(row(y0), row(y1), fy)
}

/// [`bilinear`] in each of the two planes around a point, then between them: the filter of a
/// volume texture, x first, then y, then z.
pub fn trilinear<A: Arithmetic, I: Clone>(taps: [(I, I, A); 3], texel: impl Fn(I, I, I) -> A) -> A {
    let [x, y, (z0, z1, fz)] = taps;
    let plane = |z: I| bilinear([x.clone(), y.clone()], |x, y| texel(x, y, z.clone()));
    lerp(plane(z0), plane(z1), fz)
}

impl Texture3D {
    /// The texel at `(x, y, z)`; panics out of range (unlike [`Texture3D::load`]).
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
        let taps = [(u, self.width), (v, self.height), (w, self.depth)].map(|(c, n)| linear_taps(c, n, filter));
        trilinear(taps, |x, y, z| self.texel(x, y, z))
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
