use std::sync::OnceLock;

use super::*;
use crate::bake::array::{arrange, array_entry, baked_table, material_entry};
use crate::bake::{BakeSettings, BakedErrors, bake_material};
use crate::config::Config;
use crate::exact::ExactTables;
use crate::filter::{Filter, bilinear, linear_taps};
use crate::formats::baked::{BakedSegment, sample_array};
use crate::shader::eval::{Machine, Textures, Value};
use crate::table::Table;

/// The GPU's filter: 8 fractional bits in the weights.
const GPU: Filter = Filter::QuantisedWeights { bits: 8 };

/// The example scenes' materials baked from exact integrals (few nodes of them: the values only
/// need to be the model's of some tables), in one array.
fn example_array() -> &'static (BakedArrayEntry, Table) {
    static ARRAY: OnceLock<(BakedArrayEntry, Table)> = OnceLock::new();
    ARRAY.get_or_init(|| {
        let exact = ExactTables::new(&Config::default(), 4).unwrap();
        let settings = BakeSettings::default();
        let baked: Vec<_> = crate::bake::tests::example_materials()
            .iter()
            .map(|(name, material)| bake_material(name, material, &exact, &settings).unwrap())
            .collect();
        let arrangement = arrange(&baked.iter().map(|b| b.rows()).collect::<Vec<_>>()).unwrap();
        let table = baked_table("baked", &baked, &arrangement).unwrap();
        let entries = baked
            .iter()
            .zip(&arrangement.places)
            .map(|(b, &place)| material_entry(b, place, BakedErrors::none("not measured")))
            .collect();
        let entry =
            array_entry("examples", "exact integrals", settings.tolerance, settings.nodes, &arrangement, entries);
        entry.check(&table).unwrap();
        (entry, table)
    })
}

/// An array of materials whose textures vary one parameter and two, beside one that varies
/// nothing, baked coarsely (the values only need to be some model's).
fn varied_array() -> &'static (BakedArrayEntry, Table) {
    static ARRAY: OnceLock<(BakedArrayEntry, Table)> = OnceLock::new();
    ARRAY.get_or_init(|| {
        let exact = ExactTables::new(&Config::default(), 4).unwrap();
        let settings = BakeSettings { nodes: 16, tolerance: 1e-2 };
        let text = "name = \"varied\"\n\
            [[material]]\nname = \"glaze\"\n[[material.layer]]\ntype = \"interface\"\nalpha = 0.2\n\
            vary = { eta = [1.4, 1.7] }\n\
            [[material]]\nname = \"rough-glaze\"\n[[material.layer]]\ntype = \"interface\"\n\
            vary = { eta = [1.4, 1.6], alpha = [0.1, 0.3] }\n\
            [[material]]\nname = \"plain\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n\
            [[material.layer]]\ntype = \"interface\"\neta = [0.2, 0.4, 1.4]\nkappa = [3.4, 2.4, 1.8]\nalpha = 0.1\n";
        let scene = crate::scene::Scene::from_toml(text, "varied", "varied").unwrap();
        let baked: Vec<_> = scene
            .materials
            .iter()
            .map(|m| crate::bake::bake_family(&m.name, &m.family(), &exact, &settings).unwrap())
            .collect();
        let arrangement = arrange(&baked.iter().map(|b| b.rows()).collect::<Vec<_>>()).unwrap();
        let table = baked_table("baked", &baked, &arrangement).unwrap();
        let entries = baked
            .iter()
            .zip(&arrangement.places)
            .map(|(b, &place)| material_entry(b, place, BakedErrors::none("not measured")))
            .collect();
        let entry = array_entry("varied", "exact integrals", settings.tolerance, settings.nodes, &arrangement, entries);
        entry.check(&table).unwrap();
        (entry, table)
    })
}

/// The values a varied parameter is read at: its range's ends, outside it, NaN, each node and the
/// f32 values beside it, and values between.
fn parameter_values(axis: &crate::formats::baked::BakedAxis) -> Vec<f32> {
    let [lo, hi] = axis.range.map(|v| v as f32);
    let mut values = vec![lo, hi, lo - 1.0, hi + 1.0, f32::NAN, f32::INFINITY, 0.37 * lo + 0.63 * hi];
    for j in 0..axis.nodes as usize {
        let node = axis.node(j) as f32;
        values.extend([node, f32::from_bits(node.to_bits() - 1), f32::from_bits(node.to_bits() + 1)]);
    }
    values
}

fn example_shader() -> BakedShader {
    baked_shader(&example_array().0, "baked.dds", Precision::F32).unwrap()
}

