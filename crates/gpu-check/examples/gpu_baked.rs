//! The baked shader on wgpu, against the loader's read of the same rows: the materials of the
//! scene files given, baked from exact integrals into one texture array (`tmlut::bake`; a material
//! whose textures vary parameters across them), read by the generated WGSL
//! (`tmlut::shader::baked`: one filtered sample per row through a linear clamp-to-edge sampler, per
//! block of the nodes around each varied parameter's value) at the views that matter (the ends,
//! outside [0, 1], each segment's start and the f32 views beside it) at the parameters' nominal
//! values, and at random views and random values of the parameters (a tenth of each range beyond
//! either end included), against `formats::baked::sample_array` with a GPU's 8-bit filter weights.
//!
//! ```sh
//! cargo run --release --example gpu_baked -- luts/scenes/copper-pot.toml luts/scenes/thesis [--out DIR]
//! ```
//!
//! The array is stored in f32 where the device filters 32-bit floats (`float32-filterable`), else
//! in f16, the CPU reading the same rounded texels. A GPU computes the filter weight in its own
//! fixed point and the square root to its own accuracy, so each value may differ from the CPU's by
//! 1/256 of the largest step between the two texels it blends in the blocks it reads (and 1e-6
//! besides). `--out DIR` writes the
//! shader there (`examples.baked.wgsl`, `.hlsl`, `.baked.shader.json`) for `scripts/hlsl-check`.
//! Exits non-zero beyond that, on a value that is not finite, or on a lobe past a material's own
//! that is not zero.

use tmlut_gpu_check as gpu;

use std::path::PathBuf;
use std::process::ExitCode;

use rand_pcg::Pcg64Mcg;
use tmlut::bake::array::{arrange, array_entry, baked_table, material_entry};
use tmlut::bake::{BakeSettings, BakedErrors, bake_family};
use tmlut::config::Config;
use tmlut::exact::ExactTables;
use tmlut::filter::{Filter, linear_taps};
use tmlut::formats::baked::{BakedArrayEntry, BakedMaterialEntry, parameter_taps, sample_array, texture_coordinate};
use tmlut::loader::{Precision, TextureData};
use tmlut::scene::library::read_scene_files;
use tmlut::shader::Lang;
use tmlut::shader::baked::{FUNCTION, baked_shader};
use tmlut::table::Table;

/// Random views per material, beside the ones that matter.
const RANDOM_VIEWS: usize = 2000;
/// The GPU's filter weights against the CPU's 8-bit ones: a fraction of the step between texels.
const WEIGHT_TOLERANCE: f32 = 1.0 / 256.0;
const ABSOLUTE_TOLERANCE: f32 = 1e-6;

fn main() -> ExitCode {
    gpu::exit_code("gpu_baked", run())
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    let mut scenes = Vec::new();
    let mut out = None;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--out" => out = Some(PathBuf::from(args.next().ok_or("--out takes a folder")?)),
            _ => scenes.push(PathBuf::from(arg)),
        }
    }
    if scenes.is_empty() {
        return Err("usage: gpu_baked SCENE_FILE_OR_FOLDER... [--out DIR]".into());
    }
    let gpu = gpu::Gpu::new()?;
    println!("adapter: {}", gpu.adapter);
    let precision = if gpu.float32_filterable { Precision::F32 } else { Precision::F16 };
    let (entry, table) = baked_array(&scenes, precision)?;
    let shader = baked_shader(&entry, "examples.baked.dds", precision)?;
    if let Some(out) = &out {
        std::fs::create_dir_all(out)?;
        for (lang, text) in &shader.texts {
            std::fs::write(out.join(format!("examples.baked.{}", lang.extension())), text)?;
        }
        std::fs::write(out.join("examples.baked.shader.json"), serde_json::to_string_pretty(&shader.description)?)?;
    }
    let max_lobes = shader.description.max_lobes;
    let stride = 6 + 6 * max_lobes;
    // The most varied parameters of a material: the shared function's arguments after mu.
    let varied = entry.materials.iter().map(|m| m.varied.len()).max().unwrap_or(0);
    let mut random = Pcg64Mcg::new(0xba6e_d5ad);
    let mut points: Vec<(usize, f32, Vec<f32>)> = Vec::new();
    for (index, m) in entry.materials.iter().enumerate() {
        let nominal: Vec<f32> = m.varied.iter().map(|a| a.nominal as f32).collect();
        let mut views = vec![0.0f32, 1.0, -0.5, 2.0, 1e-7];
        for s in &m.segments {
            let mu = s.u_start * s.u_start;
            views.extend([mu, f32::from_bits(mu.to_bits().saturating_sub(1)), f32::from_bits(mu.to_bits() + 1)]);
        }
        points.extend(views.into_iter().map(|mu| (index, mu, nominal.clone())));
        for _ in 0..RANDOM_VIEWS {
            let mu = gpu::uniform_f32(&mut random, 0.0, 1.0);
            let values = m
                .varied
                .iter()
                .map(|a| {
                    let [lo, hi] = a.range;
                    gpu::uniform_f32(&mut random, lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo))
                })
                .collect();
            points.push((index, mu, values));
        }
    }
    let per_point = 2 + varied;
    let inputs: Vec<f32> = points
        .iter()
        .flat_map(|(index, mu, values)| {
            let mut input = vec![*index as f32, *mu];
            input.extend((0..varied).map(|a| values.get(a).copied().unwrap_or(0.0)));
            input
        })
        .collect();
    let arguments: String = (0..varied).map(|a| format!(", inputs[{per_point}u * i + {}u]", 2 + a)).collect();
    let mut body = format!(
        "let r = {FUNCTION}(u32(inputs[{per_point}u * i]), inputs[{per_point}u * i + 1u]{arguments});\n    let o = \
         {stride}u * i;"
    );
    let mut k = 0;
    let mut store = |value: String| {
        body.push_str(&format!("\n    outputs[o + {k}u] = {value};"));
        k += 1;
    };
    for field in ["albedo", "top_albedo"] {
        for c in ["x", "y", "z"] {
            store(format!("r.{field}.{c}"));
        }
    }
    for lobe in 0..max_lobes {
        for c in ["x", "y", "z"] {
            store(format!("r.lobe_energy[{lobe}].{c}"));
        }
        for field in ["lobe_roughness", "lobe_cos", "lobe_gd"] {
            store(format!("r.{field}[{lobe}]"));
        }
    }
    let wgsl = format!("{}{}{}", shader.text(Lang::Wgsl), gpu::BUFFERS, gpu::entry_point("main", per_point, &body));
    let bound = [gpu.upload_array(0, &TextureData::from_table(&table, precision)?)?, gpu.linear_clamp_sampler(1)];
    let on_gpu = gpu.run(&gpu.module(&wgsl), "main", &bound, &inputs, points.len(), points.len() * stride);
    let mut worst = (0.0f32, String::new());
    let (mut beyond, mut not_finite, mut not_zero) = (0, 0, 0);
    for (p, (index, mu, values)) in points.iter().enumerate() {
        let (index, mu) = (*index, *mu);
        let m = &entry.materials[index];
        let got = &on_gpu[p * stride..(p + 1) * stride];
        let expected = sample_array(&table, m, mu, values, Filter::QuantisedWeights { bits: 8 });
        let steps = steps(&table, &entry, m, mu, values);
        for (v, (&g, &e)) in got.iter().zip(&expected).enumerate() {
            let allowed = WEIGHT_TOLERANCE * steps[v] + ABSOLUTE_TOLERANCE;
            if !g.is_finite() {
                not_finite += 1;
            } else if (g - e).abs() > allowed {
                beyond += 1;
            }
            if (g - e).abs() / allowed > worst.0 {
                worst = (
                    (g - e).abs() / allowed,
                    format!("{} at mu {mu}, {values:?}: {} {g} against {e}", m.material, m.values[v]),
                );
            }
        }
        not_zero += got[expected.len()..].iter().filter(|&&g| g != 0.0).count();
    }
    println!(
        "baked shader, WGSL, on the GPU API vs formats::baked::sample_array ({} texels, 8-bit weights): {} (material, \
         view) points of {} materials; largest difference {:.3} of its tolerance ({}); {beyond} beyond, {not_finite} \
         not finite, {not_zero} lobes past a material's own not zero",
        shader.description.texture.format,
        points.len(),
        entry.materials.len(),
        worst.0,
        worst.1
    );
    for (material, cost) in shader.costs() {
        println!("  {material}: {} texture reads, {} operations", cost.texture_reads, cost.operations);
    }
    Ok(beyond == 0 && not_finite == 0 && not_zero == 0)
}

