//! Packings of the 4D FGD table into volume textures a GPU can bind, each with the exact lookup a
//! shader runs (`docs/packing.md`).
//!
//! A 64^4 table has no 4D texture to live in, and a volume texture holds at most 2048 texels per
//! dimension (Direct3D 12, `D3D12_REQ_TEXTURE3D_U_V_OR_W_DIMENSION`). Every packing here is a
//! [`PackedFgd`]: the texels as stored, and one [`Program`], a function of the IR's shader
//! description that is at once the HLSL and WGSL lookup written beside the texture and the code
//! the IR runs on the CPU to measure it, its reads answered by the [`emulator`], so the error
//! figures are those of the shader a renderer pastes.
//!
//! - [`Packing::Lossless`] (the default): every node kept. Each kappa node is one `mu x alpha`
//!   tile, tiles in a near-square grid in x and y, eta along z. The lookup computes the 4D
//!   interpolation weights itself, exactly (its `node_bracket`), `Load`s the 16 texels of the
//!   cell and lerps them in f32: no hardware filtering, so it matches 4D multilinear interpolation
//!   to f32 rounding (below 1e-6 for values in [0, 1]) on any GPU.
//! - [`Packing::LosslessFiltered`]: the same texture read with two trilinear fetches (the kappa
//!   tiles around kappa; the hardware interpolates mu, alpha and eta) and one manual lerp. The x
//!   and y coordinates are clamped to the tile's first and last texel centres, where linear
//!   filtering gives the neighbouring tile weight zero, so filtering never blends across tiles.
//!   Cheaper, but hardware filtering costs accuracy: f32 texture coordinates place the filter
//!   only to `ulp(texel index)` (3e-5 texel at texel 448 of 512), and real GPUs round the filter
//!   weight to 8 bits.
//! - [`Packing::Thesis`]: the thesis renderer's 64 x 64 x 2048 volume, kappa halved by averaging
//!   node pairs and depth slice `eta_index * 32 + kappa_half_index`, read with the correct
//!   coordinates (kappa clamped inside its eta block, two fetches along eta, a manual lerp), so that
//!   its error is the packing's own and not its shader's.
//!
//! The texture filter the emulator runs is the loader's ([`tmlut_loader::filter`]: the loader
//! samples textures with it too); the packing report ([`report`]) measures each packing against
//! its recipe.

/// The emulator of a GPU's texture filtering, the loader's.
pub use tmlut_loader::filter as emulator;
#[cfg(feature = "generator")]
pub mod report;
pub mod shader;

use std::ops::{Add, Mul, Sub};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::formats::Precision;
use crate::formats::manifest::AxisEntry;
use crate::shader::{Expr, float};
use crate::table::{Axis, Channel, Mapping, Placement, Table};
pub use emulator::{Filter, Texture3D};
pub use shader::{Program, ProgramBuilder, clamp, lerp, log, with_sign_of};

/// Texels per dimension a volume texture may have (Direct3D 12; Vulkan guarantees at least 256,
/// desktop GPUs 2048).
pub const MAX_VOLUME_EXTENT: usize = 2048;

/// The quantities of the FGD table, in its axis order, as the lookup's parameters.
pub const FGD_INPUTS: [&str; 4] = ["mu", "alpha", "eta", "kappa"];

/// A way to pack the 4D FGD table into one volume texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Packing {
    /// The thesis renderer's layout: kappa halved by averaging pairs, `z = eta * Nk/2 + kappa/2`.
    Thesis,
    /// Every node; kappa tiles in x and y, eta along z; 16 texel loads and f32 lerps with weights
    /// computed in the shader.
    Lossless,
    /// The lossless texture read with two trilinear fetches and a lerp over kappa.
    LosslessFiltered,
}

impl Packing {
    pub const ALL: [Packing; 3] = [Packing::Thesis, Packing::LosslessFiltered, Packing::Lossless];

