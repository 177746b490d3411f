//! `tmlut inspect FILE`: what a table file holds (format, dimensions, channels, value range,
//! non-finite values) and, from the manifest beside it, every convention needed to read it right.

use std::fmt::Write;
use std::path::Path;

use crate::error::Result;
use crate::formats::manifest::{FileEntry, MANIFEST_FILE};
use crate::formats::{FileFormat, as_format_error, bin, dds, ktx2};
use crate::loader::{byte_disagreements, sha256_hex, table_disagreements};
use crate::table::{Axis, Placement, Table};

/// What `tmlut inspect` found: the description, and where the file and its manifest entry
/// disagree (empty when they agree or there is no entry).
#[derive(Debug, Clone, PartialEq)]
pub struct Inspection {
    pub text: String,
    pub disagreements: Vec<String>,
}

/// A readable description of a table file, checked against its manifest entry.
pub fn inspect(path: &Path) -> Result<Inspection> {
    let bytes = crate::formats::read_bytes(path)?;
    let format = crate::loader::format_of_bytes(path, &bytes)?;
    let beside = crate::loader::ManifestBeside::of(path)?;
    let (manifest_path, entry) = (&beside.manifest_path, beside.entry());

    let mut out = String::new();
    let mut disagreements = Vec::new();
    let w = &mut out;
    let _ = writeln!(w, "file:     {} ({} bytes)", path.display(), bytes.len());
    // The table the file holds, as far as the file alone (and, for DDS, the entry's axes) says.
    let (data, table): (Vec<f32>, Option<Table>) = match format {
        FileFormat::Dds => {
            let texture = dds::decode_dds(&bytes, path)?;
            let _ = writeln!(
                w,
                "format:   DDS with DX10 header, {}, {}, 1 mip level",
                dds::dxgi_format_name(texture.channels, texture.precision),
                texture.describe()
            );
            let table = entry.and_then(|entry| {
                let axes = entry.axes.iter().map(|a| a.axis.clone()).collect();
                match texture.clone().into_table(&entry.table, axes, entry.channels.clone()) {
                    Ok(table) => Some(table),
                    Err(e) => {
                        disagreements.push(as_format_error(e, path).to_string());
                        None
                    }
                }
            });
            (texture.data, table)
        }
        FileFormat::Ktx2 => {
            let file = ktx2::decode_ktx2(&bytes, path)?;
            let (texture, description) = (&file.texture, &file.description);
            let _ = writeln!(
                w,
                "format:   KTX2, VK_FORMAT_{}, {}, 1 mip level, no supercompression, orientation {}, written by {}",
                ktx2::vk_format_name(texture.channels, texture.precision),
                texture.describe(),
                description.orientation,
                description.writer
            );
            let data = texture.data.clone();
            let table = file.into_table().map_err(|e| as_format_error(e, path))?;
            if entry.is_none() {
                let _ = writeln!(w, "table:    {} (described by the file's key/value data)", table.name);
                write_axes(w, &table.axes);
                write_channels(w, &table);
            }
            (data, Some(table))
        }
        FileFormat::Bin => {
            let table = bin::decode_bin(&bytes, path, None)?;
            let _ = writeln!(w, "format:   transfer-matrix .bin (int32 sizes, float32 ranges, float32 data), f32");
            if entry.is_none() {
                write_axes(w, &table.axes);
            }
            (table.data.clone(), Some(table))
        }
        #[cfg(feature = "exr")]
        FileFormat::Exr => {
            let table = crate::formats::exr::decode_exr(&bytes, path)?;
            let _ = writeln!(w, "format:   OpenEXR, table `{}` described in the file's attributes", table.name);
            if entry.is_none() {
                write_axes(w, &table.axes);
                write_channels(w, &table);
            }
            (table.data.clone(), Some(table))
        }
        #[cfg(not(feature = "exr"))]
        FileFormat::Exr => return Err(crate::formats::no_exr_support(path)),
    };
    write_values(w, &data);

    match entry {
        Some(entry) => {
            write_entry(w, entry, &bytes);
            disagreements.extend(byte_disagreements(entry, &bytes));
            if let Some(table) = &table {
                disagreements.extend(table_disagreements(entry, format, &bytes, table));
            }
            if disagreements.is_empty() {
                let _ = writeln!(w, "manifest: {} agrees with the file", manifest_path.display());
            }
            for disagreement in &disagreements {
                let _ = writeln!(w, "DIFFERS:  {disagreement}");
            }
        }
        None if beside.manifest.is_some() => {
            let _ =
                writeln!(w, "manifest: {} lists no entry for this file: conventions unknown", manifest_path.display());
        }
        None => {
            let _ = writeln!(w, "manifest: no {MANIFEST_FILE} beside the file: conventions unknown");
        }
    }
    Ok(Inspection { text: out, disagreements })
}

