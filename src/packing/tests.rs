//! Each packing against 4D multilinear interpolation at random points, through the emitted
//! lookup program (the very expressions printed as HLSL and WGSL) and the emulator.

use super::*;

/// Deterministic pseudo-random values in [0, 1).
fn hash01(n: u64) -> f64 {
    let mut z = n.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// An FGD-shaped table of `counts` nodes holding `f` at its nodes.
fn table(counts: [usize; 4], f: impl Fn([f64; 4], usize) -> f64) -> Table {
    let axes = vec![
        Axis::node_aligned("mu", 0.0, 1.0, counts[0]).unwrap(),
        Axis::node_aligned("alpha", 0.0, 1.0, counts[1]).unwrap(),
        Axis::node_aligned("eta", 0.0, 4.0, counts[2]).unwrap(),
        Axis::node_aligned("kappa", 0.0, 4.0, counts[3]).unwrap(),
    ];
    let mut t = Table::zeros("fgd", axes, vec![Channel::new("fgd", "test")]).unwrap();
    for n in 0..t.node_count() {
        let p = t.node_position(&t.node_index(n));
        t.data[n] = f([p[0], p[1], p[2], p[3]], n) as f32;
    }
    t
}

/// Rough values in [0, 1) at every node: the hardest case for a packing that blends neighbours.
fn noise(counts: [usize; 4]) -> Table {
    table(counts, |_, n| hash01(n as u64))
}

fn points(t: &Table, count: usize, seed: u64) -> Vec<[f32; 4]> {
    (0..count)
        .map(|k| {
            let mut p = [0.0f32; 4];
            for (d, axis) in t.axes.iter().enumerate() {
                // Slightly past both ends too: lookups outside the range must clamp as the table does.
                let u = -0.05 + 1.1 * hash01(seed ^ (4 * k + d) as u64);
                p[d] = (axis.start + u * (axis.end - axis.start)) as f32;
            }
            p
        })
        .collect()
}

fn max_error_vs_interpolation(packed: &PackedFgd, t: &Table, pts: &[[f32; 4]]) -> f64 {
    pts.iter()
        .map(|&p| {
            let truth = t.interpolate(&p.map(|v| v as f64))[0];
            (packed.lookup(p, Filter::Exact) as f64 - truth).abs()
        })
        .fold(0.0, f64::max)
}

const LOSSLESS_PACKINGS: [Packing; 2] = [Packing::Lossless, Packing::LosslessFiltered];

/// `packing` of rough node values in [0, 1) (neighbours differ by up to 1: the hardest case), over
/// 64 x 64 tiles with power-of-two counts as in the default table and over an odd shape whose
/// counts and extents are not powers of two, is lossless and within `tolerance` of the table's
/// interpolation at random points.
fn assert_rough_tables_within(packing: Packing, tolerance: f64) {
    for counts in [[64, 64, 8, 8], [8, 7, 6, 5]] {
        let t = noise(counts);
        let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
        assert!(packed.lossless);
        let max = max_error_vs_interpolation(&packed, &t, &points(&t, 4000, 7));
        assert!(max < tolerance, "{packing:?} {counts:?}: max {max:e}");
    }
}

#[test]
fn lossless_matches_4d_interpolation_to_1e6_at_random_points_even_for_rough_tables() {
    // The odd shape takes the plain index formula.
    // Weights exact to 2^-25 (2^-22 for the odd counts), 15 f32 lerps of values below 1.
    assert_rough_tables_within(Packing::Lossless, 1e-6);
}

#[test]
fn lossless_weights_carry_no_rounding_of_the_node_index() {
    // A step of 1 between mu nodes 58 and 59 (of 64), like FGD's at the critical angle: at
    // `i_mu = mu * 63` in [58, 59), f32 rounds the product by up to 2^-19 node, which a lookup
    // using `fl(mu * 63) - k` as its weight turns into errors up to 1.9e-6. `lossless` must stay at
    // f32 rounding of the lerps; the plain weight on the same points shows the test can fail.
    let counts = [64, 4, 4, 4];
    let t = table(counts, |p, _| if p[0] > 58.5 / 63.0 { 1.0 } else { 0.0 });
    let packed = PackedFgd::pack(&t, Packing::Lossless, Precision::F32).unwrap();
    let (mut max, mut max_plain) = (0.0f64, 0.0f64);
    let mut mu = 58.0f32 / 63.0;
    while mu < 59.0 / 63.0 {
        let p = [mu, 0.3, 1.7, 2.9];
        let truth = t.interpolate(&p.map(|v| v as f64))[0];
        max = max.max((packed.lookup(p, Filter::Exact) as f64 - truth).abs());
        let plain_weight = mu * 63.0 - 58.0;
        max_plain = max_plain.max((plain_weight as f64 - truth).abs());
        mu = f32::from_bits(mu.to_bits() + 97);
    }
    assert!(max < 1e-7, "lossless: max {max:e}");
    assert!(max_plain > 1e-6, "plain weight: max {max_plain:e}");
    // Around every node, where the rounded product may fall on the wrong side of the node and the
    // bracket must be corrected: rough node values along mu, 41 consecutive f32 values per node.
    let t = table(counts, |_, n| hash01(n as u64));
    let packed = PackedFgd::pack(&t, Packing::Lossless, Precision::F32).unwrap();
    let mut max = 0.0f64;
    for k in 0..counts[0] {
        let node = (k as f64 / 63.0) as f32;
        for step in -20i32..=20 {
            let mu = f32::from_bits((node.to_bits() as i32 + step).max(0) as u32);
            let p = [mu, 0.3, 1.7, 2.9];
            let truth = t.interpolate(&p.map(|v| v as f64))[0];
            max = max.max((packed.lookup(p, Filter::Exact) as f64 - truth).abs());
        }
    }
    // Four levels of f32 lerps of values below 1, each rounding by at most ~3 * 2^-25: 3.6e-7;
    // a bracket off by one node would cost up to a node step (1), the plain weight 1.9e-6.
    assert!(max < 3.6e-7, "around nodes: max {max:e}");
}

#[test]
fn lossless_filtered_meets_1e6_only_for_smooth_tables() {
    // f32 coordinate arithmetic places a texel-space position of magnitude up to the width
    // (256 here) to within width * 2^-24 = 1.5e-5 texel; node values jumping by up to 1 between
    // neighbours turn that into errors of 1e-5.
    assert_rough_tables_within(Packing::LosslessFiltered, 1.6e-5);
    // Smooth (neighbouring nodes differ by a few hundredths): the rounding is then below 1e-6.
    let f = |p: [f64; 4]| {
        0.04 + 0.9 * (1.0 - p[0]).powi(5) * (1.0 - 0.5 * p[1]) + 0.1 * (p[2] * 0.7).sin() * (0.2 * p[3]).cos()
    };
    for counts in [[64, 64, 8, 8], [8, 7, 6, 5]] {
        let t = table(counts, |p, _| f(p));
        for packing in LOSSLESS_PACKINGS {
            let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
            let max = max_error_vs_interpolation(&packed, &t, &points(&t, 4000, 9));
            assert!(max < 1e-6, "{packing:?} {counts:?}: max {max:e}");
        }
    }
}

#[test]
fn lossless_reproduces_every_node() {
    for counts in [[8, 7, 6, 5], [16, 8, 4, 4]] {
        let t = noise(counts);
        for packing in LOSSLESS_PACKINGS {
            let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
            for n in 0..t.node_count() {
                let p = t.node_position(&t.node_index(n)).iter().map(|&v| v as f32).collect::<Vec<_>>();
                let v = packed.lookup([p[0], p[1], p[2], p[3]], Filter::Exact);
                // Node values as f32 inputs land within a few 1e-7 of an index, next to neighbours up to 1 away.
                assert!((v - t.data[n]).abs() < 1e-6, "{packing:?} node {n}: {v} vs {}", t.data[n]);
            }
        }
    }
}

#[test]
fn lossless_lookups_never_read_another_tile() {
    // Overwrite every texel outside the two kappa tiles a lookup needs with garbage: the result
    // must not change by a single bit.
    let counts = [16, 16, 4, 9];
    let t = noise(counts);
    let (columns, _) = tile_grid(counts[3]);
    let kappa = &t.axes[3];
    for packing in LOSSLESS_PACKINGS {
        let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
        for p in points(&t, 300, 11) {
            let k0 = kappa.bracket(p[3] as f64).0;
            let mut dirty = packed.clone();
            let tex = &mut dirty.texture;
            for z in 0..tex.depth {
                for y in 0..tex.height {
                    for x in 0..tex.width {
                        let k = (y / counts[1]) * columns + x / counts[0];
                        if k != k0 && k != k0 + 1 {
                            tex.texels[x + tex.width * (y + tex.height * z)] = 1.0e6;
                        }
                    }
                }
            }
            for filter in [Filter::Exact, Filter::QuantisedWeights { bits: 8 }] {
                assert_eq!(
                    packed.lookup(p, filter).to_bits(),
                    dirty.lookup(p, filter).to_bits(),
                    "{packing:?} at {p:?}"
                );
            }
        }
    }
}

#[test]
fn lossless_does_not_depend_on_the_hardware_filter() {
    // Texel loads only: 8-bit filter weights, as real GPUs use, change nothing.
    let counts = [16, 8, 6, 5];
    let t = noise(counts);
    let packed = PackedFgd::pack(&t, Packing::Lossless, Precision::F32).unwrap();
    assert_eq!(packed.fetches_per_lookup(), 16);
    assert!(!packed.program.uses_sampler());
    for p in points(&t, 500, 13) {
        let exact = packed.lookup(p, Filter::Exact);
        assert_eq!(exact.to_bits(), packed.lookup(p, Filter::QuantisedWeights { bits: 8 }).to_bits());
    }
    // The filtered lookup does depend on it (by up to 2^-9 of a node step).
    let filtered = PackedFgd::pack(&t, Packing::LosslessFiltered, Precision::F32).unwrap();
    let largest_change = points(&t, 500, 13)
        .into_iter()
        .map(|p| (filtered.lookup(p, Filter::Exact) - filtered.lookup(p, Filter::QuantisedWeights { bits: 8 })).abs())
        .fold(0.0f32, f32::max);
    assert!(largest_change > 1e-4, "{largest_change:e}");
}

#[test]
fn lossless_in_f16_is_within_half_float_rounding() {
    let counts = [8, 8, 6, 4];
    let t = noise(counts);
    for packing in LOSSLESS_PACKINGS {
        let packed = PackedFgd::pack(&t, packing, Precision::F16).unwrap();
        let max = max_error_vs_interpolation(&packed, &t, &points(&t, 3000, 3));
        // Half-float steps are 2^-11 relative; values are below 1, so rounding is at most 2^-12.
        assert!(max <= 2f64.powi(-12) + 4e-6, "{packing:?}: max {max:e}");
    }
}

#[test]
fn thesis_texture_holds_kappa_pair_means() {
    let counts = [4, 3, 5, 6];
    let t = noise(counts);
    let packed = PackedFgd::pack(&t, Packing::Thesis, Precision::F32).unwrap();
    assert_eq!([packed.texture.width, packed.texture.height, packed.texture.depth], [4, 3, 15]);
    for (e, h, j, i) in [(0, 0, 0, 0), (4, 2, 2, 3), (2, 1, 1, 2)] {
        let mean = 0.5 * (t.node(&[i, j, e, 2 * h])[0] + t.node(&[i, j, e, 2 * h + 1])[0]);
        assert!((packed.texture.texel(i, j, e * 3 + h) - mean).abs() < 1e-7);
    }
}

#[test]
fn thesis_lookup_is_exact_for_a_multilinear_function_inside_its_kappa_range() {
    // Averaging pairs of a function linear in kappa gives its value at the pair's midpoint, so a
    // correct coordinate formula reproduces it exactly between the first and last midpoints. An
    // off-by-half-a-slice formula (as the thesis shader's) fails this by a large margin.
    let f = |p: [f64; 4]| 0.1 + 0.2 * p[0] + 0.1 * p[1] * p[2] + 0.05 * p[2] * p[3] + 0.03 * p[3];
    let counts = [8, 8, 6, 10];
    let t = table(counts, |p, _| f(p));
    let packed = PackedFgd::pack(&t, Packing::Thesis, Precision::F32).unwrap();
    let step = 4.0 / (counts[3] - 1) as f64;
    let mut max = 0.0f64;
    for p in points(&t, 3000, 5) {
        let kappa = p[3] as f64;
        if !(0.5 * step..=(counts[3] as f64 - 1.5) * step).contains(&kappa) {
            continue;
        }
        let q = p.map(|v| (v as f64).clamp(0.0, 4.0)).map(|v| v as f32);
        let truth = t.interpolate(&q.map(|v| v as f64))[0];
        max = max.max((packed.lookup(q, Filter::Exact) as f64 - truth).abs());
    }
    assert!(max < 2e-6, "max {max:e}");
}

#[test]
fn packings_refuse_tables_they_cannot_hold_with_reasons() {
    let e = Packing::Thesis.extent([64, 64, 64, 63]).unwrap_err().to_string();
    assert!(e.contains("thesis") && e.contains("even"), "{e}");
    let e = Packing::Lossless.extent([64, 64, 4096, 4]).unwrap_err().to_string();
    assert!(e.contains("2048"), "{e}");
    assert_eq!(Packing::Lossless.extent([64; 4]).unwrap(), [512, 512, 64]);
    assert_eq!(Packing::LosslessFiltered.extent([64; 4]).unwrap(), [512, 512, 64]);
    assert_eq!(Packing::Thesis.extent([64; 4]).unwrap(), [64, 64, 2048]);
    let t = table([4, 4, 4, 4], |_, _| 0.0);
    let mut wrong = t.clone();
    wrong.axes.swap(0, 1);
    let e = PackedFgd::pack(&wrong, Packing::Lossless, Precision::F32).unwrap_err().to_string();
    assert!(e.contains("(mu, alpha, eta, kappa)"), "{e}");
    let e = Packing::parse("thesys").unwrap_err().to_string();
    assert!(e.contains("thesys") && e.contains("lossless"), "{e}");
}

#[test]
fn shader_text_is_the_evaluated_program() {
    let t = noise([64, 64, 4, 64]);
    for packing in Packing::ALL {
        let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
        let hlsl = packed.hlsl();
        let wgsl = packed.wgsl();
        crate::shader::validate::wgsl(&wgsl).unwrap_or_else(|e| panic!("{}: {e}", packing.name()));
        // Every value the manifest states appears, with its constants, in both languages.
        let statements = packed.program.statements();
        for line in &statements {
            let (name, expression) = line.split_once(" = ").unwrap();
            if name == "result" || expression.starts_with("load(") || expression.starts_with("sample(") {
                continue;
            }
            assert!(hlsl.contains(&format!("precise float {name} = {expression};")), "HLSL lacks {line}");
            assert!(wgsl.contains(&format!("let {name}: f32 = {expression};")), "WGSL lacks {line}");
        }
        let reads = statements.iter().filter(|l| l.contains(" = load(tex, ") || l.contains(" = sample(tex, ")).count();
        assert_eq!(reads, packed.fetches_per_lookup(), "{}", packing.name());
    }
    let lossless = PackedFgd::pack(&t, Packing::Lossless, Precision::F32).unwrap();
    let (hlsl, wgsl) = (lossless.hlsl(), lossless.wgsl());
    assert!(
        hlsl.contains("float fgd_lossless(Texture3D<float> tex, float mu, float alpha, float eta, float kappa)"),
        "{hlsl}"
    );
    assert!(hlsl.contains("precise float r_mu = (((u_mu * 64.0) - guess_mu) - u_mu);"), "{hlsl}");
    assert!(hlsl.contains("precise float x01 = (x00 + 1.0);"), "{hlsl}");
    assert!(hlsl.contains("float v1011 = tex.Load(int4(int(x11), int(y10), int(z1), 0));"), "{hlsl}");
    assert!(wgsl.contains("let v1011: f32 = textureLoad(tex, vec3<i32>(i32(x11), i32(y10), i32(z1)), 0).r;"), "{wgsl}");
    assert!(hlsl.contains("return (mae0 + (t_kappa * (mae1 - mae0)));"), "{hlsl}");
    assert_eq!(hlsl.matches("tex.Load(").count(), 16);
    let filtered = PackedFgd::pack(&t, Packing::LosslessFiltered, Precision::F32).unwrap();
    let (hlsl, wgsl) = (filtered.hlsl(), filtered.wgsl());
    assert!(hlsl.contains("x0 = ((((column0 * 64.0) + i_mu) + 0.5) * 0.001953125)"), "{hlsl}");
    assert!(hlsl.contains("tex.SampleLevel(linear_clamp, float3(x0, y0, z), 0)"), "{hlsl}");
    assert!(wgsl.contains("textureSampleLevel(tex, linear_clamp, vec3<f32>(x1, y1, z), 0.0).r"), "{wgsl}");
    assert!(hlsl.contains("return (v0 + (t_kappa * (v1 - v0)));"), "{hlsl}");
}

#[test]
fn node_bracket_is_the_tables_bracket_with_exact_weights() {
    // The lower node and weight the lossless lookup computes, against `Axis::bracket` in f64 at
    // the same f32 input, at and around every node and at rough points in between. For N = 32 the
    // rounded product `fl(u * 31)` lands on the node above the true bracket at the f32 node
    // positions themselves; the correction must move it back.
    for n in [5, 32, 64, 128] {
        let axis = Axis::node_aligned("mu", 0.0, 1.0, n).unwrap();
        let mut program = ProgramBuilder::new("bracket", vec!["mu"]);
        let (k, t) = node_bracket(&mut program, &axis);
        let (k, t) = (program.finish(k).unwrap(), program.finish(t).unwrap());
        let mut inputs: Vec<f32> = (0..n)
            .flat_map(|node| {
                let at = (node as f64 / (n - 1) as f64) as f32;
                (-3i32..=3).map(move |step| f32::from_bits((at.to_bits() as i32 + step).max(0) as u32).min(1.0))
            })
            .collect();
        inputs.extend((0..2000).map(|j| hash01(j) as f32));
        let texture = Texture3D { width: 1, height: 1, depth: 1, texels: vec![0.0] };
        let (mut crossings, mut worst_weight) = (0, 0.0f64);
        for &mu in &inputs {
            let (lower, _, weight) = axis.bracket(mu as f64);
            assert_eq!(k.evaluate(&[mu], &texture, Filter::Exact), lower as f32, "N {n}, mu {mu:e}");
            let shader_weight = t.evaluate(&[mu], &texture, Filter::Exact) as f64;
            worst_weight = worst_weight.max((shader_weight - weight).abs());
            let rounded_floor = ((mu * (n - 1) as f32).floor() as usize).min(n - 2);
            crossings += usize::from(rounded_floor != lower);
        }
        // Power-of-two counts: only the last subtraction rounds (2^-25 for weights below 1);
        // otherwise the product's rounding, half an ulp of a node index below 8.
        let bound = if n.is_power_of_two() { 2f64.powi(-25) } else { 2f64.powi(-22) };
        assert!(worst_weight <= bound, "N {n}: weight off by {worst_weight:e}");
        if n == 32 {
            assert!(crossings > 0, "the test must reach the corrected case");
        }
    }
}

#[test]
fn a_texture_read_back_gets_the_packing_it_was_written_with() {
    for packing in Packing::ALL {
        let t = noise([8, 6, 5, 4]);
        let packed = PackedFgd::pack(&t, packing, Precision::F16).unwrap();
        let again = PackedFgd::with_texture(packed.texture.clone(), packing, Precision::F16, &t.axes).unwrap();
        assert_eq!(again.program.statements(), packed.program.statements(), "{packing:?}");
        for p in points(&t, 200, 3) {
            assert_eq!(again.lookup(p, Filter::Exact).to_bits(), packed.lookup(p, Filter::Exact).to_bits());
        }
        // A texture of another extent is refused, naming both.
        let mut wrong = packed.texture.clone();
        wrong.depth += 1;
        wrong.texels.resize(wrong.width * wrong.height * wrong.depth, 0.0);
        let e = PackedFgd::with_texture(wrong, packing, Precision::F16, &t.axes).unwrap_err().to_string();
        assert!(e.contains("the texture is") && e.contains("the packing of"), "{e}");
    }
}

#[test]
fn the_irs_interpreter_and_its_tape_give_every_lookup_the_same_bits() {
    // The default table's spacings: the asinh axes take the selection and the logarithm.
    let spaced = |name: &str, end: f64, count: usize, mapping: Mapping| {
        Axis::node_aligned(name, 0.0, end, count).unwrap().with_mapping(mapping).unwrap()
    };
    let axes = vec![
        spaced("mu", 1.0, 16, Mapping::SqrtEnds),
        spaced("alpha", 1.0, 8, Mapping::Sqrt),
        spaced("eta", 4.0, 6, Mapping::AsinhRampBelow { scale: 0.25, centre: 1.0, slope_below: 2.0 }),
        spaced("kappa", 4.0, 8, Mapping::Asinh { scale: 0.1, centre: 0.0 }),
    ];
    let mut t = Table::zeros("fgd", axes, vec![Channel::new("fgd", "test")]).unwrap();
    for (n, v) in t.data.iter_mut().enumerate() {
        *v = hash01(n as u64) as f32;
    }
    let mut at = points(&t, 400, 17);
    at.extend([[f32::NAN, 0.3, 1.2, 0.4], [0.5, f32::NAN, 0.7, 2.0], [0.5, 0.2, f32::NAN, f32::INFINITY]]);
    for packing in Packing::ALL {
        let packed = PackedFgd::pack(&t, packing, Precision::F32).unwrap();
        for &p in &at {
            for filter in [Filter::Exact, Filter::QuantisedWeights { bits: 8 }] {
                let interpreted = packed.program.interpret(&p, &packed.texture, filter).unwrap();
                let on_tape = packed.lookup(p, filter);
                assert_eq!(
                    interpreted.to_bits(),
                    on_tape.to_bits(),
                    "{packing:?} at {p:?}: {interpreted} vs {on_tape}"
                );
            }
        }
    }
}
