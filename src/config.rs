//! The build configuration: a TOML file with one section per table. Every key has a default, so
//! an empty file (or none) builds the default LUT set; an unknown key is an error that names it.
//! [`Config`] itself, a field per table, is declared by the table registry (`crate::recipes`).
//!
//! ```toml
//! seed = 2021
//!
//! [karis]
//! mu_count = 512
//! roughness_count = 512
//! roughness_axis = "perceptual"   # or "alpha"
//! orientation = "smooth-first"    # row 0 = roughness 0; or "bottom-up-image"
//! masking = "schlick-smith"       # or "smith-separable", "smith-height-correlated"
//! [karis.sampling]
//! samples = 1024                  # per cell, a power of two
//! replicates = 4                  # independent scrambles, for error bars
//! [karis.reference]
//! cells = 64                      # nodes checked against the exact integral (0: none)
//! nodes = 8
//! [karis.output]
//! formats = ["dds", "exr"]
//! precision = "f16"               # or "f32"
//! ```
//!
//! and a `[bake]` section for `tmlut bake` ([`crate::bake::config`]).

use std::path::Path;

use crate::error::{Error, Result};
pub use crate::recipes::settings::{
    MAX_NODES_PER_AXIS, OutputConfig, ReferenceConfig, SamplingConfig, check_count, check_unit_range,
};
pub use crate::recipes::{Config, DEFAULT_SEED, TableRecipe, TableSettings};
pub use crate::table::TableKind;

impl Config {
    /// Parse a TOML configuration; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self> {
        // Parsed to a TOML table first and deserialised from it: that path refuses an array longer
        // than its field (`alpha_range = [0.1, 0.5, 0.9]`), which deserialising from the text
        // directly accepts, dropping the third value.
        let file = toml::Value::Table(text.parse().map_err(|e| Error::invalid(origin, clean_toml_error(&e)))?);
        // Every key is optional, in a section given in part too (`[gd.sampling] replicates = 8`):
        // the file is laid over the table's own defaults, key by key, before it is read.
        let defaults = toml::Value::try_from(Config::default()).expect("the defaults are plain data");
        let laid = overlay(defaults.clone(), file.clone(), "").map_err(|reason| Error::invalid(origin, reason))?;
        let config: Config = laid.try_into().map_err(|e| {
            Error::invalid(origin, refused_value(&defaults, &file).unwrap_or_else(|| clean_toml_error(&e)))
        })?;
        config.validate()?;
        Ok(config)
    }

    pub fn from_file(path: &Path) -> Result<Self> {
        let text = crate::formats::read_text_at_most(path, crate::formats::MAX_TEXT_INPUT_BYTES, "a configuration")?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// The configuration of `path`, or the built-in defaults without one.
    pub fn load(path: Option<&Path>) -> Result<Self> {
        match path {
            Some(path) => Self::from_file(path),
            None => Ok(Config::default()),
        }
    }

    /// Every table's settings, in build order.
    pub fn recipes(&self) -> impl Iterator<Item = &dyn TableRecipe> + '_ {
        TableKind::ALL.iter().map(|&kind| self.recipe(kind))
    }

    /// The settings of the table called `name`.
    pub fn recipe_named(&self, name: &str) -> Option<&dyn TableRecipe> {
        TableKind::named(name).map(|kind| self.recipe(kind))
    }

    /// Skip every table's reference and interpolation checks (for timing builds on their own).
    pub fn disable_reference_checks(&mut self) {
        for &kind in TableKind::ALL {
            self.recipe_mut(kind).reference_mut().cells = 0;
        }
        self.disable_interpolation_checks();
    }

    /// Skip every table's interpolation check (`recipes::interpolation`).
    pub fn disable_interpolation_checks(&mut self) {
        for &kind in TableKind::ALL {
            self.recipe_mut(kind).interpolation_mut().points = 0;
        }
    }

    /// Clear what decides only how every table is written ([`TableRecipe::clear_written_settings`]).
    pub fn clear_written_settings(&mut self) {
        for &kind in TableKind::ALL {
            self.recipe_mut(kind).clear_written_settings();
        }
    }

    /// Use `method` for every table.
    pub fn set_method(&mut self, method: crate::integrate::Method) {
        for &kind in TableKind::ALL {
            *self.recipe_mut(kind).method_mut() = method;
        }
    }

    pub fn validate(&self) -> Result<()> {
        for recipe in self.recipes() {
            recipe.validate()?;
        }
        for recipe in self.recipes() {
            crate::recipes::check_demand(recipe)?;
        }
        // A table with no format writes nothing, unless it has other outputs: FGD's packed
        // textures, TIR's fitted form.
        for recipe in self.recipes() {
            if recipe.output().formats.is_empty() && !recipe.companions().writes_files() {
                return Err(Error::invalid(
                    format!("{}.output.formats", recipe.name()),
                    "[] writes no file of this table; give at least one format, or leave the table out of the \
                     build with --only",
                ));
            }
        }
        self.bake.validate()
    }
}

