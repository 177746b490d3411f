//! Temporary: the packing lookups' printers as they were before the emitter, to prove the
//! emitter prints them byte for byte.
use std::fmt::Write as _;

use super::shader::{Program, Step};
use super::tests::noise;
use super::*;

/// An HLSL function `float NAME(Texture3D<float> tex[, SamplerState linear_clamp], float mu, ...)`.
/// Value locals are `precise`: the compiler must evaluate them as written (no reassociation),
/// which the exact interpolation weights rely on.
pub fn old_hlsl(p: &Program, header: &str) -> String {
    let mut s = comment_block("//", header);
    let mut params = vec!["Texture3D<float> tex".to_string()];
    if p.uses_sampler() {
        params.push("SamplerState linear_clamp".into());
    }
    params.extend(p.inputs.iter().map(|i| format!("float {i}")));
    let _ = writeln!(s, "float {}({})\n{{", p.function, params.join(", "));
    for (name, step) in &p.locals {
        let _ = match step {
            Step::Value(e) => writeln!(s, "    precise float {name} = {};", p.text(e)),
            Step::Sample(c) => {
                let [u, v, w] = p.names(c);
                writeln!(s, "    float {name} = tex.SampleLevel(linear_clamp, float3({u}, {v}, {w}), 0);")
            }
            Step::Load(c) => {
                let [x, y, z] = p.names(c);
                writeln!(s, "    float {name} = tex.Load(int4(int({x}), int({y}), int({z}), 0));")
            }
        };
    }
    let _ = writeln!(s, "    return {};\n}}", p.text(&p.result));
    s
}

/// A WGSL function `fn NAME(tex: texture_3d<f32>[, linear_clamp: sampler], mu: f32, ...) -> f32`.
pub fn old_wgsl(p: &Program, header: &str) -> String {
    let mut s = comment_block("//", header);
    let mut params = vec!["tex: texture_3d<f32>".to_string()];
    if p.uses_sampler() {
        params.push("linear_clamp: sampler".into());
    }
    params.extend(p.inputs.iter().map(|i| format!("{i}: f32")));
    let _ = writeln!(s, "fn {}({}) -> f32 {{", p.function, params.join(", "));
    for (name, step) in &p.locals {
        let _ = match step {
            Step::Value(e) => writeln!(s, "    let {name}: f32 = {};", p.text(e)),
            Step::Sample(c) => {
                let [u, v, w] = p.names(c);
                writeln!(
                    s,
                    "    let {name}: f32 = textureSampleLevel(tex, linear_clamp, vec3<f32>({u}, {v}, {w}), 0.0).r;"
                )
            }
            Step::Load(c) => {
                let [x, y, z] = p.names(c);
                writeln!(s, "    let {name}: f32 = textureLoad(tex, vec3<i32>(i32({x}), i32({y}), i32({z})), 0).r;")
            }
        };
    }
    let _ = writeln!(s, "    return {};\n}}", p.text(&p.result));
    s
}

fn comment_block(prefix: &str, text: &str) -> String {
    text.lines().map(|l| if l.is_empty() { format!("{prefix}\n") } else { format!("{prefix} {l}\n") }).collect()
}

#[test]
fn the_emitter_prints_the_packing_lookups_byte_for_byte() {
    for packing in crate::packing::Packing::ALL {
        let packed = PackedFgd::pack(&noise([64, 64, 4, 64]), packing, Precision::F32).unwrap();
        let p = &packed.program;
        assert_eq!(old_hlsl(p, "h\n\nx"), p.hlsl("h\n\nx"));
        assert_eq!(old_wgsl(p, "h\n\nx"), p.wgsl("h\n\nx"));
    }
}
