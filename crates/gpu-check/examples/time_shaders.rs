//! The cost of the baked shader against the scene shader it replaces, in time on whatever adapter
//! wgpu finds: each material of a folder built with `tmlut build --scene ... --bake`, evaluated by
//! its scene shader function (the transfer-matrix model over the folder's tables) and by its baked
//! function (a few filtered reads of the baked array), over a grid of compute invocations.
//!
//! ```sh
//! tmlut build --scene luts/scenes/thesis/layers.toml --out out/layers --bake
//! cargo run --release -p tmlut-gpu-check --example time_shaders -- out/layers [SHADER_DIR] \
//!     [--width 3840] [--height 2160] [--runs 9]
//! ```
//!
//! `SHADER_DIR` is where `tmlut shader --out` wrote the scene shader, if not beside the tables (the
//! baked shader is always the folder's). Each invocation `(x, y)` of the `--width` x `--height`
//! grid (3840 x 2160 by default, in workgroups of 8 x 8) evaluates one material at the view cosine
//! `mu = (x + 0.5) / width` (a material whose textures vary parameters, its baked function at their
//! nominal values, as its scene shader function evaluates it) and writes the sum of every value of
//! its `TmResult` to a storage buffer,
//! so that no part of either shader is left out by the compiler. Every pipeline is compiled, and
//! every table uploaded, before any dispatch is timed. Per material and shader, one warm-up
//! dispatch (whose output is read back: every invocation must have written a finite value), then
//! `--runs` dispatches, the two shaders' alternating so that a change in the machine's load falls on
//! both. Each dispatch is timed by the wall clock around its submission and the device poll that
//! waits for it, and, where the adapter has timestamp queries, by timestamps written at the start
//! and end of its compute pass; the ratio is of the GPU times where there are timestamps, else of
//! the wall times. Prints the adapter (name, backend, device type, driver), the time of the grid
//! alone (each invocation writing its `mu`: what a dispatch costs before any material), and a table
//! of the medians per material, the texture reads and operations each function costs (its
//! description's `cost`) and the ratio, with each model's materials summed. Exits non-zero where
//! an invocation wrote a value that is not finite; a tiny grid (`--width 64 --height 16 --runs 1`)
//! is that check alone, which `scripts/gpu-check` runs.

use tmlut_gpu_check as gpu;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use tmlut::loader::shader::{BAKED_DESCRIPTION_SUFFIX, BakedShaderDescription, SceneShaderFiles, ShaderCost};
use tmlut::loader::{BakedLut, LutFolder, sha256_hex};
use tmlut_loader::formats::manifest::check_file_name;

/// The grid a renderer shades at 4K, one invocation a pixel.
const DEFAULT_GRID: [u32; 2] = [3840, 2160];
const DEFAULT_RUNS: usize = 9;
/// The workgroup's side: 8 x 8 invocations, 64 as the other examples' workgroups.
const WORKGROUP_SIDE: u32 = 8;

fn main() -> ExitCode {
    gpu::exit_code("time_shaders", run())
}

struct Options {
    luts: PathBuf,
    shader: PathBuf,
    grid: [u32; 2],
    runs: usize,
}

fn options() -> Result<Options, String> {
    const USAGE: &str = "usage: time_shaders LUTS_DIR [SHADER_DIR] [--width N] [--height N] [--runs N]";
    let mut folders = Vec::new();
    let (mut grid, mut runs) = (DEFAULT_GRID, DEFAULT_RUNS);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut count = |name: &str| -> Result<usize, String> {
            let value = args.next().ok_or(format!("{name} takes a number; {USAGE}"))?;
            match value.parse::<usize>() {
                Ok(n) if n > 0 => Ok(n),
                _ => Err(format!("{name} takes a whole number above 0, not `{value}`")),
            }
        };
        match arg.as_str() {
            "--width" => grid[0] = u32::try_from(count("--width")?).map_err(|_| "--width is too large")?,
            "--height" => grid[1] = u32::try_from(count("--height")?).map_err(|_| "--height is too large")?,
            "--runs" => runs = count("--runs")?,
            other if other.starts_with("--") => return Err(format!("unknown option `{other}`; {USAGE}")),
            _ => folders.push(PathBuf::from(arg)),
        }
    }
    let (luts, shader) = match folders.as_slice() {
        [luts] => (luts.clone(), luts.clone()),
        [luts, shader] => (luts.clone(), shader.clone()),
        _ => return Err(USAGE.into()),
    };
    Ok(Options { luts, shader, grid, runs })
}