/// toml's messages span several lines with a source excerpt; keep them, but on one line each.
pub(crate) fn clean_toml_error(error: &toml::de::Error) -> String {
    error.to_string().lines().map(str::trim_end).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" | ")
}

/// `over` laid on `under`: tables merge key by key, anything else (a value, an array) replaces.
/// A key of `over` that the table under it lacks is refused, naming it (`path` is where `over`
/// sits) and the keys allowed there. The defaults hold every key a section accepts (no setting is
/// optional or a map of free keys), so this is the check of unknown keys of every table: serde's
/// `deny_unknown_fields` names neither the allowed keys nor the full path of a key in a section
/// whose settings flatten in a part of their own (the keys every table shares, the `mu` and
/// `alpha` axes, a split-sum table's own keys).
fn overlay(under: toml::Value, over: toml::Value, path: &str) -> std::result::Result<toml::Value, String> {
    match (under, over) {
        (toml::Value::Table(mut under), toml::Value::Table(over)) => {
            for (key, value) in over {
                let key_path = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
                let Some(below) = under.remove(&key) else {
                    let allowed: Vec<&str> = under.keys().map(String::as_str).collect();
                    let place = if path.is_empty() { "at the top level".to_string() } else { format!("in [{path}]") };
                    return Err(format!("unknown key `{key_path}`; allowed {place}: {}", allowed.join(", ")));
                };
                under.insert(key, overlay(below, value, &key_path)?);
            }
            Ok(toml::Value::Table(under))
        }
        (_, over) => Ok(over),
    }
}

/// The first value of `file` that its key refuses, as `path: reason`, each value laid alone over
/// `defaults` and read. serde reads a section's flattened parts from a copy of the section and
/// names a value refused there by the section alone (`in gd`, for `gd.output.precision`); a value
/// is refused or not on its own (no key's type depends on another's), so the one refused is found
/// alone, and its path is known here.
fn refused_value(defaults: &toml::Value, file: &toml::Value) -> Option<String> {
    let mut set = Vec::new();
    values_set(defaults, file, &mut Vec::new(), &mut set);
    set.into_iter().find_map(|(path, value)| {
        let mut alone = defaults.clone();
        let place = path.iter().try_fold(&mut alone, |table, key| table.get_mut(key.as_str()))?;
        *place = value.clone();
        let refused = alone.try_into::<Config>().err()?;
        Some(format!("{}: {}", path.join("."), refused.message()))
    })
}

