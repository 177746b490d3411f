//! The memory a scene's build, shader and furnace need, estimated from the scene before they
//! allocate, so that a library too large for the process's limit (`ulimit -v`, a container's) is
//! refused up front, naming the limit, rather than aborted minutes in on a failed allocation.
//!
//! The rates are upper bounds of what generated libraries (`scripts/make-library`) took on this
//! project's machine kind, address space as `ulimit -v` counts it (`VmPeak`), with a margin: a
//! build of 1,000 materials (3,345 slices and the library's shader) reserved 0.70 GiB, one of
//! 10,240 (32,529 slices) 4.2 GiB; the furnace of 1,000 materials 0.30 GiB. `docs/scenes.md`,
//! "Memory", has the measurements and their commands.

use crate::error::{Error, Result};

/// What every run reserves before any table: the program, its threads' stacks and the
/// allocator's arenas.
pub const BASE_BYTES: u128 = 384 << 20;

/// Per slice of a build: its values, replicate errors, provenance and manifest entry, held until
/// the texture arrays are written.
pub const BYTES_PER_SLICE: u128 = 48 << 10;

/// Per material of a scene's shader: its function in each language and the module around it.
pub const SHADER_BYTES_PER_MATERIAL: u128 = 288 << 10;

/// Per material of a furnace run: its curves at every view, with the exact integrals and the
/// folder's tables it reads.
pub const FURNACE_BYTES_PER_MATERIAL: u128 = 192 << 10;

/// Refuse work that needs `bytes` where this process may use less ([`crate::memory::beyond_limit`]):
/// `key` names what is refused (a scene, an option), `what` the work, `lower` what to change.
pub fn check(key: &str, what: &str, bytes: u128, lower: &str) -> Result<()> {
    match crate::memory::beyond_limit(bytes, what) {
        Some(words) => Err(Error::invalid(key, format!("{words}: {lower}, or raise the limit"))),
        None => Ok(()),
    }
}
