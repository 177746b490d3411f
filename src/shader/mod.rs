//! The shader description of the IR crate ([`tmlut_ir::shader`]: one description printed as HLSL
//! and WGSL), and built with it the transfer-matrix evaluation of a scene's materials ([`scene`])
//! and the read of baked ones ([`baked`]).

pub use tmlut_ir::shader::*;

#[cfg(feature = "generator")]
pub mod baked;
#[cfg(feature = "generator")]
pub mod scene;
