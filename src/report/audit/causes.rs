//! The causes `tmlut audit` recognises in a shipped table's error, each by a test of its own whose
//! figures the report carries, so that a claim can be checked by hand:
//!
//! - a **whole-table variant** (axes swapped, shifted or flipped by one texel along an axis, the
//!   other masking model): the file against the exact table transformed so, compared on the same
//!   texels with the file against the exact table as the preset states it. The variant is claimed
//!   when its RMS error is at most [`CLEARLY_BETTER`] of the other, that is when it explains at
//!   least three quarters of the squared error; of several, the one that explains most;
//! - a **line shifted by one texel** (one row or column of the file, moved along the other axis or
//!   holding its neighbour's values): the same comparison, line by line, where no whole-table
//!   variant was claimed;
//! - **half-float rounding**: every value within half an f16 ulp of the exact one (the ulp of the
//!   exact value's binade), allowing [`ROUNDING_SLACK`] beyond it for the integration that
//!   preceded the rounding; the count equal to the exact value rounded to nearest is reported too;
//! - **sample noise**: the errors are fitted as Gaussian, of variance `s_k^2 / N + r_k` at value
//!   `k`, where `s_k^2` is the exact variance of one visible-normal sample of the integrand there
//!   and `r_k = ulp_k^2 / 12` the rounding's; `N` (the equivalent count of independent samples) by
//!   maximum likelihood. Noise is claimed where that fit beats, each by [`NOISE_EVIDENCE`] in log
//!   likelihood, both rounding alone and errors of one size everywhere (noise grows with the
//!   integrand's own spread: none at a mirror, most at grazing rough texels), and at most 1% of the
//!   values lie beyond [`NOISE_OUTLIER_Z`] standard deviations of it.
//!
//! Rounding and noise are tested against the exact table of the variant claimed, if any, so that
//! a table with the other masking model can still be recognised as rounded or noisy.

use serde::Serialize;

/// A variant's RMS error at most this fraction of the error as the preset states it: it explains
/// at least `1 - 0.5^2 = 3/4` of the squared error.
pub const CLEARLY_BETTER: f64 = 0.5;
/// How far beyond half an f16 ulp an error may reach and still count as rounding: the integration
/// before rounding moves a value across a rounding boundary only when it lies that close to one.
/// 1e-5 is the error every preset table is held to (its reference check), and 1/50 of an ulp at
/// 0.5 to 1; near 0 (bias at smooth texels of large `n.v`) an ulp is far smaller than it.
pub const ROUNDING_SLACK: f64 = 1e-5;
/// The log-likelihood margin a noise fit must win by (a likelihood ratio of e^10, about 2e4).
pub const NOISE_EVIDENCE: f64 = 10.0;
/// An error beyond this many standard deviations of the fitted noise is an outlier: a Gaussian
/// value lies beyond 4 with probability 6.3e-5, 0.03 of the 512 values of a 16 x 16 x 2 table.
pub const NOISE_OUTLIER_Z: f64 = 4.0;
/// Noise allows one outlier per this many values (1%, at least none): low-discrepancy points gain
/// more over independent ones at some texels than at others, so a table integrated with them has
/// errors only roughly proportional to the integrand's spread (a 256-sample 16 x 16 table of tmlut's
/// has a few values between 4 and 6 standard deviations); a structured error (a wrong line, a
/// corrupted texel among rounded ones) puts far more values out.
pub const NOISE_OUTLIERS_PER: usize = 100;

/// The values of a table over two axes, `values[(i + nx j) channels + c]`, as the audit compares
/// them: the file's (non-finite ones left out by the caller), or an exact table's.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    pub nx: usize,
    pub ny: usize,
    pub channels: usize,
}

impl Grid {
    fn node(&self, i: usize, j: usize) -> usize {
        i + self.nx * j
    }

    fn count(&self, axis: usize) -> usize {
        if axis == 0 { self.nx } else { self.ny }
    }

