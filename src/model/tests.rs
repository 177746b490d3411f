use super::*;
use crate::physics::fresnel_reflectance;

fn dielectric(eta: f64, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta: [eta; 3], kappa: [0.0; 3], alpha })
}

fn conductor(eta: Rgb, kappa: Rgb, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta, kappa, alpha })
}

fn medium(sigma_s: f64, sigma_k: Rgb, depth: f64, g: f64) -> Layer {
    Layer::Medium(Medium { sigma_s: [sigma_s; 3], sigma_k, depth, g })
}

/// Smooth interfaces: FGD is Fresnel at the incident cosine, no lobe is lost to TIR, and a lobe's
/// own albedo is 1.
fn smooth_tables(lookup: &Lookup) -> f64 {
    match lookup.quantity {
        Quantity::Albedo => fresnel_reflectance(lookup.mu, lookup.eta, lookup.kappa),
        Quantity::Tir => 0.0,
        Quantity::Gd => 1.0,
    }
}

fn material(model: FluxModel, layers: Vec<Layer>) -> Material {
    Material::new(model, Stack::new(layers).unwrap())
}

const COPPER_ETA: Rgb = [0.1, 0.4, 1.6];
const COPPER_KAPPA: Rgb = [4.0, 2.4, 1.6];

/// The reflectance of a smooth coat of index `eta` over a smooth conductor, with an attenuation
/// `a` each way between them: `F + (1 - F)^2 a^2 Rc / (1 - F a^2 Rc)`, `F` at the view cosine and
/// `Rc` at the refracted one (Stokes: the coat reflects the same from below at the refracted angle).
fn coated_conductor(mu: f64, eta: f64, attenuation: impl Fn(f64) -> Rgb) -> Rgb {
    let f = fresnel_reflectance(mu, eta, 0.0);
    let mu_t = factors::refracted_cosine(mu, eta);
    let a = attenuation(mu_t);
    std::array::from_fn(|c| {
        let rc = fresnel_reflectance(mu_t, COPPER_ETA[c] / eta, COPPER_KAPPA[c] / eta) * a[c] * a[c];
        f + (1.0 - f) * (1.0 - f) * rc / (1.0 - f * rc)
    })
}

#[test]
fn a_smooth_coat_over_a_conductor_sums_its_interreflections() {
    for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
        let m = material(model, vec![dielectric(1.5, 0.0), conductor(COPPER_ETA, COPPER_KAPPA, 0.0)]);
        for mu in [1.0, 0.7, 0.3, 0.05] {
            let a = m.albedo(mu, &smooth_tables);
            let expected = coated_conductor(mu, 1.5, |_| [1.0; 3]);
            for c in 0..3 {
                assert!((a[c] - expected[c]).abs() < 1e-12, "{model:?} mu {mu} channel {c}: {a:?} vs {expected:?}");
            }
        }
    }
}

#[test]
fn an_absorbing_medium_attenuates_each_way_in_both_models() {
    let sigma_k = [0.5, 1.0, 2.0];
    let depth = 0.3;
    for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
        let m = material(
            model,
            vec![dielectric(1.5, 0.0), medium(0.0, sigma_k, depth, 0.0), conductor(COPPER_ETA, COPPER_KAPPA, 0.0)],
        );
        for mu in [1.0, 0.5, 0.1] {
            let a = m.albedo(mu, &smooth_tables);
            let expected = coated_conductor(mu, 1.5, |mu_t| sigma_k.map(|k| (-k * depth / mu_t).exp()));
            for c in 0..3 {
                assert!((a[c] - expected[c]).abs() < 1e-12, "{model:?} mu {mu}: {a:?} vs {expected:?}");
            }
        }
        // No secondary flux without scattering.
        let evaluation = m.evaluate(0.5, &smooth_tables);
        for lobe in &evaluation.lobes {
            if lobe.kind != LobeKind::Primary {
                assert!(lobe.energy.iter().all(|e| e.abs() < 1e-12), "{lobe:?}");
            }
        }
    }
}

