//! Engine presets (`tmlut build --preset NAME`): a TOML file under `luts/presets/` that sets which
//! tables to build, with the settings of one engine's own tables (axes, placement, masking,
//! precision), and which of that engine's files to write beside them (`docs/engines.md`).
//!
//! A preset is a build configuration (the sections of `luts/default.toml`) with one more section:
//!
//! ```toml
//! [preset]
//! engine = "three.js"
//! description = "one line for `tmlut list`"
//! tables = ["karis"]
//! drop_in = { format = "threejs-dfg-lut", table = "karis" }
//! ```
//!
//! The presets of `luts/presets/` are built into the binary, so `--preset threejs` works from any
//! folder; `--preset path/to/edited.toml` reads a copy a user changed.
//!
//! A preset may hold the error budgets of its tables, as `[budgets.<table>]` sections with the keys
//! of `budgets.toml`: an engine's tables are smaller than the default set's, so the default budgets
//! (meant for 512 x 512 split sums) would fail them. The build records the preset in the folder's
//! manifest, and `tmlut check` holds the folder to those budgets.

pub mod threejs;
pub mod threejs_shader;

use std::path::Path;

use serde::Deserialize;

use crate::config::Config;
use crate::error::{Error, Result};
use crate::formats::manifest::{DropInEntry, ShaderFile};
use crate::table::{Table, TableKind};

/// The presets shipped in `luts/presets/`: name and text.
const BUILT_IN: &[(&str, &str)] = &[("threejs", include_str!("../../luts/presets/threejs.toml"))];

/// The names of the built-in presets, for `tmlut list` and errors.
pub fn names() -> Vec<&'static str> {
    BUILT_IN.iter().map(|(name, _)| *name).collect()
}

/// A preset as read: its own section and the build configuration it sets.
#[derive(Debug, Clone)]
pub struct Preset {
    pub name: String,
    /// Whether it is one of `luts/presets/`, found by name.
    pub built_in: bool,
    pub section: PresetSection,
    pub config: Config,
    /// The `[budgets]` section as written, for `tmlut check` to read as a budgets file.
    pub budgets: Option<String>,
}

/// The `[preset]` section.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresetSection {
    /// The engine whose tables the preset writes.
    pub engine: String,
    /// One line for `tmlut list`.
    pub description: String,
    /// The tables to build, by name (`tmlut list`).
    pub tables: Vec<String>,
    /// The engine's own file to write beside the tables.
    pub drop_in: Option<DropInSection>,
}

/// `[preset] drop_in`: which engine file to write, from which table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DropInSection {
    pub format: DropInFormat,
    pub table: String,
}

/// The engine files tmlut writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DropInFormat {
    /// three.js's `src/renderers/shaders/DFGLUTData.js` ([`threejs`]).
    ThreejsDfgLut,
}

impl DropInFormat {
    /// The name of the engine's file.
    pub fn file_name(self) -> &'static str {
        match self {
            DropInFormat::ThreejsDfgLut => threejs::FILE,
        }
    }
}

impl Preset {
    /// The built-in preset `name`, or the preset file at `name` where it names a `.toml` file.
    pub fn load(name: &str) -> Result<Preset> {
        if name.ends_with(".toml") || name.contains(['/', '\\']) {
            let path = Path::new(name);
            let text = crate::formats::read_text_at_most(path, crate::formats::MAX_TEXT_INPUT_BYTES, "a preset")?;
            let stem = path.file_stem().map_or_else(|| name.to_string(), |s| s.to_string_lossy().into_owned());
            return Preset::from_toml(&stem, &text, name);
        }
        Preset::built_in(name)
    }

