"""Compile every HLSL file tmlut wrote under the given folders with glslang's HLSL front end.

Usage: hlsl_check.py GLSLANG_VALIDATOR DIR [DIR ...]

glslangValidator (Khronos; the Debian package glslang-tools) compiles HLSL to SPIR-V for Vulkan. A
tmlut HLSL file is a library of functions without an entry point, so each is compiled with a small
compute entry point appended that calls the functions a renderer calls and stores their results:
  - a scene shader (a `<stem>.shader.json` beside it): every material's function (a varied baked
    material's at its parameters' nominal values) and the dispatch function, at a view cosine per
    thread, every field of its TmResult;
  - any other file (a packing's lookup, a fitted form, an engine preset's functions): every function
    whose parameters are floats or textures and that returns floats or a struct of them, with a
    texture of the parameter's type bound for each texture.
The compile goes through code generation (`-V`) and SPIRV-Tools' legalisation, so a texture load,
a swizzle or an overload that HLSL refuses fails here, and so does a module too large for SPIR-V:
a file fails on any error line glslang prints, whatever its exit status
(scripts/glslang_diagnostics.py, which names the limit an error is). Exits non-zero when any file
fails, printing the compiler's messages.
"""

import json
import pathlib
import re
import sys
import tempfile

from glslang_diagnostics import compile_checked

ENTRY = "tmlut_compile_check"
FUNCTION = re.compile(r"^(\w+)\s+(\w+)\s*\(([^)]*)\)\s*\{", re.MULTILINE)
# A struct the file declares, with its first field (what a call returning it is summed by).
STRUCT = re.compile(r"^struct\s+(\w+)\s*\{\s*(float[234]?)\s+(\w+);", re.MULTILINE)


def scene_entry(description: dict) -> str:
    lobes = description["max_lobes"]
    lines = [f"    float mu = float(id.x) / 63.0;", "    float sum = 0.0;"]
    # A material whose textures vary parameters (a baked one) takes them after mu: its nominal values.
    calls = [
        f"{material['function']}({', '.join(['mu'] + [repr(float(p['nominal'])) for p in material.get('parameters', [])])})"
        for material in description["materials"]
    ]
    # The dispatch function too, at an index the invocation decides, so that no case is folded away.
    if description.get("dispatch_function"):
        calls.append(f"{description['dispatch_function']}(id.x % {len(description['materials'])}u, mu)")
    for call in calls:
        lines.append(f"    {{ TmResult r = {call};")
        lines.append("      sum += r.albedo.x + r.albedo.y + r.albedo.z + r.top_albedo.x;")
        for k in range(lobes):
            lines.append(
                f"      sum += r.lobe_energy[{k}].x + r.lobe_roughness[{k}] + r.lobe_cos[{k}] + r.lobe_gd[{k}];"
            )
        lines.append("    }")
    return "\n".join(lines)


def library_entry(text: str) -> tuple[str, str]:
    """The globals and the body calling every function of float and texture parameters."""
    globals_, body = [], ["    float v = float(id.x) / 63.0;", "    float sum = 0.0;"]
    textures: dict[str, str] = {}
    # A function returning a struct (an engine preset's) is summed by the struct's first field.
    fields = {struct: f".{field}" + ("" if kind == "float" else ".x") for struct, kind, field in STRUCT.findall(text)}
    for returned, name, parameters in FUNCTION.findall(text):
        if name == ENTRY or returned == "TmResult":
            continue
        if returned in ("float", "float2", "float3", "float4"):
            read = "" if returned == "float" else ".x"
        elif returned in fields:
            read = fields[returned]
        else:
            continue
        arguments = []
        for parameter in filter(None, (p.strip() for p in parameters.split(","))):
            kind = parameter.rsplit(None, 1)[0]
            if kind.startswith("Texture"):
                if kind not in textures:
                    textures[kind] = f"tmlut_check_texture{len(textures)}"
                    globals_.append(f"{kind} {textures[kind]} : register(t{len(textures) - 1});")
                arguments.append(textures[kind])
            elif kind in ("float", "float2", "float3", "float4"):
                arguments.append(f"({kind})v")
            else:
                break
        else:
            call = f"{name}({', '.join(arguments)})"
            body.append(f"    sum += {call}{read};")
    return "\n".join(globals_), "\n".join(body)


def compile_one(validator: str, path: pathlib.Path, work: pathlib.Path) -> str | None:
    text = path.read_text()
    description_path = path.with_suffix(".shader.json")
    if description_path.exists():
        globals_, body = "", scene_entry(json.loads(description_path.read_text()))
    else:
        globals_, body = library_entry(text)
    source = work / path.name
    source.write_text(
        f"{text}\n{globals_}\nRWStructuredBuffer<float> tmlut_check_out : register(u0);\n"
        f"[numthreads(64, 1, 1)]\nvoid {ENTRY}(uint3 id : SV_DispatchThreadID) {{\n{body}\n"
        "    tmlut_check_out[id.x] = sum;\n}\n"
    )
    return compile_checked(validator, ["-D", "-V", "-S", "comp", "-e", ENTRY, str(source), "-o", str(work / "out.spv")])


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    validator = sys.argv[1]
    files = sorted({p for d in sys.argv[2:] for p in pathlib.Path(d).rglob("*.hlsl")})
    if not files:
        print("hlsl_check: no .hlsl file under " + ", ".join(sys.argv[2:]), file=sys.stderr)
        return 1
    failed = 0
    with tempfile.TemporaryDirectory() as work:
        for path in files:
            error = compile_one(validator, path, pathlib.Path(work))
            if error is not None:
                failed += 1
                print(f"FAIL {path}:\n{error}")
    print(f"HLSL compiled by glslang to SPIR-V: {len(files) - failed} of {len(files)} files, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