    pub fn name(self) -> &'static str {
        match self {
            Packing::Thesis => "thesis",
            Packing::Lossless => "lossless",
            Packing::LosslessFiltered => "lossless-filtered",
        }
    }

    /// Whether every node is stored unchanged (up to the storage precision).
    pub fn keeps_every_node(self) -> bool {
        matches!(self, Packing::Lossless | Packing::LosslessFiltered)
    }

    pub fn parse(text: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|p| p.name() == text.trim()).ok_or_else(|| {
            Error::invalid("packing", format!("unknown packing `{}`; allowed: {}", text.trim(), Self::names()))
        })
    }

    pub fn names() -> String {
        Self::ALL.map(|p| p.name()).join(", ")
    }

    /// The file stem of the texture and shaders, e.g. `fgd_lossless`.
    pub fn file_stem(self) -> String {
        format!("fgd_{}", self.name())
    }

    /// The texture extent `[width, height, depth]` for an FGD table of node counts
    /// `[mu, alpha, eta, kappa]`, or why the packing cannot hold it.
    pub fn extent(self, [n_mu, n_alpha, n_eta, n_kappa]: [usize; 4]) -> Result<[usize; 3]> {
        let key = format!("packing `{}`", self.name());
        let extent = match self {
            Packing::Lossless | Packing::LosslessFiltered => {
                // Width and height are rounded up to powers of two: then a tile's first and last
                // texel centres, `(t + 0.5) / W`, are exact in f32 and filtering there gives the
                // next tile weight exactly 0, not a rounding residue (512 x 512 for 64^4 as is).
                let (columns, rows) = tile_grid(n_kappa);
                [(columns * n_mu).next_power_of_two(), (rows * n_alpha).next_power_of_two(), n_eta]
            }
            Packing::Thesis => {
                if n_kappa % 2 != 0 || n_kappa < 4 {
                    return Err(Error::invalid(
                        key,
                        format!(
                            "halves kappa by averaging node pairs; {n_kappa} kappa nodes given, it needs an even \
                             count of at least 4"
                        ),
                    ));
                }
                [n_mu, n_alpha, n_eta * (n_kappa / 2)]
            }
        };
        if let Some(too_big) = extent.iter().find(|&&e| e > MAX_VOLUME_EXTENT) {
            return Err(Error::invalid(
                key,
                format!(
                    "needs a {} x {} x {} volume for {n_mu} x {n_alpha} x {n_eta} x {n_kappa} nodes; {too_big} exceeds \
                     the {MAX_VOLUME_EXTENT} texels a volume texture may have per dimension",
                    extent[0], extent[1], extent[2]
                ),
            ));
        }
        Ok(extent)
    }
}

/// Columns and rows of the kappa tile grid: near-square, `columns = ceil(sqrt(n))` (8 x 8 for 64).
pub fn tile_grid(n_kappa: usize) -> (usize, usize) {
    let mut columns = (n_kappa as f64).sqrt().ceil() as usize;
    while columns * columns < n_kappa {
        columns += 1;
    }
    (columns, n_kappa.div_ceil(columns))
}

/// A packed FGD texture and its lookup.
#[derive(Debug, Clone)]
pub struct PackedFgd {
    pub packing: Packing,
    pub precision: Precision,
    /// The texels as a shader reads them (already rounded to `precision`).
    pub texture: Texture3D,
    pub program: Program,
    /// The source table's axes.
    pub source_axes: Vec<Axis>,
    /// Where each source axis is stored and how the lookup addresses it.
    pub axis_entries: Vec<AxisEntry>,
    /// The layout in words, one line per fact.
    pub layout: Vec<String>,
    /// Whether every node of the source table is stored unchanged (up to `precision`).
    pub lossless: bool,
}

/// Check that a table named `name` with `axes` and `channel_count` channels is an FGD table the
/// packings understand; return its node counts.
fn fgd_counts(name: &str, axes: &[Axis], channel_count: usize) -> Result<[usize; 4]> {
    let key = format!("table `{name}`");
    let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
    if names != FGD_INPUTS || channel_count != 1 {
        return Err(Error::invalid(
            key,
            format!(
                "has axes ({}) and {} channel(s); a packing takes the FGD table: axes (mu, alpha, eta, kappa), one \
                 channel",
                names.join(", "),
                channel_count
            ),
        ));
    }
    for axis in axes {
        let mapped = matches!(axis.mapping, Mapping::Identity | Mapping::Sqrt | Mapping::SqrtEnds)
            || axis.mapping.asinh_parts().is_some();
        if axis.placement != Placement::NodeAligned || !mapped {
            return Err(Error::invalid(
                key,
                format!(
                    "axis `{}` is {:?} with mapping {}; a packing takes node-aligned axes spaced in the quantity, its \
                     square root, (sqrt(x) - sqrt(1 - x) + 1) / 2 or asinh((x - c) / s) + r min(x - c, 0)",
                    axis.name,
                    axis.placement,
                    axis.mapping.formula(&axis.name)
                ),
            ));
        }
    }
    Ok([axes[0].count, axes[1].count, axes[2].count, axes[3].count])
}

