use super::errors::{error_views, sample};
use super::*;
use crate::config::Config;
use crate::exact::ExactTables;
use crate::filter::Filter;
use crate::model::{FluxModel, Lookup, Quantity};
use crate::scene::Scene;

/// The materials of the example scenes that vary nothing, at their own values.
pub(crate) fn example_materials() -> Vec<(String, Material)> {
    let scenes = [
        ("copper-pot", include_str!("../../luts/scenes/copper-pot.toml")),
        ("scattering", include_str!("../../luts/scenes/scattering.toml")),
        ("layers", include_str!("../../luts/scenes/thesis/layers.toml")),
        ("tir", include_str!("../../luts/scenes/thesis/tir.toml")),
        // Its `no-coat` jumps: a lobe's roughness and GD where one channel's energy crosses the
        // threshold below which the lobe's asymmetry counts that channel as 0.
        ("scattering-variants", include_str!("../../luts/scenes/thesis/scattering-variants.toml")),
    ];
    let mut materials = Vec::new();
    for (name, text) in scenes {
        let scene = Scene::from_toml(text, name, name).unwrap();
        for m in &scene.materials {
            materials.push((format!("{name}/{}", m.name), Material::new(m.model, m.stack().unwrap())));
        }
    }
    materials
}

fn gold_under_a_coat() -> Material {
    example_materials().into_iter().find(|(name, _)| name.starts_with("copper-pot/")).unwrap().1
}

#[test]
fn the_layout_packs_six_values_and_six_per_lobe_four_to_a_texel() {
    let texels: Vec<usize> = (0..5).map(|lobes| BakeLayout { lobes }.texels_per_node()).collect();
    assert_eq!(texels, [2, 3, 5, 6, 8]);
    let layout = BakeLayout { lobes: 2 };
    assert_eq!(layout.values(), 18);
    assert_eq!(layout.value_name(0), "the albedo (R)");
    assert_eq!(layout.value_name(5), "the top albedo (B)");
    assert_eq!(layout.value_name(6), "lobe 1 energy (R)");
    assert_eq!(layout.value_name(9), "lobe 1 roughness");
    assert_eq!(layout.value_name(16), "lobe 2 mean-direction cosine");
    assert_eq!(layout.value_name(17), "lobe 2 GD");
}

#[test]
fn a_flattened_evaluation_holds_each_value_where_its_name_says() {
    let material = gold_under_a_coat();
    let tables = |l: &Lookup| match l.quantity {
        Quantity::Albedo => 0.25,
        Quantity::Tir => 0.0,
        Quantity::Gd => 0.75,
    };
    let evaluation = material.evaluate(0.5, &tables);
    let layout = BakeLayout { lobes: evaluation.lobes.len() };
    let values = layout.flatten(&evaluation);
    assert_eq!(values.len(), layout.values());
    assert_eq!(values[..3], evaluation.albedo);
    assert_eq!(values[3..6], evaluation.top_albedo);
    let last = evaluation.lobes.last().unwrap();
    assert_eq!(values[values.len() - 6..values.len() - 3], last.energy);
    assert_eq!(values[values.len() - 3..], [last.roughness, last.mean_direction[2], last.gd]);
}

#[test]
fn nodes_run_from_grazing_to_the_normal_with_one_on_each_kink() {
    let uniform = NodePlacement::uniform(17);
    let mu = |p: &NodePlacement, k: usize| p.node_mu(k);
    assert_eq!((mu(&uniform, 0), mu(&uniform, 16)), (0.0, 1.0));
    assert!((1..17).all(|k| mu(&uniform, k) > mu(&uniform, k - 1)));
    // Denser toward grazing: the first interval is the narrowest.
    assert!(mu(&uniform, 1) - mu(&uniform, 0) < mu(&uniform, 16) - mu(&uniform, 15));
    let kinked = NodePlacement::with_breaks(&[0.1, 0.55], 21);
    assert_eq!(kinked.nodes(), 21);
    assert_eq!(kinked.breaks(), [0.1, 0.55]);
    let intervals: Vec<usize> = kinked.segments().iter().map(|s| s.intervals).collect();
    assert_eq!(intervals, [2, 9, 9]);
    assert_eq!((kinked.node_u(2), kinked.node_u(11), kinked.node_u(20)), (0.1, 0.55, 1.0));
    // The f32 coordinate of a node's view cosine is its texel centre, on both sides of a kink.
    for k in 0..21 {
        let x = kinked.texture_coordinate(kinked.node_mu(k) as f32);
        assert!((x * 21.0 - 0.5 - k as f32).abs() < 1e-4, "node {k}: {x}");
    }
}

