//! The transfer-matrix layered material model (Randrianandrasana, Callet & Lucas 2021), as a
//! renderer evaluates it: a layer stack in, the outgoing lobes and the directional albedo out.
//!
//! Loader side: built with `default-features = false`, so that a renderer crate can evaluate the
//! materials it loads tables for.

pub mod stack;

pub use stack::{FluxModel, Interface, Layer, MAX_LAYERS, Medium, Rgb, Stack};
