//! The two ways a GGX lobe's roughness is given, as types, so that a table is never looked up
//! with the other one: the split sums of Karis and Belcour are over perceptual roughness, the
//! albedo, TIR and FGD tables over `alpha`. Each converts into the other (`alpha = roughness^2`,
//! Burley 2012, "Physically-based shading at Disney", section 5.4), so a handle accepts either.

/// GGX `alpha`, the width of the microfacet distribution (Walter et al. 2007): what the albedo
/// (`gd`), TIR, FGD and `fgd_rarer` tables are over.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Alpha(pub f32);

/// Perceptual roughness, as artists and engines set it: `alpha = roughness^2`. What the split
/// sums of Karis and Belcour are looked up by.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Roughness(pub f32);

impl From<Roughness> for Alpha {
    /// `alpha = roughness^2`, in f32.
    fn from(roughness: Roughness) -> Alpha {
        Alpha(roughness.0 * roughness.0)
    }
}

impl From<Alpha> for Roughness {
    /// `roughness = sqrt(alpha)`, in f32; a negative `alpha` is taken as 0.
    fn from(alpha: Alpha) -> Roughness {
        Roughness(alpha.0.max(0.0).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_converts_into_the_other_through_the_square() {
        assert_eq!(Alpha::from(Roughness(0.5)), Alpha(0.25));
        assert_eq!(Roughness::from(Alpha(0.25)), Roughness(0.5));
        assert_eq!(Roughness::from(Alpha(-1e-3)), Roughness(0.0));
    }
}
