//! Penetration volumes and crossing face pairs against libigl's exact arrangement
//! (reference answers committed under `tests/fixtures/`, computed offline; see its README).

use senc_geom::cut::CutMesh;
use senc_geom::intersect::{self_intersections, SelfIntersector};
use senc_geom::{close_holes, HoleSelection, TriMesh};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, VolumeRule};
use senc_testmesh::fixture;

fn answer(name: &str) -> serde_json::Value {
    let path = format!("{}/../../tests/fixtures/{name}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

fn volume(name: &str) -> (f64, senc_gia::Diagnostics) {
    let mesh = fixture(name).unwrap();
    let a = answer(name);
    let sel = if a["close_holes"].as_bool().unwrap_or(false) { HoleSelection::All } else { HoleSelection::None };
    let closure = close_holes(&mesh, &sel).unwrap();
    let p = GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap();
    (p.volume, p.diagnostics)
}

/// Check a volume fixture: `rel` is the allowed relative error (absolute below 1e-12 m³).
fn check(name: &str, rel: f64) {
    let expect = answer(name)["penetration_volume_m3"].as_f64().unwrap();
    let (got, diag) = volume(name);
    let err = (got - expect).abs();
    assert!(
        err <= rel * expect.abs() + 1e-12,
        "{name}: {got} vs libigl {expect} (rel {:.2e}) {diag:?}",
        err / expect.abs().max(1e-300)
    );
}

#[test]
fn jittered_boxes_match_libigl() {
    check("boxes_overlap_jitter", 1e-6);
    check("boxes_apart_jitter", 0.0);
    check("boxes_apart_grid", 0.0);
    check("boxes_touch_grid", 0.0);
}

#[test]
fn icospheres_match_libigl() {
    check("icospheres_overlap_jitter", 1e-6);
}

#[test]
fn bent_tube_matches_libigl() {
    check("bent_tube_jitter", 1e-6);
}

#[test]
fn sleeve_through_torso_matches_libigl() {
    check("sleeve_torso_jitter", 1e-6);
    check("garment_benchmark", 1e-6);
}

#[test]
fn crossing_face_pairs_match_libigl_on_generic_meshes() {
    for name in [
        "icospheres_overlap_jitter",
        "bent_tube_jitter",
        "sleeve_torso_jitter",
        "garment_benchmark",
        "folded_sheet_jitter",
    ] {
        let mesh = fixture(name).unwrap();
        let ours = self_intersections(&mesh).face_pairs();
        let theirs: Vec<[u32; 2]> = answer(name)["intersecting_face_pairs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_u64().unwrap() as u32, p[1].as_u64().unwrap() as u32])
            .collect();
        assert!(mesh.n_faces() >= 5000 || name.starts_with("boxes"));
        assert_eq!(ours, theirs, "{name}");
    }
}

#[test]
fn grid_made_fixtures_match_libigl_too() {
    // Exact degeneracies everywhere (lattice contacts, a mirror-symmetric sphere pair).
    for name in ["boxes_overlap_grid", "icospheres_overlap_grid", "bent_tube_grid", "sleeve_torso_grid"] {
        check(name, 1e-6);
    }
}

#[test]
fn tangles_without_a_smaller_side_match_their_exact_volumes() {
    // Equal boxes (both sides of each contour tie), a tube through a box (its wall inside is
    // an annulus between two contours), three boxes with winding 3 in their common core, a
    // tube folded back through its elbow: analytic answers where they exist, libigl's
    // arrangement otherwise, and the analytic ones agree with libigl too.
    for name in ["equal_boxes_half", "tube_through_box", "nested_boxes", "elbow_fold"] {
        check(name, 1e-6);
        let a = answer(name);
        if let Some(exact) = a["analytic_volume_m3"].as_f64() {
            let (got, _) = volume(name);
            assert!((got - exact).abs() <= 1e-6 * exact, "{name}: {got} vs analytic {exact}");
        }
        let (_, diag) = volume(name);
        assert_eq!(diag.patches_skipped + diag.perturbed_retries, 0, "{name}: {diag:?}");
        assert_eq!(diag.inconsistent_walls, 0, "{name}: {diag:?}");
    }
}

/// Randomly crumpled closed meshes in general position: faces holding a closed network of
/// crossing chords (triple points) that reaches no edge of the face, whose outline is a hole
/// of the piece around it. Both gradient modes, nothing skipped.
#[test]
fn crumpled_meshes_match_libigl_with_nothing_skipped() {
    for name in ["crumpled_sphere", "crumpled_tube"] {
        check(name, 1e-6);
        let closure = close_holes(&fixture(name).unwrap(), &HoleSelection::None).unwrap();
        for gradient in [GradientMode::Exact, GradientMode::FixedBarycentric] {
            let p = GiaWorkspace::new(&closure)
                .penetration(&closure, &GiaOptions { gradient, ..Default::default() })
                .unwrap();
            let d = &p.diagnostics;
            assert!(d.triple_points > 0, "{name}: {d:?}");
            assert_eq!(
                d.patches_skipped + d.inconsistent_walls + d.complex_faces + d.unresolved_groups + d.perturbed_retries,
                0,
                "{name}: {d:?}"
            );
        }
    }
}

/// On the single-contour fixtures the smaller-side rule was built for, both rules agree
/// wherever it answers. (On the tangles above it can also answer wrongly without a skip: on
/// `equal_boxes_half` the first side to run out is not the overlap.)
#[test]
fn the_smaller_side_rule_agrees_wherever_it_answers() {
    for name in [
        "boxes_overlap_jitter",
        "boxes_overlap_grid",
        "icospheres_overlap_jitter",
        "bent_tube_jitter",
        "sleeve_torso_jitter",
        "garment_benchmark",
    ] {
        let mesh = fixture(name).unwrap();
        let sel = if answer(name)["close_holes"].as_bool().unwrap_or(false) {
            HoleSelection::All
        } else {
            HoleSelection::None
        };
        let closure = close_holes(&mesh, &sel).unwrap();
        let winding = GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap();
        let opts = GiaOptions { rule: VolumeRule::SmallerSide, ..Default::default() };
        let flood = GiaWorkspace::new(&closure).penetration(&closure, &opts).unwrap();
        let d = &flood.diagnostics;
        if d.fills_met + d.fills_tied + d.groups_skipped == 0 {
            assert!(
                (flood.volume - winding.volume).abs() <= 1e-9 * winding.volume.abs().max(1e-12),
                "{name}: smaller side {} vs winding {}",
                flood.volume,
                winding.volume
            );
        }
    }
}

/// One simulated garment frame: positions and faces from `tests/fixtures/garment_frames/`.
fn garment_frame(garment: &str, frame: u64) -> TriMesh {
    senc_testmesh::garment_frame(garment, u32::try_from(frame).unwrap()).unwrap()
}

fn garment_answers() -> Vec<serde_json::Value> {
    let path = format!("{}/../../tests/fixtures/garment_frames/answers.json", env!("CARGO_MANIFEST_DIR"));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["frames"].as_array().unwrap().clone()
}

/// Every committed garment frame (tangles with up to 78 triple points, fans over tangled
/// holes crossing themselves) matches libigl to 1e-6 with nothing skipped, in both modes.
#[test]
fn garment_frames_match_libigl_with_nothing_skipped() {
    for a in garment_answers() {
        let (g, f) = (a["garment"].as_str().unwrap(), a["frame"].as_u64().unwrap());
        let mesh = garment_frame(g, f);
        assert_eq!(mesh.n_faces() as u64, a["n_faces"].as_u64().unwrap());
        let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
        let expect = a["penetration_volume_m3"].as_f64().unwrap();
        for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
            let p = GiaWorkspace::new(&closure)
                .penetration(&closure, &GiaOptions { gradient: mode, ..Default::default() })
                .unwrap();
            let d = &p.diagnostics;
            assert!((p.volume - expect).abs() <= 1e-6 * expect, "{g} {f}: {} vs libigl {expect} {d:?}", p.volume);
            assert_eq!(
                d.patches_skipped + d.inconsistent_walls + d.complex_faces + d.open_paths + d.perturbed_retries,
                0,
                "{g} {f}: {d:?}"
            );
            assert_eq!(d.intersecting_pairs as u64, a["intersecting_face_pairs_closed"].as_u64().unwrap(), "{g} {f}");
        }
    }
}

/// Faces are cut in chunks on rayon's threads and joined in face order with their crossing
/// nodes renumbered: the cut is the same on any number of threads (the chunks differ).
#[test]
fn garment_frames_cut_the_same_on_any_number_of_threads() {
    for (g, f) in [("tshirt", 20), ("skirt", 90)] {
        let mesh = garment_frame(g, f);
        let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
        let m = closure.mesh();
        let inter = SelfIntersector::new(m).find(m);
        let cut_on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| CutMesh::new(m, &inter))
        };
        let one = cut_on(1);
        assert!(one.crossings.len() >= 50, "{g} {f}: {} crossings", one.crossings.len());
        for threads in [2, 3, 7] {
            let c = cut_on(threads);
            assert_eq!(c.pieces, one.pieces, "{g} {f} on {threads} threads");
            assert_eq!(c.crossings, one.crossings, "{g} {f} on {threads} threads");
            assert_eq!(c.face_pieces, one.face_pieces, "{g} {f} on {threads} threads");
            for piece in &one.pieces {
                let (a, b) = (piece.cycles[0][0].0, piece.cycles[0][1].0);
                assert_eq!(c.piece_with_directed_edge(a, b), one.piece_with_directed_edge(a, b));
            }
        }
    }
}

