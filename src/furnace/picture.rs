//! The furnace pictures of a material, as the thesis draws them (its §5.2): a sphere under a
//! uniform environment of radiance 0.42, seen orthographically, for the model with the scene's
//! tables, the random walk, and their absolute difference; and the `A(mu)` curves.
//!
//! A point of the sphere whose normal makes the angle `theta` with the view returns
//! `0.42 A(cos theta)`; each picture draws its curve, interpolated linearly in `theta` between
//! the views (which are uniform in `theta`). The background is the environment itself, so a
//! material that returns all light vanishes into it.

use std::path::Path;

use super::ENVIRONMENT_RADIANCE;
use super::report::{MaterialReport, file_stem};
use crate::error::Result;
use crate::formats::{Precision, exr::write_exr};
use crate::model::Rgb;
use crate::report::plot::{ColourBar, Line, LineStyle, Picture, images_png, lines_png, viridis};
use crate::table::{Axis, Channel, Table};

/// `A` at view cosine `mu` from a curve sampled at `mus` (uniform in angle, normal first),
/// interpolated linearly in angle.
pub fn albedo_at(mus: &[f64], curve: &[Rgb], mu: f64) -> Rgb {
    let n = mus.len();
    let theta = mu.clamp(0.0, 1.0).acos();
    let position = (theta / std::f64::consts::FRAC_PI_2 * (n - 1) as f64).clamp(0.0, (n - 1) as f64);
    let k = (position.floor() as usize).min(n - 2);
    let t = position - k as f64;
    std::array::from_fn(|c| (1.0 - t) * curve[k][c] + t * curve[k + 1][c])
}

/// The view cosine `mu = n.v` of each pixel of a `size` x `size` picture of the unit sphere seen
/// orthographically, rows top first, at pixel centres; `None` outside the sphere.
pub fn sphere_cosines(size: usize) -> Vec<Option<f64>> {
    let mut cosines = Vec::with_capacity(size * size);
    for j in 0..size {
        for i in 0..size {
            let x = 2.0 * (i as f64 + 0.5) / size as f64 - 1.0;
            let y = 1.0 - 2.0 * (j as f64 + 0.5) / size as f64;
            let r2 = x * x + y * y;
            cosines.push((r2 <= 1.0).then(|| (1.0 - r2).sqrt()));
        }
    }
    cosines
}

/// The radiance of a pixel of the furnace: `0.42 A(mu)` on the sphere (`albedo`), the environment
/// itself outside.
pub fn furnace_radiance(albedo: Option<Rgb>) -> Rgb {
    albedo.map_or([ENVIRONMENT_RADIANCE; 3], |a| a.map(|a| ENVIRONMENT_RADIANCE * a))
}

/// The radiance of each pixel of a `size` x `size` sphere, rows top first, with `A` interpolated
/// from a curve.
fn sphere(mus: &[f64], curve: &[Rgb], size: usize) -> Vec<Rgb> {
    sphere_cosines(size).into_iter().map(|mu| furnace_radiance(mu.map(|mu| albedo_at(mus, curve, mu)))).collect()
}

/// A square picture of linear radiances, rows top first, in 8-bit sRGB.
pub fn radiance_picture(title: &str, size: usize, pixels: &[Rgb]) -> Picture {
    Picture {
        title: title.to_string(),
        width: size as u32,
        height: size as u32,
        rgb: pixels.iter().flat_map(|p| p.map(srgb8)).collect(),
    }
}

/// A square picture of differences, rows top first, in viridis on a colour bar whose end is 1, 2 or
/// 5 times a power of ten above the largest.
pub fn difference_picture(title: &str, size: usize, differences: &[f64]) -> (Picture, ColourBar) {
    let bar =
        ColourBar { label: "|difference|".into(), max: nice_ceiling(differences.iter().copied().fold(0.0, f64::max)) };
    let picture = Picture {
        title: title.to_string(),
        width: size as u32,
        height: size as u32,
        rgb: differences.iter().flat_map(|&d| viridis(d / bar.max)).collect(),
    };
    (picture, bar)
}

/// Linear radiance to 8-bit sRGB (IEC 61966-2-1 transfer function), clamped to [0, 1].
fn srgb8(linear: f64) -> u8 {
    let v = linear.clamp(0.0, 1.0);
    let encoded = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (encoded * 255.0).round() as u8
}

/// The upper end of a colour bar for differences up to `max`: 1, 2 or 5 times a power of ten.
fn nice_ceiling(max: f64) -> f64 {
    if max.is_nan() || max <= 0.0 {
        return 1e-6;
    }
    let decade = 10f64.powf(max.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * decade).find(|&v| v >= max).unwrap_or(10.0 * decade)
}