fn write_values(w: &mut String, data: &[f32]) {
    let (mut min, mut max, mut nan, mut inf) = (f32::INFINITY, f32::NEG_INFINITY, 0usize, 0usize);
    for &v in data {
        if v.is_nan() {
            nan += 1;
        } else if v.is_infinite() {
            inf += 1;
        } else {
            min = min.min(v);
            max = max.max(v);
        }
    }
    let _ = writeln!(w, "values:   {} stored, min {min}, max {max}, NaN {nan}, infinite {inf}", data.len());
}

fn write_axes(w: &mut String, axes: &[Axis]) {
    let _ = writeln!(w, "axes (axis 0 varies fastest):");
    for (d, axis) in axes.iter().enumerate() {
        let placement = match axis.placement {
            Placement::NodeAligned => "node-aligned",
            Placement::CellCentred => "cell-centred",
        };
        let _ = writeln!(
            w,
            "  {d}: {:<6} {:>5} nodes over [{}, {}], {placement}, spaced in {}",
            axis.name,
            axis.count,
            axis.start,
            axis.end,
            axis.mapping.formula(&axis.name)
        );
        let _ = writeln!(w, "     texture coordinate = {}", axis.texture_coordinate_formula());
    }
}

fn write_channels(w: &mut String, table: &Table) {
    let _ = writeln!(w, "channels:");
    for channel in &table.channels {
        let _ = writeln!(w, "  {}: {}", channel.name, channel.meaning);
    }
}

fn write_entry(w: &mut String, entry: &FileEntry, bytes: &[u8]) {
    let _ = writeln!(w, "table:    {}", entry.table);
    write_axes(w, &entry.axes.iter().map(|a| a.axis.clone()).collect::<Vec<_>>());
    let _ = writeln!(w, "channels:");
    for channel in &entry.channels {
        let _ = writeln!(w, "  {}: {}", channel.name, channel.meaning);
    }
    let _ = writeln!(w, "integral: {}", entry.integrand);
    if let Some(masking) = &entry.masking {
        let _ = writeln!(w, "masking:  {masking}");
    }
    for note in &entry.notes {
        let _ = writeln!(w, "note:     {note}");
    }
    for axis in &entry.axes {
        if let Some(definition) = &axis.definition {
            let _ = writeln!(w, "quantity: {}: {definition}", axis.axis.name);
        }
    }
    if let Some(binding) = &entry.binding {
        let _ = writeln!(w, "binding:  {}; sampler: {}", binding.texture, binding.sampler);
        let _ = writeln!(
            w,
            "sample:   HLSL {}, WGSL {}, with {}",
            binding.hlsl,
            binding.wgsl,
            binding.coordinates.join(", ")
        );
    }
    let _ = writeln!(
        w,
        "sampling: {}; {}; {} samples per cell; seed {}; {:.2} s",
        entry.method, entry.sampler, entry.samples_per_cell, entry.seed, entry.wall_time_s
    );
    let error = &entry.error;
    let _ = write!(
        w,
        "error:    replicate standard error RMS {:.2e}, max {:.2e}",
        error.integration.replicate_standard_error.rms, error.integration.replicate_standard_error.max
    );
    if let Some(reference) = &error.integration.reference {
        let _ = write!(
            w,
            "; against the exact integral ({} Gauss–Legendre nodes per panel) at {} values: RMS {:.2e}, max {:.2e}",
            reference.exact_nodes, reference.difference.count, reference.difference.rms, reference.difference.max
        );
    }
    let _ = writeln!(w, "; storage rounding max {:.2e}", error.storage_rounding_max);
    if let Some(sum) = &error.storage_channel_sum {
        let _ = writeln!(
            w,
            "storage:  channels add up to an albedo, rounded `{}`: stored sum above 1 at {} texels (by up to {:.2e}), largest {}; above the integrated sum at {} texels (by up to {:.2e})",
            sum.rounding.name(),
            sum.texels_above_one,
            sum.max_above_one,
            sum.max_sum,
            sum.texels_above_integral,
            sum.max_above_integral
        );
    }
    for e in &error.interpolation {
        let _ = writeln!(
            w,
            "between nodes ({}): RMS {:.2e}, 99th percentile {:.2e}, max {:.2e} at {}; {}; read as {}; exact: quadrature, {} nodes per panel",
            e.domain, e.error.rms, e.p99, e.error.max, e.worst_at, e.points, e.read_as, e.exact_nodes
        );
    }
    let actual = sha256_hex(bytes);
    let verdict = if actual == entry.sha256 { "matches the manifest" } else { "DOES NOT match the manifest" };
    let _ = writeln!(w, "sha256:   {actual} ({verdict})");
}