    fn at(&self, axis: usize, along: usize, across: usize) -> usize {
        if axis == 0 { self.node(along, across) } else { self.node(across, along) }
    }
}

/// An exact table the file may hold: one per masking model, its mean and the variance of one
/// visible-normal sample per value.
#[derive(Debug, Clone)]
pub struct ExactTable {
    pub masking: &'static str,
    pub mean: Vec<f64>,
    pub variance: Vec<f64>,
}

/// What the tests are given.
pub struct Evidence<'a> {
    pub grid: Grid,
    /// The file's values; NaN where the file holds NaN or infinity.
    pub file: &'a [f64],
    /// Whether the file stores half floats (every value an f16).
    pub half_float: bool,
    /// The exact table under the preset's conventions.
    pub preset: &'a ExactTable,
    /// The exact tables of the other masking models.
    pub other_masking: &'a [ExactTable],
    /// The names of the two axes in prose (`n.v`, `roughness`).
    pub axis_names: [&'a str; 2],
}

/// One cause recognised, in words.
#[derive(Debug, Clone, Serialize)]
pub struct Cause {
    /// `swapped-axes`, `shifted`, `flipped`, `other-masking`, `shifted-line`,
    /// `half-float-rounding` or `sample-noise`.
    pub kind: &'static str,
    pub text: String,
}

/// The file against one variant of the exact table.
#[derive(Debug, Clone, Serialize)]
pub struct VariantFit {
    pub variant: String,
    /// Values compared (the file's finite values the variant maps onto the exact table).
    pub values: usize,
    /// RMS of file minus variant.
    pub rms: f64,
    /// RMS of file minus the exact table as the preset states it, on the same values.
    pub rms_as_stated: f64,
    pub claimed: bool,
}

/// The half-float rounding test.
#[derive(Debug, Clone, Serialize)]
pub struct RoundingTest {
    /// Whether the file stores half floats at all (otherwise nothing is tested).
    pub half_float: bool,
    pub values: usize,
    pub within_half_ulp: usize,
    /// Values equal to the exact value rounded to nearest half float.
    pub equal_to_exact_rounded: usize,
    /// The largest |error| beyond half an ulp, in ulps (0 where every value is within).
    pub largest_beyond_half_ulp: f64,
    /// The largest |error| beyond half an ulp, absolute.
    pub largest_beyond_half_ulp_absolute: f64,
    pub holds: bool,
}

/// The sample-noise fit.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseTest {
    /// Values that carry information on N (those whose integrand varies).
    pub values: usize,
    /// The equivalent count of independent visible-normal samples per texel (none where the fit
    /// prefers no noise at all).
    pub equivalent_samples: Option<f64>,
    /// Log likelihood of the fit, and its margins over rounding alone and over errors of one size.
    pub margin_over_rounding_alone: f64,
    pub margin_over_uniform_errors: f64,
    /// The largest |error| in standard deviations of the fitted noise.
    pub largest_z: f64,
    /// Values whose |error| is beyond [`NOISE_OUTLIER_Z`] standard deviations of it.
    pub outliers: usize,
    pub holds: bool,
}

/// A line of the file shifted by one texel.
#[derive(Debug, Clone, Serialize)]
pub struct LineShift {
    pub text: String,
    pub rms: f64,
    pub rms_as_stated: f64,
}

/// Every test's figures and the causes claimed.
#[derive(Debug, Clone, Serialize)]
pub struct Findings {
    pub causes: Vec<Cause>,
    pub variants: Vec<VariantFit>,
    pub shifted_lines: Vec<LineShift>,
    pub rounding: RoundingTest,
    pub noise: NoiseTest,
}

/// A variant: for each node of the file, the node of the exact table (`model`) it is compared
/// with, if any.
struct Variant<'a> {
    name: String,
    kind: &'static str,
    text: String,
    model: &'a ExactTable,
    map: Vec<Option<usize>>,
}

