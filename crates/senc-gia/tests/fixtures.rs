//! Penetration volumes and crossing face pairs against libigl's exact arrangement
//! (reference answers committed under `tests/fixtures/`, computed offline; see its README).

use senc_geom::intersect::self_intersections;
use senc_geom::shapes::fixture;
use senc_geom::{close_holes, HoleSelection};
use senc_gia::{GiaOptions, GiaWorkspace};

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
