//! tmlut-loader: read and sample the lookup tables tmlut writes, for renderer crates. Its
//! dependencies are few and pure Rust (serde, sha2, half, ktx2; `exr` and `bytemuck` on
//! request); the generator (`tmlut`) depends on it, never the reverse, and writes the files this
//! crate reads. `docs/loader.md` walks through it.
//!
//! ```no_run
//! use tmlut_loader::{Alpha, KarisLut, LutFolder, Roughness, TirLut};
//!
//! let luts = LutFolder::open("out/luts")?;
//! let karis = KarisLut::from_folder(&luts)?; // karis.dds, verified against manifest.json
//! let [scale, bias] = karis.sample(0.5, Roughness(0.3)); // (n.v, perceptual roughness)
//! let tir = TirLut::open(&luts, "tir.dds")?;
//! let lost = tir.sample(0.7, Alpha(0.01), 0.9); // (mu, alpha, eta): the handle computes the axes' quantities
//! let texture = karis.texture()?; // bytes and descriptor of a `rg16float` 2D texture
//! assert_eq!(texture.to_bytes().len(), texture.descriptor().byte_len());
//! # Ok::<(), tmlut_loader::Error>(())
//! ```
//!
//! The modules, lowest first:
//! - [`error`]: the one error type, naming the file or key and what is allowed;
//! - [`stats`], [`table`], [`physics`]: error records, axes with multilinear interpolation, and
//!   the Fresnel equations a Belcour table is read with (its Fresnel basis);
//! - [`memory`]: the memory this process may use, read before a large file is decoded;
//! - [`formats`]: DDS, KTX2, OpenEXR, the original `.bin` layout and the manifest, read (each
//!   container's `layout` is what tmlut's writer of it follows);
//! - [`filter`]: a GPU's texture filtering, emulated exactly in f32 (the handles sample with it;
//!   the generator prints the same filter into its shaders);
//! - [`loader`]: an output folder and its manifest, its files read from disk or held in memory
//!   ([`LutFolder::from_source`]), typed handles, texture descriptors.

#![warn(missing_docs)]

pub mod error;
pub mod filter;
pub mod formats;
pub mod loader;
pub mod memory;
pub mod physics;
pub mod stats;
pub mod table;

pub use error::{Error, Result};
pub use loader::{
    Alpha, BakedLut, BelcourLut, DeviceLimits, FgdLut, FgdRarerLut, GdLut, GgxEAvgLut, GgxELut, InMemory, KarisLut,
    KarisMultiscatterLut, LutFolder, LutSource, MaterialFunction, OnDisk, Roughness, SceneShaderFiles,
    ShaderDescription, TextureBinding, TextureData, TextureDescriptor, TextureDimension, TextureFormat, TirLut,
};
pub use table::{Axis, Channel, Mapping, Placement, Table};

// The README's example compiles with the doctests (it needs a built folder to run). Kept apart from
// the crate docs above so that docs.rs does not show the crate's introduction twice.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
