//! The 6-flux transfer matrices: a primary flux (unscattered, as in the 2-flux model) and a
//! secondary one split into forward- and backward-scattered parts, so that media scatter
//! (Randrianandrasana et al. 2021, §5; the reference's `transfer_matrix_6`, its products,
//! `factors`, `energy_matrix`, `asymmetry_matrix` and 6-flux `outgoing_lobes`, `docs/furnace.md`).
//!
//! The matrix is sparse and structured: only the entries below are ever non-zero, and the products
//! are the reference's, specialised by the right operand (an interface or a medium), written out
//! entry by entry. Energy and asymmetry matrices are both kept per colour channel.

use super::factors::{Component, DielectricFactors, Flux, MediumFactors, safe_ratio};
use super::lookup::Tables;
use super::tm2::{inverse, normalising_scale, transmission_asymmetries};
use super::{LobeKind, RawLobe, below};
use crate::ir::real::Real;

/// The non-zero entries of a 6-flux transfer matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix6<R = f64> {
    pub m11: R,
    pub m12: R,
    pub m21: R,
    pub m22: R,
    pub m31: R,
    pub m32: R,
    pub m33: R,
    pub m34: R,
    pub m35: R,
    pub m36: R,
    pub m41: R,
    pub m42: R,
    pub m43: R,
    pub m44: R,
    pub m45: R,
    pub m46: R,
    pub m51: R,
    pub m52: R,
    pub m61: R,
    pub m62: R,
}

/// Which reflectances the stack so far has (the reference's `ETransferFactorRequest`): the primary one from
/// the first interface on, the backward-scattered one from the first medium on, the forward one
/// once both exist.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Requested {
    primary: bool,
    forward: bool,
    backward: bool,
}

impl Requested {
    fn add_interface(&mut self) {
        self.primary = true;
        self.forward |= self.backward;
    }

    fn add_medium(&mut self) {
        self.backward = true;
        self.forward |= self.primary;
    }
}

/// The three reflectances of a stack.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reflectances<R> {
    primary: R,
    forward: R,
    backward: R,
}

impl<R: Real> Reflectances<R> {
    fn zero() -> Self {
        let zero = R::of(0.0);
        Reflectances { primary: zero, forward: zero, backward: zero }
    }
}

impl<R: Real> Matrix6<R> {
    /// Every entry 0.
    fn zero() -> Self {
        let z = R::of(0.0);
        Matrix6 {
            m11: z,
            m12: z,
            m21: z,
            m22: z,
            m31: z,
            m32: z,
            m33: z,
            m34: z,
            m35: z,
            m36: z,
            m41: z,
            m42: z,
            m43: z,
            m44: z,
            m45: z,
            m46: z,
            m51: z,
            m52: z,
            m61: z,
            m62: z,
        }
    }

    pub fn identity() -> Self {
        let one = R::of(1.0);
        Matrix6 { m11: one, m22: one, m33: one, m44: one, ..Self::zero() }
    }

    /// An interface's matrix from its primary `[r, t, rp, tp]` and secondary `[r, t, rp, tp]`
    /// reflections and transmissions (the reference's `energy_matrix` for `EDielectricInterface`).
    pub fn interface(primary: [R; 4], secondary: [R; 4]) -> Self {
        let [r, t, rp, tp] = primary;
        let [r_ff, t_ff, rp_ff, tp_ff] = secondary;
        let m11 = inverse(t);
        let m33 = inverse(t_ff);
        Matrix6 {
            m11,
            m12: -rp * m11,
            m21: r * m11,
            m22: -r * rp * m11 + tp,
            m33,
            m34: -rp_ff * m33,
            m43: r_ff * m33,
            m44: -r_ff * rp_ff * m33 + tp_ff,
            ..Self::zero()
        }
    }

    /// A medium's matrix from its primary transmission `t`, secondary backward reflection `r_fb`
    /// and forward transmission `t_ff` (the reference's `energy_matrix` for `EHomogeneousMedium`).
    pub fn medium(t: R, r_fb: R, t_ff: R) -> Self {
        let m11 = inverse(t);
        let m33 = inverse(t_ff);
        let m44 = -(r_fb * r_fb) * m33 + t_ff;
        let m36 = -r_fb * m33;
        Matrix6 {
            m11,
            m22: t,
            m33,
            m44,
            m52: m36,
            m36,
            m31: m33 - m11,
            m42: m44 - t,
            m61: -m36,
            m45: -m36,
            ..Self::zero()
        }
    }

