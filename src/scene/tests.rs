use super::plan::{Plan, PlannedBuild, plan};
use super::*;
use crate::config::{Config, TableKind};
use crate::error::Result;
use crate::recipes::slices::{SliceOf, Slices};

fn parse(text: &str) -> Result<Scene> {
    Scene::from_toml(text, "test.toml", "test")
}

fn example(name: &str) -> Scene {
    let text = match name {
        "copper-pot" => include_str!("../../luts/scenes/copper-pot.toml"),
        "profiling" => include_str!("../../luts/scenes/profiling.toml"),
        "scattering" => include_str!("../../luts/scenes/scattering.toml"),
        "textured" => include_str!("../../luts/scenes/textured.toml"),
        other => panic!("no example scene {other}"),
    };
    Scene::from_toml(text, name, name).unwrap()
}

fn error(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

const ONE_LAYER: &str =
    "[[material]]\nname = \"m\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";

#[test]
fn a_minimal_scene_takes_the_defaults() {
    let scene = parse(ONE_LAYER).unwrap();
    assert_eq!(scene.name, "test");
    assert_eq!(scene.margin_nodes, DEFAULT_MARGIN_NODES);
    let material = &scene.materials[0];
    assert_eq!((material.model, material.albedo, material.tir), (FluxModel::TwoFlux, AlbedoPath::Fgd, TirPath::Table));
    let SceneLayer::Interface(interface) = &material.layers[0] else { panic!("an interface") };
    assert_eq!(interface.eta, [Interval::point(1.5); 3]);
    assert_eq!(interface.kappa, [Interval::point(0.0); 3]);
    assert!(!interface.is_conductor());
}

#[test]
fn bad_input_names_the_material_the_layer_and_what_is_allowed() {
    let e = error(&ONE_LAYER.replace("alpha = 0.1", "alpha = 0.1\nroughness = 0.2"));
    assert!(
        e.contains(
            "material 1 (`m`), layer 1: unknown field `roughness`, expected one of `eta`, `kappa`, `alpha`, `vary`"
        ),
        "{e}"
    );
    let e = error(&ONE_LAYER.replace("eta = 1.5", "eta = -1.5"));
    assert!(e.contains("layer 1: eta") && e.contains("-1.5") && e.contains("allowed: 0.01 to 100"), "{e}");
    let e = error(&ONE_LAYER.replace("eta = 1.5", "eta = [1.5, nan, 1.5]"));
    assert!(e.contains("layer 1: eta") && e.contains("NaN") && e.contains("0.01 to 100"), "{e}");
    let e = error(&ONE_LAYER.replace("eta = 1.5", "eta = [1.5, 1.5]"));
    assert!(e.contains("2 values") && e.contains("[r, g, b]"), "{e}");
    let e = error(&ONE_LAYER.replace("alpha = 0.1", "alpha = 1.5"));
    assert!(e.contains("layer 1: alpha") && e.contains("0 to 1"), "{e}");
    let e = error(&ONE_LAYER.replace("alpha = 0.1", "alpha = 0.1\nvary = { alpha = [0.4, 0.1] }"));
    assert!(e.contains("vary.alpha") && e.contains("inverted"), "{e}");
    let medium = format!("{ONE_LAYER}[[material.layer]]\ntype = \"medium\"\nsigma_s = 0.5\n");
    let e = error(&medium);
    assert!(e.contains("material 1 (`m`), layer 2") && e.contains("without `depth`"), "{e}");
    let e = error(&format!("{ONE_LAYER}[[material.layer]]\ntype = \"medium\"\ndepth = inf\n"));
    assert!(e.contains("layer 2: depth") && e.contains("finite"), "{e}");
    let e = error("[[material]]\nname = \"empty\"\n");
    assert!(e.contains("`empty`") && e.contains("empty layer stack"), "{e}");
    let e = error(&ONE_LAYER.replace("type = \"interface\"", "type = \"coat\""));
    assert!(e.contains("layer 1: type: unknown variant `coat`, expected `interface` or `medium`"), "{e}");
    let e = error(&ONE_LAYER.replace("name = \"m\"", "name = \"m\"\nmodel = \"4-flux\""));
    assert!(e.contains("model") && e.contains("\"2-flux\", \"6-flux\""), "{e}");
    let e = error(&format!("{ONE_LAYER}{ONE_LAYER}"));
    assert!(e.contains("material 2") && e.contains("`m` is used twice"), "{e}");
    let e = error("name = \"x\"\n");
    assert!(e.contains("at least one material"), "{e}");
    let e = error(&format!("colour = 1\n{ONE_LAYER}"));
    assert!(e.contains("test.toml: unknown field `colour`, expected one of `name`, `model`"), "{e}");
}

#[test]
fn values_of_the_wrong_kind_are_refused_naming_the_material_the_layer_and_the_key() {
    for (from, to, says) in [
        ("alpha = 0.1", "alpha = \"rough\"", "material 1 (`m`), layer 1: alpha: \"rough\"; must be a number"),
        ("eta = 1.5", "eta = \"glass\"", "layer 1: eta: \"glass\"; must be a number or an array of numbers"),
        ("alpha = 0.1", "vary = { alpha = 0.3 }", "layer 1: vary.alpha: 0.3; give a range [lo, hi]"),
        ("alpha = 0.1", "vary = { alpha = [0.1, 0.2, 0.3] }", "vary.alpha: [0.1, 0.2, 0.3]; give a range [lo, hi]"),
        ("alpha = 0.1", "alpha = 0.1\nvary = { beta = [0.1, 0.2] }", "layer 1: vary: unknown field `beta`"),
        ("alpha = 0.1", "alpha = 0.1\nvary = 2", "layer 1: vary: invalid type: integer `2`, expected a table"),
        ("type = \"interface\"\n", "", "layer 1: has no `type`; allowed: \"interface\", \"medium\""),
        (
            "type = \"interface\"",
            "type = 5",
            "type: invalid type: integer `5`, expected variant identifier; allowed: \"interface\", \"medium\"",
        ),
        ("eta = 1.5", "eta = [1.5, \"x\", 1.5]", "layer 1: eta: \"x\"; must be a number"),
        ("name = \"m\"", "name = 5", "material 1: name: invalid type: integer `5`, expected a string"),
        ("name = \"m\"", "name = \"m\"\nlayers = 1", "material 1: unknown field `layers`, expected one of"),
        ("name = \"m\"", "name = \"m\"\ntir = \"fitted\"", "(`m`): tir: \"fitted\"; allowed: \"table\", \"fit\""),
    ] {
        let e = error(&ONE_LAYER.replace(from, to));
        assert!(e.contains(says), "{says}: {e}");
    }
    for value in ["9", "1.5"] {
        let e = error(&format!("margin_nodes = {value}\n{ONE_LAYER}"));
        assert!(e.contains(&format!("test.toml: margin_nodes: {value}; allowed: 0 to 8")), "{e}");
    }
    let e = error(&ONE_LAYER.replace("name = \"m\"", "name = \"m\"\nmodel = 2"));
    assert!(e.contains("material 1 (`m`): model: 2; allowed: \"2-flux\", \"6-flux\""), "{e}");
    let e = error(&format!("{ONE_LAYER}[[material.layer]]\ntype = \"medium\"\ndepth = 1.0\neta = 1.5\n"));
    assert!(e.contains("layer 2: unknown field `eta`, expected one of `sigma_s`, `sigma_k`, `depth`, `g`"), "{e}");
    let e = error("material = 1\n");
    assert!(e.contains("test.toml: material: 1; must be an array of tables ([[material]])"), "{e}");
    let e = error("[[material]]\nname = \"m\"\nlayer = 3\n");
    assert!(e.contains("material 1: layer: 3; must be an array of tables ([[material.layer]])"), "{e}");
    let e = error("material = [1]\n");
    assert!(e.contains("material 1: invalid type: integer `1`, expected a table ([[material]])"), "{e}");
}

#[test]
fn layers_below_a_conductor_are_ignored_with_a_warning() {
    let text = "[[material]]\nname = \"metal\"\n\
        [[material.layer]]\ntype = \"interface\"\neta = 0.2\nkappa = 3.0\nalpha = 0.1\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";
    let scene = parse(text).unwrap();
    assert_eq!(scene.warnings.len(), 1);
    let warning = &scene.warnings[0];
    assert!(warning.contains("`metal`") && warning.contains("layer 2") && warning.contains("ignored"), "{warning}");
    // And the plan makes no lookup below it.
    let plan = plan(&scene, &Config::default()).unwrap();
    assert!(plan.lookups.iter().all(|l| l.layer == 1), "{:?}", plan.lookups);
    assert_eq!(plan.warnings, scene.warnings);
}

fn table_names(plan: &Plan) -> Vec<&str> {
    plan.tables.iter().map(|t| t.record.name.as_str()).collect()
}

fn slices<'a>(plan: &'a Plan, name: &str) -> &'a Slices {
    match plan.tables.iter().find(|t| t.record.name == name).map(|t| &t.build) {
        Some(PlannedBuild::Slices(s)) => s,
        other => panic!("{name}: {other:?}"),
    }
}

