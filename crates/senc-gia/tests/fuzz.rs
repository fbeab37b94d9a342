//! Fuzz-style robustness: 10⁴ random and degenerate closed meshes (crumpled icospheres,
//! snapped to a coarse grid so that exact coincidences abound, collapsed vertices, open
//! holes left open or closed). Nothing may panic, and every volume and gradient is finite.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::{close_holes, HoleSelection, TriMesh, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, SizeRule, VolumeRule};
use senc_testmesh::{icosphere, tube, Caps};

/// Crumpled positions, and whether they are in general position (neither snapped nor
/// collapsed).
fn crumple(base: &TriMesh, rng: &mut ChaCha8Rng) -> (Vec<Vec3>, bool) {
    let amp: f64 = rng.random_range(0.0..0.8);
    let snap = rng.random_bool(0.4);
    let collapse = rng.random_bool(0.1);
    let mut p: Vec<Vec3> = base
        .positions()
        .iter()
        .map(|x| {
            let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let mut y = x + d * amp;
            if snap {
                y = y.map(|c| (c * 4.0).round() / 4.0);
            }
            y
        })
        .collect();
    if collapse {
        // Several vertices on one point: zero-area faces mid-simulation.
        let target = p[0];
        for q in p.iter_mut().take(5) {
            *q = target;
        }
    }
    (p, !snap && !collapse)
}

#[test]
fn ten_thousand_random_meshes_never_panic_or_give_nan() {
    let sphere = icosphere(Vec3::zeros(), 1.0, 1).unwrap();
    let open_tube = tube(0.5, 1.5, 8, 4, Caps::Open).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let (mut n_positive, mut n_general_tangles) = (0, 0);
    for case in 0..10_000 {
        let base = if case % 2 == 0 { &sphere } else { &open_tube };
        let (positions, general) = crumple(base, &mut rng);
        let mesh = base.with_positions(positions).unwrap();
        let selection = match case % 3 {
            0 => HoleSelection::All,
            1 => HoleSelection::None,
            _ => HoleSelection::Only(vec![0]),
        };
        let Ok(closure) = close_holes(&mesh, &selection) else {
            // A fan over a collapsed loop can be refused as zero-area: a typed error is fine.
            continue;
        };
        let options = GiaOptions {
            gradient: if rng.random_bool(0.5) { GradientMode::Exact } else { GradientMode::FixedBarycentric },
            rule: if rng.random_bool(0.5) { VolumeRule::Winding } else { VolumeRule::SmallerSide },
            size_rule: if rng.random_bool(0.5) { SizeRule::Faces } else { SizeRule::Area },
            ..Default::default()
        };
        let p = GiaWorkspace::new(&closure).penetration(&closure, &options).unwrap();
        assert!(p.volume.is_finite(), "case {case}: volume {}", p.volume);
        // Holes left open are closed by virtual fans whose crossings count like any other
        // (see senc_gia's docs), so every volume is one: exact up to the rounding of the
        // tetrahedra sums (the meshes are about 2 m wide).
        assert!(p.volume >= -1e-12, "case {case}: volume {} {:?} {:?}", p.volume, options, p.diagnostics);
        if options.rule == VolumeRule::Winding {
            // The volume is a function of the geometry: both gradient modes measure the same
            // one (fixed-weight node positions would put the cuts of zero-area faces
            // elsewhere, and give negative volumes on grid-snapped meshes).
            let other = GradientMode::Exact;
            let q =
                GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions { gradient: other, ..options }).unwrap();
            assert!(
                (q.volume - p.volume).abs() <= 1e-9 * p.volume.abs().max(1e-3),
                "case {case}: {} in {:?} vs {} exact",
                p.volume,
                options.gradient,
                q.volume
            );
        }
        assert!(p.area.is_finite() && p.area >= 0.0, "case {case}: area {}", p.area);
        assert!(p.gradient.iter().chain(&p.area_gradient).all(|g| g.iter().all(|c| c.is_finite())), "case {case}");
        assert_eq!(p.gradient.len(), mesh.n_vertices());
        if p.volume > 0.0 {
            n_positive += 1;
        }
        // In general position every tangle of a closed surface is resolved: no face is too
        // complex to cut, every probe agrees, and nothing is skipped.
        if general && options.rule == VolumeRule::Winding && selection == HoleSelection::All {
            let d = &p.diagnostics;
            assert_eq!(d.patches_skipped + d.complex_faces + d.unresolved_groups, 0, "case {case}: {d:?}");
            n_general_tangles += usize::from(d.triple_points > 0);
        }
    }
    assert!(n_general_tangles > 100, "only {n_general_tangles} tangles in general position");
    // The generator must really produce penetrations, or the test proves little.
    assert!(n_positive > 1000, "only {n_positive} cases had a penetration");
}

/// Grid-snapped crumpled meshes (`tests/fixtures/snapped_cases.json`: coincident vertices,
/// faces of zero area, coplanar faces crossing) on which the unperturbed winding run skips
/// patches. `penetration` re-runs them on jittered positions (`senc_gia::PERTURBATIONS`)
/// until a run skips nothing; its volume is libigl's exact arrangement's to 1e-6, the same
/// in both gradient modes and on every call.
#[test]
fn grid_snapped_meshes_that_skip_are_measured_on_jittered_positions_to_libigl() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/snapped_cases.json");
    let answers: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let bases = [icosphere(Vec3::zeros(), 1.0, 1).unwrap(), tube(0.5, 1.5, 8, 4, Caps::Fan).unwrap()];
    for case in answers["cases"].as_array().unwrap() {
        let seed = case["seed"].as_u64().unwrap();
        let reference = case["penetration_volume_m3"].as_f64().unwrap();
        let mesh = senc_testmesh::crumple_snapped(&bases[(seed % 2) as usize], 0.6, 0.25, seed).unwrap();
        let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
        assert_eq!(closure.mesh().n_faces() as u64, case["n_faces"].as_u64().unwrap());
        let run = |gradient| {
            GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions { gradient, ..Default::default() }).unwrap()
        };
        let p = run(GradientMode::Exact);
        let d = &p.diagnostics;
        assert!(d.perturbed_retries > 0, "seed {seed}: the unperturbed run skipped nothing: {d:?}");
        assert_eq!(d.patches_skipped, 0, "seed {seed}: no re-run resolved it: {d:?}");
        assert!(p.gradient.iter().all(|g| g.iter().all(|c| c.is_finite())));
        assert!((p.volume - reference).abs() <= 1e-6 * reference, "seed {seed}: {} vs libigl {reference}", p.volume);
        assert_eq!(run(GradientMode::Exact).volume, p.volume, "seed {seed}: not deterministic");
        let q = run(GradientMode::FixedBarycentric);
        assert!((q.volume - p.volume).abs() <= 1e-9 * p.volume, "seed {seed}: {} fixed weights", q.volume);
    }
}
