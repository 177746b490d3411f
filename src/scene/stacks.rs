//! A material's layer stacks as the transfer-matrix model takes them: at its nominal values, and
//! over samples of the ranges its textures vary, where the planner evaluates the model.

use super::{Interval, SceneInterface, SceneLayer, SceneMaterial};
use crate::error::{Error, Result};

impl SceneMaterial {
    /// The layer stack at the material's nominal values, as the model and the random walk take it.
    pub fn stack(&self) -> Result<crate::model::Stack> {
        self.stack_with(|_, interface| interface.nominal)
    }

    /// The stack with each interface's values given by `values(layer index, interface)`.
    fn stack_with(
        &self,
        values: impl Fn(usize, &SceneInterface) -> crate::model::Interface,
    ) -> Result<crate::model::Stack> {
        let layers = self
            .layers
            .iter()
            .enumerate()
            .map(|(k, layer)| match layer {
                SceneLayer::Interface(interface) => crate::model::Layer::Interface(values(k, interface)),
                SceneLayer::Medium(medium) => crate::model::Layer::Medium(*medium),
            })
            .collect();
        crate::model::Stack::new(layers).map_err(|e| Error::invalid(format!("material `{}`", self.name), e.to_string()))
    }

    /// Stacks over the ranges the material's textures vary: the nominal stack, then every
    /// combination of each varying parameter at its range's ends and middle (at most
    /// [`MAX_VARIANTS`]; beyond, a deterministic spread of them), the nominal values elsewhere. The
    /// planner evaluates the model over these to find where its lookups are made.
    pub fn variants(&self) -> Result<Vec<crate::model::Stack>> {
        let varying = self.varying();
        let combinations = 3usize.saturating_pow(varying.len() as u32);
        let chosen: Vec<usize> = if combinations <= MAX_VARIANTS {
            (0..combinations).collect()
        } else {
            (0..MAX_VARIANTS as u64).map(|n| (spread(n) % combinations as u64) as usize).collect()
        };
        let mut stacks = vec![self.stack()?];
        for combination in chosen {
            let level = |which: usize| (combination / 3usize.pow(which as u32)) % 3;
            let values: Vec<f64> = varying
                .iter()
                .enumerate()
                .map(|(which, &(_, _, range, _))| [range.lo, 0.5 * (range.lo + range.hi), range.hi][level(which)])
                .collect();
            stacks.push(self.stack_at(&values)?);
        }
        Ok(stacks)
    }

    /// The stack with each parameter its textures vary at `values` (in the order of
    /// [`SceneMaterial::varied`]; an index for every channel), its nominal values elsewhere.
    pub fn stack_at(&self, values: &[f64]) -> Result<crate::model::Stack> {
        let varying = self.varying();
        self.stack_with(|k, interface| {
            let mut at = interface.nominal;
            for (&(layer, parameter, _, _), &x) in varying.iter().zip(values) {
                if layer != k {
                    continue;
                }
                match parameter {
                    0 => at.eta = [x; 3],
                    1 => at.kappa = [x; 3],
                    _ => at.alpha = x,
                }
            }
            at
        })
    }

    /// The parameters its textures vary, as a bake takes them: each named (`layer 1 alpha`), with
    /// its range and its nominal value.
    pub fn varied(&self) -> Vec<crate::bake::VariedParameter> {
        self.varying()
            .into_iter()
            .map(|(layer, parameter, range, nominal)| crate::bake::VariedParameter {
                name: format!("layer {} {}", layer + 1, PARAMETERS[parameter]),
                range: [range.lo, range.hi],
                nominal,
            })
            .collect()
    }

    /// Its model at each value of the parameters its textures vary ([`SceneMaterial::stack_at`]),
    /// for a bake.
    pub fn family(&self) -> crate::bake::MaterialFamily<'_> {
        crate::bake::MaterialFamily::varied(
            self.varied(),
            Box::new(move |values| Ok(crate::model::Material::new(self.model, self.stack_at(values)?))),
        )
    }
}

/// The names of an interface's parameters, by [`SceneMaterial::varying`]'s number.
const PARAMETERS: [&str; 3] = ["eta", "kappa", "alpha"];

/// A channel value where every channel holds it, else their mean.
fn one_value(channels: [f64; 3]) -> f64 {
    match channels {
        [r, g, b] if r == g && g == b => r,
        [r, g, b] => (r + g + b) / 3.0,
    }
}

impl SceneMaterial {
    /// (layer index, parameter 0 eta / 1 kappa / 2 alpha, range, nominal value) of each parameter a
    /// texture varies; an index's nominal value is its channels' mean where they differ (a texture
    /// sets every channel to one value).
    fn varying(&self) -> Vec<(usize, usize, Interval, f64)> {
        let mut varying = Vec::new();
        for (k, layer) in self.layers.iter().enumerate() {
            if let SceneLayer::Interface(i) = layer {
                let nominal = i.nominal;
                for (parameter, range, value) in [
                    (0, i.eta[0], one_value(nominal.eta)),
                    (1, i.kappa[0], one_value(nominal.kappa)),
                    (2, i.alpha, nominal.alpha),
                ] {
                    if !range.is_point() {
                        varying.push((k, parameter, range, value));
                    }
                }
            }
        }
        varying
    }

    /// Each parameter a texture varies, in words (`layer 2 alpha in [0.1, 0.4]`, layers from 1).
    pub fn varied_parameters(&self) -> Vec<String> {
        self.varying()
            .into_iter()
            .map(|(layer, parameter, range, _)| {
                let name = PARAMETERS[parameter];
                format!("layer {} {name} in [{}, {}]", layer + 1, super::short(range.lo), super::short(range.hi))
            })
            .collect()
    }

    /// How many stacks [`Material::variants`] gives, without building them.
    pub fn variant_count(&self) -> usize {
        1 + 3usize.saturating_pow(self.varying().len() as u32).min(MAX_VARIANTS)
    }
}

/// The most stacks [`Material::variants`] gives.
pub const MAX_VARIANTS: usize = 729;

/// A well-mixed 64-bit hash of `n` (SplitMix64's finaliser), to spread samples over combinations.
fn spread(n: u64) -> u64 {
    let mut z = n.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