/// `u = clamp((m(x) - m(start)) * (1 / (m(end) - m(start))), 0, 1)`: the axis coordinate in
/// [0, 1], in f32, as a local named `u_<axis>` (for the identity mapping exact when the range is a
/// power of two, as FGD's 1 and 4 are). The mapping `m` is written out: `sqrt(max(x, 0))`,
/// `(sqrt(c) - sqrt(1 - c) + 1) * 0.5` with `c` clamped to [0, 1], or `asinh(y) + slope_below *
/// min(x - centre, 0)` with `y = (x - centre) * (1 / scale)`, the `asinh` written
/// `log(|y| + sqrt(y * y + 1))` with the sign of `y`
/// (HLSL has no `asinh`; the odd symmetry keeps the sum from cancelling where `y < 0`: without
/// it, at FGD's `y = -5` the logarithm's argument loses 50 ulps and lookups move by 5.4e-6).
fn unit_coordinate(program: &mut ProgramBuilder, axis: &Axis) -> Expr {
    let x = program.input(&axis.name);
    let mapped = match axis.mapping {
        Mapping::Sqrt => x.max(float(0.0)).sqrt(),
        Mapping::SqrtEnds => {
            let c = program.local(&format!("c_{}", axis.name), clamp(x, 0.0, 1.0));
            (c.clone().sqrt() - (float(1.0) - c).sqrt() + float(1.0)).mul(float(0.5))
        }
        Mapping::Asinh { .. } | Mapping::AsinhRampBelow { .. } => {
            let (scale, centre, slope_below) = axis.mapping.asinh_parts().unwrap_or_default();
            let from_centre = program.local(&format!("d_{}", axis.name), x.sub(float(centre as f32)));
            let y = program.local(&format!("y_{}", axis.name), from_centre.clone().mul(float((1.0 / scale) as f32)));
            let magnitude = log(y.clone().abs().add(y.clone().mul(y.clone()).add(float(1.0)).sqrt()));
            let asinh = with_sign_of(magnitude, y);
            if slope_below == 0.0 {
                asinh
            } else {
                asinh.add(from_centre.min(float(0.0)).mul(float(slope_below as f32)))
            }
        }
        Mapping::Identity | Mapping::SqrtOneMinus => x,
    };
    let (m0, m1) = (axis.mapping.forward(axis.start), axis.mapping.forward(axis.end));
    let u = clamp(mapped.sub(float(m0 as f32)).mul(float((1.0 / (m1 - m0)) as f32)), 0.0, 1.0);
    program.local(&format!("u_{}", axis.name), u)
}

/// `i = u * (N - 1)`: the continuous node index of a node-aligned axis, in f32, as a local named
/// `i_<axis>`. One rounding: up to half an ulp of `i` (1.9e-6 node for `i` in [32, 64)), which a
/// hardware-filtered lookup cannot avoid, since the filter takes one coordinate.
fn node_index(program: &mut ProgramBuilder, axis: &Axis) -> Expr {
    let u = unit_coordinate(program, axis);
    program.local(&format!("i_{}", axis.name), u.mul(float((axis.count - 1) as f32)))
}

/// The lower node `k` of the cell around `x` and the weight `t` of the upper one, as f32 locals
/// `k_<axis>` and `t_<axis>`, the same bracket as [`Axis::bracket`] (`k <= N - 2`).
///
/// When `N` is a power of two (64 for FGD), `t` is computed without the rounding of `u * (N - 1)`:
/// `u * (N - 1) - k = (u * N - k) - u`, where `u * N` is exact (a power-of-two scale), `u * N - k`
/// is exact (both are multiples of `ulp(u * N) <= 1` and the difference is no larger than `u * N`),
/// and the last subtraction rounds only to half an ulp of `t` (at most 2^-25 for `t < 1`), where
/// `fl(u * (N - 1)) - k` would carry the product's rounding, up to 2^-19 node for `u * (N - 1)` in
/// [32, 64): times the steepest FGD node step (0.74 along mu at the critical angle) that alone is
/// 1.4e-6. `k` is first taken from the rounded product; when that rounding crossed a node, the
/// exact residual lies just outside [0, 1] and `floor` of it moves `k` by one.
fn node_bracket(program: &mut ProgramBuilder, axis: &Axis) -> (Expr, Expr) {
    let name = &axis.name;
    let last_cell = (axis.count - 2) as f32;
    let u = unit_coordinate(program, axis);
    let rounded = u.clone().mul(float((axis.count - 1) as f32));
    if !axis.count.is_power_of_two() {
        let i = program.local(&format!("i_{name}"), rounded);
        let k = program.local(&format!("k_{name}"), i.clone().floor().min(float(last_cell)));
        let t = program.local(&format!("t_{name}"), i.sub(k.clone()));
        return (k, t);
    }
    let guess = program.local(&format!("guess_{name}"), rounded.floor().min(float(last_cell)));
    let residual =
        program.local(&format!("r_{name}"), u.clone().mul(float(axis.count as f32)).sub(guess.clone()).sub(u));
    let k = program.local(&format!("k_{name}"), clamp(guess.clone().add(residual.clone().floor()), 0.0, last_cell));
    let t = program.local(&format!("t_{name}"), residual.sub(k.clone().sub(guess)));
    (k, t)
}

