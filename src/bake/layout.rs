//! Where a baked value lives: its place among a node's values (the channel layout), and the
//! node of each view cosine (the spacing). Both are what a baked shader mirrors, so they are
//! written once, here.
//!
//! **Channel layout.** A node's values are, in order: the albedo (R, G, B), the top interface's
//! albedo (R, G, B), then for each lobe its energy (R, G, B), GGX roughness, mean-direction cosine
//! and GD: `6 + 6 L` values for `L` lobes, packed four to an RGBA texel, so `ceil((6 + 6 L) / 4)`
//! texels per node (3 for one lobe, 5 for two, 6 for three: two more texels per two lobes).
//!
//! Where the nodes sit along `mu` is [`super::placement`]'s.

use crate::model::Evaluation;

/// Values of the albedo and the top albedo, before the lobes.
const HEAD_VALUES: usize = 6;
/// Values of one lobe: its energy (R, G, B), roughness, mean-direction cosine and GD.
pub const LOBE_VALUES: usize = 6;

/// The kinds of value a node holds, as errors are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueKind {
    /// The albedo or the top interface's albedo.
    Albedo,
    LobeEnergy,
    LobeRoughness,
    LobeCos,
    LobeGd,
}

/// The channel layout of a material with `lobes` lobes (a property of its stack and flux model,
/// the same at every view).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BakeLayout {
    pub lobes: usize,
}

impl BakeLayout {
    /// Values per node.
    pub fn values(&self) -> usize {
        HEAD_VALUES + LOBE_VALUES * self.lobes
    }

    /// RGBA texels per node: the reads a baked shader makes.
    pub fn texels_per_node(&self) -> usize {
        self.values().div_ceil(4)
    }

    /// An evaluation's values in the layout's order.
    pub fn flatten(&self, evaluation: &Evaluation) -> Vec<f64> {
        let mut values = Vec::with_capacity(self.values());
        values.extend(evaluation.albedo);
        values.extend(evaluation.top_albedo);
        for lobe in &evaluation.lobes {
            values.extend(lobe.energy);
            values.extend([lobe.roughness, lobe.mean_direction[2], lobe.gd]);
        }
        values
    }

    /// How much an error in each value counts, given the values themselves: 1 for the albedos and
    /// lobe energies; for a lobe's roughness, mean-direction cosine and GD, the lobe's largest
    /// channel of energy (a lobe that carries nothing may have any shape).
    pub fn weights(&self, values: &[f64]) -> Vec<f64> {
        let mut weights = vec![1.0; self.values()];
        for lobe in 0..self.lobes {
            let first = HEAD_VALUES + LOBE_VALUES * lobe;
            let energy = values[first..first + 3].iter().fold(0.0f64, |m, &e| m.max(e.abs()));
            weights[first + 3..first + LOBE_VALUES].fill(energy);
        }
        weights
    }

    /// Which of the error kinds value `i` counts under.
    pub fn kind(&self, i: usize) -> ValueKind {
        match i {
            0..HEAD_VALUES => ValueKind::Albedo,
            _ => match (i - HEAD_VALUES) % LOBE_VALUES {
                0..=2 => ValueKind::LobeEnergy,
                3 => ValueKind::LobeRoughness,
                4 => ValueKind::LobeCos,
                _ => ValueKind::LobeGd,
            },
        }
    }

    /// What value `i` of the layout is, in words (`lobe 2 roughness`).
    pub fn value_name(&self, i: usize) -> String {
        const CHANNELS: [&str; 3] = ["R", "G", "B"];
        match i {
            0..=2 => format!("the albedo ({})", CHANNELS[i]),
            3..=5 => format!("the top albedo ({})", CHANNELS[i - 3]),
            _ => {
                let (lobe, within) = ((i - HEAD_VALUES) / LOBE_VALUES, (i - HEAD_VALUES) % LOBE_VALUES);
                let what = match within {
                    0..=2 => format!("energy ({})", CHANNELS[within]),
                    3 => "roughness".to_string(),
                    4 => "mean-direction cosine".to_string(),
                    _ => "GD".to_string(),
                };
                format!("lobe {} {what}", lobe + 1)
            }
        }
    }
}
