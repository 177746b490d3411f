"""Load tmlut's KTX2 files on a real GPU API beside their DDS twins (wgpu-native through Python's
`wgpu`; Mesa's lavapipe where no GPU is present).

    python scripts/gpu_check_ktx2.py DDS_FILE KTX2_FILE [DDS_FILE KTX2_FILE ...]

Each KTX2 file is read as a renderer reads it, from its own header (vkFormat, pixel extents,
level 0 from the level index), the DDS twin from its DX10 header; both are created as textures
and every texel of both is read back on the GPU (textureLoad in a compute shader). The KTX2
texture must read exactly as the DDS one and as the values of its level bytes; exits non-zero
otherwise.
"""

import struct
import sys
from pathlib import Path

import numpy as np
import wgpu

from gpu_check import device, read_dds

IDENTIFIER = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])

# VkFormat -> (WebGPU format, bytes per texel).
VK = {
    76: ("r16float", 2),
    83: ("rg16float", 4),
    97: ("rgba16float", 8),
    100: ("r32float", 4),
    103: ("rg32float", 8),
    109: ("rgba32float", 16),
}


def read_ktx2(path):
    """Level 0 of a KTX2 file: (WebGPU format, bytes per texel, extent, 3D or not, bytes)."""
    data = path.read_bytes()
    if data[:12] != IDENTIFIER or len(data) < 104:
        raise SystemExit(f"{path}: not a KTX 2.0 file")
    vk_format, _type_size, width, height, depth, layers, faces, levels, scheme = struct.unpack_from("<9I", data, 12)
    if vk_format not in VK or layers or faces != 1 or levels > 1 or scheme:
        raise SystemExit(f"{path}: not a single-level uncompressed 2D or 3D texture of a float format handled here")
    offset, length, _ = struct.unpack_from("<3Q", data, 80)
    fmt, size = VK[vk_format]
    extent = (width, height, max(depth, 1))
    if length != extent[0] * extent[1] * extent[2] * size or offset + length > len(data):
        raise SystemExit(f"{path}: level 0 is not {extent} texels of {fmt}")
    return fmt, size, extent, depth > 0, data[offset : offset + length]


def values(fmt, texels):
    """The texel values as float32, channels interleaved."""
    return np.frombuffer(texels, dtype=np.float16 if "16" in fmt else np.float32).astype(np.float32)


def load_on_gpu(dev, fmt, size, extent, volume, texels):
    """Every texel of a texture created from `texels`, read back by textureLoad: (N, 4) float32."""
    dimension = "3d" if volume else "2d"
    texture = dev.create_texture(
        size=extent, format=fmt, dimension=dimension, usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST
    )
    dev.queue.write_texture(
        {"texture": texture}, texels, {"bytes_per_row": extent[0] * size, "rows_per_image": extent[1]}, extent
    )
    count = extent[0] * extent[1] * extent[2]
    coordinate = "vec3<i32>(i32(x), i32(y), i32(z))" if volume else "vec2<i32>(i32(x), i32(y))"
    code = f"""
@group(0) @binding(0) var tex: texture_{dimension}<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= {count}u) {{ return; }}
    let x = i % {extent[0]}u;
    let y = (i / {extent[0]}u) % {extent[1]}u;
    let z = i / ({extent[0]}u * {extent[1]}u);
    out[i] = textureLoad(tex, {coordinate}, 0);
}}
"""
    out = dev.create_buffer(size=count * 16, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
    layout = dev.create_bind_group_layout(entries=[
        {
            "binding": 0,
            "visibility": wgpu.ShaderStage.COMPUTE,
            "texture": {"sample_type": wgpu.TextureSampleType.unfilterable_float, "view_dimension": dimension},
        },
        {"binding": 1, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": wgpu.BufferBindingType.storage}},
    ])
    pipeline = dev.create_compute_pipeline(
        layout=dev.create_pipeline_layout(bind_group_layouts=[layout]),
        compute={"module": dev.create_shader_module(code=code), "entry_point": "main"},
    )
    group = dev.create_bind_group(layout=layout, entries=[
        {"binding": 0, "resource": texture.create_view()},
        {"binding": 1, "resource": {"buffer": out, "offset": 0, "size": out.size}},
    ])
    encoder = dev.create_command_encoder()
    compute = encoder.begin_compute_pass()
    compute.set_pipeline(pipeline)
    compute.set_bind_group(0, group)
    compute.dispatch_workgroups((count + 63) // 64)
    compute.end()
    dev.queue.submit([encoder.finish()])
    return np.frombuffer(dev.queue.read_buffer(out), dtype=np.float32).reshape(count, 4)


def check_twin(dev, dds_path, ktx2_path):
    fmt, size, extent, volume, texels = read_ktx2(ktx2_path)
    dds_fmt, dds_size, dds_extent, dds_texels = read_dds(dds_path)
    if (fmt, size, extent) != (dds_fmt, dds_size, dds_extent):
        raise SystemExit(f"{ktx2_path}: {fmt} {extent}, its DDS twin {dds_fmt} {dds_extent}")
    from_ktx2 = load_on_gpu(dev, fmt, size, extent, volume, texels)
    from_dds = load_on_gpu(dev, dds_fmt, dds_size, dds_extent, volume, dds_texels)
    channels = size // (2 if "16" in fmt else 4)
    stored = values(fmt, texels).reshape(-1, channels)
    differing = int(np.count_nonzero(from_ktx2 != from_dds))
    wrong = int(np.count_nonzero(from_ktx2[:, :channels] != stored))
    print(f"  {ktx2_path.name}: {fmt} {'x'.join(map(str, extent))}, {len(stored)} texels read on the GPU; "
          f"{differing} values differ from {dds_path.name}, {wrong} from the file's level bytes")
    return differing + wrong


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        raise SystemExit(__doc__)
    dev = device()
    failures = sum(check_twin(dev, Path(d), Path(k)) for d, k in zip(argv[0::2], argv[1::2]))
    print(f"KTX2 textures on the GPU API vs their DDS twins: {failures} values differ")
    if failures:
        raise SystemExit("FAILED")


if __name__ == "__main__":
    main(sys.argv[1:])
