//! A content-addressed cache of the tables a scene build integrates, shared across scenes, output
//! folders and runs (`tmlut build --scene ... --cache [DIR]`, `tmlut cache`).
//!
//! A slice's stored values depend on its table and settings (samples, replicates, masking, basis,
//! top index), its `(mu, alpha)` axes, the indices of its channels, the seed and the recipe's code,
//! and on nothing else: not on its name, the materials that read it, or the other slices of the
//! build (`recipes::slices::integrate_batch` makes it so), nor on the files it is written to:
//! their container and precision are applied when a build writes them, so an entry holds the f32
//! values as integrated and serves a DDS, KTX2 or EXR build, f32 or f16, alike. The SHA-256 of
//! those, with [`CACHE_FORMAT`] and the crate's version, is its key. A full or sub-range table of
//! a plan (GD, a sub-range FGD or TIR) is keyed by its table's name and every setting its values
//! depend on (all but `output` and the files written beside it:
//! [`TableRecipe::clear_written_settings`]). The entry `<key>.slice` holds the inputs its key was
//! computed from (as hashed), the table's layout, values, replicate standard errors, provenance
//! and the checks of the run that built it (for the interpolation check, the exact integrals that
//! each build compares its own files with), after one line with the cache's marker, the format
//! and the SHA-256 of the rest; an entry of another format is never read.
//!
//! - **Its own folder.** A cache folder carries a `CACHEDIR.TAG` (the Cache Directory Tagging
//!   Specification's, so that backups skip it) naming tmlut. A folder without one is taken as a
//!   cache only while empty, or holding nothing but files named as entries; anything else is
//!   refused, naming what was found. Counting and pruning touch only files named as entries
//!   (64 hexadecimal digits and an entry's extension) that begin with the cache's marker.
//! - **Verified against what produced it.** An entry read back is used only if its hash line
//!   matches, the SHA-256 of its recorded inputs is its key, and its values agree with the exact
//!   integral at [`VERIFIED_NODES`] nodes drawn where no one can predict them; else the table is
//!   built again (a merge fails), with a warning naming the entry.
//! - An entry is written to a temporary file of its own (created exclusively, under a name no
//!   other process can predict, locked while it is written) and renamed into place, so concurrent
//!   builds sharing a cache write whole entries (two writers of one key write the same bytes),
//!   and a temporary that no live writer holds, left by a killed build, is removed by the next.
//! - A cache folder that cannot be created, read or written (read-only, full, not a folder)
//!   degrades to building, with one warning.
//!
//! A whole build is kept too ([`store_build`], [`restore_build`]): the record `<key>.build` lists
//! every file of the output folder it left (tables, shaders, the manifest) by SHA-256, and each
//! file is kept once as `<sha256>.object`. Its key covers everything the files depend on (the
//! scenes as parsed and as written, the configuration with its containers and precision, the
//! seed, the options, [`CACHE_FORMAT`] and the version), so a build of an unchanged library
//! restores that folder whole, every file verified by its hash, without integrating a table: the
//! entries serve a library that changed, or the same library written to other files.
//!
//! A shard of a library build (`--shard I/N`) leaves beside its entries a record naming the
//! library it was planned for (its configuration as integrated: the merge chooses the files) and
//! its part, `<sha256>.shard`; `tmlut merge` joins only the shards of the library it is given,
//! all N of them.
//!
//! tmlut touches nothing outside the folders it is given, so the cache is used only when asked
//! for: `--cache DIR`, or `--cache` alone for the default folder ([`default_dir`]).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::loader::sha256_hex;
use crate::recipes::driver::{Metadata, Provenance, SamplingRecord, TableBuild};
use crate::recipes::interpolation::ExactValues;
use crate::recipes::slices::{SliceOf, Slices};
use crate::recipes::{Kernel, TableRecipe, TableSettings};
use crate::scene::build::Shard;
use crate::stats::{ErrorRecord, ErrorSummary, ReferenceComparison};
use crate::table::Table;

/// The layout of an entry and of what its key covers; a change to either, or to how a slice is
/// integrated, changes it (and the crate's version is in every key besides).
pub const CACHE_FORMAT: u32 = 9;

/// The extension of an entry.
pub const ENTRY_EXTENSION: &str = "slice";
/// The extension of a whole build's record ([`store_build`]).
pub const BUILD_EXTENSION: &str = "build";
/// The extension of a file a build record lists, named by its SHA-256.
pub const OBJECT_EXTENSION: &str = "object";
/// The extension of a shard's record ([`ShardRecord`]).
pub const SHARD_EXTENSION: &str = "shard";
/// Every extension of the cache's files: what `tmlut cache` counts and prunes.
const EXTENSIONS: [&str; 4] = [ENTRY_EXTENSION, BUILD_EXTENSION, OBJECT_EXTENSION, SHARD_EXTENSION];

/// What every file of the cache begins with, before its format and the SHA-256 of the rest.
const MARKER: &str = "tmlut-cache";

/// The tag file of a cache folder, and its first line, as the Cache Directory Tagging
/// Specification (Bryan Ford, <https://bford.info/cachedir/>) has it.
pub const TAG_FILE: &str = "CACHEDIR.TAG";
const TAG_SIGNATURE: &str = "Signature: 8a477f597d28d172789f06886806bc55";

/// Nodes of every entry read back that are compared with the exact integral.
pub const VERIFIED_NODES: usize = 2;

/// How long a temporary file of the cache is left alone even when no process holds its lock: a
/// writer takes its lock just after creating the file.
const ABANDONED_AFTER: std::time::Duration = std::time::Duration::from_secs(60);

/// The note a slice from the cache carries in the manifest.
pub const FROM_CACHE_NOTE: &str = "From the table cache: integrated in an earlier run with the same settings, axes, indices and seed (the same values, whatever files that run wrote them to); its checks are those of that run.";

/// The default cache folder: `$XDG_CACHE_HOME/tmlut`, else `$HOME/.cache/tmlut`
/// (`%LOCALAPPDATA%\tmlut\cache` on Windows).
pub fn default_dir() -> Option<PathBuf> {
    let from = |var: &str| std::env::var_os(var).filter(|v| !v.is_empty()).map(PathBuf::from);
    if cfg!(windows) {
        return from("LOCALAPPDATA").map(|d| d.join("tmlut").join("cache"));
    }
    from("XDG_CACHE_HOME").map(|d| d.join("tmlut")).or_else(|| from("HOME").map(|h| h.join(".cache").join("tmlut")))
}

/// What an entry holds.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Entry {
    key: String,
    /// What the key is the SHA-256 of, as hashed: the inputs that produced the entry.
    inputs: String,
    integrand: String,
    masking: Option<crate::physics::MaskingShadowing>,
    notes: Vec<String>,
    accuracy: Vec<crate::stats::AccuracyReport>,
    /// The table's layout: its name, axes and channels.
    table: String,
    axes: Vec<crate::table::Axis>,
    channels: Vec<crate::table::Channel>,
    values: Vec<f32>,
    standard_error: Option<Vec<f32>>,
    replicate_standard_error: ErrorSummary,
    reference: Option<ReferenceComparison>,
    interpolation: Vec<ExactValues>,
    sampling: SamplingRecord,
    wall_time_s: f64,
}