    /// The built-in preset `name`, never a file: what a folder's manifest names is looked up here,
    /// so that a manifest cannot make `check` read a path it states.
    pub fn built_in(name: &str) -> Result<Preset> {
        match BUILT_IN.iter().find(|(known, _)| *known == name) {
            Some((_, text)) => {
                let preset = Preset::from_toml(name, text, &format!("luts/presets/{name}.toml"))?;
                Ok(Preset { built_in: true, ..preset })
            }
            None => Err(Error::invalid(
                "--preset",
                format!(
                    "unknown preset `{name}`; known presets: {} (or the path of a preset file, ending in .toml)",
                    names().join(", ")
                ),
            )),
        }
    }

    /// Parse a preset's text; `origin` names it in errors.
    pub fn from_toml(name: &str, text: &str, origin: &str) -> Result<Preset> {
        let mut file: toml::Table =
            text.parse().map_err(|e| Error::invalid(origin, crate::config::clean_toml_error(&e)))?;
        let section = file
            .remove("preset")
            .ok_or_else(|| Error::invalid(origin, "no [preset] section: a preset names its engine and tables there"))?;
        let section: PresetSection = section
            .try_into()
            .map_err(|e: toml::de::Error| Error::invalid(format!("{origin}: [preset]"), e.message().to_string()))?;
        let budgets = match file.remove("budgets") {
            Some(toml::Value::Table(budgets)) => Some(toml::to_string(&budgets).expect("a parsed TOML table prints")),
            Some(_) => return Err(Error::invalid(format!("{origin}: budgets"), "must be sections, [budgets.<table>]")),
            None => None,
        };
        let config = Config::from_toml(&toml::to_string(&file).expect("a parsed TOML table prints"), origin)?;
        let preset = Preset { name: name.to_string(), built_in: false, section, config, budgets };
        preset.validate()?;
        Ok(preset)
    }

    /// The tables it builds, checked against the tables tmlut knows.
    pub fn tables(&self) -> Result<Vec<TableKind>> {
        let known = || TableKind::names().join(", ");
        if self.section.tables.is_empty() {
            return Err(Error::invalid("preset.tables", format!("no table named; known tables: {}", known())));
        }
        self.section
            .tables
            .iter()
            .map(|name| {
                TableKind::named(name).ok_or_else(|| {
                    Error::invalid("preset.tables", format!("unknown table `{name}`; known tables: {}", known()))
                })
            })
            .collect()
    }

    /// The settings must agree with each other and with the engine file the preset writes: a key
    /// that would make the file read wrong in the engine is refused by name.
    fn validate(&self) -> Result<()> {
        let tables = self.tables()?;
        let Some(drop_in) = &self.section.drop_in else { return Ok(()) };
        let kind = TableKind::named(&drop_in.table).filter(|kind| tables.contains(kind)).ok_or_else(|| {
            Error::invalid(
                "preset.drop_in.table",
                format!(
                    "`{}` is not one of the tables the preset builds ({})",
                    drop_in.table,
                    self.section.tables.join(", ")
                ),
            )
        })?;
        match drop_in.format {
            DropInFormat::ThreejsDfgLut => threejs::check_settings(&self.config, kind),
        }
    }

    /// The table `tmlut audit` measures with this preset (the one its engine file holds) and that
    /// file's format; refused, saying so, where the preset writes no engine file.
    pub fn audited_table(&self) -> Result<(TableKind, DropInFormat)> {
        let drop_in = self.section.drop_in.as_ref().ok_or_else(|| {
            Error::invalid(
                "--preset",
                format!(
                    "preset `{}` writes no engine file ([preset] drop_in), so it names no shipped table to audit",
                    self.name
                ),
            )
        })?;
        let kind = TableKind::named(&drop_in.table).expect("a preset's drop-in table is checked when it is read");
        Ok((kind, drop_in.format))
    }

    /// The shape of the engine file's table, in words, for errors.
    pub fn drop_in_shape(&self) -> Result<String> {
        let (kind, format) = self.audited_table()?;
        let template = self.config.recipe(kind).empty_table()?;
        Ok(match format {
            DropInFormat::ThreejsDfgLut => threejs::expected_shape(&template),
        })
    }

