//! `tmlut cache`: what the table cache holds, and pruning it.

use std::path::PathBuf;

use clap::Args;

use tmlut::scene::cache::{self, CacheUsage};
use tmlut::scene::plan::human_bytes;

use super::Context;

/// Show the table cache (entries and bytes) that `tmlut build --scene ... --cache` reads and
/// fills, or prune it to a size, oldest entries first. Only the cache's own files are touched.
#[derive(Args)]
pub struct CacheArgs {
    /// The cache folder (default: $XDG_CACHE_HOME/tmlut, else ~/.cache/tmlut).
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Remove the oldest entries until the cache holds at most this many bytes (0 empties it).
    #[arg(long)]
    prune_to: Option<u64>,
    /// Integrate every entry again from the inputs it records and compare its values bit for bit:
    /// the full audit of a cache (every read checks an entry at a few nodes only). Costs what
    /// building every entry costs; exits 1 naming each entry whose values differ.
    #[arg(long, conflicts_with = "prune_to")]
    verify: bool,
}

pub fn exec(args: CacheArgs, context: &Context) -> tmlut::Result<()> {
    let dir = super::build::cache_folder(Some(args.dir.unwrap_or_default()))?.expect("a folder or an error");
    if !dir.exists() {
        println!("table cache {}: no cache there yet (a build with --cache creates it)", dir.display());
        return Ok(());
    }
    let shown = |usage: CacheUsage| {
        let unmarked = match usage.unmarked {
            0 => String::new(),
            n => format!(
                " ({n} files named as entries are not this tmlut's: an earlier cache format's, neither counted nor \
                 pruned; remove them by hand)"
            ),
        };
        format!("{} entries, {}{unmarked}", usage.entries, human_bytes(usage.bytes))
    };
    let before = cache::usage(&dir)?;
    if args.verify {
        let verified = cache::verify(&dir, &context.progress())?;
        println!(
            "table cache {}: {} entries integrated again, {} identical to the bit, {} of another tmlut version or \
             cache format (not compared), {} refused",
            dir.display(),
            verified.identical + verified.refused.len() + verified.other_version,
            verified.identical,
            verified.other_version,
            verified.refused.len()
        );
        if !verified.refused.is_empty() {
            return Err(tmlut::Error::invalid(
                "tmlut cache --verify",
                format!(
                    "{} entries of {} hold values their inputs do not integrate to, or are damaged; remove them, or \
                     prune the cache (--prune-to 0):\n  {}",
                    verified.refused.len(),
                    dir.display(),
                    verified.refused.join("\n  ")
                ),
            ));
        }
        return Ok(());
    }
    match args.prune_to {
        Some(max_bytes) => {
            let after = cache::prune(&dir, max_bytes)?;
            println!("table cache {}: {} before, {} after pruning", dir.display(), shown(before), shown(after));
        }
        None => println!("table cache {}: {}", dir.display(), shown(before)),
    }
    Ok(())
}