#[test]
fn a_read_at_a_node_is_that_node() {
    let nodes = 17;
    let material = gold_under_a_coat();
    let tables = |l: &Lookup| match l.quantity {
        Quantity::Albedo => crate::physics::fresnel_reflectance(l.mu, l.eta, l.kappa),
        Quantity::Tir => 0.1 * l.mu,
        Quantity::Gd => 1.0 - 0.2 * l.alpha,
    };
    let settings = BakeSettings { nodes, ..BakeSettings::default() };
    let baked = bake_material("gold", &material, &tables, &settings).unwrap();
    for k in 0..nodes {
        let read = sample(&baked, baked.placement.node_mu(k) as f32, &[], Filter::Exact);
        let stored: Vec<f32> = (0..baked.rows()).flat_map(|r| baked.texel(r, k)).take(read.len()).collect();
        for (a, b) in read.iter().zip(&stored) {
            assert!((a - b).abs() <= 2e-6 * b.abs().max(1.0), "node {k}: read {a}, stored {b}");
        }
    }
    // Outside [0, 1] and NaN read the end nodes.
    assert_eq!(sample(&baked, -0.5, &[], Filter::Exact), sample(&baked, 0.0, &[], Filter::Exact));
    assert_eq!(sample(&baked, f32::NAN, &[], Filter::Exact), sample(&baked, 0.0, &[], Filter::Exact));
    assert_eq!(sample(&baked, 7.0, &[], Filter::Exact), sample(&baked, 1.0, &[], Filter::Exact));
}

#[test]
fn error_views_hold_the_nodes_and_the_views_between_them() {
    let placement = NodePlacement::with_breaks(&[0.3], 5);
    let views = error_views(&placement, 4);
    assert_eq!(views.len(), 17);
    assert_eq!((views[0], views[16]), (1.0, 0.0));
    for k in 0..5 {
        assert!(views.contains(&placement.node_mu(k)), "node {k}");
    }
}

/// The nodes [`placement::place_nodes`] places for the values `f(u)`, every value weighed 1.
fn place(f: impl Fn(f64) -> Vec<f64> + Sync, nodes: usize, tolerance: f64) -> NodePlacement {
    let read = |us: &[f64]| Ok(us.iter().map(|&u| f(u)).collect());
    let weights = |v: &[f64]| vec![1.0; v.len()];
    placement::place_nodes(&mut placement::Samples::new(&read), &weights, nodes, tolerance).unwrap()
}

#[test]
fn a_kink_gets_a_node_and_a_smooth_curve_none() {
    // |u - 0.3| has a kink at 0.3 (its slope jumps by 2); u^2 has none.
    // At 33 nodes a curvature of 9 errs by 1.1e-3 ((1/32)^2 9 / 8), a kink of 2 by 1.6e-2.
    let kinked = place(|u| vec![(u - 0.3).abs(), u * u], 33, 2e-3);
    let kinks = kinked.breaks();
    assert_eq!(kinks.len(), 1, "{kinks:?}");
    assert!((kinks[0] - 0.3).abs() < 1e-9, "{kinks:?}");
    let smooth = place(|u| vec![u * u, (3.0 * u).sin()], 33, 2e-3);
    assert!(smooth.breaks().is_empty(), "{:?}", smooth.breaks());
    // A kink too small to matter at this spacing is left alone.
    let slight = place(|u| vec![1e-5 * (u - 0.3).abs()], 33, 2e-3);
    assert!(slight.breaks().is_empty(), "{:?}", slight.breaks());
    // Where the curvature is the error, segments are cut to even it out: denser where it is larger.
    let curved = place(|u| vec![(1.0 - u).powi(4)], 33, 1e-4);
    let first = curved.segments().first().unwrap();
    let last = curved.segments().last().unwrap();
    assert!(curved.breaks().len() >= 2, "{:?}", curved.breaks());
    assert!(
        (first.u_end - first.u_start) / (first.intervals as f64)
            < (last.u_end - last.u_start) / (last.intervals as f64),
        "{:?}",
        curved.segments()
    );
    assert!(curved.segments().iter().all(|s| !s.jump));
}

