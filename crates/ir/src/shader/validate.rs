//! WGSL validation with naga (the WebGPU shader front end of wgpu and Firefox): parse, then
//! validate types, uniformity and resource use, as a WebGPU implementation does before it compiles
//! a shader module. HLSL has no free validator among the Rust crates (naga writes HLSL but does
//! not read it); `docs/shaders.md` states what is checked instead.

/// Parse and validate `text` as a WGSL module; the error names the line naga points at.
pub fn wgsl(text: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(text).map_err(|e| e.emit_to_string(text))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| e.emit_to_string(text))?;
    Ok(module)
}