#[test]
fn index_matched_interfaces_and_empty_media_change_nothing() {
    let plain = material(FluxModel::TwoFlux, vec![dielectric(1.5, 0.2), conductor(COPPER_ETA, COPPER_KAPPA, 0.1)]);
    let padded = material(
        FluxModel::TwoFlux,
        vec![
            dielectric(1.5, 0.2),
            dielectric(1.5, 0.7),
            medium(0.0, [0.0; 3], 2.0, 0.0),
            medium(1.0, [1.0; 3], 0.0, 0.5),
            conductor(COPPER_ETA, COPPER_KAPPA, 0.1),
        ],
    );
    let tables = |l: &Lookup| match l.quantity {
        Quantity::Albedo => fresnel_reflectance(l.mu, l.eta, l.kappa) * (1.0 - 0.1 * l.alpha),
        Quantity::Tir => 0.2 * l.alpha,
        Quantity::Gd => 1.0 - 0.3 * l.alpha,
    };
    for mu in [1.0, 0.4, 0.0] {
        assert_eq!(plain.albedo(mu, &tables), padded.albedo(mu, &tables), "mu {mu}");
    }
}

#[test]
fn the_top_term_is_the_first_interfaces_own_albedo_and_internal_lobes_are_weighted_by_gd() {
    let m = material(FluxModel::TwoFlux, vec![dielectric(1.5, 0.3), conductor(COPPER_ETA, COPPER_KAPPA, 0.2)]);
    let gd = 0.8;
    let tables = |l: &Lookup| match l.quantity {
        Quantity::Albedo => fresnel_reflectance(l.mu, l.eta, l.kappa),
        Quantity::Tir => 0.0,
        Quantity::Gd => gd,
    };
    let e = m.evaluate(0.6, &tables);
    assert_eq!(e.top_albedo, [fresnel_reflectance(0.6, 1.5, 0.0); 3]);
    assert_eq!(e.lobes.len(), 2);
    assert!(e.lobes[0].is_top && !e.lobes[1].is_top);
    assert_eq!(e.lobes[1].gd, gd);
    for c in 0..3 {
        let expected = e.top_albedo[c] + e.lobes[1].energy[c] * gd;
        assert!((e.albedo[c] - expected).abs() < 1e-15);
    }
    // The 6-flux model normalises its lobes by GD: the same stack's albedo does not depend on it.
    let m6 = Material::new(FluxModel::SixFlux, m.stack.clone());
    let with_gd = |gd: f64| move |l: &Lookup| if l.quantity == Quantity::Gd { gd } else { tables(l) };
    assert_eq!(m6.albedo(0.6, &with_gd(0.5)), m6.albedo(0.6, &with_gd(0.9)));
}

#[test]
fn tir_moves_energy_from_transmission_to_reflection_on_the_side_of_the_lower_index() {
    // A coat of index 1.5 loses light upward (relative index 1 / 1.5 from below): with TIR = 1
    // nothing comes back out, and the albedo is the top reflection alone.
    let m = material(FluxModel::TwoFlux, vec![dielectric(1.5, 0.1), conductor(COPPER_ETA, COPPER_KAPPA, 0.1)]);
    let tables = |tir: f64| {
        move |l: &Lookup| match l.quantity {
            Quantity::Albedo => fresnel_reflectance(l.mu, l.eta, l.kappa),
            Quantity::Tir => {
                assert_eq!(l.site, Site::Up, "{l:?}");
                assert!((l.eta - 1.0 / 1.5).abs() < 1e-15);
                tir
            }
            Quantity::Gd => 1.0,
        }
    };
    let total = m.evaluate(0.8, &tables(1.0));
    assert!(total.albedo.iter().all(|a| a.is_finite()), "{total:?}");
    for c in 0..3 {
        assert!((total.albedo[c] - fresnel_reflectance(0.8, 1.5, 0.0)).abs() < 1e-12, "{total:?}");
    }
    let none = m.albedo(0.8, &tables(0.0));
    let half = m.albedo(0.8, &tables(0.5));
    for c in 0..3 {
        assert!(total.albedo[c] < half[c] && half[c] < none[c], "{:?} {half:?} {none:?}", total.albedo);
    }
    // Going down into a lower index the downward branch acts instead.
    let low = material(FluxModel::TwoFlux, vec![dielectric(0.7, 0.1), conductor(COPPER_ETA, COPPER_KAPPA, 0.1)]);
    let sites = std::cell::RefCell::new(Vec::new());
    low.albedo(0.5, &|l: &Lookup| {
        sites.borrow_mut().push((l.quantity, l.site));
        smooth_tables(l)
    });
    assert!(sites.borrow().contains(&(Quantity::Tir, Site::Down)), "{:?}", sites.borrow());
}

