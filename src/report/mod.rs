//! Reports a person reads: what a table file holds and under which conventions.

pub mod audit;
pub mod bench;
pub mod check;
pub mod ci;
pub mod converge;
pub mod error_map;
mod inspect;
pub mod plot;

pub use inspect::{Inspection, inspect};
