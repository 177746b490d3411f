//! Shader validation with naga (the WebGPU shader front end of wgpu and Firefox): parse, then
//! validate types, uniformity and resource use, as a WebGPU implementation does before it compiles
//! a shader module. WGSL by its own front end; GLSL by naga's GLSL front end, which reads a whole
//! shader (a `#version` and an entry point: a module printed as GLSL is an include, validated
//! inside a shader that wraps it). HLSL has no free validator among the Rust crates (naga writes
//! HLSL but does not read it); `docs/shaders.md` states what is checked instead.

/// What naga made of a shader: the module and what validation found of it (what naga's back ends
/// write other languages from).
pub type Validated = (naga::Module, naga::valid::ModuleInfo);

/// Parse and validate `text` as a WGSL module; the error names the line naga points at.
pub fn wgsl(text: &str) -> Result<Validated, String> {
    let module = naga::front::wgsl::parse_str(text).map_err(|e| e.emit_to_string(text))?;
    validated(module, text)
}

/// Parse and validate `text` as a GLSL shader of `stage`; the error names the line naga points at.
pub fn glsl(text: &str, stage: naga::ShaderStage) -> Result<Validated, String> {
    let module = naga::front::glsl::Frontend::default()
        .parse(&naga::front::glsl::Options::from(stage), text)
        .map_err(|e| e.emit_to_string(text))?;
    validated(module, text)
}

fn validated(module: naga::Module, text: &str) -> Result<Validated, String> {
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| e.emit_to_string(text))?;
    Ok((module, info))
}
