//! Quantities an axis may sample that a lookup does not pass as such but computes from its
//! parameters `(mu, alpha, eta, kappa)`, so that a table's nodes follow a feature of its integrand
//! rather than the parameters' own grid.
//!
//! The TIR table is a step in `mu` at the critical cosine `sqrt(1 - eta^2)` when the lobe is
//! narrow. Over a grid of `(mu, eta)` the step runs diagonally through the cells, where no
//! interpolation between nodes can follow it: the original 64^3 table read 0.771 at
//! `(mu 0.716, alpha 0.0002, eta 0.70)`, where TIR is 0.005. Over the critical-angle offset
//! `asin(eta) - acos(mu)` the step lies at offset 0 for every `mu` and every `eta`, and an axis
//! dense around 0 resolves it at any roughness.

use super::{Arithmetic, Axis};

/// The angle between the critical angle of total internal reflection and the view, in radians:
/// `asin(eta) - acos(mu)`. Positive when the view lies inside the critical cone (a narrow lobe
/// there loses nothing to TIR), negative past it.
pub const CRITICAL_ANGLE_OFFSET: &str = "critical_angle_offset";

/// [`CRITICAL_ANGLE_OFFSET`] at `(mu, eta)`, both clamped to [0, 1].
pub fn critical_angle_offset(mu: f64, eta: f64) -> f64 {
    critical_angle_offset_in(mu, eta)
}

/// [`critical_angle_offset`] in the arithmetic of `mu`, which the scene shader prints; the
/// critical angle of `eta`, a material's constant, computed in f64 and then rounded to it.
pub fn critical_angle_offset_in<T: Arithmetic>(mu: T, eta: f64) -> T {
    critical_angle::<T>(eta) - view_angle(mu)
}

/// `asin(eta)`, `eta` clamped to [0, 1], in `T`'s precision.
fn critical_angle<T: Arithmetic>(eta: f64) -> T {
    T::of(eta.clamp(0.0, 1.0).asin())
}

/// `acos(mu)`, `mu` clamped to [0, 1].
fn view_angle<T: Arithmetic>(mu: T) -> T {
    mu.clamp(T::of(0.0), T::of(1.0)).acos()
}

/// The relative index whose critical angle lies `offset` radians from the view of cosine `mu`:
/// `sin(acos(mu) + offset)`, the angle clamped to [0, pi/2] (offsets past those ends have the
/// values of `eta = 0` and `eta = 1`).
pub fn eta_at_critical_angle_offset(mu: f64, offset: f64) -> f64 {
    (mu.clamp(0.0, 1.0).acos() + offset).clamp(0.0, std::f64::consts::FRAC_PI_2).sin()
}

/// How a shader computes [`CRITICAL_ANGLE_OFFSET`], for the manifest.
pub const CRITICAL_ANGLE_OFFSET_FORMULA: &str = "asin(clamp(eta, 0, 1)) - acos(clamp(mu, 0, 1))";

/// Where the critical angle lies between the view and the end of its range, as a fraction:
/// `(theta_c - theta_v) / theta_v` when the critical angle `theta_c = asin(eta)` lies below the
/// view angle `theta_v = acos(mu)` (from -1 at `eta = 0` to 0 at the critical view), and
/// `(theta_c - theta_v) / (pi/2 - theta_v)` above it (from 0 to 1 at `eta = 1`). Like
/// [`CRITICAL_ANGLE_OFFSET`] it puts the critical view at 0 for every `mu` and `eta`, and unlike it
/// every value in [-1, 1] is an index below 1 at every view, so no node lies outside the lookups'
/// reach: FGD below a rarer medium, whose Fresnel has a cusp at the critical angle, spends all its
/// nodes on `eta < 1`.
pub const CRITICAL_ANGLE_FRACTION: &str = "critical_angle_fraction";

/// [`CRITICAL_ANGLE_FRACTION`] at `(mu, eta)`, both clamped to [0, 1], as
/// [`CRITICAL_ANGLE_FRACTION_FORMULA`] states it: the range above the view is taken at least 1e-7
/// wide, so the fraction is 0 at the one point where both ranges are empty (`mu = 0`, `eta = 1`).
pub fn critical_angle_fraction(mu: f64, eta: f64) -> f64 {
    critical_angle_fraction_in(mu, eta)
}

/// [`critical_angle_fraction`] in the arithmetic of `mu`, which the scene shader prints.
pub fn critical_angle_fraction_in<T: Arithmetic>(mu: T, eta: f64) -> T {
    let (view, critical) = (view_angle(mu), critical_angle::<T>(eta));
    let offset = critical.clone() - view.clone();
    let above = offset.clone() / (T::of(std::f64::consts::FRAC_PI_2) - view.clone()).max(T::of(1e-7));
    T::select(critical.less_than(view.clone()), offset / view, above)
}

/// The relative index at [`CRITICAL_ANGLE_FRACTION`] `fraction` (clamped to [-1, 1]) for the view
/// of cosine `mu`: the inverse of [`critical_angle_fraction`].
pub fn eta_at_critical_angle_fraction(mu: f64, fraction: f64) -> f64 {
    let half_pi = std::f64::consts::FRAC_PI_2;
    let view = mu.clamp(0.0, 1.0).acos();
    let fraction = fraction.clamp(-1.0, 1.0);
    let critical = if fraction < 0.0 { view * (1.0 + fraction) } else { view + fraction * (half_pi - view) };
    critical.clamp(0.0, half_pi).sin()
}

