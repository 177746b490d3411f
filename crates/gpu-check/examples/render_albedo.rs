//! A renderer's first run of tmlut's scene shader: load a folder built for a scene, upload its
//! tables to wgpu, run each material's function of the generated WGSL in a compute pass, read the
//! directional albedo back, and compare it with tmlut's CPU evaluator.
//!
//! ```sh
//! tmlut build --scene luts/scenes/copper-pot.toml --out out/copper-pot   # tables + shader
//! cargo run --example render_albedo -- out/copper-pot [SHADER_DIR] [--picture DIR]
//! ```
//!
//! `SHADER_DIR` is where `tmlut shader --out` wrote the shader, if not beside the tables. With
//! `--picture DIR`, also draws each material's furnace (`tmlut furnace`'s sphere under a uniform
//! environment, `docs/furnace.md`) on the GPU, the shader evaluated at every pixel's view cosine,
//! beside the CPU evaluator's and their difference: `DIR/<material>_furnace_gpu.png`. Exits
//! non-zero where GPU and CPU differ by more than 1e-5 or the GPU returns a value that is not
//! finite. The wgpu plumbing (device, texture upload, one compute pass) is in `gpu/mod.rs`.

use tmlut_gpu_check as gpu;

use std::process::ExitCode;

use tmlut::loader::{LutFolder, SceneShaderFiles};
use tmlut::model::Material;
use tmlut::model::folder::{FgdSource, FolderTables, LibraryTables};

/// View cosines `mu = k / (VIEWS - 1)` per material.
const VIEWS: usize = 17;
/// Pixels across a furnace picture.
const PICTURE_SIZE: usize = 256;
/// The scene shader computes in f32 what the CPU evaluator computes in f64 (`docs/shaders.md`).
const TOLERANCE: f64 = 1e-5;

fn main() -> ExitCode {
    gpu::exit_code("render_albedo", run())
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let picture_dir = match args.iter().position(|a| a == "--picture") {
        Some(k) if k + 1 < args.len() => Some(args.drain(k..k + 2).nth(1).expect("two drained")),
        Some(_) => return Err("--picture needs a folder".into()),
        None => None,
    };
    let (luts_dir, shader_dir) = match args.as_slice() {
        [luts] => (luts, luts),
        [luts, shader] => (luts, shader),
        _ => return Err("usage: render_albedo LUTS_DIR [SHADER_DIR] [--picture DIR]".into()),
    };
    // Every file is verified against the manifest as it loads (length, SHA-256, shape).
    let luts = LutFolder::open(luts_dir)?;
    let shader = SceneShaderFiles::open(shader_dir)?;
    // A device granting what the description says the shader needs (textures per stage, array
    // layers, texture sizes), as a renderer asks for it beside its own needs.
    let gpu = gpu::Gpu::with_limits(&shader.description.limits)?;
    println!("adapter: {}", gpu.adapter);

    // One texture per table file, created from its texels as stored, at the binding the shader's
    // description gives: a texture array where it is `layered`.
    let mut textures = Vec::new();
    for t in shader.description.textures.iter() {
        textures.push(gpu.upload_bound(t, &luts.texture(&t.file)?)?);
    }
    // Then the constants buffer every function reads, from its file beside the shader.
    if let Some(constants) = &shader.description.constants {
        textures.push(gpu.constants(constants.binding, &shader.constants));
    }

    // The generated WGSL as written, and one entry point per material: A(mu), RGB, per view.
    let mut wgsl = shader.wgsl.clone() + gpu::BUFFERS;
    for m in shader.description.materials.iter() {
        let body = format!(
            "let a = {}(inputs[i]).albedo;\n    outputs[3u * i] = a.x; outputs[3u * i + 1u] = a.y; outputs[3u * i + 2u] = a.z;",
            m.function
        );
        wgsl += &gpu::entry_point(&format!("albedo_{}", m.function), 1, &body);
    }
    let module = gpu.module(&wgsl);
    let views: Vec<f32> = (0..VIEWS).map(|k| k as f32 / (VIEWS - 1) as f32).collect();

    // The CPU evaluator reads the same folder as the shader reads it; the materials are the
    // scene's, as `tmlut build --scene` recorded it in the manifest.
    let record =
        luts.manifest().scene.as_ref().ok_or("the folder records no scene: build it with `tmlut build --scene`")?;
    let scene = tmlut::scene::Scene::from_toml(&record.text, &format!("{luts_dir}/manifest.json"), &record.name)?;
    let materials = tmlut::scene::shader_files::shader_materials(&scene)?;

    let library = LibraryTables::open(&luts, FgdSource::Packing, materials.iter().map(|m| m.reads()))?;
    let (mut on_gpu, mut on_cpu) = (Vec::new(), Vec::new());
    let mut pictures_pass = true;
    for function in shader.description.materials.iter() {
        let albedo = gpu.run(&module, &format!("albedo_{}", function.function), &textures, &views, VIEWS, 3 * VIEWS);
        let index =
            materials.iter().position(|m| m.name == function.material).ok_or("a shader material not in the scene")?;
        let (m, tables) = (&materials[index], library.of(index));
        let cpu = Material::new(m.model, m.stack.clone());
        println!("{} ({}): A(mu) on the GPU, R G B", function.material, function.function);
        for (k, &mu) in views.iter().enumerate() {
            on_cpu.extend(cpu.evaluate(mu as f64, tables).albedo);
            if k % 4 == 0 {
                println!("  mu {mu:.2}: {:.6} {:.6} {:.6}", albedo[3 * k], albedo[3 * k + 1], albedo[3 * k + 2]);
            }
        }
        on_gpu.extend(albedo);
        if let Some(dir) = &picture_dir {
            let entry = format!("albedo_{}", function.function);
            let drawn = draw_furnace(&gpu, &module, &entry, &textures, (&cpu, tables), dir, &function.material)?;
            pictures_pass &= drawn.passes(TOLERANCE);
            println!("  furnace picture: {}", drawn.summary(TOLERANCE));
        }
        // A lookup the folder holds no table for would make the comparison meaningless.
        if let Some(first) = tables.misses().first {
            return Err(format!("material `{}`: the folder holds no table for {first}", function.material).into());
        }
    }
    let comparison = gpu::Comparison::of(&on_gpu, on_cpu);
    println!("albedo, {VIEWS} views x 3 channels per material: {}", comparison.summary(TOLERANCE));
    Ok(comparison.passes(TOLERANCE) && pictures_pass)
}

