//! The optics every table integrates: the GGX microfacet distribution with its Smith terms,
//! reflection and refraction about a normal, Fresnel reflectance (the loader's, which reads a
//! Belcour table with it), and the Henyey–Greenstein phase function with the roughness mapping of
//! the transfer-matrix model.
//! All in f64 but the lobe statistics the transfer-matrix model reads, which are generic over
//! its number type ([`crate::ir::real::Real`]); each function is named by the quantity it returns
//! and cites its source.

pub mod henyey_greenstein;
pub mod microfacet;

pub use henyey_greenstein::{
    ggx_to_hg, henyey_greenstein_phase, hg_backward_share, hg_refract, hg_to_ggx, sample_henyey_greenstein,
    sample_henyey_greenstein_cosine,
};
pub use microfacet::{
    MaskingShadowing, direction_from_cosine, ggx_distribution, reflect, refract, schlick_smith_g1, smith_g1,
    smith_g2_height_correlated, smith_g2_height_correlated_transmission, smith_g2_separable, smith_lambda,
    visible_normal_density,
};
pub use tmlut_loader::physics::{
    FresnelBasis, critical_cosine, fresnel_reflectance, normal_incidence_reflectance, schlick_reflectance,
    schlick_weight,
};
pub use tmlut_loader::physics::{fresnel, fresnel_basis};
