//! The reports a researcher reads: one fitted form's `report.md` ([`markdown`]: its figures at the
//! start and fitted values, against exact integrals where certified, the parameters, the search,
//! what is ill-determined, its cost and its files), and a folder's ranking ([`ranking_markdown`]).

use super::fitting::{FolderFits, FormReport};
use super::pictures::{ERROR_MAP_FILE, RESIDUALS_FILE};
use super::shader::{GLSL_HARNESS_EXTENSION, LANGUAGES};

/// The ranking as a table, best first, with each form's cost.
pub fn ranking_markdown(ranking: &FolderFits) -> String {
    use std::fmt::Write as _;
    let mut s = format!("# Forms fitted to table `{}` ({})\n\n", ranking.table, ranking.table_file);
    let weighted = ranking.forms.iter().any(|f| f.weighted_figures.is_some());
    if !ranking.ranges.is_empty() || weighted {
        let ranges: Vec<String> =
            ranking.ranges.iter().map(|r| format!("{} in [{}, {}]", r.variable, r.lo, r.hi)).collect();
        let _ = writeln!(
            s,
            "Region: {}; weights: {}. Each form's report.md has its figures in full.\n",
            if ranges.is_empty() { "the whole table".to_string() } else { ranges.join(", ") },
            ranking.weights
        );
    }
    let timed = ranking.forms.iter().any(|f| f.cost.as_ref().is_some_and(|c| c.timing.is_some()));
    let figures = if weighted { "weighted RMS | weighted p99 | weighted max" } else { "RMS | p99 | max" };
    let _ = writeln!(
        s,
        "| rank | form | parameters | {figures} | max at | operations (arith, transc, select) |{} fit |",
        if timed { " ns, form / lookup |" } else { "" }
    );
    let _ = writeln!(s, "|---:|---|---:|---:|---:|---:|---|---|{}---|", if timed { "---|" } else { "" });
    for (k, f) in ranking.forms.iter().enumerate() {
        let figures = f.ranked_by();
        let at: Vec<String> = figures.max_at.iter().map(|(v, x)| format!("{v} {x:.3}")).collect();
        let operations = f.cost.as_ref().map_or("-".to_string(), |c| {
            let o = &c.operations;
            format!("{}, {}, {}", o.arithmetic, o.transcendental, o.select)
        });
        let time = match f.cost.as_ref().and_then(|c| c.timing.as_ref()) {
            Some(t) => format!(" {:.1} / {:.1} |", t.form_ns, t.lookup_ns),
            None if timed => " - |".to_string(),
            None => String::new(),
        };
        let _ = writeln!(
            s,
            "| {} | `{}` | {} | {:.6} | {:.6} | {:.6} | {} | {operations} |{time} {}/ |",
            k + 1,
            f.form_file,
            f.parameters,
            figures.rms,
            figures.p99,
            figures.max,
            at.join(", "),
            f.folder
        );
    }
    let _ = writeln!(s, "\nRanked {}.", ranking.rule);
    if timed {
        let _ = writeln!(
            s,
            "CPU times per evaluation: medians of {} runs (the form in f32, the table's lookup as a GPU samples it); \
             measured, not asserted.",
            ranking.timing_runs
        );
    }
    s
}

