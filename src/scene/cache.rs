//! A content-addressed cache of the tables a scene build integrates, shared across scenes, output
//! folders and runs (`tmlut build --scene ... --cache [DIR]`, `tmlut cache`).
//!
//! A slice's stored values depend on its table and settings (samples, replicates, masking, basis,
//! top index), its `(mu, alpha)` axes, the indices of its channels, the seed and the recipe's code,
//! and on nothing else: not on its name, the materials that read it, or the other slices of the
//! build (`recipes::slices::integrate_batch` makes it so). The SHA-256 of those, with
//! [`CACHE_FORMAT`] and the crate's version, is its key. A full or sub-range table of a plan (GD,
//! a sub-range FGD or TIR) is keyed by its table's name and every setting. The entry
//! `<key>.slice` holds the table's layout, values, replicate standard errors, provenance and the
//! checks of the run that built it, after one line with the SHA-256 of the rest.
//!
//! - An entry is written to a temporary file of its own and renamed into place, so concurrent
//!   builds sharing a cache write whole entries (two writers of one key write the same bytes).
//! - An entry whose hash, key or size does not match is damaged: it is never used; the slice is
//!   built and the entry written again, with a warning.
//! - A cache folder that cannot be created, read or written (read-only, full, not a folder)
//!   degrades to building, with one warning.
//!
//! A whole build is kept too ([`store_build`], [`restore_build`]): the record `<key>.build` lists
//! every file of the output folder it left (tables, shaders, the manifest) by SHA-256, and each
//! file is kept once as `<sha256>.object`. Its key covers everything the files depend on (the
//! scenes as parsed and as written, the configuration, the seed, the options, [`CACHE_FORMAT`] and
//! the version), so a build of an unchanged library restores that folder whole, every file
//! verified by its hash, without planning or reading a table: the slices' entries serve a library
//! that changed.
//!
//! tmlut touches nothing outside the folders it is given, so the cache is used only when asked
//! for: `--cache DIR`, or `--cache` alone for the default folder ([`default_dir`]).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::loader::sha256_hex;
use crate::recipes::Kernel;
use crate::recipes::driver::{Metadata, Provenance, SamplingRecord, TableBuild};
use crate::recipes::interpolation::ExactValues;
use crate::recipes::slices::Slices;
use crate::stats::{ErrorRecord, ErrorSummary, ReferenceComparison};

/// The layout of an entry and of what its key covers; a change to either, or to how a slice is
/// integrated, changes it (and the crate's version is in every key besides).
pub const CACHE_FORMAT: u32 = 7;

/// The extension of an entry.
pub const ENTRY_EXTENSION: &str = "slice";
/// The extension of a whole build's record ([`store_build`]).
pub const BUILD_EXTENSION: &str = "build";
/// The extension of a file a build record lists, named by its SHA-256.
pub const OBJECT_EXTENSION: &str = "object";
/// Every extension of the cache's files: what `tmlut cache` counts and prunes.
const EXTENSIONS: [&str; 3] = [ENTRY_EXTENSION, BUILD_EXTENSION, OBJECT_EXTENSION];

/// The note a slice from the cache carries in the manifest.
pub const FROM_CACHE_NOTE: &str = "From the table cache: built in an earlier run with the same settings, axes, indices and seed (the same bytes); its checks are those of that run.";

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