#[test]
fn a_jump_gets_a_segment_of_one_interval_whose_nodes_are_its_two_sides() {
    // A step of 0.05 at u = 0.4137 on a gentle slope, and a kink of 2 at 0.7: linear interpolation
    // across the step errs by up to the step at any spacing.
    let step = 0.4137;
    let f = |u: f64| vec![0.2 * u + if u > step { 0.05 } else { 0.0 }, (u - 0.7).abs()];
    let placed = place(f, 33, 1e-3);
    let jumps: Vec<&placement::Segment> = placed.segments().iter().filter(|s| s.jump).collect();
    assert_eq!(jumps.len(), 1, "{:?}", placed.segments());
    let jump = jumps[0];
    assert_eq!(jump.intervals, 1);
    assert!(jump.u_start <= step && step < jump.u_end, "{jump:?}");
    assert!(jump.u_end - jump.u_start <= placement::JUMP_WIDTH, "{jump:?}");
    // The kink is a break of its own, not a jump.
    assert!(placed.breaks().iter().any(|&u| (u - 0.7).abs() < 1e-9), "{:?}", placed.breaks());
    assert_eq!(placed.nodes(), 33);
    // Read through the filter, the two nodes of the jump are its two sides, and the views the
    // errors are measured at skip the inside of the jump.
    let views = error_views(&placed, 4);
    let inside = |mu: f64| mu.sqrt() > jump.u_start && mu.sqrt() < jump.u_end;
    assert!(!views.iter().any(|&mu| inside(mu)), "a view inside the jump");
    for (k, u) in [(jump.first_node, jump.u_start), (jump.first_node + 1, jump.u_end)] {
        let x = placed.texture_coordinate((u * u) as f32);
        assert!((x * 33.0 - 0.5 - k as f32).abs() < 0.02, "node {k}: {}", x * 33.0 - 0.5);
    }
}

#[test]
fn a_model_that_returns_nan_is_refused_naming_the_material_and_the_view() {
    let material = gold_under_a_coat();
    let tables = |l: &Lookup| if l.quantity == Quantity::Albedo && l.mu < 0.3 { f64::NAN } else { 0.5 };
    let settings = BakeSettings { nodes: 9, ..BakeSettings::default() };
    let e = bake_material("gold", &material, &tables, &settings).unwrap_err().to_string();
    assert!(e.contains("material `gold`") && e.contains("NaN") && e.contains("mu = 0"), "{e}");
    let settings = BakeSettings { nodes: 1, ..BakeSettings::default() };
    let e = bake_material("gold", &material, &|_: &Lookup| 0.5, &settings).unwrap_err().to_string();
    assert!(e.contains("bake.nodes") && e.contains("9 to 8192"), "{e}");
}

#[test]
fn a_bake_is_the_same_to_the_bit_on_one_thread_and_on_three() {
    let material = gold_under_a_coat();
    let exact = ExactTables::new(&Config::default(), 4).unwrap();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let settings = BakeSettings { nodes: 24, ..BakeSettings::default() };
        pool.install(|| bake_material("gold", &material, &exact, &settings).unwrap())
    };
    let (one, three) = (on(1), on(3));
    let bits = |b: &BakedMaterial| b.texels.iter().flatten().map(|v| v.to_bits()).collect::<Vec<u32>>();
    assert_eq!(bits(&one), bits(&three));
}

/// The claim `BakeSettings::default` makes: every example material baked from exact integrals and
/// read through a GPU's filter (8-bit weights) stays within 1e-3 of its model, albedo, lobe
/// energies and the energy-weighted lobe shape alike, at views between the nodes.
#[test]
fn the_example_materials_baked_by_default_stay_within_1e_3_of_their_model() {
    let exact = ExactTables::new(&Config::default(), crate::exact::DEFAULT_NODES).unwrap();
    let mut six_flux = 0;
    for (name, material) in example_materials() {
        six_flux += usize::from(material.model == FluxModel::SixFlux);
        let baked = bake_material(&name, &material, &exact, &BakeSettings::default()).unwrap();
        let errors =
            baked_errors(&baked, &MaterialFamily::fixed(&material), &exact, 4, Filter::QuantisedWeights { bits: 8 })
                .unwrap();
        println!("{name}: breaks at u = {:?}, {} views: {:.1e}", baked.placement.breaks(), errors.views, errors.max());
        assert!(errors.max() <= 1e-3, "{name}: {errors:#?}");
        // Something was measured: the bake is not the model at every view.
        assert!(errors.albedo.max > 0.0, "{name}: {errors:#?}");
    }
    assert!(six_flux > 0, "no 6-flux material among the examples");
}

