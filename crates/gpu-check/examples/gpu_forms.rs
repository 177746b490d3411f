//! Forms fitted by `tmlut fit --form` on wgpu: each output folder's WGSL function at random points
//! over the region the form was fitted over (the table's range of each variable, narrowed by the
//! `--range`s fit.json records), every channel against the CPU's evaluation of the same form from
//! fit.json's definition and parameters (`FormEvaluator::from_definition`). The function is passed
//! its arguments as fit.json's `shader_arguments` say: a variable as drawn, `roughness` as the f32
//! square root of alpha, alpha being first moved to the square of that root, so that the function
//! (which squares a roughness argument where the form reads alpha) and the CPU (which takes the
//! square root where it reads roughness) compute from the same numbers:
//!
//! - in f32, the shader's operations in its order: held to [`TOLERANCE`];
//! - in f64: printed, the f32 rounding of the shader and the CPU together.
//!
//! ```sh
//! tmlut fit --form luts/forms --table out/luts/tir.dds --out fits/tir
//! tmlut fit --form luts/forms/karis-env-brdf-approx.toml --table out/luts/karis.dds --out fits/karis
//! cargo run --example gpu_forms -- --expect 9 fits/tir fits/karis
//! ```
//!
//! Each argument is a fit's output folder (holding fit.json) or a folder of them (`--form DIR`).
//! Exits non-zero beyond the tolerance, on a value that is not finite on the GPU or the CPU, when
//! no form is found, or when `--expect N` is given and N forms are not.

use tmlut_gpu_check as gpu;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use rand_pcg::Pcg64Mcg;
use serde::Deserialize;
use tmlut::fit::forms::{FormEvaluator, Range, Region, WeightsSpec};
use tmlut::loader::LutFolder;

use gpu::Comparison;

/// Random points per form.
const POINTS: usize = 10_000;
/// The GPU against the CPU computing the same f32 operations: what is left is the difference of
/// their transcendental functions (WGSL allows a few ulp more than correct rounding) and the
/// intermediate roundings a GPU compiler fuses away (SPIR-V allows it for an operation not marked
/// NoContraction, naga marks none, and Mesa's lavapipe does), a few ulp of values of order 1.
///
/// Where a form amplifies rounding (a difference that cancels, then divides by a small width;
/// `1 - c^2` near `c = 1`), one ulp apart in an operation is more than this apart in the value,
/// and the CPU's own f32 evaluation is as far from f64 by the same amplification. There a channel
/// is held instead by its largest difference from the f64 evaluation over the points: no larger
/// than the largest of the CPU's f32 evaluation, plus this tolerance (the GPU rounds differently,
/// and over the form no worse). A rule over the form, not point by point: at a point where the
/// CPU's f32 happens to land near f64, a GPU one ulp apart in a step the form amplifies is farther.
/// The output says which rule a channel passed by.
const TOLERANCE: f64 = 1e-6;

/// The parts of fit.json this reads.
#[derive(Deserialize)]
struct Fit {
    form: String,
    table_file: PathBuf,
    variables: Vec<String>,
    channels: Vec<String>,
    definition: Vec<String>,
    parameters: BTreeMap<String, f64>,
    parameter_order: Vec<String>,
    ranges: Vec<Range>,
    shader_function: String,
    /// Empty in a fit.json written before the arguments were recorded: the variables then.
    #[serde(default)]
    shader_arguments: Vec<Argument>,
    files: Vec<String>,
}

/// An argument of the form's function and the quantity it carries.
#[derive(Deserialize)]
struct Argument {
    axis: String,
}