/// What a slice's key covers, as hashed.
#[derive(Serialize)]
struct KeyFields<'a> {
    format: u32,
    version: &'a str,
    of: &'a crate::recipes::slices::SliceOf,
    mu: &'a crate::table::Axis,
    alpha: &'a crate::table::Axis,
    /// The channels' indices, to the bit.
    indices: Vec<(u64, u64)>,
    seed: u64,
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
    /// The cache at `dir`, created if needed; a folder that cannot be created leaves the cache
    /// unusable, with a warning (the build goes on).
    pub fn open(dir: &Path) -> SliceCache {
        let cache = SliceCache {
            dir: dir.to_path_buf(),
            read_only: Vec::new(),
            note_reads: true,
            usable: AtomicBool::new(true),
            warnings: Mutex::new(Vec::new()),
            hits: AtomicUsize::new(0),
        };
        if let Err(e) = std::fs::create_dir_all(dir) {
            cache.disable(&format!("cannot create it: {e}"));
        } else if !dir.is_dir() {
            cache.disable("it is not a folder");
        }
        cache
    }

    /// The shard folders of a merge (`tmlut merge`), read and never written, every entry first
    /// verified: a damaged entry, or a file that is no entry, is an error naming it rather than a
    /// table to build again (a merge integrates nothing).
    pub fn shards(dirs: &[PathBuf]) -> Result<SliceCache> {
        let Some((first, rest)) = dirs.split_first() else {
            return Err(Error::invalid("tmlut merge", "no shard folder given"));
        };
        for dir in dirs {
            for (path, _, _) in entries(dir)? {
                let bytes = crate::formats::read_bytes(&path)?;
                let key = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                decode(&bytes, &key).map_err(|why| Error::format(&path, format!("is a damaged shard entry: {why}")))?;
            }
        }
        Ok(SliceCache {
            dir: first.clone(),
            read_only: rest.to_vec(),
            note_reads: false,
            usable: AtomicBool::new(true),
            warnings: Mutex::new(Vec::new()),
            hits: AtomicUsize::new(0),
        })
    }

    /// The key of `slices` built with `seed`.
    pub fn key(slices: &Slices, seed: u64) -> String {
        let fields = KeyFields {
            format: CACHE_FORMAT,
            version: env!("CARGO_PKG_VERSION"),
            of: &slices.of,
            mu: &slices.mu,
            alpha: &slices.alpha,
            indices: slices.channels.iter().map(|c| (c.eta.to_bits(), c.kappa.to_bits())).collect(),
            seed,
        };
        sha256_hex(serde_json::to_string(&fields).expect("plain data").as_bytes())
    }

    /// The key of a full (or sub-range) table of a scene plan: its table and settings (every key,
    /// sub-ranges and counts included) and the seed.
    pub fn table_key(table: &str, settings: &impl Serialize, seed: u64) -> String {
        let fields = (CACHE_FORMAT, env!("CARGO_PKG_VERSION"), table, settings, seed);
        sha256_hex(serde_json::to_string(&fields).expect("plain data").as_bytes())
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
        let mut build = self.get_by_key(&Self::key(slices, seed), &expected.axes)?;
        build.table.name = expected.name;
        build.table.channels = expected.channels;
        Some(build)
    }

    /// The build stored under `key`, whose axes must be `axes`.
    pub fn get_by_key(&self, key: &str, axes: &[crate::table::Axis]) -> Option<TableBuild> {
        if !self.usable() {
            return None;
        }
        let file = format!("{key}.{ENTRY_EXTENSION}");
        let path = std::iter::once(&self.dir)
            .chain(&self.read_only)
            .map(|dir| dir.join(&file))
            .find(|path| path.exists())
            .unwrap_or_else(|| self.entry_path(key));
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
            Err(e) => {
                self.warn(format!("table cache entry {}: {e}; built again", path.display()));
                return None;
            }
        };
        match decode(&bytes, key).and_then(|entry| into_build(axes, entry)) {
            Ok(mut build) => {
                if !self.note_reads {
                    build.provenance.metadata.notes.retain(|n| n != FROM_CACHE_NOTE);
                }
                self.hits.fetch_add(1, Ordering::Relaxed);
                Some(build)
            }
            Err(why) => {
                self.warn(format!("table cache entry {} is damaged ({why}); built again", path.display()));
                None
            }
        }
    }

    /// Store the build of `slices`; a failure (read-only or full folder) disables the cache for
    /// the rest of the build, with a warning.
    pub fn put(&self, slices: &Slices, seed: u64, build: &TableBuild) {
        self.put_by_key(&Self::key(slices, seed), build);
    }

    /// Store `build` under `key`. A build whose provenance holds what an entry does not keep (a
    /// Fresnel basis, a channel-sum rounding: the split-sum tables) is not stored.
    pub fn put_by_key(&self, key: &str, build: &TableBuild) {
        let p = &build.provenance;
        let metadata = &p.metadata;
        if !self.usable() || metadata.fresnel_basis.is_some() || metadata.channel_sum.is_some() {
            return;
        }
        let key = key.to_string();
        let entry = Entry {
            key: key.clone(),
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
        let bytes = sealed(&entry);
        let path = self.entry_path(&key);
        // A temporary name of this writer's own, then a rename: readers see a whole entry or none.
        let temporary = self.dir.join(format!(".{key}.tmp-{}-{:?}", std::process::id(), std::thread::current().id()));
        let written = std::fs::write(&temporary, &bytes).and_then(|()| std::fs::rename(&temporary, &path));
        if let Err(e) = written {
            let _ = std::fs::remove_file(&temporary);
            self.disable(&format!("cannot write {}: {e}", path.display()));
        }
    }
}

