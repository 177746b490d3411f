//! `tmlut bench`'s suites other than the tables (those are measured in the library's tests): each
//! prints its Markdown section with a row per case, and refuses bad settings.

use super::{assert_clean_failure, stderr, stdout, tmlut};

/// The rows of the Markdown table under the section `heading` of `text`, split into cells.
fn table_rows(text: &str, heading: &str) -> Vec<Vec<String>> {
    assert!(text.starts_with(heading), "no `{heading}` section in:\n{text}");
    text.lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("|---"))
        .skip(1)
        .map(|l| l.trim_matches('|').split(" | ").map(|cell| cell.trim().to_string()).collect())
        .collect()
}

fn number(cell: &str) -> f64 {
    cell.parse().unwrap_or_else(|_| panic!("`{cell}` is not a number"))
}

#[test]
fn the_walk_suite_times_both_stacks_at_every_view_and_thread_count() {
    let output = tmlut(&["bench", "walk", "--paths", "1024", "--repeats", "2", "--threads", "2"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("1024 paths per run") && text.contains("median of 2 runs on 1 and 2 thread(s)"), "{text}");
    let rows = table_rows(&text, "## Random walk: time per path");
    assert_eq!(rows.len(), 2 * 3 * 2, "{text}");
    for row in &rows {
        let [stack, mu, threads, median, runs, albedo, se, paths] = &row[..] else { panic!("{row:?}") };
        assert!(["varnished conductor", "scattering coat"].contains(&stack.as_str()), "{row:?}");
        assert!([1.0, 0.5, 0.05].contains(&number(mu)) && ["1", "2"].contains(&threads.as_str()), "{row:?}");
        assert!(number(median) > 0.0 && runs.split(", ").map(number).count() == 2, "{row:?}");
        let albedo: Vec<f64> = albedo.split(", ").map(number).collect();
        assert!(albedo.len() == 3 && albedo.iter().all(|a| (0.0..=1.0).contains(a)), "{row:?}");
        assert!(number(se) > 0.0 && number(paths) > 0.0, "{row:?}");
    }
}

#[test]
fn the_furnace_suite_walks_six_materials_with_the_paths_asked_for() {
    let output = tmlut(&["bench", "furnace", "-q", "--views", "2", "--max-paths", "1024", "--threads", "2"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("at 2 view cosines") && text.contains("on 2 thread(s)"), "{text}");
    assert!(text.contains("after at least 1024 and at most 1024 paths"), "{text}");
    let rows = table_rows(&text, "## Furnace workload: the random walk over six materials");
    assert_eq!(rows.len(), 6, "{text}");
    for row in &rows {
        let [_, wall, paths, se, most, at] = &row[..] else { panic!("{row:?}") };
        // One batch of 1024 paths at each of the two views.
        assert!(number(wall) >= 0.0 && paths == "2048" && most == "1024", "{row:?}");
        assert!(number(se) > 0.0 && [0.0, 1.0].contains(&number(at)), "{row:?}");
    }
    assert!(text.contains("Whole workload: "), "{text}");
}

#[test]
fn the_quadrature_suite_compares_every_hard_lookup_and_states_the_largest_difference() {
    let output = tmlut(&["bench", "quadrature", "-q", "--samples", "65536"]);
    assert!(output.status.success(), "{}{}", stdout(&output), stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("65536 Sobol samples in 16 replicates"), "{text}");
    let rows = table_rows(&text, "## Exact integrals against Monte Carlo");
    assert!(rows.len() >= 20, "{text}");
    for row in &rows {
        let [_, _, _, _, _, quadrature, finer, monte_carlo, se, difference, agrees] = &row[..] else {
            panic!("{row:?}")
        };
        assert!(number(quadrature).is_finite() && number(finer).abs() <= 1e-5, "{row:?}");
        assert!((number(quadrature) - number(monte_carlo)).abs() <= 5.0 * number(se) + 1e-6, "{row:?}");
        assert!(number(difference) >= 0.0 && agrees == "yes", "{row:?}");
    }
    assert!(
        text.contains("Max |quadrature − MC|: ") && text.contains(&format!("{0} of {0} lookups agree", rows.len()))
    );
}

#[test]
fn the_suites_refuse_bad_settings_by_name() {
    for (args, expected) in [
        (&["bench", "walk", "--paths", "0"][..], "--paths"),
        (&["bench", "walk", "--repeats", "0"], "--repeats"),
        (&["bench", "furnace", "--views", "1"], "--views"),
        (&["bench", "furnace", "--max-paths", "0"], "--max-paths"),
        (&["bench", "furnace", "--repeats", "101"], "--repeats"),
        (&["bench", "quadrature", "--samples", "8"], "--samples"),
        (&["bench", "quadrature", "--samples", "1000"], "--samples"),
        (&["bench", "bake", "--nodes", "3"], "--nodes"),
        (&["bench", "bake", "--error-views", "0"], "--error-views"),
        (&["bench", "bake", "--scene", "luts/scenes/no-such-scene.toml"], "no-such-scene"),
    ] {
        assert_clean_failure(&tmlut(args), &[expected]);
    }
    // The tables' options belong to the tables: given beside another suite they are refused.
    let output = tmlut(&["bench", "--only", "gd", "walk"]);
    assert!(!output.status.success() && stderr(&output).contains("--only"), "{}", stderr(&output));
}

#[test]
fn the_bake_suite_bakes_every_material_and_measures_it_against_its_model() {
    let output = tmlut(&[
        "bench",
        "bake",
        "--scene",
        "luts/scenes/copper-pot.toml",
        "--scene",
        "luts/scenes/textured.toml",
        "--nodes",
        "32",
        "--error-views",
        "2",
        "--alone",
        "2",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("3 materials of 2 scene file(s)") && text.contains("at 32 nodes of mu"), "{text}");
    assert!(text.contains("the first 2 alone"), "{text}");
    let rows = table_rows(&text, "## tmlut bench bake");
    let names: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(names, ["copper-pot/varnished-copper", "textured/worn-gold", "textured/glazed-ceramic"], "{text}");
    for (k, row) in rows.iter().enumerate() {
        let [_, lobes, reads, breaks, jumps, ms, errors @ ..] = &row[..] else { panic!("{row:?}") };
        // Six values and six per lobe, four to a texel.
        assert_eq!(number(reads), ((6.0 + 6.0 * number(lobes)) / 4.0).ceil(), "{row:?}");
        assert!(number(breaks) <= 7.0 && 2.0 * number(jumps) <= number(breaks), "{row:?}");
        // The first two were baked alone too, the third side by side only.
        assert!(if k < 2 { number(ms) > 0.0 } else { ms == "–" }, "{row:?}");
        assert!(errors.iter().all(|e| (0.0..0.1).contains(&number(e))), "{row:?}");
    }
    assert!(text.contains("Largest error: ") && text.contains("side by side"), "{text}");
}
