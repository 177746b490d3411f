//! The Fresnel equations of conductors and dielectrics, and the Fresnel basis a Belcour table is
//! read with (Belcour, Bati & Barla 2020): what reading the tables needs of the optics. The rest of
//! the optics (GGX, Smith, Henyey–Greenstein) is the generator's (`tmlut::physics`).

pub mod fresnel;
pub mod fresnel_basis;

pub use fresnel::{
    critical_cosine, fresnel_reflectance, normal_incidence_reflectance, schlick_reflectance, schlick_weight,
};
pub use fresnel_basis::FresnelBasis;