/// One shader's function of a material, ready to dispatch: its pipeline and the group of the
/// tables it reads (group 1, the output, is the same for all).
struct Dispatch {
    pipeline: wgpu::ComputePipeline,
    textures: wgpu::BindGroup,
}

/// A dispatch's time, in ms: by the wall clock, and between timestamps where the device writes
/// them.
#[derive(Debug, Clone, Copy, Default)]
struct Time {
    wall: f64,
    gpu: Option<f64>,
}

impl Time {
    /// The time compared: the GPU's where there is one.
    fn compared(&self) -> f64 {
        self.gpu.unwrap_or(self.wall)
    }

    /// The median of each clock over `times`.
    fn median(times: &[Time]) -> Time {
        let gpu: Option<Vec<f64>> = times.iter().map(|t| t.gpu).collect();
        Time { wall: median(times.iter().map(|t| t.wall).collect()), gpu: gpu.map(median) }
    }

    fn sum(times: impl IntoIterator<Item = Time>) -> Time {
        times.into_iter().fold(Time { wall: 0.0, gpu: Some(0.0) }, |a, b| Time {
            wall: a.wall + b.wall,
            gpu: a.gpu.zip(b.gpu).map(|(a, b)| a + b),
        })
    }
}

impl std::fmt::Display for Time {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.gpu {
            Some(gpu) => write!(f, "{gpu:.3} ({:.3})", self.wall),
            None => write!(f, "{:.3}", self.wall),
        }
    }
}

/// A material timed both ways.
struct Timed {
    material: String,
    model: String,
    lobes: usize,
    /// The scene shader's function, then the baked one's.
    costs: [ShaderCost; 2],
    times: [Time; 2],
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    let options = options()?;
    let luts = LutFolder::open(&options.luts)?;
    let scene_shader = SceneShaderFiles::open(&options.shader)?;
    let baked = BakedLut::from_folder(&luts)?;
    let baked_description: BakedShaderDescription =
        serde_json::from_str(&baked_shader_file(&luts, &baked, BAKED_DESCRIPTION_SUFFIX)?)?;
    let baked_wgsl = baked_shader_file(&luts, &baked, ".baked.wgsl")?;