fn left_out<'a>(plan: &'a Plan, what: &str) -> &'a str {
    &plan.left_out.iter().find(|l| l.what.starts_with(what)).unwrap_or_else(|| panic!("{what} not left out")).reason
}

#[test]
fn copper_pot_gets_two_fgd_slices_a_tir_slice_and_gd() {
    let plan = plan(&example("copper-pot"), &Config::default()).unwrap();
    assert_eq!(
        table_names(&plan),
        [
            "fgd_varnished-copper_l1_from-above",
            "fgd_varnished-copper_l2_from-above",
            "tir_varnished-copper_l1_up",
            "gd"
        ]
    );
    // From above the varnish: every cosine, on a grid dense at grazing; one channel, since R, G and
    // B share eta 1.1.
    let top = slices(&plan, "fgd_varnished-copper_l1_from-above");
    assert_eq!((top.mu.start, top.mu.end, top.mu.mapping), (0.0, 1.0, crate::table::Mapping::Sqrt));
    assert!(top.mu.count > 64, "{:?}", top.mu);
    assert_eq!(top.channels.len(), 1);
    assert_eq!((top.channels[0].eta, top.channels[0].kappa), (1.1, 0.0));
    // A roughness that never varies lies between two neighbouring nodes of the slice lattice.
    let lattice_step = 1.0 / crate::recipes::slices::FGD_SLICE_LATTICE[0];
    assert_eq!(top.alpha.count, 2);
    assert!(top.alpha.start <= 0.01 && 0.01 <= top.alpha.end, "{:?}", top.alpha);
    assert!((top.alpha.end.sqrt() - top.alpha.start.sqrt() - lattice_step).abs() < 1e-12, "{:?}", top.alpha);
    // The copper is read at the cosines of light refracted by the varnish: from the critical
    // cosine sqrt(1 - 1/1.1^2) (a grazing view) up, from the lattice node at or below it.
    let critical = (1.0 - 1.0 / (1.1f64 * 1.1)).sqrt();
    let copper = slices(&plan, "fgd_varnished-copper_l2_from-above");
    let from_the_node_below = |start: f64, lattice: f64| start <= critical && critical - start < 1.0 / lattice;
    assert!(from_the_node_below(copper.mu.start, 1.0 / lattice_step) && copper.mu.end == 1.0, "{:?}", copper.mu);
    // One channel per colour, indices relative to the varnish, padded to RGBA.
    let pairs: Vec<(f64, f64)> = copper.channels.iter().map(|c| (c.eta, c.kappa)).collect();
    assert_eq!(pairs, [(0.1 / 1.1, 4.0 / 1.1), (0.4 / 1.1, 2.4 / 1.1), (1.6 / 1.1, 1.6 / 1.1)]);
    assert_eq!(copper.stored_channel_count(), 4);
    // TIR on the way up through the varnish, at the copper's cosines, for lobes reflected by the
    // copper (at least as rough as it) and narrowed by the smooth varnish: a small range.
    let tir = slices(&plan, "tir_varnished-copper_l1_up");
    assert!(matches!(tir.of, SliceOf::Tir(_)));
    assert!(from_the_node_below(tir.mu.start, crate::recipes::slices::TIR_SLICE_LATTICE[0]), "{:?}", tir.mu);
    assert!(tir.alpha.start >= 0.0085 && tir.alpha.end < 0.02, "{:?}", tir.alpha);
    assert!((tir.channels[0].eta - 1.0 / 1.1).abs() < 1e-15);
    assert!(left_out(&plan, "fgd (4D").contains("2 slice tables replace it"));
    assert!(left_out(&plan, "tir (3D").contains("1 slice table replaces it"));
    assert!(left_out(&plan, "belcour").contains("belcour path"));
    assert_eq!(plan.bytes, plan.tables.iter().map(|t| t.record.bytes).sum::<u64>());
    assert_eq!(
        plan.default_set_bytes,
        (64usize.pow(4) * 4
            + 64 * 64 * 4
            + 64 * 64 * 129 * 4
            + 128 * 128 * 4 * 2
            + 512 * 512 * 2 * 2
            + 64 * 64 * 129 * 4) as u64
    );
    assert!(plan.bytes < 32 * 1024, "{}", plan.bytes);
}

