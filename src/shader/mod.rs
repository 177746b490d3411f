//! The shader emitter of the loader crate ([`tmlut_loader::shader`]: one description printed as
//! HLSL and WGSL), and the transfer-matrix evaluation of a scene's materials built with it.

pub use tmlut_loader::shader::*;

// The scene shader reads materials' fitted forms through the generator's form language.
#[cfg(feature = "generator")]
pub mod scene;
#[cfg(feature = "generator")]
pub mod tape;
