//! A layer stack at one point of a surface: interfaces and the media between them, top first, with
//! air (index 1) above. The transfer-matrix model ([`super::Material::evaluate`]) and the random
//! walk that checks it read the same description.
//!
//! An interface states the absolute complex index `eta + i kappa` of the medium *below* it and its
//! GGX roughness; a medium states what lies between the interface above it and the next one. Any
//! `kappa > 0` makes an interface an opaque conductor: nothing below it is ever reached, so what a
//! stack holds below its first conductor is kept but never evaluated (the scene parser warns).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// One value per colour channel (R, G, B).
pub type Rgb = [f64; 3];

/// The transfer-matrix model a material is evaluated with (Randrianandrasana et al. 2021, §4–5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FluxModel {
    /// Reflection and transmission of each interface (2 × 2 matrices); media only absorb.
    #[serde(rename = "2-flux")]
    TwoFlux,
    /// Adds scattering inside media: backscattering, forward scattering and re-emission.
    #[serde(rename = "6-flux")]
    SixFlux,
}

impl FluxModel {
    pub fn name(self) -> &'static str {
        match self {
            FluxModel::TwoFlux => "2-flux",
            FluxModel::SixFlux => "6-flux",
        }
    }
}

/// A rough boundary; the indices are those of the medium below it, absolute (air is 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interface {
    pub eta: Rgb,
    pub kappa: Rgb,
    /// GGX roughness.
    pub alpha: f64,
}

impl Interface {
    /// Whether light goes no further: any channel absorbs.
    pub fn is_conductor(&self) -> bool {
        self.kappa.iter().any(|&k| k > 0.0)
    }
}

/// A plane-parallel participating medium between two interfaces.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Medium {
    /// Scattering coefficient per unit length, per channel.
    pub sigma_s: Rgb,
    /// Absorption coefficient per unit length, per channel.
    pub sigma_k: Rgb,
    /// Thickness, in the units of the coefficients' inverse.
    pub depth: f64,
    /// Henyey–Greenstein asymmetry of the phase function.
    pub g: f64,
}

