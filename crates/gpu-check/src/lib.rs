//! tmlut's shaders and lookups run on a GPU API (wgpu: Vulkan, lavapipe in CI, Metal, DX12) and
//! compared with the CPU evaluation; `scripts/gpu-check` runs its examples (`examples/`). Its own
//! crate, so that only this check compiles wgpu.
//!
//! This file is the wgpu plumbing the examples share: a headless device, a table uploaded as a
//! texture from the loader's texel bytes and descriptor, and one compute pass from an f32 input
//! array to an f32 output array.

use tmlut::loader::{DeviceLimits, TextureBinding, TextureData, TextureDimension, TextureFormat};

pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The adapter, as wgpu names it (`llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)` on lavapipe).
    pub adapter: String,
    /// What the adapter says of itself: its name, backend, device type and driver.
    pub info: wgpu::AdapterInfo,
    /// Whether the device filters 32-bit float textures (WebGPU's `float32-filterable`, asked for
    /// where the adapter has it).
    pub float32_filterable: bool,
    /// Whether compute passes may write timestamps (`timestamp-query`, asked for by
    /// [`Gpu::for_timing`] where the adapter has it).
    pub timestamps: bool,
}

/// GPU values against the CPU's: the largest difference, where it is, and the values (on either
/// side) that are not finite.
#[derive(Debug, Default)]
pub struct Comparison {
    pub worst: f64,
    /// The index of the value with the largest difference.
    pub worst_at: usize,
    pub not_finite: usize,
    pub values: usize,
}

impl Comparison {
    /// Each GPU value against the CPU value in the same place.
    pub fn of(gpu: &[f32], cpu: impl IntoIterator<Item = f64>) -> Self {
        let mut comparison = Comparison::default();
        for (&g, c) in gpu.iter().zip(cpu) {
            comparison.add(g, c);
        }
        comparison
    }

    fn add(&mut self, gpu: f32, cpu: f64) {
        let difference = (gpu as f64 - cpu).abs();
        if !gpu.is_finite() || !cpu.is_finite() {
            self.not_finite += 1;
        } else if difference > self.worst {
            (self.worst, self.worst_at) = (difference, self.values);
        }
        self.values += 1;
    }

    pub fn passes(&self, tolerance: f64) -> bool {
        self.worst <= tolerance && self.not_finite == 0
    }

    /// `max |GPU - CPU| ... over N values (tolerance ...), K not finite`.
    pub fn summary(&self, tolerance: f64) -> String {
        format!(
            "max |GPU - CPU| {:.2e} over {} values (tolerance {tolerance:e}), {} not finite",
            self.worst, self.values, self.not_finite
        )
    }
}

