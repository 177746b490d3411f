//! A scene shader run on the CPU: its module's statements interpreted in f32 with WGSL's meaning
//! (the IR's [`tmlut::shader::eval`]), each `textureLoad` reading the texels of the folder's file
//! as stored, so that the generated code (its coordinates, slice choosers, filtering and the
//! recorded model) is compared with the CPU evaluator on any machine, without a GPU API. What it
//! checks that the GPU does not: a load outside its texture is an error here, where a GPU would
//! read some texel or 0.

use std::collections::HashMap;

use tmlut::error::Result;
use tmlut::loader::LutFolder;
use tmlut::shader::Module;
pub use tmlut::shader::eval::Value;
use tmlut::shader::eval::{Machine, Run, Textures};
use tmlut::shader::scene::{CONSTANTS, SceneShader};

/// A texture's texels as stored (f16 widened exactly), channels interleaved, x fastest.
struct Texels {
    extent: [usize; 3],
    channels: usize,
    data: Vec<f32>,
}

/// The folder's textures, by the variable each is bound to.
struct Folder(HashMap<String, Texels>);

pub struct Emulator<'a> {
    machine: Machine<'a>,
    textures: Folder,
}

impl<'a> Emulator<'a> {
    /// The emulator of `shader`, its textures read from `folder`, its constants buffer bound.
    pub fn new(shader: &'a SceneShader, folder: &LutFolder) -> Self {
        let mut emulator = Self::of_module(&shader.module, shader, folder);
        emulator.machine.bind_buffer(CONSTANTS, shader.constants.clone()).unwrap();
        emulator
    }

    /// The emulator of `module`, which binds the textures of `shader`, read from `folder`.
    pub fn of_module(module: &'a Module, shader: &SceneShader, folder: &LutFolder) -> Self {
        let textures = shader
            .textures
            .iter()
            .map(|binding| {
                let table = folder.load(&binding.file).unwrap();
                let extent = binding.extent;
                let channels = table.channel_count();
                assert_eq!(table.data.len(), extent.iter().product::<usize>() * channels, "{}", binding.file);
                (binding.variable.clone(), Texels { extent, channels, data: table.data })
            })
            .collect();
        Emulator { machine: Machine::new(module).unwrap(), textures: Folder(textures) }
    }

    /// Function `name` called with `arguments`: what it returns, every value known.
    pub fn call(&self, name: &str, arguments: Vec<Value>) -> Value {
        self.run(name, arguments).value
    }

    /// [`Self::call`], with what the call cost.
    pub fn run(&self, name: &str, arguments: Vec<Value>) -> Run {
        let run = self.machine.call(name, arguments, &self.textures).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(run.value.is_known(), "{name} returned {:?}", run.value);
        run
    }
}

impl Textures for Folder {
    /// The texel at `at` of `texture` as WGSL's `textureLoad` returns it: four channels, a
    /// missing one 0 (alpha 1).
    fn load(&self, texture: &str, at: &[i32]) -> Result<Option<[f32; 4]>> {
        let texels = &self.0[texture];
        let mut index = 0;
        for d in (0..3).rev() {
            let x = at.get(d).copied().unwrap_or(0);
            assert!(
                x >= 0 && (x as usize) < texels.extent[d],
                "a load of {texture} at {at:?}, outside its extent {:?}",
                texels.extent
            );
            index = index * texels.extent[d] + x as usize;
        }
        let first = index * texels.channels;
        Ok(Some([0, 1, 2, 3].map(|c| match texels.data.get(first + c).filter(|_| c < texels.channels) {
            Some(&value) => value,
            None if c == 3 => 1.0,
            None => 0.0,
        })))
    }

    fn sample(&self, texture: &str, _: &str, _: &[f32], _: Option<i32>) -> Result<Option<[f32; 4]>> {
        panic!("a scene shader filters by hand, yet it samples {texture}")
    }
}