impl Medium {
    /// Whether any channel scatters.
    pub fn scatters(&self) -> bool {
        self.sigma_s.iter().any(|&s| s > 0.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Layer {
    Interface(Interface),
    Medium(Medium),
}

/// A validated layer stack, top first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stack {
    layers: Vec<Layer>,
}

/// Layers a stack may hold: the transfer matrices' cost grows with them, and no material of the
/// field has more.
pub const MAX_LAYERS: usize = 64;

impl Stack {
    /// A stack of `layers`, top first, refused with the layer and value named when it is not one
    /// the model and the random walk can evaluate: it must start with an interface (a medium above
    /// the first interface would lie in air), hold at most [`MAX_LAYERS`] layers, and every value
    /// must be finite and in range (`eta > 0`, `kappa >= 0`, `alpha` in [0, 1], `sigma_s` and
    /// `sigma_k >= 0`, `depth >= 0`, `g` in [-1, 1]).
    pub fn new(layers: Vec<Layer>) -> Result<Self> {
        if layers.is_empty() {
            return Err(Error::invalid("layer stack", "is empty; a stack needs at least one interface"));
        }
        if layers.len() > MAX_LAYERS {
            return Err(Error::invalid(
                "layer stack",
                format!("{} layers; allowed: at most {MAX_LAYERS}", layers.len()),
            ));
        }
        if let Layer::Medium(_) = layers[0] {
            return Err(Error::invalid(
                "layer stack, layer 1",
                "is a medium; the top layer must be an interface (a medium lies below the interface above it)",
            ));
        }
        for (k, layer) in layers.iter().enumerate() {
            let at = |key: &str| format!("layer stack, layer {}: {key}", k + 1);
            let check = |key: &str, values: &[f64], admits: fn(f64) -> bool, allowed: &str| -> Result<()> {
                match values.iter().find(|&&v| !(v.is_finite() && admits(v))) {
                    Some(bad) => Err(Error::invalid(at(key), format!("{bad}; allowed: {allowed}"))),
                    None => Ok(()),
                }
            };
            match layer {
                Layer::Interface(i) => {
                    check("eta", &i.eta, |v| v > 0.0, "finite and > 0")?;
                    check("kappa", &i.kappa, |v| v >= 0.0, "finite and >= 0")?;
                    check("alpha", &[i.alpha], |v| (0.0..=1.0).contains(&v), "0 to 1")?;
                }
                Layer::Medium(m) => {
                    check("sigma_s", &m.sigma_s, |v| v >= 0.0, "finite and >= 0")?;
                    check("sigma_k", &m.sigma_k, |v| v >= 0.0, "finite and >= 0")?;
                    check("depth", &[m.depth], |v| v >= 0.0, "finite and >= 0")?;
                    check("g", &[m.g], |v| (-1.0..=1.0).contains(&v), "-1 to 1")?;
                }
            }
        }
        Ok(Stack { layers })
    }

    /// Every layer, top first, including any below the first conductor.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The layers light can reach: everything down to and including the first conductor.
    pub fn reachable_layers(&self) -> &[Layer] {
        match self.layers.iter().position(|l| matches!(l, Layer::Interface(i) if i.is_conductor())) {
            Some(conductor) => &self.layers[..=conductor],
            None => &self.layers,
        }
    }

    /// Whether the stack ends in an opaque conductor (otherwise light can leave through the bottom).
    pub fn is_opaque(&self) -> bool {
        self.layers.iter().any(|l| matches!(l, Layer::Interface(i) if i.is_conductor()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dielectric(eta: f64, alpha: f64) -> Layer {
        Layer::Interface(Interface { eta: [eta; 3], kappa: [0.0; 3], alpha })
    }

    #[test]
    fn layers_below_the_first_conductor_are_not_reachable() {
        let conductor = Layer::Interface(Interface { eta: [0.2; 3], kappa: [3.0, 2.0, 0.0], alpha: 0.1 });
        let stack = Stack::new(vec![dielectric(1.5, 0.1), conductor, dielectric(1.2, 0.3)]).unwrap();
        assert_eq!(stack.reachable_layers().len(), 2);
        assert!(stack.is_opaque());
        let clear = Stack::new(vec![dielectric(1.5, 0.1)]).unwrap();
        assert_eq!(clear.reachable_layers().len(), 1);
        assert!(!clear.is_opaque());
    }

    #[test]
    fn invalid_stacks_are_refused_with_the_layer_named() {
        let medium = Layer::Medium(Medium { sigma_s: [1.0; 3], sigma_k: [0.0; 3], depth: 1.0, g: 0.0 });
        let top = Stack::new(vec![medium]).unwrap_err().to_string();
        assert!(top.contains("layer 1") && top.contains("must be an interface"), "{top}");
        let alpha = Stack::new(vec![dielectric(1.5, 1.5)]).unwrap_err().to_string();
        assert!(alpha.contains("layer 1: alpha") && alpha.contains("0 to 1"), "{alpha}");
        let eta = Stack::new(vec![dielectric(1.5, 0.1), dielectric(f64::NAN, 0.1)]).unwrap_err().to_string();
        assert!(eta.contains("layer 2: eta"), "{eta}");
        let g = Layer::Medium(Medium { sigma_s: [1.0; 3], sigma_k: [0.0; 3], depth: 1.0, g: -1.5 });
        let g = Stack::new(vec![dielectric(1.5, 0.1), g]).unwrap_err().to_string();
        assert!(g.contains("layer 2: g"), "{g}");
        assert!(Stack::new(Vec::new()).is_err());
        assert!(Stack::new(vec![dielectric(1.5, 0.1); MAX_LAYERS + 1]).is_err());
    }
}
