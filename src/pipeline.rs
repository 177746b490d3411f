//! A build: configuration in, table files and their manifest out.
//!
//! Each selected table is integrated, written in every configured format, hashed, and described
//! in the folder's `manifest.json`, which keeps the entries of files this build did not touch.
//!
//! Files are first written into a staging folder inside the locked output folder and moved into
//! place by one commit once every table of the build has been integrated and written
//! ([`crate::commit`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::commit::{Move, OutputFolder};
use crate::config::{Config, OutputConfig, TableKind};
use crate::error::{Error, Result};
use crate::formats::manifest::{
    AxisEntry, ChannelSumStorage, DropInEntry, ErrorEntry, FileEntry, Manifest, PackingEntry, SceneRecord, ShaderFile,
    write_manifest,
};
use crate::formats::slice_array::{ArraySlice, SliceArrayEntry, Slot};
use crate::formats::{self, FileFormat, Precision, SumRounding};
use crate::integrate::Progress;
use crate::loader::texture::SampledTable;
use crate::packing::{Filter, PackedFgd, Packing};
use crate::presets::Preset;
use crate::recipes::{Provenance, TableBuild, interpolation};
use crate::stats::InterpolationError;
use crate::table::Table;

/// What to build and where.
#[derive(Debug, Clone)]
pub struct BuildRequest {
    pub config: Config,
    /// Table names to build; `None` builds every table.
    pub only: Option<Vec<String>>,
    pub out: PathBuf,
    /// Also write each table's error map (`maps/<table>_error.exr` and `.png`).
    pub error_maps: bool,
}

pub use crate::commit::MAPS_FOLDER;

/// One file a build wrote.
#[derive(Debug, Clone)]
pub struct WrittenFile {
    pub path: PathBuf,
    pub entry: FileEntry,
}

/// Check table names against the tables tmlut knows; `None` selects every table `config` builds
/// unnamed ([`crate::recipes::TableRecipe::built_unnamed`]: the default set, and an engine's table
/// whose `build` is `always`).
pub fn resolve_tables(config: &Config, only: Option<&[String]>) -> Result<Vec<TableKind>> {
    let known = || TableKind::names().join(", ");
    let Some(only) = only else {
        return Ok(TableKind::ALL.iter().copied().filter(|&kind| config.recipe(kind).built_unnamed()).collect());
    };
    let mut selected = Vec::new();
    for name in only {
        let name = name.trim();
        match TableKind::named(name) {
            Some(kind) if !selected.contains(&kind) => selected.push(kind),
            Some(_) => {}
            None => {
                return Err(Error::invalid("--only", format!("unknown table `{name}`; known tables: {}", known())));
            }
        }
    }
    if selected.is_empty() {
        return Err(Error::invalid("--only", format!("no table named; known tables: {}", known())));
    }
    Ok(selected)
}

/// What a build wrote, one line per file with its size, build time and error estimates, then
/// indented lines for its interpolation errors and accuracy figures: the summary `tmlut build`
/// prints.
pub fn summary(written: &[WrittenFile]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    for file in written {
        let e = &file.entry;
        let reference = e.error.integration.reference.as_ref().map_or(String::new(), |r| {
            format!(", reference max |diff| {:.2e} ({} values)", r.difference.max, r.difference.count)
        });
        // A table integrated by quadrature has no replicates to spread.
        let spread = match e.samples_per_cell {
            0 => "quadrature".to_string(),
            _ => format!("replicate s.e. max {:.2e}", e.error.integration.replicate_standard_error.max),
        };
        let _ = writeln!(
            out,
            "{}  {} bytes  built in {:.2} s, {spread}{reference}",
            file.path.display(),
            e.bytes,
            e.wall_time_s,
        );
        for interpolation in &e.error.interpolation {
            let _ = writeln!(
                out,
                "    interpolated vs the exact integral, {}: RMS {:.2e}, 99th percentile {:.2e}, max {:.2e}",
                interpolation.domain, interpolation.error.rms, interpolation.p99, interpolation.error.max
            );
        }
        for accuracy in &e.accuracy {
            let what = accuracy.what.split(['(', ';']).next().unwrap_or_default().trim_end();
            let _ = writeln!(out, "    {what}: RMS {:.2e}, max {:.2e}", accuracy.error.rms, accuracy.error.max);
        }
    }
    out
}