/// What a slice's key covers, as hashed, and as [`verify`] reads it back from an entry.
#[derive(Serialize, Deserialize)]
struct SliceInputs {
    format: u32,
    version: String,
    of: crate::recipes::slices::SliceOf,
    mu: crate::table::Axis,
    alpha: crate::table::Axis,
    /// The channels' indices, to the bit.
    indices: Vec<(u64, u64)>,
    seed: u64,
}

/// A cache key: the SHA-256 of the inputs that determine a table's bytes, kept with them so that
/// an entry states what produced it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CacheKey {
    /// The SHA-256, in hexadecimal: the entry's file name.
    pub hex: String,
    inputs: String,
}

impl CacheKey {
    fn of_inputs(inputs: String) -> CacheKey {
        CacheKey { hex: sha256_hex(inputs.as_bytes()), inputs }
    }

    /// The key of `slices` built with `seed`: of what is integrated, not of the files it is
    /// written to ([`TableRecipe::clear_written_settings`]).
    pub fn of_slices(slices: &Slices, seed: u64) -> CacheKey {
        let mut of = slices.of.clone();
        match &mut of {
            SliceOf::Fgd(settings) => settings.clear_written_settings(),
            SliceOf::Tir(settings) => settings.clear_written_settings(),
        }
        let fields = SliceInputs {
            format: CACHE_FORMAT,
            version: env!("CARGO_PKG_VERSION").into(),
            of,
            mu: slices.mu.clone(),
            alpha: slices.alpha.clone(),
            indices: slices.channels.iter().map(|c| (c.eta.to_bits(), c.kappa.to_bits())).collect(),
            seed,
        };
        CacheKey::of_inputs(serde_json::to_string(&fields).expect("plain data"))
    }

    /// The key of a full (or sub-range) table of a scene plan: its table and the settings it is
    /// integrated with (every key, sub-ranges and counts included; not its files' formats and
    /// precision, nor the files beside it) and the seed.
    pub fn of_table(settings: &TableSettings, seed: u64) -> CacheKey {
        let mut integrated = settings.clone();
        integrated.recipe_mut().clear_written_settings();
        let fields = (CACHE_FORMAT, env!("CARGO_PKG_VERSION"), settings.kind().name(), integrated, seed);
        CacheKey::of_inputs(serde_json::to_string(&fields).expect("plain data"))
    }
}

/// A cache folder, for one build.
pub struct SliceCache {
    pub dir: PathBuf,
    /// Further folders read, never written: the shards a merge joins ([`SliceCache::shards`]).
    read_only: Vec<PathBuf>,
    /// Whether a table read back says so in its notes: a merge's tables are its shards', and say
    /// nothing a build of them all would not.
    note_reads: bool,
    /// False once the folder proved unusable: the build goes on without it.
    usable: AtomicBool,
    warnings: Mutex<Vec<String>>,
    hits: AtomicUsize,
}

impl SliceCache {
    fn new(dir: &Path, read_only: Vec<PathBuf>, note_reads: bool) -> SliceCache {
        SliceCache {
            dir: dir.to_path_buf(),
            read_only,
            note_reads,
            usable: AtomicBool::new(true),
            warnings: Mutex::new(Vec::new()),
            hits: AtomicUsize::new(0),
        }
    }

    /// The cache at `dir`, created if needed. A folder that is not a cache ([`claim`]) is an
    /// error; one that cannot be created or written leaves the cache unusable, with a warning
    /// (the build goes on). Temporary files that killed builds left are removed.
    pub fn open(dir: &Path) -> Result<SliceCache> {
        let cache = SliceCache::new(dir, Vec::new(), true);
        match claim(dir) {
            Ok(()) => remove_abandoned_temporaries(dir),
            Err(e @ Error::Format { .. }) => return Err(e),
            Err(e) => cache.disable(&format!("cannot use it: {e}")),
        }
        Ok(cache)
    }

    /// The shard folders of a merge (`tmlut merge`) of the library whose key is `library`
    /// ([`crate::scene::build::SceneBuildRequest::library_key`]), read and never written: they
    /// must hold every part of one split of that library, and every entry is verified first
    /// (its hash and the key of its recorded inputs): a damaged entry, or a file that is no
    /// entry, is an error naming it rather than a table to build again (a merge integrates
    /// nothing).
    pub fn shards(dirs: &[PathBuf], library: &str) -> Result<SliceCache> {
        let Some((first, rest)) = dirs.split_first() else {
            return Err(Error::invalid("tmlut merge", "no shard folder given"));
        };
        let mut parts = std::collections::BTreeSet::new();
        let mut other_libraries = 0;
        for dir in dirs {
            if !is_tagged(dir) {
                return Err(Error::format(dir, format!("is not a shard folder: it has no {TAG_FILE} naming tmlut")));
            }
            for (path, _, _) in entries(dir)? {
                let bytes = crate::formats::read_bytes(&path)?;
                let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                let damaged = |why: String| Error::format(&path, format!("is a damaged shard entry: {why}"));
                match path.extension().and_then(|e| e.to_str()) {
                    Some(ENTRY_EXTENSION) => {
                        decode(&bytes, &name).map_err(damaged)?;
                    }
                    Some(SHARD_EXTENSION) => {
                        let record = decode_shard_record(&bytes, &name).map_err(damaged)?;
                        if record.library == library {
                            parts.insert((record.count, record.index));
                        } else {
                            other_libraries += 1;
                        }
                    }
                    _ => {}
                }
            }
        }
        let counts: std::collections::BTreeSet<usize> = parts.iter().map(|p| p.0).collect();
        let refused = |reason: String| Error::invalid("tmlut merge", reason);
        match counts.len() {
            0 => {
                return Err(refused(format!(
                    "the shard folders hold no shard of this library ({other_libraries} of other scenes, \
                     configurations, seeds or checks): merge with the scenes, configuration, seed and \
                     --slice-checks the shards were built with"
                )));
            }
            1 => {}
            _ => {
                return Err(refused(format!(
                    "the shard folders hold shards of several splits of this library ({}): give the folders of one",
                    counts.iter().map(|c| format!("into {c}")).collect::<Vec<_>>().join(", ")
                )));
            }
        }
        let count = *counts.first().expect("one count");
        let missing: Vec<String> =
            (1..=count).filter(|i| !parts.contains(&(count, *i))).map(|i| format!("{i}/{count}")).collect();
        if !missing.is_empty() {
            return Err(refused(format!(
                "shard(s) {} of this library are in none of the folders given: run every shard (`tmlut build \
                 --shard I/N` for I = 1 to N) and give all their folders",
                missing.join(", ")
            )));
        }
        Ok(SliceCache::new(first, rest.to_vec(), false))
    }

