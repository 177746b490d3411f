//! Writing `manifest.json`; its types and its reader are the loader's
//! (`tmlut_loader::formats::manifest`), re-exported here.

pub use tmlut_loader::formats::manifest::*;

use std::path::Path;

use super::{MAX_MANIFEST_BYTES, write_bytes_atomically};
use crate::error::{Error, Result};

/// Write `manifest` as the manifest of `dir`, atomically.
pub fn write_manifest(manifest: &Manifest, dir: &Path) -> Result<()> {
    let mut text = serde_json::to_string_pretty(manifest).expect("a manifest is plain data and always serialises");
    text.push('\n');
    // What every reader refuses is never written.
    if text.len() as u64 > MAX_MANIFEST_BYTES {
        return Err(Error::format(
            dir.join(MANIFEST_FILE),
            format!(
                "would be {} bytes long; a manifest may be at most {MAX_MANIFEST_BYTES} bytes, which tmlut's readers \
                 hold it to: build fewer materials into one folder",
                text.len()
            ),
        ));
    }
    write_bytes_atomically(&dir.join(MANIFEST_FILE), text.as_bytes())
}

/// Takes every baked array's entry out of `manifest` and returns the files that leave with them:
/// the arrays and their baked shader's files. A bake is replaced whole or not at all, so whoever
/// writes a new one (or changes what the old one was baked from) removes all of these together.
pub fn take_bake(manifest: &mut Manifest) -> Vec<String> {
    let mut leaving = Vec::new();
    manifest.files.retain(|name, entry| {
        let Some(baked) = &entry.baked else { return true };
        leaving.push(name.clone());
        leaving.extend(baked.shader_files.iter().map(|f| f.file.clone()));
        false
    });
    leaving
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::{FileFormat, Precision};
    use crate::stats::{ErrorRecord, ErrorSummary, ReferenceComparison};
    use crate::table::{Axis, Channel};

    #[test]
    fn manifest_round_trips_through_json() {
        let axis = Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap();
        let axes = vec![AxisEntry::new(&axis, "axis 0")];
        let channels = vec![Channel::new("value", "albedo")];
        let mut entry = FileEntry::new("gd", FileFormat::Bin, Precision::F32, axes, channels, &[0; 16408]);
        entry.integrand = "E[G1(wo)]".into();
        entry.masking = Some("smith-separable".into());
        (entry.method, entry.sampler) = ("m".into(), "s".into());
        (entry.samples_per_cell, entry.seed, entry.wall_time_s) = (1024, 1, 0.5);
        entry.value_range = [0.3, 1.0];
        let reference = ReferenceComparison::new(8, ErrorSummary::new(10, 1e-5, 2e-5));
        entry.error = ErrorEntry::new(ErrorRecord::new(ErrorSummary::new(4096, 1e-5, 1e-4), Some(reference)), 0.0);
        let mut manifest = Manifest::new("tmlut test");
        manifest.files.insert("gd.bin".into(), entry);
        let dir = tempfile::tempdir().unwrap();
        write_manifest(&manifest, dir.path()).unwrap();
        let back = Manifest::read_or_default(dir.path()).unwrap();
        assert_eq!(back, manifest);
        let text = std::fs::read_to_string(dir.path().join(MANIFEST_FILE)).unwrap();
        assert!(text.contains("\"texture_coordinate\": \"(mu) * 63 / 64 + 0.5 / 64\""), "{text}");
        assert!(text.contains("\"placement\": \"node-aligned\""), "{text}");
    }
}
