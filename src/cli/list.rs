//! `tmlut list`: the tables of the registry and the engine presets.

use clap::Args;

use tmlut::config::Config;

use super::Context;

/// List the tables tmlut knows, and its engine presets (`build --preset`).
#[derive(Args)]
pub struct ListArgs {}

pub fn exec(_: ListArgs, _: &Context) -> tmlut::Result<()> {
    for recipe in Config::default().recipes() {
        println!("{:<8} {}", recipe.name(), recipe.description());
    }
    println!("\npresets (tmlut build --preset NAME --out DIR; files in luts/presets/):");
    for name in tmlut::presets::names() {
        let preset = tmlut::presets::Preset::load(name)?;
        println!("{name:<8} {}", preset.section.description);
    }
    Ok(())
}