#[test]
fn profiling_scene_merges_equal_colour_channels() {
    let plan = plan(&example("profiling"), &Config::default()).unwrap();
    // kappa (1.0, 0.1, 0.1) under a coat of 1.5: G and B share one channel.
    let conductor = slices(&plan, "fgd_coated-conductor_l2_from-above");
    assert_eq!(conductor.channels.len(), 2);
    assert!(conductor.channels[1].used_by.ends_with("G, B"), "{}", conductor.channels[1].used_by);
    assert!((conductor.channels[0].eta - 1.0 / 1.5).abs() < 1e-15);
    assert!((conductor.channels[0].kappa - 1.0 / 1.5).abs() < 1e-15);
    // The coat's roughness 0.1 is read between two neighbouring lattice nodes.
    let coat = slices(&plan, "fgd_coated-conductor_l1_from-above");
    assert!(coat.alpha.count == 2 && coat.alpha.start <= 0.1 && 0.1 <= coat.alpha.end, "{:?}", coat.alpha);
    // TIR through the coat: lobes transmitted by it are narrower than its reflection (the
    // reference scales their roughness by the refraction's spread), so below its 0.1.
    let tir = slices(&plan, "tir_coated-conductor_l1_up");
    assert!(tir.alpha.start >= 0.01 && tir.alpha.end < 0.1, "{:?}", tir.alpha);
}