#[test]
fn every_lookup_is_made_at_the_parameters_the_reference_reads() {
    // Varnished copper: the coat is read at the view cosine, the copper at the refracted cosine
    // and its indices relative to the coat, the TIR upward at the refracted cosine and 1 / 1.1.
    let m = material(FluxModel::TwoFlux, vec![dielectric(1.1, 0.01), conductor(COPPER_ETA, COPPER_KAPPA, 0.01)]);
    let seen = std::cell::RefCell::new(Vec::new());
    let mu = 0.6;
    m.albedo(mu, &|l: &Lookup| {
        seen.borrow_mut().push(*l);
        smooth_tables(l)
    });
    let seen = seen.into_inner();
    let mu_t = factors::refracted_cosine(mu, 1.1);
    let coat: Vec<_> = seen.iter().filter(|l| l.layer == 1 && l.quantity == Quantity::Albedo).collect();
    assert_eq!(coat.len(), 1);
    assert_eq!((coat[0].mu, coat[0].alpha, coat[0].eta, coat[0].kappa, coat[0].channel), (mu, 0.01, 1.1, 0.0, None));
    let copper: Vec<_> = seen.iter().filter(|l| l.layer == 2 && l.quantity == Quantity::Albedo).collect();
    assert_eq!(copper.len(), 3);
    for (c, l) in copper.iter().enumerate() {
        assert_eq!(l.channel, Some(c));
        assert_eq!((l.mu, l.eta, l.kappa), (mu_t, COPPER_ETA[c] / 1.1, COPPER_KAPPA[c] / 1.1));
    }
    let tir: Vec<_> = seen.iter().filter(|l| l.quantity == Quantity::Tir).collect();
    assert_eq!(tir.len(), 1);
    assert_eq!((tir[0].site, tir[0].mu, tir[0].eta), (Site::Up, mu_t, 1.0 / 1.1));
    // The lobe's roughness: at least the copper's (its reflection's asymmetry multiplies in).
    assert!(tir[0].alpha >= 0.01 && tir[0].alpha < 0.1, "{:?}", tir[0]);
    let gd: Vec<_> = seen.iter().filter(|l| l.quantity == Quantity::Gd).collect();
    assert_eq!(gd.len(), 1);
    assert_eq!((gd[0].mu, gd[0].layer), (mu, 2));
}

/// Tables that answer at the edges of what they can: every FGD 1 or 0, TIR 1, GD 0 or 1.
fn stiff_tables(albedo: f64, tir: f64, gd: f64) -> impl Fn(&Lookup) -> f64 {
    move |l: &Lookup| match l.quantity {
        Quantity::Albedo => albedo,
        Quantity::Tir => tir,
        Quantity::Gd => gd,
    }
}

#[test]
fn stiff_stacks_give_finite_lobes_and_albedos() {
    let stacks: Vec<Vec<Layer>> = vec![
        vec![dielectric(1.0, 0.3), conductor(COPPER_ETA, COPPER_KAPPA, 0.1)],
        vec![dielectric(0.5, 0.0), dielectric(1.0, 1.0), conductor([1.0; 3], [1e4; 3], 0.0)],
        vec![dielectric(1.5, 1.0), medium(1.0, [0.0; 3], 1e6, 0.999), conductor(COPPER_ETA, COPPER_KAPPA, 0.0)],
        vec![dielectric(1.5, 0.4), medium(1.0, [0.0; 3], 1.0, -0.999), dielectric(1.2, 0.0)],
        vec![dielectric(1.5, 0.4), medium(0.0, [0.0, 1e3, 0.0], 1.0, 1.0), medium(5.0, [1e-9; 3], 1e9, -1.0)],
        vec![dielectric(4.0, 0.0); 8],
    ];
    let tables: Vec<Box<dyn Tables>> = vec![
        Box::new(smooth_tables),
        Box::new(stiff_tables(1.0, 1.0, 0.0)),
        Box::new(stiff_tables(0.0, 1.0, 1.0)),
        Box::new(stiff_tables(1.0, 0.0, 1.0)),
        Box::new(stiff_tables(0.5, 0.5, 0.5)),
    ];
    for layers in stacks {
        for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
            let m = material(model, layers.clone());
            for t in &tables {
                for mu in [0.0, 1e-7, 0.3, 1.0] {
                    let e = m.evaluate(mu, t.as_ref());
                    let finite = e.albedo.iter().all(|a| a.is_finite())
                        && e.lobes.iter().all(|l| l.energy.iter().all(|x| x.is_finite()) && l.asymmetry.is_finite());
                    assert!(finite, "{model:?} {layers:?} mu {mu}: {e:?}");
                }
            }
        }
    }
}

