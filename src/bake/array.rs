//! Baked materials laid out as one texture array (`tmlut_loader::formats::baked` states the
//! layout a reader relies on): each material's rows consecutive in one layer, layers a power of
//! two rows high so that a row's centre is exact in f32, as few texels as that allows.

use super::BakedMaterial;
use crate::error::{Error, Result};
use crate::formats::baked::{BakedArrayEntry, BakedErrors, BakedMaterialEntry};
use crate::formats::slice_array::{MAX_LAYERS, texel_axes};
use crate::table::{Channel, Table};

/// The tallest layer: WebGPU's default `maxTextureDimension2D`, which every adapter supports.
pub const MAX_LAYER_HEIGHT: usize = 8192;

/// Where each material's rows go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Arrangement {
    /// Rows per layer, a power of two.
    pub layer_height: usize,
    /// Layers, at least 2 (every axis of a table has two nodes or more).
    pub layers: usize,
    /// Each material's `(layer, first row)`, in input order.
    pub places: Vec<(usize, usize)>,
}

/// Materials of `rows` rows each, in order, filling each layer from the top (next fit: a material
/// that does not fit below the last opens the next layer), in layers of the power-of-two height
/// that takes the fewest texels (the lower of equals) within [`MAX_LAYERS`] layers. Deterministic:
/// it depends on the row counts and their order only. Refused where no height fits, naming the
/// rows.
pub fn arrange(rows: &[usize]) -> Result<Arrangement> {
    let most = rows.iter().copied().max().unwrap_or(1).max(2);
    let heights =
        std::iter::successors(Some(most.next_power_of_two()), |h| Some(h * 2)).take_while(|&h| h <= MAX_LAYER_HEIGHT);
    heights
        .map(|layer_height| arrange_in(rows, layer_height))
        .filter(|a| a.layers <= MAX_LAYERS)
        .min_by_key(|a| a.layer_height * a.layers)
        .ok_or_else(|| {
            let total: usize = rows.iter().sum();
            Error::invalid(
                "baked materials",
                format!(
                    "{} materials take {total} rows (the largest {most}); one array holds at most {MAX_LAYERS} layers \
                     of {MAX_LAYER_HEIGHT} rows: bake fewer materials in one folder",
                    rows.len()
                ),
            )
        })
}

/// [`arrange`] at one layer height.
fn arrange_in(rows: &[usize], layer_height: usize) -> Arrangement {
    let (mut layer, mut next_row) = (0, 0);
    let places = rows
        .iter()
        .map(|&r| {
            if next_row + r > layer_height {
                (layer, next_row) = (layer + 1, 0);
            }
            next_row += r;
            (layer, next_row - r)
        })
        .collect();
    Arrangement { layer_height, layers: (layer + 1).max(2), places }
}

/// The table of `materials` laid out by `arrangement`: RGBA texels, `nodes` wide, texels of no
/// material zero. Every material must have `nodes` nodes.
pub fn baked_table(name: &str, materials: &[BakedMaterial], arrangement: &Arrangement) -> Result<Table> {
    let nodes = materials.first().map_or(0, BakedMaterial::nodes);
    if let Some(other) = materials.iter().find(|m| m.nodes() != nodes) {
        return Err(Error::invalid(
            format!("baked material `{}`", other.name),
            format!("has {} nodes where the others have {nodes}: one array holds rows of one width", other.nodes()),
        ));
    }
    let height = arrangement.layer_height;
    let mut data = vec![0f32; nodes * height * arrangement.layers * 4];
    for (material, &(layer, first_row)) in materials.iter().zip(&arrangement.places) {
        for row in 0..material.rows() {
            for k in 0..nodes {
                let to = ((layer * height + first_row + row) * nodes + k) * 4;
                data[to..to + 4].copy_from_slice(&material.texel(row, k));
            }
        }
    }
    let channels = ["r", "g", "b", "a"]
        .iter()
        .enumerate()
        .map(|(c, name)| Channel::new(*name, format!("value 4 row + {c} of each material: baked.materials[].values")))
        .collect();
    Table::new(name, texel_axes([nodes, height], arrangement.layers)?, channels, data)
}

/// The manifest entry of one material at `place`, with its `error`.
pub fn material_entry(
    material: &BakedMaterial,
    (layer, first_row): (usize, usize),
    error: BakedErrors,
) -> BakedMaterialEntry {
    let layout = material.layout;
    BakedMaterialEntry::new(
        &material.name,
        layout.lobes as u32,
        (layer as u32, first_row as u32),
        material.placement.segment_maps(),
        (0..layout.values()).map(|i| layout.value_name(i)).collect(),
        material.axes.clone(),
        error,
    )
}

