//! tmlut: lookup tables for transfer-matrix layered materials (Randrianandrasana et al. 2021), as
//! brought to real-time rendering — integrated, checked, written with their conventions, and
//! loaded back.
//!
//! The modules follow the path of a table:
//! - [`physics`]: the optics every table integrates (GGX, Smith, Fresnel, Henyey–Greenstein);
//! - [`sampling`]: point sets and the visible-normal warp;
//! - [`integrate`]: Monte Carlo estimators over the visible-normal measure (generator);
//! - [`table`]: axes, grids and multilinear interpolation;
//! - [`recipes`]: one file per table, each the integral it computes (generator);
//! - [`formats`]: DDS, KTX2, OpenEXR, the original `.bin` layout and the manifest, written here and
//!   read by the loader;
//! - [`pipeline`]: a configuration in, files and a manifest out (generator), committed into a locked
//!   folder by [`commit`];
//! - [`packing`]: the 4D FGD table packed into volume textures, with the exact shader lookup and a
//!   GPU sampling emulator to measure it;
//! - [`shader`]: one emitter that writes every shader as HLSL and WGSL from one description, and
//!   the transfer-matrix evaluation of a scene's materials, and the read of baked ones;
//! - [`loader`]: what a renderer needs to read and sample the files;
//! - [`model`]: the transfer-matrix model itself: layer stacks, their lobes and directional albedo;
//! - [`bake`]: a material's whole model result tabulated over the view cosine, and what that costs
//!   in accuracy (generator);
//! - [`random_walk`]: the furnace test's ground truth, a random walk through an explicit layer stack
//!   (generator);
//! - [`stability`]: the stiff-case matrix over every physics function and table (generator);
//! - [`scene`]: scene files of layer stacks and the plan of the tables they need (generator);
//! - [`exact`]: the model's lookups answered by quadrature, with no table (what the furnace, the
//!   bake and the checks compare with) (generator);
//! - [`furnace`]: the furnace test: the model with tables, with exact integrals, and a random walk (generator);
//! - [`fit`]: forms written as text, fitted to any table by least squares with NLopt (generator); a
//!   fitted form compiled from a manifest's definition (loader side).
//!
//! The lowest layers (`error`, `stats`, `table`, `physics`, the reading side of `formats`, the
//! texture filter and `loader`) are the `tmlut-loader` crate (`crates/loader`), which a renderer
//! depends on alone; this crate re-exports them under the same names, its own writers beside the
//! loader's readers in `formats`. Without the default
//! `generator` feature this crate is the model and the form language over that loader.

// The loader crate's modules, as this crate's own: the layers every module here builds on.
pub use tmlut_loader::{error, filter, loader, memory, stats, table};
// The expression IR every shader and every recorded evaluation lowers to.
pub use tmlut_ir as ir;

pub mod fit;
// The loader's readers with this crate's writers beside them.
pub mod formats;
pub mod model;
pub mod packing;
pub mod physics;
#[cfg(feature = "generator")]
pub mod report;
pub mod sampling;
pub mod shader;

#[cfg(feature = "generator")]
pub mod bake;
#[cfg(feature = "generator")]
pub mod commit;
#[cfg(feature = "generator")]
pub mod config;
#[cfg(feature = "generator")]
pub mod exact;
#[cfg(feature = "generator")]
pub mod furnace;
#[cfg(feature = "generator")]
pub mod integrate;
#[cfg(feature = "generator")]
pub mod pipeline;
#[cfg(feature = "generator")]
pub mod presets;
#[cfg(feature = "generator")]
pub mod random_walk;
#[cfg(feature = "generator")]
pub mod recipes;
#[cfg(feature = "generator")]
pub mod scene;
#[cfg(feature = "generator")]
pub mod stability;

pub use error::{Error, Result};
pub use table::{Axis, Channel, Mapping, Placement, Table};

// The examples of `docs/loader.md` compile with this crate's doctests (it depends on the loader),
// not the loader's own: the guide lives in the repository, outside the loader's package.
#[cfg(doctest)]
#[doc = include_str!("../docs/loader.md")]
pub struct LoaderGuide;