    let gpu = gpu::Gpu::for_timing()?;
    let info = &gpu.info;
    println!(
        "adapter: {}; backend {:?}; device type {:?}; driver {} ({})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    );
    let [width, height] = options.grid;
    let invocations = width as u64 * height as u64;
    let output_bytes = invocations * size_of::<f32>() as u64;
    let limits = gpu.device.limits();
    let largest = (limits.max_storage_buffer_binding_size as u64).min(limits.max_buffer_size);
    if output_bytes > largest {
        return Err(format!(
            "a grid of {width} x {height} writes {output_bytes} bytes, more than this device binds as one storage \
             buffer ({largest}); ask for a smaller --width or --height"
        )
        .into());
    }
    let workgroups = [width.div_ceil(WORKGROUP_SIDE), height.div_ceil(WORKGROUP_SIDE)];
    if workgroups.iter().any(|&n| n > limits.max_compute_workgroups_per_dimension) {
        return Err(format!(
            "a grid of {width} x {height} takes {} x {} workgroups, more than this device dispatches along one axis \
             ({})",
            workgroups[0], workgroups[1], limits.max_compute_workgroups_per_dimension
        )
        .into());
    }

    // Pairs of the scene shader's and the baked shader's functions of one material.
    let mut pairs = Vec::new();
    let mut not_baked = Vec::new();
    for m in scene_shader.description.materials.iter() {
        match baked_description.materials.iter().find(|b| b.material == m.material) {
            Some(b) => pairs.push((m, b)),
            None => not_baked.push(m.material.as_str()),
        }
    }
    if pairs.is_empty() {
        return Err(format!(
            "no material of the scene shader in {} is baked in {}: bake the folder built for that scene (tmlut \
             build --scene ... --bake, or tmlut bake)",
            options.shader.display(),
            options.luts.display()
        )
        .into());
    }

    // Every table uploaded and every pipeline compiled before the first dispatch.
    let output = gpu.buffer(
        output_bytes,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
    );
    let output_layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[gpu::storage_entry(0, false)],
    });
    let output_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &output_layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: output.as_entire_binding() }],
    });
    let scene_functions: Vec<(&str, String)> =
        pairs.iter().map(|(m, _)| (m.function.as_str(), String::new())).collect();
    // A material whose textures vary parameters, at their nominal values, as its scene shader
    // function evaluates it.
    let baked_functions: Vec<(&str, String)> = pairs
        .iter()
        .map(|(_, b)| {
            let nominal = b.parameters.iter().map(|p| format!(", {}", tmlut::shader::literal(p.nominal as f32)));
            (b.function.as_str(), nominal.collect())
        })
        .collect();
    let scene_module = gpu.module(
        &(scene_shader.wgsl.clone()
            + &timing_entry_points(&scene_functions, scene_shader.description.max_lobes, options.grid)),
    );
    let baked_module =
        gpu.module(&(baked_wgsl + &timing_entry_points(&baked_functions, baked_description.max_lobes, options.grid)));
    let baked_tables = [
        gpu.upload_array(baked_description.texture.binding, &baked.texture()?)?,
        gpu.linear_clamp_sampler(baked_description.sampler.binding),
    ];
    let (baked_layout, baked_group) = gpu.texture_group(&baked_tables);
    let baked_dispatch = |entry: &str| Dispatch {
        pipeline: gpu.compute_pipeline(&baked_module, entry, &[&baked_layout, &output_layout]),
        textures: baked_group.clone(),
    };
    let grid_alone = baked_dispatch(GRID_ALONE);
    let mut dispatches = Vec::new();
    for (m, b) in &pairs {
        // A material binds only the tables its function reads, as a renderer's pipeline of it would.
        let mut tables = Vec::new();
        for t in scene_shader.description.textures.iter().filter(|t| m.textures.contains(&t.binding)) {
            tables.push(gpu.upload_bound(t, &luts.texture(&t.file)?)?);
        }
        // And the constants, which every function of the scene shader reads.
        if let Some(constants) = &scene_shader.description.constants {
            tables.push(gpu.constants(constants.binding, &scene_shader.constants));
        }
        let (layout, textures) = gpu.texture_group(&tables);
        let scene = Dispatch {
            pipeline: gpu.compute_pipeline(&scene_module, &entry_point(&m.function), &[&layout, &output_layout]),
            textures,
        };
        dispatches.push([scene, baked_dispatch(&entry_point(&b.function))]);
    }

    println!(
        "grid: {width} x {height} invocations ({invocations}) in workgroups of {WORKGROUP_SIDE} x {WORKGROUP_SIDE}, \
         each one material at mu = (x + 0.5) / {width}, its whole TmResult summed into one f32 written to a storage \
         buffer"
    );
    let timer = Timer::new(&gpu);
    println!(
        "timed: {}; the median of --runs {} per material and shader after one warm-up, the shaders alternating",
        match &timer.timestamps {
            Some(_) =>
                "timestamp queries at the start and end of each compute pass (GPU ms), and the wall clock \
                        around submit and device poll (wall ms); the ratio of GPU times",
            None => "the wall clock around submit and device poll (wall ms; the adapter has no timestamp queries)",
        },
        options.runs
    );
    let time = |dispatch: &Dispatch| timer.time(&gpu, dispatch, &output_group, workgroups);
    time(&grid_alone);
    let floor: Vec<Time> = (0..options.runs).map(|_| time(&grid_alone)).collect();
    let floor = Time::median(&floor);
    println!(
        "the grid alone (each invocation writes its mu, no material): {}",
        match floor.gpu {
            Some(gpu) => format!("{gpu:.3} GPU ms ({:.3} wall ms)", floor.wall),
            None => format!("{:.3} wall ms", floor.wall),
        }
    );
    let mut all_finite = true;
    let mut timed = Vec::new();
    for ((m, b), pair) in pairs.iter().zip(&dispatches) {
        for (shader, dispatch) in ["scene", "baked"].iter().zip(pair) {
            // Unwritten values read as NaN: the warm-up must write every one of them.
            gpu.queue.write_buffer(&output, 0, &f32::NAN.to_le_bytes().repeat(invocations as usize));
            time(dispatch);
            let not_finite = timer.not_finite(&gpu, &output, output_bytes);
            if not_finite > 0 {
                println!("{}: the {shader} shader wrote {not_finite} values that are not finite", m.material);
                all_finite = false;
            }
        }
        let mut samples: [Vec<Time>; 2] = Default::default();
        for _ in 0..options.runs {
            for (k, dispatch) in pair.iter().enumerate() {
                samples[k].push(time(dispatch));
            }
        }
        timed.push(Timed {
            material: m.material.clone(),
            model: m.model.clone(),
            lobes: m.lobes,
            costs: [m.cost, b.cost],
            times: samples.map(|s| Time::median(&s)),
        });
    }
    print!("{}", table(&timed));
    if !not_baked.is_empty() {
        println!("not baked, not timed: {}", not_baked.join(", "));
    }
    Ok(all_finite)
}

