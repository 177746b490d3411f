//! `manifest.json`: one per output folder, one entry per file, stating every convention a reader
//! needs — axes with their placement, mapping and the exact texture-coordinate formula, channels and
//! their meaning, the integrand and masking-shadowing model, how it was sampled, its error, and the
//! file's SHA-256. Users of other LUT tools trip over exactly these unstated conventions (flipped
//! roughness, sRGB loading, half-texel shifts).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::files::FileKind;
use super::{FileFormat, Precision};
use crate::error::{Error, Result};
use crate::physics::FresnelBasis;
use crate::stats::{AccuracyReport, ErrorRecord};
use crate::table::{Axis, Channel};

/// The manifest's file name inside an output folder.
pub const MANIFEST_FILE: &str = "manifest.json";

/// The journal of a build's commit: it exists only while a build moves its files into place, from
/// the first rename to the last (`docs/formats.md`, "How a build commits"). A folder holding one
/// is between two builds, and its files and manifest may disagree until a build completes it.
pub const COMMIT_JOURNAL: &str = ".tmlut-commit.json";

/// The journal of `dir` if a build was interrupted while committing into it (or is committing now).
pub fn pending_commit(dir: &Path) -> Option<std::path::PathBuf> {
    let journal = dir.join(COMMIT_JOURNAL);
    journal.symlink_metadata().is_ok().then_some(journal)
}

/// The error a reader gives for a folder with a pending commit.
pub fn pending_commit_error(journal: &Path) -> Error {
    Error::Unfinished {
        path: journal.to_path_buf(),
        reason: "a build was interrupted while moving its files into this folder, so its files and manifest.json may \
         disagree; run `tmlut build` into the folder again (any build completes the interrupted one first)"
            .into(),
    }
}

/// Whether `name` names a file directly inside the folder: one ordinary path component, no folder,
/// no `..`, not absolute. A manifest naming anything else is refused rather than followed.
pub fn check_file_name(name: &str) -> std::result::Result<(), String> {
    let ordinary = !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\', '\0'])
        && !(name.len() >= 2 && name.as_bytes()[1] == b':');
    if ordinary {
        Ok(())
    } else {
        Err(format!(
            "`{}` is not a file name inside the folder; a manifest lists its own files only",
            name.escape_debug()
        ))
    }
}

/// The manifest of an output folder.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct Manifest {
    /// The tool and version that last wrote the folder.
    pub generator: String,
    /// One entry per file, keyed by file name (sorted, so the manifest itself is deterministic).
    pub files: BTreeMap<String, FileEntry>,
    /// The scene and plan of the last `tmlut build --scene` into this folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<SceneRecord>,
    /// The scene shader written into this folder over its own tables (`tmlut build --scene`, or
    /// `tmlut shader` with `--out` the folder of `--luts`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_shader: Option<SceneShaderRecord>,
    /// Engines' own files written by a preset build (`tmlut build --preset`), keyed by file name:
    /// a table rewritten in the layout and encoding of the file that engine ships.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub drop_ins: BTreeMap<String, DropInEntry>,
    /// The engine preset of the last build into this folder, where that build was a preset's
    /// (`tmlut build --preset`): `tmlut check` holds the folder to that preset's budgets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<PresetRecord>,
}

/// The preset a folder was built with.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct PresetRecord {
    /// Its name: a preset of `luts/presets/` (`built_in`), or the stem of the file a user edited.
    pub name: String,
    /// Whether it is one of tmlut's own presets, which `check` can find by name.
    pub built_in: bool,
}

impl PresetRecord {
    /// The record of preset `name`.
    pub fn new(name: impl Into<String>, built_in: bool) -> Self {
        PresetRecord { name: name.into(), built_in }
    }
}

/// An engine's own file, holding a table of this folder in that engine's layout
/// (`docs/engines.md`): what it replaces, how it is laid out, and its length and SHA-256.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct DropInEntry {
    /// The engine, e.g. `three.js`.
    pub engine: String,
    /// The file of the engine's source tree it replaces.
    pub replaces: String,
    /// The table whose stored values it holds.
    pub table: String,
    /// The file of this folder whose values it repeats.
    pub source_file: String,
    /// Its layout: identifiers, shape, order, encoding, and the conventions the engine samples it with.
    pub layout: Vec<String>,
    /// The file's length in bytes.
    pub bytes: u64,
    /// SHA-256 of the file's bytes, in lowercase hex.
    pub sha256: String,
    /// Shader functions written beside it that read the table as the engine reads it and apply
    /// what the engine applies to it (`docs/engines.md`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shaders: Vec<ShaderFile>,
}