#[test]
fn scattering_stack_reads_the_conductor_at_refracted_cosines_and_gd_for_its_lobes() {
    let plan = plan(&example("scattering"), &Config::default()).unwrap();
    assert!(table_names(&plan).contains(&"gd"), "{:?}", table_names(&plan));
    // The model reads the conductor below the medium at the refracted mean cosine of the flux;
    // the scattered fluxes reuse those factors.
    let critical = (1.0 - 1.0 / (1.5f64 * 1.5)).sqrt();
    let conductor = slices(&plan, "fgd_scattering-stack_l3_from-above");
    let lattice_step = 1.0 / crate::recipes::slices::FGD_SLICE_LATTICE[0];
    let from_the_node_below = conductor.mu.start <= critical && critical - conductor.mu.start < lattice_step;
    assert!(from_the_node_below && conductor.mu.end == 1.0, "{:?}", conductor.mu);
    assert!((conductor.channels[0].eta - 0.1 / 1.5).abs() < 1e-15);
    // Light comes back up through the coat (from the conductor, and scattered by the medium).
    let tir = slices(&plan, "tir_scattering-stack_l1_up");
    assert!(tir.alpha.start > 0.0 && tir.alpha.end < 0.4, "{:?}", tir.alpha);
    // The same stack in the 2-flux model: the medium only absorbs, and a warning says so; its
    // internal lobe still reads GD.
    let two_flux =
        include_str!("../../luts/scenes/scattering.toml").replace("model = \"6-flux\"", "model = \"2-flux\"");
    let scene = parse(&two_flux).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("sigma_s is ignored")), "{:?}", scene.warnings);
    let plan = super::plan::plan(&scene, &Config::default()).unwrap();
    assert!(table_names(&plan).contains(&"gd"));
}

#[test]
fn nothing_comes_back_up_from_a_medium_that_only_absorbs() {
    let text = format!("{ONE_LAYER}[[material.layer]]\ntype = \"medium\"\nsigma_k = 0.5\ndepth = 1.0\n");
    let absorbing = plan(&parse(&text).unwrap(), &Config::default()).unwrap();
    assert!(absorbing.lookups.iter().all(|l| l.site == crate::model::Site::FromAbove), "{:?}", absorbing.lookups);
    // The same medium scattering in a 6-flux material sends light back up through the coat.
    let text =
        text.replace("sigma_k = 0.5", "sigma_s = 0.5").replace("name = \"m\"", "name = \"m\"\nmodel = \"6-flux\"");
    let plan = plan(&parse(&text).unwrap(), &Config::default()).unwrap();
    let up: Vec<&super::lookups::LookupRange> =
        plan.lookups.iter().filter(|l| l.site == crate::model::Site::Up).collect();
    assert_eq!(up.len(), 3);
    assert!(up.iter().all(|l| (l.eta.lo - 1.0 / 1.5).abs() < 1e-15), "{up:?}");
}

#[test]
fn textured_ranges_give_sub_ranges_and_a_varying_index_the_4d_table() {
    let plan = plan(&example("textured"), &Config::default()).unwrap();
    let coat = slices(&plan, "fgd_worn-gold_l1_from-above");
    assert!(coat.alpha.start <= 0.1 && coat.alpha.end >= 0.4 && coat.alpha.end < 0.45, "{:?}", coat.alpha);
    let Some(PlannedBuild::Table(crate::config::TableSettings::Fgd(fgd))) =
        plan.tables.iter().find(|t| t.record.name == "fgd").map(|t| &t.build)
    else {
        panic!("the glaze's varying index needs the 4D table: {:?}", table_names(&plan));
    };
    // eta over [1.4, 1.7] and kappa 0 only, between nodes of the default grid at most two cells
    // outside the lookups.
    let full_eta = &Config::default().fgd.axes().unwrap()[2];
    let node_below = |x: f64| full_eta.value_at((full_eta.continuous_index(x).floor() - 1.0) / 63.0);
    let node_above = |x: f64| full_eta.value_at((full_eta.continuous_index(x).ceil() + 1.0) / 63.0);
    assert!(fgd.eta_range[0] <= 1.4 && fgd.eta_range[0] >= node_below(1.4) - 1e-12, "{:?}", fgd.eta_range);
    assert!(fgd.eta_range[1] >= 1.7 && fgd.eta_range[1] <= node_above(1.7) + 1e-12, "{:?}", fgd.eta_range);
    assert_eq!(fgd.kappa_range[0], 0.0);
    assert_eq!(fgd.kappa_count, 2);
    assert!((fgd.mu_alpha.alpha_range[0]..=fgd.mu_alpha.alpha_range[1]).contains(&0.2));
    let full = Config::default().fgd;
    assert!(
        fgd.eta_count * fgd.kappa_count * fgd.alpha_count < full.eta_count * full.kappa_count * full.alpha_count / 100
    );
}