    /// `self * e` for an interface `e`.
    fn then_interface(&self, e: &Matrix6<R>) -> Self {
        let m = self;
        Matrix6 {
            m11: m.m11 * e.m11 + m.m12 * e.m21,
            m12: m.m11 * e.m12 + m.m12 * e.m22,
            m21: m.m21 * e.m11 + m.m22 * e.m21,
            m22: m.m21 * e.m12 + m.m22 * e.m22,
            m31: m.m31 * e.m11 + m.m32 * e.m21,
            m32: m.m31 * e.m12 + m.m32 * e.m22,
            m33: m.m33 * e.m33 + m.m34 * e.m43,
            m34: m.m33 * e.m34 + m.m34 * e.m44,
            m35: m.m35 * e.m33 + m.m36 * e.m43,
            m36: m.m35 * e.m34 + m.m36 * e.m44,
            m41: m.m41 * e.m11 + m.m42 * e.m21,
            m42: m.m41 * e.m12 + m.m42 * e.m22,
            m43: m.m43 * e.m33 + m.m44 * e.m43,
            m44: m.m43 * e.m34 + m.m44 * e.m44,
            m45: m.m45 * e.m33 + m.m46 * e.m43,
            m46: m.m45 * e.m34 + m.m46 * e.m44,
            m51: m.m51 * e.m11 + m.m52 * e.m21,
            m52: m.m51 * e.m12 + m.m52 * e.m22,
            m61: m.m61 * e.m11 + m.m62 * e.m21,
            m62: m.m61 * e.m12 + m.m62 * e.m22,
        }
        .normalised()
    }

    /// `self * e` for a medium `e`.
    fn then_medium(&self, e: &Matrix6<R>) -> Self {
        let m = self;
        Matrix6 {
            m11: m.m11 * e.m11,
            m12: m.m12 * e.m22,
            m21: m.m21 * e.m11,
            m22: m.m22 * e.m22,
            m31: m.m31 * e.m11 + m.m33 * e.m31 - m.m36 * e.m36,
            m32: m.m32 * e.m22 + m.m34 * e.m42 + m.m35 * e.m36,
            m33: m.m33 * e.m33 - m.m36 * e.m36,
            m34: m.m34 * e.m44 + m.m35 * e.m36,
            m35: -m.m34 * e.m36 + m.m35 * e.m33,
            m36: m.m33 * e.m36 + m.m36 * e.m44,
            m41: m.m41 * e.m11 + m.m43 * e.m31 - m.m46 * e.m36,
            m42: m.m42 * e.m22 + m.m44 * e.m42 + m.m45 * e.m36,
            m43: m.m43 * e.m33 - m.m46 * e.m36,
            m44: m.m44 * e.m44 + m.m45 * e.m36,
            m45: -m.m44 * e.m36 + m.m45 * e.m33,
            m46: m.m43 * e.m36 + m.m46 * e.m44,
            m51: -m.m34 * e.m36 + m.m35 * e.m31 + m.m51 * e.m11,
            m52: m.m33 * e.m36 + m.m36 * e.m42 + m.m52 * e.m22,
            m61: -m.m44 * e.m36 + m.m45 * e.m31 + m.m61 * e.m11,
            m62: m.m43 * e.m36 + m.m46 * e.m42 + m.m62 * e.m22,
        }
        .normalised()
    }

    /// Every entry through `f`.
    fn map(self, mut f: impl FnMut(R) -> R) -> Self {
        let m = self;
        Matrix6 {
            m11: f(m.m11),
            m12: f(m.m12),
            m21: f(m.m21),
            m22: f(m.m22),
            m31: f(m.m31),
            m32: f(m.m32),
            m33: f(m.m33),
            m34: f(m.m34),
            m35: f(m.m35),
            m36: f(m.m36),
            m41: f(m.m41),
            m42: f(m.m42),
            m43: f(m.m43),
            m44: f(m.m44),
            m45: f(m.m45),
            m46: f(m.m46),
            m51: f(m.m51),
            m52: f(m.m52),
            m61: f(m.m61),
            m62: f(m.m62),
        }
    }