/// Integrates one table.
pub type Integration<'a> = Box<dyn Fn(&dyn Progress) -> Result<TableBuild> + 'a>;

/// One table to integrate and how to write it.
pub struct Job<'a> {
    pub run: Integration<'a>,
    pub output: OutputConfig,
    /// Volume-texture packings written beside it (FGD only).
    pub packings: Vec<Packing>,
    /// The texture files of each packing (DDS, KTX2).
    pub packing_formats: Vec<FileFormat>,
    /// Fit the analytic TIR form to the table with this seed, record it in the table's entries and
    /// write its shader files (TIR with `fit = "best"` only; `docs/fit.md`).
    pub fit_seed: Option<u64>,
    /// For a texture array of slices: the slices it holds, recorded in its entries.
    pub slice_array: Option<SliceArrayEntry>,
    /// The preset whose engine file is written from this table's stored values, if it writes one.
    pub preset: Option<Arc<Preset>>,
}

/// Integrate, write and describe every requested table.
pub fn build(request: &BuildRequest, progress: &dyn Progress) -> Result<Vec<WrittenFile>> {
    request.config.validate()?;
    let tables = resolve_tables(&request.config, request.only.as_deref())?;
    build_tables(request, tables, None, progress)
}

/// Build a preset's tables into `out` as [`build`] builds tables, with the engine's own file
/// beside them in the same commit. Returns the tables' files and the engine files written.
pub fn build_preset(preset: Preset, out: &Path, progress: &dyn Progress) -> Result<(Vec<WrittenFile>, Vec<PathBuf>)> {
    let tables = preset.tables()?;
    let request = BuildRequest { config: preset.config.clone(), only: None, out: out.to_path_buf(), error_maps: false };
    let written = build_tables(&request, tables, Some(Arc::new(preset)), progress)?;
    let manifest = Manifest::read(&out.join(crate::formats::manifest::MANIFEST_FILE))?;
    let built: std::collections::BTreeSet<&str> = written.iter().map(|f| f.entry.table.as_str()).collect();
    let drop_ins = manifest.drop_ins.iter().filter(|(_, e)| built.contains(e.table.as_str()));
    let drop_ins = drop_ins.map(|(name, _)| out.join(name)).collect();
    Ok((written, drop_ins))
}

fn build_tables(
    request: &BuildRequest,
    tables: Vec<TableKind>,
    preset: Option<Arc<Preset>>,
    progress: &dyn Progress,
) -> Result<Vec<WrittenFile>> {
    let mut config = request.config.clone();
    if request.error_maps {
        // A map needs every node's replicate spread; FGD computes it for a subset by default.
        config.fgd.replicate_error_columns = usize::MAX;
    }
    let seed = config.seed;
    let jobs = tables
        .into_iter()
        .map(|kind| {
            let recipe = config.recipe(kind);
            let companions = recipe.companions();
            Job {
                run: Box::new(move |progress| recipe.build(seed, progress)),
                output: recipe.output().clone(),
                packings: companions.packings,
                packing_formats: companions.packing_formats,
                fit_seed: companions.fitted_form.then_some(seed),
                slice_array: None,
                preset: preset.clone(),
            }
        })
        .collect();
    write_jobs(&request.out, jobs, request.error_maps, None, progress)
}

