//! The properties the matrix checks, one small function each: given the value (and what it is held
//! to), a [`Check`] that says pass or fail, with the numbers behind the verdict.

/// The verdict of one check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Pass,
    Fail,
    /// The property cannot hold at this point for a physical reason, stated in the detail; the
    /// value is still checked to be finite and in range by the other checks of the case.
    Limitation,
}

impl Outcome {
    pub fn label(self) -> &'static str {
        match self {
            Outcome::Pass => "pass",
            Outcome::Fail => "FAIL",
            Outcome::Limitation => "limitation",
        }
    }
}

/// One property checked on one case.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    pub property: &'static str,
    pub outcome: Outcome,
    /// The numbers behind the verdict (value, bound, difference) or, for a limitation, the reason.
    pub detail: String,
}

impl Check {
    pub fn new(property: &'static str, pass: bool, detail: String) -> Self {
        Check { property, outcome: if pass { Outcome::Pass } else { Outcome::Fail }, detail }
    }

    pub fn limitation(property: &'static str, reason: String) -> Self {
        Check { property, outcome: Outcome::Limitation, detail: reason }
    }

    pub fn passed(&self) -> bool {
        self.outcome != Outcome::Fail
    }
}

/// The value is a finite number (not NaN, not infinite).
pub fn finite(value: f64) -> Check {
    Check::new("finite", value.is_finite(), format!("{value:e}"))
}

/// A reflectance, albedo or share lies in `[0, 1]`, allowing `slack` for Monte Carlo or rounding.
pub fn unit_interval(value: f64, slack: f64) -> Check {
    let pass = value >= -slack && value <= 1.0 + slack;
    Check::new("in [0, 1]", pass, format!("{value:e} (slack {slack:.0e})"))
}

/// The value lies in `[lo, hi]`.
pub fn within(property: &'static str, value: f64, lo: f64, hi: f64) -> Check {
    Check::new(property, value >= lo && value <= hi, format!("{value:e} in [{lo:e}, {hi:e}]"))
}

/// `|value - expected| <= tolerance`: a limit, a closed form or another path.
pub fn close(property: &'static str, value: f64, expected: f64, tolerance: f64) -> Check {
    let difference = (value - expected).abs();
    Check::new(
        property,
        difference <= tolerance,
        format!("{value:e} vs {expected:e}: |diff| {difference:.2e} <= {tolerance:.0e}"),
    )
}

/// `|value - expected| <= absolute + relative * |expected|`.
pub fn close_relative(property: &'static str, value: f64, expected: f64, relative: f64, absolute: f64) -> Check {
    let difference = (value - expected).abs();
    let tolerance = absolute + relative * expected.abs();
    Check::new(
        property,
        difference <= tolerance,
        format!(
            "{value:e} vs {expected:e}: |diff| {difference:.2e} <= {tolerance:.2e} ({relative:.0e} rel + {absolute:.0e})"
        ),
    )
}

/// The value is exactly the expected one (a limit that the formula must reach, not approach).
pub fn exact(property: &'static str, value: f64, expected: f64) -> Check {
    Check::new(property, value == expected, format!("{value:e}, expected exactly {expected:e}"))
}

/// `value <= bound + slack` (an albedo with Fresnel never exceeds the one without, say).
pub fn at_most(property: &'static str, value: f64, bound: f64, slack: f64) -> Check {
    Check::new(property, value <= bound + slack, format!("{value:e} <= {bound:e} + {slack:.0e}"))
}

/// Hölder-1/2 continuity across a kink: the jump `jump_small` at offset `delta_small` is no more
/// than `factor` times what a square-root rise predicts from `jump_large` at `delta_large`. A true
/// discontinuity keeps its jump as the offset shrinks and fails.
pub fn square_root_continuity(jump_large: f64, delta_large: f64, jump_small: f64, delta_small: f64) -> Check {
    const FACTOR: f64 = 2.0;
    let predicted = jump_large * (delta_small / delta_large).sqrt();
    let pass = jump_small.is_finite() && jump_small <= FACTOR * predicted + 1e-15;
    Check::new(
        "continuous across the kink",
        pass,
        format!(
            "jump {jump_large:.2e} at ±{delta_large:.0e}, {jump_small:.2e} at ±{delta_small:.0e} (sqrt rise predicts {predicted:.2e}, allowed x{FACTOR})"
        ),
    )
}