/// The point (the variables' values) moved where the function's arguments carry it exactly, and
/// those arguments: each variable as it is, `roughness` the f32 square root of alpha, alpha then
/// that root squared (the f32 square root of an f32 square is the number squared).
fn arguments_at(fit: &Fit, point: &mut [f32]) -> Result<Vec<f32>, String> {
    if fit.shader_arguments.is_empty() {
        return Ok(point.to_vec());
    }
    let index =
        |name: &str| fit.variables.iter().position(|v| v == name).ok_or(format!("{}: no variable `{name}`", fit.form));
    let mut arguments = Vec::with_capacity(fit.shader_arguments.len());
    for argument in &fit.shader_arguments {
        if argument.axis == "roughness" {
            let alpha = index("alpha")?;
            let roughness = point[alpha].sqrt();
            point[alpha] = roughness * roughness;
            arguments.push(roughness);
        } else {
            arguments.push(point[index(&argument.axis)?]);
        }
    }
    Ok(arguments)
}

fn main() -> ExitCode {
    gpu::exit_code("gpu_forms", run())
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let expected = match args.iter().position(|a| a == "--expect") {
        Some(k) => {
            let count = args.get(k + 1).and_then(|n| n.parse::<usize>().ok()).ok_or("--expect takes a count")?;
            args.drain(k..k + 2);
            Some(count)
        }
        None => None,
    };
    if args.is_empty() {
        return Err("usage: gpu_forms [--expect N] FIT_DIR... (folders written by `tmlut fit --form`)".into());
    }
    let mut folders = Vec::new();
    for arg in &args {
        folders.extend(fit_folders(Path::new(arg))?);
    }
    if folders.is_empty() || expected.is_some_and(|n| n != folders.len()) {
        return Err(format!(
            "{} fitted forms under {}; expected {}",
            folders.len(),
            args.join(", "),
            expected.map_or("at least one".to_string(), |n| n.to_string())
        )
        .into());
    }
    let gpu = gpu::Gpu::new()?;
    println!("adapter: {}; {POINTS} random points per form", gpu.adapter);
    let mut random = Pcg64Mcg::new(0x7e1e_c0de);
    let mut all_pass = true;
    for folder in &folders {
        all_pass &= check_form(&gpu, folder, &mut random)?;
    }
    println!("{} forms checked: {}", folders.len(), if all_pass { "all pass" } else { "FAILED" });
    Ok(all_pass)
}

/// `path` itself where it holds fit.json, otherwise its folders that do, in name order.
fn fit_folders(path: &Path) -> Result<Vec<PathBuf>, Box<dyn std::error::Error>> {
    if path.join("fit.json").is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    let mut folders: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .map(|entry| entry.map(|e| e.path()))
        .collect::<Result<Vec<_>, _>>()?;
    folders.retain(|f| f.join("fit.json").is_file());
    folders.sort();
    Ok(folders)
}