fn unit_formula(axis: &Axis) -> String {
    if axis.mapping == Mapping::Identity {
        return format!("u_{0} = clamp(({0} - {1}) / ({2} - {1}), 0, 1)", axis.name, axis.start, axis.end);
    }
    let (m0, m1) = (axis.mapping.forward(axis.start), axis.mapping.forward(axis.end));
    let clamped = format!("clamp({}, 0, 1)", axis.name);
    let mapped = match axis.mapping {
        Mapping::Sqrt => axis.mapping.formula(&format!("max({}, 0)", axis.name)),
        Mapping::Asinh { .. } | Mapping::AsinhRampBelow { .. } => axis.mapping.formula(&axis.name),
        Mapping::Identity | Mapping::SqrtOneMinus | Mapping::SqrtEnds => axis.mapping.formula(&clamped),
    };
    format!("u_{} = clamp(({mapped} - {m0}) / ({m1} - {m0}), 0, 1)", axis.name)
}

fn index_formula(axis: &Axis) -> String {
    format!("{}; i_{} = u_{} * {}", unit_formula(axis), axis.name, axis.name, axis.count - 1)
}

/// The manifest entries of the four source axes: axis `d` stored along `stored_along[d]`, its node
/// index by `formula`, then `addresses[d]`, its place in the texture.
fn axis_entries_of(
    axes: &[Axis],
    formula: fn(&Axis) -> String,
    stored_along: [String; 4],
    addresses: [String; 4],
) -> Vec<AxisEntry> {
    axes.iter()
        .zip(stored_along)
        .zip(addresses)
        .map(|((axis, stored_along), address)| {
            // The packing's own address in place of the texture coordinate, and no definition:
            // the lookup statements say how each axis is read.
            let mut entry = AxisEntry::new(axis, stored_along);
            entry.texture_coordinate = format!("{}; {address}", formula(axis));
            entry.definition = None;
            entry
        })
        .collect()
}

fn bracket_formula(axis: &Axis) -> String {
    let (name, n) = (&axis.name, axis.count);
    if n.is_power_of_two() {
        format!(
            "{}; guess = min(floor(u_{name} * {}), {}); r = (u_{name} * {n} - guess) - u_{name}; k_{name} = \
             clamp(guess + floor(r), 0, {}); t_{name} = r - (k_{name} - guess)",
            unit_formula(axis),
            n - 1,
            n - 2,
            n - 2
        )
    } else {
        format!("{}; k_{name} = min(floor(i_{name}), {}); t_{name} = i_{name} - k_{name}", index_formula(axis), n - 2)
    }
}

/// The 8 corners `(a, b, c)` of a 3D cell, first index fastest.
fn corners3() -> impl Iterator<Item = (usize, usize, usize)> {
    (0..8).map(|n| (n & 1, n >> 1 & 1, n >> 2 & 1))
}

/// Tile row and column of kappa node `k` (an integer-valued local) in a grid of `columns`, as
/// locals `row<suffix>`, `column<suffix>`; `+ 0.5` keeps `floor` away from a rounding edge.
fn tile_of(program: &mut ProgramBuilder, k: &Expr, columns: usize, suffix: &str) -> (Expr, Expr) {
    let inv_columns = 1.0 / columns as f32;
    let row = program.local(&format!("row{suffix}"), k.clone().add(float(0.5)).mul(float(inv_columns)).floor());
    let column = program.local(&format!("column{suffix}"), k.clone().sub(row.clone().mul(float(columns as f32))));
    (row, column)
}

/// A packing's lookup as written: the value it returns (its locals are the builder's), its layout
/// in words and its source axes' manifest entries.
struct WrittenLookup {
    result: Expr,
    layout: Vec<String>,
    axis_entries: Vec<AxisEntry>,
}

/// A packing's node counts (`mu`, `alpha`, `eta`, `kappa`) and its volume's extent.
#[derive(Clone, Copy)]
struct Shape {
    counts: [usize; 4],
    extent: [usize; 3],
}

