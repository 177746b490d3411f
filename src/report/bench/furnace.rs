//! `tmlut bench furnace`: the furnace test's random-walk workload, timed: six materials (the five
//! of the example scenes and two rough coats over a scattering medium over gold) at view cosines
//! uniform in `mu`, with the furnace's default walk settings.

use std::fmt::Write;

use super::walk::{scattering_coat, varnished_conductor};
use super::{median, timed};
use crate::error::Result;
use crate::integrate::Progress;
use crate::model::{Interface, Layer, Medium, Stack};
use crate::random_walk::{WalkEstimate, WalkSettings, directional_albedo_curve};

/// Gold's indices (R, G, B) after Gulbrandsen 2014's table of metals, as the textured scene has them.
const GOLD_ETA: [f64; 3] = [0.18, 0.42, 1.37];
const GOLD_KAPPA: [f64; 3] = [3.42, 2.35, 1.77];

/// The materials of the workload, by name: those of the example scenes (`luts/scenes/`) and a
/// stack heavier than any of them.
pub fn materials() -> Result<Vec<(&'static str, Stack)>> {
    let interface = |eta: [f64; 3], kappa: [f64; 3], alpha: f64| Layer::Interface(Interface { eta, kappa, alpha });
    Ok(vec![
        ("varnished-copper", varnished_conductor()?),
        (
            "coated-conductor",
            Stack::new(vec![interface([1.5; 3], [0.0; 3], 0.1), interface([1.0; 3], [1.0, 0.1, 0.1], 0.01)])?,
        ),
        ("scattering-stack", scattering_coat()?),
        ("worn-gold", Stack::new(vec![interface([1.5; 3], [0.0; 3], 0.25), interface(GOLD_ETA, GOLD_KAPPA, 0.1)])?),
        ("glazed-ceramic", Stack::new(vec![interface([1.5; 3], [0.0; 3], 0.2)])?),
        (
            "two coats over a medium",
            Stack::new(vec![
                interface([1.3; 3], [0.0; 3], 0.05),
                interface([1.6; 3], [0.0; 3], 0.3),
                Layer::Medium(Medium { sigma_s: [2.0; 3], sigma_k: [0.1, 0.3, 0.6], depth: 0.5, g: 0.5 }),
                interface(GOLD_ETA, GOLD_KAPPA, 0.2),
            ])?,
        ),
    ])
}

/// What to measure.
#[derive(Debug, Clone)]
pub struct FurnaceBenchSettings {
    /// View cosines per material, `k / (views - 1)` for `k` from 0 to `views - 1`.
    pub views: usize,
    /// Runs of the whole workload; the medians are reported.
    pub repeats: usize,
    pub walk: WalkSettings,
}

impl Default for FurnaceBenchSettings {
    fn default() -> Self {
        FurnaceBenchSettings { views: 64, repeats: 1, walk: WalkSettings::default() }
    }
}

impl FurnaceBenchSettings {
    pub fn view_cosines(&self) -> Vec<f64> {
        let last = self.views.max(2) - 1;
        (0..=last).map(|k| k as f64 / last as f64).collect()
    }
}

/// One material's walks over every view.
#[derive(Debug, Clone)]
pub struct MaterialTiming {
    pub name: &'static str,
    /// Wall seconds of each run.
    pub seconds: Vec<f64>,
    /// The walk's estimate at each view (the same in every run: the walk is seeded per batch).
    pub curve: Vec<WalkEstimate>,
}

impl MaterialTiming {
    pub fn median_seconds(&self) -> f64 {
        median(&self.seconds)
    }

    pub fn paths(&self) -> u64 {
        self.curve.iter().map(|e| e.paths).sum()
    }

    /// The largest standard error of the reflected albedo over views and channels.
    pub fn largest_standard_error(&self) -> f64 {
        self.curve.iter().flat_map(|e| e.reflected_standard_error).fold(0.0, f64::max)
    }

    /// The view that traced the most paths.
    pub fn costliest_view(&self) -> Option<&WalkEstimate> {
        self.curve.iter().max_by_key(|e| e.paths)
    }
}

/// The whole workload's timings.
#[derive(Debug, Clone)]
pub struct FurnaceBench {
    pub materials: Vec<MaterialTiming>,
    /// Wall seconds of each run of the whole workload.
    pub total_seconds: Vec<f64>,
}

/// Run the workload `settings.repeats` times on the global thread pool.
pub fn bench_furnace(settings: &FurnaceBenchSettings, progress: &dyn Progress) -> Result<FurnaceBench> {
    let mus = settings.view_cosines();
    let materials = materials()?;
    let mut timings: Vec<MaterialTiming> =
        materials.iter().map(|&(name, _)| MaterialTiming { name, seconds: Vec::new(), curve: Vec::new() }).collect();
    let mut total_seconds = Vec::new();
    for _ in 0..settings.repeats.max(1) {
        let (total, ()) = timed(|| {
            for ((_, stack), timing) in materials.iter().zip(&mut timings) {
                let (seconds, curve) = timed(|| directional_albedo_curve(stack, &mus, &settings.walk, progress));
                timing.seconds.push(seconds);
                timing.curve = curve;
            }
        });
        total_seconds.push(total);
    }
    Ok(FurnaceBench { materials: timings, total_seconds })
}

/// The timings as a Markdown section, with the settings and thread count they were measured under.
pub fn markdown(bench: &FurnaceBench, settings: &FurnaceBenchSettings, threads: usize) -> String {
    let walk = &settings.walk;
    let mut out = String::new();
    let _ = writeln!(out, "## Furnace workload: the random walk over six materials\n");
    let _ = writeln!(
        out,
        "The random walk's directional albedo of six materials at {} view cosines uniform in mu (0 to 1), on \
         {threads} thread(s): each view stops at standard error {:e} in every channel, after at least {} and at most \
         {} paths ({} masking, seed {}). Wall time: median of {} run(s) of the whole workload.\n",
        settings.views,
        walk.target_standard_error,
        walk.min_paths,
        walk.max_paths,
        walk.masking.name(),
        walk.seed,
        settings.repeats,
    );
    let _ = writeln!(out, "| material | wall (s, median) | paths | largest s.e. | most paths in a view | at mu |");
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|");
    for m in &bench.materials {
        let (most, at) = m.costliest_view().map_or((0, f64::NAN), |e| (e.paths, e.mu));
        let _ = writeln!(
            out,
            "| {} | {:.2} | {} | {:.2e} | {most} | {at:.3} |",
            m.name,
            m.median_seconds(),
            m.paths(),
            m.largest_standard_error(),
        );
    }
    let _ = writeln!(out, "\nWhole workload: {:.2} s wall (median).", median(&bench.total_seconds));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_furnace_bench_walks_every_material_at_every_view() {
        let walk = WalkSettings { min_paths: 1024, max_paths: 1024, ..WalkSettings::default() };
        let settings = FurnaceBenchSettings { views: 3, repeats: 2, walk };
        assert_eq!(settings.view_cosines(), [0.0, 0.5, 1.0]);
        let bench = bench_furnace(&settings, &()).unwrap();
        assert_eq!(bench.materials.len(), 6);
        assert_eq!(bench.total_seconds.len(), 2);
        for m in &bench.materials {
            assert_eq!(m.seconds.len(), 2);
            assert_eq!(m.paths(), 3 * 1024, "{m:?}");
            assert!(m.largest_standard_error() > 0.0, "{m:?}");
        }
        let text = markdown(&bench, &settings, 2);
        assert!(text.contains("| two coats over a medium |") && text.contains("on 2 thread(s)"), "{text}");
    }
}
