//! Analytic forms fitted to tables by least squares. A form exists as a form file only
//! (`luts/forms/`, [`forms`]): read, compiled, fitted, certified and printed as shader code by the
//! generator, and evaluated from a manifest's definition by the loader-side model
//! ([`crate::ir::compile`]). The search itself ([`least_squares`]: NLopt) is the generator's.

pub mod forms;
#[cfg(feature = "generator")]
pub mod least_squares;

#[cfg(feature = "generator")]
pub use least_squares::*;