/// Draws the furnace of one material on the GPU, the albedo entry point run at every pixel's view
/// cosine, beside the CPU evaluator's picture and their difference (`<dir>/<material>_furnace_gpu.png`);
/// returns the comparison of the GPU's albedo with the CPU's over the sphere's pixels.
fn draw_furnace(
    gpu: &gpu::Gpu,
    module: &wgpu::ShaderModule,
    entry: &str,
    textures: &[gpu::Bound],
    (cpu, tables): (&Material, &FolderTables),
    dir: &str,
    material: &str,
) -> Result<gpu::Comparison, Box<dyn std::error::Error>> {
    use tmlut::furnace::picture::{difference_picture, furnace_radiance, radiance_picture, sphere_cosines};

    let cosines = sphere_cosines(PICTURE_SIZE);
    let views: Vec<f32> = cosines.iter().flatten().map(|&mu| mu as f32).collect();
    let albedo = gpu.run(module, entry, textures, &views, views.len(), 3 * views.len());
    let on_cpu: Vec<[f64; 3]> = views.iter().map(|&mu| cpu.evaluate(mu as f64, tables).albedo).collect();
    let comparison = gpu::Comparison::of(&albedo, on_cpu.iter().flatten().copied());

    // Back to pixels: the sphere's in order, the environment around it.
    let (mut gpu_pixels, mut cpu_pixels, mut differences) = (Vec::new(), Vec::new(), Vec::new());
    let mut k = 0;
    for mu in &cosines {
        let (on_gpu, on_cpu) = match mu {
            Some(_) => {
                k += 1;
                let a = &albedo[3 * (k - 1)..3 * k];
                (Some([a[0] as f64, a[1] as f64, a[2] as f64]), Some(on_cpu[k - 1]))
            }
            None => (None, None),
        };
        let (g, c) = (furnace_radiance(on_gpu), furnace_radiance(on_cpu));
        differences.push((0..3).map(|i| (g[i] - c[i]).abs()).sum::<f64>() / 3.0);
        gpu_pixels.push(g);
        cpu_pixels.push(c);
    }
    let (heat, bar) = difference_picture("|GPU - CPU|, mean of R, G, B", PICTURE_SIZE, &differences);
    std::fs::create_dir_all(dir)?;
    tmlut::report::plot::images_png(
        &std::path::Path::new(dir).join(format!("{}_furnace_gpu.png", tmlut::furnace::report::file_stem(material))),
        &format!(
            "{material}: furnace of radiance {}, the scene shader on the GPU at every pixel",
            tmlut::furnace::ENVIRONMENT_RADIANCE
        ),
        &[
            radiance_picture("GPU (scene shader, WGSL)", PICTURE_SIZE, &gpu_pixels),
            radiance_picture("CPU evaluator", PICTURE_SIZE, &cpu_pixels),
            heat,
        ],
        Some(&bar),
    )?;
    Ok(comparison)
}
