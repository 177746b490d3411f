//! The packings of the 4D FGD table into volume textures, with their exact lookups
//! ([`tmlut_loader::packing`]), and the report that measures each against its recipe.

pub use tmlut_loader::packing::*;

#[cfg(feature = "generator")]
pub mod report;
