//! three.js's DFG table, `src/renderers/shaders/DFGLUTData.js`: a JavaScript module holding the
//! split-sum pair as RG16F half-float bit patterns in a `Uint16Array` named `DATA`, and
//! `getDFGLUT()`, which wraps it in a `DataTexture` (linear filtering, clamp to edge, no mipmaps).
//!
//! Its layout, as three.js samples it (`texture2D( dfgLUT, vec2( roughness, dotNV ) ).rg`; the
//! sources are cited in `luts/presets/threejs.toml` and `docs/engines.md`): `x` is perceptual
//! roughness and `y` is `n.v`, both at texel centres; the rows run `n.v` upward from the first;
//! `R` is Karis's `scale` (the `F0` weight) and `G` his `bias` (the `F90` weight). That is tmlut's
//! `karis` table with its two axes swapped: tmlut keeps `n.v` as `x` in its own files, so this
//! file is written with the axes transposed.

use crate::config::Config;
use crate::error::{Error, Result};
use crate::formats::Precision;
use crate::recipes::split_sum::{Orientation, RoughnessAxis};
use crate::table::{Table, TableKind};

/// The file this format writes and the file of three.js's tree it replaces.
pub const FILE: &str = "DFGLUTData.js";
pub const REPLACES: &str = "src/renderers/shaders/DFGLUTData.js";

/// Texels on one line of the `DATA` array: one row of the texture, as three.js lays its file out.
const CHANNELS: usize = 2;

/// Refuse settings of `table` that three.js's shader would read wrong, naming the key.
pub fn check_settings(config: &Config, table: TableKind) -> Result<()> {
    if table != TableKind::Karis {
        return Err(Error::invalid(
            "preset.drop_in.table",
            format!(
                "`{}`: three.js's DFGLUTData.js holds Karis's split-sum pair (scale, bias); its table is `karis`",
                table.name()
            ),
        ));
    }
    let karis = &config.karis;
    if karis.roughness_axis != RoughnessAxis::Perceptual {
        return Err(Error::invalid(
            "karis.roughness_axis",
            "three.js samples its DFG table at perceptual roughness (alpha = roughness^2); set \"perceptual\"",
        ));
    }
    if karis.orientation != Orientation::SmoothFirst {
        return Err(Error::invalid(
            "karis.orientation",
            "three.js's texture coordinate is roughness itself, so the first texel is the smoothest; set \"smooth-first\"",
        ));
    }
    if karis.alpha_range != [0.0, 1.0] {
        return Err(Error::invalid(
            "karis.alpha_range",
            format!("{:?}: three.js maps roughness 0 to 1 across the whole texture; set [0.0, 1.0]", karis.alpha_range),
        ));
    }
    if karis.shared.output.precision != Precision::F16 {
        return Err(Error::invalid(
            "karis.output.precision",
            "DFGLUTData.js holds half-float bit patterns (HalfFloatType); set \"f16\"",
        ));
    }
    Ok(())
}

/// The `karis` table as three.js reads it, texel by texel in its file's order: rows of `n.v`,
/// within a row roughness increasing, `(scale, bias)` in each texel. `stored` holds f16 values
/// (the values of the table's DDS), so each converts to its bit pattern exactly.
pub fn texels_in_file_order(stored: &Table) -> Vec<u16> {
    let [mu_count, roughness_count] = [stored.axes[0].count, stored.axes[1].count];
    let mut bits = Vec::with_capacity(mu_count * roughness_count * CHANNELS);
    for mu in 0..mu_count {
        for roughness in 0..roughness_count {
            bits.extend(stored.node(&[mu, roughness]).iter().map(|&v| half::f16::from_f32(v).to_bits()));
        }
    }
    bits
}

/// The text of `DFGLUTData.js` holding `stored` (the `karis` table's f16 values).
pub fn dfg_lut_js(stored: &Table) -> String {
    let [height, width] = [stored.axes[0].count, stored.axes[1].count];
    let rows: Vec<String> = texels_in_file_order(stored)
        .chunks(width * CHANNELS)
        .map(|row| {
            let words: Vec<String> = row.iter().map(|bits| format!("0x{bits:04x}")).collect();
            format!("\t{}", words.join(", "))
        })
        .collect();
    format!(
        "/**\n\
         \x20* The DFG table of the split sum, written by tmlut from its own integrals (`tmlut build --preset threejs`;\n\
         \x20* its manifest.json states the integral, masking model, sample count and measured error).\n\
         \x20* Resolution: {width}x{height}, x = roughness, y = dot( N, V ), both at texel centres\n\
         \x20* Format: RG16F half-float bit patterns (R: scale, G: bias)\n\
         \x20*/\n\
         \n\
         import {{ DataTexture }} from '../../textures/DataTexture.js';\n\
         import {{ RGFormat, HalfFloatType, LinearFilter, ClampToEdgeWrapping }} from '../../constants.js';\n\
         \n\
         const DATA = new Uint16Array( [\n\
         {}\n\
         ] );\n\
         \n\
         let lut = null;\n\
         \n\
         export function getDFGLUT() {{\n\
         \n\
         \tif ( lut === null ) {{\n\
         \n\
         \t\tlut = new DataTexture( DATA, {width}, {height}, RGFormat, HalfFloatType );\n\
         \t\tlut.name = 'DFG_LUT';\n\
         \t\tlut.minFilter = LinearFilter;\n\
         \t\tlut.magFilter = LinearFilter;\n\
         \t\tlut.wrapS = ClampToEdgeWrapping;\n\
         \t\tlut.wrapT = ClampToEdgeWrapping;\n\
         \t\tlut.generateMipmaps = false;\n\
         \t\tlut.needsUpdate = true;\n\
         \n\
         \t}}\n\
         \n\
         \treturn lut;\n\
         \n\
         }}\n",
        rows.join(",\n")
    )
}