/// Holes left open are closed virtually by fans to their centroids (crate docs, "Holes left
/// open"): on every committed garment frame, leaving any one hole open, or all of them,
/// gives libigl's answer with every hole fanned, skips nothing, and gives the gradient of
/// the closure that fans them (the same function of the garment's vertices).
#[test]
fn garment_frames_with_open_holes_measure_the_virtually_closed_surface() {
    for a in garment_answers() {
        let (g, f) = (a["garment"].as_str().unwrap(), a["frame"].as_u64().unwrap());
        let mesh = garment_frame(g, f);
        let expect = a["penetration_volume_m3"].as_f64().unwrap();
        let n_loops = mesh.topology().boundary_loops().len();
        assert!(n_loops >= 2, "{g}: {n_loops} loops");
        let all = close_holes(&mesh, &HoleSelection::All).unwrap();
        let closed = GiaWorkspace::new(&all).penetration(&all, &GiaOptions::default()).unwrap();
        let scale = closed.gradient.iter().map(|v| v.norm()).fold(0.0, f64::max);
        assert!(scale > 0.0, "{g} {f}");
        let mut selections: Vec<HoleSelection> = (0..n_loops).map(|i| HoleSelection::AllExcept(vec![i])).collect();
        selections.push(HoleSelection::None);
        for sel in selections {
            let closure = close_holes(&mesh, &sel).unwrap();
            let p = GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap();
            let d = &p.diagnostics;
            assert!(
                (p.volume - expect).abs() <= 1e-6 * expect,
                "{g} {f} {sel:?}: {} vs libigl {expect} {d:?}",
                p.volume
            );
            assert_eq!(d.patches_skipped + d.inconsistent_walls + d.unresolved_groups, 0, "{g} {f} {sel:?}: {d:?}");
            assert_eq!(d.intersecting_pairs, closed.diagnostics.intersecting_pairs, "{g} {f} {sel:?}");
            assert_eq!(p.gradient.len(), mesh.n_vertices());
            for (x, y) in p.gradient.iter().zip(&closed.gradient) {
                assert!((x - y).norm() <= 1e-9 * scale, "{g} {f} {sel:?}: {x:?} vs {y:?}");
            }
        }
    }
}

