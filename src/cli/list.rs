//! `tmlut list`: the tables of the registry.

use clap::Args;

use tmlut::config::Config;

use super::Context;

/// List the tables tmlut knows.
#[derive(Args)]
pub struct ListArgs {}

pub fn exec(_: ListArgs, _: &Context) -> tmlut::Result<()> {
    for recipe in Config::default().recipes() {
        println!("{:<8} {}", recipe.name(), recipe.description());
    }
    Ok(())
}
