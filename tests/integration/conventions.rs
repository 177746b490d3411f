//! The conventions a renderer author reads in the manifest, checked by reading the files the way
//! that author would, with nothing of tmlut but its command line: the DDS bytes decoded here, the
//! texture coordinates computed here from the manifest's axes, bilinear filtering written here as
//! Direct3D and Vulkan specify it, and the integrals estimated here by plain Monte Carlo over GGX
//! normals (Karis 2013's own estimator), independent of tmlut's visible-normal sampler.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn tmlut(args: &[&str]) {
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut")).args(args).output().expect("the tmlut binary runs");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

/// Build `only` with `config` into a fresh folder; returns it and its manifest.
fn build(config: &str, only: &str) -> (tempfile::TempDir, Value) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("config.toml");
    std::fs::write(&path, config).unwrap();
    let out = dir.path().join("luts");
    tmlut(&["build", "--quiet", "--config", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--only", only]);
    let manifest = serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    (dir, manifest)
}

/// A DDS file's 2D texture: width, height, channels and the texels as f32, decoded from the
/// header fields (DDS_HEADER height at byte 12, width at 16; the DX10 header's DXGI format at 128)
/// and the data after the 148 header bytes.
fn read_dds(path: &Path) -> (usize, usize, usize, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..4], b"DDS ");
    let field = |offset: usize| u32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap()) as usize;
    let (height, width, format) = (field(12), field(16), field(128));
    let (channels, f16) = match format {
        34 => (2, true),  // DXGI_FORMAT_R16G16_FLOAT
        41 => (1, false), // DXGI_FORMAT_R32_FLOAT
        other => panic!("format {other}"),
    };
    let data = &bytes[148..];
    let texels = if f16 {
        data.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()).collect()
    } else {
        data.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
    };
    (width, height, channels, texels)
}

