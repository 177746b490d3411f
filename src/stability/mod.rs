//! The stiff-case matrix: every physics function and every table recipe evaluated at the
//! edges of its domain, each result held to named properties (finite, in range, the right limit,
//! continuous where physics is, the f32 path agreeing with the f64 one, surviving half-float
//! storage), and a readable report of all of it.
//!
//! The original implementations failed exactly here (`docs/stability.md`: NaN from unguarded square
//! roots, `1 / 0` at total internal reflection, half-float subnormals) and hid it behind
//! `saturate(NaN) = 0`. The report hides nothing: a property that cannot hold at a point (Fresnel
//! at grazing incidence jumps from 0 at `eta = 1` to 1 at `eta = 1 ± 1e-6`) is listed as a
//! *limitation* with the reason, never as a pass.
//!
//! The matrix is data ([`matrix`]), each property a small function returning a [`Check`]
//! ([`properties`]), the cases in [`physics`] and [`tables`], and the whole run in [`run`].

pub mod matrix;
pub mod model;
pub mod physics;
pub mod properties;
pub mod tables;

#[cfg(test)]
mod proptests;

use std::fmt::Write as _;

use crate::config::TableKind;
use crate::error::{Error, Result};
pub use properties::{Check, Outcome};

/// One evaluated case: what was evaluated, where, the value, and the properties checked on it.
#[derive(Debug, Clone)]
pub struct Case {
    /// The function or table, e.g. `fresnel_reflectance` or `fgd (per-cell f64)`.
    pub subject: String,
    /// The stiff point, e.g. `c=0 eta=1.000001 kappa=0`.
    pub parameters: String,
    /// The value (or values) computed there, as printed.
    pub value: String,
    pub checks: Vec<Check>,
}

impl Case {
    pub fn new(subject: impl Into<String>, parameters: impl Into<String>, value: impl Into<String>) -> Self {
        Case { subject: subject.into(), parameters: parameters.into(), value: value.into(), checks: Vec::new() }
    }

    pub fn with(mut self, check: Check) -> Self {
        self.checks.push(check);
        self
    }

    pub fn failed(&self) -> bool {
        self.checks.iter().any(|c| c.outcome == Outcome::Fail)
    }
}

/// The largest difference between two precisions (or two integration paths) over a set of cases.
#[derive(Debug, Clone)]
pub struct PrecisionDifference {
    /// What is compared, e.g. `fgd: fast f32 kernel vs per-cell f64`.
    pub comparison: String,
    /// Values compared.
    pub count: usize,
    /// Largest `|a - b| / max(|b|, floor)`, and where.
    pub worst_relative: f64,
    pub worst_relative_at: String,
    /// Largest `|a - b|`, and where.
    pub worst_absolute: f64,
    pub worst_absolute_at: String,
    /// What the relative difference is divided by when `|b|` is smaller (so that values near 0 do
    /// not turn rounding noise into huge ratios).
    pub relative_floor: f64,
}

impl PrecisionDifference {
    pub fn new(comparison: impl Into<String>, relative_floor: f64) -> Self {
        PrecisionDifference {
            comparison: comparison.into(),
            count: 0,
            worst_relative: 0.0,
            worst_relative_at: String::new(),
            worst_absolute: 0.0,
            worst_absolute_at: String::new(),
            relative_floor,
        }
    }

    /// Record one pair: `value` from the path under test, `reference` from the one it is held to.
    pub fn record(&mut self, value: f64, reference: f64, at: &str) {
        self.count += 1;
        let absolute = (value - reference).abs();
        let relative = absolute / reference.abs().max(self.relative_floor);
        // NaN compares false: count it as the worst possible.
        if absolute.is_nan() || absolute > self.worst_absolute {
            self.worst_absolute = if absolute.is_nan() { f64::INFINITY } else { absolute };
            self.worst_absolute_at = at.to_string();
        }
        if relative.is_nan() || relative > self.worst_relative {
            self.worst_relative = if relative.is_nan() { f64::INFINITY } else { relative };
            self.worst_relative_at = at.to_string();
        }
    }
}