/// The description and axis entries of the two lossless packings' layout: every node kept, kappa
/// nodes as tiles in x and y, eta along z.
fn lossless_layout(shape: Shape) -> (Vec<String>, [String; 4], usize) {
    let [n_mu, n_alpha, n_eta, n_kappa] = shape.counts;
    let [width, height, depth] = shape.extent;
    let (columns, _) = tile_grid(n_kappa);
    let layout = vec![
        format!(
            "{width} x {height} x {depth} volume, one channel, every node of the {n_mu} x {n_alpha} x {n_eta} x {n_kappa} table kept."
        ),
        format!(
            "kappa node k is a {n_mu} x {n_alpha} (mu x alpha) tile at tile column k mod {columns} (along x) and tile row floor(k / {columns}) (along y); unused tiles and the padding to {width} x {height} hold 0."
        ),
        "eta node e is depth slice e.".into(),
    ];
    let stored_along = [
        format!("x within a kappa tile ({n_mu} texels)"),
        format!("y within a kappa tile ({n_alpha} texels)"),
        "z".into(),
        format!("tile: column k mod {columns} along x, row floor(k / {columns}) along y"),
    ];
    (layout, stored_along, columns)
}

/// [`Packing::Lossless`]: the lookup computes the 4D weights itself and loads the cell's 16 texels.
fn lossless_lookup(program: &mut ProgramBuilder, axes: &[Axis], shape: Shape) -> WrittenLookup {
    let [n_mu, n_alpha, _, _] = shape.counts;
    let (mut layout, stored_along, columns) = lossless_layout(shape);
    let result = load_lookup(program, axes, columns);
    layout.extend([
            "No hardware filtering: the lookup computes the 4D interpolation weights in f32 (exact to 2^-25 for power-of-two node counts), loads the 16 texels of the cell and lerps them, mu, alpha, eta, then kappa.".to_string(),
            "So it reproduces 4D multilinear interpolation to f32 rounding on any GPU (no 8-bit filter weights, no coordinate rounding), and needs no sampler; r32float needs no float32-filterable feature in WebGPU.".into(),
        ]);
    let addresses = [
        format!("texel x = column * {n_mu} + k_mu (+ 1), lerp by t_mu"),
        format!("texel y = row * {n_alpha} + k_alpha (+ 1), lerp by t_alpha"),
        "texel z = k_eta (+ 1), lerp by t_eta".into(),
        "tiles of kappa nodes k_kappa and k_kappa + 1, lerp by t_kappa".into(),
    ];
    let axis_entries = axis_entries_of(axes, bracket_formula, stored_along, addresses);
    WrittenLookup { result, layout, axis_entries }
}

/// [`Packing::LosslessFiltered`]: two trilinear fetches, one in each kappa tile around kappa.
fn lossless_filtered_lookup(program: &mut ProgramBuilder, axes: &[Axis], shape: Shape) -> WrittenLookup {
    let [n_mu, n_alpha, _, n_kappa] = shape.counts;
    let [width, height, depth] = shape.extent;
    let (inv_w, inv_h, inv_d) = (1.0 / width as f32, 1.0 / height as f32, 1.0 / depth as f32);
    let (mut layout, stored_along, columns) = lossless_layout(shape);
    let [i_mu, i_alpha, i_eta, i_kappa] = [0, 1, 2, 3].map(|d| node_index(program, &axes[d]));
    let (k0, t_kappa, k1) = nodes_around(program, i_kappa, n_kappa, ["k0", "t_kappa", "k1"]);
    let mut tile = |k: &Expr, suffix: &str| {
        let (row, column) = tile_of(program, k, columns, suffix);
        let x = column.mul(float(n_mu as f32)).add(i_mu.clone()).add(float(0.5)).mul(float(inv_w));
        let y = row.mul(float(n_alpha as f32)).add(i_alpha.clone()).add(float(0.5)).mul(float(inv_h));
        (program.local(&format!("x{suffix}"), x), program.local(&format!("y{suffix}"), y))
    };
    let (x0, y0) = tile(&k0, "0");
    let (x1, y1) = tile(&k1, "1");
    let z = program.local("z", i_eta.add(float(0.5)).mul(float(inv_d)));
    let v0 = program.sample("v0", [&x0, &y0, &z]);
    let v1 = program.sample("v1", [&x1, &y1, &z]);
    let result = lerp(v0, v1, t_kappa);
    layout.extend([
            "The hardware interpolates mu, alpha and eta inside a tile: two trilinear fetches, one in each kappa tile around kappa, lerped by hand with the kappa weight.".to_string(),
            "x and y are clamped to the first and last texel centres of the tile, where linear filtering gives the neighbouring tile weight 0: filtering never blends across tiles.".into(),
            "Hardware filtering limits accuracy: f32 coordinates place the filter to an ulp of the texel index (3e-5 texel at texel 448), and GPUs round filter weights to 8 bits; use `lossless` for 4D interpolation to f32 rounding.".into(),
        ]);
    let addresses = [
        format!("x = (column * {n_mu} + i_mu + 0.5) / {width}"),
        format!("y = (row * {n_alpha} + i_alpha + 0.5) / {height}"),
        format!("z = (i_eta + 0.5) / {depth}"),
        format!("k0 = min(floor(i_kappa), {}), k1 = k0 + 1, lerp by i_kappa - k0", n_kappa - 2),
    ];
    let axis_entries = axis_entries_of(axes, index_formula, stored_along, addresses);
    WrittenLookup { result, layout, axis_entries }
}

