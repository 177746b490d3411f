//! Baking a scene's materials into the folder built for it (`tmlut bake`, `tmlut build --scene
//! --bake`): every material's model evaluated at its nodes of `mu` ([`crate::bake`]), the rows of
//! all of them written as one texture array with its manifest entry (`FileEntry::baked`), each
//! material's error measured on the file as written, read as a GPU filters it, against its model
//! with exact integrals.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use super::Scene;
use super::shader_files::shader_materials;
use crate::bake::array::{arrange, array_entry, baked_table, material_entry};
use crate::bake::errors::{baked_errors, error_views, errors_across};
use crate::bake::varied::{MAX_BLOCKS, MAX_PARAMETER_NODES, MAX_VARIED, values_in_words};
use crate::bake::{
    BakeConfig, BakeLayout, BakeSettings, BakeSource, BakedMaterial, HELD_TO_TOLERANCES, MaterialFamily,
    TABLES_REFERENCE, TABLES_SOURCE, bake_materials,
};
use crate::commit::{Move, OutputFolder};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::exact::ExactTables;
use crate::filter::Filter;
use crate::formats::FileFormat;
use crate::formats::baked::{BakedErrors, BakedMaterialEntry, sample_array};
use crate::formats::manifest::{LeftOutRecord, MANIFEST_FILE, Manifest, SceneShaderFile, write_manifest};
use crate::integrate::Progress;
use crate::loader::LutFolder;
use crate::loader::shader::{BAKED_DESCRIPTION_SUFFIX, BakedShaderDescription};
use crate::model::folder::{FgdSource, LibraryTables};
use crate::model::{Material, Tables};
use crate::pipeline::{WrittenFile, write_table_file};
use crate::recipes::driver::{Metadata, Provenance, SamplingRecord, TableBuild};
use crate::stats::{ErrorRecord, ErrorSummary};

/// The name of the baked array's table (its files are `baked.dds`, `baked.ktx2`, ...).
pub const BAKED_TABLE: &str = "baked";

/// Views per node interval a material's error is measured at when it is baked: the nodes and the
/// midpoints between them, where linear interpolation errs most.
pub const ERROR_VIEWS_PER_INTERVAL: usize = 2;

/// The filter the errors are read through: a GPU's, with 8-bit filter weights.
const GPU_FILTER: Filter = Filter::QuantisedWeights { bits: 8 };

