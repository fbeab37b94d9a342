//! Tests of the generators and of the committed fixture answers.

use super::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn box_is_closed_with_exact_volume_and_counts() {
    let m = grid_box(v(-0.5, 0.0, 1.0), v(1.5, 0.75, 1.5), 5).unwrap();
    assert_eq!(m.n_faces(), 12 * 25);
    assert_eq!(m.n_vertices(), 6 * 25 + 2);
    assert!(m.topology().boundary_loops().is_empty());
    assert_eq!(m.topology().n_components(), 1);
    assert!(rel(m.signed_volume(), 2.0 * 0.75 * 0.5) < 1e-14, "{}", m.signed_volume());
    // n = 1: the 12-triangle cube.
    let c = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 1).unwrap();
    assert_eq!((c.n_faces(), c.n_vertices()), (12, 8));
    assert_eq!(c.signed_volume(), 1.0);
}

#[test]
fn box_vertices_are_on_the_exact_lattice() {
    let m = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 8).unwrap();
    for p in m.positions() {
        for x in p.iter() {
            assert_eq!((x * 8.0).fract(), 0.0, "{p:?}");
        }
    }
}

#[test]
fn icosphere_volume_between_inscribed_and_circumscribed_balls() {
    for level in 0..=4 {
        let (r, c) = (0.7, v(1.0, -2.0, 0.5));
        let m = icosphere(c, r, level).unwrap();
        assert_eq!(m.n_faces(), 20 * 4usize.pow(level as u32));
        assert!(m.topology().boundary_loops().is_empty());
        // Smallest distance from the centre to a face plane.
        let r_in = (0..m.n_faces())
            .map(|f| {
                let n = m.face_normal_scaled(f).normalize();
                let d = n.dot(&(m.triangle(f)[0] - c));
                assert!(d > 0.0, "face {f} not outward");
                d
            })
            .fold(f64::INFINITY, f64::min);
        let vol = m.signed_volume();
        let ball = |x: f64| 4.0 / 3.0 * PI * x.powi(3);
        assert!(vol > ball(r_in) && vol < ball(r), "level {level}: {vol}");
        if level == 4 {
            assert!(rel(vol, ball(r)) < 0.004, "{}", rel(vol, ball(r)));
        }
    }
}

#[test]
fn capped_tube_is_the_polygonal_prism() {
    let (r, l, n) = (0.3, 2.0, 17);
    let m = tube(r, l, n, 5, Caps::Fan).unwrap();
    assert!(m.topology().boundary_loops().is_empty());
    let prism = 0.5 * n as f64 * r * r * (TAU / n as f64).sin() * l;
    assert!(rel(m.signed_volume(), prism) < 1e-13);
    let open = tube(r, l, n, 5, Caps::Open).unwrap();
    assert_eq!(open.topology().boundary_loops().len(), 2);
    assert_eq!(open.n_faces(), 2 * 17 * 5);
    // Outward: every side face's normal points away from the axis.
    for f in 0..open.n_faces() {
        let [a, b, c] = open.triangle(f);
        let mid = (a + b + c) / 3.0;
        assert!(open.face_normal_scaled(f).dot(&v(mid.x, mid.y, 0.0)) > 0.0);
    }
}

#[test]
fn torus_volume_close_to_analytic() {
    let (big, small, n1, n2) = (1.0, 0.3, 64, 24);
    let m = torus(big, small, n1, n2).unwrap();
    assert!(m.topology().boundary_loops().is_empty());
    assert_eq!(m.n_faces(), 2 * n1 * n2);
    let exact = 2.0 * PI * PI * big * small * small;
    let tol = 1.5 * ((TAU / n1 as f64).powi(2) + (TAU / n2 as f64).powi(2)) / 6.0;
    let e = rel(m.signed_volume(), exact);
    assert!(e < tol, "{e} vs {tol}");
    // A finer torus is closer.
    let fine = torus(big, small, 2 * n1, 2 * n2).unwrap();
    assert!(rel(fine.signed_volume(), exact) < e / 3.0);
    assert!(torus(1.0, 1.0, 8, 8).is_err());
}