/// Run every job, write its files into `out` and describe them in the folder's manifest, with
/// `scene` recorded there when given. The folder is locked for the whole build and the files move
/// into place by one commit (see [`crate::commit`]): a build that fails or dies leaves the
/// folder's earlier files and manifest, or a journal that the next build completes.
pub fn write_jobs(
    out: &Path,
    jobs: Vec<Job>,
    error_maps: bool,
    mut scene: Option<SceneRecord>,
    progress: &dyn Progress,
) -> Result<Vec<WrittenFile>> {
    // Every job of a preset's build carries the preset; a build without one leaves the folder
    // another build's, held to the default budgets again.
    let preset = jobs.iter().find_map(|job| job.preset.as_ref());
    let preset = preset.map(|p| crate::formats::manifest::PresetRecord::new(&p.name, p.built_in));
    let folder = OutputFolder::take(out, |message| progress.note(message))?;
    // Read the old manifest before integrating, so that a foreign or damaged one stops the build
    // before minutes of work rather than after.
    let mut manifest = Manifest::read_or_default(out)?;
    manifest.generator = generator_name();

    let mut staging = folder.staging()?;
    let staged_maps = staging.dir.join(MAPS_FOLDER);
    let mut staged = Vec::new();
    let mut moves = Vec::new();
    let mut rebuilt = std::collections::BTreeSet::new();
    let mut drop_ins = Vec::new();
    // Each table's files are written, hashed, read back for the interpolation check and (TIR)
    // fitted on a thread of their own while the next tables integrate: that work runs on one core
    // and would otherwise leave the integration's other core idle. Tables are still collected in
    // job order, so the staged files and the manifest do not depend on which finishes first.
    std::thread::scope(|scope| -> Result<()> {
        let mut collect = |files: StagedFiles| {
            // A fit whose table is not written (a scene's `tir = "fit"`) is recorded with the plan.
            if let (Some(fit), Some(scene)) = (files.unwritten_fit, scene.as_mut()) {
                scene.plan.tir_fit = Some(fit);
            }
            staged.extend(files.files);
            moves.extend(files.moves);
            drop_ins.extend(files.drop_ins);
        };
        let join = |writing: std::thread::ScopedJoinHandle<'_, Result<StagedFiles>>| {
            writing.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        };
        let mut writing = std::collections::VecDeque::new();
        for job in jobs {
            let Job { run, output, packings, packing_formats, fit_seed, slice_array, preset } = job;
            let build = run(progress)?;
            rebuilt.insert(build.table.name.clone());
            // A large table's files can take longer to write than the next small tables take to
            // integrate: waiting for them would idle a core, so a few writings stay in flight.
            if writing.len() == WRITINGS_IN_FLIGHT {
                collect(join(writing.pop_front().expect("a writing is in flight"))?);
            }
            let (dir, maps) = (&staging.dir, &staged_maps);
            let files =
                JobFiles { build, output, packings, packing_formats, fit_seed, slice_array, error_maps, preset };
            writing.push_back(scope.spawn(move || files.write(dir, maps)));
        }
        for previous in writing {
            collect(join(previous)?);
        }
        Ok(())
    })?;
    // The earlier entries of every table built again describe an earlier build: a file in a
    // format no longer asked for would stay listed beside the new ones and disagree with them.
    // They leave the manifest, and their files the folder, in the same commit.
    let mut removals = Vec::new();
    manifest.files.retain(|name, entry| {
        if !rebuilt.contains(&entry.table) {
            return true;
        }
        removals.push(name.clone());
        let shaders = entry.packing.iter().flat_map(|p| &p.shaders).chain(entry.fit.iter().flat_map(|f| &f.shaders));
        removals.extend(shaders.map(|shader| shader.file.clone()));
        false
    });
    // So do the engine files written from them: a build without the preset leaves none stale.
    manifest.drop_ins.retain(|name, entry| {
        let stays = !rebuilt.contains(&entry.table);
        if !stays {
            removals.push(name.clone());
            removals.extend(entry.shaders.iter().map(|shader| shader.file.clone()));
        }
        stays
    });
    // A scene shader is specialised to the tables it was written over: it leaves with them, and
    // `build --scene` writes it again over the new ones.
    removals.extend(manifest.scene_shader.take().into_iter().flat_map(|s| s.files).map(|f| f.file));
    // So is a bake of the scene's materials, which a scene build may have changed: it leaves too,
    // and `build --scene --bake` (or `tmlut bake`) makes it again.
    if scene.is_some() {
        removals.extend(crate::formats::manifest::take_bake(&mut manifest));
    }
    let mut written = Vec::new();
    for mut file in staged {
        file.entry.seal();
        let name = file_name(&file.path);
        moves.push(same_name(&file.path, None));
        manifest.files.insert(name.clone(), file.entry.clone());
        written.push(WrittenFile { path: out.join(&name), entry: file.entry });
    }
    for (name, entry) in drop_ins {
        let shaders = entry.shaders.iter().map(|shader| &shader.file);
        moves.extend(shaders.map(|file| Move { staged: file.clone(), destination: file.clone() }));
        moves.push(Move { staged: name.clone(), destination: name.clone() });
        manifest.drop_ins.insert(name, entry);
    }
    if scene.is_some() {
        manifest.scene = scene;
    }
    manifest.preset = preset;
    write_manifest(&manifest, &staging.dir)?;
    removals.retain(|file| !moves.iter().any(|m| &m.destination == file));
    removals.sort();
    removals.dedup();
    crate::commit::commit(&folder, &mut staging, moves, removals)?;
    Ok(written)
}