/// The two nodes around node index `index` of an axis of `count` nodes and the weight of the
/// upper one, as locals named `names`: `lo = min(floor(index), count - 2)`, `t = index - lo`,
/// `hi = lo + 1`.
fn nodes_around(program: &mut ProgramBuilder, index: Expr, count: usize, [lo, t, hi]: [&str; 3]) -> (Expr, Expr, Expr) {
    let lower = program.local(lo, index.clone().floor().min(float((count - 2) as f32)));
    let weight = program.local(t, index.sub(lower.clone()));
    let upper = program.local(hi, lower.clone().add(float(1.0)));
    (lower, weight, upper)
}

/// [`Packing::Thesis`]: the thesis renderer's volume, kappa halved, read at the eta nodes around eta.
fn thesis_lookup(program: &mut ProgramBuilder, axes: &[Axis], shape: Shape) -> WrittenLookup {
    let [n_mu, n_alpha, n_eta, n_kappa] = shape.counts;
    let [width, height, depth] = shape.extent;
    let (inv_w, inv_h, inv_d) = (1.0 / width as f32, 1.0 / height as f32, 1.0 / depth as f32);
    let [i_mu, i_alpha, i_eta, i_kappa] = [0, 1, 2, 3].map(|d| node_index(program, &axes[d]));
    let n_half = n_kappa / 2;
    let (e0, t_eta, e1) = nodes_around(program, i_eta, n_eta, ["e0", "t_eta", "e1"]);
    // The mean of nodes 2h and 2h + 1 sits halfway between them, at full index 2h + 0.5.
    let h = program.local("h", clamp(i_kappa.sub(float(0.5)).mul(float(0.5)), 0.0, (n_half - 1) as f32));
    let x = program.local("x", i_mu.add(float(0.5)).mul(float(inv_w)));
    let y = program.local("y", i_alpha.add(float(0.5)).mul(float(inv_h)));
    let slice = |e: Expr| e.mul(float(n_half as f32)).add(h.clone()).add(float(0.5)).mul(float(inv_d));
    let z0 = program.local("z0", slice(e0));
    let z1 = program.local("z1", slice(e1));
    let v0 = program.sample("v0", [&x, &y, &z0]);
    let v1 = program.sample("v1", [&x, &y, &z1]);
    let result = lerp(v0, v1, t_eta);
    let layout = vec![
        format!("{width} x {height} x {depth} volume, one channel: the thesis renderer's packing of the {n_mu} x {n_alpha} x {n_eta} x {n_kappa} table."),
        format!("kappa halved to {n_half} nodes by averaging node pairs (2h, 2h + 1); the mean sits at kappa node index 2h + 0.5."),
        format!("depth slice = eta_index * {n_half} + h: each eta node is a block of {n_half} slices."),
        "The hardware interpolates mu, alpha and kappa (inside the eta block, h clamped to its first and last slice centres); two fetches, at the eta nodes around eta, lerped by hand.".into(),
    ];
    let stored_along = [
        "x".into(),
        "y".into(),
        format!("z, block of {n_half} slices per eta node"),
        format!("z within an eta block ({n_half} averaged pairs)"),
    ];
    let addresses = [
        format!("x = (i_mu + 0.5) / {width}"),
        format!("y = (i_alpha + 0.5) / {height}"),
        format!("e0 = min(floor(i_eta), {}), e1 = e0 + 1, lerp by i_eta - e0", n_eta - 2),
        format!("h = clamp((i_kappa - 0.5) / 2, 0, {}); z = (e * {n_half} + h + 0.5) / {depth}", n_half - 1),
    ];
    let axis_entries = axis_entries_of(axes, index_formula, stored_along, addresses);
    WrittenLookup { result, layout, axis_entries }
}