/// Bake the materials of `scene` into `luts`, the folder built for it, and commit the array's
/// files with the folder's manifest (replacing an earlier bake). Refused where the folder was
/// built for another scene, and where a material's model returns a value that is not finite.
pub fn write_baked(
    scene: &Scene,
    luts: &Path,
    config: &Config,
    request: &BakeConfig,
    progress: &dyn Progress,
) -> Result<WrittenBake> {
    request.validate()?;
    let folder_lock = OutputFolder::take(luts, |holder| progress.note(&format!("waiting for {holder}")))?;
    let folder = LutFolder::open(luts)?;
    check_scene(&folder, scene)?;
    let (kept, mut left_out) = bakeable(scene)?;
    let materials: Vec<MaterialFamily> = kept.iter().map(|&i| scene.materials[i].family()).collect();
    let named: Vec<(&str, &MaterialFamily)> =
        kept.iter().zip(&materials).map(|(&i, material)| (scene.materials[i].name.as_str(), material)).collect();
    let exact = ExactTables::new(config, request.exact_nodes)?;
    // Baked from the folder's tables, a material is measured against its source: the error the
    // bake adds to what it tabulates (`tmlut furnace` measures the baked file against the model
    // with exact integrals, errors.baked).
    let library = match request.source {
        BakeSource::Exact => None,
        BakeSource::Tables => {
            let shader_materials = shader_materials(scene)?;
            Some(LibraryTables::open(&folder, FgdSource::Packing, shader_materials.iter().map(|m| m.reads()))?)
        }
    };
    let source_of = |scene_index: usize| -> &(dyn Tables + Sync) {
        match &library {
            Some(library) => library.of(scene_index),
            None => &exact,
        }
    };
    let started = Instant::now();
    progress.start("bake", materials.len() as u64);
    let baked = bake_materials(&named, |i| source_of(kept[i]), &request.settings(), progress)?;
    if let Some(library) = &library {
        for (&index, (name, _)) in kept.iter().zip(&named) {
            let (misses, _) = library.of(index).take_counts();
            if misses.count > 0 {
                return Err(Error::invalid(
                    format!("material `{name}`"),
                    format!(
                        "{} lookup(s) the folder {} holds no table for, first: {}; build the scene's tables into it \
                         (tmlut build --scene) or bake from exact integrals",
                        misses.count,
                        luts.display(),
                        misses.first.unwrap_or_default()
                    ),
                ));
            }
        }
    }
    progress.finish();
    let (baked, materials, kept) =
        hold_varied(scene, baked, materials, kept, &source_of, &request.settings(), &mut left_out)?;
    let wall_time_s = started.elapsed().as_secs_f64();
    let arrangement = arrange(&baked.iter().map(BakedMaterial::rows).collect::<Vec<_>>())?;
    let table = baked_table(BAKED_TABLE, &baked, &arrangement)?;
    let build = TableBuild { table, provenance: provenance(request, &exact, wall_time_s) };

    let mut manifest = Manifest::read(&luts.join(MANIFEST_FILE))?;
    let mut staging = folder_lock.staging()?;
    let mut written = Vec::new();
    for &format in &request.formats {
        let mut file = write_table_file(&staging.dir, &build, format, request.precision)?;
        let stored = crate::loader::load_verified(&file.path, &file.entry)?;
        let references: Vec<&(dyn Tables + Sync)> = kept.iter().map(|&i| source_of(i)).collect();
        let against = reference_words(request, &exact);
        let entries = measured_entries(&baked, &materials, &arrangement.places, &stored, &references, &against)?;
        let source = source_words(request, &exact);
        let mut entry = array_entry(&scene.name, &source, request.tolerance, baked[0].nodes(), &arrangement, entries);
        entry.left_out = left_out.clone();
        file.entry.baked = Some(entry);
        written.push(file);
    }
    let (shader_files, shader) = write_baked_shader(&scene.name, &written, request.precision, &staging.dir)?;
    for file in &mut written {
        if let Some(baked) = file.entry.baked.as_mut() {
            baked.shader_files = shader_files.clone();
        }
        file.entry.seal();
    }
    // An earlier bake leaves with its files: the new array replaces it whole.
    let mut removals = crate::formats::manifest::take_bake(&mut manifest);
    let mut moves = Vec::new();
    for file in &written {
        let name = file_name(&file.path);
        manifest.files.insert(name.clone(), file.entry.clone());
        moves.push(Move { staged: name.clone(), destination: name });
    }
    moves.extend(shader_files.iter().map(|f| Move { staged: f.file.clone(), destination: f.file.clone() }));
    removals.retain(|file| !moves.iter().any(|m| &m.destination == file));
    write_manifest(&manifest, &staging.dir)?;
    crate::commit::commit(&folder_lock, &mut staging, moves, removals)?;
    let files = written
        .into_iter()
        .map(|file| WrittenFile { path: luts.join(file_name(&file.path)), entry: file.entry })
        .collect();
    let description_file = shader_files.iter().find(|f| f.file.ends_with(BAKED_DESCRIPTION_SUFFIX));
    let shader = description_file.zip(shader).map(|(file, description)| (luts.join(&file.file), description));
    Ok(WrittenBake { files, shader })
}

/// What a bake committed: the array's files with their manifest entries, and the baked shader's
/// description with the path it was written to (none where only EXR was written), so that a
/// caller reports what it wrote without reading it back.
pub struct WrittenBake {
    pub files: Vec<WrittenFile>,
    pub shader: Option<(PathBuf, BakedShaderDescription)>,
}

