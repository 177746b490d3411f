"""Time what a renderer pays to use a scene shader over a whole library: its WGSL's size, the shader
module's creation (parsing and validation), the compute pipeline's, and the first dispatch, of one
entry point calling the dispatch function, `tm_material(index, mu)`, for every material at a few
views, on the adapter wgpu finds (Mesa's llvmpipe, through lavapipe, where there is no GPU; lavapipe
compiles the shader at the first dispatch, so that figure holds the compile). With `--shapes K`,
the entry point calls instead the functions of one material of each of the first K stack shapes,
which the compiler inlines whole as it inlines every shape into `tm_material`: how the compile grows
with the shapes. Mesa keeps compiled shaders on disk and reads them back for the same text: set
MESA_SHADER_CACHE_DISABLE=true for the compile's time.

    python scripts/time_library_pipeline.py SHADER_DIR LUTS_DIR [--views N] [--shapes K]

SHADER_DIR holds one <scene>.wgsl, <scene>.shader.json and <scene>.constants.bin (`tmlut shader`,
or `tmlut build --scene`, which writes them beside the tables in LUTS_DIR). Prints one line per
figure; every value the dispatch writes must be finite.
"""

import json
import sys
import time
from pathlib import Path

import numpy as np
import wgpu

from gpu_check import read_dds, run_harness, wgsl_module


def main(argv):
    options = {"--views": 4, "--shapes": None}
    for option in options:
        if option in argv:
            k = argv.index(option)
            options[option] = int(argv[k + 1])
            argv = argv[:k] + argv[k + 2 :]
    views, shapes = options["--views"], options["--shapes"]
    if len(argv) != 2:
        raise SystemExit(__doc__)
    shader_dir, luts = Path(argv[0]), Path(argv[1])
    [description_path] = sorted(shader_dir.glob("*.shader.json"))
    stem = description_path.name[: -len(".shader.json")]
    description = json.loads(description_path.read_text())
    text = (shader_dir / f"{stem}.wgsl").read_text()
    constants = description["constants"]
    adapter = wgpu.gpu.request_adapter_sync(power_preference="high-performance")
    info = adapter.info
    print(f"adapter: {info.get('device', '?')} ({info.get('backend_type', '?')}, {info.get('adapter_type', '?')})")
    needed = description["limits"]["max_sampled_textures_per_shader_stage"]
    dev = adapter.request_device_sync(required_limits={"max-sampled-textures-per-shader-stage": max(16, needed)})
    materials = description["materials"]
    functions = []
    if shapes is not None:
        first = {}
        for m in materials:
            first.setdefault(m["shape"], m)
        materials = [first[s] for s in sorted(first)[:shapes]]
        functions = [m["function"] for m in materials]
    print(
        f"{stem}: {len(materials)} materials, {len(description['shapes'])} shared functions; "
        f"{stem}.wgsl {len(text.encode())} bytes, {stem}.constants.bin {constants['elements'] * 4} bytes"
    )
    entries, resources = [], []
    for t in description["textures"]:
        fmt, size, extent, texels = read_dds(luts / t["file"])
        texture = dev.create_texture(
            size=extent,
            format=fmt,
            dimension="3d" if t["dimension"] == 3 else "2d",
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST,
        )
        dev.queue.write_texture(
            {"texture": texture}, texels, {"bytes_per_row": extent[0] * size, "rows_per_image": extent[1]}, extent
        )
        entries.append({
            "binding": t["binding"],
            "visibility": wgpu.ShaderStage.COMPUTE,
            "texture": {"sample_type": wgpu.TextureSampleType.unfilterable_float, "view_dimension": t["view_dimension"]},
        })
        resources.append({"binding": t["binding"], "resource": texture.create_view(dimension=t["view_dimension"])})
    data = (shader_dir / constants["file"]).read_bytes()
    buffer = dev.create_buffer_with_data(data=data, usage=wgpu.BufferUsage.STORAGE)
    whole = lambda b: {"buffer": b, "offset": 0, "size": b.size}
    entries.append({
        "binding": constants["binding"],
        "visibility": wgpu.ShaderStage.COMPUTE,
        "buffer": {"type": wgpu.BufferBindingType.read_only_storage},
    })
    resources.append({"binding": constants["binding"], "resource": whole(buffer)})
    lobes = description["max_lobes"]
    stride = 6 + 6 * lobes
    started = time.perf_counter()
    dispatch = None if functions else description["dispatch_function"]
    module = wgsl_module(dev, text, functions, stride, lobes, dispatch)
    module_s = time.perf_counter() - started
    group0_layout = dev.create_bind_group_layout(entries=entries)
    storage = lambda kind: {"type": kind}
    group1_layout = dev.create_bind_group_layout(entries=[
        {"binding": 0, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": storage(wgpu.BufferBindingType.read_only_storage)},
        {"binding": 1, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": storage(wgpu.BufferBindingType.storage)},
        {"binding": 2, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": storage(wgpu.BufferBindingType.read_only_storage)},
    ])
    layout = dev.create_pipeline_layout(bind_group_layouts=[group0_layout, group1_layout])
    started = time.perf_counter()
    pipeline = dev.create_compute_pipeline(layout=layout, compute={"module": module, "entry_point": "harness_main"})
    pipeline_s = time.perf_counter() - started
    mus = np.tile(np.linspace(0.0, 1.0, views, dtype=np.float32), len(materials))
    # Through the dispatch function a material's index in the description; else one in `functions`.
    which = np.repeat(np.arange(len(materials), dtype=np.uint32), views)
    views_buffer = dev.create_buffer_with_data(data=mus.tobytes(), usage=wgpu.BufferUsage.STORAGE)
    material_buffer = dev.create_buffer_with_data(data=which.tobytes(), usage=wgpu.BufferUsage.STORAGE)
    out_buffer = dev.create_buffer(size=len(mus) * stride * 4, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
    group0 = dev.create_bind_group(layout=group0_layout, entries=resources)
    group1 = dev.create_bind_group(layout=group1_layout, entries=[
        {"binding": 0, "resource": whole(views_buffer)},
        {"binding": 1, "resource": whole(out_buffer)},
        {"binding": 2, "resource": whole(material_buffer)},
    ])
    started = time.perf_counter()
    out = run_harness(dev, pipeline, group0, group1, len(mus), out_buffer)
    dispatch_s = time.perf_counter() - started
    not_finite = int(np.count_nonzero(~np.isfinite(out)))
    print(f"shader module (parse and validate): {module_s:.2f} s")
    over = f"{dispatch}(index, mu), every material" if dispatch else f"the functions of {len(functions)} stack shapes"
    print(f"compute pipeline over {over}: {pipeline_s:.2f} s")
    print(
        f"first dispatch (the compile, then {len(materials)} materials x {views} views): {dispatch_s:.2f} s, "
        f"{not_finite} values not finite"
    )
    if not_finite:
        raise SystemExit("FAILED: values not finite")


if __name__ == "__main__":
    main(sys.argv[1:])
