//! Least-squares fits of analytic forms to the TIR table, with each form's error and evaluation
//! cost side by side.
//!
//! The forms themselves ([`forms`], with the dual numbers of their gradients) build without the
//! generator, so that a renderer evaluates a fitted form exactly as the fit did; the fitting
//! ([`least_squares`]: NLopt, timing, the build's fit) is the generator's.

pub mod dual;
pub mod forms;
#[cfg(feature = "generator")]
pub mod least_squares;
pub mod real;
#[cfg(feature = "generator")]
pub mod summary;
#[cfg(feature = "generator")]
pub mod text;

pub use forms::{ALL_FORMS, Form, ShaderLanguage};
#[cfg(feature = "generator")]
pub use least_squares::*;
