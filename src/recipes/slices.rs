//! Specialised slices: FGD or TIR at a few fixed relative indices, as 2D `(mu, alpha)` tables with
//! one channel per index. Where a scene's materials use only a handful of discrete `(eta, kappa)`
//! pairs, these replace the 4D FGD and 3D TIR tables (`docs/scenes.md`): the same integrals, with
//! no interpolation across `eta` and `kappa`, in a few kilobytes.
//!
//! ```text
//! FGD slice, channel k:  FGD(mu, alpha; eta_k, kappa_k) = E_{h ~ VNDF(wi)}[ F(wi.h; eta_k, kappa_k) G2 / G1(wi) ]
//! TIR slice, channel k:  TIR(mu, alpha; eta_k)          = ∫ rho(w) [1 - w.z^2 > eta_k^2] dw / ∫ rho(w) dw
//! ```
//!
//! Each is computed exactly as its full table computes a node ([`super::fgd::fgd_pairs_fast`],
//! [`super::tir::tir_column`]), with the full table's settings, so that a slice node equals the full
//! table's node at the same parameters up to rounding. The `mu` and `alpha` axes are sub-ranges of
//! the full table's grid (the planner picks them), so the nodes coincide.

use serde::{Deserialize, Serialize};

use super::fgd::{FgdSettings, projected_fresnel};
use super::settings::{OutputConfig, ReferenceConfig, SamplingConfig};
use super::tir::{TirSettings, tir_cell, tir_column};
use super::{Integrated, Kernel, Metadata, fill_mu_alpha_nodes};
use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::integrate::measure::Projection;
use crate::integrate::{Estimate, Method, Progress, estimate_cosine_functions};
use crate::physics::MaskingShadowing;
use crate::physics::fresnel_reflectance;
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Channel, Table};

/// The integral a slice tabulates, with the settings of the full table it specialises.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SliceOf {
    Fgd(FgdSettings),
    Tir(TirSettings),
}

/// One channel of a slice: the relative index it is evaluated at (kappa is 0 for TIR) and which
/// colour channels of which lookups read it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SliceChannel {
    pub eta: f64,
    pub kappa: f64,
    pub used_by: String,
}

/// A DDS texture holds 1, 2 or 4 channels: a slice of three indices gets a fourth, zero channel.
pub const PADDING_CHANNEL: &str = "padding";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Slices {
    pub name: String,
    pub of: SliceOf,
    pub mu: Axis,
    pub alpha: Axis,
    /// The `mu` and `alpha` ranges the lookups reach (inside the axes, which add a margin): the
    /// accuracy check samples these.
    pub lookup_mu: [f64; 2],
    pub lookup_alpha: [f64; 2],
    pub channels: Vec<SliceChannel>,
}

impl Slices {
    pub fn validate(&self) -> Result<()> {
        let key = format!("slices `{}`", self.name);
        if self.channels.is_empty() || self.channels.len() > 4 {
            return Err(Error::invalid(key, format!("{} channels; allowed: 1 to 4", self.channels.len())));
        }
        for axis in [&self.mu, &self.alpha] {
            axis.validate()?;
            if axis.start < 0.0 || axis.end > 1.0 {
                return Err(Error::invalid(&key, format!("axis `{}` leaves [0, 1]", axis.name)));
            }
        }
        match &self.of {
            SliceOf::Fgd(settings) => settings.validate(),
            SliceOf::Tir(settings) => settings.validate(),
        }
    }

    /// Channels as stored: one per index, plus a zero padding channel after three.
    pub fn stored_channel_count(&self) -> usize {
        if self.channels.len() == 3 { 4 } else { self.channels.len() }
    }

    /// Bytes of the stored texels.
    pub fn texel_bytes(&self) -> u64 {
        (self.mu.count * self.alpha.count * self.stored_channel_count() * self.output().precision.bytes()) as u64
    }

    pub fn sampling(&self) -> SamplingConfig {
        match &self.of {
            SliceOf::Fgd(s) => s.sampling,
            SliceOf::Tir(s) => s.sampling,
        }
    }

    fn reference(&self) -> ReferenceConfig {
        match &self.of {
            SliceOf::Fgd(s) => s.reference,
            SliceOf::Tir(s) => s.reference,
        }
    }

