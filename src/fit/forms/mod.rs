//! Forms written as text: a form file names a table, its parameters and one expression per
//! channel ([`form`], in the language of [`crate::ir::text`]); it is compiled once onto the IR's
//! tape ([`crate::ir::compile`]) and evaluated in f32 or f64 with an exact gradient, and fitted by
//! least squares ([`fitting`]) over a region of the table with weights ([`region`]): to the
//! table's points ([`data`]) prepared for the search ([`prepared`]), judged by its error figures
//! ([`figures`]), what it leaves ill-determined ([`identifiability`]) and exact integrals
//! ([`certify`]), and reported ([`markdown`]); it is costed beside the table's fetch ([`cost`]) and
//! printed as WGSL, HLSL, GLSL and MSL ([`shader`]).
//! `docs/fit.md`, "Forms as text", describes the language and the command; [`build`] is the TIR
//! form the default build fits.
//!
//! The expression language, the tape and a form compiled from the definition a manifest states are
//! the IR crate's ([`crate::ir`]), so that the model evaluates a built folder's fitted form as the
//! fit judged it without the generator; reading form files (TOML), fitting, regions, weights,
//! costs and printing are the generator's, here.

#[cfg(feature = "generator")]
pub mod batch;
#[cfg(feature = "generator")]
pub mod build;
#[cfg(feature = "generator")]
pub mod certify;
#[cfg(feature = "generator")]
pub mod cost;
#[cfg(feature = "generator")]
pub mod data;
#[cfg(feature = "generator")]
pub mod figures;
#[cfg(feature = "generator")]
pub mod fitted;
#[cfg(feature = "generator")]
pub mod fitting;
#[cfg(feature = "generator")]
pub mod form;
#[cfg(feature = "generator")]
pub mod identifiability;
#[cfg(feature = "generator")]
pub mod markdown;
#[cfg(feature = "generator")]
pub mod pictures;
#[cfg(feature = "generator")]
pub mod prepared;
#[cfg(feature = "generator")]
pub mod region;
#[cfg(feature = "generator")]
pub mod shader;

pub use crate::ir::compile::FormEvaluator;
#[cfg(feature = "generator")]
pub use fitted::FittedForm;
#[cfg(feature = "generator")]
pub use fitting::{FitOptions, FolderFitRequest, FormFitRequest, FormReport, fit_form_file, fit_form_files};
#[cfg(feature = "generator")]
pub use form::Form;
#[cfg(feature = "generator")]
pub use region::{Range, Region, SceneLookups, WeightsSpec};

#[cfg(all(test, feature = "generator"))]
mod tests;
