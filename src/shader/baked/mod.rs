//! The baked shader: the materials of a texture array of baked rows (`bake::array`,
//! `tmlut_loader::formats::baked`) read back as the scene shader's `TmResult`, one filtered sample
//! per row, in place of the transfer-matrix model.
//!
//! One function reads every material, `tmh_baked(material, mu)`: the material's index picks its
//! row of a constant table (`tmh_baked_materials`: its layer, lobe count, first row's centre and
//! segment maps, each material's segments padded to the table's with starts no `u` reaches), then
//!
//! ```text
//! u = sqrt(select(0, min(mu, 1), mu > 0))      (clamped to [0, 1], NaN as grazing)
//! slope, offset = those of the last segment s with u >= u_start_s   (a compare and two selects each)
//! x = u * slope + offset
//! texel r = textureSampleLevel(array, linear clamp sampler, (x, row + r / height), layer, 0)
//! ```
//!
//! which is [`texture_coordinate`] and [`row_coordinate`] in the same f32 operations: the rows read
//! are those `formats::baked::sample` reads. The rows of the albedo and the first lobes every
//! material has are read outright, each further lobe's under a branch on the material's lobe count
//! (nested, so a material pays for the lobes it has, and one compare past its last). Each material
//! has its function under the scene shader's name for it, `tm_<material>(mu)`, which calls
//! `tmh_baked` with its index. The names follow the scene shader's rule (`shader::scene`): a
//! material's function alone begins with `tm_`.
//!
//! [`texture_coordinate`]: crate::formats::baked::texture_coordinate
//! [`row_coordinate`]: crate::formats::baked::row_coordinate

use std::collections::BTreeSet;

use super::scene::{RESULT_STRUCT, material_function, result_struct};
use super::{
    Expr, Item, Lang, Module, Parens, ShaderCost, Stmt, Ty, assign, float, func, let_, name, select, var, vec3,
};
use crate::error::{Error, Result};
use crate::formats::baked::{BakedArrayEntry, BakedMaterialEntry, row_coordinate};
use crate::loader::shader::{
    BakedMaterialFunction, BakedShaderDescription, DeviceLimits, SHADER_DESCRIPTION_FORMAT, SamplerBinding,
    TextureBinding,
};
use crate::loader::{Precision, TextureFormat};

/// The function every material's calls: `(material index, mu) -> TmResult`.
pub const FUNCTION: &str = "tmh_baked";
/// The constant table of the materials, and the struct of its rows.
const TABLE: &str = "tmh_baked_materials";
const ROW_STRUCT: &str = "TmBakedMaterial";
/// The bindings: the texture array (binding 0) and its sampler (binding 1).
const ARRAY: &str = "tmh_baked_array";
const SAMPLER: &str = "tmh_baked_sampler";
/// The start of a padding segment: past every `u` (at most 1), so never chosen.
const NEVER: f32 = 2.0;
/// Values before the first lobe's (the albedo and the top albedo, RGB each), then per lobe.
const HEAD_VALUES: usize = 6;
const LOBE_VALUES: usize = 6;

/// The baked shader of one texture array: its module, its text in each language, and what a
/// renderer binds and calls (`<stem>.baked.shader.json`), each material's cost included.
#[derive(Debug, Clone)]
pub struct BakedShader {
    pub module: Module,
    pub texts: [(Lang, String); 2],
    pub description: BakedShaderDescription,
}

impl BakedShader {
    /// The text in `lang`.
    pub fn text(&self, lang: Lang) -> &str {
        self.texts.iter().find(|(l, _)| *l == lang).map(|(_, text)| text.as_str()).expect("both languages")
    }

    /// What one call of each material's function costs, in the order of the array's materials.
    pub fn costs(&self) -> Vec<(&str, ShaderCost)> {
        self.description.materials.iter().map(|m| (m.material.as_str(), m.cost)).collect()
    }
}