#[test]
fn bent_tube_is_closed_and_each_ring_sits_on_its_leg() {
    let m = bent_tube_grid().unwrap();
    assert!(m.topology().boundary_loops().is_empty());
    assert_eq!(m.n_faces(), 64 * 48 * 2 + 128);
    // Leg A: the z <= 0 half of the straight tube; leg B: the rest, rotated 135° about y
    // and shifted 0.02 along y.
    let d_b = Rotation3::from_axis_angle(&Vec3::y_axis(), 135f64.to_radians()) * Vec3::z();
    let (mut on_a, mut on_b) = (0, 0);
    for p in m.positions() {
        let q = p - Vec3::new(0.0, 0.02, 0.0);
        let to_b = q - d_b * q.dot(&d_b);
        if p.z <= 0.0 && (p.xy().norm() - 0.1).abs() < 1e-12 {
            on_a += 1;
        } else if q.dot(&d_b) > 0.0 && (to_b.norm() - 0.1).abs() < 1e-12 {
            on_b += 1;
        }
    }
    assert_eq!((on_a, on_b), (64 * 25, 64 * 24), "ring vertices off their leg");
    // The elbow's wedge changes the volume a little from the straight prism (each leg
    // keeps its own), never its sign.
    let prism = 0.5 * 64.0 * 0.01 * (TAU / 64.0).sin() * 1.2;
    assert!(rel(m.signed_volume(), prism) < 0.05, "{} vs {prism}", m.signed_volume());
    assert!(bent_tube(0.1, 0.6, PI, 0.0, 8, 2).is_err());
}

#[test]
fn sleeve_torso_has_four_holes_and_two_components() {
    let m = sleeve_torso_grid().unwrap();
    assert_eq!(m.topology().boundary_loops().len(), 4);
    assert_eq!(m.topology().n_components(), 2);
    assert_eq!(m.n_faces(), 96 * 32 * 2 + 32 * 16 * 2);
    // Closed by fans: both tubes become prisms; the signed volume is their sum.
    let closed = senc_geom::close_holes(&m, &senc_geom::HoleSelection::All).unwrap();
    let p = SleeveTorso::default();
    let prism = |r: f64, l: f64, n: usize| 0.5 * n as f64 * r * r * (TAU / n as f64).sin() * l;
    let expect = prism(p.torso_radius, p.torso_height, 96) + prism(p.sleeve_radius, 0.27, 32);
    assert!(rel(closed.mesh().signed_volume(), expect) < 1e-12);
}

#[test]
fn garment_benchmark_is_big_open_and_closable() {
    let m = garment_benchmark().unwrap();
    assert!(m.n_faces() >= 10_000);
    assert_eq!(m.n_faces(), 13_152);
    assert_eq!(m.topology().boundary_loops().len(), 4);
    assert_eq!(m.topology().n_components(), 2);
    let closed = senc_geom::close_holes(&m, &senc_geom::HoleSelection::All).unwrap();
    assert!(closed.mesh().signed_volume() > 0.0);
    // Deterministic.
    assert_eq!(garment_benchmark().unwrap().positions(), m.positions());
}

#[test]
fn sheets_have_one_loop_and_the_fold_dips_below() {
    let s = grid_sheet(2.0, 1.0, 4, 3).unwrap();
    assert_eq!(s.topology().boundary_loops().len(), 1);
    assert_eq!(s.topology().boundary_loops()[0].len(), 2 * (4 + 3));
    assert!((s.area() - 2.0).abs() < 1e-14);
    assert!((0..s.n_faces()).all(|f| s.face_normal_scaled(f).z > 0.0));
    let f = folded_sheet_grid().unwrap();
    assert_eq!(f.topology().boundary_loops().len(), 1);
    let zs: Vec<f64> = f.positions().iter().map(|p| p.z).collect();
    assert!(zs.iter().any(|&z| z < 0.0) && zs.iter().any(|&z| z > 0.0));
}

#[test]
fn jitter_is_seeded_small_and_validated() {
    let m = unit_box().unwrap();
    let a = jitter(&m, 1e-3, 5).unwrap();
    assert_eq!(a.positions(), jitter(&m, 1e-3, 5).unwrap().positions());
    assert_ne!(a.positions(), jitter(&m, 1e-3, 6).unwrap().positions());
    let d = m.bounding_diagonal();
    for (p, q) in m.positions().iter().zip(a.positions()) {
        assert!((p - q).amax() <= 1e-3 * d);
        assert!(p != q);
    }
    assert_eq!(jitter(&m, 0.0, 1).unwrap().positions(), m.positions());
    assert!(jitter(&m, f64::NAN, 1).is_err());
}