/// Tables whose files are being written while the next ones integrate: enough for the 4D FGD
/// table's files to finish under the small tables after it, few enough that the tables held in
/// memory stay bounded in a build of thousands of slices.
const WRITINGS_IN_FLIGHT: usize = 3;

/// One table as built and what its job asks to write of it ([`Job`]).
struct JobFiles {
    build: TableBuild,
    output: OutputConfig,
    packings: Vec<Packing>,
    packing_formats: Vec<FileFormat>,
    fit_seed: Option<u64>,
    slice_array: Option<SliceArrayEntry>,
    error_maps: bool,
    preset: Option<Arc<Preset>>,
}

/// What [`JobFiles::write`] staged.
struct StagedFiles {
    /// The files with their manifest entries, the table's own first.
    files: Vec<WrittenFile>,
    /// Files without a manifest entry of their own (shaders, listed in the table's entry; error maps).
    moves: Vec<Move>,
    /// The fitted form of a table none of whose own files is written (a scene's `tir = "fit"`).
    unwritten_fit: Option<crate::formats::manifest::FitEntry>,
    /// Engine files written from the table (a preset's), by name with their manifest entries.
    drop_ins: Vec<(String, DropInEntry)>,
}

impl JobFiles {
    /// Write every file of the table into `dir` (error maps into `maps`), in formats, fit,
    /// packings, maps order.
    fn write(self, dir: &Path, maps: &Path) -> Result<StagedFiles> {
        let (build, output) = (&self.build, &self.output);
        let mut staged =
            StagedFiles { files: Vec::new(), moves: Vec::new(), unwritten_fit: None, drop_ins: Vec::new() };
        for &format in &output.formats {
            let mut file = write_table_file(dir, build, format, output.precision)?;
            file.entry.slice_array = self.slice_array.clone();
            staged.files.push(file);
        }
        if let (Some(preset), Some(source)) = (&self.preset, staged.files.first()) {
            let stored = stored_values(&build.table, &build.provenance, output.precision)?;
            if let Some(files) = preset.drop_in_of(&stored, &file_name(&source.path))? {
                formats::write_bytes_atomically(&dir.join(&files.name), &files.bytes)?;
                for (name, bytes) in &files.shaders {
                    formats::write_bytes_atomically(&dir.join(name), bytes)?;
                }
                staged.drop_ins.push((files.name, files.entry));
            }
        }
        if let Some(seed) = self.fit_seed {
            let (fit, shaders) = crate::fit::forms::build::fit_for_build(&build.table, seed, dir)?;
            for file in &mut staged.files {
                file.entry.fit = Some(fit.clone());
            }
            if staged.files.is_empty() {
                staged.unwritten_fit = Some(fit);
            }
            staged.moves.extend(shaders.iter().map(|path| same_name(path, None)));
        }
        for &packing in &self.packings {
            let (textures, shaders) =
                write_packing_files(dir, build, packing, &self.packing_formats, output.precision)?;
            staged.files.extend(textures);
            staged.moves.extend(shaders.iter().map(|path| same_name(path, None)));
        }
        if self.error_maps {
            std::fs::create_dir_all(maps).map_err(|source| Error::io(maps, source))?;
            let written = crate::report::error_map::write_error_maps(maps, build)?;
            staged.moves.extend(written.iter().map(|path| same_name(path, Some(MAPS_FOLDER))));
        }
        Ok(staged)
    }
}

/// The move of a staged file to the same name in the output folder (under `subfolder`).
fn same_name(staged: &Path, subfolder: Option<&str>) -> Move {
    let name = file_name(staged);
    match subfolder {
        Some(folder) => Move { staged: format!("{folder}/{name}"), destination: format!("{folder}/{name}") },
        None => Move { staged: name.clone(), destination: name },
    }
}

pub fn generator_name() -> String {
    format!("tmlut {}", env!("CARGO_PKG_VERSION"))
}

fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// Write one table in one format and describe the file.
pub fn write_table_file(
    dir: &Path,
    build: &TableBuild,
    format: FileFormat,
    precision: Precision,
) -> Result<WrittenFile> {
    let file = format!("{}.{}", build.table.name, format.extension());
    write_table_file_named(&dir.join(file), &build.table, &build.provenance, format, precision)
}