/// Run every test.
pub fn recognise(evidence: &Evidence) -> Findings {
    let grid = evidence.grid;
    let identity: Vec<Option<usize>> = (0..grid.nx * grid.ny).map(Some).collect();
    let as_stated = rounding_test(evidence, evidence.preset, &identity);
    let mut variants = whole_table_variants(evidence);
    let mut fits: Vec<VariantFit> = variants
        .iter()
        .map(|v| {
            let (rms, rms_as_stated, values) = compare(evidence, v.model, &v.map);
            let claimed = !as_stated.holds && values > 0 && rms <= CLEARLY_BETTER * rms_as_stated;
            VariantFit { variant: v.name.clone(), values, rms, rms_as_stated, claimed }
        })
        .collect();
    let best = fits
        .iter()
        .enumerate()
        .filter(|(_, f)| f.claimed)
        .min_by(|(_, a), (_, b)| (a.rms / a.rms_as_stated).total_cmp(&(b.rms / b.rms_as_stated)))
        .map(|(k, _)| k);
    for (k, fit) in fits.iter_mut().enumerate() {
        fit.claimed = Some(k) == best;
    }
    let mut causes = Vec::new();
    let (model, map) = match best {
        Some(k) => {
            let variant = variants.swap_remove(k);
            let fit = &fits[k];
            causes.push(Cause {
                kind: variant.kind,
                text: format!(
                    "{}: against that table the RMS error is {:.3e}, against the stated one {:.3e} (the same {} values)",
                    variant.text, fit.rms, fit.rms_as_stated, fit.values
                ),
            });
            (variant.model, variant.map)
        }
        None => (evidence.preset, identity.clone()),
    };
    let shifted_lines = if best.is_none() && !as_stated.holds { shifted_lines(evidence) } else { Vec::new() };
    for line in &shifted_lines {
        causes.push(Cause { kind: "shifted-line", text: line.text.clone() });
    }
    let rounding = if best.is_some() { rounding_test(evidence, model, &map) } else { as_stated };
    let noise = noise_test(evidence, model, &map, rounding.holds);
    if rounding.holds {
        let within = if rounding.within_half_ulp == rounding.values {
            format!("all {} values within half an f16 ulp of the exact value", rounding.values)
        } else {
            format!(
                "{} of {} values within half an f16 ulp of the exact value, the rest at most {:.1e} beyond it (the \
                 integration before rounding)",
                rounding.within_half_ulp, rounding.values, rounding.largest_beyond_half_ulp_absolute
            )
        };
        causes.push(Cause {
            kind: "half-float-rounding",
            text: format!(
                "half-float rounding: {within}; {} equal to the exact value rounded to nearest",
                rounding.equal_to_exact_rounded
            ),
        });
    }
    if noise.holds {
        causes.push(Cause {
            kind: "sample-noise",
            text: format!(
                "sample noise: the errors are those of about {:.0} independent visible-normal samples per texel ({} \
                 of {} errors beyond 4 standard deviations of that noise, the largest {:.1}; the fit beats rounding \
                 alone by {:.0} and errors of one size by {:.0} in log likelihood)",
                noise.equivalent_samples.unwrap_or(f64::NAN),
                noise.outliers,
                noise.values,
                noise.largest_z,
                noise.margin_over_rounding_alone,
                noise.margin_over_uniform_errors
            ),
        });
    }
    Findings { causes, variants: fits, shifted_lines, rounding, noise }
}

