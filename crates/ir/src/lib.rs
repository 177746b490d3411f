//! tmlut-ir: the one intermediate representation every piece of generated code lowers to, after
//! naga's shape (one IR, several front ends, several back ends).
//!
//! - The IR is a [`tape::Tape`]: f32/f64 instructions in order, each reading earlier ones,
//!   evaluated on the CPU in f32 or f64 with an exact reverse-mode gradient.
//! - Front ends: code written once over the number type [`real::Real`] (the transfer-matrix
//!   model, the optics it reads) is recorded onto a tape ([`record`]); a form's expressions,
//!   written in the small language of [`text`], are compiled onto one ([`compile`]).
//! - Back ends: the tape is printed ([`mod@print`]) as the statements of one shader description
//!   ([`shader`]), which prints itself as HLSL, WGSL and GLSL (and, through naga, MSL in
//!   `tmlut`); the same tape is what the CPU evaluates, so what a shader computes is checked
//!   without a GPU.
//!
//! The crates above: `tmlut-loader` below it (its error type), `tmlut` above it (the model, the
//! forms, the scene shader, the packings' lookups).

pub mod compile;
pub mod print;
pub mod real;
pub mod record;
pub mod shader;
pub mod tape;
pub mod text;