/// A uniform value in `[lo, hi)` from 24 random bits, the precision an f32 holds: the points both
/// GPU examples evaluate at.
pub fn uniform_f32(random: &mut rand_pcg::Pcg64Mcg, lo: f64, hi: f64) -> f32 {
    use rand_pcg::rand_core::RngCore;
    let u = (random.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
    lo as f32 + u * (hi - lo) as f32
}

/// The exit code of an example: 0 when every comparison passed, 1 when one did not, 2 on an error
/// (printed).
pub fn exit_code(example: &str, result: Result<bool, Box<dyn std::error::Error>>) -> std::process::ExitCode {
    match result {
        Ok(true) => std::process::ExitCode::SUCCESS,
        Ok(false) => std::process::ExitCode::FAILURE,
        Err(e) => {
            eprintln!("{example}: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

/// What `limits` grant, as a shader description names the limits it needs.
fn device_limits(limits: &wgpu::Limits) -> DeviceLimits {
    DeviceLimits {
        max_sampled_textures_per_shader_stage: limits.max_sampled_textures_per_shader_stage,
        max_samplers_per_shader_stage: limits.max_samplers_per_shader_stage,
        max_texture_array_layers: limits.max_texture_array_layers,
        max_texture_dimension_2d: limits.max_texture_dimension_2d,
        max_texture_dimension_3d: limits.max_texture_dimension_3d,
        max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
        max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
    }
}

/// A texture, a sampler or a read-only storage buffer bound in group 0 at `binding`.
pub struct Bound {
    pub binding: u32,
    pub resource: Resource,
}

pub enum Resource {
    /// A texture, read by `textureLoad` or, where `filterable`, sampled through a sampler.
    Texture { view: wgpu::TextureView, dimension: wgpu::TextureViewDimension, filterable: bool },
    /// A filtering sampler.
    Sampler(wgpu::Sampler),
    /// A read-only storage buffer (a scene shader's constants).
    Buffer(wgpu::Buffer),
}

impl Gpu {
    /// A device on the first adapter wgpu finds: the machine's GPU, or a software one (Mesa's
    /// lavapipe) where there is none. No window, no surface. WebGPU's default limits.
    pub fn new() -> Result<Gpu, String> {
        Self::with_limits(&DeviceLimits::WEBGPU_DEFAULTS)
    }

    /// A device granting at least `needed` (a shader description's `limits`) and WebGPU's
    /// defaults, as a renderer asks for them; refused, naming the limit, where the adapter has less.
    pub fn with_limits(needed: &DeviceLimits) -> Result<Gpu, String> {
        Self::open(needed, wgpu::Features::FLOAT32_FILTERABLE)
    }

    /// As [`Gpu::new`], with timestamp queries where the adapter has them: a device to time
    /// dispatches on.
    pub fn for_timing() -> Result<Gpu, String> {
        Self::open(&DeviceLimits::WEBGPU_DEFAULTS, wgpu::Features::FLOAT32_FILTERABLE | wgpu::Features::TIMESTAMP_QUERY)
    }

    /// A device granting `needed`, with those of `optional` the adapter has.
    fn open(needed: &DeviceLimits, optional: wgpu::Features) -> Result<Gpu, String> {
        let instance = wgpu::Instance::new(&wgpu::InstanceDescriptor::from_env_or_default());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .map_err(|e| format!("no GPU adapter (install a Vulkan driver, e.g. mesa-vulkan-drivers): {e}"))?;
        let info = adapter.get_info();
        let features = adapter.features() & optional;
        let beyond = needed.beyond(&device_limits(&adapter.limits()));
        if !beyond.is_empty() {
            let named: Vec<String> =
                beyond.iter().map(|(name, need, has)| format!("{name} {need} (the adapter has {has})")).collect();
            return Err(format!("{}: the shader needs {}", info.name, named.join(", ")));
        }
        let mut required_limits = wgpu::Limits::default();
        for (limit, need) in [
            (&mut required_limits.max_sampled_textures_per_shader_stage, needed.max_sampled_textures_per_shader_stage),
            (&mut required_limits.max_samplers_per_shader_stage, needed.max_samplers_per_shader_stage),
            (&mut required_limits.max_texture_array_layers, needed.max_texture_array_layers),
            (&mut required_limits.max_texture_dimension_2d, needed.max_texture_dimension_2d),
            (&mut required_limits.max_texture_dimension_3d, needed.max_texture_dimension_3d),
            (&mut required_limits.max_storage_buffers_per_shader_stage, needed.max_storage_buffers_per_shader_stage),
            (&mut required_limits.max_storage_buffer_binding_size, needed.max_storage_buffer_binding_size),
        ] {
            *limit = (*limit).max(need);
        }
        let descriptor = wgpu::DeviceDescriptor { required_features: features, required_limits, ..Default::default() };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| format!("{}: no device: {e}", info.name))?;
        Ok(Gpu {
            device,
            queue,
            adapter: format!("{} ({:?})", info.name, info.backend),
            info,
            float32_filterable: features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
        })
    }

    /// A texture holding a table, created and filled from the loader's descriptor, whose fields
    /// are named as wgpu names them (docs/loader.md). Bound at `binding` of group 0.
    pub fn upload(&self, binding: u32, data: &TextureData) -> Result<Bound, String> {
        self.upload_as(binding, data, false, false)
    }

    /// A texture array holding a table of three axes, its third the layers, bound at `binding` of
    /// group 0 to be filtered by a sampler.
    pub fn upload_array(&self, binding: u32, data: &TextureData) -> Result<Bound, String> {
        self.upload_as(binding, data, true, true)
    }

    /// A table's texture as a scene shader's description binds it: at its binding, an array of
    /// 2D textures where it is `layered`, its texels loaded rather than filtered.
    pub fn upload_bound(&self, bound: &TextureBinding, data: &TextureData) -> Result<Bound, String> {
        self.upload_as(bound.binding, data, bound.layered, false)
    }

    fn upload_as(&self, binding: u32, data: &TextureData, layered: bool, filterable: bool) -> Result<Bound, String> {
        let d = data.descriptor();
        let size = wgpu::Extent3d { width: d.width, height: d.height, depth_or_array_layers: d.depth_or_layers };
        let (dimension, view_dimension) = match (layered, d.dimension) {
            (true, _) => (wgpu::TextureDimension::D2, wgpu::TextureViewDimension::D2Array),
            (false, TextureDimension::D3) => (wgpu::TextureDimension::D3, wgpu::TextureViewDimension::D3),
            _ => (wgpu::TextureDimension::D2, wgpu::TextureViewDimension::D2),
        };
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size,
            mip_level_count: d.mip_level_count,
            sample_count: 1,
            dimension,
            format: texture_format(d.format)?,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        // Rows are packed: `write_texture` takes them so (a buffer copy would pad them to 256 bytes).
        self.queue.write_texture(
            texture.as_image_copy(),
            data.bytes(),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(d.bytes_per_row),
                rows_per_image: Some(d.rows_per_image),
            },
            size,
        );
        let view =
            texture.create_view(&wgpu::TextureViewDescriptor { dimension: Some(view_dimension), ..Default::default() });
        Ok(Bound { binding, resource: Resource::Texture { view, dimension: view_dimension, filterable } })
    }

    /// A sampler of linear magnification and minification and clamp-to-edge addressing (the
    /// default), bound at `binding` of group 0.
    pub fn linear_clamp_sampler(&self, binding: u32) -> Bound {
        let sampler = self.device.create_sampler(&wgpu::SamplerDescriptor {
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Bound { binding, resource: Resource::Sampler(sampler) }
    }

    /// Run the compute entry point `entry` of `module` over `items` items of `inputs` (an
    /// [`entry_point`]) and return the `outputs` f32 values it writes. The module declares
    /// `textures` in group 0 and [`BUFFERS`] in group 1.
    pub fn run(
        &self,
        module: &wgpu::ShaderModule,
        entry: &str,
        textures: &[Bound],
        inputs: &[f32],
        items: usize,
        outputs: usize,
    ) -> Vec<f32> {
        let device = &self.device;
        let buffers_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[storage_entry(0, true), storage_entry(1, false)],
        });
        let (textures_layout, textures_group) = self.texture_group(textures);
        let pipeline = self.compute_pipeline(module, entry, &[&textures_layout, &buffers_layout]);
        let buffer = |size: usize, usage| self.buffer(size as u64, usage);
        let input = buffer(size_of_val(inputs), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST);
        self.queue.write_buffer(&input, 0, &f32_bytes(inputs));
        let out_size = outputs * size_of::<f32>();
        let output = buffer(out_size, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
        let readback = buffer(out_size, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
        let groups = [
            textures_group,
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &buffers_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
                ],
            }),
        ];
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &groups[0], &[]);
            pass.set_bind_group(1, &groups[1], &[]);
            pass.dispatch_workgroups(items.div_ceil(64) as u32, 1, 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, out_size as u64);
        self.queue.submit([encoder.finish()]);
        self.read_back(&readback).chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
    }

    /// A scene shader's constants buffer holding `values`, bound at `binding`.
    pub fn constants(&self, binding: u32, values: &[f32]) -> Bound {
        let bytes = f32_bytes(values);
        let buffer = self.buffer(bytes.len() as u64, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST);
        self.queue.write_buffer(&buffer, 0, &bytes);
        Bound { binding, resource: Resource::Buffer(buffer) }
    }

    /// A buffer of `size` bytes, unmapped.
    pub fn buffer(&self, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor { label: None, size, usage, mapped_at_creation: false })
    }

    /// The bytes of a buffer of `MAP_READ` usage, once the work submitted before has finished.
    pub fn read_back(&self, buffer: &wgpu::Buffer) -> Vec<u8> {
        buffer.map_async(wgpu::MapMode::Read, .., |mapped| mapped.expect("mapping the read-back buffer"));
        self.device.poll(wgpu::PollType::wait_indefinitely()).expect("the GPU finishes the work submitted");
        let bytes = buffer.get_mapped_range(..).to_vec();
        buffer.unmap();
        bytes
    }

    /// The layout of group 0 holding `textures`, and the group binding them.
    pub fn texture_group(&self, textures: &[Bound]) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
        // The scene shaders' tables are read with textureLoad: no sampler, unfilterable float
        // (r32float needs no feature); a baked array is filtered by its sampler. Compute only.
        let entries: Vec<_> = textures
            .iter()
            .map(|t| wgpu::BindGroupLayoutEntry {
                binding: t.binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: match &t.resource {
                    Resource::Texture { dimension, filterable, .. } => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: *filterable },
                        view_dimension: *dimension,
                        multisampled: false,
                    },
                    Resource::Sampler(_) => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    Resource::Buffer(_) => storage_entry(t.binding, true).ty,
                },
                count: None,
            })
            .collect();
        let layout =
            self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &entries });
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &textures
                .iter()
                .map(|t| wgpu::BindGroupEntry {
                    binding: t.binding,
                    resource: match &t.resource {
                        Resource::Texture { view, .. } => wgpu::BindingResource::TextureView(view),
                        Resource::Sampler(sampler) => wgpu::BindingResource::Sampler(sampler),
                        Resource::Buffer(buffer) => buffer.as_entire_binding(),
                    },
                })
                .collect::<Vec<_>>(),
        });
        (layout, group)
    }

    /// The compute pipeline of entry point `entry` of `module`, its groups laid out as `layouts`
    /// (an explicit layout: a layout derived from the shader would leave out the tables this entry
    /// point does not read, and binding them would then fail). Compiled here, so that a dispatch
    /// timed later pays no compilation.
    pub fn compute_pipeline(
        &self,
        module: &wgpu::ShaderModule,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> wgpu::ComputePipeline {
        let layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: layouts,
            push_constant_ranges: &[],
        });
        self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    }

    /// The WGSL function `function` of a fitted form (`source`, its file), of `variables` f32
    /// arguments, returning `channels` f32 values (`f32` for one, `vecN<f32>` for more), at each
    /// point of `points` (`variables` values a point): `channels` values a point, in order.
    pub fn run_form(
        &self,
        source: &str,
        function: &str,
        variables: usize,
        channels: usize,
        points: &[f32],
    ) -> Vec<f32> {
        let arguments: Vec<String> = (0..variables).map(|k| format!("inputs[{variables}u * i + {k}u]")).collect();
        let call = format!("{function}({})", arguments.join(", "));
        let body = match channels {
            1 => format!("outputs[i] = {call};"),
            _ => {
                let stores: String =
                    (0..channels).map(|c| format!(" outputs[{channels}u * i + {c}u] = r[{c}];")).collect();
                format!("let r = {call};{stores}")
            }
        };
        let wgsl = format!("{source}{BUFFERS}{}", entry_point("main", variables, &body));
        let items = points.len() / variables;
        self.run(&self.module(&wgsl), "main", &[], points, items, items * channels)
    }

    /// A WGSL module; wgpu (naga) reports an invalid one.
    pub fn module(&self, wgsl: &str) -> wgpu::ShaderModule {
        self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        })
    }
}