/// The whole-table variants: axes swapped (square tables), shifted and flipped along each axis,
/// and each other masking model.
fn whole_table_variants<'a>(evidence: &Evidence<'a>) -> Vec<Variant<'a>> {
    let grid = evidence.grid;
    let names = evidence.axis_names;
    let remap = |f: &dyn Fn(usize, usize) -> Option<(usize, usize)>| -> Vec<Option<usize>> {
        (0..grid.ny)
            .flat_map(|j| (0..grid.nx).map(move |i| (i, j)))
            .map(|(i, j)| f(i, j).map(|(a, b)| grid.node(a, b)))
            .collect()
    };
    let mut variants = Vec::new();
    if grid.nx == grid.ny {
        variants.push(Variant {
            name: "swapped axes".into(),
            kind: "swapped-axes",
            text: format!(
                "swapped axes: the file holds the exact table transposed ({} where {} is)",
                names[1], names[0]
            ),
            model: evidence.preset,
            map: remap(&|i, j| Some((j, i))),
        });
    }
    for (axis, name) in names.into_iter().enumerate() {
        let n = grid.count(axis);
        for step in [-1isize, 1] {
            let shifted = move |k: usize| k.checked_add_signed(step).filter(|&s| s < n);
            variants.push(Variant {
                name: format!("shifted by {step:+} along {}", name),
                kind: "shifted",
                text: format!(
                    "shifted by one texel: each texel holds the exact value of the texel {step:+} along {}",
                    name
                ),
                model: evidence.preset,
                map: remap(&|i, j| if axis == 0 { shifted(i).map(|s| (s, j)) } else { shifted(j).map(|s| (i, s)) }),
            });
        }
        variants.push(Variant {
            name: format!("flipped along {}", name),
            kind: "flipped",
            text: format!("flipped: the file runs {} the other way", name),
            model: evidence.preset,
            map: remap(&|i, j| Some(if axis == 0 { (n - 1 - i, j) } else { (i, n - 1 - j) })),
        });
    }
    for other in evidence.other_masking {
        variants.push(Variant {
            name: format!("masking {}", other.masking),
            kind: "other-masking",
            text: format!("the other masking model: the file matches {} masking", other.masking),
            model: other,
            map: (0..grid.nx * grid.ny).map(Some).collect(),
        });
    }
    variants
}

/// The file's finite values that `map` takes onto the exact table: per value its place in the
/// file, its place in the exact table, and the value.
fn mapped_values<'a>(
    evidence: &'a Evidence,
    map: &'a [Option<usize>],
) -> impl Iterator<Item = (usize, usize, f64)> + 'a {
    let c = evidence.grid.channels;
    map.iter().enumerate().filter_map(|(node, target)| target.map(|t| (node, t))).flat_map(move |(node, target)| {
        (0..c).filter_map(move |k| {
            let value = evidence.file[node * c + k];
            value.is_finite().then_some((node * c + k, target * c + k, value))
        })
    })
}

/// RMS of file minus `model` through `map`, and of file minus the stated exact table on the same
/// values, and how many values.
fn compare(evidence: &Evidence, model: &ExactTable, map: &[Option<usize>]) -> (f64, f64, usize) {
    let (mut variant, mut stated, mut count) = (0.0, 0.0, 0usize);
    for (at, target, value) in mapped_values(evidence, map) {
        variant += (value - model.mean[target]).powi(2);
        stated += (value - evidence.preset.mean[at]).powi(2);
        count += 1;
    }
    let rms = |sum: f64| if count > 0 { (sum / count as f64).sqrt() } else { 0.0 };
    (rms(variant), rms(stated), count)
}

/// The spacing of f16 values in the binade of `v` (the subnormal spacing below the normal range).
pub fn half_ulp_spacing(v: f64) -> f64 {
    let magnitude = v.abs();
    if magnitude < 2f64.powi(-14) { 2f64.powi(-24) } else { 2f64.powi(magnitude.log2().floor() as i32 - 10) }
}

/// The spacing of f32 values in the binade of `v`.
fn single_ulp_spacing(v: f64) -> f64 {
    let magnitude = v.abs();
    if magnitude < 2f64.powi(-126) { 2f64.powi(-149) } else { 2f64.powi(magnitude.log2().floor() as i32 - 23) }
}