impl DropInEntry {
    /// The entry of a drop-in file of `contents` for `engine`.
    pub fn new(
        engine: impl Into<String>,
        replaces: impl Into<String>,
        table: impl Into<String>,
        source_file: impl Into<String>,
        layout: Vec<String>,
        contents: &[u8],
    ) -> Self {
        DropInEntry {
            engine: engine.into(),
            replaces: replaces.into(),
            table: table.into(),
            source_file: source_file.into(),
            layout,
            bytes: contents.len() as u64,
            sha256: super::sha256_hex(contents),
            shaders: Vec::new(),
        }
    }
}

/// The files of a scene shader (`docs/shaders.md`), each verified by `tmlut check` and the loader.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct SceneShaderRecord {
    /// The scene's name.
    pub scene: String,
    /// Each file of the shader, with its length and SHA-256.
    pub files: Vec<SceneShaderFile>,
}

impl SceneShaderRecord {
    /// The record of `scene`'s shader, its files to be added.
    pub fn new(scene: impl Into<String>) -> Self {
        SceneShaderRecord { scene: scene.into(), files: Vec::new() }
    }
}

/// One file of a scene shader: what it is, its length and its SHA-256.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct SceneShaderFile {
    /// The file's name inside the folder.
    pub file: String,
    /// What the file holds, in words (the WGSL, the HLSL, the binding description, ...).
    pub what: String,
    /// The file's length in bytes.
    pub bytes: u64,
    /// SHA-256 of the file's bytes, in lowercase hex.
    pub sha256: String,
}

impl SceneShaderFile {
    /// The record of the file `file`, holding `what`, of `contents`: its length and SHA-256.
    pub fn new(file: impl Into<String>, what: impl Into<String>, contents: &[u8]) -> Self {
        SceneShaderFile {
            file: file.into(),
            what: what.into(),
            bytes: contents.len() as u64,
            sha256: super::sha256_hex(contents),
        }
    }
}

/// A scene a folder was built for, and the plan that was built.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct SceneRecord {
    /// The scene's name.
    pub name: String,
    /// Where the scene file was read from.
    pub source: String,
    /// SHA-256 of the scene file's bytes.
    pub sha256: String,
    /// The scene file itself.
    pub text: String,
    /// The tables the scene's plan built, what it left out, and why.
    pub plan: PlanRecord,
}

impl SceneRecord {
    /// The record of the scene `name`, read from `source` as `text` (its SHA-256 taken here),
    /// built by `plan`.
    pub fn new(name: impl Into<String>, source: impl Into<String>, text: impl Into<String>, plan: PlanRecord) -> Self {
        let text = text.into();
        SceneRecord { name: name.into(), source: source.into(), sha256: super::sha256_hex(text.as_bytes()), text, plan }
    }
}

/// What a scene's plan builds, what it leaves out, and why.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct PlanRecord {
    /// Each table (or fitted form) the plan builds, with the lookups it answers.
    pub tables: Vec<PlannedTableRecord>,
    /// The lookups the plan builds nothing for, each with the reason.
    pub left_out: Vec<LeftOutRecord>,
    /// What the planner warned of, in words.
    pub warnings: Vec<String>,
    /// Texel bytes of the planned tables.
    pub bytes: u64,
    /// Texel bytes of the default set, counted the same way.
    pub default_set_bytes: u64,
    /// The analytic TIR form fitted for the scene's `tir = "fit"` materials (its shaders are
    /// `tir_fit.hlsl` and `.wgsl`; no TIR table is written for them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_fit: Option<FitEntry>,
    /// The fitted forms the scene's materials name in place of the TIR table
    /// (`tir = "fit:PATH"`): name, path, form text, definition and fitted parameters. The scene
    /// shader holds each as `tmlut_<name>`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tir_forms: Vec<FittedForm>,
    /// The fitted forms the materials name in place of an albedo table (`albedo = "fit:PATH"`),
    /// each once. The scene shader holds each as `tmlut_<name>`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub albedo_forms: Vec<FittedForm>,
}

impl PlanRecord {
    /// A plan of `tables` of `bytes` texel bytes (the default set's `default_set_bytes`), leaving
    /// `left_out` out, with its `warnings`; no fitted form yet.
    pub fn new(
        tables: Vec<PlannedTableRecord>,
        left_out: Vec<LeftOutRecord>,
        warnings: Vec<String>,
        bytes: u64,
        default_set_bytes: u64,
    ) -> Self {
        PlanRecord { tables, left_out, warnings, bytes, default_set_bytes, ..PlanRecord::default() }
    }
}