/// Pack the FGD table of `build`, write its texture as `fgd_<packing>.dds` and/or `.ktx2` (one
/// file per format) and the `.hlsl` and `.wgsl` lookups into `dir`, and describe each texture
/// (the shader files are listed in its entry). Returns the textures and the paths of the shader
/// files.
pub fn write_packing_files(
    dir: &Path,
    build: &TableBuild,
    packing: Packing,
    formats: &[FileFormat],
    precision: Precision,
) -> Result<(Vec<WrittenFile>, Vec<PathBuf>)> {
    let packed = PackedFgd::pack(&build.table, packing, precision)?;
    let stem = packing.file_stem();
    let texture = packed.texture_table()?;
    // Read as its shader reads it: the lookup program on the texels as stored.
    let read_as = format!(
        "the lookup of {stem}.hlsl / .wgsl, statement by statement in f32, on the texels as stored (GPU emulator, exact filter weights)"
    );
    let channels = [build.table.channels[0].name.clone()];
    let interpolation: Vec<InterpolationError> = build
        .provenance
        .interpolation
        .iter()
        .map(|exact| {
            interpolation::compare(exact, &read_as, &channels, |p| {
                vec![packed.lookup([p[0] as f32, p[1] as f32, p[2] as f32, p[3] as f32], Filter::Exact) as f64]
            })
        })
        .collect();
    let mut shaders = Vec::new();
    let mut paths = Vec::new();
    for (language, text) in [("hlsl", packed.hlsl()), ("wgsl", packed.wgsl())] {
        let file = format!("{stem}.{language}");
        let path = dir.join(&file);
        formats::write_bytes_atomically(&path, text.as_bytes())?;
        shaders.push(ShaderFile::new(language, file, packed.program.name().to_string(), text.as_bytes()));
        paths.push(path);
    }
    let mut packing_entry = PackingEntry::new(
        packing.name(),
        packed.lossless,
        [packed.texture.width, packed.texture.height, packed.texture.depth],
        packed.axis_entries.clone(),
        packed.layout.clone(),
        packed.program.statements(),
        packed.fetches_per_lookup(),
    );
    packing_entry.shaders = shaders;
    let mut textures = Vec::new();
    for &format in formats {
        let mut written = write_table_file_named(
            &dir.join(format!("{stem}.{}", format.extension())),
            &texture,
            &build.provenance.of_derived_table(),
            format,
            precision,
        )?;
        // Its lookup is the shader's (`packing.lookup`), not one sample call.
        written.entry.binding = None;
        // The texels were rounded when packed; state what rounding did to the source values.
        written.entry.error.storage_rounding_max = storage_rounding(&build.table, precision);
        written.entry.error.interpolation = interpolation.clone();
        written.entry.packing = Some(packing_entry.clone());
        textures.push(written);
    }
    Ok((textures, paths))
}

/// The manifest record of slice `build` stored at `slot` of a texture array of `layer_extent`
/// texels per layer: its axes with their coordinates in the array, and its error as a file of its
/// own would state it. Its interpolation check reads its values as stored, filtered with clamp
/// addressing: what a read clamped to its nodes in the array gives, since its gutter repeats its
/// edge ([`formats::slice_array`]).
pub fn array_slice_record(
    build: &TableBuild,
    precision: Precision,
    slot: Slot,
    layer_extent: [usize; 2],
) -> Result<ArraySlice> {
    let table = &build.table;
    let stored = Table::new(
        &table.name,
        table.axes.clone(),
        table.channels.clone(),
        table.data.iter().map(|&v| precision.round(v)).collect(),
    )?;
    let channels = checked_channels(table);
    let texture = SampledTable::new(&stored)?;
    let read_as = "a slice of a texture array: its coordinates in f32 clamped to its nodes, linear filtering, texels as \
                   stored (GPU emulator, exact filter weights)";
    let interpolation = build
        .provenance
        .interpolation
        .iter()
        .map(|exact| {
            interpolation::compare(exact, read_as, &channels, |p| {
                (0..channels.len()).map(|c| texture.sample(c, p) as f64).collect()
            })
        })
        .collect();
    let axes = table
        .axes
        .iter()
        .enumerate()
        .map(|(d, axis)| {
            let mut entry = AxisEntry::new(axis, ["x", "y"][d]);
            entry.texture_coordinate =
                formats::slice_array::texture_coordinate_formula(axis, slot.origin[d] as u32, layer_extent[d]);
            entry
        })
        .collect();
    let stats = table.stats();
    let mut error = ErrorEntry::new(build.provenance.error.clone(), storage_rounding(table, precision));
    error.interpolation = interpolation;
    let (layer, origin) = (slot.layer as u32, slot.origin.map(|o| o as u32));
    let mut slice =
        ArraySlice::new(&table.name, layer, origin, axes, table.channels.clone(), [stats.min, stats.max], error);
    slice.accuracy = build.provenance.accuracy.clone();
    Ok(slice)
}

