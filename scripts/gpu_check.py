"""Run tmlut's generated WGSL, and its HLSL compiled to SPIR-V, on a real GPU API (wgpu-native
through Python's `wgpu`; Mesa's lavapipe where no GPU is present) and compare them with tmlut's
CPU evaluation.

    python scripts/gpu_check.py [--hlsl GLSLANG_VALIDATOR] SHADER_DIR LUTS_DIR [SHADER_DIR LUTS_DIR ...]

For each scene shader (<scene>.wgsl, <scene>.shader.json, <scene>.constants.bin,
<scene>.reference.json from `tmlut shader --reference-views N`), every texture of the shader is
created from the table file's texels as stored (the DDS header gives format and extent), the
constants buffer from its file, and each material is run once per reference view in a compute
shader. Where a shader stage can bind all of the scene's textures, every material is run through
the dispatch function, `tm_material(index, mu)`, in one module and one dispatch; otherwise each
material's own function, one module and one dispatch per run of materials whose textures a
shader stage can bind together, which compiles a scene's text a few times rather than once per
material. With `--hlsl`, the same again with <scene>.hlsl:
compiled by glslang's HLSL front end to SPIR-V (`register(tN)` becomes binding N of set 0, as the
WGSL's group 0; any error line glslang prints fails, whatever its exit status), which wgpu takes as
the shader module. Prints the largest |GPU - CPU| over albedo, top
albedo, lobe energies and cosines; over lobe roughnesses and GD, each weighted by its lobe's
energy (largest channel); and the NaN count; exits non-zero where either is above 1e-5, or on any
NaN.

Why the weight: a lobe's roughness comes from its asymmetry, the ratio of two increments of
cumulative reflectances, so in f32 it is known to about 1e-7 / (the lobe's energy), and its GD
follows it (and is 0 for a lobe without energy, which rounding decides for a lobe at 1e-8). What
a renderer draws is the lobe's energy times its shape, so the shape's error counts in proportion
to the energy it shapes. The unweighted largest difference is printed too.
"""

import json
import logging
import math
import struct
import sys
import tempfile
from pathlib import Path

import numpy as np
import wgpu

from glslang_diagnostics import compile_checked

TOLERANCE = 1e-5

# DXGI format -> (WebGPU format, bytes per texel).
DXGI = {
    41: ("r32float", 4),
    16: ("rg32float", 8),
    2: ("rgba32float", 16),
    54: ("r16float", 2),
    34: ("rg16float", 4),
    10: ("rgba16float", 8),
}


def read_dds(path):
    """Texels of a DDS file with the DX10 header: (WebGPU format, bytes per texel, extent, bytes)."""
    data = path.read_bytes()
    if data[:4] != b"DDS " or len(data) < 148:
        raise SystemExit(f"{path}: not a DDS file with a DX10 header")
    height, width = struct.unpack_from("<II", data, 12)
    # A volume states its depth; an array (a library's slices) its layers in the DX10 header.
    depth = struct.unpack_from("<I", data, 24)[0] or struct.unpack_from("<I", data, 140)[0] or 1
    if data[84:88] != b"DX10":
        raise SystemExit(f"{path}: no DX10 header")
    dxgi = struct.unpack_from("<I", data, 128)[0]
    if dxgi not in DXGI:
        raise SystemExit(f"{path}: DXGI format {dxgi} not handled here")
    fmt, size = DXGI[dxgi]
    texels = data[148 : 148 + width * height * depth * size]
    return fmt, size, (width, height, depth), texels


def device():
    adapter = wgpu.gpu.request_adapter_sync(power_preference="high-performance")
    info = adapter.info
    print(f"adapter: {info.get('device', '?')} ({info.get('backend_type', '?')}, {info.get('adapter_type', '?')})")
    return adapter.request_device_sync()