/// A form fitted to the TIR table by `tmlut fit --form`, which a scene's material names in place
/// of the table (`tir = "fit:PATH"`): what the model evaluates, the scene shader prints, and the
/// manifest and the furnace report record. Read and compiled by `crate::fit::forms::fitted`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct FittedForm {
    /// The form's name (its file's stem): its shader function is `tmlut_<name>`.
    pub name: String,
    /// The table the form was fitted to and replaces: `tir` (a material's `tir = "fit:PATH"`), or
    /// an albedo table, `karis` or `fgd` (`albedo = "fit:PATH"`).
    #[serde(default = "tir_table", skip_serializing_if = "is_tir_table")]
    pub table: String,
    /// The path as the scene gives it, after `fit:`.
    pub source: String,
    /// The form file's text.
    pub form_text: String,
    /// The form statement by statement.
    pub definition: Vec<String>,
    /// Parameter names, in the form's order.
    pub parameter_order: Vec<String>,
    /// The fitted values, in that order.
    pub parameters: Vec<f64>,
}

impl FittedForm {
    /// The form `name` fitted to `table`, read from `source` (`form_text`, its `definition`
    /// statement by statement), with its `parameters` in `parameter_order`.
    pub fn new(
        name: impl Into<String>,
        table: impl Into<String>,
        source: impl Into<String>,
        form_text: impl Into<String>,
        definition: Vec<String>,
        parameter_order: Vec<String>,
        parameters: Vec<f64>,
    ) -> Self {
        FittedForm {
            name: name.into(),
            table: table.into(),
            source: source.into(),
            form_text: form_text.into(),
            definition,
            parameter_order,
            parameters,
        }
    }
}

/// The table of a [`FittedForm`] recorded before forms replaced albedo tables: TIR.
fn tir_table() -> String {
    "tir".into()
}

fn is_tir_table(table: &str) -> bool {
    table == "tir"
}

/// One table of a scene's plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct PlannedTableRecord {
    /// The table's name (its files' stem).
    pub name: String,
    /// What it is, in words (e.g. a kind of slice, or a fitted form that writes no table).
    pub kind: String,
    /// Node counts and ranges of the axes, and channels.
    pub shape: String,
    /// Its texel bytes (0 for a fitted form, which writes no table).
    pub bytes: u64,
    /// The lookups it answers.
    pub reasons: Vec<String>,
}

impl PlannedTableRecord {
    /// The planned table `name`, a `kind` of `shape` and `bytes` texel bytes, for `reasons`.
    pub fn new(
        name: impl Into<String>,
        kind: impl Into<String>,
        shape: impl Into<String>,
        bytes: u64,
        reasons: Vec<String>,
    ) -> Self {
        PlannedTableRecord { name: name.into(), kind: kind.into(), shape: shape.into(), bytes, reasons }
    }
}

/// Lookups a scene's plan builds no table for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct LeftOutRecord {
    /// Which lookups, in words (a material's layer, a site's albedo, ...).
    pub what: String,
    /// Why nothing is built for them (an index-matched interface, a fitted form in place, ...).
    pub reason: String,
}

impl LeftOutRecord {
    /// `what` a plan leaves out, and why.
    pub fn new(what: impl Into<String>, reason: impl Into<String>) -> Self {
        LeftOutRecord { what: what.into(), reason: reason.into() }
    }
}

/// One axis as a file stores it, with the formula a shader uses to address it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct AxisEntry {
    /// The axis itself: its quantity, range, node count, placement and mapping (flattened into
    /// the entry).
    #[serde(flatten)]
    pub axis: Axis,
    /// Which dimension of the file the axis runs along: `x`, `y`, `z` of a texture or image, `tile`
    /// for the slices of an EXR atlas, `axis N` of a `.bin` file.
    pub stored_along: String,
    /// The texture coordinate a cell-centred GPU sampler must be given for a value of the quantity.
    pub texture_coordinate: String,
    /// How a lookup computes the axis's quantity from its parameters, where the quantity is not
    /// one of them (`table::derived`), and what a shader language lacks to evaluate the formula.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub definition: Option<String>,
}

impl AxisEntry {
    /// The entry of `axis` stored along `stored_along`, with its texture-coordinate formula and,
    /// where the quantity is derived or the mapping uses `asinh`, its definition.
    pub fn new(axis: &Axis, stored_along: impl Into<String>) -> Self {
        let derived = crate::table::derived::definition(&axis.name).map(|f| format!("{} = {f}", axis.name));
        let asinh = axis
            .mapping
            .asinh_parts()
            .is_some()
            .then(|| "HLSL has no asinh: asinh(x) = sign(x) * log(abs(x) + sqrt(x * x + 1))".to_string());
        let definition = [derived, asinh].into_iter().flatten().collect::<Vec<_>>();
        AxisEntry {
            axis: axis.clone(),
            stored_along: stored_along.into(),
            texture_coordinate: axis.texture_coordinate_formula(),
            definition: (!definition.is_empty()).then(|| definition.join("; ")),
        }
    }
}

