//! three.js's image-based specular term as shader functions over a preset folder's `karis`
//! texture, so that a renderer outside three.js (or a test of three.js's own) computes what
//! three.js computes from the table tmlut wrote: `threejs_dfg(roughness, dot_nv)` reads
//! `(scale, bias)` as three.js reads `DFGLUTData.js` (the same f16 values; tmlut's file keeps
//! `n.v` as `x`, so the coordinates are the manifest's, not three.js's swapped pair), and
//! `threejs_multiscattering(specular_color, specular_f90, roughness, dot_nv)` applies the energy
//! compensation three.js applies to them, Fdez-Agüera 2019 ("A Multiple-Scattering Microfacet
//! Model for Real-Time Image-based Lighting", JCGT 8(1)):
//!
//! ```text
//! FssEss = F0 scale + F90 bias                      single scattering (the split sum)
//! Ess = scale + bias,  Ems = 1 - Ess                the lobe's albedo with F = 1, and what it loses
//! Favg = F0 + (1 - F0) / 21                         Schlick's Fresnel averaged over the hemisphere
//! Fms = FssEss Favg / (1 - Ems Favg)                the multiple-scattering colour (a geometric series)
//! multi_scatter = Fms Ems
//! ```
//!
//! three.js adds `single_scatter` to its specular and `multi_scatter` to it again, weighted by its
//! radiance and irradiance (`lights_physical_pars_fragment`, `docs/engines.md`).

use crate::error::{Error, Result};
use crate::ir::shader::validate;
use crate::ir::shader::{Expr, Item, Lang, Module, Parens, Stmt, Ty, float, func, let_, name, splat3};
use crate::shader::scene::texture_coordinate;
use crate::table::Axis;

/// The texture binding (the folder's `karis.dds` or `karis.ktx2`) and its sampler.
pub const TEXTURE: &str = "dfg_lut";
pub const SAMPLER: &str = "dfg_lut_sampler";
/// The functions and the struct the second returns.
pub const DFG: &str = "threejs_dfg";
pub const MULTISCATTERING: &str = "threejs_multiscattering";
pub const SCATTERING: &str = "ThreejsScattering";
/// The files' name, before each language's extension.
pub const STEM: &str = "threejs_dfg";