/// Write `<material>_furnace.exr` (linear radiance, three spheres side by side: the model with
/// tables, the random walk, their absolute difference per channel), `<material>_furnace.png` (the
/// same for people, the difference as the mean over channels on a colour bar) and
/// `<material>_albedo.png` (the `A(mu)` curves per channel against the view angle). Where the walk
/// did not run for the material, the second sphere is the model with exact integrals and the
/// difference is the table error. Returns the file names written, relative to `dir`.
pub fn write_material_pictures(dir: &Path, report: &MaterialReport, size: usize) -> Result<Vec<String>> {
    let stem = file_stem(&report.name);
    let (reference, reference_name) = match &report.albedo_walk {
        Some(walk) => (walk, "random walk"),
        None => (&report.albedo_exact, "model, exact integrals"),
    };
    let model = sphere(&report.mu, &report.albedo_tables, size);
    let other = sphere(&report.mu, reference, size);
    let difference: Vec<Rgb> =
        model.iter().zip(&other).map(|(a, b)| std::array::from_fn(|c| (a[c] - b[c]).abs())).collect();
    let files = [format!("{stem}_furnace.exr"), format!("{stem}_furnace.png"), format!("{stem}_albedo.png")];

    // EXR: the numbers, three panels along x.
    let mut data = Vec::with_capacity(3 * size * size * 3);
    for j in 0..size {
        for panel in [&model, &other, &difference] {
            for i in 0..size {
                data.extend(panel[i + size * j].map(|v| v as f32));
            }
        }
    }
    let axes = vec![Axis::cell_centred("x", 0.0, 3.0, 3 * size)?, Axis::cell_centred("y", 1.0, -1.0, size)?];
    let channels = ["R", "G", "B"]
        .map(|c| Channel::new(c, format!("linear radiance under a uniform environment of {ENVIRONMENT_RADIANCE}; panels: model with tables, {reference_name}, |difference|")))
        .to_vec();
    let table = Table::new(format!("{}_furnace", report.name), axes, channels, data)?;
    write_exr(&dir.join(&files[0]), &table, Precision::F32)?;

    // PNG: sRGB spheres and the difference on a colour bar.
    let mean_difference: Vec<f64> = difference.iter().map(|d| (d[0] + d[1] + d[2]) / 3.0).collect();
    let (heat, bar) =
        difference_picture(&format!("|model - {reference_name}|, mean of R, G, B"), size, &mean_difference);
    let title = format!(
        "{}: furnace of radiance {ENVIRONMENT_RADIANCE} ({}, albedo {}, TIR {})",
        report.name,
        report.model.name(),
        report.albedo_label(),
        report.tir_label()
    );
    images_png(
        &dir.join(&files[1]),
        &title,
        &[
            radiance_picture("model, scene's tables", size, &model),
            radiance_picture(reference_name, size, &other),
            heat,
        ],
        Some(&bar),
    )?;

    // The curves against the view angle.
    let degrees: Vec<f64> = report.mu.iter().map(|mu| mu.clamp(0.0, 1.0).acos().to_degrees()).collect();
    const COLOURS: [[u8; 3]; 3] = [[214, 39, 40], [44, 160, 44], [31, 119, 180]];
    let mut lines = Vec::new();
    let mut highest: f64 = 0.0;
    for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
        let curves = [
            Some((&report.albedo_tables, "model, tables", LineStyle::Solid)),
            Some((&report.albedo_exact, "model, exact", LineStyle::Dashed)),
            report.albedo_walk.as_ref().map(|walk| (walk, "random walk", LineStyle::Markers)),
        ];
        for (curve, what, style) in curves.into_iter().flatten() {
            let points: Vec<(f64, f64)> = degrees.iter().zip(curve.iter()).map(|(&d, a)| (d, a[c])).collect();
            highest = points.iter().map(|p| p.1).fold(highest, f64::max);
            lines.push(Line { name: format!("{name}: {what}"), points, colour: COLOURS[c], style });
        }
    }
    lines_png(
        &dir.join(&files[2]),
        &format!("{}: directional albedo A(mu)", report.name),
        ("view angle (degrees from the normal)", 0.0..90.0),
        ("A(mu)", 0.0..(highest * 1.05).max(0.1)),
        &lines,
    )?;
    Ok(files.to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_interpolate_in_angle_and_hit_their_samples() {
        let mus: Vec<f64> = (0..5).map(|k| (std::f64::consts::FRAC_PI_2 * k as f64 / 4.0).cos()).collect();
        let curve: Vec<Rgb> = (0..5).map(|k| [k as f64; 3]).collect();
        for (k, &mu) in mus.iter().enumerate() {
            assert!((albedo_at(&mus, &curve, mu)[0] - k as f64).abs() < 1e-9);
        }
        // Half-way in angle between the first two views.
        let mid = (std::f64::consts::FRAC_PI_2 / 8.0).cos();
        assert!((albedo_at(&mus, &curve, mid)[1] - 0.5).abs() < 1e-9);
        assert_eq!(albedo_at(&mus, &curve, 0.0)[2], 4.0);
    }

    #[test]
    fn srgb_and_colour_bar_ends() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(0.42), 173);
        assert_eq!(nice_ceiling(3.1e-3), 5e-3);
        assert_eq!(nice_ceiling(1e-3), 1e-3);
        assert_eq!(nice_ceiling(0.0), 1e-6);
    }
}