/// The example scene's material whose texture varies its glaze's index over [1.4, 1.7].
fn glazed_ceramic() -> crate::scene::SceneMaterial {
    let scene = Scene::from_toml(include_str!("../../luts/scenes/textured.toml"), "textured", "textured").unwrap();
    scene.materials.into_iter().find(|m| m.name == "glazed-ceramic").unwrap()
}

/// A varied material baked by default: at a node of its parameter and of `mu` the read is its
/// model there; midway between its parameter's nodes, where linear interpolation across the
/// parameter errs most, and between the nodes of `mu` it stays within the 1e-3 it is held to; and
/// at the nodes of `mu`, where nothing but the parameter's interpolation errs, within the bake's
/// tolerance, as its parameter's nodes were chosen to be.
#[test]
fn a_varied_material_reads_its_model_at_its_nodes_and_stays_within_1e_3_between_them() {
    let exact = ExactTables::new(&Config::default(), crate::exact::DEFAULT_NODES).unwrap();
    let settings = BakeSettings::default();
    let material = glazed_ceramic();
    let family = material.family();
    let baked = bake_family("glazed-ceramic", &family, &exact, &settings).unwrap();
    let axis = &baked.axes[0];
    assert_eq!((baked.axes.len(), axis.parameter.as_str(), axis.range), (1, "layer 1 eta", [1.4, 1.7]));
    assert!(axis.nodes > 2 && axis.nodes <= varied::MAX_PARAMETER_NODES, "{axis:?}");
    assert_eq!(baked.rows(), baked.block_rows() * axis.nodes as usize);
    let filter = Filter::QuantisedWeights { bits: 8 };
    for j in [0, axis.nodes as usize / 2, axis.nodes as usize - 1] {
        let model = family.at(&[axis.node(j)]).unwrap();
        for k in [0, baked.nodes() / 3, baked.nodes() - 1] {
            let mu = baked.placement.node_mu(k);
            let exact_values = baked.layout.flatten(&model.evaluate(mu, &exact));
            let read = sample(&baked, mu as f32, &[axis.node(j) as f32], filter);
            for (i, (&r, &e)) in read.iter().zip(&exact_values).enumerate() {
                assert!((f64::from(r) - e).abs() <= 1e-5 * e.abs().max(1.0), "node {j}, mu {mu}: value {i} {r} vs {e}");
            }
        }
    }
    let errors = baked_errors(&baked, &family, &exact, 4, filter).unwrap();
    let views = error_views(&baked.placement, 4).len();
    assert_eq!(errors.views, views * (2 * axis.nodes as usize - 1), "every view at every node and midpoint");
    assert!(errors.max() > 0.0 && errors.max() <= settings.held_to(), "{errors:#?}");
    let midpoints: Vec<f64> = (0..axis.nodes as usize - 1).map(|j| 0.5 * (axis.node(j) + axis.node(j + 1))).collect();
    let node_views: Vec<f64> = (0..baked.nodes()).map(|k| baked.placement.node_mu(k)).collect();
    for &eta in &midpoints {
        let model = family.at(&[eta]).unwrap();
        let across = errors::reading_errors(&baked.layout, &node_views, &model, &exact, |mu| {
            sample(&baked, mu, &[eta as f32], filter)
        });
        assert!(across.max() > 0.0 && across.max() <= settings.tolerance, "eta {eta}: {across:#?}");
    }
    println!(
        "glazed-ceramic: {} nodes of eta, {} views: {:.1e} at {:?}",
        axis.nodes,
        errors.views,
        errors.max(),
        errors.worst()
    );
}

#[test]
fn more_varied_parameters_than_a_baked_material_takes_are_refused_naming_them() {
    let text = "name = \"three\"\n[[material]]\nname = \"m\"\n[[material.layer]]\ntype = \"interface\"\n\
                vary = { eta = [1.4, 1.6], alpha = [0.1, 0.2] }\n[[material.layer]]\ntype = \"interface\"\n\
                eta = 2.0\nvary = { alpha = [0.1, 0.3] }\n";
    let scene = Scene::from_toml(text, "three", "three").unwrap();
    let family = scene.materials[0].family();
    assert_eq!(family.parameters().len(), 3);
    let e = bake_family("m", &family, &|_: &Lookup| 0.5, &BakeSettings::default()).unwrap_err().to_string();
    assert!(e.contains("material `m`") && e.contains("vary 3 parameters") && e.contains("at most 2"), "{e}");
}