/// What the file is, for its manifest entry.
pub fn layout_notes(stored: &Table) -> Vec<String> {
    let [height, width] = [stored.axes[0].count, stored.axes[1].count];
    vec![
        format!(
            "const DATA = new Uint16Array([...]): {width} x {height} texels of two half floats (RG16F bit patterns), one \
             line per row; getDFGLUT() wraps it in DataTexture(DATA, {width}, {height}, RGFormat, HalfFloatType) with \
             linear filtering and clamp-to-edge addressing."
        ),
        "x (within a row) = perceptual roughness, y (row) = n.v, both at texel centres (i + 0.5) / n; row 0 = the \
         smallest n.v. three.js samples texture2D(dfgLUT, vec2(roughness, dotNV)).rg: R = scale (the F0 weight), G = \
         bias (the F90 weight); single scattering F0 * scale + F90 * bias, Ess = scale + bias."
            .into(),
        "The same f16 values as the source file, axes transposed (tmlut's own files keep n.v as x).".into(),
    ]
}

/// The most bytes of a `DFGLUTData.js` read: three.js's file is a few kilobytes, and a table of
/// 512 x 512 texels written this way is about 4 MiB.
pub const MAX_FILE_BYTES: u64 = 8 << 20;

/// The `DATA` array of a `DFGLUTData.js` text, as half-float bit patterns in file order. Spaces and
/// line breaks may fall anywhere around `new Uint16Array( [`, and comments inside the array are
/// skipped; each word is a 16-bit integer literal, hexadecimal (`0x3c00`) or decimal.
pub fn parse_data(text: &str) -> Result<Vec<u16>> {
    let body = data_array_body(text)?;
    body.split(',')
        .map(str::trim)
        .filter(|word| !word.is_empty())
        .map(|word| {
            let value = match word.strip_prefix("0x").or_else(|| word.strip_prefix("0X")) {
                Some(hex) => u16::from_str_radix(hex, 16).ok(),
                None => word.parse::<u16>().ok(),
            };
            value.ok_or_else(|| {
                let shown: String = word.chars().take(40).collect();
                Error::invalid(
                    FILE,
                    format!("`{shown}` in DATA is not a 16-bit integer literal (0x.... or 0 to 65535)"),
                )
            })
        })
        .collect()
}

/// The text between `new Uint16Array( [` and its `]` after `const DATA =`, comments removed.
fn data_array_body(text: &str) -> Result<String> {
    let missing = || Error::invalid(FILE, "no `const DATA = new Uint16Array( [ ... ] )` in the file");
    let declaration = text.find("const DATA").ok_or_else(missing)?;
    let rest = text[declaration + "const DATA".len()..].trim_start();
    let rest = rest.strip_prefix('=').ok_or_else(missing)?.trim_start();
    let rest = rest.strip_prefix("new").ok_or_else(missing)?.trim_start();
    let rest = rest.strip_prefix("Uint16Array").ok_or_else(missing)?.trim_start();
    let rest = rest.strip_prefix('(').ok_or_else(missing)?.trim_start();
    let rest = rest.strip_prefix('[').ok_or_else(missing)?;
    let mut body = String::with_capacity(rest.len().min(1 << 20));
    let mut chars = rest.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, chars.peek()) {
            (']', _) => return Ok(body),
            ('/', Some('/')) => {
                chars.by_ref().find(|&c| c == '\n');
                body.push(' ');
            }
            ('/', Some('*')) => {
                chars.next();
                let mut last = ' ';
                if !chars.by_ref().any(|c| std::mem::replace(&mut last, c) == '*' && c == '/') {
                    return Err(Error::invalid(FILE, "a comment inside the DATA array is not closed (`*/`)"));
                }
                body.push(' ');
            }
            _ => body.push(c),
        }
    }
    Err(Error::invalid(FILE, "the DATA array is not closed (`]`)"))
}

/// The shape a `DFGLUTData.js` of `template`'s axes holds, in words, for errors.
pub fn expected_shape(template: &Table) -> String {
    let [height, width] = [template.axes[0].count, template.axes[1].count];
    format!(
        "{width} x {height} x {CHANNELS} = {} half floats ({height} rows of n.v, {width} roughness texels each, \
         (scale, bias) per texel)",
        width * height * CHANNELS
    )
}

/// The table a `DFGLUTData.js` text holds, on the axes and channels of `template` (the preset's
/// `karis` table): the inverse of [`texels_in_file_order`], every value read from its bit pattern
/// (NaN and infinity included, for the caller to report). A `DATA` array of any other length is
/// refused, naming the shape expected.
pub fn table_of_file(text: &str, template: &Table) -> Result<Table> {
    let words = parse_data(text)?;
    let [mu_count, roughness_count] = [template.axes[0].count, template.axes[1].count];
    if words.len() != mu_count * roughness_count * CHANNELS {
        return Err(Error::invalid(
            FILE,
            format!("DATA holds {} half floats; expected {}", words.len(), expected_shape(template)),
        ));
    }
    let mut table = template.clone();
    for (texel, pair) in words.chunks(CHANNELS).enumerate() {
        let (mu, roughness) = (texel / roughness_count, texel % roughness_count);
        let start = table.node_number(&[mu, roughness]) * CHANNELS;
        for (value, &bits) in table.data[start..start + CHANNELS].iter_mut().zip(pair) {
            *value = half::f16::from_bits(bits).to_f32();
        }
    }
    Ok(table)
}
