//! The summary `tmlut fit` prints: one Markdown row per fitted form, then the table fetch it is
//! weighed against.

use std::fmt::Write as _;

use super::least_squares::FitManifest;

/// The fits of `manifest` as a Markdown table, the best form costing no more than eq56, and where
/// `fit.json` was written (`fit_json`).
pub fn markdown(manifest: &FitManifest, fit_json: &std::path::Path) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| form | parameters | RMSE | MSE | max error | at (mu, alpha, eta) | ns/eval (f32) | status (best start) |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for f in &manifest.forms {
        let at = f.figures.max_at;
        let status = f.search.as_ref().map_or("-".to_string(), |s| {
            format!(
                "{} ({}/{} starts succeeded)",
                s.starts[s.best_start].status,
                s.starts.iter().filter(|x| x.succeeded).count(),
                s.starts.len()
            )
        });
        let _ = writeln!(
            out,
            "| {} | {} | {:.4} | {:.5} | {:.3} | ({:.3}, {:.3}, {:.3}) | {:.2} | {status} |",
            f.name,
            f.parameters.len(),
            f.figures.rmse,
            f.figures.mse,
            f.figures.max_abs_error,
            at[0],
            at[1],
            at[2],
            f.cost_ns_per_evaluation_f32,
        );
    }
    let _ = writeln!(
        out,
        "| table fetch (GPU emulator, trilinear) | - | 0 at nodes | - | - | - | {:.2} | - |",
        manifest.table_fetch_cost_ns_f32
    );
    let _ = writeln!(
        out,
        "best form costing no more than eq56: {}",
        manifest.best_under_eq56_cost.as_deref().unwrap_or("none (eq56 not requested, or none cheaper)")
    );
    let _ = writeln!(out, "wrote {}", fit_json.display());
    out
}