/// Everything known about one file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct FileEntry {
    /// The name of the table the file holds (e.g. `karis`, `gd`, `tir`).
    pub table: String,
    /// The file's format.
    pub format: FileFormat,
    /// Storage precision (`.bin` files are always f32).
    pub precision: Precision,
    /// The DXGI format of a DDS file, e.g. `R16G16_FLOAT`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dxgi_format: Option<String>,
    /// The Vulkan format of a KTX2 file without its `VK_FORMAT_` prefix, e.g. `R16G16_SFLOAT`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vk_format: Option<String>,
    /// Axis 0 varies fastest in storage.
    pub axes: Vec<AxisEntry>,
    /// Each channel's name and meaning, in storage order.
    pub channels: Vec<Channel>,
    /// The integral the table tabulates, in words.
    pub integrand: String,
    /// Masking-shadowing model (`smith-separable`, `smith-height-correlated`, `schlick-smith`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masking: Option<String>,
    /// Conventions a user must know (orientation, linear data, the grazing limit, ...).
    pub notes: Vec<String>,
    /// The estimator or quadrature that integrated the table, in words.
    pub method: String,
    /// The point set it drew from, in words (`none: no random points` for a quadrature).
    pub sampler: String,
    /// Sample points per cell, replicates together (0 for a quadrature).
    pub samples_per_cell: u64,
    /// The seed of the point set and of the checks' random points.
    pub seed: u64,
    /// Wall time of the table's integration (not of writing the file), in seconds.
    pub wall_time_s: f64,
    /// `[min, max]` of the table's finite values in f32, before rounding to the file's precision.
    pub value_range: [f32; 2],
    /// How many stored values are NaN or infinite (a build refuses any, so 0).
    pub nan_count: usize,
    /// Error of the f32 values; see [`ErrorEntry`].
    pub error: ErrorEntry,
    /// The Fresnel basis a shader needs to use a Belcour table: curves and probe cosines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fresnel_basis: Option<FresnelBasis>,
    /// Further measured accuracy figures.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub accuracy: Vec<AccuracyReport>,
    /// SHA-256 of the file as written, in lowercase hex; every load verifies it.
    pub sha256: String,
    /// The file's length in bytes.
    pub bytes: u64,
    /// For a packed texture (e.g. `fgd_lossless.dds`, `fgd_lossless.ktx2`): how the source table is laid out in it and
    /// the exact lookup. The entry's `axes` are then the texture's own texel axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub packing: Option<PackingEntry>,
    /// The analytic approximation fitted to this table by the build (TIR with `tir.fit = "best"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitEntry>,
    /// How a renderer binds and samples a DDS or KTX2 texture that its GPU filters (not a packing,
    /// whose lookup is in `packing`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub binding: Option<Binding>,
    /// For a texture array of a library's slices: the slices it holds, where, and their axes and
    /// error ([`super::slice_array`]). The entry's `axes` are then the array's texel axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slice_array: Option<super::slice_array::SliceArrayEntry>,
    /// For a texture array of baked materials: the materials it holds, where, how their nodes are
    /// placed and how far they are from their model ([`super::baked`]). The entry's `axes` are
    /// then the array's texel axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baked: Option<super::baked::BakedArrayEntry>,
    /// SHA-256 of every other field of this entry as the build wrote it ([`FileEntry::claims_hash`]):
    /// what a file cannot say about itself (a DDS file's axes, a fit's parameters, a packing's
    /// lookup, an array's slices) is held to it, so that an entry edited after the build is found
    /// by the loader and by `tmlut check`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub claims_sha256: Option<String>,
}