#[test]
fn tir_off_and_fit_leave_the_tir_lookups_out() {
    let text = include_str!("../../luts/scenes/copper-pot.toml");
    for (path, says) in [("off", "tir = \"off\""), ("fit", "fitted analytic form")] {
        let scene = parse(&text.replace("tir = \"table\"", &format!("tir = \"{path}\""))).unwrap();
        let plan = plan(&scene, &Config::default()).unwrap();
        let tir_tables: Vec<&str> = table_names(&plan).into_iter().filter(|n| n.starts_with("tir")).collect();
        // The fitted form ships its shaders only: no texels.
        let expected: &[&str] = if path == "fit" { &["tir_fit"] } else { &[] };
        assert_eq!(tir_tables, expected);
        assert!(plan.tables.iter().all(|t| !t.record.name.starts_with("tir") || t.record.bytes == 0));
        assert!(left_out(&plan, "TIR lookups of varnished-copper, layer 1 up").contains(says));
    }
}

#[test]
fn split_sum_paths_replace_the_fgd_lookups() {
    let text = include_str!("../../luts/scenes/copper-pot.toml").replace("albedo = \"fgd\"", "albedo = \"belcour\"");
    let plan = plan(&parse(&text).unwrap(), &Config::default()).unwrap();
    assert_eq!(table_names(&plan), ["belcour", "tir_varnished-copper_l1_up", "gd"]);
    assert!(left_out(&plan, "fgd (4D").contains("no material reads albedo on the FGD path"));
}

#[test]
fn an_index_matched_interface_needs_no_lookup() {
    let text = "[[material]]\nname = \"m\"\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.0\nalpha = 0.3\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";
    let plan = plan(&parse(text).unwrap(), &Config::default()).unwrap();
    assert!(
        plan.lookups.iter().all(|l| l.layer == 2 || l.kind == super::lookups::LookupKind::Gd),
        "{:?}",
        plan.lookups
    );
    assert!(left_out(&plan, "m, layer 1").contains("index-matched"));
}

/// The configuration of the build tests: small tables whose grids hold the examples' indices
/// (eta spacing 0.5 over [0, 4], kappa spacing 1 over [0, 4], TIR eta spacing 1/6).
fn small_config() -> Config {
    let mut config = Config::default();
    let (fgd, tir) = (&mut config.fgd, &mut config.tir);
    [fgd.mu_count, fgd.alpha_count, fgd.eta_count, fgd.kappa_count] = [9, 9, 9, 5];
    fgd.packings = Vec::new();
    [tir.mu_count, tir.alpha_count, tir.eta_count] = [9, 9, 7];
    for kind in [TableKind::Fgd, TableKind::Tir] {
        let recipe = config.recipe_mut(kind);
        recipe.sampling_mut().samples = 1 << 12;
        *recipe.reference_mut() = crate::recipes::settings::ReferenceConfig { cells: 8, nodes: 4 };
    }
    config.seed = 11;
    config
}

#[test]
fn slice_nodes_agree_with_independent_per_cell_estimates() {
    // A coat of 2 over a conductor (1, 2): FGD slices from above both interfaces, TIR upward
    // through the coat. Each node is computed by the fast kernels; the per-cell f64 estimator with
    // independent points must agree within their standard errors.
    let text = "[[material]]\nname = \"m\"\n\
        [[material.layer]]\ntype = \"interface\"\neta = 2.0\nalpha = 0.25\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.0\nkappa = 2.0\nalpha = 0.5\n";
    let config = small_config();
    let plan = plan(&parse(text).unwrap(), &config).unwrap();
    let progress = ();
    let kinds: Vec<&str> = plan.tables.iter().map(|t| t.record.kind.as_str()).collect();
    assert_eq!(kinds, ["FGD slice", "FGD slice", "TIR slice", "GD 2D, whole"]);
    let reference = crate::recipes::reference_points(1 << 16, 99).unwrap();
    let mut compared = 0;
    for planned in &plan.tables {
        let PlannedBuild::Slices(slices) = &planned.build else { continue };
        let build = crate::recipes::driver::build(slices, config.seed, &progress).unwrap();
        let standard_error = build.provenance.standard_error.as_ref().unwrap();
        let stored = build.table.channel_count();
        for n in (0..build.table.node_count()).step_by(7) {
            let position = build.table.node_position(&build.table.node_index(n));
            let independent = slices.estimate_node(&reference, &position);
            for k in 0..slices.channels.len() {
                let value = build.table.data[n * stored + k] as f64;
                let spread = (standard_error[n * stored + k] as f64).hypot(independent.standard_error[k]);
                // TIR integrates an indicator, discontinuous along the critical cone: scrambled
                // net points integrate it with an error of order n^(-3/4) for n points per
                // replicate (Owen 1997), and a spread over four replicates estimates that poorly,
                // so it is allowed besides.
                let discontinuity = match slices.of {
                    SliceOf::Tir(ref s) => {
                        (s.shared.sampling.samples as f64 / s.shared.sampling.replicates as f64).powf(-0.75)
                    }
                    SliceOf::Fgd(_) => 0.0,
                };
                let tolerance = 1e-5 + discontinuity + 4.0 * spread;
                assert!(
                    (value - independent.mean[k]).abs() <= tolerance,
                    "{} at {position:?}: {value} vs {} (s.e. {} and {})",
                    slices.name,
                    independent.mean[k],
                    standard_error[n * stored + k],
                    independent.standard_error[k]
                );
                compared += 1;
            }
        }
    }
    assert!(compared >= 50, "{compared}");
}