/// The texture array as a GPU samples it: the bilinear filter of one layer, 8-bit weights, clamp
/// addressing (`crate::filter`, the loader's sampler).
struct Sampled<'a>(&'a Table);

impl Textures for Sampled<'_> {
    fn load(&self, texture: &str, _: &[i32]) -> crate::error::Result<Option<[f32; 4]>> {
        panic!("the baked shader loads no texel, yet it loads one of {texture}")
    }

    fn sample(
        &self,
        texture: &str,
        sampler: &str,
        at: &[f32],
        layer: Option<i32>,
    ) -> crate::error::Result<Option<[f32; 4]>> {
        assert_eq!((texture, sampler), (ARRAY, SAMPLER));
        let [width, height, layers] = [0, 1, 2].map(|k| self.0.axes[k].count);
        let layer = layer.expect("a layer") as usize;
        assert!(layer < layers, "layer {layer} of {layers}");
        let taps = [linear_taps(at[0], width, GPU), linear_taps(at[1], height, GPU)];
        let texel = |x: usize, y: usize, c: usize| self.0.data[((layer * height + y) * width + x) * 4 + c];
        Ok(Some([0, 1, 2, 3].map(|c| bilinear(taps, |x, y| texel(x, y, c)))))
    }
}

/// A run's `TmResult` as the baked values of a material of `lobes` lobes, in storage order; the
/// lobes past its own must be zero.
fn flattened(result: &Value, lobes: usize) -> Vec<f32> {
    let field = |f: &str| result.field(f).unwrap_or_else(|| panic!("no {f} in {result:?}"));
    let lobe = |f: &str, k: usize| field(f).element(k).unwrap().components().unwrap();
    let mut values = [field("albedo"), field("top_albedo")].map(|v| v.components().unwrap()).concat();
    let max_lobes = match field("lobe_gd") {
        Value::Array(lobes) => lobes.len(),
        other => panic!("{other:?}"),
    };
    for k in 0..max_lobes {
        let lobe_values = ["lobe_energy", "lobe_roughness", "lobe_cos", "lobe_gd"].map(|f| lobe(f, k)).concat();
        match k < lobes {
            true => values.extend(lobe_values),
            false => assert!(lobe_values.iter().all(|&v| v == 0.0), "lobe {k} of {lobes}: {lobe_values:?}"),
        }
    }
    values
}

/// The views a material is read at: the ends, outside [0, 1], NaN, each segment's start and the
/// f32 views either side of it, and views between.
fn views(segments: &[BakedSegment]) -> Vec<f32> {
    let mut views = vec![0.0, -0.0, 1.0, -0.5, 3.0, f32::NAN, 1e-7, 0.3, 0.77];
    for s in segments {
        let mu = s.u_start * s.u_start;
        views.extend([mu, f32::from_bits(mu.to_bits().saturating_sub(1)), f32::from_bits(mu.to_bits() + 1)]);
    }
    views
}

#[test]
fn the_shader_run_on_the_cpu_reads_what_the_loader_samples_for_every_material() {
    let (entry, table) = example_array();
    let shader = example_shader();
    let machine = Machine::new(&shader.module).unwrap();
    let lobe_counts: BTreeSet<u32> = entry.materials.iter().map(|m| m.lobes).collect();
    assert!(lobe_counts.len() >= 2, "the examples have materials of one lobe count: {lobe_counts:?}");
    let mut runs = 0;
    for m in &entry.materials {
        for mu in views(&m.segments) {
            let function = &shader.description.materials.iter().find(|f| f.material == m.material).unwrap().function;
            let run = machine.call(function, vec![Value::F32(mu)], &Sampled(table)).unwrap();
            let read = flattened(&run.value, m.lobes as usize);
            let expected = sample_array(table, m, mu, &[], GPU);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&read), bits(&expected), "{} at mu = {mu}: {read:?} against {expected:?}", m.material);
            runs += 1;
        }
    }
    assert!(runs > entry.materials.len() * 9);
}