impl FileEntry {
    /// The entry of a file of `contents` (its length and SHA-256 taken here) holding table `table`
    /// in `format` and `precision`, over `axes`, with `channels`; the texel format a DDS or KTX2
    /// file states, from those. What the build knows of the table (its integrand, sampling, error,
    /// value range, ...) is empty, zero or absent, for the build to fill in.
    pub fn new(
        table: impl Into<String>,
        format: FileFormat,
        precision: Precision,
        axes: Vec<AxisEntry>,
        channels: Vec<Channel>,
        contents: &[u8],
    ) -> Self {
        let texel_format = |wanted: FileFormat, name: fn(usize, Precision) -> String| {
            (format == wanted).then(|| name(channels.len(), precision))
        };
        FileEntry {
            table: table.into(),
            format,
            precision,
            dxgi_format: texel_format(FileFormat::Dds, super::dds::dxgi_format_name),
            vk_format: texel_format(FileFormat::Ktx2, super::ktx2::vk_format_name),
            axes,
            channels,
            integrand: String::new(),
            masking: None,
            notes: Vec::new(),
            method: String::new(),
            sampler: String::new(),
            samples_per_cell: 0,
            seed: 0,
            wall_time_s: 0.0,
            value_range: [0.0, 0.0],
            nan_count: 0,
            error: ErrorEntry::default(),
            fresnel_basis: None,
            accuracy: Vec::new(),
            sha256: super::sha256_hex(contents),
            bytes: contents.len() as u64,
            packing: None,
            fit: None,
            binding: None,
            slice_array: None,
            baked: None,
            claims_sha256: None,
        }
    }

    /// SHA-256 of the entry's JSON without `claims_sha256` and with no wall time: how long a build
    /// took is no claim about the file, and two builds of one configuration seal alike.
    pub fn claims_hash(&self) -> String {
        let mut claims = self.clone();
        claims.claims_sha256 = None;
        claims.wall_time_s = 0.0;
        super::sha256_hex(&serde_json::to_vec(&claims).expect("plain data"))
    }

    /// Record [`FileEntry::claims_hash`] in the entry: the last step of writing it.
    pub fn seal(&mut self) {
        self.claims_sha256 = Some(self.claims_hash());
    }

    /// Where the entry's claims differ from those the build sealed: `None` when they agree or the
    /// entry has no seal (`tmlut check` fails those: [`UNSEALED`]), else what a reader reports.
    pub fn claims_disagreement(&self) -> Option<String> {
        let sealed = self.claims_sha256.as_ref()?;
        let now = self.claims_hash();
        (*sealed != now).then(|| {
            format!(
                "its entry was changed after the build wrote it: the SHA-256 of its claims is {now}, the build sealed {sealed}"
            )
        })
    }
}

/// What `tmlut check` says of an entry with no `claims_sha256`.
pub const UNSEALED: &str = "no `claims_sha256`, so its claims cannot be verified; build the folder again";

/// The texture, the sampler and the call that reproduce the table's interpolation on a GPU.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct Binding {
    /// Texture type in HLSL and WGSL, texel format (DXGI and WebGPU), mips, colour space.
    pub texture: String,
    /// The sampler state the call needs.
    pub sampler: String,
    /// Each texture coordinate, from the axes' `texture_coordinate`.
    pub coordinates: Vec<String>,
    /// The sample call in HLSL, at those coordinates.
    pub hlsl: String,
    /// The same call in WGSL.
    pub wgsl: String,
}

impl Binding {
    /// The binding of a `texture` sampled with `sampler` at `coordinates` by the calls `hlsl` and
    /// `wgsl`.
    pub fn new(
        texture: impl Into<String>,
        sampler: impl Into<String>,
        coordinates: Vec<String>,
        hlsl: impl Into<String>,
        wgsl: impl Into<String>,
    ) -> Self {
        Binding { texture: texture.into(), sampler: sampler.into(), coordinates, hlsl: hlsl.into(), wgsl: wgsl.into() }
    }
}

/// One start of a least-squares search (`tmlut fit`, the build's fit): where it began, where it ended, and what NLopt said.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct StartRecord {
    /// The parameters the search began from.
    pub start: Vec<f64>,
    /// The parameters it ended at.
    pub parameters: Vec<f64>,
    /// The least-squares objective there (NaN where it was not finite).
    pub objective: f64,
    /// NLopt's status, e.g. `Success`, `FtolReached`, `MaxEvalReached`, `RoundoffLimited`.
    pub status: String,
    /// Whether NLopt reported success rather than failure.
    pub succeeded: bool,
    /// Evaluations of the objective this start took.
    pub evaluations: u64,
}

impl StartRecord {
    /// A start from `start` that ended at `parameters` with `objective` after `evaluations`, as
    /// NLopt's `status` said, a success or not.
    pub fn new(
        start: Vec<f64>,
        parameters: Vec<f64>,
        objective: f64,
        status: impl Into<String>,
        succeeded: bool,
        evaluations: u64,
    ) -> Self {
        StartRecord { start, parameters, objective, status: status.into(), succeeded, evaluations }
    }
}

