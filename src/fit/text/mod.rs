//! Forms written as text: a form file names a table, its parameters and one expression per
//! channel ([`form`], in the language of [`expr`]); it is compiled once ([`tape`]) and evaluated
//! in f32 or f64 with an exact gradient, fitted by the same search as the built-in forms
//! ([`fitting`]) over a region of the table with weights ([`region`]), costed beside the table's
//! fetch ([`cost`]), and printed as WGSL, HLSL, GLSL and MSL ([`shader`]). `docs/fit.md`, "Forms as
//! text", describes the language and the command.

pub mod batch;
pub mod cost;
pub mod expr;
pub mod fitted;
pub mod fitting;
pub mod form;
pub mod pictures;
pub mod region;
pub mod shader;
pub mod tape;

pub use fitted::{FittedForm, FormEvaluator};
pub use fitting::{FormFitRequest, FormReport, fit_form_file};
pub use form::Form;
pub use region::{Range, Region, WeightsSpec};

#[cfg(test)]
mod tests;