    /// Slices are textures, written in the precision of the full table's output and in the texture
    /// formats the full table is written in: FGD's `packing_formats` (its 4D table is no
    /// texture), TIR's DDS and KTX2 `output.formats`; as DDS where those list neither.
    pub fn output(&self) -> OutputConfig {
        let (texture_formats, precision) = match &self.of {
            SliceOf::Fgd(s) => (&s.packing_formats, s.output.precision),
            SliceOf::Tir(s) => (&s.output.formats, s.output.precision),
        };
        let mut formats: Vec<FileFormat> =
            texture_formats.iter().copied().filter(|f| FileFormat::TEXTURES.contains(f)).collect();
        if formats.is_empty() {
            formats.push(FileFormat::TEXTURES[0]);
        }
        OutputConfig { formats, precision }
    }

    fn table_name(&self) -> &'static str {
        match self.of {
            SliceOf::Fgd(_) => "FGD",
            SliceOf::Tir(_) => "TIR",
        }
    }

    fn channel_list(&self) -> Vec<Channel> {
        let mut channels: Vec<Channel> = self
            .channels
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let index = match self.of {
                    SliceOf::Fgd(_) => format!("eta {}, kappa {}", c.eta, c.kappa),
                    SliceOf::Tir(_) => format!("eta {}", c.eta),
                };
                let channel = Channel::new(
                    format!("{}{k}", self.table_name().to_lowercase()),
                    format!("{} at {index}; read by {}", self.table_name(), c.used_by),
                )
                .with_fixed("eta", c.eta);
                match self.of {
                    SliceOf::Fgd(_) => channel.with_fixed("kappa", c.kappa),
                    SliceOf::Tir(_) => channel,
                }
            })
            .collect();
        if channels.len() == 3 {
            channels.push(Channel::new(PADDING_CHANNEL, "zero: pads three channels to RGBA (DDS holds 1, 2 or 4)"));
        }
        channels
    }

    fn pairs(&self) -> Vec<(f64, f64)> {
        self.channels.iter().map(|c| (c.eta, c.kappa)).collect()
    }

    /// Every channel at one `(mu, alpha)` by the full table's fast method (padding included).
    fn estimate_fast(&self, points: &PointSet, mu: f64, alpha: f64, projections: &[Projection]) -> Estimate {
        let mut estimate = match &self.of {
            SliceOf::Fgd(settings) => super::fgd::fgd_pairs_fast(
                settings.masking,
                settings.cosine_basis(),
                points,
                mu,
                alpha,
                &self.pairs(),
                projections,
            ),
            SliceOf::Tir(settings) => {
                // tir_column buckets by ascending eta: evaluate in sorted order, store in channel order.
                let mut order: Vec<usize> = (0..self.channels.len()).collect();
                order.sort_by(|&a, &b| self.channels[a].eta.total_cmp(&self.channels[b].eta));
                let etas: Vec<f64> = order.iter().map(|&k| self.channels[k].eta.min(settings.top_eta)).collect();
                let sorted = tir_column(mu, alpha, &etas, points);
                let mut estimate = Estimate { mean: vec![0.0; order.len()], standard_error: vec![0.0; order.len()] };
                for (position, &k) in order.iter().enumerate() {
                    estimate.mean[k] = sorted.mean[position];
                    estimate.standard_error[k] = sorted.standard_error[position];
                }
                estimate
            }
        };
        pad(&mut estimate, self.stored_channel_count());
        estimate
    }

    /// Every channel at one `(mu, alpha)` on its own, in f64 (padding included): the references.
    pub fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let (mu, alpha) = (position[0], position[1]);
        let mut estimate = match &self.of {
            // One pass over the samples serves every channel.
            SliceOf::Fgd(settings) => {
                let f = |c: f64, k: usize| fresnel_reflectance(c, self.channels[k].eta, self.channels[k].kappa);
                let cell = |n| {
                    estimate_cosine_functions::<1>(mu, alpha, settings.masking, Method::PerCell, points, move |c| {
                        [f(c, n)]
                    })
                };
                match self.channels.len() {
                    2 => estimate_cosine_functions(mu, alpha, settings.masking, Method::PerCell, points, |c| {
                        [f(c, 0), f(c, 1)]
                    }),
                    3 => estimate_cosine_functions(mu, alpha, settings.masking, Method::PerCell, points, |c| {
                        [f(c, 0), f(c, 1), f(c, 2)]
                    }),
                    _ => Estimate::from_channels(&(0..self.channels.len()).map(cell).collect::<Vec<_>>()),
                }
            }
            SliceOf::Tir(settings) => Estimate::from_channels(
                &self
                    .channels
                    .iter()
                    .map(|c| tir_cell(mu, alpha, c.eta.min(settings.top_eta), points))
                    .collect::<Vec<_>>(),
            ),
        };
        pad(&mut estimate, self.stored_channel_count());
        estimate
    }

    fn masking(&self) -> MaskingShadowing {
        match &self.of {
            SliceOf::Fgd(s) => s.masking,
            SliceOf::Tir(_) => MaskingShadowing::SmithSeparable,
        }
    }
}