/// Everything one run found.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub cases: Vec<Case>,
    pub precision: Vec<PrecisionDifference>,
    /// Observations that are not pass or fail (half-float behaviour, say).
    pub notes: Vec<String>,
    pub wall_time_s: f64,
}

impl Report {
    pub fn checks(&self) -> impl Iterator<Item = &Check> {
        self.cases.iter().flat_map(|c| &c.checks)
    }

    pub fn count(&self, outcome: Outcome) -> usize {
        self.checks().filter(|c| c.outcome == outcome).count()
    }

    pub fn passed(&self) -> bool {
        self.count(Outcome::Fail) == 0
    }

    /// One line: cases, checks, failures, limitations, time.
    pub fn summary(&self) -> String {
        format!(
            "stability: {} cases, {} checks: {} passed, {} failed, {} limitations stated; {:.1} s",
            self.cases.len(),
            self.checks().count(),
            self.count(Outcome::Pass),
            self.count(Outcome::Fail),
            self.count(Outcome::Limitation),
            self.wall_time_s
        )
    }

    /// The report as text. With `all_cases` every case is listed with every check; otherwise only
    /// failed cases and stated limitations, then the precision comparisons and the summary line.
    pub fn render(&self, all_cases: bool) -> String {
        let mut out = String::new();
        let mut subject = "";
        for case in &self.cases {
            let interesting = case.checks.iter().any(|c| c.outcome != Outcome::Pass);
            if !all_cases && !interesting {
                continue;
            }
            if case.subject != subject {
                subject = &case.subject;
                let _ = writeln!(out, "\n## {subject}");
            }
            let verdict = if case.failed() { "FAIL" } else { "ok" };
            let _ = writeln!(out, "{verdict:<4} {}  =>  {}", case.parameters, case.value);
            for check in &case.checks {
                if all_cases || check.outcome != Outcome::Pass {
                    let _ = writeln!(out, "       {:<10} {}: {}", check.outcome.label(), check.property, check.detail);
                }
            }
        }
        if !self.precision.is_empty() {
            let _ = writeln!(out, "\n## Worst differences between precisions and paths");
            for p in &self.precision {
                let _ = writeln!(
                    out,
                    "- {} ({} values): relative {:.2e} at {}; absolute {:.2e} at {} (relative to max(|reference|, {:.0e}))",
                    p.comparison,
                    p.count,
                    p.worst_relative,
                    p.worst_relative_at,
                    p.worst_absolute,
                    p.worst_absolute_at,
                    p.relative_floor
                );
            }
        }
        if !self.notes.is_empty() {
            let _ = writeln!(out, "\n## Notes");
            for note in &self.notes {
                let _ = writeln!(out, "- {note}");
            }
        }
        let _ = writeln!(out, "\n{}", self.summary());
        out
    }
}

/// The parts of the matrix `--table` can select: the physics functions, one table, half-float
/// storage, or the transfer-matrix model with its random walk.
pub fn sections() -> Vec<&'static str> {
    let mut sections = vec!["physics"];
    sections.extend(TableKind::names());
    sections.extend(["f16", "model"]);
    sections
}

/// Run the matrix: everything, or one section of [`sections`].
pub fn run(section: Option<&str>) -> Result<Report> {
    if let Some(name) = section.filter(|name| !sections().contains(name)) {
        return Err(Error::invalid("--table", format!("`{name}`; allowed: {}", sections().join(", "))));
    }
    let started = std::time::Instant::now();
    let wanted = |name: &str| section.is_none_or(|s| s == name);
    let mut report = Report::default();
    if wanted("physics") {
        physics::run(&mut report);
    }
    let evaluation = tables::Evaluation::new()?;
    for &kind in TableKind::ALL {
        if wanted(kind.name()) {
            tables::run(kind, &evaluation, &mut report);
        }
    }
    if wanted("f16") {
        tables::half_float(&mut report);
    }
    if wanted("model") {
        model::run(&mut report)?;
    }
    report.wall_time_s = started.elapsed().as_secs_f64();
    Ok(report)
}
