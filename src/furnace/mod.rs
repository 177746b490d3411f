//! The furnace test: every material of a scene under a uniform environment, its directional albedo
//! `A(mu)` from the transfer-matrix model with the scene's tables, from the model with exact
//! integrals, and from a random walk through the explicit stack, so that the error of the tables
//! and the error of the model are measured apart.

pub mod exact;