/// Linear filtering with clamp addressing at normalised coordinates `(u, v)`, as Direct3D and
/// Vulkan specify it: texel centres at `(i + 0.5) / N`, row 0 at `v` of its centre.
fn sample(texture: &(usize, usize, usize, Vec<f32>), u: f64, v: f64, channel: usize) -> f64 {
    let (width, height, channels, texels) = texture;
    let axis = |t: f64, n: usize| {
        let x = (t * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let i = (x.floor() as usize).min(n - 2);
        (i, x - i as f64)
    };
    let ((i, a), (j, b)) = (axis(u, *width), axis(v, *height));
    let at = |x: usize, y: usize| texels[(y * width + x) * channels + channel] as f64;
    (1.0 - b) * ((1.0 - a) * at(i, j) + a * at(i + 1, j)) + b * ((1.0 - a) * at(i, j + 1) + a * at(i + 1, j + 1))
}

/// xorshift64*: pseudo-random numbers unrelated to tmlut's Sobol points.
struct Random(u64);

impl Random {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A GGX normal drawn from `D(h) h.z` (Walter et al. 2007, eq. 35-36) and the mirror direction of
/// the view `(sqrt(1 - mu^2), 0, mu)` about it: `(v.h, n.h, n.l)`.
fn ggx_sample(mu: f64, alpha: f64, random: &mut Random) -> (f64, f64, f64) {
    let (u1, u2) = (random.uniform(), random.uniform());
    let cos_h = ((1.0 - u1) / (1.0 + (alpha * alpha - 1.0) * u1)).sqrt();
    let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let h = [sin_h * phi.cos(), sin_h * phi.sin(), cos_h];
    let v = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let v_h = v[0] * h[0] + v[2] * h[2];
    (v_h, cos_h, 2.0 * v_h * h[2] - v[2])
}

/// Karis 2013, p. 7: `scale` and `bias` of the split sum with Schlick–Smith `k = alpha / 2`.
fn karis_exact(mu: f64, alpha: f64, samples: u32) -> [f64; 2] {
    let mut random = Random(0x853C_49E6_748F_EA9B ^ (mu.to_bits() >> 3) ^ alpha.to_bits());
    let k = alpha / 2.0;
    let g1 = |z: f64| z / (z * (1.0 - k) + k);
    let (mut scale, mut bias) = (0.0, 0.0);
    for _ in 0..samples {
        let (v_h, n_h, n_l) = ggx_sample(mu, alpha, &mut random);
        if n_l <= 0.0 || v_h <= 0.0 {
            continue;
        }
        let weight = g1(mu) * g1(n_l) * v_h / (n_h * mu);
        let fc = (1.0 - v_h).powi(5);
        scale += (1.0 - fc) * weight;
        bias += fc * weight;
    }
    [scale / samples as f64, bias / samples as f64]
}

#[test]
fn karis_samples_at_nov_and_roughness_as_unreal_and_filament_read_it() {
    let (dir, manifest) = build(
        "[karis]\nmu_count = 64\nroughness_count = 64\n[karis.sampling]\nsamples = 4096\nreplicates = 4\n\
         [karis.reference]\ncells = 0\nnodes = 8\n[karis.interpolation]\npoints = 0\nnodes = 6\n",
        "karis",
    );
    let entry = &manifest["files"]["karis.dds"];
    // What the manifest says: u = n.v, v = sqrt(alpha) = roughness, and the call that samples it.
    assert_eq!(entry["axes"][0]["texture_coordinate"], "mu");
    assert_eq!(entry["axes"][1]["texture_coordinate"], "sqrt(alpha)");
    assert_eq!(entry["binding"]["hlsl"], "tex.SampleLevel(linear_clamp, float2(u, v), 0)");
    let notes = entry["notes"].to_string();
    assert!(notes.contains("float2(NoV, roughness)"), "{notes}");
    let texture = read_dds(&dir.path().join("luts/karis.dds"));
    assert_eq!((texture.0, texture.1, texture.2), (64, 64, 2));
    let (mut right, mut flipped) = (0.0f64, 0.0f64);
    for (no_v, roughness) in [(0.9, 0.1), (0.5, 0.3), (0.2, 0.5), (0.7, 0.75), (0.35, 0.9), (0.95, 0.6)] {
        let exact = karis_exact(no_v, roughness * roughness, 1 << 18);
        for (channel, exact) in exact.into_iter().enumerate() {
            // float2(NoV, roughness), as Unreal Engine 4 and Filament sample their table.
            right = right.max((sample(&texture, no_v, roughness, channel) - exact).abs());
            flipped = flipped.max((sample(&texture, no_v, 1.0 - roughness, channel) - exact).abs());
        }
    }
    // f16 storage, 64 texels and the estimate's own noise stay below 3e-3; read upside down the
    // table is rough where the surface is smooth.
    assert!(right < 3e-3, "sampled at (NoV, roughness): {right}");
    assert!(flipped > 0.1, "sampled at (NoV, 1 - roughness): {flipped}");
}

/// `m(x)` of a mapping as the manifest names it, written here from the documented formulas.
fn mapped(mapping: &Value, x: f64) -> f64 {
    match mapping.as_str() {
        Some("identity") => x,
        Some("sqrt") => x.max(0.0).sqrt(),
        Some("sqrt-ends") => (x.sqrt() - (1.0 - x).sqrt() + 1.0) / 2.0,
        other => panic!("mapping {other:?}"),
    }
}

/// The texture coordinate of `x` on a manifest axis: `u = (m(x) - m(start)) / (m(end) - m(start))`,
/// and `(u (N - 1) + 0.5) / N` for a node-aligned axis.
fn texture_coordinate(axis: &Value, x: f64) -> f64 {
    let m = |v: f64| mapped(&axis["mapping"], v);
    let (start, end, n) =
        (axis["start"].as_f64().unwrap(), axis["end"].as_f64().unwrap(), axis["count"].as_f64().unwrap());
    let u = (m(x) - m(start)) / (m(end) - m(start));
    if axis["placement"] == "node-aligned" { (u * (n - 1.0) + 0.5) / n } else { u }
}

/// A GGX normal drawn from the visible normals of the view `(sqrt(1 - mu^2), 0, mu)` (Heitz 2018,
/// "Sampling the GGX distribution of visible normals", listing 1, isotropic), and the mirror
/// direction's cosine `n.l`.
fn visible_normal_sample(mu: f64, alpha: f64, random: &mut Random) -> f64 {
    let view = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let stretched = [alpha * view[0], alpha * view[1], view[2]];
    let length = (stretched[0].powi(2) + stretched[1].powi(2) + stretched[2].powi(2)).sqrt();
    let vh = stretched.map(|x| x / length);
    let lensq = vh[0] * vh[0] + vh[1] * vh[1];
    let t1 = if lensq > 0.0 { [-vh[1] / lensq.sqrt(), vh[0] / lensq.sqrt(), 0.0] } else { [1.0, 0.0, 0.0] };
    let t2 = [vh[1] * t1[2] - vh[2] * t1[1], vh[2] * t1[0] - vh[0] * t1[2], vh[0] * t1[1] - vh[1] * t1[0]];
    let (r, phi) = (random.uniform().sqrt(), 2.0 * std::f64::consts::PI * random.uniform());
    let (p1, p2) = (r * phi.cos(), r * phi.sin());
    let s = 0.5 * (1.0 + vh[2]);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).sqrt() + s * p2;
    let p3 = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh: Vec<f64> = (0..3).map(|k| p1 * t1[k] + p2 * t2[k] + p3 * vh[k]).collect();
    let ne = [alpha * nh[0], alpha * nh[1], nh[2].max(0.0)];
    let length = (ne[0].powi(2) + ne[1].powi(2) + ne[2].powi(2)).sqrt();
    let h = ne.map(|x| x / length);
    let v_h = view[0] * h[0] + view[2] * h[2];
    2.0 * v_h * h[2] - view[2]
}

/// GD (separable Smith): `∫ D G1(v) G1(l) / (4 mu) dl = E[G1(l)]` over the visible normals;
/// `G1(w) = 2 / (1 + sqrt(1 + alpha^2 tan^2))`, 0 below the horizon.
fn gd_exact(mu: f64, alpha: f64, samples: u32, random: &mut Random) -> f64 {
    let mu = mu.max(1e-6);
    let g1 = |z: f64| 2.0 / (1.0 + (1.0 + alpha * alpha * (1.0 - z * z) / (z * z)).sqrt());
    let mut sum = 0.0;
    for _ in 0..samples {
        let n_l = visible_normal_sample(mu, alpha, random);
        if n_l > 0.0 {
            sum += g1(n_l);
        }
    }
    sum / samples as f64
}

#[test]
fn the_interpolation_error_in_the_manifest_is_what_an_independent_estimate_finds() {
    // A coarse GD table, so that interpolation errs far more than either estimate's noise.
    let (dir, manifest) = build(
        "[gd]\nmu_count = 9\nalpha_count = 9\n[gd.sampling]\nsamples = 16384\nreplicates = 4\n\
         [gd.reference]\ncells = 0\nnodes = 8\n[gd.interpolation]\npoints = 1024\nnodes = 6\n",
        "gd",
    );
    let entry = &manifest["files"]["gd.dds"];
    let stated =
        entry["error"]["interpolation"].as_array().unwrap().iter().find(|d| d["domain"] == "whole domain").unwrap();
    let (stated_rms, stated_max) = (stated["rms"].as_f64().unwrap(), stated["max"].as_f64().unwrap());
    let texture = read_dds(&dir.path().join("luts/gd.dds"));
    let axes = &entry["axes"];
    let mut random = Random(0x9E37_79B9_7F4A_7C15);
    let (mut sum2, mut max, mut noise, points) = (0.0, 0.0f64, 0.0f64, 1500);
    for _ in 0..points {
        let (mu, alpha) = (random.uniform(), random.uniform());
        let read = sample(&texture, texture_coordinate(&axes[0], mu), texture_coordinate(&axes[1], alpha), 0);
        // Two independent halves: their mean is the exact value, their difference measures its
        // noise, which is taken out of the squared error (unbiased for the interpolation's).
        let (a, b) = (gd_exact(mu, alpha, 1 << 14, &mut random), gd_exact(mu, alpha, 1 << 14, &mut random));
        let difference = read - 0.5 * (a + b);
        sum2 += difference * difference - 0.25 * (a - b) * (a - b);
        max = max.max(difference.abs());
        noise = noise.max((a - b).abs());
    }
    let rms = (sum2 / points as f64).sqrt();
    assert!(stated_rms > 3e-3, "a coarse table errs: {stated_rms}");
    assert!((rms / stated_rms - 1.0).abs() < 0.25, "independent RMS {rms:.3e}, manifest {stated_rms:.3e}");
    // The manifest's max is over its random points and the points where the error peaks; no
    // independent point may exceed it by more than the independent estimate's own noise (the
    // largest difference of two halves bounds the error of their mean). Its largest error over
    // random points is a heavy-tailed statistic (1,500 points here found 1.9 times the manifest's
    // maximum over its 1,024), so it is held from below by three quarters of that maximum.
    let random_max = stated["random_max"].as_f64().unwrap();
    assert!(
        max <= stated_max + noise && max >= 0.75 * random_max,
        "independent max {max:.3e}; manifest {stated_max:.3e} (random points {random_max:.3e}), noise {noise:.3e}"
    );
}