    /// Record in the folder that it holds part `shard` of the library whose key is `library`.
    pub fn put_shard_record(&self, library: &str, shard: Shard) -> Result<()> {
        let record = ShardRecord { library: library.to_string(), index: shard.index, count: shard.count };
        let path = self.dir.join(format!("{}.{SHARD_EXTENSION}", record.file_stem()));
        write_cache_file(&path, &sealed(&record)).map_err(|source| Error::io(&path, source))
    }

    fn entry_path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.{ENTRY_EXTENSION}"))
    }

    fn usable(&self) -> bool {
        self.usable.load(Ordering::Relaxed)
    }

    fn disable(&self, why: &str) {
        // Only the first failure warns.
        if self.usable.swap(false, Ordering::Relaxed) {
            self.warn(format!("table cache {}: {why}; building without it", self.dir.display()));
        }
    }

    /// What follows an entry refused: a build integrates the table again; a merge's shards are
    /// read, never built again (the merge names the entry).
    fn then_built_again(&self) -> &'static str {
        if self.note_reads { "; built again" } else { "" }
    }

    fn warn(&self, warning: String) {
        self.warnings.lock().unwrap_or_else(|p| p.into_inner()).push(warning);
    }

    /// Whether the folder proved unusable in this build (it could not be created or written).
    pub fn failed(&self) -> bool {
        !self.usable()
    }

    /// What went wrong with the cache in this build (damaged entries, an unusable folder).
    pub fn warnings(&self) -> Vec<String> {
        self.warnings.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Slices read from the cache in this build.
    pub fn hits(&self) -> usize {
        self.hits.load(Ordering::Relaxed)
    }

    /// The slice's build from the cache, if an intact entry holds it; a damaged entry is reported
    /// and left for [`SliceCache::put`] to replace.
    pub fn get(&self, slices: &Slices, seed: u64) -> Option<TableBuild> {
        let expected = slices.empty_table().ok()?;
        // The channels' descriptions name the materials that read them: this build's.
        let mut build = self.read_verified(&CacheKey::of_slices(slices, seed), slices, &expected.axes)?;
        build.table.name = expected.name;
        build.table.channels = expected.channels;
        Some(build)
    }

    /// The build of `kernel` stored under `key`, verified: its hash, the key of its recorded
    /// inputs, its axes, and its values against the exact integral at [`VERIFIED_NODES`] nodes
    /// no one can predict.
    pub fn get_by_key<K: Kernel + ?Sized>(&self, key: &CacheKey, kernel: &K) -> Option<TableBuild> {
        self.read_verified(key, kernel, &kernel.empty_table().ok()?.axes)
    }

    /// [`SliceCache::get_by_key`] of a table whose axes must be `axes`.
    fn read_verified<K: Kernel + ?Sized>(
        &self,
        key: &CacheKey,
        kernel: &K,
        axes: &[crate::table::Axis],
    ) -> Option<TableBuild> {
        if !self.usable() {
            return None;
        }
        let file = format!("{}.{ENTRY_EXTENSION}", key.hex);
        let path = std::iter::once(&self.dir)
            .chain(&self.read_only)
            .map(|dir| dir.join(&file))
            .find(|path| path.symlink_metadata().is_ok())
            .unwrap_or_else(|| self.entry_path(&key.hex));
        let bytes = match crate::formats::read_bytes(&path) {
            Ok(bytes) => bytes,
            Err(Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => return None,
            Err(e) => {
                self.warn(format!("table cache entry: {e}{}", self.then_built_again()));
                return None;
            }
        };
        let verified = decode(&bytes, &key.hex)
            .and_then(|entry| {
                if entry.inputs != key.inputs {
                    return Err("its recorded inputs are not this table's".into());
                }
                into_build(axes, entry)
            })
            .and_then(|build| verify_values(kernel, &build.table).map(|()| build));
        match verified {
            Ok(mut build) => {
                if !self.note_reads {
                    build.provenance.metadata.notes.retain(|n| n != FROM_CACHE_NOTE);
                }
                self.hits.fetch_add(1, Ordering::Relaxed);
                Some(build)
            }
            Err(why) => {
                self.warn(format!(
                    "table cache entry {} is damaged ({why}){}",
                    path.display(),
                    self.then_built_again()
                ));
                None
            }
        }
    }

    /// Store the build of `slices`; a failure (read-only or full folder) disables the cache for
    /// the rest of the build, with a warning.
    pub fn put(&self, slices: &Slices, seed: u64, build: &TableBuild) {
        self.put_by_key(&CacheKey::of_slices(slices, seed), build);
    }

    /// Store `build` under `key`. A build whose provenance holds what an entry does not keep (a
    /// Fresnel basis, a channel-sum rounding: the split-sum tables) is not stored.
    pub fn put_by_key(&self, key: &CacheKey, build: &TableBuild) {
        let p = &build.provenance;
        let metadata = &p.metadata;
        if !self.usable() || metadata.fresnel_basis.is_some() || metadata.channel_sum.is_some() {
            return;
        }
        let entry = Entry {
            key: key.hex.clone(),
            inputs: key.inputs.clone(),
            integrand: metadata.integrand.clone(),
            masking: metadata.masking,
            notes: metadata.notes.iter().filter(|n| n.as_str() != FROM_CACHE_NOTE).cloned().collect(),
            accuracy: p.accuracy.clone(),
            table: build.table.name.clone(),
            axes: build.table.axes.clone(),
            channels: build.table.channels.clone(),
            values: build.table.data.clone(),
            standard_error: p.standard_error.clone(),
            replicate_standard_error: p.error.replicate_standard_error,
            reference: p.error.reference.clone(),
            interpolation: p.interpolation.clone(),
            sampling: p.sampling.clone(),
            wall_time_s: p.wall_time_s,
        };
        let path = self.entry_path(&key.hex);
        if let Err(e) = write_cache_file(&path, &sealed(&entry)) {
            self.disable(&format!("cannot write {}: {e}", path.display()));
        }
    }
}

/// Quadrature nodes per panel of the exact integral an entry is verified against (the reference
/// check's default: its own error is about 2e-6, `docs/integration.md`).
const VERIFY_QUADRATURE_NODES: usize = 8;

/// Compare `table`, read back from the cache, with the exact integral of `kernel` at
/// [`VERIFIED_NODES`] nodes drawn from this process's randomness, so that an entry edited at
/// chosen nodes cannot know to spare them. Allowed: 0.01 plus the scale of a Monte Carlo estimate
/// of `n` samples, `1 / sqrt(n)`; an honest entry's error is orders of magnitude below that
/// (`budgets.toml` holds references to 1e-4 to 1e-3).
pub(crate) fn verify_values<K: Kernel + ?Sized>(kernel: &K, table: &Table) -> std::result::Result<(), String> {
    let quadrature = VisibleNormalQuadrature::new(VERIFY_QUADRATURE_NODES).map_err(|e| e.to_string())?;
    let sampling = kernel.sampling();
    let samples = (sampling.samples as f64 * f64::from(sampling.replicates.max(1))).max(1.0);
    let allowed = 0.01 + 1.0 / samples.sqrt();
    let seed = u64::from_str_radix(&crate::formats::files::unpredictable_name(), 16).unwrap_or_default();
    for cell in crate::recipes::random_cells(table.node_count(), VERIFIED_NODES, seed) {
        let index = table.node_index(cell as usize);
        let position = table.node_position(&index);
        let exact = kernel.exact_value(&quadrature, &position);
        for (channel, (&stored, exact)) in table.node(&index).iter().zip(exact).enumerate() {
            let difference = (f64::from(stored) - exact).abs();
            // A NaN stored or integrated fails too.
            if difference.is_nan() || difference > allowed {
                return Err(format!(
                    "its value at node {position:?}, channel {channel}, is {stored}, the exact integral {exact:.6}: \
                     they differ by {difference:.3e}, more than the {allowed:.3e} any honest build differs by"
                ));
            }
        }
    }
    Ok(())
}

/// `value` as the cache stores it: one line with the cache's marker, its format and the SHA-256
/// of its JSON, then the JSON.
fn sealed(value: &impl Serialize) -> Vec<u8> {
    sealed_bytes(&serde_json::to_vec(value).expect("plain data"))
}

/// `body` after the line `tmlut-cache <format> <SHA-256 of body>`.
fn sealed_bytes(body: &[u8]) -> Vec<u8> {
    let mut bytes = format!("{MARKER} {CACHE_FORMAT} {}\n", sha256_hex(body)).into_bytes();
    bytes.extend_from_slice(body);
    bytes
}

/// The cache format a file of the cache states on its first line: an entry of another format is
/// laid out and keyed otherwise, neither read nor audited by this one.
fn sealed_format(bytes: &[u8]) -> Option<u32> {
    let line = bytes.split(|&b| b == b'\n').next()?.strip_prefix(format!("{MARKER} ").as_bytes())?;
    std::str::from_utf8(line).ok()?.split(' ').next()?.parse().ok()
}

/// The body of [`sealed_bytes`] `bytes`, if its first line is the cache's and its hash matches.
fn unsealed(bytes: &[u8]) -> std::result::Result<&[u8], String> {
    let newline = bytes.iter().take(256).position(|&b| b == b'\n').ok_or("no marker line")?;
    let (line, body) = (&bytes[..newline], &bytes[newline + 1..]);
    let expected_start = format!("{MARKER} {CACHE_FORMAT} ");
    let Some(hash) = line.strip_prefix(expected_start.as_bytes()) else {
        return Err(format!("its first line is not `{expected_start}<sha256>`: another format or not an entry"));
    };
    if hash != sha256_hex(body).as_bytes() {
        return Err("its SHA-256 does not match its contents".into());
    }
    Ok(body)
}

/// The entry of `bytes`, if its hash, key and layout are intact and its recorded inputs hash to
/// its key.
fn decode(bytes: &[u8], key: &str) -> std::result::Result<Entry, String> {
    let body = unsealed(bytes)?;
    let entry: Entry = serde_json::from_slice(body).map_err(|e| format!("not an entry: {e}"))?;
    if entry.key != key {
        return Err(format!("it holds key {}", entry.key));
    }
    if sha256_hex(entry.inputs.as_bytes()) != entry.key {
        return Err("the SHA-256 of its recorded inputs is not its key".into());
    }
    Ok(entry)
}

/// The build an entry holds, whose axes must be `axes`.
fn into_build(axes: &[crate::table::Axis], entry: Entry) -> std::result::Result<TableBuild, String> {
    if entry.axes != axes {
        return Err("its axes differ from the table's".into());
    }
    let mut table = crate::table::Table::zeros(entry.table, entry.axes, entry.channels).map_err(|e| e.to_string())?;
    if entry.values.len() != table.data.len()
        || entry.standard_error.as_ref().is_some_and(|s| s.len() != table.data.len())
        || entry.values.iter().any(|v| !v.is_finite())
    {
        return Err(format!("{} values where the table has {}", entry.values.len(), table.data.len()));
    }
    table.data = entry.values;
    let mut notes = entry.notes;
    notes.push(FROM_CACHE_NOTE.into());
    Ok(TableBuild {
        table,
        provenance: Provenance {
            metadata: Metadata { integrand: entry.integrand, masking: entry.masking, notes, ..Metadata::default() },
            sampling: entry.sampling,
            error: ErrorRecord::new(entry.replicate_standard_error, entry.reference),
            wall_time_s: entry.wall_time_s,
            accuracy: entry.accuracy,
            standard_error: entry.standard_error,
            interpolation: entry.interpolation,
        },
    })
}

/// Which part of which library a shard folder holds ([`SliceCache::put_shard_record`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ShardRecord {
    library: String,
    index: usize,
    count: usize,
}

