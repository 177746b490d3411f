//! Error statistics shared by the generator, which computes them, and the manifest, which
//! publishes them.

use serde::{Deserialize, Serialize};

/// RMS and maximum of a set of absolute differences or standard errors.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ErrorSummary {
    /// Number of values summarised.
    pub count: usize,
    /// Root mean square of the values (0 for none).
    pub rms: f64,
    /// Largest absolute value (0 for none).
    pub max: f64,
}

impl ErrorSummary {
    /// The summary of `count` values of root mean square `rms` and largest magnitude `max`.
    pub fn new(count: usize, rms: f64, max: f64) -> Self {
        ErrorSummary { count, rms, max }
    }

    /// RMS and maximum of the absolute values.
    pub fn of_differences(differences: impl IntoIterator<Item = f64>) -> Self {
        let (mut count, mut sum2, mut max) = (0usize, 0.0f64, 0.0f64);
        for d in differences {
            count += 1;
            sum2 += d * d;
            max = max.max(d.abs());
        }
        ErrorSummary { count, rms: if count == 0 { 0.0 } else { (sum2 / count as f64).sqrt() }, max }
    }

    /// The summary of the values of two summaries together.
    pub fn pooled(&self, other: &ErrorSummary) -> Self {
        let count = self.count + other.count;
        let sum2 = self.rms * self.rms * self.count as f64 + other.rms * other.rms * other.count as f64;
        ErrorSummary {
            count,
            rms: if count == 0 { 0.0 } else { (sum2 / count as f64).sqrt() },
            max: self.max.max(other.max),
        }
    }
}

/// A table compared, at a subset of its nodes, with the exact integral there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ReferenceComparison {
    /// Gauss–Legendre nodes per panel of each node's exact integral (the deterministic
    /// visible-normal quadrature).
    #[serde(default)]
    pub exact_nodes: usize,
    /// Stored f32 value minus reference, over the compared cells and all channels.
    pub difference: ErrorSummary,
}

impl ReferenceComparison {
    /// The `difference` at nodes integrated exactly with `exact_nodes` nodes per panel.
    pub fn new(exact_nodes: usize, difference: ErrorSummary) -> Self {
        ReferenceComparison { exact_nodes, difference }
    }
}

/// The integration error of a table, estimated two independent ways.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ErrorRecord {
    /// Standard error of each cell's mean from the spread of its independently scrambled
    /// replicates, summarised over all cells and channels.
    pub replicate_standard_error: ErrorSummary,
    /// Difference to the exact integral at random nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<ReferenceComparison>,
}

impl ErrorRecord {
    /// The error of replicates spread by `replicate_standard_error`, compared with the exact
    /// integral where `reference` says.
    pub fn new(replicate_standard_error: ErrorSummary, reference: Option<ReferenceComparison>) -> Self {
        ErrorRecord { replicate_standard_error, reference }
    }

    /// The error of two tables' values together (the slices of a texture array): replicate errors
    /// pooled, and reference differences pooled where both were compared with the same quadrature.
    pub fn pooled(&self, other: &ErrorRecord) -> Self {
        let reference = match (&self.reference, &other.reference) {
            (Some(a), Some(b)) if a.exact_nodes == b.exact_nodes => {
                Some(ReferenceComparison { exact_nodes: a.exact_nodes, difference: a.difference.pooled(&b.difference) })
            }
            (Some(a), _) => Some(a.clone()),
            (None, b) => b.clone(),
        };
        ErrorRecord {
            replicate_standard_error: self.replicate_standard_error.pooled(&other.replicate_standard_error),
            reference,
        }
    }
}

/// A measured accuracy figure beyond the integration error: for instance how well a split-sum
/// table with its coefficients reproduces the full FGD integral over a parameter domain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct AccuracyReport {
    /// What was compared with what, and over which domain.
    pub what: String,
    /// RMS and maximum of the absolute error over the domain.
    pub error: ErrorSummary,
    /// Where the largest error occurred, in the parameters' own words.
    pub worst_at: String,
}

impl AccuracyReport {
    /// What was compared, with its `error`, the largest `worst_at`.
    pub fn new(what: impl Into<String>, error: ErrorSummary, worst_at: impl Into<String>) -> Self {
        AccuracyReport { what: what.into(), error, worst_at: worst_at.into() }
    }
}

/// A file (or a table) read at random points of a domain, against the exact integral there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct InterpolationError {
    /// The domain's name (`whole domain`, `low roughness`, ...): what budgets refer to.
    pub domain: String,
    /// How its points were drawn: the box of lookup parameters and their number.
    pub points: String,
    /// How the values were read (the renderer's path).
    pub read_as: String,
    /// Gauss–Legendre nodes per panel of each exact value (the deterministic visible-normal
    /// quadrature, `recipes::Kernel::exact_value`).
    #[serde(default)]
    pub exact_nodes: usize,
    /// Read value minus exact, over points and channels.
    #[serde(flatten)]
    pub error: ErrorSummary,
    /// The 99th percentile of `|read - exact|`: the level all but 1 % of lookups stay within,
    /// where the maximum is one point on a feature the grid cannot follow.
    #[serde(default)]
    pub p99: f64,
    /// The largest `|read - exact|` over the random points alone (`error.max` is over the points
    /// where the error peaks as well; the RMS and `p99` are over the random points).
    #[serde(default)]
    pub random_max: f64,
    /// Where the largest difference is, and both values there.
    pub worst_at: String,
}

impl InterpolationError {
    /// The `domain`'s `points` read as `read_as` against exact values of `exact_nodes` nodes per
    /// panel, with `error` and its largest `worst_at`; no percentile or random-point maximum yet.
    pub fn new(
        domain: impl Into<String>,
        points: impl Into<String>,
        read_as: impl Into<String>,
        exact_nodes: usize,
        error: ErrorSummary,
        worst_at: impl Into<String>,
    ) -> Self {
        InterpolationError {
            domain: domain.into(),
            points: points.into(),
            read_as: read_as.into(),
            exact_nodes,
            error,
            p99: 0.0,
            random_max: 0.0,
            worst_at: worst_at.into(),
        }
    }
}

/// The `q`-quantile of `values` (0 <= q <= 1), the nearest rank `ceil(q n)`; 0 for none.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.max(1) - 1).copied().unwrap_or(0.0)
}

/// The median of `values` (the mean of the middle two for an even count); NaN for none.
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 { sorted[n / 2] } else { 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_differences() {
        let e = ErrorSummary::of_differences([3.0, -4.0]);
        assert_eq!(e.count, 2);
        assert!((e.rms - (12.5f64).sqrt()).abs() < 1e-15);
        assert_eq!(e.max, 4.0);
        assert_eq!(ErrorSummary::of_differences([]).rms, 0.0);
    }

    #[test]
    fn quantile_takes_the_nearest_rank() {
        let values: Vec<f64> = (1..=200).rev().map(f64::from).collect();
        assert_eq!(quantile(&values, 0.99), 198.0);
        assert_eq!(quantile(&values, 1.0), 200.0);
        assert_eq!(quantile(&values, 0.0), 1.0);
        assert_eq!(quantile(&[], 0.99), 0.0);
    }
}