/// The shader reading the materials of `entry`, whose texels are the file `array_file` stored in
/// `precision`. Refused, naming the material, where an entry is not one the shader can read: no
/// segments, more values than its lobes give, rows outside its layer, or two materials whose
/// function names are one.
pub fn baked_shader(entry: &BakedArrayEntry, array_file: &str, precision: Precision) -> Result<BakedShader> {
    check(entry)?;
    let max_lobes = entry.materials.iter().map(|m| m.lobes as usize).max().unwrap_or(1).max(1);
    let min_lobes = entry.materials.iter().map(|m| m.lobes as usize).min().unwrap_or(0);
    let segments = entry.materials.iter().map(|m| m.segments.len()).max().unwrap_or(1);
    let mut module = Module::new(Parens::Minimal);
    module.comment(&format!(
        "tmlut baked shader: the transfer-matrix model of the materials of `{}`, baked along the view\n\
         cosine into the rows of one texture array, read back with one filtered sample per row.\n\
         Generated; the read is tmlut-loader's formats::baked::sample in f32. Bindings: group 0, the\n\
         array at 0, a linear clamp-to-edge sampler at 1 (see the .baked.shader.json beside this file).",
        entry.scene
    ));
    module.push(result_struct(max_lobes));
    let segment_array = || Ty::Array(Box::new(Ty::F32), segments);
    module.push(Item::Struct {
        name: ROW_STRUCT.into(),
        fields: vec![
            ("layer".into(), Ty::U32),
            ("lobes".into(), Ty::U32),
            ("row".into(), Ty::F32),
            ("u_start".into(), segment_array()),
            ("slope".into(), segment_array()),
            ("offset".into(), segment_array()),
        ],
    });
    let listing: Vec<String> =
        entry.materials.iter().enumerate().map(|(k, m)| format!("{k}: {}", m.material)).collect();
    module.comment(&format!(
        "Each material's layer, lobe count, first row's centre and segment maps, by index:\n{}",
        listing.join("\n")
    ));
    module.push(Item::Constant {
        name: TABLE.into(),
        ty: Ty::Array(Box::new(Ty::Named(ROW_STRUCT.into())), entry.materials.len()),
        value: Expr::Aggregate(
            Ty::Array(Box::new(Ty::Named(ROW_STRUCT.into())), entry.materials.len()),
            entry.materials.iter().map(|m| table_row(m, entry.layer_extent[1], segments)).collect(),
        ),
    });
    module.push(Item::Binding { group: 0, binding: 0, name: ARRAY.into(), ty: Ty::TextureArray });
    module.push(Item::Binding { group: 0, binding: 1, name: SAMPLER.into(), ty: Ty::Sampler });
    module.comment(
        "The baked values of material `material` at view cosine mu: the rows of its lobes only, each\n\
         read at u = sqrt(mu) mapped by its segment, as tmlut-loader's formats::baked::sample reads them.",
    );
    let lobes = Lobes { min: min_lobes, max: max_lobes };
    module.function(
        FUNCTION,
        vec![("material", Ty::U32), ("mu", Ty::F32)],
        Ty::Named(RESULT_STRUCT.into()),
        body(segments, entry.layer_extent[1], lobes),
    );
    let mut functions = BTreeSet::new();
    for (index, m) in entry.materials.iter().enumerate() {
        let function = material_function(&m.material);
        if !functions.insert(function.clone()) {
            return Err(refuse(
                &m.material,
                format!(
                    "its function name `{function}` is another material's; material names must differ in more than \
                     punctuation and case"
                ),
            ));
        }
        module.function(
            &function,
            vec![("mu", Ty::F32)],
            Ty::Named(RESULT_STRUCT.into()),
            vec![Stmt::Return(func(FUNCTION, vec![Expr::U32(index as u32), name("mu")]))],
        );
    }
    let materials = entry
        .materials
        .iter()
        .enumerate()
        .map(|(index, m)| {
            let function = material_function(&m.material);
            Ok(BakedMaterialFunction {
                material: m.material.clone(),
                cost: super::cost(&module, &function)?,
                function,
                index: index as u32,
                lobes: m.lobes as usize,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let description = description(entry, array_file, precision, max_lobes, materials)?;
    let texts = [Lang::Hlsl, Lang::Wgsl].map(|lang| (lang, module.print(lang)));
    Ok(BakedShader { module, texts, description })
}

fn refuse(material: &str, what: String) -> Error {
    Error::invalid(format!("baked shader, material `{material}`"), what)
}

/// What the shader relies on of each material: a segment at least, its values those of its lobes
/// four to a row, its rows inside its layer; and layers a power of two rows high.
fn check(entry: &BakedArrayEntry) -> Result<()> {
    let [_, height] = entry.layer_extent;
    if entry.materials.is_empty() {
        return Err(Error::invalid("baked shader", format!("the array of `{}` holds no material", entry.scene)));
    }
    if !height.is_power_of_two() {
        return Err(Error::invalid(
            "baked shader",
            format!("layers {height} rows high: a row's centre is exact only in a power-of-two height"),
        ));
    }
    for m in &entry.materials {
        let values = HEAD_VALUES + LOBE_VALUES * m.lobes as usize;
        if m.segments.is_empty() || m.segments.len() > crate::bake::placement::MAX_BREAKS + 1 {
            return Err(refuse(
                &m.material,
                format!(
                    "it has {} segments; a baked material has 1 to {}",
                    m.segments.len(),
                    crate::bake::placement::MAX_BREAKS + 1
                ),
            ));
        }
        if m.values.len() != values || m.rows as usize != values.div_ceil(4) {
            return Err(refuse(
                &m.material,
                format!(
                    "it stores {} values in {} rows where {} lobes give {values} values in {} rows",
                    m.values.len(),
                    m.rows,
                    m.lobes,
                    values.div_ceil(4)
                ),
            ));
        }
        if m.layer >= entry.layers || m.first_row + m.rows > height {
            return Err(refuse(
                &m.material,
                format!(
                    "its rows {} to {} of layer {} lie outside the {} layers of {height} rows",
                    m.first_row,
                    m.first_row + m.rows,
                    m.layer,
                    entry.layers
                ),
            ));
        }
    }
    Ok(())
}

/// Material `m`'s row of the constant table, its segments padded to `segments` with starts no `u`
/// reaches.
fn table_row(m: &BakedMaterialEntry, height: u32, segments: usize) -> Expr {
    let padded = |value: fn(&crate::formats::baked::BakedSegment) -> f32, padding: f32| {
        let values = (0..segments).map(|k| float(m.segments.get(k).map_or(padding, value))).collect();
        Expr::Aggregate(Ty::Array(Box::new(Ty::F32), segments), values)
    };
    Expr::Aggregate(
        Ty::Named(ROW_STRUCT.into()),
        vec![
            Expr::U32(m.layer),
            Expr::U32(m.lobes),
            float(row_coordinate(m.first_row, height)),
            padded(|s| s.u_start, NEVER),
            padded(|s| s.slope, 0.0),
            padded(|s| s.offset, 0.0),
        ],
    )
}

/// The lobe counts of the array's materials: lobes below `min` are read outright, the others
/// under a branch.
#[derive(Debug, Clone, Copy)]
struct Lobes {
    min: usize,
    max: usize,
}

/// `tmh_baked`'s body over `segments` segments in layers `height` rows high.
fn body(segments: usize, height: u32, lobes: Lobes) -> Vec<Stmt> {
    let constants = || name("constants");
    let mu = || name("mu");
    let mut body = vec![
        let_("constants", Ty::Named(ROW_STRUCT.into()), name(TABLE).element(name("material"))),
        Stmt::Comment("formats::baked::texture_coordinate: mu clamped to [0, 1], NaN read as 0.".into()),
        let_("u", Ty::F32, select(mu().gt(float(0.0)), mu().min(float(1.0)), float(0.0)).sqrt()),
        var("slope", Ty::F32, constants().member("slope").index(0)),
        var("offset", Ty::F32, constants().member("offset").index(0)),
    ];
    for k in 1..segments {
        let past = format!("past{k}");
        body.push(let_(&past, Ty::Bool, name("u").ge(constants().member("u_start").index(k))));
        for field in ["slope", "offset"] {
            body.push(assign(name(field), select(name(&past), constants().member(field).index(k), name(field))));
        }
    }
    // `precise`: HLSL may not fuse the multiply and add, which the CPU's coordinate does not.
    body.push(Stmt::Let {
        name: "x".into(),
        ty: Ty::F32,
        value: name("u") * name("slope") + name("offset"),
        typed: true,
        precise: true,
    });
    body.push(Stmt::Var { name: "result".into(), ty: Ty::Named(RESULT_STRUCT.into()), value: None });
    let mut reader = RowReader { height, read: 0 };
    for (field, first) in [("albedo", 0), ("top_albedo", 3)] {
        let value = reader.triple(first, &mut body);
        body.push(assign(name("result").member(field), value));
    }
    body.extend(lobe_blocks(0, lobes, &mut reader));
    body.push(Stmt::Return(name("result")));
    body
}

/// The statements filling lobe `k` and those after it: outright below `lobes.min`, else under a
/// branch on the material's lobe count, the next lobe's nested inside.
fn lobe_blocks(k: usize, lobes: Lobes, reader: &mut RowReader) -> Vec<Stmt> {
    if k == lobes.max {
        return Vec::new();
    }
    let mut block = Vec::new();
    let first = HEAD_VALUES + LOBE_VALUES * k;
    let field = |f: &str| name("result").member(f).index(k);
    let energy = reader.triple(first, &mut block);
    block.push(assign(field("lobe_energy"), energy));
    for (offset, f) in [(3, "lobe_roughness"), (4, "lobe_cos"), (5, "lobe_gd")] {
        let value = reader.value(first + offset, &mut block);
        block.push(assign(field(f), value));
    }
    block.extend(lobe_blocks(k + 1, lobes, reader));
    match k < lobes.min {
        true => block,
        false => vec![Stmt::If {
            condition: name("constants").member("lobes").gt(Expr::U32(k as u32)),
            then: block,
            otherwise: Vec::new(),
        }],
    }
}

/// Reads a material's rows as its values need them, each once: row `r` into the local `t<r>`.
struct RowReader {
    height: u32,
    /// Rows read so far (rows `0..read`), in this block or one around it.
    read: usize,
}

impl RowReader {
    /// Value `i` (channel `i % 4` of row `i / 4`), its row read first where it is not yet.
    fn value(&mut self, i: usize, block: &mut Vec<Stmt>) -> Expr {
        let row = i / 4;
        while self.read <= row {
            block.push(let_(&format!("t{}", self.read), Ty::Vec(4), self.sample(self.read)));
            self.read += 1;
        }
        name(&format!("t{row}")).member(&"xyzw"[i % 4..i % 4 + 1])
    }

    /// Values `i..i + 3`: a swizzle of one row where they lie in one.
    fn triple(&mut self, i: usize, block: &mut Vec<Stmt>) -> Expr {
        let [a, b, c] = [i, i + 1, i + 2].map(|i| self.value(i, block));
        match (i / 4 == (i + 2) / 4, &a) {
            (true, Expr::Member(texel, _)) => texel.as_ref().clone().member(&"xyzw"[i % 4..i % 4 + 3]),
            _ => vec3(a, b, c),
        }
    }

    /// The filtered sample of row `r` of the material: at its centre `row + r / height`, exact in
    /// f32 as [`row_coordinate`]'s, so the filter reads that row alone.
    fn sample(&self, r: usize) -> Expr {
        let row = name("constants").member("row");
        let y = match r {
            0 => row,
            _ => row + float(r as f32 / self.height as f32),
        };
        Expr::SampleLevel {
            texture: ARRAY.into(),
            scalar_texture: false,
            sampler: SAMPLER.into(),
            coordinates: vec![name("x"), y],
            layer: Some(Box::new(name("constants").member("layer"))),
            swizzle: "xyzw",
        }
    }
}

/// `<stem>.baked.shader.json`.
fn description(
    entry: &BakedArrayEntry,
    array_file: &str,
    precision: Precision,
    max_lobes: usize,
    materials: Vec<BakedMaterialFunction>,
) -> Result<BakedShaderDescription> {
    let format = TextureFormat::of(4, precision).expect("four channels have a format in every precision");
    let [width, height] = entry.layer_extent;
    let texture = TextureBinding {
        binding: 0,
        variable: ARRAY.into(),
        file: array_file.into(),
        extent: [width as usize, height as usize, entry.layers as usize],
        dimension: 2,
        depth: 1,
        array_layers: entry.layers as usize,
        channels: 4,
        layered: true,
        format: format.webgpu_name().into(),
        view_dimension: "2d-array".into(),
        sample_type: "float".into(),
    };
    Ok(BakedShaderDescription {
        format_version: SHADER_DESCRIPTION_FORMAT,
        result_struct: RESULT_STRUCT.into(),
        max_lobes,
        function: FUNCTION.into(),
        limits: DeviceLimits::of(std::slice::from_ref(&texture), 1),
        texture,
        sampler: SamplerBinding {
            binding: 1,
            variable: SAMPLER.into(),
            filter: "linear".into(),
            address_mode: "clamp-to-edge".into(),
        },
        materials,
        notes: format!(
            "Bind the texture array in group 0 at binding 0 (HLSL: register t0), created from the file's texels as \
             stored ({}), one mip level, linear data, view dimension 2d-array, sample type float: the sampler filters \
             it{}. Bind a sampler at binding 1 (HLSL: register s1) with linear magnification and minification and \
             clamp-to-edge addressing. Call a material's function with the view cosine mu = n.v, or {FUNCTION} with \
             its index and mu.",
            format.webgpu_name(),
            match precision {
                Precision::F32 => " (WebGPU filters rgba32float only on a device with the float32-filterable feature)",
                Precision::F16 => "",
            }
        ),
    })
}

#[cfg(test)]
mod tests;

/// What the baked shader's functions cost per call, in one line: the range over its materials.
pub fn cost_summary(description: &BakedShaderDescription) -> String {
    let materials = &description.materials;
    let range = |of: fn(&ShaderCost) -> u32| {
        let values = materials.iter().map(|m| of(&m.cost));
        (values.clone().min().unwrap_or(0), values.max().unwrap_or(0))
    };
    let (reads, operations) = (range(|c| c.texture_reads), range(|c| c.operations));
    format!(
        "  the baked shader per call: {} to {} texture reads, {} to {} operations ({} materials; {}(index, mu) reads any)\n",
        reads.0,
        reads.1,
        operations.0,
        operations.1,
        materials.len(),
        description.function
    )
}