impl ShardRecord {
    /// Its file's name before the extension: the SHA-256 of the library and the part.
    fn file_stem(&self) -> String {
        sha256_hex(format!("{} {}/{}", self.library, self.index, self.count).as_bytes())
    }
}

fn decode_shard_record(bytes: &[u8], name: &str) -> std::result::Result<ShardRecord, String> {
    let record: ShardRecord = serde_json::from_slice(unsealed(bytes)?).map_err(|e| e.to_string())?;
    if record.file_stem() != name {
        return Err("it is not the record its name says".into());
    }
    Ok(record)
}

/// Write `bytes` to the cache file `path`: into a temporary of its own, locked while it is written
/// so that [`remove_abandoned_temporaries`] tells a live writer's from a dead one's, then renamed
/// into place. Not synced: an entry torn by a crash fails its hash and is built again.
fn write_cache_file(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (temporary, mut file) = crate::formats::files::create_temporary(dir, &name)?;
    let written =
        fs4::FileExt::lock(&file).and_then(|()| file.write_all(bytes)).and_then(|()| std::fs::rename(&temporary, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written
}

/// Remove the temporary files of the cache at `dir` that their writers left when they died: a
/// regular file (never a link) named as a temporary, older than a minute, whose lock no process
/// holds.
fn remove_abandoned_temporaries(dir: &Path) {
    let Ok(listing) = std::fs::read_dir(dir) else { return };
    let now = std::time::SystemTime::now();
    for entry in listing.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !crate::formats::files::is_temporary(&name) {
            continue;
        }
        let path = entry.path();
        let old = path
            .symlink_metadata()
            .ok()
            .filter(|m| m.is_file())
            .and_then(|m| m.modified().ok())
            .is_some_and(|modified| now.duration_since(modified).unwrap_or_default() > ABANDONED_AFTER);
        if !old {
            continue;
        }
        if let Ok((file, _)) = crate::formats::files::open_regular(&path, "a cache temporary")
            && fs4::FileExt::try_lock(&file).is_ok()
        {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// The text of a cache folder's [`TAG_FILE`].
fn tag_text() -> String {
    format!(
        "{TAG_SIGNATURE}\n# This folder is a tmlut table cache (tmlut build --scene ... --cache). tmlut counts, prunes \
         and removes only\n# the files named as its entries (<sha256>.slice, .build, .object, .shard) that begin with \
         `{MARKER}`.\n# For information about cache directory tags see https://bford.info/cachedir/\n"
    )
}

/// Whether `dir` carries a tmlut cache's [`TAG_FILE`].
fn is_tagged(dir: &Path) -> bool {
    crate::formats::read_bytes_at_most(&dir.join(TAG_FILE), 4096, "a cache tag")
        .is_ok_and(|tag| tag.starts_with(TAG_SIGNATURE.as_bytes()) && tag.windows(5).any(|w| w == b"tmlut"))
}

/// Whether `name` is one a cache file has: 64 lowercase hexadecimal digits and an entry's extension.
fn is_entry_name(name: &str) -> bool {
    name.split_once('.').is_some_and(|(stem, extension)| {
        stem.len() == 64
            && stem.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
            && EXTENSIONS.contains(&extension)
    })
}

/// Take `dir` as a cache folder: create it where it does not exist, and tag it where it is new,
/// empty or holds only files named as a cache's (an earlier tmlut's cache, untagged). A folder
/// holding anything else is not a cache: refused as a `Format` error naming what it holds, so
/// that no count, prune or build touches it.
pub fn claim(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
    if is_tagged(dir) {
        return Ok(());
    }
    let listing = std::fs::read_dir(dir).map_err(|source| Error::io(dir, source))?;
    let mut foreign: Vec<String> = listing
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|name| !is_entry_name(name) && !crate::formats::files::is_temporary(name))
        .collect();
    if !foreign.is_empty() {
        foreign.sort();
        let shown: Vec<String> = foreign.iter().take(3).map(|n| format!("`{}`", n.escape_debug())).collect();
        return Err(Error::format(
            dir,
            format!(
                "is not a tmlut table cache: it has no {TAG_FILE} naming tmlut and holds {} file(s) no cache writes \
                 ({}{}); tmlut touches no file of it: name a new or empty folder for the cache",
                foreign.len(),
                shown.join(", "),
                if foreign.len() > 3 { ", ..." } else { "" }
            ),
        ));
    }
    crate::formats::write_bytes_atomically(&dir.join(TAG_FILE), tag_text().as_bytes())
}

/// A whole build's record: every file of the output folder it left, the manifest among them.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct BuildRecord {
    key: String,
    files: Vec<RecordedFile>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct RecordedFile {
    name: String,
    sha256: String,
    bytes: u64,
}

/// Why [`restore_build`] restored nothing where the cache has never kept the build.
pub const NO_RECORD: &str = "no record of this build";

/// What [`restore_build`] put into the output folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Restored {
    pub files: usize,
    pub bytes: u64,
}

fn build_record_path(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("{key}.{BUILD_EXTENSION}"))
}

fn object_path(dir: &Path, sha256: &str) -> PathBuf {
    dir.join(format!("{sha256}.{OBJECT_EXTENSION}"))
}

/// Keep the files of the output folder `out` in the cache at `dir` under the whole build's `key`
/// ([`restore_build`]): every file its manifest lists and the manifest, each checked against the
/// SHA-256 the manifest states, taken under the folder's lock.
pub fn store_build(dir: &Path, key: &str, out: &Path) -> Result<()> {
    let _folder = crate::commit::OutputFolder::take(out, |_| {})?;
    let manifest_bytes = crate::formats::read_bytes_at_most(
        &out.join(crate::formats::manifest::MANIFEST_FILE),
        crate::formats::MAX_MANIFEST_BYTES,
        "a manifest",
    )?;
    let manifest: crate::formats::manifest::Manifest = serde_json::from_slice(&manifest_bytes)
        .map_err(|e| Error::format(out, format!("not a tmlut manifest: {e}")))?;
    claim(dir)?;
    let mut files = Vec::new();
    let mut keep = |name: &str, bytes: &[u8]| -> Result<()> {
        let sha256 = sha256_hex(bytes);
        let object = object_path(dir, &sha256);
        // A file kept by an earlier build is written again where it is not intact.
        if read_object(&object, &sha256, bytes.len() as u64).is_err() {
            write_cache_file(&object, &sealed_bytes(bytes)).map_err(|source| Error::io(&object, source))?;
        }
        files.push(RecordedFile { name: name.to_string(), sha256, bytes: bytes.len() as u64 });
        Ok(())
    };
    for (name, stated) in manifest.listed_files() {
        let path = out.join(name);
        let bytes = crate::formats::read_bytes(&path)?;
        if sha256_hex(&bytes) != stated {
            return Err(Error::format(&path, "its SHA-256 is not the one its manifest states: not kept"));
        }
        keep(name, &bytes)?;
    }
    keep(crate::formats::manifest::MANIFEST_FILE, &manifest_bytes)?;
    let record = BuildRecord { key: key.to_string(), files };
    let path = build_record_path(dir, key);
    write_cache_file(&path, &sealed(&record)).map_err(|source| Error::io(&path, source))
}

/// The file a build record lists as `sha256` of `bytes` bytes, from its object, if intact.
fn read_object(object: &Path, sha256: &str, bytes: u64) -> std::result::Result<Vec<u8>, String> {
    let sealed = crate::formats::read_bytes(object).map_err(|e| e.to_string())?;
    let body =
        unsealed(&sealed).map_err(|why| format!("{} does not hold the bytes of its name ({why})", object.display()))?;
    if body.len() as u64 != bytes || sha256_hex(body) != sha256 {
        return Err(format!("{} does not hold the bytes of its name", object.display()));
    }
    Ok(body.to_vec())
}

/// Restore the output folder a build with `key` left ([`store_build`]) into `out`, as one commit
/// once `verify` accepts the staged folder (the values of its tables: see
/// [`crate::scene::build::verify_restored`]): `Ok(Err(why))` where the cache holds no intact
/// record and files of it (a file missing or not of its SHA-256), where `verify` refuses them
/// (the build goes on, `why` says what was wrong), or where `out` holds files that the record
/// does not (a build into that folder would keep them beside its own).
pub fn restore_build(
    dir: &Path,
    key: &str,
    out: &Path,
    on_wait: impl FnOnce(&str),
    verify: impl FnOnce(&Path) -> std::result::Result<(), String>,
) -> Result<std::result::Result<Restored, String>> {
    let record_path = build_record_path(dir, key);
    if !is_tagged(dir) {
        return Ok(Err(NO_RECORD.into()));
    }
    let bytes = match crate::formats::read_bytes(&record_path) {
        Ok(bytes) => bytes,
        Err(Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Err(NO_RECORD.into()));
        }
        Err(e) => return Ok(Err(e.to_string())),
    };
    let record = match decode_record(&bytes, key) {
        Ok(record) => record,
        Err(why) => return Ok(Err(format!("{}: {why}", record_path.display()))),
    };
    let folder = crate::commit::OutputFolder::take(out, on_wait)?;
    let manifest = crate::formats::manifest::Manifest::read_or_default(out)?;
    if let Some((name, _)) =
        manifest.listed_files().into_iter().find(|(name, _)| !record.files.iter().any(|f| f.name == *name))
    {
        return Ok(Err(format!("{} holds `{name}`, which that build did not write", out.display())));
    }
    let mut staging = folder.staging()?;
    let mut moves = Vec::new();
    let mut total = 0;
    for file in &record.files {
        let object = object_path(dir, &file.sha256);
        let bytes = match read_object(&object, &file.sha256, file.bytes) {
            Ok(bytes) => bytes,
            Err(why) => return Ok(Err(why)),
        };
        crate::formats::manifest::check_file_name(&file.name)
            .map_err(|why| Error::format(&record_path, format!("lists `{}`: {why}", file.name)))?;
        let staged = staging.dir.join(&file.name);
        if let Some(parent) = staged.parent()
            && parent != staging.dir
        {
            crate::formats::files::create_folder_inside(parent)?;
        }
        crate::formats::write_bytes_atomically(&staged, &bytes)?;
        total += file.bytes;
        if file.name != crate::formats::manifest::MANIFEST_FILE {
            moves.push(crate::commit::Move { staged: file.name.clone(), destination: file.name.clone() });
        }
    }
    if let Err(why) = verify(&staging.dir) {
        return Ok(Err(format!("the build {key} it keeps is damaged: {why}")));
    }
    crate::commit::commit(&folder, &mut staging, moves, Vec::new())?;
    // Pruning removes the oldest files first: a record just used, and its files, are the newest.
    let now = std::time::SystemTime::now();
    for path in std::iter::once(record_path).chain(record.files.iter().map(|f| object_path(dir, &f.sha256))) {
        if let Ok((file, _)) = crate::formats::files::open_regular(&path, "a cache file") {
            let _ = file.set_modified(now);
        }
    }
    Ok(Ok(Restored { files: record.files.len(), bytes: total }))
}