/// One fitted form: its WGSL on the GPU against the CPU, channel by channel.
fn check_form(gpu: &gpu::Gpu, folder: &Path, random: &mut Pcg64Mcg) -> Result<bool, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(folder.join("fit.json"))?;
    let fit: Fit = serde_json::from_str(&text).map_err(|e| format!("{}/fit.json: {e}", folder.display()))?;
    let parameters = (fit.parameter_order.iter())
        .map(|p| fit.parameters.get(p).copied().ok_or(format!("{}: no value of parameter `{p}`", fit.form)))
        .collect::<Result<Vec<f64>, String>>()?;
    let form = FormEvaluator::from_definition(&fit.definition, &fit.parameter_order, &parameters)
        .map_err(|e| format!("{}: {e}", fit.form))?;
    let extent = fitted_extent(&fit)?;
    let wgsl_file = fit.files.iter().find(|f| f.ends_with(".wgsl")).ok_or("fit.json lists no WGSL file")?;
    let wgsl = std::fs::read_to_string(folder.join(wgsl_file))?;

    let mut points: Vec<f32> = (0..POINTS)
        .flat_map(|_| extent.iter().map(|&(lo, hi)| gpu::uniform_f32(random, lo, hi)).collect::<Vec<_>>())
        .collect();
    let (variables, channels) = (fit.variables.len(), fit.channels.len());
    let mut arguments = Vec::with_capacity(points.len());
    for point in points.chunks_exact_mut(variables) {
        arguments.extend(arguments_at(&fit, point)?);
    }
    let arity = arguments.len() / POINTS;
    let on_gpu = gpu.run_form(&wgsl, &fit.shader_function, arity, channels, &arguments);
    let on_f32: Vec<f32> = points.chunks_exact(variables).flat_map(|p| form.channels(p)).collect();
    let on_f64: Vec<f64> = points
        .chunks_exact(variables)
        .flat_map(|p| form.channels(&p.iter().map(|&v| f64::from(v)).collect::<Vec<_>>()))
        .collect();

    let ranges: Vec<String> =
        fit.variables.iter().zip(&extent).map(|(v, (lo, hi))| format!("{v} in [{lo}, {hi}]")).collect();
    println!("{wgsl_file} ({}), over {}:", folder.display(), ranges.join(", "));
    let mut passes = true;
    for (c, channel) in fit.channels.iter().enumerate() {
        let of_channel = |values: &[f32]| values.iter().skip(c).step_by(channels).copied().collect::<Vec<f32>>();
        let (gpu_values, cpu_f32) = (of_channel(&on_gpu), of_channel(&on_f32));
        let cpu_f64: Vec<f64> = on_f64.iter().skip(c).step_by(channels).copied().collect();
        let against_f32 = Comparison::of(&gpu_values, cpu_f32.iter().map(|&v| f64::from(v)));
        let against_f64 = Comparison::of(&gpu_values, cpu_f64.iter().copied());
        let f32_rounding = Comparison::of(&cpu_f32, cpu_f64.iter().copied());
        let beyond = gpu_values.iter().zip(&cpu_f32).filter(|&(&g, &c)| f64::from((g - c).abs()) > TOLERANCE).count();
        let at = |comparison: &Comparison| {
            let point = &points[comparison.worst_at * variables..][..variables];
            let named: Vec<String> = fit.variables.iter().zip(point).map(|(v, x)| format!("{v} {x}")).collect();
            named.join(", ")
        };
        println!(
            "  {channel}: max |GPU - CPU f32| {:.2e} at ({}); {beyond} of {} values beyond {TOLERANCE:e}, {} not finite",
            against_f32.worst,
            at(&against_f32),
            against_f32.values,
            against_f32.not_finite
        );
        println!(
            "  {channel}: max |GPU - CPU f64| {:.2e} at ({}); max |CPU f32 - CPU f64| {:.2e} at ({})",
            against_f64.worst,
            at(&against_f64),
            f32_rounding.worst,
            at(&f32_rounding)
        );
        let verdict = if against_f32.passes(TOLERANCE) {
            "pass: within the tolerance of CPU f32"
        } else if against_f64.passes(f32_rounding.worst + TOLERANCE) {
            "pass, ill-conditioned: beyond the tolerance of CPU f32; max |GPU - CPU f64| within \
             max |CPU f32 - CPU f64| plus the tolerance"
        } else {
            "FAIL"
        };
        println!("  {channel}: {verdict}");
        passes &= !verdict.starts_with("FAIL");
    }
    Ok(passes)
}

/// The box of the form's variables the fit's points lie in: its table's ranges narrowed by the
/// fit's `--range`s, as the fit resolved them.
fn fitted_extent(fit: &Fit) -> Result<Vec<(f64, f64)>, Box<dyn std::error::Error>> {
    let table_folder = fit.table_file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let table_name =
        fit.table_file.file_name().and_then(|n| n.to_str()).ok_or("fit.json's table_file names no file")?;
    let table = LutFolder::open(table_folder)?.load(table_name)?;
    let region = Region::new(&fit.ranges, &WeightsSpec::Uniform, None, &table, &fit.variables)?;
    Ok(region.extent(&table, &fit.variables))
}