/// The report a researcher reads: the figures at the start and fitted values, the parameters,
/// what is ill-determined, and the files.
pub fn markdown(report: &FormReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "# Form `{}` fitted to table `{}`\n", report.form, report.table);
    let _ = writeln!(
        s,
        "Form file `{}`, table file `{}`; {} points: {}.\n",
        report.form_file, report.table_file, report.points, report.points_are
    );
    if !report.ranges.is_empty() || report.weighted_figures.is_some() {
        let ranges: Vec<String> =
            report.ranges.iter().map(|r| format!("{} in [{}, {}]", r.variable, r.lo, r.hi)).collect();
        let _ = writeln!(
            s,
            "Region: {}; weights: {}. The fit minimises the weighted mean squared residual; every figure below \
             is over the region's points, weighted where it says so.\n",
            if ranges.is_empty() { "the whole table".to_string() } else { ranges.join(", ") },
            report.weights_are
        );
    }
    let _ = writeln!(s, "```text\n{}\n```\n", report.definition.join("\n"));
    let _ = writeln!(s, "| channel | RMS at start | RMS fitted | p99 fitted | max fitted | max at |");
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|");
    let rows = std::iter::once(("together".to_string(), &report.start_figures.together, &report.figures.together))
        .chain(report.figures.channels.iter().map(|(c, f)| (c.clone(), &report.start_figures.channels[c], f)));
    let weighted = report.weighted_figures.as_ref().zip(report.weighted_start_figures.as_ref()).map(|(f, st)| {
        std::iter::once(("together, weighted".to_string(), &st.together, &f.together))
            .chain(f.channels.iter().map(|(c, x)| (format!("{c}, weighted"), &st.channels[c], x)))
    });
    for (channel, start, fitted) in rows.chain(weighted.into_iter().flatten()) {
        let at: Vec<String> = fitted.max_at.iter().map(|(v, x)| format!("{v} {x:.4}")).collect();
        let _ = writeln!(
            s,
            "| {channel} | {:.6} | {:.6} | {:.6} | {:.6} | {}{} |",
            start.rms,
            fitted.rms,
            fitted.p99,
            fitted.max,
            at.join(", "),
            fitted.max_channel.as_ref().map(|c| format!(" ({c})")).unwrap_or_default()
        );
    }
    certified_markdown(&mut s, report);
    let _ = writeln!(s, "\n| parameter | start | fitted | bounds |\n|---|---:|---:|---|");
    for name in &report.parameter_order {
        let [lo, hi] = report.bounds[name];
        let _ = writeln!(s, "| {name} | {} | {} | [{lo}, {hi}] |", report.start[name], report.parameters[name]);
    }
    let id = &report.identifiability;
    let _ = writeln!(s);
    if let Some(search) = &report.search {
        let succeeded = search.starts.iter().filter(|s| s.succeeded).count();
        let _ = writeln!(
            s,
            "Search: {} from {} starts (seed {}), {succeeded} ended with a success status; start {} won, mean squared residual {:.6e}.",
            search.algorithm,
            search.starts.len(),
            report.settings.seed,
            search.best_start,
            search.objective
        );
    } else {
        let _ = writeln!(s, "No search (no parameters, or max evaluations 0): the figures are the start values'.");
    }
    if id.ill_determined.is_empty() {
        let _ = writeln!(s, "\nEvery parameter is determined by the data ({}).", id.rule);
    } else {
        let ratios: Vec<String> = id.ill_determined.iter().map(|w| format!("{:.1e}", w.singular_value_ratio)).collect();
        let _ = writeln!(
            s,
            "\nIll-determined: {} direction(s) of parameter space, made of {} (singular values {} of the largest; {}): \
             the data fixes fewer combinations of these than there are parameters.",
            id.ill_determined.len(),
            id.ill_determined_parameters.join(", "),
            ratios.join(", "),
            id.rule
        );
    }
    if !id.at_bounds.is_empty() {
        let _ = writeln!(s, "\nAt a bound: {}.", id.at_bounds.join(", "));
    }
    cost_and_files_markdown(&mut s, report);
    s
}