class Worst:
    """The largest |GPU - CPU| of one kind of value, and where it was."""

    def __init__(self):
        self.difference, self.where = 0.0, ""

    def record(self, difference, where):
        if difference > self.difference:
            self.difference, self.where = difference, where

    def merge(self, other):
        self.record(other.difference, other.where)


def wgsl_module(dev, text, functions, stride, lobes, dispatch):
    """The scene's WGSL with an entry point that runs, at point `i`, material
    `harness_material[i]` at view cosine `harness_views[i]`: with `dispatch` the material's index
    in the description passed to that function, else an index into `functions`."""
    if dispatch:
        call = f"r = {dispatch}(harness_material[i], harness_views[i]);"
    else:
        cases = "\n".join(
            f"        case {k}u{', default' if k == len(functions) - 1 else ''}: {{ r = {function}(harness_views[i]); }}"
            for k, function in enumerate(functions)
        )
        call = f"switch harness_material[i] {{\n{cases}\n    }}"
    entry = f"""
@group(1) @binding(0) var<storage, read> harness_views: array<f32>;
@group(1) @binding(1) var<storage, read_write> harness_out: array<f32>;
@group(1) @binding(2) var<storage, read> harness_material: array<u32>;
@compute @workgroup_size(64)
fn harness_main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= arrayLength(&harness_views)) {{ return; }}
    var r: TmResult;
    {call}
    let o = i * {stride}u;
    harness_out[o + 0u] = r.albedo.x; harness_out[o + 1u] = r.albedo.y; harness_out[o + 2u] = r.albedo.z;
    harness_out[o + 3u] = r.top_albedo.x; harness_out[o + 4u] = r.top_albedo.y; harness_out[o + 5u] = r.top_albedo.z;
    for (var k = 0u; k < {lobes}u; k++) {{
        let b = o + 6u + 6u * k;
        harness_out[b + 0u] = r.lobe_energy[k].x; harness_out[b + 1u] = r.lobe_energy[k].y; harness_out[b + 2u] = r.lobe_energy[k].z;
        harness_out[b + 3u] = r.lobe_roughness[k]; harness_out[b + 4u] = r.lobe_cos[k]; harness_out[b + 5u] = r.lobe_gd[k];
    }}
}}
"""
    return dev.create_shader_module(code=text + entry)


def hlsl_module(dev, text, functions, stride, lobes, dispatch, glslang):
    """The same entry point in HLSL, compiled to SPIR-V by glslang. wgpu's SPIR-V reader (naga)
    warns once per `precise` value (the SPIR-V decoration NoContraction) that it does not keep
    the decoration; the warnings are silenced and `main` says so once."""
    if dispatch:
        call = f"r = {dispatch}(harness_material[i], harness_views[i]);"
    else:
        cases = "\n".join(
            f"        {'default' if k == len(functions) - 1 else f'case {k}'}: r = {function}(harness_views[i]); break;"
            for k, function in enumerate(functions)
        )
        call = f"switch (harness_material[i]) {{\n{cases}\n    }}"
    entry = f"""
StructuredBuffer<float> harness_views : register(t0, space1);
RWStructuredBuffer<float> harness_out : register(u1, space1);
StructuredBuffer<uint> harness_material : register(t2, space1);
[numthreads(64, 1, 1)]
void harness_main(uint3 id : SV_DispatchThreadID) {{
    uint count, element_stride;
    harness_views.GetDimensions(count, element_stride);
    uint i = id.x;
    if (i >= count) {{ return; }}
    TmResult r;
    {call}
    uint o = i * {stride};
    harness_out[o + 0] = r.albedo.x; harness_out[o + 1] = r.albedo.y; harness_out[o + 2] = r.albedo.z;
    harness_out[o + 3] = r.top_albedo.x; harness_out[o + 4] = r.top_albedo.y; harness_out[o + 5] = r.top_albedo.z;
    for (uint k = 0; k < {lobes}; k++) {{
        uint b = o + 6 + 6 * k;
        harness_out[b + 0] = r.lobe_energy[k].x; harness_out[b + 1] = r.lobe_energy[k].y; harness_out[b + 2] = r.lobe_energy[k].z;
        harness_out[b + 3] = r.lobe_roughness[k]; harness_out[b + 4] = r.lobe_cos[k]; harness_out[b + 5] = r.lobe_gd[k];
    }}
}}
"""
    with tempfile.TemporaryDirectory() as work:
        source, spirv = Path(work) / "scene.hlsl", Path(work) / "scene.spv"
        source.write_text(text + entry)
        arguments = ["-D", "-V", "-S", "comp", "-e", "harness_main", str(source), "-o", str(spirv)]
        failure = compile_checked(glslang, arguments)
        if failure is not None:
            raise SystemExit(f"glslang could not compile the HLSL of {', '.join(functions)}:\n{failure}")
        quiet = logging.getLogger("wgpu")
        level = quiet.level
        quiet.setLevel(logging.ERROR)
        try:
            return dev.create_shader_module(code=spirv.read_bytes())
        finally:
            quiet.setLevel(level)