/// The baked shader over the array as `written` (bound from its first texture file, DDS before
/// KTX2), written into `dir` as `<scene>.baked.wgsl`, `.baked.hlsl` and `.baked.shader.json`;
/// none where only EXR was written, which a GPU does not bind. Returns the files and the
/// description written.
fn write_baked_shader(
    scene: &str,
    written: &[WrittenFile],
    precision: crate::formats::Precision,
    dir: &Path,
) -> Result<(Vec<SceneShaderFile>, Option<BakedShaderDescription>)> {
    let bound = FileFormat::TEXTURES.iter().find_map(|&format| written.iter().find(|f| f.entry.format == format));
    let Some(array) = bound else { return Ok((Vec::new(), None)) };
    let entry = array.entry.baked.as_ref().expect("every written file has its baked entry");
    let array_file = file_name(&array.path);
    let shader = crate::shader::baked::baked_shader(entry, &array_file, precision)?;
    let stem = crate::shader::scene::identifier(scene);
    let varied = entry.materials.iter().filter(|m| !m.varied.is_empty()).count();
    let functions = match varied {
        0 => format!("tm_<material>(mu) for each of its {} materials", entry.materials.len()),
        _ => format!(
            "tm_<material>(mu), or (mu, varied...) for the {varied} whose textures vary parameters, for each of its {} \
             materials",
            entry.materials.len()
        ),
    };
    let mut files: Vec<(String, String, Vec<u8>)> = shader
        .texts
        .iter()
        .map(|(lang, text)| {
            let what = format!(
                "{}: the baked materials of {array_file} read by one filtered sample per row, {} and \
                 {functions}; bound as {stem}{BAKED_DESCRIPTION_SUFFIX} states",
                lang.extension().to_uppercase(),
                shader.description.function
            );
            (format!("{stem}.baked.{}", lang.extension()), what, text.clone().into_bytes())
        })
        .collect();
    let mut json = serde_json::to_string_pretty(&shader.description).expect("a shader description is plain data");
    json.push('\n');
    files.push((
        format!("{stem}{BAKED_DESCRIPTION_SUFFIX}"),
        "what the baked shader binds (the array and a linear sampler) and each material's function, index and cost"
            .into(),
        json.into_bytes(),
    ));
    let files = files
        .into_iter()
        .map(|(file, what, bytes)| {
            crate::formats::write_bytes_atomically(&dir.join(&file), &bytes)?;
            Ok(SceneShaderFile::new(file, what, &bytes))
        })
        .collect::<Result<_>>()?;
    Ok((files, Some(shader.description)))
}

/// The indices of the scene's materials a bake holds, and those it leaves out with why: a
/// material whose textures vary more parameters than a baked material may ([`MAX_VARIED`]), named
/// with its parameters and the size its table would take at the fewest nodes. Refused where no
/// material is left.
fn bakeable(scene: &Scene) -> Result<(Vec<usize>, Vec<LeftOutRecord>)> {
    let (mut kept, mut left_out) = (Vec::new(), Vec::new());
    for (index, material) in scene.materials.iter().enumerate() {
        let varied = material.varied_parameters();
        if varied.len() <= MAX_VARIED {
            kept.push(index);
            continue;
        }
        // The lobe count is the stack's: any answer to the lookups gives it.
        let lobes =
            Material::new(material.model, material.stack()?).evaluate(1.0, &|_: &crate::model::Lookup| 0.5).lobes.len();
        let rows = BakeLayout { lobes }.texels_per_node();
        let blocks = 1usize << varied.len();
        left_out.push(LeftOutRecord::new(
            format!("material `{}`", material.name),
            format!(
                "its textures vary {} parameters ({}): baked at the fewest nodes, the ends of each range, its table \
                 would take {blocks} blocks of {rows} rows ({} rows, {} texture reads per call; up to {MAX_BLOCKS} \
                 blocks where the ranges need more nodes), and a baked material varies at most {MAX_VARIED}; its \
                 scene shader evaluates it",
                varied.len(),
                varied.join(", "),
                blocks * rows,
                blocks * rows,
            ),
        ));
    }
    if kept.is_empty() {
        let reasons: Vec<String> = left_out.iter().map(|l| format!("{} ({})", l.what, l.reason)).collect();
        return Err(Error::invalid(
            format!("scene `{}`", scene.name),
            format!("has no material a bake can hold: {}", reasons.join("; ")),
        ));
    }
    Ok((kept, left_out))
}

