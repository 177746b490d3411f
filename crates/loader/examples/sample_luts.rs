//! A renderer's first contact with a folder tmlut built: open it, sample the split-sum and TIR
//! tables where they are present, and describe the texture each would be uploaded as.
//!
//! ```sh
//! scripts/build-luts                                              # or: tmlut build --out out/luts
//! cargo run -p tmlut-loader --example sample_luts -- luts
//! ```

use std::process::ExitCode;

use tmlut_loader::{Alpha, KarisLut, LutFolder, Roughness, TextureData, TirLut};

fn describe(name: &str, texture: &TextureData) {
    let descriptor = texture.descriptor();
    println!(
        "  {name}: {:?} texture {} x {} x {}, {:?}, {} bytes",
        descriptor.dimension,
        descriptor.width,
        descriptor.height,
        descriptor.depth_or_layers,
        descriptor.format,
        descriptor.byte_len()
    );
}

fn run(folder: &str) -> tmlut_loader::Result<()> {
    let luts = LutFolder::open(folder)?;
    println!("{folder}: {} files in its manifest", luts.manifest().files.len());
    if luts.manifest().files.contains_key("karis.dds") {
        let karis = KarisLut::from_folder(&luts)?;
        println!("Karis split sum (scale, bias) at n.v = 0.5:");
        for roughness in [0.1f32, 0.5, 0.9] {
            let [scale, bias] = karis.sample(0.5, Roughness(roughness));
            println!("  roughness {roughness}: ({scale:.5}, {bias:.5})");
        }
        describe("karis.dds", &karis.texture()?);
    }
    if luts.manifest().files.contains_key("tir.dds") {
        let tir = TirLut::from_folder(&luts)?;
        println!("TIR: the energy kept inside a dielectric at mu = 0.7, alpha = 0.01:");
        for eta in [0.67f32, 0.9, 1.0] {
            println!("  eta {eta}: {:.5}", tir.sample(0.7, Alpha(0.01), eta));
        }
        describe("tir.dds", &tir.texture()?);
    }
    Ok(())
}

fn main() -> ExitCode {
    let Some(folder) = std::env::args().nth(1) else {
        eprintln!("usage: sample_luts FOLDER   (a folder tmlut built, with its manifest.json)");
        return ExitCode::from(2);
    };
    match run(&folder) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