/// Write one table in one format to `path` and describe the file, with `provenance` saying how
/// the table was made.
fn write_table_file_named(
    path: &Path,
    table: &Table,
    provenance: &Provenance,
    format: FileFormat,
    precision: Precision,
) -> Result<WrittenFile> {
    let path = path.to_path_buf();
    // `.bin` has no precision field: it is f32 by definition.
    let precision = if format == FileFormat::Bin { Precision::F32 } else { precision };
    // Channels that add up to an albedo are rounded together; the writers' own rounding then
    // leaves those values as they are (each is already a value of the precision).
    let stored =
        provenance.metadata.channel_sum.map(|rounding| stored_with_sum(table, rounding, precision)).transpose()?;
    formats::write_table(&path, stored.as_ref().unwrap_or(table), format, precision)?;
    let bytes = formats::read_bytes(&path)?;
    let stats = table.stats();
    let axes = table.axes.iter().zip(stored_along(table, format)).map(|(a, s)| AxisEntry::new(a, s)).collect();
    let mut entry = FileEntry::new(&table.name, format, precision, axes, table.channels.clone(), &bytes);
    entry.integrand = provenance.metadata.integrand.clone();
    entry.masking = provenance.metadata.masking.map(|m| m.name().to_string());
    entry.notes = provenance.metadata.notes.clone();
    entry.method = provenance.sampling.method.clone();
    entry.sampler = provenance.sampling.sampler.clone();
    entry.samples_per_cell = provenance.sampling.samples_per_cell;
    entry.seed = provenance.sampling.seed;
    entry.wall_time_s = provenance.wall_time_s;
    entry.value_range = [stats.min, stats.max];
    entry.nan_count = stats.nan_count + stats.infinite_count;
    let storage_rounding_max = match &stored {
        Some(stored) => max_difference(&table.data, &stored.data),
        None => storage_rounding(table, precision),
    };
    entry.error = ErrorEntry::new(provenance.error.clone(), storage_rounding_max);
    entry.error.storage_channel_sum =
        provenance.metadata.channel_sum.zip(stored.as_ref()).map(|(r, s)| channel_sum_storage(table, s, r));
    entry.fresnel_basis = provenance.metadata.fresnel_basis.clone();
    entry.accuracy = provenance.accuracy.clone();
    entry.binding = formats::binding(&table.axes, table.channel_count(), precision, format);
    entry.error.interpolation = interpolation_errors(&path, &entry, &provenance.interpolation)?;
    Ok(WrittenFile { path, entry })
}

/// The file at `path`, read back as `entry` describes it and sampled as a renderer samples it, at
/// the random points of every domain of an interpolation check (`exact`).
fn interpolation_errors(
    path: &Path,
    entry: &FileEntry,
    exact: &[interpolation::ExactValues],
) -> Result<Vec<InterpolationError>> {
    if exact.is_empty() {
        return Ok(Vec::new());
    }
    let table = crate::loader::load_verified(path, entry)?;
    let channels = checked_channels(&table);
    let compare_all = |read_as: &str, read: &dyn Fn(&[f64]) -> Vec<f64>| {
        exact.iter().map(|exact| interpolation::compare(exact, read_as, &channels, read)).collect()
    };
    if entry.format == FileFormat::Bin || table.dimension() > 3 {
        let how = if entry.format == FileFormat::Bin {
            "the .bin table interpolated multilinearly in f64 (Table::interpolate), as the transfer-matrix reference code reads it"
        } else {
            "the 4D table interpolated multilinearly in f64 (Table::interpolate): no GPU texture has four axes"
        };
        return Ok(compare_all(how, &|p| table.interpolate(p)));
    }
    let texture = SampledTable::new(&table)?;
    let read_as = "a GPU texture: the manifest's texture coordinates in f32, linear filtering with clamp addressing, texels as stored (GPU emulator, exact filter weights)";
    Ok(compare_all(read_as, &|p| (0..channels.len()).map(|c| texture.sample(c, p) as f64).collect()))
}