/// The outcome of a least-squares search over several starts: the best start's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct Minimum {
    /// The NLopt algorithm used, e.g. `Lbfgs` or `Bobyqa`.
    pub algorithm: String,
    /// The best start's parameters.
    pub parameters: Vec<f64>,
    /// The best start's objective.
    pub objective: f64,
    /// Index into `starts` of the best start.
    pub best_start: usize,
    /// Every start, in the order they ran.
    pub starts: Vec<StartRecord>,
}

impl Minimum {
    /// The search by `algorithm` over `starts`, the best of them `best_start` with its
    /// `parameters` and `objective`.
    pub fn new(
        algorithm: impl Into<String>,
        parameters: Vec<f64>,
        objective: f64,
        best_start: usize,
        starts: Vec<StartRecord>,
    ) -> Self {
        Minimum { algorithm: algorithm.into(), parameters, objective, best_start, starts }
    }
}

/// Error of a form over the table's nodes, evaluated in f32 (what a shader computes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ErrorFigures {
    /// Root mean square of the error over the nodes.
    pub rmse: f64,
    /// Mean squared error (the thesis reports MSE 0.0724 for eq. 5.6, against a naive estimator).
    pub mse: f64,
    /// The largest absolute error over the nodes.
    pub max_abs_error: f64,
    /// `(mu, alpha, eta)` of the largest error.
    pub max_at: [f64; 3],
    /// How many nodes the figures are over.
    pub nodes: usize,
}

impl ErrorFigures {
    /// The figures over `nodes` nodes, the largest error at `max_at`.
    pub fn new(rmse: f64, mse: f64, max_abs_error: f64, max_at: [f64; 3], nodes: usize) -> Self {
        ErrorFigures { rmse, mse, max_abs_error, max_at, nodes }
    }
}

/// A form fitted to a table by least squares (`crate::fit`), with its shaders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct FitEntry {
    /// The form's name (its form file's stem).
    pub form: String,
    /// The form in words.
    pub formula: String,
    /// The form file's text (`luts/forms/`), which the generator reads the form from.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub form_text: String,
    /// The form statement by statement, complete, in the form language (`docs/fit.md`, "Forms as
    /// text"): `table = tir, variables: mu, alpha, eta`, then `name = expression` in order, then
    /// `channel tir = expression`; the expressions read the parameters by `parameter_names`. The
    /// model evaluates it (`tmlut_ir::compile::FormEvaluator::from_definition`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub definition: Vec<String>,
    /// Why this form: the rule that chose it.
    pub chosen_by: String,
    /// The names of the form's parameters, in order.
    pub parameter_names: Vec<String>,
    /// The fitted values, in that order.
    pub parameters: Vec<f64>,
    /// Against this table's nodes, the form evaluated in f32.
    pub figures: ErrorFigures,
    /// The search: algorithm, every start with NLopt's own status.
    pub search: Option<Minimum>,
    /// `tmlut_tir(mu, alpha, eta)` with the coefficients baked in.
    pub shaders: Vec<ShaderFile>,
    /// The shader function's arguments, in order: each one's name and the quantity it carries.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shader_arguments: Vec<ShaderArgument>,
}

impl FitEntry {
    /// The form `form` (`formula` in words) with its fitted `parameters` by `parameter_names`, its
    /// `figures`, chosen by the rule `chosen_by`; no form text, definition, search or shader yet.
    pub fn new(
        form: impl Into<String>,
        formula: impl Into<String>,
        chosen_by: impl Into<String>,
        parameter_names: Vec<String>,
        parameters: Vec<f64>,
        figures: ErrorFigures,
    ) -> Self {
        FitEntry {
            form: form.into(),
            formula: formula.into(),
            form_text: String::new(),
            definition: Vec::new(),
            chosen_by: chosen_by.into(),
            parameter_names,
            parameters,
            figures,
            search: None,
            shaders: Vec::new(),
            shader_arguments: Vec::new(),
        }
    }
}

/// How a table of more axes than a texture has is packed into one, and how to read it back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct PackingEntry {
    /// The packing's name (`lossless`, `lossless-filtered`, `thesis`).
    pub name: String,
    /// Whether every node of the source table is stored unchanged (up to the file's precision).
    pub lossless: bool,
    /// `[width, height, depth]` in texels.
    pub texture_extent: [usize; 3],
    /// The source table's axes: where each is stored and how the lookup addresses it.
    pub source_axes: Vec<AxisEntry>,
    /// The layout in words.
    pub layout: Vec<String>,
    /// The lookup, statement by statement, in f32: exactly what the shader files compute.
    pub lookup: Vec<String>,
    /// Texel fetches one lookup makes.
    pub fetches_per_lookup: usize,
    /// The shader functions written beside the texture.
    pub shaders: Vec<ShaderFile>,
}