#[test]
fn a_slice_beats_the_4d_table_between_its_eta_nodes() {
    // A varnish of 1.1: Fresnel changes fast with eta just above 1, and the full table
    // interpolates between nodes 1.0 and 1.5 of the small grid.
    let mut config = small_config();
    // Fine in mu and alpha, so that the slice's own interpolation error is small.
    config.fgd.mu_count = 64;
    config.fgd.alpha_count = 64;
    let plan = plan(&example("copper-pot"), &config).unwrap();
    let slices = slices(&plan, "fgd_varnished-copper_l1_from-above");
    let progress = ();
    let build = crate::recipes::driver::build(slices, config.seed, &progress).unwrap();
    let full = crate::recipes::driver::build(&config.fgd, config.seed, &progress).unwrap().table;
    let (exact, full_report) = super::build::slice_accuracy(slices, &full, config.seed, &progress).unwrap();
    let names = vec!["fgd0".to_string()];
    let slice = crate::recipes::interpolation::compare(&exact, "test", &names, |p| build.table.interpolate(p)).error;
    let full = full_report.error;
    assert!(full_report.what.starts_with("full 64 x 64 x 9 x 5"), "{}", full_report.what);
    assert!(slice.count >= 16 && slice.count == full.count);
    assert!(slice.rms * 5.0 < full.rms, "slice {slice:?} vs full {full:?}");
}

#[test]
fn a_material_is_evaluated_at_its_nominal_values() {
    let scene = example("textured");
    let gold = scene.materials[0].stack().unwrap();
    let crate::model::Layer::Interface(coat) = gold.layers()[0] else { panic!("an interface") };
    // Given beside the range: that value; the range itself is what the plan covers.
    assert_eq!(coat.alpha, 0.25);
    let ceramic = scene.materials[1].stack().unwrap();
    let crate::model::Layer::Interface(glaze) = ceramic.layers()[0] else { panic!("an interface") };
    assert_eq!((glaze.eta, glaze.alpha), ([1.5; 3], 0.2));
    // A range alone: its middle.
    let text =
        ONE_LAYER.replace("alpha = 0.1", "vary = { alpha = [0.1, 0.3], eta = [1.2, 1.6] }").replace("eta = 1.5\n", "");
    let stack = parse(&text).unwrap().materials[0].stack().unwrap();
    let crate::model::Layer::Interface(i) = stack.layers()[0] else { panic!("an interface") };
    assert!((i.alpha - 0.2).abs() < 1e-15 && (i.eta[0] - 1.4).abs() < 1e-15, "{i:?}");
    let e = error(&ONE_LAYER.replace("alpha = 0.1", "alpha = 0.5\nvary = { alpha = [0.1, 0.3] }"));
    assert!(e.contains("layer 1: alpha") && e.contains("outside vary.alpha"), "{e}");
}

#[test]
fn a_medium_on_top_is_refused() {
    let text = "[[material]]\nname = \"m\"\n[[material.layer]]\ntype = \"medium\"\ndepth = 1.0\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";
    let e = error(text);
    assert!(e.contains("layer 1") && e.contains("top layer must be an interface"), "{e}");
}

#[test]
fn impossible_values_and_sizes_are_refused_in_the_scenes_own_words() {
    // An index no medium has, in a vary range or given: refused before anything is planned.
    for (text, key, value) in [
        (ONE_LAYER.replace("eta = 1.5", "vary = { eta = [1.4, 1e20] }"), "vary.eta", "1e20"),
        (ONE_LAYER.replace("eta = 1.5", "vary = { eta = [1.4, 1e10] }"), "vary.eta", "1e10"),
        (ONE_LAYER.replace("eta = 1.5", "eta = 1e300"), "eta", "1e300"),
        (ONE_LAYER.replace("eta = 1.5", "eta = 1.5\nkappa = 1e5"), "kappa", "100000"),
    ] {
        let e = error(&text);
        assert!(e.contains(&format!("layer 1: {key}")) && e.contains(value) && e.contains("to 100"), "{e}");
    }
    // More layers than the model evaluates, more materials than a scene holds.
    let layer = "[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";
    let deep = format!("[[material]]\nname = \"deep\"\n{}", layer.repeat(crate::model::MAX_LAYERS + 1));
    let e = error(&deep);
    assert!(e.contains("`deep`") && e.contains("65 layers") && e.contains("at most 64"), "{e}");
    let many: String = (0..=MAX_MATERIALS).map(|k| format!("[[material]]\nname = \"m{k}\"\n{layer}")).collect();
    let e = error(&many);
    assert!(e.contains("257 materials") && e.contains("at most 256"), "{e}");

    // A relative index whose sub-range the grid cannot cover: the lookups' site is named.
    let text = "[[material]]\nname = \"thin-over-dense\"\n\
        [[material.layer]]\ntype = \"interface\"\neta = 0.01\nalpha = 0.1\n\
        [[material.layer]]\ntype = \"interface\"\nvary = { eta = [1.0, 100.0] }\nalpha = 0.1\n";
    let scene = Scene::from_toml(text, "t.toml", "t").unwrap();
    // On a uniform eta axis (the original layout); the default's asinh spacing reaches 10000 in 55
    // nodes.
    let mut uniform = Config::default();
    uniform.fgd.eta_axis = crate::recipes::spacing::IndexAxis::Uniform;
    let e = plan(&scene, &uniform).unwrap_err().to_string();
    assert!(e.contains("thin-over-dense, layer 2 from above") && e.contains("reach eta 100 to 10000"), "{e}");
    assert!(e.contains("allowed: at most 16384 nodes"), "{e}");
}