/// The wgpu format of the same name.
fn texture_format(format: TextureFormat) -> Result<wgpu::TextureFormat, String> {
    Ok(match format {
        TextureFormat::R16Float => wgpu::TextureFormat::R16Float,
        TextureFormat::Rg16Float => wgpu::TextureFormat::Rg16Float,
        TextureFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
        TextureFormat::R32Float => wgpu::TextureFormat::R32Float,
        TextureFormat::Rg32Float => wgpu::TextureFormat::Rg32Float,
        TextureFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
        other => return Err(format!("texture format {} is not mapped to wgpu here", other.webgpu_name())),
    })
}

/// A storage buffer at `binding`, read by compute shaders (and written, unless `read_only`).
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The group 1 bindings of [`Gpu::run`].
pub const BUFFERS: &str = "
@group(1) @binding(0) var<storage, read> inputs: array<f32>;
@group(1) @binding(1) var<storage, read_write> outputs: array<f32>;
";

/// A compute entry point running `body` for item `i` of the items of `inputs_per_item` inputs
/// each; `body` reads `inputs[...]` and writes `outputs[...]`.
pub fn entry_point(name: &str, inputs_per_item: usize, body: &str) -> String {
    format!(
        "
@compute @workgroup_size(64)
fn {name}(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= arrayLength(&inputs) / {inputs_per_item}u) {{ return; }}
    {body}
}}
"
    )
}