fn rounding_test(evidence: &Evidence, model: &ExactTable, map: &[Option<usize>]) -> RoundingTest {
    let mut test = RoundingTest {
        half_float: evidence.half_float,
        values: 0,
        within_half_ulp: 0,
        equal_to_exact_rounded: 0,
        largest_beyond_half_ulp: 0.0,
        largest_beyond_half_ulp_absolute: 0.0,
        holds: false,
    };
    if !evidence.half_float {
        return test;
    }
    for (_, target, value) in mapped_values(evidence, map) {
        let exact = model.mean[target];
        test.values += 1;
        let ulp = half_ulp_spacing(exact);
        let beyond = ((value - exact).abs() - 0.5 * ulp) / ulp;
        if beyond <= 0.0 {
            test.within_half_ulp += 1;
        }
        test.largest_beyond_half_ulp = test.largest_beyond_half_ulp.max(beyond);
        test.largest_beyond_half_ulp_absolute = test.largest_beyond_half_ulp_absolute.max(beyond * ulp);
        if half::f16::from_f64(exact).to_f64() == value {
            test.equal_to_exact_rounded += 1;
        }
    }
    let every_value_finite = evidence.file.iter().all(|v| v.is_finite());
    test.holds = every_value_finite && test.values > 0 && test.largest_beyond_half_ulp_absolute <= ROUNDING_SLACK;
    test
}

/// The error, sample variance and rounding variance of each value the fit uses.
struct NoiseSample {
    error: f64,
    sample_variance: f64,
    rounding_variance: f64,
}

fn log_likelihood(samples: &[NoiseSample], variance: impl Fn(&NoiseSample) -> f64) -> f64 {
    samples
        .iter()
        .map(|s| {
            let v = variance(s);
            -0.5 * (v.ln() + s.error * s.error / v)
        })
        .sum()
}

/// The maximum of `f` over `[lo, hi]`: a grid of `steps`, then golden-section search around the
/// best node. The likelihoods here have one maximum in the log of their scale.
fn maximise(f: impl Fn(f64) -> f64, lo: f64, hi: f64, steps: usize) -> (f64, f64) {
    let h = (hi - lo) / steps as f64;
    let best = (0..=steps).map(|k| lo + h * k as f64).max_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap_or(lo);
    let (mut a, mut b) = ((best - h).max(lo), (best + h).min(hi));
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..60 {
        let (x1, x2) = (b - ratio * (b - a), a + ratio * (b - a));
        if f(x1) >= f(x2) { b = x2 } else { a = x1 }
    }
    let x = 0.5 * (a + b);
    (x, f(x))
}

/// The largest `log2 N` the noise fit considers: beyond it the noise is far below any rounding.
const MAX_LOG2_SAMPLES: f64 = 48.0;

fn noise_test(evidence: &Evidence, model: &ExactTable, map: &[Option<usize>], rounding_holds: bool) -> NoiseTest {
    let samples: Vec<NoiseSample> = mapped_values(evidence, map)
        .map(|(_, target, value)| {
            let exact = model.mean[target];
            let ulp = if evidence.half_float { half_ulp_spacing(exact) } else { single_ulp_spacing(exact) };
            NoiseSample {
                error: value - exact,
                sample_variance: model.variance[target].max(0.0),
                rounding_variance: ulp * ulp / 12.0,
            }
        })
        .collect();
    let informative = samples.iter().filter(|s| s.sample_variance > 0.0).count();
    let noise = |log2_n: f64| {
        let n = log2_n.exp2();
        log_likelihood(&samples, |s| s.sample_variance / n + s.rounding_variance)
    };
    let uniform = |log2_c: f64| {
        let c2 = (2.0 * log2_c).exp2();
        log_likelihood(&samples, |s| c2 + s.rounding_variance)
    };
    let rounding_alone = log_likelihood(&samples, |s| s.rounding_variance);
    let (log2_n, fitted) = maximise(noise, 0.0, MAX_LOG2_SAMPLES, 960);
    let (_, uniform_best) = maximise(uniform, -60.0, 0.0, 1200);
    let n = log2_n.exp2();
    let largest_z = samples
        .iter()
        .map(|s| s.error.abs() / (s.sample_variance / n + s.rounding_variance).sqrt())
        .fold(0.0, f64::max);
    let outliers = samples
        .iter()
        .filter(|s| s.error.abs() > NOISE_OUTLIER_Z * (s.sample_variance / n + s.rounding_variance).sqrt())
        .count();
    let interior = log2_n < MAX_LOG2_SAMPLES - 0.5;
    let (over_rounding, over_uniform) = (fitted - rounding_alone, fitted - uniform_best);
    NoiseTest {
        values: informative,
        equivalent_samples: interior.then_some(n),
        margin_over_rounding_alone: over_rounding,
        margin_over_uniform_errors: over_uniform,
        largest_z,
        outliers,
        holds: !rounding_holds
            && interior
            && informative > 0
            && over_rounding >= NOISE_EVIDENCE
            && over_uniform >= NOISE_EVIDENCE
            && outliers <= samples.len() / NOISE_OUTLIERS_PER,
    }
}