/// The text of the baked shader's file ending in `suffix`, as the folder's baked array lists it,
/// verified against its stated length and SHA-256.
fn baked_shader_file(luts: &LutFolder, baked: &BakedLut, suffix: &str) -> Result<String, String> {
    let listed = baked.baked().shader_files.iter().find(|f| f.file.ends_with(suffix)).ok_or_else(|| {
        format!(
            "{}: the baked array {} lists no baked shader (`*{suffix}`): bake the folder again (tmlut bake)",
            luts.dir().display(),
            baked.file()
        )
    })?;
    check_file_name(&listed.file).map_err(|reason| format!("{}: {reason}", luts.dir().display()))?;
    let path = luts.dir().join(&listed.file);
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    if bytes.len() as u64 != listed.bytes || sha256_hex(&bytes) != listed.sha256 {
        return Err(format!("{}: differs from its entry in the folder's manifest (length or SHA-256)", path.display()));
    }
    String::from_utf8(bytes).map_err(|_| format!("{}: is not UTF-8 text", path.display()))
}

/// The entry point that times material function `function`.
fn entry_point(function: &str) -> String {
    format!("timing_{function}")
}

/// WGSL appended to a shader module defining `functions` (each `(mu: f32, ...) -> TmResult`, called
/// with `mu` and the WGSL arguments after it, each beginning `, `): the
/// output buffer in group 1, per function an entry point over the grid writing the sum of its
/// result's values, and [`GRID_ALONE`]. The names begin `timing_`, which neither generated shader
/// uses.
fn timing_entry_points(functions: &[(&str, String)], max_lobes: usize, [width, height]: [u32; 2]) -> String {
    let mut sum = String::from("dot(r.albedo, vec3<f32>(1.0)) + dot(r.top_albedo, vec3<f32>(1.0))");
    for lobe in 0..max_lobes {
        sum += &format!(
            "\n        + dot(r.lobe_energy[{lobe}], vec3<f32>(1.0)) + r.lobe_roughness[{lobe}] + r.lobe_cos[{lobe}] + \
             r.lobe_gd[{lobe}]"
        );
    }
    let mut wgsl = format!(
        "
@group(1) @binding(0) var<storage, read_write> timing_output: array<f32>;

fn timing_sum(r: TmResult) -> f32 {{
    return {sum};
}}
"
    );
    // The grid alone: the view written as it is, no material evaluated.
    let calls = functions.iter().map(|(f, arguments)| (entry_point(f), format!("timing_sum({f}(mu{arguments}))")));
    for (entry, value) in calls.chain([(GRID_ALONE.to_owned(), "mu".to_owned())]) {
        wgsl += &format!(
            "
@compute @workgroup_size({WORKGROUP_SIDE}, {WORKGROUP_SIDE})
fn {entry}(@builtin(global_invocation_id) id: vec3<u32>) {{
    if (id.x >= {width}u || id.y >= {height}u) {{ return; }}
    let mu = (f32(id.x) + 0.5) / {width}.0;
    timing_output[id.y * {width}u + id.x] = {value};
}}
"
        );
    }
    wgsl
}