/// The figures against exact integrals, one table per domain certified
/// ([`super::certify::Certified`]).
fn certified_markdown(s: &mut String, report: &FormReport) {
    use std::fmt::Write as _;
    for c in &report.certified {
        let _ = writeln!(
            s,
            "\nAgainst exact integrals at {} random points (the quadrature, {} Gauss–Legendre nodes per panel), {}{}:\n",
            c.points,
            c.exact_nodes,
            c.domain,
            if report.ranges.is_empty() { "" } else { ", those of them inside the region" }
        );
        let _ = writeln!(
            s,
            "| channel | form at start: RMS | fitted: RMS | p99 | max | max at | table interpolated: RMS | p99 | max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---|---:|---:|---:|");
        let rows =
            std::iter::once(("together".to_string(), &c.form_at_start.together, &c.form.together, &c.table.together))
                .chain(
                    c.form
                        .channels
                        .iter()
                        .map(|(k, f)| (k.clone(), &c.form_at_start.channels[k], f, &c.table.channels[k])),
                );
        // Weighted, the start's figures are not kept: its column repeats the unweighted one's.
        let weighted = c.form_weighted.as_ref().zip(c.table_weighted.as_ref()).map(|(f, t)| {
            std::iter::once(("together, weighted".to_string(), &c.form_at_start.together, &f.together, &t.together))
                .chain(
                    f.channels
                        .iter()
                        .map(|(k, x)| (format!("{k}, weighted"), &c.form_at_start.channels[k], x, &t.channels[k])),
                )
        });
        for (channel, start, fitted, table) in rows.chain(weighted.into_iter().flatten()) {
            let at: Vec<String> = fitted.max_at.iter().map(|(v, x)| format!("{v} {x:.4}")).collect();
            let _ = writeln!(
                s,
                "| {channel} | {:.6} | {:.6} | {:.6} | {:.6} | {} | {:.2e} | {:.2e} | {:.2e} |",
                start.rms,
                fitted.rms,
                fitted.p99,
                fitted.max,
                at.join(", "),
                table.rms,
                table.p99,
                table.max
            );
        }
    }
}

/// The form's cost, and the files of its set: the shaders and the pictures.
fn cost_and_files_markdown(s: &mut String, report: &FormReport) {
    use std::fmt::Write as _;
    if let Some(cost) = &report.cost {
        let o = &cost.operations;
        let _ = writeln!(
            s,
            "\nCost: {} arithmetic operations, {} transcendental functions, {} selects (the instructions the channels read).",
            o.arithmetic, o.transcendental, o.select
        );
        if let Some(t) = &cost.timing {
            let _ = writeln!(
                s,
                "CPU time per evaluation, median of {} runs over {} of the points: the form {:.1} ns (f32, the instruction list \
                 interpreted), the table's lookup {:.1} ns ({}; the GPU emulator's sampling in Rust). Measured, not asserted: \
                 it depends on the machine and its load.",
                t.runs, t.batch, t.form_ns, t.lookup_ns, t.lookup
            );
        }
    }
    let arguments: Vec<String> = report
        .shader_arguments
        .iter()
        .map(|a| if a.name == a.axis { a.name.clone() } else { format!("{} ({})", a.name, a.axis) })
        .collect();
    let (languages, harness): (Vec<&String>, Vec<&String>) = report
        .files
        .iter()
        .filter(|f| {
            LANGUAGES.iter().any(|(_, ext)| f.ends_with(&format!(".{ext}"))) || f.ends_with(GLSL_HARNESS_EXTENSION)
        })
        .partition(|f| !f.ends_with(GLSL_HARNESS_EXTENSION));
    let languages: Vec<&str> = languages.into_iter().map(String::as_str).collect();
    let _ = write!(
        s,
        "\nShader function `{}({})` in: {}",
        report.shader_function,
        arguments.join(", "),
        languages.join(", ")
    );
    match harness.first() {
        Some(harness) => {
            let _ = writeln!(s, "; the GLSL is an include file of the functions, validated inside {harness}.");
        }
        None => s.push_str(".\n"),
    }
    if report.files.iter().any(|f| f == ERROR_MAP_FILE) {
        let _ = writeln!(
            s,
            "\n![|form - table| over two axes]({ERROR_MAP_FILE})\n\n\
             [`{ERROR_MAP_FILE}`]({ERROR_MAP_FILE}): |form - table| of the channel with the largest error \
             over the table's first two axes (over the form's first two variables where the points are a \
             uniform grid), the max over any other axis, on a logarithmic colour scale.\n\n\
             ![histogram of the residuals]({RESIDUALS_FILE})\n\n\
             [`{RESIDUALS_FILE}`]({RESIDUALS_FILE}): every residual (form - table), all points and channels, \
             with the RMS and 99th percentile of |r| marked."
        );
    }
}