/// A medium's factors recorded and run in f32 (as the scene shader computes them) against f64,
/// where its asymmetry's slab reaches `gamma tau = 47.7`, past where `sinh^2` overflows f32
/// (`x = 44.4`): the slab's divided form keeps them finite and within f32 rounding.
#[test]
fn a_mediums_factors_in_f32_stay_finite_where_the_slabs_sinh_squared_would_overflow() {
    use crate::ir::record::{Recorded, record};
    let thick = Medium { sigma_s: [2.0; 3], sigma_k: [0.01; 3], depth: 1e3, g: -0.3 };
    let cpu = factors::medium(&thick, 1.0, true).expect("a scattering medium");
    let (recorded, tape) = record(|| factors::medium(&thick, Recorded::variable(0), true).expect("the same"));
    let mut values: Vec<f32> = Vec::new();
    tape.values_with(|_, _| 1.0f32, &mut values);
    let run = |r: Recorded| r.known_value().unwrap_or_else(|| f64::from(values[r.instruction()]));
    for (f32_flux, f64_flux) in [(recorded.r_fb, cpu.r_fb), (recorded.t_ff, cpu.t_ff), (recorded.t, cpu.t)] {
        for (r, e) in f32_flux.energy.iter().zip(f64_flux.energy) {
            assert!((run(*r) - e).abs() <= 1e-6 * e.abs().max(1e-30), "energy {} against {e}", run(*r));
        }
        let g = run(f32_flux.g);
        assert!(g.is_finite() && (g - f64_flux.g).abs() <= 1e-5, "asymmetry {g} against {}", f64_flux.g);
    }
}

#[test]
fn a_stand_in_region_holds_its_indices_and_meets_every_range_that_reaches_them() {
    let rarer = stand_in(crate::table::TableKind::FgdRarer).expect("fgd_rarer stands in for FGD");
    assert_eq!(rarer.quantity, Quantity::Albedo);
    let region = rarer.region;
    assert!(region.holds(0.7, 0.0) && region.holds(0.0, 0.0));
    assert!(
        !region.holds(1.0, 0.0) && !region.holds(1.5, 0.0) && !region.holds(0.7, 0.1) && !region.holds(f64::NAN, 0.0)
    );
    // Some index of the ranges in the region: eta below 1 somewhere, kappa 0 somewhere.
    assert!(region.meets([0.9, 1.2], [0.0, 0.0]));
    assert!(region.meets([0.8, 0.9], [0.0, 0.5]));
    assert!(!region.meets([1.0, 1.2], [0.0, 0.0]));
    assert!(!region.meets([0.8, 0.9], [0.1, 0.5]));
    // Every range meets the region exactly where one of its corners lies in it.
    for eta in [[0.5, 0.8], [0.9, 1.1], [1.0, 1.3]] {
        for kappa in [[0.0, 0.0], [0.0, 2.0], [0.5, 2.0]] {
            let corners = eta.iter().any(|&e| kappa.iter().any(|&k| region.holds(e, k)));
            assert_eq!(region.meets(eta, kappa), corners, "eta {eta:?}, kappa {kappa:?}");
        }
    }
}

#[test]
fn every_stand_in_is_a_3d_table_whose_axes_a_lookup_addresses() {
    // The folder reads a stand-in at the point its axes name and the scene shader reads it as a
    // 3D texture: a stand-in of another shape would be refused by the shader at generation time.
    let mut count = 0;
    for stand_in in stand_ins() {
        let axes: Vec<crate::table::Axis> = stand_in
            .table
            .shape()
            .axes
            .iter()
            .map(|names| crate::table::Axis::node_aligned(names[0], 0.0, 0.5, 2).unwrap())
            .collect();
        assert_eq!(axes.len(), 3, "{}", stand_in.table.name());
        assert!(
            crate::table::derived::point_of(&axes, 0.5, 0.1, 0.7, 0.0).is_some(),
            "{}: an axis no lookup addresses",
            stand_in.table.name()
        );
        assert!(matches!(stand_in.quantity, Quantity::Albedo | Quantity::Tir), "{}", stand_in.table.name());
        count += 1;
    }
    assert!(count >= 1);
}