/// The entry point that writes each invocation's view and evaluates nothing: what a dispatch costs
/// before any material.
const GRID_ALONE: &str = "timing_grid_alone";

/// Times dispatches: by the wall clock, and by timestamps where the device writes them.
struct Timer {
    timestamps: Option<Timestamps>,
}

struct Timestamps {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
}

impl Timer {
    fn new(gpu: &gpu::Gpu) -> Self {
        let timestamps = gpu.timestamps.then(|| {
            let bytes = 2 * wgpu::QUERY_SIZE as u64;
            Timestamps {
                queries: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: None,
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolved: gpu.buffer(bytes, wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
                readback: gpu.buffer(bytes, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
                period: gpu.queue.get_timestamp_period() as f64,
            }
        });
        Timer { timestamps }
    }

    /// One dispatch of `dispatch` over `workgroups`, timed; the command buffer is recorded before
    /// the clock starts.
    fn time(&self, gpu: &gpu::Gpu, dispatch: &Dispatch, output: &wgpu::BindGroup, workgroups: [u32; 2]) -> Time {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let timestamp_writes = self.timestamps.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes });
            pass.set_pipeline(&dispatch.pipeline);
            pass.set_bind_group(0, &dispatch.textures, &[]);
            pass.set_bind_group(1, output, &[]);
            pass.dispatch_workgroups(workgroups[0], workgroups[1], 1);
        }
        if let Some(t) = &self.timestamps {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolved, 0);
            encoder.copy_buffer_to_buffer(&t.resolved, 0, &t.readback, 0, t.resolved.size());
        }
        let commands = encoder.finish();
        let start = Instant::now();
        gpu.queue.submit([commands]);
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).expect("the GPU finishes the dispatch");
        let wall = start.elapsed().as_secs_f64() * 1e3;
        let gpu_ms = self.timestamps.as_ref().map(|t| {
            let bytes = gpu.read_back(&t.readback);
            let tick = |k: usize| u64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().expect("8 bytes"));
            tick(1).saturating_sub(tick(0)) as f64 * t.period * 1e-6
        });
        Time { wall, gpu: gpu_ms }
    }

    /// The values of `output` that are not finite.
    fn not_finite(&self, gpu: &gpu::Gpu, output: &wgpu::Buffer, bytes: u64) -> usize {
        let readback = gpu.buffer(bytes, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(output, 0, &readback, 0, bytes);
        gpu.queue.submit([encoder.finish()]);
        let values = gpu.read_back(&readback);
        values.chunks_exact(4).filter(|b| !f32::from_le_bytes([b[0], b[1], b[2], b[3]]).is_finite()).count()
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => values[n / 2],
        _ => (values[n / 2 - 1] + values[n / 2]) / 2.0,
    }
}

/// The medians as a Markdown table, a row per material and one per model summing its materials.
fn table(timed: &[Timed]) -> String {
    let unit = if timed.iter().all(|t| t.times[0].gpu.is_some()) { "GPU ms (wall ms)" } else { "wall ms" };
    let mut text = format!(
        "| material | model | lobes | scene shader: reads, operations | baked: reads, operations | scene shader: \
         {unit} | baked: {unit} | scene / baked |\n|---|---|---:|---|---|---:|---:|---:|\n"
    );
    let mut by_model: BTreeMap<&str, Vec<&Timed>> = BTreeMap::new();
    for t in timed {
        let [scene, baked] = t.times;
        let [scene_cost, baked_cost] = t.costs;
        text += &format!(
            "| {} | {} | {} | {}, {} | {}, {} | {scene} | {baked} | {:.1} |\n",
            t.material,
            t.model,
            t.lobes,
            scene_cost.texture_reads,
            scene_cost.operations,
            baked_cost.texture_reads,
            baked_cost.operations,
            scene.compared() / baked.compared()
        );
        by_model.entry(&t.model).or_default().push(t);
    }
    for (model, materials) in by_model {
        let [scene, baked] = [0, 1].map(|k| Time::sum(materials.iter().map(|t| t.times[k])));
        text += &format!(
            "| {model} materials summed ({}) | {model} | | | | {scene} | {baked} | {:.1} |\n",
            materials.len(),
            scene.compared() / baked.compared()
        );
    }
    text
}