#[test]
fn planning_work_is_bounded() {
    // Twelve roughness maps: 1 + 729 stacks, 257 views, 64 layers = 12 million layer evaluations, within
    // the bound; five such materials are not.
    let mut material = String::from("[[material]]\nname = \"NAME\"\n");
    for k in 0..crate::model::MAX_LAYERS {
        let eta = if k % 2 == 0 { 1.5 } else { 1.3 };
        let alpha = if k < 12 { "vary = { alpha = [0.1, 0.4] }" } else { "alpha = 0.1" };
        material.push_str(&format!("[[material.layer]]\ntype = \"interface\"\neta = {eta}\n{alpha}\n"));
    }
    let five: String = (0..5).map(|k| material.replace("NAME", &format!("m{k}"))).collect();
    let scene = Scene::from_toml(&five, "five.toml", "five").unwrap();
    let e = plan(&scene, &Config::default()).unwrap_err().to_string();
    assert!(
        e.contains("scene `five`") && e.contains("at most 33554432") && e.contains("`m0` (64 layers, 730 stacks"),
        "{e}"
    );
}

#[test]
fn values_the_shader_cannot_hold_in_f32_are_refused_naming_key_and_range() {
    // Each printed `inf` into the scene's shader (or a subnormal a GPU flushes to 0), which then
    // failed to compile while `tmlut shader` exited 0.
    let medium = |line: &str| format!("{ONE_LAYER}[[material.layer]]\ntype = \"medium\"\n{line}\n");
    for (text, key, allowed) in [
        (medium("sigma_k = 0.5\ndepth = 3.4e38"), "layer 2: depth", "a finite number from 1e-30 to 1e30"),
        (medium("sigma_k = 0.5\ndepth = 1e-40"), "layer 2: depth", "a finite number from 1e-30 to 1e30"),
        (medium("sigma_s = 1e39\ndepth = 1.0"), "layer 2: sigma_s", "0, or 1e-30 to 1e30"),
        (medium("sigma_k = 1e-40\ndepth = 1.0"), "layer 2: sigma_k", "0, or 1e-30 to 1e30"),
        (medium("sigma_s = 0.5\ng = 1e-40\ndepth = 1.0"), "layer 2: g", "-1 to 1, 0 or at least 1e-30 in magnitude"),
        (ONE_LAYER.replace("eta = 1.5", "eta = 1.5\nkappa = 5e-324"), "layer 1: kappa", "0, or 1e-30 to 100"),
        (ONE_LAYER.replace("alpha = 0.1", "alpha = 1e-40"), "layer 1: alpha", "0, or 1e-30 to 1"),
    ] {
        let e = error(&text);
        assert!(e.contains(key) && e.contains(&format!("allowed: {allowed}")), "{key}: {e}");
    }
    // The ends of the ranges are values a scene may give.
    for line in [
        "sigma_k = 1e30\ndepth = 1e30",
        "sigma_s = 1e-30\nsigma_k = 0\ndepth = 1e-30",
        "sigma_k = 0.5\ndepth = 1.0\ng = -1e-30",
    ] {
        parse(&medium(line)).unwrap();
    }
}

#[test]
fn names_that_would_share_a_file_or_not_fit_one_are_refused() {
    // `plan` passed these, and `build` then failed on "a format listed twice" or "file name too
    // long"; `Copper` and `copper` shared their furnace pictures.
    let named = |name: &str| ONE_LAYER.replace("name = \"m\"", &format!("name = \"{name}\""));
    for (a, b) in [("Copper", "copper"), ("glass a", "glass-a"), ("glass_a", "glass.a"), ("été", "-t-")] {
        let e = error(&format!("{}{}", named(a), named(b)));
        assert!(e.contains("material 2") && e.contains(&format!("`{b}`")) && e.contains(&format!("(`{a}`)")), "{e}");
        assert!(e.contains("differ in more than case and punctuation"), "{e}");
    }
    let long = "x".repeat(MAX_NAME_CHARS + 1);
    let e = error(&named(&long));
    assert!(e.contains("material 1: name") && e.contains("65 characters") && e.contains("allowed: 1 to 64"), "{e}");
    parse(&named(&"x".repeat(MAX_NAME_CHARS))).unwrap();
    let e = error(&named(""));
    assert!(e.contains("material 1: name") && e.contains("is empty"), "{e}");
    let e = error(&format!("name = \"\"\n{ONE_LAYER}"));
    assert!(e.contains("test.toml: name") && e.contains("is empty"), "{e}");
    let e = error(&format!("name = \"{long}\"\n{ONE_LAYER}"));
    assert!(e.contains("test.toml: name") && e.contains("allowed: 1 to 64"), "{e}");
    // Whatever the name, the files a plan makes are named by the same mapping the parser holds apart.
    let scene = parse(&format!("{}{}", named("Glass A"), named("glass b").replace("1.5", "1.6"))).unwrap();
    let plan = plan(&scene, &Config::default()).unwrap();
    let mut slice_names: Vec<&str> = table_names(&plan).into_iter().filter(|n| n.starts_with("fgd_")).collect();
    slice_names.sort();
    assert_eq!(slice_names, ["fgd_glass-a_l1_from-above", "fgd_glass-b_l1_from-above"]);
}