    /// The engine file at `path`, in the preset's drop-in format, as a table on the axes and
    /// channels the preset builds (read bounded in size; a file of another shape is refused,
    /// naming the shape expected).
    pub fn read_drop_in(&self, path: &Path) -> Result<Table> {
        let (kind, format) = self.audited_table()?;
        let template = self.config.recipe(kind).empty_table()?;
        match format {
            DropInFormat::ThreejsDfgLut => {
                let text =
                    crate::formats::read_text_at_most(path, threejs::MAX_FILE_BYTES, "a three.js DFGLUTData.js")?;
                threejs::table_of_file(&text, &template)
                    .map_err(|e| Error::invalid(path.display().to_string(), e.to_string()))
            }
        }
    }

    /// The engine file of `table` as stored (`stored`: the values of the table's files), named
    /// `source_file` in this folder, with the shader functions written beside it. None where the
    /// preset writes no file of this table.
    pub fn drop_in_of(&self, stored: &Table, source_file: &str) -> Result<Option<DropInFiles>> {
        let Some(drop_in) = self.section.drop_in.as_ref().filter(|d| d.table == stored.name) else {
            return Ok(None);
        };
        Ok(Some(match drop_in.format {
            DropInFormat::ThreejsDfgLut => {
                let text = threejs::dfg_lut_js(stored);
                let mut entry = DropInEntry::new(
                    &self.section.engine,
                    threejs::REPLACES,
                    &stored.name,
                    source_file,
                    threejs::layout_notes(stored),
                    text.as_bytes(),
                );
                let shaders = threejs_shader::files(&stored.axes)?;
                entry.shaders = shaders
                    .iter()
                    .map(|(lang, file, text)| {
                        ShaderFile::new(lang.extension(), file, threejs_shader::MULTISCATTERING, text.as_bytes())
                    })
                    .collect();
                let shaders = shaders.into_iter().map(|(_, file, text)| (file, text.into_bytes())).collect();
                DropInFiles { name: threejs::FILE.to_string(), bytes: text.into_bytes(), entry, shaders }
            }
        }))
    }
}

/// What a preset writes from one table: the engine's file and the shaders beside it.
pub struct DropInFiles {
    pub name: String,
    pub bytes: Vec<u8>,
    pub entry: DropInEntry,
    /// The shader files, by name, listed in `entry.shaders`.
    pub shaders: Vec<(String, Vec<u8>)>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::manifest::{MANIFEST_FILE, Manifest};

    /// The shipped threejs preset with one of its settings replaced: `key = value` under `[section]`.
    fn edited(section: &str, key: &str, value: &str) -> String {
        let text = BUILT_IN[0].1;
        let header = format!("[{section}]\n");
        let start = text.find(&header).expect("the section is in the preset") + header.len();
        let line = text[start..].lines().position(|l| l.starts_with(&format!("{key} "))).expect("the key is set");
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let index = text[..start].lines().count() + line;
        lines[index] = format!("{key} = {value}");
        lines.join("\n")
    }

    fn refusal(text: &str) -> String {
        Preset::from_toml("edited", text, "edited.toml").unwrap_err().to_string()
    }