/// The entry of the whole array.
pub fn array_entry(
    scene: &str,
    source: &str,
    tolerance: f64,
    nodes: usize,
    arrangement: &Arrangement,
    materials: Vec<BakedMaterialEntry>,
) -> BakedArrayEntry {
    let extent = [nodes as u32, arrangement.layer_height as u32];
    BakedArrayEntry::new(scene, source, tolerance, extent, arrangement.layers as u32, materials)
}

/// Most materials [`summary`] lists one by one (the largest errors first).
const MATERIALS_LISTED: usize = 16;

/// What a bake wrote, in a few lines: the array's size, and the materials of the largest error
/// with their lobes, rows and breaks.
pub fn summary(array: &BakedArrayEntry) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let materials = &array.materials;
    let _ = writeln!(
        out,
        "baked {} material(s) from {}: {} layer(s) of {} x {} RGBA texels",
        materials.len(),
        array.source,
        array.layers,
        array.layer_extent[0],
        array.layer_extent[1]
    );
    if super::measured_against_its_tables(array) {
        let _ = writeln!(out, "  errors against {}", super::TABLES_REFERENCE);
    }
    let mut by_error: Vec<&BakedMaterialEntry> = materials.iter().collect();
    by_error.sort_by(|a, b| b.error.max().total_cmp(&a.error.max()));
    for m in by_error.iter().take(MATERIALS_LISTED) {
        let worst = m.error.worst();
        let varied: Vec<String> = m.varied.iter().map(|a| format!("{} ({} nodes)", a.parameter, a.nodes)).collect();
        let at_varied: Vec<String> =
            m.varied.iter().zip(&worst.at_varied).map(|(a, v)| format!(", {} {v:.4}", a.parameter)).collect();
        let _ = writeln!(
            out,
            "  {}: {} lobe(s), {} texel reads, {} break(s){}; largest error {:.1e} ({} at mu {:.4}{})",
            m.material,
            m.lobes,
            m.rows << m.varied.len(),
            m.segments.len().saturating_sub(1),
            if varied.is_empty() { String::new() } else { format!(", varied: {}", varied.join(", ")) },
            worst.max,
            if worst.value.is_empty() { "none" } else { &worst.value },
            worst.at_mu,
            at_varied.concat()
        );
    }
    for left_out in &array.left_out {
        let _ = writeln!(out, "  not baked: {}: {}", left_out.what, left_out.reason);
    }
    if materials.len() > MATERIALS_LISTED {
        let _ = writeln!(out, "  ... and {} more, each within {:.1e}", materials.len() - MATERIALS_LISTED, {
            by_error.get(MATERIALS_LISTED).map_or(0.0, |m| m.error.max())
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn materials_fill_layers_in_order_without_crossing_one() {
        let a = arrange_in(&[3, 5, 6, 3, 12], 16);
        assert_eq!(a.places, vec![(0, 0), (0, 3), (0, 8), (1, 0), (1, 3)]);
        assert_eq!(a.layers, 2);
        assert_eq!(arrange_in(&[9, 9, 9], 16).places, vec![(0, 0), (1, 0), (2, 0)]);
        assert_eq!(arrange_in(&[3], 4).layers, 2, "an array has two layers at least");
    }

    #[test]
    fn the_height_is_a_power_of_two_taking_the_fewest_texels() {
        let small = arrange(&[5, 5, 6, 3, 6]).unwrap();
        assert!(small.layer_height.is_power_of_two());
        assert_eq!((small.layer_height, small.layers), (16, 2), "25 rows: 2 layers of 16 beat 2 of 32");
        // A thousand three-lobe materials: too many layers at the smallest heights.
        let library = arrange(&vec![6; 1000]).unwrap();
        assert!(library.layers <= MAX_LAYERS && library.layer_height.is_power_of_two());
        assert!(library.layer_height * library.layers >= 6000);
        for (&(layer, row), next) in library.places.iter().zip(library.places.iter().skip(1)) {
            assert!(row + 6 <= library.layer_height && layer < library.layers);
            assert!(*next > (layer, row), "places follow the input order");
        }
    }

    #[test]
    fn more_rows_than_any_array_holds_are_refused_by_count() {
        let error = arrange(&vec![12; MAX_LAYERS * MAX_LAYER_HEIGHT / 12 + 1000]).unwrap_err().to_string();
        assert!(error.contains("bake fewer materials") && error.contains("rows"), "{error}");
    }
}