/// The record of `bytes`, if its hash and key are intact.
fn decode_record(bytes: &[u8], key: &str) -> std::result::Result<BuildRecord, String> {
    let body = unsealed(bytes)?;
    let record: BuildRecord = serde_json::from_slice(body).map_err(|e| e.to_string())?;
    if record.key != key {
        return Err("it is the record of another build".into());
    }
    if !record.files.iter().any(|f| f.name == crate::formats::manifest::MANIFEST_FILE) {
        return Err("it lists no manifest".into());
    }
    Ok(record)
}

/// What [`verify`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Verified {
    /// Entries integrated again from their recorded inputs, equal to the bit.
    pub identical: usize,
    /// Entries of another cache format or tmlut version, which this one does not integrate alike
    /// (nor, for another format, read).
    pub other_version: usize,
    /// Each entry refused, with why: damaged, or integrated to other values.
    pub refused: Vec<String>,
}

/// Integrate every slice and table entry of the cache at `dir` again from the inputs it records,
/// and compare its values bit for bit (a build is deterministic: the same inputs give the same
/// bits). The full audit that the sampled check of every read ([`VERIFIED_NODES`]) is not: it
/// costs what building every entry costs.
pub fn verify(dir: &Path, progress: &dyn crate::integrate::Progress) -> Result<Verified> {
    use rayon::prelude::*;
    claim(dir)?;
    let slice_entries: Vec<PathBuf> = entries(dir)?
        .into_iter()
        .map(|(path, ..)| path)
        .filter(|path| path.extension().is_some_and(|e| e == ENTRY_EXTENSION))
        .collect();
    let outcomes: Vec<std::result::Result<bool, String>> = slice_entries
        .par_iter()
        .map(|path| {
            let named = |why: String| format!("{}: {why}", path.display());
            let bytes = crate::formats::read_bytes(path).map_err(|e| e.to_string())?;
            let key = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            if sealed_format(&bytes).is_some_and(|format| format != CACHE_FORMAT) {
                return Ok(false);
            }
            let entry = decode(&bytes, &key).map_err(named)?;
            let Some(built) = rebuild(&entry.inputs, progress).map_err(named)? else { return Ok(false) };
            let differing = built.data.iter().zip(&entry.values).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
            if differing > 0 || built.data.len() != entry.values.len() {
                return Err(named(format!(
                    "{differing} of its {} values are not those its recorded inputs integrate to",
                    entry.values.len()
                )));
            }
            Ok(true)
        })
        .collect();
    let mut verified = Verified::default();
    for outcome in outcomes {
        match outcome {
            Ok(true) => verified.identical += 1,
            Ok(false) => verified.other_version += 1,
            Err(why) => verified.refused.push(why),
        }
    }
    Ok(verified)
}