/// `open_box_pierced`: a unit box with its top left open (one square loop), pierced
/// through the opening by one closed box that touches no wall and by one that also crosses a
/// wall. With the opening left open, the first crosses only the virtual fan over it; the
/// volume is the parts below the opening (analytic, and libigl's arrangement with the hole
/// fanned), in both gradient modes, whether the hole is closed or left open.
#[test]
fn boxes_through_an_open_hole_are_measured_against_its_virtual_fan() {
    let name = "open_box_pierced";
    let mesh = fixture(name).unwrap();
    assert_eq!(mesh.topology().boundary_loops().len(), 1);
    let a = answer(name);
    let expect = a["penetration_volume_m3"].as_f64().unwrap();
    let exact = a["analytic_volume_m3"].as_f64().unwrap();
    assert!((expect - exact).abs() <= 1e-12, "libigl {expect} vs analytic {exact}");
    for sel in [HoleSelection::None, HoleSelection::All] {
        let closure = close_holes(&mesh, &sel).unwrap();
        for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
            let p = GiaWorkspace::new(&closure)
                .penetration(&closure, &GiaOptions { gradient: mode, ..Default::default() })
                .unwrap();
            let d = &p.diagnostics;
            assert!((p.volume - expect).abs() <= 1e-9, "{sel:?} {mode:?}: {} vs {expect} {d:?}", p.volume);
            assert_eq!(d.patches_skipped + d.inconsistent_walls, 0, "{d:?}");
            if sel == HoleSelection::None {
                assert!(d.virtual_fan_pairs > 0 && d.virtual_fan_pairs < d.intersecting_pairs, "{d:?}");
            } else {
                assert_eq!(d.virtual_fan_pairs, 0, "{d:?}");
            }
        }
    }
}