/// The `lossless` lookup: the bracket and exact weight of every axis ([`node_bracket`]), texel
/// indices of the cell's 16 corners in the kappa tiles `k_kappa` and `k_kappa + 1` of a grid of
/// `columns`, 16 `Load`s, and 15 lerps (mu, alpha, eta, then kappa), as `Table::interpolate`.
fn load_lookup(program: &mut ProgramBuilder, axes: &[Axis], columns: usize) -> Expr {
    let (n_mu, n_alpha) = (axes[0].count, axes[1].count);
    let [(k_mu, t_mu), (k_alpha, t_alpha), (k_eta, t_eta), (k_kappa, t_kappa)] =
        [0, 1, 2, 3].map(|d| node_bracket(program, &axes[d]));
    let one = || float(1.0);
    // Texel indices of the cell's corners: integers, exact in f32.
    let z = [k_eta.clone(), program.local("z1", k_eta.add(one()))];
    let mut x = Vec::new();
    let mut y = Vec::new();
    for (j, k) in [k_kappa.clone(), program.local("kappa1", k_kappa.add(one()))].iter().enumerate() {
        let (row, column) = tile_of(program, k, columns, &j.to_string());
        let x0 = program.local(&format!("x{j}0"), column.mul(float(n_mu as f32)).add(k_mu.clone()));
        let x1 = program.local(&format!("x{j}1"), x0.clone().add(one()));
        let y0 = program.local(&format!("y{j}0"), row.mul(float(n_alpha as f32)).add(k_alpha.clone()));
        let y1 = program.local(&format!("y{j}1"), y0.clone().add(one()));
        x.push([x0, x1]);
        y.push([y0, y1]);
    }
    // v<mu><alpha><eta><kappa>: the 16 corners, each one texel as stored.
    let mut v = std::collections::BTreeMap::new();
    for (alpha, eta, kappa) in corners3() {
        for (mu, x_mu) in x[kappa].iter().enumerate() {
            let name = format!("v{mu}{alpha}{eta}{kappa}");
            let fetched = program.load(&name, [x_mu, &y[kappa][alpha], &z[eta]]);
            v.insert((mu, alpha, eta, kappa), fetched);
        }
    }
    // Lerp away one axis at a time, mu, alpha, eta, then kappa (15 lerps); a local's
    // digits are the corner's remaining indices.
    let mut m = std::collections::BTreeMap::new();
    for (alpha, eta, kappa) in corners3() {
        let (a, b) = (v[&(0, alpha, eta, kappa)].clone(), v[&(1, alpha, eta, kappa)].clone());
        m.insert((alpha, eta, kappa), program.local(&format!("m{alpha}{eta}{kappa}"), lerp(a, b, t_mu.clone())));
    }
    let mut ma = std::collections::BTreeMap::new();
    for (eta, kappa) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let (a, b) = (m[&(0, eta, kappa)].clone(), m[&(1, eta, kappa)].clone());
        ma.insert((eta, kappa), program.local(&format!("ma{eta}{kappa}"), lerp(a, b, t_alpha.clone())));
    }
    let along_eta: Vec<Expr> = (0..2)
        .map(|kappa| {
            let (a, b) = (ma[&(0, kappa)].clone(), ma[&(1, kappa)].clone());
            program.local(&format!("mae{kappa}"), lerp(a, b, t_eta.clone()))
        })
        .collect();
    lerp(along_eta[0].clone(), along_eta[1].clone(), t_kappa)
}

impl PackedFgd {
    /// Pack an FGD table (axes mu, alpha, eta, kappa; node-aligned) for storage in `precision`.
    pub fn pack(table: &Table, packing: Packing, precision: Precision) -> Result<Self> {
        let counts = fgd_counts(&table.name, &table.axes, table.channel_count())?;
        let [width, height, depth] = packing.extent(counts)?;
        let [n_mu, n_alpha, n_eta, n_kappa] = counts;
        let value = |i: usize, j: usize, e: usize, k: usize| table.data[i + n_mu * (j + n_alpha * (e + n_eta * k))];
        let mut texels = vec![0.0f32; width * height * depth];
        match packing {
            Packing::Lossless | Packing::LosslessFiltered => {
                let (columns, _) = tile_grid(n_kappa);
                for k in 0..n_kappa {
                    let (column, row) = (k % columns, k / columns);
                    for e in 0..n_eta {
                        for j in 0..n_alpha {
                            let start = column * n_mu + width * (row * n_alpha + j + height * e);
                            for i in 0..n_mu {
                                texels[start + i] = value(i, j, e, k);
                            }
                        }
                    }
                }
            }
            Packing::Thesis => {
                let n_half = n_kappa / 2;
                for e in 0..n_eta {
                    for h in 0..n_half {
                        let slice = e * n_half + h;
                        for j in 0..n_alpha {
                            for i in 0..n_mu {
                                // The thesis's box filter: the mean of kappa nodes 2h and 2h + 1.
                                let mean = 0.5 * (value(i, j, e, 2 * h) as f64 + value(i, j, e, 2 * h + 1) as f64);
                                texels[i + width * (j + height * slice)] = mean as f32;
                            }
                        }
                    }
                }
            }
        }
        for t in &mut texels {
            *t = precision.round(*t);
        }
        Self::with_texture(Texture3D { width, height, depth, texels }, packing, precision, &table.axes)
    }