/// The values `over` sets where [`overlay`] lays it on `under`, each with its path below `path`:
/// a table on a table is walked into, anything else is one value.
fn values_set<'a>(
    under: &toml::Value,
    over: &'a toml::Value,
    path: &mut Vec<String>,
    set: &mut Vec<(Vec<String>, &'a toml::Value)>,
) {
    match (under, over) {
        (toml::Value::Table(under), toml::Value::Table(over)) => {
            for (key, value) in over {
                path.push(key.clone());
                match under.get(key) {
                    Some(below) => values_set(below, value, path, set),
                    None => set.push((path.clone(), value)),
                }
                path.pop();
            }
        }
        _ => set.push((path.clone(), over)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error_of(text: &str) -> String {
        Config::from_toml(text, "test.toml").unwrap_err().to_string()
    }

    #[test]
    fn the_registry_pairs_every_kind_of_the_loaders_list_with_its_recipe_in_order() {
        assert_eq!(crate::recipes::REGISTRY_SECTIONS, TableKind::names().as_slice());
        let config = Config::default();
        for &kind in TableKind::ALL {
            assert_eq!(config.recipe(kind).name(), kind.name());
        }
    }

    #[test]
    fn empty_configuration_is_the_default() {
        assert_eq!(Config::from_toml("", "empty").unwrap(), Config::default());
    }

    #[test]
    fn partial_sections_keep_the_other_defaults() {
        let config = Config::from_toml("seed = 5\n[karis]\nmu_count = 32\n", "t").unwrap();
        assert_eq!(config.seed, 5);
        assert_eq!(config.karis.mu_count, 32);
        assert_eq!(config.karis.roughness_count, 512);
    }

    #[test]
    fn the_bake_section_is_read_key_by_key_and_bad_values_name_their_key() {
        let config = Config::from_toml("[bake]\nsource = \"tables\"\nnodes = 128\n", "t").unwrap();
        let bake = &config.bake;
        assert_eq!((bake.source, bake.nodes), (crate::bake::BakeSource::Tables, 128));
        assert_eq!(bake.formats, crate::bake::BakeConfig::default().formats, "the other keys keep their defaults");
        for (text, named) in [
            ("[bake]\nnodes = 4\n", "bake.nodes"),
            ("[bake]\ntolerance = 0.0\n", "bake.tolerance"),
            ("[bake]\nformats = [\"bin\"]\n", "bake.formats"),
            ("[bake]\nformats = []\n", "bake.formats"),
            ("[bake]\nexact_nodes = 1\n", "bake.exact_nodes"),
            ("[bake]\nsource = \"walk\"\n", "bake.source"),
        ] {
            let e = error_of(text);
            assert!(e.contains(named) && (e.contains("allowed") || e.contains("expected")), "{text}: {e}");
        }
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = error_of("[karis]\nmu_cuont = 32\n");
        assert!(e.contains("test.toml") && e.contains("mu_cuont"), "{e}");
        let e = error_of("[fgdd]\n");
        assert!(e.contains("fgdd"), "{e}");
    }

    #[test]
    fn unknown_keys_are_refused_in_the_split_sum_sections_whose_own_keys_are_flattened_in() {
        let e = error_of("[karis]\nmu_cuont = 32\n");
        assert!(e.contains("`karis.mu_cuont`") && e.contains("allowed in [karis]: alpha_range"), "{e}");
        assert!(e.contains("mu_count") && e.contains("storage_rounding") && !e.contains("cosine_intervals"), "{e}");
        // Each table's own key belongs to its section only, and the Rust field holding it is no key.
        let e = error_of("[belcour]\nstorage_rounding = \"nearest\"\n");
        assert!(e.contains("`belcour.storage_rounding`") && e.contains("cosine_intervals"), "{e}");
        let e = error_of("[karis]\ncosine_intervals = 64\n");
        assert!(e.contains("`karis.cosine_intervals`"), "{e}");
        let e = error_of("[karis.own]\nstorage_rounding = \"nearest\"\n");
        assert!(e.contains("`karis.own`"), "{e}");
        let e = error_of("[karis.sampling]\nsample = 1024\n");
        assert!(
            e.contains("`karis.sampling.sample`") && e.contains("allowed in [karis.sampling]: replicates, samples"),
            "{e}"
        );
        let e = error_of("fgdd = 1\n");
        assert!(e.contains("`fgdd`") && e.contains("allowed at the top level: bake, belcour, fgd"), "{e}");
        // The own keys are read where they belong, and a bad value names what is allowed.
        let config =
            Config::from_toml("[karis]\nstorage_rounding = \"nearest\"\n[belcour]\ncosine_intervals = 64\n", "t")
                .unwrap();
        assert_eq!(config.karis.own.storage_rounding, crate::formats::SumRounding::Nearest);
        assert_eq!(config.belcour.own.cosine_intervals, 64);
        let e = error_of("[karis]\nstorage_rounding = \"up\"\n");
        assert!(e.contains("`up`") && e.contains("no-energy-gain"), "{e}");
        // Read on their own, without the configuration's check, the settings still refuse an
        // unknown key (serde's check of what the flattened part left).
        let e = toml::from_str::<crate::recipes::karis::KarisSettings>("mu_cuont = 3\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `mu_cuont`"), "{e}");
        let e = toml::from_str::<crate::recipes::belcour::BelcourSettings>("storage_rounding = \"nearest\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `storage_rounding`"), "{e}");
        let karis: crate::recipes::karis::KarisSettings = toml::from_str("storage_rounding = \"nearest\"\n").unwrap();
        assert_eq!(karis.own.storage_rounding, crate::formats::SumRounding::Nearest);
    }

    #[test]
    fn out_of_range_values_are_named_with_what_is_allowed() {
        let cases: &[(&str, &[&str])] = &[
            ("[karis]\nalpha_range = [-0.1, 1.0]\n", &["karis.alpha_range", "allowed"]),
            ("[karis]\nalpha_range = [0.8, 0.2]\n", &["karis.alpha_range", "inverted"]),
            ("[karis]\nmu_count = 0\n", &["karis.mu_count", "allowed: 2 to"]),
            ("[karis]\nmu_count = 1\n", &["karis.mu_count", "allowed: 2 to"]),
            ("[karis.sampling]\nsamples = 1000\nreplicates = 4\n", &["karis.sampling.samples", "power of two"]),
            (
                "[karis.output]\nformats = [\"bin\"]\nprecision = \"f16\"\n",
                &["karis.output.formats", "allowed: dds, exr"],
            ),
            ("[tir]\nfit = \"always\"\n", &["always", "best", "off"]),
            ("[karis]\nmasking = \"beckmann\"\n", &["beckmann", "smith-separable"]),
            // Read through a TOML table, so that a longer array is refused rather than cut short.
            ("[karis]\nalpha_range = [0.1, 0.5, 0.9]\n", &["invalid length 3", "karis.alpha_range"]),
            (
                "[karis.sampling]\nsamples = 1024\nreplicates = 3\n",
                &["karis.sampling.replicates", "3; allowed: a power of two"],
            ),
        ];
        for (text, expected) in cases {
            let e = error_of(text);
            assert!(expected.iter().all(|part| e.contains(part)), "{text}: {e}");
        }
    }

    #[test]
    fn a_value_or_key_in_a_flattened_part_is_named_by_its_whole_path() {
        // The keys every table shares, the mu and alpha axes, a split-sum table's own keys: each
        // read through a flattened struct, where serde names the section alone.
        let cases: &[(&str, &[&str])] = &[
            ("[gd.output]\nprecision = \"f8\"\n", &["test.toml: gd.output.precision: unknown variant `f8`", "`f16`"]),
            ("[fgd]\nmu_range = [0.1, 0.5, 0.9]\n", &["test.toml: fgd.mu_range: invalid length 3"]),
            ("[tir]\nroughness_axis = \"cubic\"\n", &["tir.roughness_axis: unknown variant `cubic`", "`perceptual`"]),
            ("[karis.sampling]\nsamples = \"many\"\n", &["karis.sampling.samples: invalid type: string \"many\""]),
            ("[belcour]\ncosine_intervals = -1\n", &["belcour.cosine_intervals: invalid value: integer `-1`"]),
            ("[fgd]\nreference = 3\n", &["fgd.reference: invalid type: integer `3`"]),
            // Beside a good value the refused one is still the one named.
            ("[gd]\nmu_count = 8\n[gd.interpolation]\npoints = 1.5\n", &["gd.interpolation.points: invalid type"]),
            ("seed = -1\n", &["test.toml: seed: invalid value: integer `-1`"]),
            (
                "[gd.output]\nprecison = \"f32\"\n",
                &["`gd.output.precison`", "allowed in [gd.output]: formats, precision"],
            ),
            ("[fgd]\nmu_rnage = [0.0, 1.0]\n", &["`fgd.mu_rnage`", "alpha_range", "mu_range", "sampling", "packings"]),
        ];
        for (text, expected) in cases {
            let e = error_of(text);
            assert!(expected.iter().all(|part| e.contains(part)), "{text}: {e}");
        }
        // The flattened parts are read where they belong.
        let config = Config::from_toml(
            "[fgd]\nmu_range = [0.25, 0.5]\nroughness_axis = \"alpha\"\n[tir.reference]\ncells = 5\n",
            "t",
        )
        .unwrap();
        assert_eq!(config.fgd.mu_alpha.mu_range, [0.25, 0.5]);
        assert_eq!(config.fgd.mu_alpha.roughness_axis, crate::recipes::spacing::RoughnessAxis::Alpha);
        assert_eq!(config.tir.mu_alpha, Config::default().tir.mu_alpha);
        assert_eq!(config.tir.shared.reference.cells, 5);
    }

    #[test]
    fn a_build_that_would_not_fit_in_memory_or_time_is_refused_naming_its_keys() {
        // Every FGD count at its maximum: 2^56 values.
        let e = error_of(
            "[fgd]\nmu_count = 16384\nalpha_count = 16384\neta_count = 16384\nkappa_count = 16384\npackings = []\n",
        );
        assert!(
            e.starts_with("fgd: ") && e.contains("fgd.mu_count, fgd.alpha_count, fgd.eta_count, fgd.kappa_count"),
            "{e}"
        );
        assert!(e.contains("allowed: at most 16.0 GiB"), "{e}");
        // 2^32 samples: 144 GiB of points.
        let e = error_of("[karis.sampling]\nsamples = 4294967296\nreplicates = 4\n");
        assert!(e.starts_with("karis: ") && e.contains("karis.sampling.samples"), "{e}");
        // The per-cell method over the default FGD table with 2^20 samples: 2^44 evaluations and more.
        let e = error_of("[fgd]\nmethod = \"per-cell\"\n[fgd.sampling]\nsamples = 2097152\nreplicates = 4\n");
        assert!(e.contains("fgd.sampling.samples = 2097152") && e.contains("per-cell") && e.contains("2^44"), "{e}");
        // The default set needs far less.
        let config = Config::default();
        for recipe in config.recipes() {
            let demand = crate::recipes::demand(recipe).unwrap();
            assert!(demand.bytes < 1 << 30, "{}: {demand:?}", recipe.name());
        }
    }

    #[test]
    fn a_section_given_in_part_takes_the_tables_own_defaults_for_the_rest() {
        let config =
            Config::from_toml("[gd.sampling]\nreplicates = 8\n[karis.output]\nprecision = \"f32\"\n", "t").unwrap();
        let defaults = Config::default();
        assert_eq!(config.gd.shared.sampling.replicates, 8);
        assert_eq!(config.gd.shared.sampling.samples, defaults.gd.shared.sampling.samples);
        assert_eq!(config.karis.shared.output.formats, defaults.karis.shared.output.formats);
        assert_eq!(config.karis.shared.output.precision, crate::formats::Precision::F32);
        // Tables merge; arrays and values replace whole.
        let config = Config::from_toml("[karis.output]\nformats = [\"exr\"]\n", "t").unwrap();
        assert_eq!(config.karis.shared.output.formats, [crate::formats::FileFormat::Exr]);
        assert_eq!(overlay(toml::Value::Integer(1), toml::Value::Integer(2), "k"), Ok(toml::Value::Integer(2)));
    }

    #[test]
    fn a_format_listed_twice_or_no_format_at_all_is_refused() {
        let e = error_of("[karis.output]\nformats = [\"dds\", \"exr\", \"dds\"]\nprecision = \"f16\"\n");
        assert!(e.contains("karis.output.formats") && e.contains("`dds` is listed twice"), "{e}");
        let e = error_of("[karis.output]\nformats = []\nprecision = \"f16\"\n");
        assert!(e.contains("karis.output.formats") && e.contains("writes no file") && e.contains("--only"), "{e}");
        // FGD's packed texture and TIR's fitted form are files of their own.
        let packed_only =
            "[fgd.output]\nformats = []\nprecision = \"f32\"\n[tir.output]\nformats = []\nprecision = \"f32\"\n";
        assert!(Config::from_toml(packed_only, "t").is_ok());
        let e = error_of(&format!("{packed_only}[tir]\nfit = \"off\"\n"));
        assert!(e.contains("tir.output.formats"), "{e}");
    }
}