impl PackingEntry {
    /// The packing `name` into a texture of `texture_extent` texels, `lossless` or not, of a
    /// table over `source_axes`, laid out as `layout` says and read by `lookup` in
    /// `fetches_per_lookup` fetches; its shaders to be added.
    pub fn new(
        name: impl Into<String>,
        lossless: bool,
        texture_extent: [usize; 3],
        source_axes: Vec<AxisEntry>,
        layout: Vec<String>,
        lookup: Vec<String>,
        fetches_per_lookup: usize,
    ) -> Self {
        PackingEntry {
            name: name.into(),
            lossless,
            texture_extent,
            source_axes,
            layout,
            lookup,
            fetches_per_lookup,
            shaders: Vec::new(),
        }
    }
}

/// A shader source file holding a lookup function.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ShaderFile {
    /// `hlsl` or `wgsl`.
    pub language: String,
    /// The file's name inside the folder.
    pub file: String,
    /// The name of the lookup function it defines.
    pub function: String,
    /// SHA-256 of the file's bytes, in lowercase hex.
    pub sha256: String,
}

impl ShaderFile {
    /// The `language` file `file` of `contents` (its SHA-256 taken here), defining `function`.
    pub fn new(
        language: impl Into<String>,
        file: impl Into<String>,
        function: impl Into<String>,
        contents: &[u8],
    ) -> Self {
        ShaderFile {
            language: language.into(),
            file: file.into(),
            function: function.into(),
            sha256: super::sha256_hex(contents),
        }
    }
}

/// An argument of a fitted form's shader function: its name in the function, and the quantity it
/// carries (`axis`): a lookup variable of the table (`mu`, `alpha`, `eta`, `kappa`), or `roughness`,
/// `sqrt(alpha)`, the function squaring it where the form reads `alpha`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ShaderArgument {
    /// The argument's name in the function.
    pub name: String,
    /// The quantity it carries.
    pub axis: String,
}

impl ShaderArgument {
    /// The argument `name`, carrying `axis`.
    pub fn new(name: impl Into<String>, axis: impl Into<String>) -> Self {
        ShaderArgument { name: name.into(), axis: axis.into() }
    }
}

/// The error of a file's values: the integration error of the f32 table, and what storing it in
/// the file's precision adds.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ErrorEntry {
    /// The integration error of the f32 values (flattened into the entry).
    #[serde(flatten)]
    pub integration: ErrorRecord,
    /// The largest change of a value by rounding to the file's precision.
    pub storage_rounding_max: f64,
    /// Where the channels add up to an albedo (Karis): what storage did to their sum.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub storage_channel_sum: Option<ChannelSumStorage>,
    /// The file read as a renderer reads it, at random points of each domain, against the exact
    /// integral there: what interpolation between nodes (and storage) costs a lookup.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub interpolation: Vec<crate::stats::InterpolationError>,
}

impl ErrorEntry {
    /// The error of values integrated with `integration`, changed by at most
    /// `storage_rounding_max` by storage; no channel sum or interpolation figures yet.
    pub fn new(integration: ErrorRecord, storage_rounding_max: f64) -> Self {
        ErrorEntry { integration, storage_rounding_max, ..ErrorEntry::default() }
    }
}

/// What rounding to the storage precision did to the sum of a texel's channels, where that sum is
/// an albedo (Karis: `scale + bias`, the albedo at `F0 = 1`), which must not exceed 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ChannelSumStorage {
    /// How the channels were rounded.
    pub rounding: super::SumRounding,
    /// Texels whose stored sum exceeds 1.
    pub texels_above_one: usize,
    /// The largest excess of a stored sum over 1.
    pub max_above_one: f64,
    /// Texels whose stored sum exceeds the integrated (f32) one.
    pub texels_above_integral: usize,
    /// The largest excess of a stored sum over the integrated one.
    pub max_above_integral: f64,
    /// The largest stored sum.
    pub max_sum: f64,
}

impl ChannelSumStorage {
    /// What `rounding` did, before any texel is counted: nothing.
    pub fn new(rounding: super::SumRounding) -> Self {
        ChannelSumStorage {
            rounding,
            texels_above_one: 0,
            max_above_one: 0.0,
            texels_above_integral: 0,
            max_above_integral: 0.0,
            max_sum: 0.0,
        }
    }
}

impl Manifest {
    /// A manifest written by `generator` (the tool and its version), listing no file yet.
    pub fn new(generator: impl Into<String>) -> Self {
        Manifest { generator: generator.into(), ..Manifest::default() }
    }

