//! The integration tests, one binary (one link of the library, and every test in one parallel
//! run): each module was a test file of its own.

mod check;
mod cli;
mod common;
mod conventions;
mod emulator;
mod furnace;
mod fuzz;
mod hardening;
mod layers;
mod repository;
mod shader;