#[cfg(test)]
mod default_file_tests {
    use super::*;

    #[test]
    fn the_committed_default_configuration_is_the_built_in_default() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/default.toml");
        assert_eq!(Config::from_file(&path).unwrap(), Config::default());
    }
}

#[cfg(test)]
mod serialisation_tests {
    use super::*;
    use crate::scene::plan::PlannedBuild;

    /// The configurations under `luts/` (the other files there are budgets, scenes and fitted forms).
    const CONFIGURATIONS: &[&str] = &["luts/ci.toml", "luts/default.toml", "luts/gpu-check.toml", "luts/original.toml"];

    /// Every scene file under `dir`, sorted.
    fn scene_files(dir: &Path) -> Vec<std::path::PathBuf> {
        let mut files = Vec::new();
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                files.extend(scene_files(&path));
            } else if path.extension().is_some_and(|e| e == "toml") {
                files.push(path);
            }
        }
        files.sort();
        files
    }

    /// One line per serialisation the project hashes or reads back: each configuration as TOML
    /// (what `from_toml` lays a file over) and as JSON (the scene build's key), and the settings of
    /// every table of every `luts/` scene's plan under each configuration (the table cache's keys),
    /// each as the SHA-256 of its text.
    fn serialisations() -> String {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut configurations = vec![("built-in".to_string(), Config::default())];
        for name in CONFIGURATIONS {
            configurations.push((name.to_string(), Config::from_file(&root.join(name)).unwrap()));
        }
        let scenes = scene_files(&root.join("luts/scenes"));
        let hash = |text: &str| crate::loader::sha256_hex(text.as_bytes());
        let mut lines = String::new();
        for (name, config) in &configurations {
            lines += &format!("{name} toml {}\n", hash(&toml::to_string(config).unwrap()));
            lines += &format!("{name} json {}\n", hash(&serde_json::to_string(config).unwrap()));
            for path in &scenes {
                let (scene, _) = crate::scene::Scene::read(path).unwrap();
                let plan = crate::scene::plan::plan(&scene, config).unwrap();
                let settings: Vec<String> = plan
                    .tables
                    .iter()
                    .map(|table| match &table.build {
                        PlannedBuild::Table(settings) => serde_json::to_string(settings),
                        PlannedBuild::Slices(slices) => serde_json::to_string(&slices.of),
                        PlannedBuild::TirFit(settings) => serde_json::to_string(settings),
                    })
                    .collect::<std::result::Result<_, _>>()
                    .unwrap();
                let scene = path.strip_prefix(root).unwrap().display();
                lines += &format!("{name} {scene} {}\n", hash(&settings.join("\n")));
            }
        }
        lines
    }

    /// The table cache's keys hash the settings as serialised, so a change of their text (a key
    /// renamed, moved or added) makes every entry a miss; the recorded hashes hold the text as it
    /// is. Where such a change is meant, the failure prints the lines to record.
    #[test]
    fn the_settings_serialise_to_the_recorded_text() {
        let recorded = include_str!("../tests/data/settings-serialisations.txt");
        let now = serialisations();
        assert!(recorded == now, "the settings serialise to other text than recorded; now:\n{now}");
    }
}
