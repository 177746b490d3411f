//! The shader description of the IR crate ([`tmlut_ir::shader`]: one description printed as HLSL
//! and WGSL), and the transfer-matrix evaluation of a scene's materials built with it.

pub use tmlut_ir::shader::*;

#[cfg(feature = "generator")]
pub mod scene;
