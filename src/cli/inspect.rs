//! `tmlut inspect`: describe a table file.

use std::path::PathBuf;

use clap::Args;

use super::Context;

/// Describe a table file: axes, channels, value range, NaN count, conventions.
#[derive(Args)]
pub struct InspectArgs {
    file: PathBuf,
}

pub fn exec(args: InspectArgs, _: &Context) -> tmlut::Result<()> {
    let inspection = tmlut::report::inspect(&args.file)?;
    print!("{}", inspection.text);
    if inspection.disagreements.is_empty() {
        Ok(())
    } else {
        Err(tmlut::Error::format(
            &args.file,
            format!(
                "differs from its entry in manifest.json in {} way(s) (see DIFFERS above)",
                inspection.disagreements.len()
            ),
        ))
    }
}