#[test]
fn rigid_transform_and_merge_keep_volumes() {
    let m = icosphere(v(0.0, 0.0, 0.0), 1.0, 2).unwrap();
    let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let t = rigid_transform(&m, &rot, &v(3.0, -4.0, 5.0)).unwrap();
    assert!(rel(t.signed_volume(), m.signed_volume()) < 1e-12);
    let both = merge(&m, &t).unwrap();
    assert_eq!(both.n_faces(), 2 * m.n_faces());
    assert_eq!(both.topology().n_components(), 2);
    assert!(rel(both.signed_volume(), 2.0 * m.signed_volume()) < 1e-12);
}

#[test]
fn bad_parameters_are_typed_errors() {
    assert!(matches!(grid_box(v(0.0, 0.0, 0.0), v(1.0, 0.0, 1.0), 2), Err(ShapeError::InvalidParameter { .. })));
    assert!(grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 0).is_err());
    assert!(icosphere(v(0.0, 0.0, 0.0), -1.0, 2).is_err());
    assert!(icosphere(v(0.0, 0.0, 0.0), f64::NAN, 2).is_err());
    assert!(tube(1.0, 1.0, 2, 1, Caps::Open).is_err());
    assert!(folded_sheet(1.0, 1).is_err());
    assert!(matches!(fixture("nope"), Err(ShapeError::UnknownFixture { .. })));
}

#[test]
fn every_fixture_builds_and_names_are_unique() {
    let mut names: Vec<&str> = FIXTURES.iter().map(|f| f.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), FIXTURES.len());
    for f in FIXTURES {
        let m = f.build().unwrap();
        // The crumpled meshes are small on purpose (every face in the tangle); the others
        // have over a thousand faces.
        let least = if f.name.starts_with("crumpled") { 80 } else { 1000 };
        assert!(m.n_faces() >= least, "{}", f.name);
    }
}

/// The committed answer files record each fixture's size and coordinate sums; a change
/// of generator that would silently invalidate the answers fails here.
#[test]
fn committed_fixture_answers_match_the_generators() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures");
    let mut checked = 0;
    for f in FIXTURES {
        let path = dir.join(format!("{}.json", f.name));
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e}; regenerate with tools/libigl_answers.py", path.display()));
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        let m = f.build().unwrap();
        assert_eq!(json["n_vertices"].as_u64(), Some(m.n_vertices() as u64), "{}", f.name);
        assert_eq!(json["n_faces"].as_u64(), Some(m.n_faces() as u64), "{}", f.name);
        let sum: f64 = m.positions().iter().map(|p| p.x + 2.0 * p.y + 3.0 * p.z).sum();
        let scale: f64 = m.positions().iter().map(|p| p.x.abs() + 2.0 * p.y.abs() + 3.0 * p.z.abs()).sum();
        let want = json["coordinate_checksum"].as_f64().unwrap();
        // Rounding and libm differences stay far below this; a 1e-9 jitter does not.
        assert!((sum - want).abs() <= 1e-13 * (1.0 + scale), "{}: {sum} vs {want}", f.name);
        // The answers themselves: pairs sorted, unique, in range; exact volumes match.
        let pairs: Vec<[u64; 2]> = json["intersecting_face_pairs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_u64().unwrap(), p[1].as_u64().unwrap()])
            .collect();
        assert_eq!(pairs.len() as u64, json["n_intersecting_face_pairs"].as_u64().unwrap());
        assert!(pairs.windows(2).all(|w| w[0] < w[1]), "{}: pairs not sorted", f.name);
        assert!(pairs.iter().all(|p| p[0] < p[1] && p[1] < m.n_faces() as u64), "{}", f.name);
        if let (Some(vol), Some(exact)) = (json["penetration_volume_m3"].as_f64(), json["analytic_volume_m3"].as_f64())
        {
            // A jittered fixture's analytic answer is that of the mesh before the jitter,
            // which moves the volume by about (surface area) × 1e-9 × (diagonal).
            let tol = if f.description.contains("jittered") { 1e-8 * exact } else { 1e-12 * exact.max(1.0) };
            assert!((vol - exact).abs() <= tol, "{}: {vol} vs {exact}", f.name);
        }
        checked += 1;
    }
    assert_eq!(checked, FIXTURES.len());
}

#[test]
fn garment_frames_load_and_a_missing_frame_is_a_typed_error() {
    let shirt = garment_frame("tshirt", 20).unwrap();
    assert!(shirt.n_faces() > 10_000, "{} faces", shirt.n_faces());
    assert!(matches!(garment_frame("tshirt", 9_999), Err(ShapeError::GarmentFrame { .. })));
    assert!(matches!(garment_frame("no_such_garment", 20), Err(ShapeError::GarmentFrame { .. })));
}