fn pad(estimate: &mut Estimate, channels: usize) {
    estimate.mean.resize(channels, 0.0);
    estimate.standard_error.resize(channels, 0.0);
}

impl Kernel for Slices {
    fn validate(&self) -> Result<()> {
        Slices::validate(self)
    }

    fn sampling(&self) -> SamplingConfig {
        Slices::sampling(self)
    }

    fn reference(&self) -> ReferenceConfig {
        Slices::reference(self)
    }

    /// Each channel is computed as the fast method computes the full table's node.
    fn method(&self) -> Method {
        Method::Fast
    }

    fn empty_table(&self) -> Result<Table> {
        Table::zeros(&self.name, vec![self.mu.clone(), self.alpha.clone()], self.channel_list())
    }

    fn metadata(&self) -> Metadata {
        let (integrand, sampler) = match self.of {
            SliceOf::Fgd(ref settings) => (
                "FGD(mu, alpha; eta_k, kappa_k) = E_{h~VNDF(wi)}[F(wi.h; eta_k, kappa_k) G2(wi,wo) / G1(wi)], one channel per (eta_k, kappa_k)",
                format!(
                    "visible-normal measure per (mu, alpha) on {} hat intervals in wi.h, times projected Fresnel",
                    settings.cosine_intervals
                ),
            ),
            SliceOf::Tir(_) => (
                "TIR(mu, alpha; eta_k) = Σ G1(w) [1 - w.z^2 > eta_k^2] / Σ G1(w), w = reflect(wi, h), h ~ VNDF(wi), one channel per eta_k",
                "ratio estimator over visible normals, f32 kernel".to_string(),
            ),
        };
        Metadata {
            integrand: integrand.into(),
            masking: Some(self.masking()),
            notes: vec![
                format!(
                    "A specialised slice of the {} table: fixed relative indices, one per channel; mu and alpha are sub-ranges of the full table's node-aligned grid, lookups outside them clamp.",
                    self.table_name()
                ),
                "Node-aligned: a GPU sampler needs the half-texel correction given per axis.".into(),
            ],
            sampler,
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let projections: Vec<Projection> = match &self.of {
            SliceOf::Fgd(settings) => {
                self.channels.iter().map(|c| projected_fresnel(settings.cosine_basis(), c.eta, c.kappa)).collect()
            }
            SliceOf::Tir(_) => Vec::new(),
        };
        let estimates =
            fill_mu_alpha_nodes(table, progress, |_, mu, alpha| self.estimate_fast(points, mu, alpha, &projections));
        Ok(Integrated::of(&estimates))
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        Slices::estimate_node(self, points, position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::table_points;

    #[test]
    fn tir_channels_in_any_order_equal_their_single_channel_values() {
        let settings = TirSettings::default();
        let axis = |name: &str| Axis::node_aligned(name, 0.25, 0.75, 3).unwrap();
        let slices = |etas: &[f64]| Slices {
            name: "tir_test".into(),
            of: SliceOf::Tir(settings.clone()),
            mu: axis("mu"),
            alpha: axis("alpha"),
            lookup_mu: [0.25, 0.75],
            lookup_alpha: [0.25, 0.75],
            channels: etas.iter().map(|&eta| SliceChannel { eta, kappa: 0.0, used_by: "test".into() }).collect(),
        };
        let points = table_points(&SamplingConfig { samples: 1 << 12, replicates: 4 }, 3).unwrap();
        // Descending, as R, G, B of a coat whose index falls with wavelength.
        let both = slices(&[0.9, 0.6]).estimate_fast(&points, 0.5, 0.5, &[]);
        for (k, eta) in [0.9, 0.6].into_iter().enumerate() {
            let alone = slices(&[eta]).estimate_fast(&points, 0.5, 0.5, &[]);
            assert_eq!(both.mean[k], alone.mean[0], "eta {eta}");
        }
        assert!(both.mean[0] < both.mean[1], "a higher index loses less: {:?}", both.mean);
    }
}
