//! The arithmetic the analytic forms are written in, so that one definition of a form evaluates
//! in f32 (as a shader does), in f64, and in dual numbers (for its gradient, [`super::dual`]).

/// The arithmetic the forms need, for f32 and f64 alike.
pub trait Real: Copy + PartialOrd + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> {
    fn of(v: f64) -> Self;
    fn to_f64(self) -> f64;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn powf(self, e: Self) -> Self;
    fn abs(self) -> Self;
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    /// `if condition { if_true } else { if_false }`, without a branch where the type allows: the
    /// forms' two-sided formulas select on data that a timing loop cannot predict.
    fn select(condition: bool, if_true: Self, if_false: Self) -> Self {
        if condition { if_true } else { if_false }
    }
}

macro_rules! real {
    ($t:ty, $select:expr) => {
        impl Real for $t {
            fn select(condition: bool, if_true: Self, if_false: Self) -> Self {
                $select(condition, if_true, if_false)
            }
            fn of(v: f64) -> Self {
                v as $t
            }
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn mul(self, o: Self) -> Self {
                self * o
            }
            fn div(self, o: Self) -> Self {
                self / o
            }
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            fn powf(self, e: Self) -> Self {
                <$t>::powf(self, e)
            }
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
        }
    };
}
real!(f32, select_f32);
real!(f64, |condition: bool, if_true: f64, if_false: f64| if condition { if_true } else { if_false });

/// A bit-mask select for f32, the type a shader evaluates (and the CPU cost is timed in): both
/// sides are computed anyway, and a mispredicted branch costs more than the select.
fn select_f32(condition: bool, if_true: f32, if_false: f32) -> f32 {
    let mask = (condition as u32).wrapping_neg();
    f32::from_bits((if_true.to_bits() & mask) | (if_false.to_bits() & !mask))
}