    /// The matrix divided by its largest entry. Every reflectance below is invariant under a
    /// common scale (each is a ratio of products of equal degree in the entries), so this changes
    /// none, and keeps the product of many strongly attenuating layers finite.
    fn normalised(self) -> Self {
        let mut largest = R::of(0.0);
        self.map(|v| {
            largest = largest.max(v.abs());
            v
        });
        let scale = normalising_scale(largest);
        self.map(|v| v / scale)
    }

    /// The requested reflectances of the stack, over a conductor of reflectance `base` or over
    /// nothing (the reference's two `factors`); entries not requested keep the values in `previous`.
    fn reflectances(&self, base: Option<R>, requested: Requested, previous: Reflectances<R>) -> Reflectances<R> {
        let m = self;
        let mut out = previous;
        match base {
            None => {
                let x0 = R::of(1.0) / m.m11;
                if requested.backward {
                    let x1 = -m.m31 * m.m33 + m.m35 * m.m51;
                    let x2 = m.m31 * m.m35 - m.m33 * m.m51;
                    let x3 = x0 / (m.m33 * m.m33 - m.m35 * m.m35);
                    let x4 = m.m43 * x3;
                    let x5 = m.m45 * x3;
                    out.backward = m.m61 * x0 + x1 * x5 + x4 * x2;
                    if requested.forward {
                        out.forward = m.m41 * x0 + x1 * x4 + x2 * x5;
                    }
                }
                if requested.primary {
                    out.primary = m.m21 * x0;
                }
            }
            Some(rc) => {
                let x0 = R::of(1.0) / (m.m11 + m.m12 * rc);
                if requested.backward {
                    let x1 = m.m45 + m.m46 * rc;
                    let x2 = m.m31 + m.m32 * rc;
                    let x3 = m.m35 + m.m36 * rc;
                    let x4 = m.m33 + m.m34 * rc;
                    let x5 = m.m51 + m.m52 * rc;
                    let x6 = x0 / (-x3 * x3 + x4 * x4);
                    let x7 = x6 * (x2 * x3 - x4 * x5);
                    let x8 = m.m43 + m.m44 * rc;
                    let x9 = x6 * (x2 * x4 - x3 * x5);
                    out.backward = x0 * (m.m61 + m.m62 * rc) - x1 * x9 + x7 * x8;
                    if requested.forward {
                        out.forward = x0 * (m.m41 + m.m42 * rc) + x1 * x7 - x8 * x9;
                    }
                }
                if requested.primary {
                    out.primary = x0 * (m.m21 + m.m22 * rc);
                }
            }
        }
        // Where nothing crosses (0 / 0), the limit adds nothing to what was reflected above.
        Reflectances {
            primary: out.primary.finite_or(previous.primary),
            forward: out.forward.finite_or(previous.forward),
            backward: out.backward.finite_or(previous.backward),
        }
    }
}

/// Energy or weighted asymmetry of a flux in channel `c`: the energy matrices take the first, the
/// asymmetry matrices the second (the reference's `asymmetry_matrix`: `norm * g` per channel).
fn entry<R: Real>(flux: &Flux<R>, c: usize, asymmetry: bool) -> R {
    if asymmetry { flux.energy[c] * flux.g } else { flux.energy[c] }
}

fn interface_matrix<R: Real>(
    primary: &DielectricFactors<R>,
    secondary: &DielectricFactors<R>,
    c: usize,
    asymmetry: bool,
) -> Matrix6<R> {
    let four = |f: &DielectricFactors<R>| {
        [entry(&f.r, c, asymmetry), entry(&f.t, c, asymmetry), entry(&f.rp, c, asymmetry), entry(&f.tp, c, asymmetry)]
    };
    Matrix6::interface(four(primary), four(secondary))
}

