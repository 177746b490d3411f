//! Reports a person reads: what a table file holds and under which conventions.

pub mod bench;
pub mod check;
mod inspect;

pub use inspect::inspect;