#[test]
fn gd_is_planned_for_every_lobe_the_shader_reads_it_for_even_one_without_energy() {
    // A coat over a conductor that reflects nothing (relative index 1, kappa 5e-324, once admitted)
    // has a lobe with no energy at every view: the model reads no GD for it, but the shader binds
    // GD for it all the same, and refused the folder whose plan had left GD out.
    let text = format!("{ONE_LAYER}[[material.layer]]\ntype = \"interface\"\neta = 1.5\nkappa = 1.0\nalpha = 0.2\n");
    let mut scene = parse(&text).unwrap();
    let SceneLayer::Interface(conductor) = &mut scene.materials[0].layers[1] else { panic!("an interface") };
    conductor.kappa = [Interval::point(5e-324); 3];
    conductor.nominal.kappa = [5e-324; 3];
    let plan = plan(&scene, &Config::default()).unwrap();
    assert!(table_names(&plan).contains(&"gd"), "{:?}", table_names(&plan));
}

#[test]
fn shards_partition_a_plan_and_anything_but_i_of_n_is_refused() {
    use super::build::Shard;
    let plan = plan(&example("copper-pot"), &Config::default()).unwrap();
    assert!(plan.tables.len() >= 4);
    for count in 1..=5 {
        let owned: Vec<Vec<bool>> =
            (1..=count).map(|i| Shard::parse(&format!("{i}/{count}")).unwrap().owned(&plan)).collect();
        for place in 0..plan.tables.len() {
            assert_eq!(owned.iter().filter(|o| o[place]).count(), 1, "table {place} of {count} shards");
        }
    }
    for bad in ["0/3", "4/3", "3", "a/b", "1/0", "1/5000", "-1/3"] {
        assert!(Shard::parse(bad).unwrap_err().contains("I/N"), "{bad}");
    }
}

#[test]
fn a_stand_in_is_planned_and_weighed_for_the_lookups_of_its_region_only() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/scenes/gpu-check/varied-coats.toml");
    let (scene, _) = Scene::read(&path).unwrap();
    let plan = plan(&scene, &Config::default()).unwrap();
    let rarer: Vec<_> = plan.tables.iter().filter(|t| t.record.name == TableKind::FgdRarer.name()).collect();
    assert_eq!(rarer.len(), 1);
    assert!(matches!(&rarer[0].build, PlannedBuild::Table(settings) if settings.kind() == TableKind::FgdRarer));
    assert_eq!(rarer[0].record.reasons.len(), 1, "{:?}", rarer[0].record.reasons);
    assert!(
        rarer[0].record.reasons[0].starts_with("lower-index-under-a-coat, layer 2"),
        "{:?}",
        rarer[0].record.reasons
    );
    // A scene with no dielectric onto a rarer medium plans none.
    let copper = super::plan::plan(&example("copper-pot"), &Config::default()).unwrap();
    assert!(copper.tables.iter().all(|t| t.record.name != TableKind::FgdRarer.name()));

    // The fit's scene weights: the stand-in's lookups are those that reach its region, a subset
    // of FGD's.
    let weights = super::lookups::table_lookups(&path, TableKind::FgdRarer.name()).unwrap();
    let fgd = super::lookups::table_lookups(&path, TableKind::Fgd.name()).unwrap();
    let names =
        |l: &crate::fit::forms::region::SceneLookups| l.materials.iter().map(|(m, _)| m.clone()).collect::<Vec<_>>();
    assert_eq!(names(&weights), ["lower-index-under-a-coat"]);
    assert_eq!(names(&fgd).len(), 3, "{:?}", names(&fgd));
    for (_, hulls) in &weights.materials {
        for [_, _, eta, kappa] in hulls {
            assert!(eta.0 < 1.0 && kappa.0 == 0.0, "eta {eta:?}, kappa {kappa:?}");
        }
    }
    let count = |l: &crate::fit::forms::region::SceneLookups| l.materials.iter().map(|(_, h)| h.len()).sum::<usize>();
    assert!(count(&weights) < count(&fgd));
}