    #[test]
    fn the_threejs_file_holds_the_dds_values_transposed_and_the_table_meets_its_reference() {
        let dir = tempfile::tempdir().unwrap();
        let (written, engine_files) = crate::pipeline::build_preset(Preset::load("threejs").unwrap(), dir.path(), &())
            .expect("the preset builds");
        assert_eq!(engine_files, vec![dir.path().join(threejs::FILE)]);
        let manifest = Manifest::read(&dir.path().join(MANIFEST_FILE)).unwrap();
        let dds = written.iter().find(|f| f.path.extension().is_some_and(|e| e == "dds")).expect("a DDS is written");
        let table = crate::loader::load_verified(&dds.path, &dds.entry).unwrap();
        let [mu_count, roughness_count] = [table.axes[0].count, table.axes[1].count];
        assert_eq!([mu_count, roughness_count], [16, 16]);

        let text = std::fs::read_to_string(&engine_files[0]).unwrap();
        let entry = &manifest.drop_ins[threejs::FILE];
        assert_eq!((entry.table.as_str(), entry.source_file.as_str()), ("karis", "karis.dds"));
        assert_eq!(entry.sha256, crate::pipeline::sha256_hex(text.as_bytes()));
        let halves = threejs::parse_data(&text).unwrap();
        assert_eq!(halves.len(), mu_count * roughness_count * 2);
        // Row = n.v, column = roughness, (scale, bias) in each texel: the DDS's node [mu, roughness].
        for (texel, pair) in halves.chunks(2).enumerate() {
            let (mu, roughness) = (texel / roughness_count, texel % roughness_count);
            let read: Vec<f32> = pair.iter().map(|&bits| half::f16::from_bits(bits).to_f32()).collect();
            assert_eq!(read, table.node(&[mu, roughness]), "texel (n.v {mu}, roughness {roughness})");
        }
        // The DDS itself holds the integrated values rounded to nearest half float.
        let integrated_to_f16 = dds.entry.error.storage_rounding_max;
        assert!(integrated_to_f16 <= 2.5e-4, "{integrated_to_f16}");

        let reference = dds.entry.error.integration.reference.as_ref().expect("every texel is checked");
        assert_eq!(reference.difference.count, 2 * mu_count * roughness_count);
        assert!(reference.difference.rms < 1e-5, "{reference:?}");
    }

    #[test]
    fn an_unknown_preset_names_the_known_ones() {
        let error = Preset::load("unreal-engine-4").unwrap_err().to_string();
        assert!(error.contains("unknown preset `unreal-engine-4`") && error.contains("threejs"), "{error}");
    }

    #[test]
    fn settings_three_js_would_read_wrong_are_refused_by_key() {
        for (section, key, value, named) in [
            ("karis", "roughness_axis", "\"alpha\"", "karis.roughness_axis"),
            ("karis", "orientation", "\"bottom-up-image\"", "karis.orientation"),
            ("karis", "alpha_range", "[0.0, 0.5]", "karis.alpha_range"),
            ("karis.output", "precision", "\"f32\"", "karis.output.precision"),
            ("preset", "drop_in", "{ format = \"threejs-dfg-lut\", table = \"belcour\" }", "preset.drop_in.table"),
            ("preset", "tables", "[\"karis\", \"krais\"]", "preset.tables"),
        ] {
            let error = refusal(&edited(section, key, value));
            assert!(error.contains(named), "{key} = {value}: {error}");
        }
        // A drop-in from a table the preset builds, but not the one three.js's file holds.
        let belcour = edited("preset", "tables", "[\"karis\", \"belcour\"]")
            .replace("table = \"karis\" }", "table = \"belcour\" }");
        assert!(refusal(&belcour).contains("its table is `karis`"), "{}", refusal(&belcour));
    }

    #[test]
    fn unknown_keys_and_formats_are_named() {
        let error = refusal(&edited("preset", "engine", "\"three.js\"\nengnie = \"x\""));
        assert!(error.contains("engnie"), "{error}");
        let error = refusal(&edited("preset", "drop_in", "{ format = \"threejs\", table = \"karis\" }"));
        assert!(error.contains("threejs-dfg-lut"), "{error}");
        let error = refusal(&edited("karis", "mu_count", "16\nmu_cuont = 3"));
        assert!(error.contains("mu_cuont"), "{error}");
        assert!(refusal("[karis]\nmu_count = 16\n").contains("no [preset] section"));
    }

    #[test]
    fn a_damaged_data_array_is_refused_with_the_word_at_fault() {
        let error = threejs::parse_data("const DATA = new Uint16Array( [ 0x3c00, 1.5 ] );").unwrap_err().to_string();
        assert!(error.contains("`1.5`"), "{error}");
        assert!(threejs::parse_data("export {};").unwrap_err().to_string().contains("no `const DATA"));
    }
}