    /// The manifest of `dir`, or an empty one if the folder has none yet.
    pub fn read_or_default(dir: &Path) -> Result<Self> {
        let path = dir.join(MANIFEST_FILE);
        if !path.exists() {
            return Ok(Manifest::default());
        }
        Self::read(&path)
    }

    /// The manifest at `path`; refused where it is longer than [`super::MAX_MANIFEST_BYTES`], more than this
    /// process's memory can parse ([`FileKind::read`]), or not a tmlut manifest.
    pub fn read(path: &Path) -> Result<Self> {
        Self::from_bytes(&FileKind::Manifest.read(path)?, path)
    }

    /// The manifest whose text is `bytes`, read from `path` (which errors name); refused unless a
    /// tmlut manifest.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("not a tmlut manifest: {e}")))
    }

    /// The entry of the file named `file`, if the manifest lists it.
    pub fn entry(&self, file: &str) -> Option<&FileEntry> {
        self.files.get(file)
    }

    /// Every shader file the manifest lists (a packing's lookups, a fitted form's functions, a
    /// scene's fitted TIR form, a scene shader's files, a baked shader's files, an engine's drop-in files) with the SHA-256 stated for it and, where
    /// the manifest states it, its length; a file listed by several entries once per statement.
    pub fn shader_files(&self) -> std::collections::BTreeSet<(&str, &str, Option<u64>)> {
        let listed = self
            .files
            .values()
            .flat_map(|e| {
                let packing = e.packing.iter().flat_map(|p| &p.shaders);
                packing.chain(e.fit.iter().flat_map(|f| &f.shaders))
            })
            .chain(self.scene.iter().flat_map(|s| s.plan.tir_fit.iter().flat_map(|f| &f.shaders)))
            .map(|shader| (shader.file.as_str(), shader.sha256.as_str(), None));
        let scene_shader = self.scene_shader.iter().flat_map(|s| &s.files);
        let baked_shader = self.files.values().flat_map(|e| e.baked.iter().flat_map(|b| &b.shader_files));
        let with_lengths = scene_shader.chain(baked_shader);
        let drop_ins = self.drop_ins.iter().map(|(file, e)| (file.as_str(), e.sha256.as_str(), Some(e.bytes)));
        let drop_in_shaders = self.drop_ins.values().flat_map(|e| &e.shaders);
        let listed = listed.chain(drop_in_shaders.map(|shader| (shader.file.as_str(), shader.sha256.as_str(), None)));
        listed
            .chain(with_lengths.map(|f| (f.file.as_str(), f.sha256.as_str(), Some(f.bytes))))
            .chain(drop_ins)
            .collect()
    }

    /// Every file the manifest lists, tables and shaders, with the SHA-256 stated for it.
    pub fn listed_files(&self) -> std::collections::BTreeSet<(&str, &str)> {
        let tables = self.files.iter().map(|(name, e)| (name.as_str(), e.sha256.as_str()));
        tables.chain(self.shader_files().into_iter().map(|(file, sha256, _)| (file, sha256))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::test_folder::test_folder;

    #[test]
    fn a_written_manifest_reads_back_with_every_entrys_conventions() {
        let manifest = Manifest::read(&test_folder().join(MANIFEST_FILE)).unwrap();
        assert_eq!(manifest.generator, "tmlut test");
        let gd = manifest.entry("gd.dds").unwrap();
        assert_eq!((gd.table.as_str(), gd.format, gd.precision), ("gd", FileFormat::Dds, Precision::F16));
        assert_eq!(gd.dxgi_format.as_deref(), Some("R16_FLOAT"));
        assert_eq!(gd.axes[0].texture_coordinate, gd.axes[0].axis.texture_coordinate_formula());
        assert_eq!(manifest.entry("tir.ktx2").unwrap().vk_format.as_deref(), Some("R32_SFLOAT"));
        assert_eq!(manifest.entry("slices.dds").unwrap().axes[2].stored_along, "layer");
        assert!(manifest.entry("missing.dds").is_none());
        assert_eq!(manifest.listed_files().len(), manifest.files.len(), "tables only: no shaders listed");
    }

    #[test]
    fn a_foreign_file_is_not_a_manifest() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(MANIFEST_FILE), b"{\"hello\": 1}").unwrap();
        let err = Manifest::read_or_default(dir.path()).unwrap_err().to_string();
        assert!(err.contains("not a tmlut manifest"), "{err}");
        assert_eq!(Manifest::read_or_default(&dir.path().join("empty")).unwrap(), Manifest::default());
    }
}