/// The module over a `karis` table of `axes` (`n.v`, then `alpha` mapped to perceptual roughness).
pub fn module(axes: &[Axis]) -> Module {
    let mut m = Module::new(Parens::Minimal);
    m.comment(
        "three.js's image-based specular term over tmlut's karis table (written by `tmlut build --preset threejs`;\n\
         the folder's manifest.json states the table's integral, conventions and error). Bind karis.dds or\n\
         karis.ktx2 as dfg_lut with a linear, clamp-to-edge sampler, as three.js binds DFGLUTData.js.",
    );
    m.push(Item::Binding { group: 0, binding: 0, name: TEXTURE.into(), ty: Ty::Texture { dims: 2, scalar: false } });
    m.push(Item::Binding { group: 0, binding: 1, name: SAMPLER.into(), ty: Ty::Sampler });
    m.push(Item::Struct {
        name: SCATTERING.into(),
        fields: vec![("single_scatter".into(), Ty::Vec(3)), ("multi_scatter".into(), Ty::Vec(3))],
    });
    m.push(Item::Blank);
    m.comment(
        "(scale, bias) at perceptual roughness and n.v: three.js's texture2D(dfgLUT, vec2(roughness, dotNV)).rg.",
    );
    // The table's second axis is alpha; its coordinate maps alpha back to roughness, so the read
    // is at the texel three.js's roughness coordinate reads.
    let alpha = name("roughness") * name("roughness");
    let coordinates = vec![texture_coordinate(&axes[0], name("dot_nv")), texture_coordinate(&axes[1], alpha)];
    let read = Expr::SampleLevel {
        texture: TEXTURE.into(),
        scalar_texture: false,
        sampler: SAMPLER.into(),
        coordinates,
        layer: None,
        swizzle: "xy",
    };
    m.function(DFG, vec![("roughness", Ty::F32), ("dot_nv", Ty::F32)], Ty::Vec(2), vec![Stmt::Return(read)]);
    m.push(Item::Blank);
    m.comment(
        "Single and multiple scattering of the specular lobe for the environment (Fdez-Agüera 2019), as three.js's\n\
         computeMultiscattering adds them: specular_color is F0, specular_f90 is F90.",
    );
    let one = || splat3(float(1.0));
    let (specular_color, fab) = (|| name("specular_color"), || name("fab"));
    let body = vec![
        let_("fab", Ty::Vec(2), func(DFG, vec![name("roughness"), name("dot_nv")])),
        let_(
            "fss_ess",
            Ty::Vec(3),
            specular_color() * fab().member("x") + splat3(name("specular_f90") * fab().member("y")),
        ),
        let_("ems", Ty::F32, float(1.0) - (fab().member("x") + fab().member("y"))),
        let_("f_avg", Ty::Vec(3), specular_color() + (one() - specular_color()) * float((1.0f64 / 21.0) as f32)),
        let_("f_ms", Ty::Vec(3), name("fss_ess") * name("f_avg") / (one() - splat3(name("ems")) * name("f_avg"))),
        Stmt::Var { name: "result".into(), ty: Ty::Named(SCATTERING.into()), value: None },
        Stmt::Assign(name("result").member("single_scatter"), name("fss_ess")),
        Stmt::Assign(name("result").member("multi_scatter"), name("f_ms") * name("ems")),
        Stmt::Return(name("result")),
    ];
    let params =
        vec![("specular_color", Ty::Vec(3)), ("specular_f90", Ty::F32), ("roughness", Ty::F32), ("dot_nv", Ty::F32)];
    m.function(MULTISCATTERING, params, Ty::Named(SCATTERING.into()), body);
    m
}