/// The baked materials, their models and their indices in the scene without those whose textures
/// vary parameters and which, baked, err by more than a baked material is held to
/// (`BakeSettings::held_to`; measured as the file's errors are, against the source material `i` was
/// baked from, `source_of(kept[i])`, on the texels before they are stored): left out, with the
/// parameters, the size their table took and the error, since at the most nodes a material may take
/// its table cannot hold them within the limit (a kink of the model that moves with the parameter,
/// such as a lobe's roughness reaching its clamp, errs in proportion to the node spacing). Refused
/// where no material is left.
#[allow(clippy::too_many_arguments)]
fn hold_varied<'a, 't>(
    scene: &Scene,
    baked: Vec<BakedMaterial>,
    materials: Vec<MaterialFamily<'a>>,
    kept: Vec<usize>,
    source_of: &(dyn Fn(usize) -> &'t (dyn Tables + Sync) + Sync),
    settings: &BakeSettings,
    left_out: &mut Vec<LeftOutRecord>,
) -> Result<(Vec<BakedMaterial>, Vec<MaterialFamily<'a>>, Vec<usize>)> {
    let errors: Vec<Option<BakedErrors>> = baked
        .par_iter()
        .zip(&materials)
        .zip(&kept)
        .map(|((b, family), &index)| match b.axes.is_empty() {
            true => Ok(None),
            false => baked_errors(b, family, source_of(index), ERROR_VIEWS_PER_INTERVAL, GPU_FILTER).map(Some),
        })
        .collect::<Result<_>>()?;
    let (mut held, mut held_materials, mut held_indices) = (Vec::new(), Vec::new(), Vec::new());
    for (((b, family), index), error) in baked.into_iter().zip(materials).zip(kept).zip(errors) {
        match error {
            Some(error) if error.max() > settings.held_to() => left_out.push(too_coarse(&b, &family, &error, settings)),
            _ => {
                held.push(b);
                held_materials.push(family);
                held_indices.push(index);
            }
        }
    }
    if held.is_empty() {
        let reasons: Vec<String> = left_out.iter().map(|l| format!("{} ({})", l.what, l.reason)).collect();
        return Err(Error::invalid(
            format!("scene `{}`", scene.name),
            format!("has no material a bake can hold: {}", reasons.join("; ")),
        ));
    }
    Ok((held, held_materials, held_indices))
}

/// Why the varied material `baked` is left out: its parameters, its size, and `error`, beyond
/// what `settings` hold a baked material to.
fn too_coarse(
    baked: &BakedMaterial,
    family: &MaterialFamily,
    error: &BakedErrors,
    settings: &BakeSettings,
) -> LeftOutRecord {
    let worst = error.worst();
    let parameters: Vec<String> =
        family.parameters().iter().map(|p| format!("{} in [{}, {}]", p.name, p.range[0], p.range[1])).collect();
    let nodes: Vec<String> = baked.axes.iter().map(|a| a.nodes.to_string()).collect();
    LeftOutRecord::new(
        format!("material `{}`", baked.name),
        format!(
            "its textures vary {}: baked at {} nodes ({} blocks of {} rows: {} rows, {} texture reads per call; a \
             baked material takes at most {MAX_PARAMETER_NODES} nodes a parameter and {MAX_BLOCKS} blocks), it errs \
             by {:.1e} ({} at mu {:.4}, {}), more than the {:.1e} a baked material is held to ({HELD_TO_TOLERANCES} times the bake \
             tolerance); its scene shader evaluates it",
            parameters.join(", "),
            nodes.join(" x "),
            baked.blocks(),
            baked.block_rows(),
            baked.rows(),
            baked.block_rows() << baked.axes.len(),
            worst.max,
            worst.value,
            worst.at_mu,
            values_in_words(family.parameters(), &worst.at_varied),
            settings.held_to()
        ),
    )
}

/// Refuse a folder built for another scene (or for none): its tables, and the plan its manifest
/// records, are not this scene's.
fn check_scene(folder: &LutFolder, scene: &Scene) -> Result<()> {
    match &folder.manifest().scene {
        Some(record) if record.name == scene.name => Ok(()),
        Some(record) => Err(Error::invalid(
            folder.dir().display().to_string(),
            format!(
                "was built for scene `{}`, not `{}`; bake the folder built for this scene (tmlut build --scene)",
                record.name, scene.name
            ),
        )),
        None => Err(Error::invalid(
            folder.dir().display().to_string(),
            format!("was built for no scene; build scene `{}` into it first (tmlut build --scene)", scene.name),
        )),
    }
}

/// Each material's entry, its error measured on `stored` (the array as written, read back) read
/// through a GPU's filter, against its model evaluated with `references[i]` (what `against`
/// says), at views along `mu` and at the nodes of its varied parameters and midway between them.
fn measured_entries(
    baked: &[BakedMaterial],
    materials: &[MaterialFamily],
    places: &[(usize, usize)],
    stored: &crate::table::Table,
    references: &[&(dyn Tables + Sync)],
    against: &str,
) -> Result<Vec<BakedMaterialEntry>> {
    let where_read = "the array read as stored through a linear filter with 8-bit weights; lobe roughness, cosine and \
                      GD weighted by the lobe's largest energy";
    let against_varied = format!(
        "{against}, at the nodes and midway between them (along mu, and across each varied parameter); {where_read}"
    );
    let against_nothing_varied = format!("{against}, at the nodes and midway between them; {where_read}");
    baked
        .par_iter()
        .zip(materials)
        .zip(places)
        .zip(references)
        .map(|(((material, model), &place), &reference)| {
            let against = if material.axes.is_empty() { &against_nothing_varied } else { &against_varied };
            // Placed first: the error is read through the entry's own segments and rows.
            let mut entry = material_entry(material, place, BakedErrors::none(against.as_str()));
            let views = error_views(&material.placement, ERROR_VIEWS_PER_INTERVAL);
            let error = errors_across(&material.layout, &material.axes, &views, model, reference, |mu, varied| {
                sample_array(stored, &entry, mu, varied, GPU_FILTER)
            })?;
            entry.error = BakedErrors { against: against.clone(), ..error };
            Ok(entry)
        })
        .collect()
}

/// What a bake's errors are measured against, in words: the model with exact integrals, or, baked
/// from the folder's tables, the model with those tables.
fn reference_words(request: &BakeConfig, exact: &ExactTables) -> String {
    match request.source {
        BakeSource::Exact => {
            format!("the model with exact integrals ({} Gauss–Legendre nodes per panel)", exact.nodes())
        }
        BakeSource::Tables => TABLES_REFERENCE.into(),
    }
}

/// The integral source in words, for the manifest.
fn source_words(request: &BakeConfig, exact: &ExactTables) -> String {
    match request.source {
        BakeSource::Exact => format!("exact integrals ({} Gauss–Legendre nodes per panel)", exact.nodes()),
        BakeSource::Tables => TABLES_SOURCE.into(),
    }
}

/// How the array was made, for its manifest entry.
fn provenance(request: &BakeConfig, exact: &ExactTables, wall_time_s: f64) -> Provenance {
    Provenance {
        metadata: Metadata {
            integrand: "each material's transfer-matrix result TmResult(mu) (albedo, top albedo, and per lobe energy, \
                        GGX roughness, mean-direction cosine and GD) at its nodes of mu: baked.materials[]"
                .into(),
            masking: None,
            notes: vec![
                "An array of RGBA rows: a material's value i is channel i % 4 of its row first_row + i / 4 of its layer; \
                 baked.materials[].values names them."
                    .into(),
                "Read it as baked.lookup states; each material's error against its model: baked.materials[].error.".into(),
            ],
            sampler: "none: the model evaluated at each node".into(),
            fresnel_basis: None,
            channel_sum: None,
        },
        sampling: SamplingRecord {
            method: format!("the transfer-matrix model evaluated from {}", source_words(request, exact)),
            sampler: "none: no random points".into(),
            samples_per_cell: 0,
            replicates: 0,
            seed: 0,
        },
        error: ErrorRecord::new(ErrorSummary::new(0, 0.0, 0.0), None),
        wall_time_s,
        accuracy: Vec::new(),
        standard_error: None,
        interpolation: Vec::new(),
    }
}

/// The file name of `path`.
fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}
