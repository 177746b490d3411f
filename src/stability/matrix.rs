//! The stiff points of every domain, as data. Each list holds both ends of its domain, values a rounding
//! step away from them, and the points where formulas change regime (eta = 1, the critical angle).

/// GGX roughness: smooth (a Dirac), vanishingly rough, the reference's clamp (1e-4), rough.
pub const ALPHAS: [f64; 5] = [0.0, 1e-7, 1e-4, 1e-2, 1.0];

/// Cosines `mu` of the view direction (and `c = wi.h` for Fresnel): the horizon, a rounding step
/// above it, grazing, middle, a rounding step below the normal, the normal.
pub const COSINES: [f64; 6] = [0.0, 1e-7, 1e-3, 0.5, 1.0 - 1e-7, 1.0];

/// Relative index `eta`: no medium, near 0, TIR-prone, either side of 1 by 1e-6 and exactly 1,
/// glass, and high indices.
pub const ETAS: [f64; 9] = [0.0, 1e-3, 0.5, 1.0 - 1e-6, 1.0, 1.0 + 1e-6, 1.5, 4.0, 10.0];

/// Extinction `kappa`: dielectric, barely absorbing, metals, and a near-perfect conductor.
pub const KAPPAS: [f64; 6] = [0.0, 1e-6, 1.0, 4.0, 10.0, 100.0];

/// Henyey–Greenstein asymmetry: full back-scatter, isotropic, the model's floor, forward.
pub const ASYMMETRIES: [f64; 5] = [-1.0, 0.0, 0.2, 1.0 - 1e-7, 1.0];

/// Cosines across the critical angle `c*` are probed at `c* ± delta` for these offsets: the jump
/// must shrink like `sqrt(delta)` (Fresnel rises from its kink like a square root).
pub const CRITICAL_OFFSETS: [f64; 2] = [1e-8, 1e-12];

/// A compact label of a number for the report: shortest round-trip form.
pub fn label(x: f64) -> String {
    format!("{x}")
}
