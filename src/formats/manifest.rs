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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::{FileFormat, Precision};
    use crate::stats::{ErrorRecord, ErrorSummary, ReferenceComparison};
    use crate::table::{Axis, Channel};
    use std::collections::BTreeMap;

    #[test]
    fn manifest_round_trips_through_json() {
        let axis = Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap();
        let entry = FileEntry {
            table: "gd".into(),
            format: FileFormat::Bin,
            precision: Precision::F32,
            dxgi_format: None,
            vk_format: None,
            axes: vec![AxisEntry::new(&axis, "axis 0")],
            channels: vec![Channel::new("value", "albedo")],
            integrand: "E[G1(wo)]".into(),
            masking: Some("smith-separable".into()),
            notes: vec![],
            method: "m".into(),
            sampler: "s".into(),
            samples_per_cell: 1024,
            seed: 1,
            wall_time_s: 0.5,
            value_range: [0.3, 1.0],
            nan_count: 0,
            error: ErrorEntry {
                integration: ErrorRecord {
                    replicate_standard_error: ErrorSummary { count: 4096, rms: 1e-5, max: 1e-4 },
                    reference: Some(ReferenceComparison {
                        exact_nodes: 8,
                        difference: ErrorSummary { count: 10, rms: 1e-5, max: 2e-5 },
                    }),
                },
                storage_rounding_max: 0.0,
                storage_channel_sum: None,
                interpolation: vec![],
            },
            fresnel_basis: None,
            accuracy: vec![],
            sha256: "00".into(),
            bytes: 16408,
            packing: None,
            fit: None,
            binding: None,
            slice_array: None,
            claims_sha256: None,
        };
        let mut manifest = Manifest { generator: "tmlut test".into(), files: BTreeMap::new(), ..Default::default() };
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