/// The materials of `scenes` (files or folders), named `<scene>/<material>`, baked from exact
/// integrals with the default settings into one array, its texels rounded to `precision`.
fn baked_array(
    scenes: &[PathBuf],
    precision: Precision,
) -> Result<(BakedArrayEntry, Table), Box<dyn std::error::Error>> {
    let exact = ExactTables::new(&Config::default(), tmlut::exact::DEFAULT_NODES)?;
    let settings = BakeSettings::default();
    let mut baked = Vec::new();
    for file in read_scene_files(scenes)? {
        let scene = file.scene;
        for m in &scene.materials {
            baked.push(bake_family(&format!("{}/{}", scene.name, m.name), &m.family(), &exact, &settings)?);
        }
    }
    let arrangement = arrange(&baked.iter().map(|b| b.rows()).collect::<Vec<_>>())?;
    let mut table = baked_table("baked", &baked, &arrangement)?;
    table.data.iter_mut().for_each(|v| *v = precision.round(*v));
    let entries = baked
        .iter()
        .zip(&arrangement.places)
        .map(|(b, &place)| material_entry(b, place, BakedErrors::none("")))
        .collect();
    let entry = array_entry("examples", "exact integrals", settings.tolerance, settings.nodes, &arrangement, entries);
    entry.check(&table)?;
    Ok((entry, table))
}

/// Per value of `m` at `mu` and the varied values `values`: the largest difference of the two
/// texels a linear filter blends there, over the blocks of the nodes around each value.
fn steps(table: &Table, entry: &BakedArrayEntry, m: &BakedMaterialEntry, mu: f32, values: &[f32]) -> Vec<f32> {
    let [width, height] = entry.layer_extent.map(|n| n as usize);
    let (lower, upper, _) = linear_taps(texture_coordinate(&m.segments, mu), width, Filter::Exact);
    let texel = |row: usize, node: usize, c: usize| {
        table.data[((m.layer as usize * height + m.first_row as usize + row) * width + node) * 4 + c]
    };
    // The first row of each block read: the nodes around every value, the first parameter fastest.
    let mut blocks = vec![0usize];
    let mut stride = m.rows as usize;
    for (a, axis) in m.varied.iter().enumerate() {
        let (node, _) = parameter_taps(axis, values.get(a).copied().unwrap_or(axis.nominal as f32));
        blocks = blocks.iter().flat_map(|&b| [b + node * stride, b + (node + 1) * stride]).collect();
        stride *= axis.nodes as usize;
    }
    (0..m.values.len())
        .map(|v| {
            let step = |first: &usize| (texel(first + v / 4, upper, v % 4) - texel(first + v / 4, lower, v % 4)).abs();
            blocks.iter().map(step).fold(0.0f32, f32::max)
        })
        .collect()
}