/// The table an entry's recorded `inputs` integrate to, or `None` where they are another cache
/// format's or tmlut version's.
fn rebuild(inputs: &str, progress: &dyn crate::integrate::Progress) -> std::result::Result<Option<Table>, String> {
    let current = |format: u32, version: &str| format == CACHE_FORMAT && version == env!("CARGO_PKG_VERSION");
    if let Ok(slice) = serde_json::from_str::<SliceInputs>(inputs) {
        if !current(slice.format, &slice.version) {
            return Ok(None);
        }
        let slices = Slices {
            name: "verified".into(),
            of: slice.of,
            lookup_mu: [slice.mu.start, slice.mu.end],
            lookup_alpha: [slice.alpha.start, slice.alpha.end],
            mu: slice.mu,
            alpha: slice.alpha,
            channels: slice
                .indices
                .iter()
                .map(|&(eta, kappa)| crate::recipes::slices::SliceChannel {
                    eta: f64::from_bits(eta),
                    kappa: f64::from_bits(kappa),
                    used_by: String::new(),
                })
                .collect(),
        };
        let built = crate::recipes::driver::build(&slices, slice.seed, progress).map_err(|e| e.to_string())?;
        return Ok(Some(built.table));
    }
    let (format, version, table, settings, seed): (u32, String, String, serde_json::Value, u64) =
        serde_json::from_str(inputs)
            .map_err(|e| format!("its recorded inputs are neither a slice's nor a table's: {e}"))?;
    if !current(format, &version) {
        return Ok(None);
    }
    let config: crate::config::Config = serde_json::from_value(serde_json::json!({ table.as_str(): settings }))
        .map_err(|e| format!("its recorded settings of `{table}` are not this tmlut's: {e}"))?;
    let recipe = config.recipe_named(&table).ok_or_else(|| format!("no table is named `{table}`"))?;
    Ok(Some(recipe.build(seed, progress).map_err(|e| e.to_string())?.table))
}

/// What a cache folder holds: entries and their bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CacheUsage {
    pub entries: usize,
    pub bytes: u64,
    /// Files named as entries that do not begin with this tmlut's marker (an earlier cache
    /// format's, or not a cache's): neither counted nor pruned.
    pub unmarked: usize,
}