/// How a shader computes [`CRITICAL_ANGLE_FRACTION`], for the manifest.
pub const CRITICAL_ANGLE_FRACTION_FORMULA: &str = "with v = acos(clamp(mu, 0, 1)), c = asin(clamp(eta, 0, 1)): \
     c < v ? (c - v) / v : (c - v) / max(pi/2 - v, 1e-7)";

/// The point a lookup at `(mu, alpha, eta, kappa)` reads in a table of `axes`: each axis's
/// quantity, by name. `None` when an axis samples a quantity this module does not know.
pub fn point_of(axes: &[Axis], mu: f64, alpha: f64, eta: f64, kappa: f64) -> Option<Vec<f64>> {
    point_in(axes, mu, alpha, eta, kappa)
}

/// [`point_of`] in the arithmetic of `mu` and `alpha`, which the scene shader prints; the indices
/// are a material's constants.
pub fn point_in<T: Arithmetic>(axes: &[Axis], mu: T, alpha: T, eta: f64, kappa: f64) -> Option<Vec<T>> {
    axes.iter().map(|axis| quantity_in(&axis.name, mu.clone(), alpha.clone(), eta, kappa)).collect()
}

/// The quantity an axis named `name` samples, at the lookup `(mu, alpha, eta, kappa)`: one
/// coordinate of [`point_in`], for a reader that keeps the point off the heap (the CPU evaluator,
/// once per lookup). `None` for a quantity this module does not know.
pub fn quantity_in<T: Arithmetic>(name: &str, mu: T, alpha: T, eta: f64, kappa: f64) -> Option<T> {
    match name {
        "mu" => Some(mu),
        "alpha" => Some(alpha),
        "eta" => Some(T::of(eta)),
        "kappa" => Some(T::of(kappa)),
        CRITICAL_ANGLE_OFFSET => Some(critical_angle_offset_in(mu, eta)),
        CRITICAL_ANGLE_FRACTION => Some(critical_angle_fraction_in(mu, eta)),
        _ => None,
    }
}

/// The definition of an axis's quantity in the lookup's parameters, where it is derived.
pub fn definition(name: &str) -> Option<&'static str> {
    match name {
        CRITICAL_ANGLE_OFFSET => Some(CRITICAL_ANGLE_OFFSET_FORMULA),
        CRITICAL_ANGLE_FRACTION => Some(CRITICAL_ANGLE_FRACTION_FORMULA),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_and_index_are_inverse_inside_the_quarter_circle() {
        for mu in [0.0, 0.1, 0.5, 0.716, 0.99, 1.0] {
            for eta in [0.0, 0.2, 0.7, 0.999, 1.0] {
                let offset = critical_angle_offset(mu, eta);
                assert!((eta_at_critical_angle_offset(mu, offset) - eta).abs() < 1e-12, "mu {mu} eta {eta}");
            }
        }
        // The step of a narrow lobe is at offset 0: the view at the critical cosine.
        let eta: f64 = 0.7;
        assert!(critical_angle_offset((1.0 - eta * eta).sqrt(), eta).abs() < 1e-12);
        // Past the ends the index clamps.
        assert_eq!(eta_at_critical_angle_offset(0.5, 3.0), 1.0);
        assert_eq!(eta_at_critical_angle_offset(0.5, -3.0), 0.0);
    }

    #[test]
    fn fraction_and_index_are_inverse_and_the_critical_view_is_at_zero() {
        for mu in [0.0, 1e-3, 0.1, 0.5, 0.716, 0.99, 1.0] {
            for eta in [0.0, 0.2, 0.7, 0.999, 1.0] {
                let fraction = critical_angle_fraction(mu, eta);
                assert!((-1.0..=1.0).contains(&fraction), "mu {mu} eta {eta}: {fraction}");
                if mu > 0.0 || eta < 1.0 {
                    let back = eta_at_critical_angle_fraction(mu, fraction);
                    assert!((back - eta).abs() < 1e-12, "mu {mu} eta {eta}: {back}");
                }
            }
        }
        // The ends of the range are eta = 0 and eta = 1 at every view with both sides.
        for mu in [0.1, 0.5, 0.9] {
            assert_eq!(critical_angle_fraction(mu, 0.0), -1.0);
            assert_eq!(critical_angle_fraction(mu, 1.0), 1.0);
            let eta: f64 = (1.0 - mu * mu).sqrt();
            assert!(critical_angle_fraction(mu, eta).abs() < 1e-12);
        }
    }

    #[test]
    fn points_follow_the_axes_by_name() {
        let axes = [
            Axis::node_aligned("mu", 0.0, 1.0, 4).unwrap(),
            Axis::node_aligned("alpha", 0.0, 1.0, 4).unwrap(),
            Axis::node_aligned(CRITICAL_ANGLE_OFFSET, -1.5, 1.5, 4).unwrap(),
        ];
        let point = point_of(&axes, 0.6, 0.1, 0.8, 0.0).unwrap();
        assert_eq!(&point[..2], &[0.6, 0.1]);
        assert!((point[2] - (0.8f64.asin() - 0.6f64.acos())).abs() < 1e-15);
        assert!(point_of(&[Axis::node_aligned("x", 0.0, 1.0, 2).unwrap()], 0.5, 0.5, 0.5, 0.0).is_none());
    }
}