#[test]
fn the_constant_table_holds_each_materials_f32_constants_bit_for_bit() {
    let (entry, _) = example_array();
    let shader = example_shader();
    let machine = Machine::new(&shader.module).unwrap();
    let table = machine.global(TABLE).unwrap();
    let most = entry.materials.iter().map(|m| m.segments.len()).max().unwrap();
    for (k, m) in entry.materials.iter().enumerate() {
        let row = table.element(k).unwrap();
        let at = |f: &str| row.field(f).unwrap().clone();
        assert_eq!(at("layer"), Value::U32(m.layer));
        assert_eq!(at("lobes"), Value::U32(m.lobes));
        let centre = row_coordinate(m.first_row, entry.layer_extent[1]);
        assert_eq!(at("row").f32().unwrap().to_bits(), centre.to_bits());
        let stated = |of: fn(&BakedSegment) -> f32| m.segments.iter().map(|s| of(s).to_bits()).collect::<Vec<u32>>();
        for (f, stated) in
            [("u_start", stated(|s| s.u_start)), ("slope", stated(|s| s.slope)), ("offset", stated(|s| s.offset))]
        {
            let Value::Array(values) = at(f) else { panic!("{f}") };
            assert_eq!(values.len(), most);
            let values: Vec<u32> = values.iter().map(|v| v.f32().unwrap().to_bits()).collect();
            assert_eq!(values[..stated.len()], stated, "{} {f}", m.material);
        }
    }
}

#[test]
fn the_shader_validates_and_binds_one_array_and_one_sampler() {
    let shader = example_shader();
    let wgsl = shader.text(Lang::Wgsl);
    crate::shader::validate::wgsl(wgsl).unwrap_or_else(|e| panic!("{e}\n{wgsl}"));
    assert_eq!(
        wgsl.matches("textureSampleLevel(").count(),
        (6 + 6 * shader.description.max_lobes).div_ceil(4),
        "{wgsl}"
    );
    let hlsl = shader.text(Lang::Hlsl);
    assert!(hlsl.contains("Texture2DArray<float4> tmh_baked_array : register(t0);"), "{hlsl}");
    assert!(hlsl.contains("SamplerState tmh_baked_sampler : register(s1);"), "{hlsl}");
    assert!(hlsl.contains("static const TmBakedMaterial tmh_baked_materials["), "{hlsl}");
    let (entry, _) = example_array();
    for (k, m) in entry.materials.iter().enumerate() {
        let call = format!("return tmh_baked({k}u, mu);");
        let function = material_function(&m.material);
        assert!(wgsl.contains(&format!("fn {function}(mu: f32) -> TmResult {{\n    {call}")), "{function}");
        assert!(hlsl.contains(&format!("TmResult {function}(float mu) {{\n    {call}")), "{function}");
    }
    let description = &shader.description;
    assert_eq!(
        (description.texture.view_dimension.as_str(), description.texture.format.as_str()),
        ("2d-array", "rgba32float")
    );
    assert_eq!(
        description.texture.extent,
        [entry.nodes as usize, entry.layer_extent[1] as usize, entry.layers as usize]
    );
    let json = serde_json::to_string(description).unwrap();
    assert_eq!(serde_json::from_str::<BakedShaderDescription>(&json).unwrap(), *description);
}

/// The budget: a material of up to 3 lobes reads at most 8 texels and computes at most 40
/// operations, 2 reads and 10 operations more per further lobe; each reads its own rows only.
#[test]
fn each_material_costs_its_own_rows_and_stays_within_the_budget() {
    let (entry, _) = example_array();
    let shader = example_shader();
    for (m, (name, cost)) in entry.materials.iter().zip(shader.costs()) {
        assert_eq!(m.material, name);
        assert_eq!(cost.texture_reads, m.rows, "{name}: {cost:?}");
        let further = m.lobes.saturating_sub(3);
        assert!(cost.texture_reads <= 8 + 2 * further && cost.operations <= 40 + 10 * further, "{name}: {cost:?}");
        println!("{name}: {} lobes, {} segments: {cost:?}", m.lobes, m.segments.len());
    }
    let cheapest = shader.costs().iter().map(|(_, c)| c.operations).min().unwrap();
    let dearest = shader.costs().iter().map(|(_, c)| c.operations).max().unwrap();
    assert!(cheapest < dearest, "every material costs the most lobes' operations: {:?}", shader.costs());
}

#[test]
fn an_entry_the_shader_cannot_read_is_refused_naming_the_material() {
    let (entry, _) = example_array();
    let mut no_segments = entry.clone();
    no_segments.materials[1].segments.clear();
    let error = baked_shader(&no_segments, "baked.dds", Precision::F16).unwrap_err().to_string();
    assert!(error.contains(&entry.materials[1].material) && error.contains("0 segments"), "{error}");
    let mut twins = entry.clone();
    twins.materials[1].material = twins.materials[0].material.replace('/', "-");
    let error = baked_shader(&twins, "baked.dds", Precision::F16).unwrap_err().to_string();
    assert!(error.contains("is another material's"), "{error}");
    let mut outside = entry.clone();
    outside.materials[0].first_row = entry.layer_extent[1];
    let error = baked_shader(&outside, "baked.dds", Precision::F16).unwrap_err().to_string();
    assert!(error.contains("outside"), "{error}");
}