    /// The lookup of `packing` over a texture packed from an FGD table with `source_axes` (read
    /// back from a file, say): the same program, and so the same values, as [`PackedFgd::pack`]
    /// gives. The texture's extent must be the packing's for those axes.
    pub fn with_texture(
        texture: Texture3D,
        packing: Packing,
        precision: Precision,
        source_axes: &[Axis],
    ) -> Result<Self> {
        let counts = fgd_counts("fgd", source_axes, 1)?;
        let [width, height, depth] = packing.extent(counts)?;
        if [texture.width, texture.height, texture.depth] != [width, height, depth] {
            return Err(Error::invalid(
                format!("packing `{}`", packing.name()),
                format!(
                    "the texture is {} x {} x {}; the packing of a {counts:?} table is {width} x {height} x {depth}",
                    texture.width, texture.height, texture.depth
                ),
            ));
        }
        let shape = Shape { counts, extent: [width, height, depth] };
        // The file stem of `lossless-filtered` holds a `-`, which no shading language admits in a name.
        let mut builder = ProgramBuilder::new(packing.file_stem().replace('-', "_"), FGD_INPUTS.to_vec());
        let WrittenLookup { result, layout, axis_entries } = match packing {
            Packing::Lossless => lossless_lookup(&mut builder, source_axes, shape),
            Packing::LosslessFiltered => lossless_filtered_lookup(&mut builder, source_axes, shape),
            Packing::Thesis => thesis_lookup(&mut builder, source_axes, shape),
        };
        Ok(PackedFgd {
            packing,
            precision,
            texture,
            program: builder.finish(result)?,
            source_axes: source_axes.to_vec(),
            axis_entries,
            layout,
            lossless: packing.keeps_every_node(),
        })
    }

    /// The shader's lookup at `(mu, alpha, eta, kappa)`, through the emulator.
    pub fn lookup(&self, [mu, alpha, eta, kappa]: [f32; 4], filter: Filter) -> f32 {
        self.program.evaluate(&[mu, alpha, eta, kappa], &self.texture, filter)
    }

    pub fn fetches_per_lookup(&self) -> usize {
        self.program.fetch_count()
    }

    /// Bytes of the texels on the GPU (and of the DDS file, less its 148-byte header).
    pub fn texel_bytes(&self) -> usize {
        self.texture.texels.len() * self.precision.bytes()
    }

    /// The texture as a 3-axis table of cell-centred texels, the form the DDS writer takes.
    pub fn texture_table(&self) -> Result<Table> {
        let t = &self.texture;
        let axes = vec![
            Axis::cell_centred("x", 0.0, 1.0, t.width)?,
            Axis::cell_centred("y", 0.0, 1.0, t.height)?,
            Axis::cell_centred("z", 0.0, 1.0, t.depth)?,
        ];
        let channel = Channel::new(
            "fgd",
            format!("FGD packed by `{}`; address it with the lookup of the manifest's `packing`", self.packing.name()),
        );
        Table::new("fgd", axes, vec![channel], t.texels.clone())
    }

    fn shader_header(&self) -> String {
        let mut h = format!(
            "{}: generated by tmlut {} for {} ({:?} texels).\n",
            self.program.name(),
            env!("CARGO_PKG_VERSION"),
            self.packing.file_stem() + ".dds",
            self.precision
        );
        if self.program.uses_sampler() {
            h.push_str("Bind the texture as linear data with a sampler: linear min/mag/mip filter, clamp addressing, mip level 0.\n");
        } else {
            h.push_str("Bind the texture as linear data; no sampler: the lookup loads texels of mip level 0 (in WebGPU, sample type unfilterable-float serves).\n");
        }
        h.push_str("Returns FGD(mu, alpha, eta, kappa), interpolated as the 4D table is.\n\n");
        for line in &self.layout {
            h.push_str(line);
            h.push('\n');
        }
        h
    }

    pub fn hlsl(&self) -> String {
        self.program.hlsl(&self.shader_header())
    }

    /// WGSL: `r32float` is not filterable without the `float32-filterable` feature; store the
    /// packing as f16 (`r16float`) for WebGPU.
    pub fn wgsl(&self) -> String {
        self.program.wgsl(&self.shader_header())
    }
}

#[cfg(test)]
mod tests;