/// `value` as the cache stores it: one line with the SHA-256 of its JSON, then the JSON.
fn sealed(value: &impl Serialize) -> Vec<u8> {
    let body = serde_json::to_vec(value).expect("plain data");
    let mut bytes = format!("{}\n", sha256_hex(&body)).into_bytes();
    bytes.extend_from_slice(&body);
    bytes
}

/// The JSON of [`sealed`] `bytes`, if it matches its SHA-256 line.
fn unsealed(bytes: &[u8]) -> std::result::Result<&[u8], String> {
    let newline = bytes.iter().position(|&b| b == b'\n').ok_or("no hash line")?;
    let (hash, body) = (&bytes[..newline], &bytes[newline + 1..]);
    if hash != sha256_hex(body).as_bytes() {
        return Err("its SHA-256 does not match its contents".into());
    }
    Ok(body)
}

/// The entry of `bytes`, if its hash, key and layout are intact.
fn decode(bytes: &[u8], key: &str) -> std::result::Result<Entry, String> {
    let body = unsealed(bytes)?;
    let entry: Entry = serde_json::from_slice(body).map_err(|e| format!("not an entry: {e}"))?;
    if entry.key != key {
        return Err(format!("it holds key {}", entry.key));
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
            error: ErrorRecord { replicate_standard_error: entry.replicate_standard_error, reference: entry.reference },
            wall_time_s: entry.wall_time_s,
            accuracy: entry.accuracy,
            standard_error: entry.standard_error,
            interpolation: entry.interpolation,
        },
    })
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
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
    let mut files = Vec::new();
    let mut keep = |name: &str, bytes: &[u8]| -> Result<()> {
        let sha256 = sha256_hex(bytes);
        let object = object_path(dir, &sha256);
        // A file kept by an earlier build is written again where it is not intact.
        if std::fs::read(&object).ok().is_none_or(|kept| sha256_hex(&kept) != sha256) {
            crate::formats::write_bytes_atomically(&object, bytes)?;
        }
        files.push(RecordedFile { name: name.to_string(), sha256, bytes: bytes.len() as u64 });
        Ok(())
    };
    for (name, stated) in manifest.listed_files() {
        let path = out.join(name);
        let bytes = std::fs::read(&path).map_err(|source| Error::io(&path, source))?;
        if sha256_hex(&bytes) != stated {
            return Err(Error::format(&path, "its SHA-256 is not the one its manifest states: not kept"));
        }
        keep(name, &bytes)?;
    }
    keep(crate::formats::manifest::MANIFEST_FILE, &manifest_bytes)?;
    let record = BuildRecord { key: key.to_string(), files };
    crate::formats::write_bytes_atomically(&build_record_path(dir, key), &sealed(&record))
}