def run_harness(dev, pipeline, group0, group1, points, out_buffer):
    """One dispatch of the harness entry point over `points` points; what it wrote, as f32."""
    encoder = dev.create_command_encoder()
    compute = encoder.begin_compute_pass()
    compute.set_pipeline(pipeline)
    compute.set_bind_group(0, group0)
    compute.set_bind_group(1, group1)
    compute.dispatch_workgroups((points + 63) // 64)
    compute.end()
    dev.queue.submit([encoder.finish()])
    return np.frombuffer(dev.queue.read_buffer(out_buffer), dtype=np.float32)


def batches(materials, limit, textures_bound):
    """The materials in order, in runs whose functions read at most `limit` textures together
    (the device's textures per shader stage): one module and one dispatch per run, so that a
    scene's text is compiled once per run rather than once per material. Where the stage binds
    all `textures_bound` of the scene, one run of every material (through the dispatch function)."""
    if textures_bound <= limit:
        return [materials]
    runs, run, textures = [], [], set()
    for material in materials:
        reads = set(material["textures"])
        if run and len(textures | reads) > limit:
            runs.append(run)
            run, textures = [], set()
        run.append(material)
        textures |= reads
    return runs + [run] if run else runs


def check_scene(dev, shader_dir, luts, language, glslang):
    descriptions = sorted(shader_dir.glob("*.shader.json"))
    if not descriptions:
        raise SystemExit(f"{shader_dir}: no .shader.json")
    worst = {"values": Worst(), "weighted shape": Worst(), "shape": Worst()}
    # Per flux model and per kind of table read: points, and the two largest differences.
    groups = {}
    nans = 0
    points = 0
    for description_path in descriptions:
        stem = description_path.name[: -len(".shader.json")]
        description = json.loads(description_path.read_text())
        reference = json.loads((shader_dir / f"{stem}.reference.json").read_text())
        text = (shader_dir / f"{stem}.{language}").read_text()
        lobes = description["max_lobes"]
        stride = 6 + 6 * lobes
        textures = {}
        for t in description["textures"]:
            fmt, size, extent, texels = read_dds(luts / t["file"])
            dimension = "3d" if t["dimension"] == 3 else "2d"
            texture = dev.create_texture(
                size=extent, format=fmt, dimension=dimension, usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST
            )
            dev.queue.write_texture(
                {"texture": texture}, texels, {"bytes_per_row": extent[0] * size, "rows_per_image": extent[1]}, extent
            )
            view_dimension = "2d-array" if t.get("layered") else dimension
            textures[t["binding"]] = (view_dimension, texture.create_view(dimension=view_dimension))
        constants = description["constants"]
        constants_data = (shader_dir / constants["file"]).read_bytes()
        if len(constants_data) != constants["elements"] * constants["element_stride"]:
            raise SystemExit(f"{shader_dir / constants['file']}: {len(constants_data)} bytes, not {constants['elements']} f32")
        constants_buffer = dev.create_buffer_with_data(data=constants_data, usage=wgpu.BufferUsage.STORAGE)
        dispatch = description["dispatch_function"]
        group1_layout = dev.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": wgpu.BufferBindingType.read_only_storage}},
            {"binding": 1, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": wgpu.BufferBindingType.storage}},
            {"binding": 2, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": wgpu.BufferBindingType.read_only_storage}},
        ])
        limit = dev.limits["max-sampled-textures-per-shader-stage"]
        for run in batches(description["materials"], limit, len(description["textures"])):
            whole_scene = len(run) == len(description["materials"]) and len(description["textures"]) <= limit
            run_dispatch = dispatch if whole_scene else None
            bindings = sorted(textures) if run_dispatch else sorted({b for material in run for b in material["textures"]})
            group0_layout = dev.create_bind_group_layout(entries=[
                {
                    "binding": b,
                    "visibility": wgpu.ShaderStage.COMPUTE,
                    "texture": {"sample_type": wgpu.TextureSampleType.unfilterable_float, "view_dimension": textures[b][0]},
                }
                for b in bindings
            ] + [{
                "binding": constants["binding"],
                "visibility": wgpu.ShaderStage.COMPUTE,
                "buffer": {"type": wgpu.BufferBindingType.read_only_storage},
            }])
            layout = dev.create_pipeline_layout(bind_group_layouts=[group0_layout, group1_layout])
            functions = [material["function"] for material in run]
            views = {function: [] for function in functions}
            for p in reference:
                if p["function"] in views:
                    views[p["function"]].append(p["evaluation"])
            mus = np.array([v["mu"] for f in functions for v in views[f]], dtype=np.float32)
            index = {m["function"]: k for k, m in enumerate(description["materials"])}
            which = np.array(
                [index[f] if run_dispatch else k for k, f in enumerate(functions) for _ in views[f]], dtype=np.uint32
            )
            if language == "wgsl":
                module = wgsl_module(dev, text, functions, stride, lobes, run_dispatch)
            else:
                module = hlsl_module(dev, text, functions, stride, lobes, run_dispatch, glslang)
            pipeline = dev.create_compute_pipeline(layout=layout, compute={"module": module, "entry_point": "harness_main"})
            views_buffer = dev.create_buffer_with_data(data=mus.tobytes(), usage=wgpu.BufferUsage.STORAGE)
            material_buffer = dev.create_buffer_with_data(data=which.tobytes(), usage=wgpu.BufferUsage.STORAGE)
            out_buffer = dev.create_buffer(size=len(mus) * stride * 4, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
            whole = lambda buffer: {"buffer": buffer, "offset": 0, "size": buffer.size}
            group0 = dev.create_bind_group(
                layout=group0_layout,
                entries=[{"binding": b, "resource": textures[b][1]} for b in bindings]
                + [{"binding": constants["binding"], "resource": whole(constants_buffer)}],
            )
            group1 = dev.create_bind_group(
                layout=group1_layout,
                entries=[
                    {"binding": 0, "resource": whole(views_buffer)},
                    {"binding": 1, "resource": whole(out_buffer)},
                    {"binding": 2, "resource": whole(material_buffer)},
                ],
            )
            out = run_harness(dev, pipeline, group0, group1, len(mus), out_buffer).reshape(len(mus), stride)
            nans += int(np.count_nonzero(~np.isfinite(out)))
            start = 0
            for material in run:
                material_views = views[material["function"]]
                rows = out[start : start + len(material_views)]
                start += len(material_views)
                mine = {"values": Worst(), "weighted shape": Worst(), "shape": Worst()}
                for row, view in zip(rows, material_views):
                    at = f"{stem} / {material['material']}, mu {view['mu']:.6g}"
                    values = list(zip(list(view["albedo"]) + list(view["top_albedo"]), row[:6]))
                    for k, lobe in enumerate(view["lobes"]):
                        b = 6 + 6 * k
                        values += list(zip(list(lobe["energy"]) + [lobe["incident"][2]], list(row[b : b + 3]) + [row[b + 4]]))
                        energy = max(lobe["energy"])
                        for name, expected, got in [("roughness", lobe["roughness"], row[b + 3]), ("GD", lobe["gd"], row[b + 5])]:
                            if math.isfinite(got):
                                where = f"{at}, lobe {k} {name} (energy {energy:.3g})"
                                mine["shape"].record(abs(float(got) - expected), where)
                                mine["weighted shape"].record(energy * abs(float(got) - expected), where)
                    for expected, got in values:
                        if math.isfinite(got):
                            mine["values"].record(abs(float(got) - expected), at)
                    points += 1
                for kind in worst:
                    worst[kind].merge(mine[kind])
                for group in [material.get("model", "?")] + material.get("reads", []):
                    count, values, weighted = groups.get(group, (0, Worst(), Worst()))
                    values.merge(mine["values"])
                    weighted.merge(mine["weighted shape"])
                    groups[group] = (count + len(material_views), values, weighted)
                through = f"{dispatch}({index[material['function']]}, mu)" if run_dispatch else material["function"]
                print(f"  {language}: {stem} / {material['material']}: {len(material_views)} views, through {through}")
    return worst, nans, points, groups


def main(argv):
    glslang = None
    if argv[:1] == ["--hlsl"]:
        glslang, argv = argv[1], argv[2:]
    if len(argv) < 2 or len(argv) % 2:
        raise SystemExit(__doc__)
    dev = device()
    failed = False
    for language in ["wgsl"] + (["hlsl"] if glslang else []):
        failed |= check_language(dev, argv, language, glslang)
    if failed:
        raise SystemExit("FAILED")


def check_language(dev, argv, language, glslang):
    """Runs every scene's shader in one language; prints the summary; whether it failed."""
    worst = {"values": Worst(), "weighted shape": Worst(), "shape": Worst()}
    nans, points, groups = 0, 0, {}
    for shader_dir, luts in zip(argv[0::2], argv[1::2]):
        w, n, p, g = check_scene(dev, Path(shader_dir), Path(luts), language, glslang)
        for kind in worst:
            worst[kind].merge(w[kind])
        nans, points = nans + n, points + p
        for group, (count, values, weighted) in g.items():
            total, all_values, all_weighted = groups.get(group, (0, Worst(), Worst()))
            all_values.merge(values)
            all_weighted.merge(weighted)
            groups[group] = (total + count, all_values, all_weighted)
    values, weighted, shape = worst["values"], worst["weighted shape"], worst["shape"]
    source = "WGSL" if language == "wgsl" else "HLSL (glslang to SPIR-V; naga keeps no NoContraction, HLSL's `precise`)"
    print(f"scene shaders, {source}, on the GPU API vs the CPU evaluator: {points} (material, view) points, tolerance {TOLERANCE:g}\n"
          f"  albedo, top albedo, lobe energies and cosines: max |GPU - CPU| {values.difference:.3e} ({values.where})\n"
          f"  lobe roughness and GD times the lobe's energy: max {weighted.difference:.3e} ({weighted.where})\n"
          f"  lobe roughness and GD, unweighted: max {shape.difference:.3e} ({shape.where})\n"
          f"  {nans} NaN/inf\n"
          f"  by flux model and by table read (points; max |GPU - CPU| of values; of shapes times energy):")
    for group, (count, values, weighted) in sorted(groups.items()):
        print(f"    {group:15} {count:6} points  {values.difference:.3e}  {weighted.difference:.3e}")
    return values.difference > TOLERANCE or weighted.difference > TOLERANCE or nans > 0


if __name__ == "__main__":
    main(sys.argv[1:])