/// The channels of `table` an interpolation check compares: all but a slice's padding channel,
/// which holds no value.
fn checked_channels(table: &Table) -> Vec<String> {
    table
        .channels
        .iter()
        .map(|c| c.name.clone())
        .filter(|name| name != crate::recipes::slices::PADDING_CHANNEL)
        .collect()
}

/// Which dimension of the file each axis runs along.
fn stored_along(table: &Table, format: FileFormat) -> Vec<String> {
    (0..table.dimension())
        .map(|d| match (format, d) {
            (FileFormat::Bin, d) => format!("axis {d}"),
            (FileFormat::Dds | FileFormat::Ktx2, 2) if table.axes[2].name == formats::LAYER_AXIS => "layer".into(),
            (FileFormat::Dds | FileFormat::Ktx2, d) => ["x", "y", "z"][d].to_string(),
            (FileFormat::Exr, d) if table.dimension() <= 2 => ["x", "y"][d].to_string(),
            (FileFormat::Exr, 0) => "x within a tile".into(),
            (FileFormat::Exr, 1) => "y within a tile".into(),
            (FileFormat::Exr, d) => format!("tile number (digit {} of the slice index, fastest first)", d - 2),
        })
        .collect()
}

/// The values the files of `table` hold at `precision`: rounded as its texture files round them.
pub fn stored_values(table: &Table, provenance: &Provenance, precision: Precision) -> Result<Table> {
    match provenance.metadata.channel_sum {
        Some(rounding) => stored_with_sum(table, rounding, precision),
        None => Table::new(
            &table.name,
            table.axes.clone(),
            table.channels.clone(),
            table.data.iter().map(|&v| precision.round(v)).collect(),
        ),
    }
}

/// `table` with each texel's channels rounded to `precision` by `rounding`.
fn stored_with_sum(table: &Table, rounding: SumRounding, precision: Precision) -> Result<Table> {
    let channels = table.channel_count();
    let data = table.data.chunks(channels).flat_map(|texel| formats::round_texel(rounding, texel, precision)).collect();
    Table::new(&table.name, table.axes.clone(), table.channels.clone(), data)
}

fn max_difference(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).abs()).fold(0.0, f64::max)
}

/// What storing `table` as `stored` did to the sum of each texel's channels.
fn channel_sum_storage(table: &Table, stored: &Table, rounding: SumRounding) -> ChannelSumStorage {
    let channels = table.channel_count();
    let mut record = ChannelSumStorage::new(rounding);
    for (integrated, kept) in table.data.chunks(channels).zip(stored.data.chunks(channels)) {
        let sum = |values: &[f32]| values.iter().map(|&v| v as f64).sum::<f64>();
        let (integrated, kept) = (sum(integrated), sum(kept));
        record.max_sum = record.max_sum.max(kept);
        if kept > 1.0 {
            record.texels_above_one += 1;
            record.max_above_one = record.max_above_one.max(kept - 1.0);
        }
        if kept > integrated {
            record.texels_above_integral += 1;
            record.max_above_integral = record.max_above_integral.max(kept - integrated);
        }
    }
    record
}

/// The largest change of a value by storing it in `precision`.
pub fn storage_rounding(table: &Table, precision: Precision) -> f64 {
    table.data.iter().map(|&v| (precision.round(v) as f64 - v as f64).abs()).fold(0.0, f64::max)
}

pub use crate::loader::sha256_hex;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_tables_are_named_with_the_known_ones() {
        let config = Config::default();
        let err = resolve_tables(&config, Some(&["karis".into(), "fdg".into()])).unwrap_err().to_string();
        assert!(err.contains("unknown table `fdg`") && err.contains("karis"), "{err}");
        assert_eq!(resolve_tables(&config, Some(&["karis".into(), "karis".into()])).unwrap(), vec![TableKind::Karis]);
    }

    #[test]
    fn sha256_of_a_known_string() {
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }
}