/// Restore the output folder a build with `key` left ([`store_build`]) into `out`, as one commit:
/// `Ok(None)` where the cache holds no intact record and files of it (a file missing or not of
/// its SHA-256: the build goes on, `why` says what was wrong), or where `out` holds files that
/// the record does not (a build into that folder would keep them beside its own).
pub fn restore_build(
    dir: &Path,
    key: &str,
    out: &Path,
    on_wait: impl FnOnce(&str),
) -> Result<std::result::Result<Restored, String>> {
    let record_path = build_record_path(dir, key);
    let Ok(bytes) = std::fs::read(&record_path) else {
        return Ok(Err(NO_RECORD.into()));
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
        let bytes = match std::fs::read(&object) {
            Ok(bytes) if bytes.len() as u64 == file.bytes && sha256_hex(&bytes) == file.sha256 => bytes,
            Ok(_) => return Ok(Err(format!("{} does not hold the bytes of its name", object.display()))),
            Err(e) => return Ok(Err(format!("{}: {e}", object.display()))),
        };
        crate::formats::manifest::check_file_name(&file.name)
            .map_err(|why| Error::format(&record_path, format!("lists `{}`: {why}", file.name)))?;
        let staged = staging.dir.join(&file.name);
        if let Some(parent) = staged.parent() {
            std::fs::create_dir_all(parent).map_err(|source| Error::io(parent, source))?;
        }
        std::fs::write(&staged, &bytes).map_err(|source| Error::io(&staged, source))?;
        total += file.bytes;
        if file.name != crate::formats::manifest::MANIFEST_FILE {
            moves.push(crate::commit::Move { staged: file.name.clone(), destination: file.name.clone() });
        }
    }
    crate::commit::commit(&folder, &mut staging, moves, Vec::new())?;
    // Pruning removes the oldest files first: a record just used, and its files, are the newest.
    let now = std::time::SystemTime::now();
    for path in std::iter::once(record_path).chain(record.files.iter().map(|f| object_path(dir, &f.sha256))) {
        let _ = std::fs::File::options().append(true).open(&path).and_then(|f| f.set_modified(now));
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

/// What a cache folder holds: entries and their bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CacheUsage {
    pub entries: usize,
    pub bytes: u64,
}

/// The entries of the cache at `dir`, oldest first, with their sizes.
fn entries(dir: &Path) -> Result<Vec<(PathBuf, u64, std::time::SystemTime)>> {
    let listing = std::fs::read_dir(dir).map_err(|source| Error::io(dir, source))?;
    let mut entries: Vec<(PathBuf, u64, std::time::SystemTime)> = listing
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| EXTENSIONS.iter().any(|&known| x == known)))
        .filter_map(|e| {
            let metadata = e.metadata().ok().filter(|m| m.is_file())?;
            Some((e.path(), metadata.len(), metadata.modified().unwrap_or(std::time::UNIX_EPOCH)))
        })
        .collect();
    entries.sort_by(|a, b| a.2.cmp(&b.2).then_with(|| a.0.cmp(&b.0)));
    Ok(entries)
}

/// Entries and bytes of the cache at `dir`.
pub fn usage(dir: &Path) -> Result<CacheUsage> {
    let entries = entries(dir)?;
    Ok(CacheUsage { entries: entries.len(), bytes: entries.iter().map(|e| e.1).sum() })
}

/// Remove the oldest entries of the cache at `dir` until it holds at most `max_bytes` (0 empties
/// it), and the temporary files of writers that died; only files of the cache's own names are
/// touched. Returns what is left.
pub fn prune(dir: &Path, max_bytes: u64) -> Result<CacheUsage> {
    if let Ok(listing) = std::fs::read_dir(dir) {
        for entry in listing.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') && name.contains(".tmp-") && entry.path().is_file() {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    let entries = entries(dir)?;
    let mut total: u64 = entries.iter().map(|e| e.1).sum();
    let mut left = entries.len();
    for (path, bytes, _) in &entries {
        if total <= max_bytes {
            break;
        }
        std::fs::remove_file(path).map_err(|source| Error::io(path, source))?;
        total -= bytes;
        left -= 1;
    }
    Ok(CacheUsage { entries: left, bytes: total })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::fgd::FgdSettings;
    use crate::recipes::settings::SamplingConfig;
    use crate::recipes::slices::{SliceChannel, SliceOf, integrate_batch};
    use crate::table::{Axis, Mapping};

    fn slice(name: &str, eta: f64) -> Slices {
        let mut settings = FgdSettings { sampling: SamplingConfig::replicated(1 << 10), ..FgdSettings::default() };
        settings.reference.cells = 4;
        settings.reference.nodes = 4;
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
        let cache = SliceCache::open(dir.path());
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
        let path = cache.entry_path(&SliceCache::key(&slice("a", 1.5), 3));
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
    }

    #[test]
    fn a_cache_that_cannot_be_written_degrades_to_building_with_one_warning() {
        let dir = tempfile::tempdir().unwrap();
        // A file where the cache folder should be.
        let file = dir.path().join("not-a-folder");
        std::fs::write(&file, b"x").unwrap();
        let cache = SliceCache::open(&file);
        let built = integrate_batch(&[&slice("a", 1.5)], 3, &()).unwrap().remove(0);
        cache.put(&slice("a", 1.5), 3, &built);
        assert!(cache.get(&slice("a", 1.5), 3).is_none());
        assert_eq!(cache.warnings().len(), 1, "{:?}", cache.warnings());
        assert!(cache.warnings()[0].contains("building without it"), "{:?}", cache.warnings());
    }
}