fn medium_matrix<R: Real>(m: &MediumFactors<R>, c: usize, asymmetry: bool) -> Matrix6<R> {
    Matrix6::medium(entry(&m.t, c, asymmetry), entry(&m.r_fb, c, asymmetry), entry(&m.t_ff, c, asymmetry))
}

/// The outgoing lobes of the 6-flux model: per component, a primary lobe once an interface has
/// been crossed, a backward-scattered lobe once a medium has, and a forward-scattered one once
/// both have (the reference's 6-flux `outgoing_lobes`). Energies are clamped at 0 and asymmetries are the
/// channel mean of `safe_div(delta G, delta E)`, as there.
pub fn lobes<R: Real>(components: &[(usize, Component<R>)], tables: &dyn Tables<R>) -> Vec<RawLobe<R>> {
    let mut energy = [Matrix6::identity(); 3];
    let mut asymmetry = [Matrix6::identity(); 3];
    let mut requested = Requested::default();
    let mut r_above = [Reflectances::zero(); 3];
    let mut g_above = [Reflectances::zero(); 3];
    let (mut g_primary, mut g_secondary) = (R::of(1.0), R::of(1.0));
    let mut lobes = Vec::with_capacity(3 * components.len());
    for (index, &(layer, component)) in components.iter().enumerate() {
        let base: Option<([R; 3], [R; 3])> = match component {
            Component::Pass => continue,
            Component::Dielectric(mut primary) => {
                // The secondary factors start as copies of the primary ones (as in the reference), and get their
                // own first-order asymmetries and TIR.
                let mut secondary = primary;
                let below = below(&components[index + 1..]);
                let returns = below.returns_light;
                g_primary =
                    transmission_asymmetries(&mut primary, g_primary, below.reflection_g, returns, layer, tables);
                // A scattered lobe reflected below crosses the media between twice.
                let g_next = below.media_forward_g * below.reflection_g * below.media_forward_g;
                g_secondary = transmission_asymmetries(&mut secondary, g_secondary, g_next, returns, layer, tables);
                requested.add_interface();
                for c in 0..3 {
                    energy[c] = energy[c].then_interface(&interface_matrix(&primary, &secondary, c, false));
                    asymmetry[c] = asymmetry[c].then_interface(&interface_matrix(&primary, &secondary, c, true));
                }
                None
            }
            Component::Medium(m) => {
                requested.add_medium();
                for c in 0..3 {
                    energy[c] = energy[c].then_medium(&medium_matrix(&m, c, false));
                    asymmetry[c] = asymmetry[c].then_medium(&medium_matrix(&m, c, true));
                }
                None
            }
            Component::Conductor { r } => {
                requested.add_interface();
                Some((r.energy, std::array::from_fn(|c| r.energy[c] * r.g)))
            }
        };
        let r_total: [Reflectances<R>; 3] =
            std::array::from_fn(|c| energy[c].reflectances(base.map(|(e, _)| e[c]), requested, r_above[c]));
        let g_total: [Reflectances<R>; 3] =
            std::array::from_fn(|c| asymmetry[c].reflectances(base.map(|(_, g)| g[c]), requested, g_above[c]));
        for (kind, wanted, pick) in [
            (LobeKind::Primary, requested.primary, (|r: &Reflectances<R>| r.primary) as fn(&Reflectances<R>) -> R),
            (LobeKind::Forward, requested.forward, |r: &Reflectances<R>| r.forward),
            (LobeKind::Backward, requested.backward, |r: &Reflectances<R>| r.backward),
        ] {
            if !wanted {
                continue;
            }
            let delta: [R; 3] = std::array::from_fn(|c| pick(&r_total[c]) - pick(&r_above[c]));
            let g_delta: [R; 3] = std::array::from_fn(|c| pick(&g_total[c]) - pick(&g_above[c]));
            // The channel mean of the ratios (a sum from -0.0, as `Iterator::sum` adds).
            let ratios: [R; 3] = std::array::from_fn(|c| safe_ratio(g_delta[c], delta[c]));
            let g = (ratios[0] + ratios[1] + ratios[2]) / 3.0;
            lobes.push(RawLobe { layer, kind, energy: delta.map(|e| e.max(R::of(0.0))), g });
        }
        r_above = r_total;
        g_above = g_total;
    }
    lobes
}