#[test]
fn the_shader_run_on_the_cpu_reads_what_the_loader_samples_at_varied_parameters() {
    let (entry, table) = varied_array();
    let counts: Vec<usize> = entry.materials.iter().map(|m| m.varied.len()).collect();
    assert_eq!(counts, [1, 2, 0], "{entry:?}");
    let shader = baked_shader(entry, "baked.dds", Precision::F32).unwrap();
    let machine = Machine::new(&shader.module).unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut runs = 0;
    for m in &entry.materials {
        let function = &shader.description.materials.iter().find(|f| f.material == m.material).unwrap().function;
        // Every value of the first parameter with the second at each of its own, and the reverse.
        let mut points: Vec<Vec<f32>> = vec![Vec::new()];
        for (a, axis) in m.varied.iter().enumerate() {
            let others: Vec<f32> = m.varied.iter().map(|x| x.nominal as f32).collect();
            points = parameter_values(axis)
                .into_iter()
                .flat_map(|v| {
                    let mut p = others.clone();
                    p[a] = v;
                    [p]
                })
                .chain(points.into_iter().filter(|p| p.len() == m.varied.len()))
                .collect();
        }
        if let [first, second] = m.varied.as_slice() {
            for a in parameter_values(first) {
                for b in parameter_values(second).into_iter().step_by(3) {
                    points.push(vec![a, b]);
                }
            }
        }
        for varied in &points {
            for mu in [0.0, 1.0, 0.3, f32::NAN, 0.77, m.segments.last().unwrap().u_start.powi(2)] {
                let mut arguments = vec![Value::F32(mu)];
                arguments.extend(varied.iter().map(|&v| Value::F32(v)));
                let run = machine.call(function, arguments, &Sampled(table)).unwrap();
                let read = flattened(&run.value, m.lobes as usize);
                let expected = sample_array(table, m, mu, varied, GPU);
                assert_eq!(
                    bits(&read),
                    bits(&expected),
                    "{} at mu = {mu}, {varied:?}: {read:?} against {expected:?}",
                    m.material
                );
                runs += 1;
            }
        }
    }
    assert!(runs > 200, "{runs}");
}

#[test]
fn a_varied_material_reads_twice_its_rows_per_parameter_and_the_shader_validates() {
    let (entry, _) = varied_array();
    let shader = baked_shader(entry, "baked.dds", Precision::F32).unwrap();
    let wgsl = shader.text(Lang::Wgsl);
    crate::shader::validate::wgsl(wgsl).unwrap_or_else(|e| panic!("{e}\n{wgsl}"));
    assert!(wgsl.contains("fn tm_glaze(mu: f32, layer_1_eta: f32) -> TmResult"), "{wgsl}");
    assert!(wgsl.contains("fn tm_rough_glaze(mu: f32, layer_1_eta: f32, layer_1_alpha: f32) -> TmResult"), "{wgsl}");
    assert!(wgsl.contains("fn tm_plain(mu: f32) -> TmResult"), "{wgsl}");
    let hlsl = shader.text(Lang::Hlsl);
    assert!(hlsl.contains("TmResult tm_rough_glaze(float mu, float layer_1_eta, float layer_1_alpha)"), "{hlsl}");
    // What each material costs more than in the same array with every parameter taken away.
    let mut unvaried = entry.clone();
    unvaried.materials.iter_mut().for_each(|m| m.varied.clear());
    let unvaried_shader = baked_shader(&unvaried, "baked.dds", Precision::F32).unwrap();
    let unvaried_costs = unvaried_shader.costs();
    for ((m, (_, cost)), (_, without)) in entry.materials.iter().zip(shader.costs()).zip(unvaried_costs) {
        assert_eq!(cost.texture_reads, m.rows << m.varied.len(), "{}: {cost:?}", m.material);
        // Every material: the compare of its count of parameters. Per parameter it has: 12 to map
        // its value and move to its block, the compare of the next parameter's count where the
        // array has one, and per row the next block's read and its blend (4; the second's, 9).
        let (rows, n) = (m.rows, m.varied.len() as u32);
        let next_compare = u32::from(entry.materials.iter().any(|m| m.varied.len() > 1));
        let expected = 1 + n.min(1) * (12 + next_compare + 4 * rows) + n.saturating_sub(1) * (12 + 9 * rows);
        assert_eq!(cost.operations - without.operations, expected, "{}: {cost:?} against {without:?}", m.material);
        println!("{}: {} lobes, {rows} rows, {n} varied: {cost:?}", m.material, m.lobes);
    }
}