/// Lines of the file shifted by one texel: a line along one axis moved along itself, or holding
/// the exact values of its neighbour across.
fn shifted_lines(evidence: &Evidence) -> Vec<LineShift> {
    let grid = evidence.grid;
    let names = evidence.axis_names;
    let mut found = Vec::new();
    for axis in 0..2 {
        let other = 1 - axis;
        let (n, m) = (grid.count(axis), grid.count(other));
        for step in [-1isize, 1] {
            let shifted = |k: usize| k.checked_add_signed(step).filter(|&s| s < n);
            // The line at index `across` on the other axis, its texels moved along `axis`.
            for across in 0..m {
                let pairs: Vec<(usize, usize)> = (0..n)
                    .filter_map(|along| Some((grid.at(axis, along, across), grid.at(axis, shifted(along)?, across))))
                    .collect();
                if let Some((rms, rms_as_stated)) = line_fit(evidence, &pairs) {
                    found.push(LineShift {
                        text: format!(
                            "the line of {} index {across} is shifted by one texel along {}: each of its texels holds \
                             the exact value {step:+} along (RMS {rms:.3e} against that, {rms_as_stated:.3e} as stated)",
                            names[other], names[axis]
                        ),
                        rms,
                        rms_as_stated,
                    });
                }
            }
            // The line at index `along` on `axis` holding the exact line `step` away.
            for along in 0..n {
                let Some(neighbour) = shifted(along) else { continue };
                let pairs: Vec<(usize, usize)> =
                    (0..m).map(|across| (grid.at(axis, along, across), grid.at(axis, neighbour, across))).collect();
                if let Some((rms, rms_as_stated)) = line_fit(evidence, &pairs) {
                    found.push(LineShift {
                        text: format!(
                            "the line of {} index {along} holds the exact values of index {neighbour} (RMS {rms:.3e} \
                             against those, {rms_as_stated:.3e} as stated)",
                            names[axis]
                        ),
                        rms,
                        rms_as_stated,
                    });
                }
            }
        }
    }
    found
}

/// Where a line fits the shifted exact values clearly better than the stated ones, and its error
/// as stated is beyond rounding: the two RMS errors.
fn line_fit(evidence: &Evidence, pairs: &[(usize, usize)]) -> Option<(f64, f64)> {
    let c = evidence.grid.channels;
    let exact = &evidence.preset.mean;
    let (mut shifted, mut stated, mut count, mut beyond_rounding) = (0.0, 0.0, 0usize, false);
    for &(node, source) in pairs {
        for k in 0..c {
            let value = evidence.file[node * c + k];
            if !value.is_finite() {
                continue;
            }
            let error = value - exact[node * c + k];
            let allowed =
                if evidence.half_float { 0.5 * half_ulp_spacing(exact[node * c + k]) + ROUNDING_SLACK } else { 0.0 };
            beyond_rounding |= error.abs() > allowed;
            shifted += (value - exact[source * c + k]).powi(2);
            stated += error * error;
            count += 1;
        }
    }
    // A line of one or two texels fits anything: a shift is claimed on three or more.
    if count < 3 * c || !beyond_rounding {
        return None;
    }
    let (shifted, stated) = ((shifted / count as f64).sqrt(), (stated / count as f64).sqrt());
    (shifted <= CLEARLY_BETTER * stated).then_some((shifted, stated))
}
