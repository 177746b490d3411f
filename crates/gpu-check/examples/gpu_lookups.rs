//! The default build's lookup shaders on wgpu, against the library's own evaluation, at random
//! points:
//!
//! - `fgd_lossless.wgsl` reading `fgd_lossless.dds`, against 4D multilinear interpolation of
//!   `fgd.exr` (`FgdLut::sample`);
//! - `tir_fit.wgsl`, against the fitted form evaluated in f64 from the definition and the
//!   coefficients in the manifest (`FormEvaluator::from_definition`).
//!
//! ```sh
//! tmlut build --out out/luts      # or --only fgd,tir
//! cargo run --example gpu_lookups -- luts
//! ```
//!
//! Each shader file is the one the manifest lists, verified against its SHA-256. Exits non-zero
//! beyond the tolerances below or on a value that is not finite.

use tmlut_gpu_check as gpu;

use std::process::ExitCode;

use rand_pcg::Pcg64Mcg;
use tmlut::fit::forms::FormEvaluator;
use tmlut::loader::{Alpha, FgdLut, LutFolder};

use gpu::Comparison;

/// Random points per shader.
const POINTS: usize = 16_384;
/// The lossless lookup interpolates the same texels in f32 (`docs/packing.md`), from texture
/// coordinates it computes in f32 (for the asinh-spaced `eta` and `kappa` axes with the odd
/// symmetry that keeps `log(|y| + sqrt(y * y + 1))` from cancelling).
const FGD_TOLERANCE: f64 = 1e-6;
/// The fitted form in f32 on the GPU against f64 on the CPU; WGSL allows its transcendental
/// functions a few ulp more than correct rounding.
const TIR_FIT_TOLERANCE: f64 = 1e-5;

fn main() -> ExitCode {
    gpu::exit_code("gpu_lookups", run())
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [luts_dir] = args.as_slice() else {
        return Err("usage: gpu_lookups LUTS_DIR (a folder of `tmlut build`, with fgd and tir)".into());
    };
    let luts = LutFolder::open(luts_dir)?;
    let gpu = gpu::Gpu::new()?;
    println!("adapter: {}", gpu.adapter);
    let mut random = Pcg64Mcg::new(0x7e1e_c0de);
    let mut uniform = move |range: [f64; 2]| gpu::uniform_f32(&mut random, range[0], range[1]);
    let fgd_ok = check_fgd(&gpu, &luts, &mut uniform)?;
    let tir_ok = check_tir_fit(&gpu, &luts, &mut uniform)?;
    Ok(fgd_ok && tir_ok)
}

/// `fgd_lossless.wgsl` at random `(mu, alpha, eta, kappa)` over the 4D table's ranges.
fn check_fgd(
    gpu: &gpu::Gpu,
    luts: &LutFolder,
    uniform: &mut impl FnMut([f64; 2]) -> f32,
) -> Result<bool, Box<dyn std::error::Error>> {
    let fgd = FgdLut::from_folder(luts)?; // fgd.exr: the 4D table itself
    let (file, packing) = luts
        .manifest()
        .files
        .iter()
        .find_map(|(file, e)| e.packing.as_ref().filter(|p| p.name == "lossless").map(|p| (file, p)))
        .ok_or("the folder has no lossless FGD packing (fgd_lossless.dds)")?;
    let lookup = packing.shaders.iter().find(|s| s.language == "wgsl").ok_or("the packing lists no WGSL lookup")?;
    let texture = gpu.upload(0, &luts.texture(file)?)?;
    let wgsl = format!(
        "{}\n@group(0) @binding(0) var fgd_texture: texture_3d<f32>;\n{}{}",
        luts.shader(lookup)?,
        gpu::BUFFERS,
        gpu::entry_point(
            "main",
            4,
            &format!(
                "outputs[i] = {}(fgd_texture, inputs[4u * i], inputs[4u * i + 1u], inputs[4u * i + 2u], inputs[4u * i + 3u]);",
                lookup.function
            )
        )
    );
    let ranges: Vec<[f64; 2]> = fgd.table().axes.iter().map(|a| [a.start, a.end]).collect();
    let points: Vec<f32> = (0..POINTS).flat_map(|_| ranges.iter().map(|&r| uniform(r)).collect::<Vec<_>>()).collect();
    let on_gpu = gpu.run(&gpu.module(&wgsl), "main", &[texture], &points, POINTS, POINTS);
    let on_cpu = points.chunks_exact(4).map(|p| fgd.sample(p[0], Alpha(p[1]), p[2], p[3]) as f64);
    let comparison = Comparison::of(&on_gpu, on_cpu);
    println!("{} over {file} vs fgd.exr interpolated: {}", lookup.file, comparison.summary(FGD_TOLERANCE));
    Ok(comparison.passes(FGD_TOLERANCE))
}

/// `tir_fit.wgsl` at random `(mu, alpha, eta)` in `[0, 1]^3`, the domain the form is fitted over
/// (`docs/fit.md`).
fn check_tir_fit(
    gpu: &gpu::Gpu,
    luts: &LutFolder,
    uniform: &mut impl FnMut([f64; 2]) -> f32,
) -> Result<bool, Box<dyn std::error::Error>> {
    let fit = luts
        .manifest()
        .files
        .values()
        .find_map(|e| e.fit.as_ref())
        .ok_or("the folder has no fitted TIR form ([tir] fit = \"best\")")?;
    let form = FormEvaluator::from_definition(&fit.definition, &fit.parameter_names, &fit.parameters)
        .map_err(|e| format!("the fitted form `{}`: {e}", fit.form))?;
    let function = fit.shaders.iter().find(|s| s.language == "wgsl").ok_or("the fit lists no WGSL function")?;
    let points: Vec<f32> = (0..3 * POINTS).map(|_| uniform([0.0, 1.0])).collect();
    let on_gpu = gpu.run_form(&luts.shader(function)?, &function.function, 3, 1, &points);
    let on_cpu = points.chunks_exact(3).map(|p| form.eval_f64(&[p[0] as f64, p[1] as f64, p[2] as f64]));
    let comparison = Comparison::of(&on_gpu, on_cpu);
    println!(
        "{} ({}) vs the form in f64 from the manifest's definition and coefficients: {}",
        function.file,
        fit.form,
        comparison.summary(TIR_FIT_TOLERANCE)
    );
    Ok(comparison.passes(TIR_FIT_TOLERANCE))
}
