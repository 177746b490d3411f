//! Forward-mode dual numbers: a value and its derivatives with respect to up to [`MAX_PARAMETERS`]
//! parameters. Evaluating a form generic over [`Real`] with `Dual` parameters gives its exact
//! gradient, so any form can use a gradient-based search without a hand-written derivative.

use std::cmp::Ordering;
use std::ops::{Add, Sub};

use super::real::Real;

/// The most parameters a dual number carries derivatives for.
pub const MAX_PARAMETERS: usize = 10;

#[derive(Debug, Clone, Copy)]
pub struct Dual {
    pub value: f64,
    pub gradient: [f64; MAX_PARAMETERS],
}

impl Dual {
    /// Parameter `index` with value `value`: derivative 1 along itself.
    pub fn parameter(value: f64, index: usize) -> Dual {
        let mut gradient = [0.0; MAX_PARAMETERS];
        gradient[index] = 1.0;
        Dual { value, gradient }
    }

    fn constant(value: f64) -> Dual {
        Dual { value, gradient: [0.0; MAX_PARAMETERS] }
    }

    /// `f(x)` with `f'(x) = slope`.
    fn chain(self, value: f64, slope: f64) -> Dual {
        let mut gradient = self.gradient;
        for g in &mut gradient {
            *g *= slope;
        }
        Dual { value, gradient }
    }
}

impl PartialEq for Dual {
    fn eq(&self, other: &Self) -> bool {
        self.value == other.value
    }
}

impl PartialOrd for Dual {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        self.value.partial_cmp(&other.value)
    }
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        let mut gradient = self.gradient;
        for (g, d) in gradient.iter_mut().zip(o.gradient) {
            *g += d;
        }
        Dual { value: self.value + o.value, gradient }
    }
}

impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        let mut gradient = self.gradient;
        for (g, d) in gradient.iter_mut().zip(o.gradient) {
            *g -= d;
        }
        Dual { value: self.value - o.value, gradient }
    }
}

impl Real for Dual {
    fn of(v: f64) -> Self {
        Dual::constant(v)
    }
    fn to_f64(self) -> f64 {
        self.value
    }
    fn mul(self, o: Self) -> Self {
        let mut gradient = [0.0; MAX_PARAMETERS];
        for (k, g) in gradient.iter_mut().enumerate() {
            *g = self.gradient[k] * o.value + self.value * o.gradient[k];
        }
        Dual { value: self.value * o.value, gradient }
    }
    fn div(self, o: Self) -> Self {
        let value = self.value / o.value;
        let mut gradient = [0.0; MAX_PARAMETERS];
        for (k, g) in gradient.iter_mut().enumerate() {
            *g = (self.gradient[k] - value * o.gradient[k]) / o.value;
        }
        Dual { value, gradient }
    }
    fn sqrt(self) -> Self {
        let value = self.value.sqrt();
        // The derivative is infinite at 0; the forms only take square roots of quantities they
        // keep away from 0 or of constants, so a 0 slope there is the safe limit.
        self.chain(value, if value > 0.0 { 0.5 / value } else { 0.0 })
    }
    fn exp(self) -> Self {
        let value = self.value.exp();
        self.chain(value, value)
    }
    fn ln(self) -> Self {
        self.chain(self.value.ln(), 1.0 / self.value)
    }
    fn sin(self) -> Self {
        self.chain(self.value.sin(), self.value.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.value.cos(), -self.value.sin())
    }
    fn powf(self, e: Self) -> Self {
        let value = self.value.powf(e.value);
        if value == 0.0 {
            // 0^e with e > 0: the value and every derivative vanish (the ln 0 of the formula below
            // would make them NaN).
            return Dual::constant(0.0);
        }
        let (d_base, d_exponent) = (e.value * value / self.value, value * self.value.ln());
        let mut gradient = [0.0; MAX_PARAMETERS];
        for (k, g) in gradient.iter_mut().enumerate() {
            *g = d_base * self.gradient[k] + d_exponent * e.gradient[k];
        }
        Dual { value, gradient }
    }
    fn abs(self) -> Self {
        if self.value < 0.0 { Dual::constant(0.0) - self } else { self }
    }
    fn max(self, o: Self) -> Self {
        if o.value > self.value { o } else { self }
    }
    fn min(self, o: Self) -> Self {
        if o.value < self.value { o } else { self }
    }
}
