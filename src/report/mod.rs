//! Reports a person reads: what a table file holds and under which conventions.

mod inspect;

pub use inspect::inspect;