/// The files of the cache at `dir` that are provably its own, oldest first, with their sizes:
/// regular files (not links) named as entries ([`is_entry_name`]) that begin with the cache's
/// marker.
fn entries(dir: &Path) -> Result<Vec<(PathBuf, u64, std::time::SystemTime)>> {
    let listing = std::fs::read_dir(dir).map_err(|source| Error::io(dir, source))?;
    let marked = |path: &Path| {
        crate::formats::files::open_regular(path, "a cache file").is_ok_and(|(file, _)| {
            let mut start = [0u8; MARKER.len()];
            std::io::Read::read_exact(&mut &file, &mut start).is_ok() && start == *MARKER.as_bytes()
        })
    };
    let mut entries: Vec<(PathBuf, u64, std::time::SystemTime)> = listing
        .filter_map(|e| e.ok())
        .filter(|e| is_entry_name(&e.file_name().to_string_lossy()))
        .filter_map(|e| {
            let metadata = e.path().symlink_metadata().ok().filter(|m| m.is_file())?;
            marked(&e.path()).then(|| (e.path(), metadata.len(), metadata.modified().unwrap_or(std::time::UNIX_EPOCH)))
        })
        .collect();
    entries.sort_by(|a, b| a.2.cmp(&b.2).then_with(|| a.0.cmp(&b.0)));
    Ok(entries)
}

/// Entries and bytes of the cache at `dir` ([`claim`]ed: a folder that is not a cache is refused).
pub fn usage(dir: &Path) -> Result<CacheUsage> {
    claim(dir)?;
    let entries = entries(dir)?;
    Ok(CacheUsage {
        entries: entries.len(),
        bytes: entries.iter().map(|e| e.1).sum(),
        unmarked: unmarked(dir, &entries),
    })
}

/// Regular files of `dir` named as entries that [`entries`] did not find its own.
fn unmarked(dir: &Path, own: &[(PathBuf, u64, std::time::SystemTime)]) -> usize {
    let Ok(listing) = std::fs::read_dir(dir) else { return 0 };
    listing
        .flatten()
        .filter(|e| is_entry_name(&e.file_name().to_string_lossy()))
        .filter(|e| e.path().symlink_metadata().is_ok_and(|m| m.is_file()))
        .filter(|e| !own.iter().any(|(path, ..)| *path == e.path()))
        .count()
}