/// The module's text in each language it ships in, with its file name: `threejs_dfg.wgsl`,
/// `.hlsl` and `.glsl` (an includable function file, as the fitted forms' GLSL). The WGSL, with a
/// compute entry point calling both functions, and the GLSL, inside such a harness, are validated
/// by naga; a module it refuses is an error, never a file.
pub fn files(axes: &[Axis]) -> Result<Vec<(Lang, String, String)>> {
    let m = module(axes);
    let refused = |what: &str, e: String| Error::invalid("threejs shader", format!("naga refused the {what}: {e}"));
    let (wgsl, glsl) = (m.print(Lang::Wgsl), m.print(Lang::Glsl));
    let calls = format!("{DFG}(0.5, 0.5); _ = {MULTISCATTERING}(vec3<f32>(0.04), 1.0, 0.5, 0.5);");
    let entry = format!("{wgsl}\n@compute @workgroup_size(1)\nfn main() {{\n    _ = {calls}\n}}\n");
    validate::wgsl(&entry).map_err(|e| refused("WGSL", e))?;
    let harness = format!(
        "#version 450\n{glsl}\nlayout(local_size_x = 1) in;\nvoid main() {{\n    vec2 fab = {DFG}(0.5, 0.5);\n    \
         {SCATTERING} s = {MULTISCATTERING}(vec3(0.04), 1.0, 0.5, 0.5);\n}}\n"
    );
    validate::glsl(&harness, naga::ShaderStage::Compute).map_err(|e| refused("GLSL", e))?;
    Ok([(Lang::Wgsl, wgsl), (Lang::Hlsl, m.print(Lang::Hlsl)), (Lang::Glsl, glsl)]
        .into_iter()
        .map(|(lang, text)| (lang, format!("{STEM}.{}", lang.extension()), text))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::manifest::{MANIFEST_FILE, Manifest};
    use crate::ir::shader::eval::{Machine, Textures, Value};
    use crate::loader::{KarisLut, LutFolder, Roughness};

    /// The folder's karis texture as a GPU filters it (the loader's sampler: 8-bit weights, clamp).
    struct Karis(KarisLut);

    impl Textures for Karis {
        fn load(&self, texture: &str, _: &[i32]) -> crate::error::Result<Option<[f32; 4]>> {
            panic!("the functions filter, yet they load a texel of {texture}")
        }
        fn sample(
            &self,
            texture: &str,
            sampler: &str,
            at: &[f32],
            _: Option<i32>,
        ) -> crate::error::Result<Option<[f32; 4]>> {
            assert_eq!((texture, sampler), (TEXTURE, SAMPLER));
            let [scale, bias] = self.0.sample_uv(at[0], at[1]);
            Ok(Some([scale, bias, 0.0, 1.0]))
        }
    }

    /// What three.js computes from `(scale, bias)` (Fdez-Agüera 2019, the module's doc), in f64:
    /// single and multiple scattering per channel.
    fn multiscattering(f0: [f64; 3], f90: f64, [scale, bias]: [f64; 2]) -> [[f64; 3]; 2] {
        let ems = 1.0 - (scale + bias);
        let single = f0.map(|f| f * scale + f90 * bias);
        let multi = [0, 1, 2].map(|c| {
            let f_avg = f0[c] + (1.0 - f0[c]) / 21.0;
            single[c] * f_avg / (1.0 - ems * f_avg) * ems
        });
        [single, multi]
    }

    #[test]
    fn the_functions_run_on_the_cpu_give_what_three_js_computes_from_the_folders_table() {
        let dir = tempfile::tempdir().unwrap();
        let preset = crate::presets::Preset::load("threejs").unwrap();
        crate::pipeline::build_preset(preset, dir.path(), &()).expect("the preset builds");
        // The three files are listed with the engine file, and hold what the module prints.
        let manifest = Manifest::read(&dir.path().join(MANIFEST_FILE)).unwrap();
        let entry = &manifest.drop_ins[crate::presets::threejs::FILE];
        let listed: Vec<&str> = entry.shaders.iter().map(|s| s.file.as_str()).collect();
        assert_eq!(listed, ["threejs_dfg.wgsl", "threejs_dfg.hlsl", "threejs_dfg.glsl"]);
        let lut = KarisLut::from_folder(&LutFolder::open(dir.path()).unwrap()).unwrap();
        let axes = lut.table().axes.clone();
        for (lang, file, text) in files(&axes).unwrap() {
            assert_eq!(std::fs::read_to_string(dir.path().join(&file)).unwrap(), text, "{lang:?}");
        }

        let module = module(&axes);
        let machine = Machine::new(&module).unwrap();
        let karis = Karis(lut);
        let grid = [0.0f32, 1e-3, 0.03, 0.2, 0.5, 0.77, 0.999, 1.0];
        for &roughness in &grid {
            for &dot_nv in &grid {
                // The read, at the texel the loader's own lookup by roughness reads.
                let run = machine.call(DFG, vec![Value::F32(roughness), Value::F32(dot_nv)], &karis).unwrap();
                let read = run.value.components().unwrap();
                assert_eq!(
                    read,
                    karis.0.sample_gpu(dot_nv, Roughness(roughness)),
                    "roughness {roughness}, n.v {dot_nv}"
                );

                let (f0, f90) = ([0.04f32, 0.5, 0.95], 1.0f32);
                let arguments =
                    vec![Value::Vector(f0.to_vec()), Value::F32(f90), Value::F32(roughness), Value::F32(dot_nv)];
                let run = machine.call(MULTISCATTERING, arguments, &karis).unwrap();
                let expected = multiscattering(f0.map(f64::from), f64::from(f90), [read[0], read[1]].map(f64::from));
                for (field, expected) in ["single_scatter", "multi_scatter"].into_iter().zip(expected) {
                    let got = run.value.field(field).unwrap().components().unwrap();
                    for (g, e) in got.iter().zip(expected) {
                        assert!(
                            g.is_finite() && (f64::from(*g) - e).abs() <= 1e-6,
                            "{field} at {roughness}, {dot_nv}: {got:?} vs {expected:?}"
                        );
                    }
                }
            }
        }
    }
}