/// Remove the oldest entries of the cache at `dir` until it holds at most `max_bytes` (0 empties
/// it), and the temporary files of writers that died; only files provably the cache's own are
/// touched ([`entries`]), in a folder that is a cache ([`claim`]). Returns what is left.
pub fn prune(dir: &Path, max_bytes: u64) -> Result<CacheUsage> {
    claim(dir)?;
    remove_abandoned_temporaries(dir);
    let oldest_first = entries(dir)?;
    let mut total: u64 = oldest_first.iter().map(|e| e.1).sum();
    let mut left = oldest_first.len();
    for (path, bytes, _) in &oldest_first {
        if total <= max_bytes {
            break;
        }
        std::fs::remove_file(path).map_err(|source| Error::io(path, source))?;
        total -= bytes;
        left -= 1;
    }
    let kept = entries(dir)?;
    Ok(CacheUsage { entries: left, bytes: total, unmarked: unmarked(dir, &kept) })
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::fgd::FgdSettings;
    use crate::recipes::settings::SamplingConfig;
    use crate::recipes::slices::{SliceChannel, SliceOf, integrate_batch};
    use crate::table::{Axis, Mapping};

    fn slice(name: &str, eta: f64) -> Slices {
        let mut settings = FgdSettings::default();
        settings.shared.sampling = SamplingConfig::replicated(1 << 10);
        settings.shared.reference.cells = 4;
        settings.shared.reference.nodes = 4;
        let mu = Axis::node_aligned("mu", 0.5, 0.5 + 4.0 / 128.0, 5).unwrap();
        let alpha = Axis::node_aligned("alpha", 0.0625, 0.0625 * (1.0 + 1.0 / 32.0) * (1.0 + 1.0 / 32.0), 2)
            .unwrap()
            .with_mapping(Mapping::Sqrt)
            .unwrap();
        Slices {
            name: name.into(),
            of: SliceOf::Fgd(settings),
            lookup_mu: [mu.start, mu.end],
            lookup_alpha: [alpha.start, alpha.end],
            mu,
            alpha,
            channels: vec![SliceChannel { eta, kappa: 0.0, used_by: name.into() }],
        }
    }

    #[test]
    fn an_entry_gives_back_the_bits_it_stored_under_any_name_and_a_damaged_one_is_never_used() {
        let dir = tempfile::tempdir().unwrap();
        let cache = SliceCache::open(dir.path()).unwrap();
        let built = integrate_batch(&[&slice("a", 1.5)], 3, &()).unwrap().remove(0);
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        cache.put(&slice("a", 1.5), 3, &built);
        // Another name, the same integral: the same entry.
        let read = cache.get(&slice("renamed", 1.5), 3).expect("a hit");
        assert_eq!(read.table.data, built.table.data);
        assert_eq!(read.provenance.error, built.provenance.error);
        assert_eq!(cache.hits(), 1);
        // Another index or seed: another key.
        assert!(cache.get(&slice("a", 1.6), 3).is_none() && cache.get(&slice("a", 1.5), 4).is_none());

        // One byte changed: refused with a warning, built again and stored whole.
        let path = cache.entry_path(&CacheKey::of_slices(&slice("a", 1.5), 3).hex);
        let mut bytes = std::fs::read(&path).unwrap();
        let last = bytes.len() - 2;
        bytes[last] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        assert!(cache.warnings().iter().any(|w| w.contains("damaged")), "{:?}", cache.warnings());
        cache.put(&slice("a", 1.5), 3, &built);
        assert_eq!(cache.get(&slice("a", 1.5), 3).unwrap().table.data, built.table.data);

        assert_eq!(usage(dir.path()).unwrap().entries, 1);
        assert_eq!(prune(dir.path(), 0).unwrap(), CacheUsage::default());
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        // An entry of an earlier format (no marker line) is the folder's by name only: left alone, and said.
        let old_format = dir.path().join(format!("{}.slice", "a".repeat(64)));
        std::fs::write(&old_format, format!("{}\n{{}}", "b".repeat(64))).unwrap();
        assert_eq!(prune(dir.path(), 0).unwrap(), CacheUsage { unmarked: 1, ..CacheUsage::default() });
        assert!(old_format.exists());
    }

    #[test]
    fn a_key_covers_what_is_integrated_not_the_files_it_is_written_to() {
        use crate::formats::{FileFormat, Precision};
        let dir = tempfile::tempdir().unwrap();
        let cache = SliceCache::open(dir.path()).unwrap();
        let dds = slice("a", 1.5);
        let built = integrate_batch(&[&dds], 3, &()).unwrap().remove(0);
        cache.put(&dds, 3, &built);
        let mut ktx2_f16 = dds.clone();
        let SliceOf::Fgd(settings) = &mut ktx2_f16.of else { unreachable!("an FGD slice") };
        settings.packing_formats = vec![FileFormat::Ktx2];
        settings.packings.clear();
        settings.shared.output =
            crate::config::OutputConfig { formats: vec![FileFormat::Exr], precision: Precision::F16 };
        assert_eq!(CacheKey::of_slices(&dds, 3), CacheKey::of_slices(&ktx2_f16, 3));
        assert_eq!(cache.get(&ktx2_f16, 3).expect("a hit").table.data, built.table.data);
        let mut resampled = dds.clone();
        let SliceOf::Fgd(settings) = &mut resampled.of else { unreachable!("an FGD slice") };
        settings.shared.sampling.samples *= 2;
        assert_ne!(CacheKey::of_slices(&dds, 3), CacheKey::of_slices(&resampled, 3));

        // A whole table: its output and companions aside, every setting is in its key.
        let tir = crate::recipes::tir::TirSettings::default();
        let mut written_otherwise = tir.clone();
        written_otherwise.shared.output =
            crate::config::OutputConfig { formats: vec![FileFormat::Ktx2], precision: Precision::F16 };
        written_otherwise.fit = crate::recipes::tir::TirFit::Off;
        let key =
            |settings: &crate::recipes::tir::TirSettings| CacheKey::of_table(&TableSettings::Tir(settings.clone()), 3);
        assert_eq!(key(&tir), key(&written_otherwise));
        written_otherwise.top_eta = 0.999;
        assert_ne!(key(&tir), key(&written_otherwise));

        // The full audit integrates the entry again from the inputs it records, output cleared;
        // an entry of another cache format is neither read nor refused.
        let other_format = dir.path().join(format!("{}.slice", "c".repeat(64)));
        std::fs::write(&other_format, format!("{MARKER} {} {}\n{{}}", CACHE_FORMAT - 1, "d".repeat(64))).unwrap();
        let verified = verify(dir.path(), &()).unwrap();
        assert_eq!(verified, Verified { identical: 1, other_version: 1, refused: Vec::new() });
    }

    #[test]
    fn a_cache_that_cannot_be_written_degrades_to_building_with_one_warning() {
        let dir = tempfile::tempdir().unwrap();
        // A file where the cache folder should be.
        let file = dir.path().join("not-a-folder");
        std::fs::write(&file, b"x").unwrap();
        let cache = SliceCache::open(&file).unwrap();
        let built = integrate_batch(&[&slice("a", 1.5)], 3, &()).unwrap().remove(0);
        cache.put(&slice("a", 1.5), 3, &built);
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        assert_eq!(cache.warnings().len(), 1, "{:?}", cache.warnings());
        assert!(cache.warnings()[0].contains("building without it"), "{:?}", cache.warnings());
    }

    /// An entry re-sealed around edited values, as an attacker with write access to the folder
    /// would make it: its hash line is right, its values are not.
    fn reseal(path: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
        let bytes = std::fs::read(path).unwrap();
        let mut entry: serde_json::Value = serde_json::from_slice(unsealed(&bytes).unwrap()).unwrap();
        edit(&mut entry);
        std::fs::write(path, sealed(&entry)).unwrap();
    }

    #[test]
    fn an_entry_resealed_around_other_values_or_inputs_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let cache = SliceCache::open(dir.path()).unwrap();
        let built = integrate_batch(&[&slice("a", 1.5)], 3, &()).unwrap().remove(0);
        cache.put(&slice("a", 1.5), 3, &built);
        let path = cache.entry_path(&CacheKey::of_slices(&slice("a", 1.5), 3).hex);
        let honest = std::fs::read(&path).unwrap();

        // Every value raised by 0.25: whichever nodes are drawn, the exact integral disagrees.
        reseal(&path, |entry| {
            for v in entry["values"].as_array_mut().unwrap() {
                *v = serde_json::json!(v.as_f64().unwrap() + 0.25);
            }
        });
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        let warnings = cache.warnings();
        assert!(warnings.last().unwrap().contains("exact integral"), "{warnings:?}");

        // Inputs that are not what the key was computed from.
        std::fs::write(&path, &honest).unwrap();
        reseal(&path, |entry| entry["inputs"] = serde_json::json!("{}"));
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        assert!(cache.warnings().last().unwrap().contains("recorded inputs"), "{:?}", cache.warnings());

        // The honest entry is still read.
        std::fs::write(&path, &honest).unwrap();
        assert!(cache.get(&slice("a", 1.5), 3).is_some());
    }

    #[test]
    fn a_folder_that_is_not_a_cache_is_refused_and_only_the_caches_own_files_are_pruned() {
        let dir = tempfile::tempdir().unwrap();
        let project = dir.path().join("project");
        std::fs::create_dir(&project).unwrap();
        for name in ["project.build", "model.object", "notes.slice", ".vimrc.tmp-1"] {
            std::fs::write(project.join(name), b"mine").unwrap();
        }
        let refused = prune(&project, 0).unwrap_err().to_string();
        assert!(refused.contains("not a tmlut table cache") && refused.contains("model.object"), "{refused}");
        assert!(SliceCache::open(&project).is_err());
        assert_eq!(std::fs::read_dir(&project).unwrap().count(), 4);

        // A cache: a file named as an entry that is not one (no marker) is left alone.
        let cache_dir = dir.path().join("cache");
        let cache = SliceCache::open(&cache_dir).unwrap();
        assert!(is_tagged(&cache_dir));
        let built = integrate_batch(&[&slice("a", 1.5)], 3, &()).unwrap().remove(0);
        cache.put(&slice("a", 1.5), 3, &built);
        let impostor = cache_dir.join(format!("{}.object", "0".repeat(64)));
        std::fs::write(&impostor, b"a user's file").unwrap();
        assert_eq!(usage(&cache_dir).unwrap().entries, 1);
        assert_eq!(prune(&cache_dir, 0).unwrap(), CacheUsage { unmarked: 1, ..CacheUsage::default() });
        assert!(impostor.exists() && cache_dir.join(TAG_FILE).exists());
    }

    #[test]
    fn a_temporary_is_removed_once_its_writer_is_gone_and_never_while_it_writes() {
        let dir = tempfile::tempdir().unwrap();
        SliceCache::open(dir.path()).unwrap();
        let old = std::time::SystemTime::now() - 2 * ABANDONED_AFTER;
        let (abandoned, file) = crate::formats::files::create_temporary(dir.path(), "x.slice").unwrap();
        file.set_modified(old).unwrap();
        drop(file);
        let (live, file) = crate::formats::files::create_temporary(dir.path(), "y.slice").unwrap();
        fs4::FileExt::lock(&file).unwrap();
        file.set_modified(old).unwrap();
        let (young, _young_file) = crate::formats::files::create_temporary(dir.path(), "z.slice").unwrap();
        SliceCache::open(dir.path()).unwrap();
        assert!(!abandoned.exists() && live.exists() && young.exists());
    }
}
