//! Known-answer, invariance and gradient tests of the penetration volume.

use nalgebra::{Rotation3, Vector3};
use senc_geom::{close_holes, HoleSelection, TriMesh, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, Gradients, Penetration, SizeRule, VolumeRule};
use senc_testmesh::{grid_box, icosphere, jitter, merge, rigid_transform, turned_over};

fn pen(mesh: &TriMesh, opts: &GiaOptions) -> Penetration {
    let closure = close_holes(mesh, &HoleSelection::All).unwrap();
    GiaWorkspace::new(&closure).penetration(&closure, opts).unwrap()
}

fn two_boxes(offset: Vec3, n: usize) -> TriMesh {
    let a = grid_box(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), n).unwrap();
    let b = grid_box(offset, offset + Vec3::new(1.0, 1.0, 1.0), n).unwrap();
    merge(&a, &b).unwrap()
}

fn overlap(offset: Vec3) -> f64 {
    offset.iter().map(|d| (1.0 - d.abs()).max(0.0)).product()
}

#[test]
fn overlapping_boxes_give_the_exact_overlap() {
    for (offset, n) in [
        (Vec3::new(0.5, 0.25, 0.25), 1),
        (Vec3::new(0.3, 0.2, -0.1), 2),
        (Vec3::new(0.5, 0.5, 0.5), 3), // grid-made
    ] {
        let m = two_boxes(offset, n);
        let expect = overlap(offset);
        for size_rule in [SizeRule::Faces, SizeRule::Area] {
            let opts = GiaOptions { rule: VolumeRule::SmallerSide, size_rule, ..Default::default() };
            let p = pen(&m, &opts);
            assert!(
                (p.volume - expect).abs() <= 1e-9 * expect,
                "offset {offset:?} n {n}: {} vs {expect}, {:?}",
                p.volume,
                p.diagnostics
            );
            assert_eq!(p.regions.len(), 1, "{:?}", p.diagnostics);
        }
        let p = pen(&m, &GiaOptions::default());
        assert!((p.volume - expect).abs() <= 1e-9 * expect, "winding, offset {offset:?}: {} vs {expect}", p.volume);
        // The part of each box inside the other: winding 1 outside it, 2 inside.
        let weighted: Vec<_> = p.patches.iter().filter(|q| q.weight != 0).collect();
        assert_eq!(weighted.len(), 2, "{:?}", p.patches);
        assert!(weighted.iter().all(|q| q.winding_outside == 1 && q.weight == 1));
        assert_eq!(p.diagnostics.patches_skipped, 0);
    }
}

#[test]
fn gradients_left_out_change_nothing_else() {
    // Two boxes overlapping (both rules answer) and the same boxes with an open hole (the
    // winding rule's virtual closure pulls the gradients back).
    let boxes = two_boxes(Vec3::new(0.3, 0.2, -0.1), 2);
    let mut open = boxes.faces().to_vec();
    open.remove(0);
    let open = TriMesh::new(boxes.positions().to_vec(), open).unwrap();
    for (mesh, selection, closed) in [(&boxes, HoleSelection::All, true), (&open, HoleSelection::None, false)] {
        let closure = close_holes(mesh, &selection).unwrap();
        for rule in [VolumeRule::Winding, VolumeRule::SmallerSide] {
            let query = |gradients| {
                let opts = GiaOptions { rule, gradients, ..Default::default() };
                GiaWorkspace::new(&closure).penetration(&closure, &opts).unwrap()
            };
            let all = query(Gradients::VolumeAndArea);
            // SENC's rule may skip a contour that reaches the open hole.
            assert!(all.volume > 0.01 || (rule == VolumeRule::SmallerSide && !closed), "{rule:?}");
            assert_eq!(all.gradient.len(), mesh.n_vertices());
            assert_eq!(all.area_gradient.len(), mesh.n_vertices());
            let volume_only = query(Gradients::Volume);
            assert_eq!((volume_only.volume, volume_only.area), (all.volume, all.area), "{rule:?}");
            assert_eq!(volume_only.gradient, all.gradient, "{rule:?}");
            assert!(volume_only.area_gradient.is_empty());
            let none = query(Gradients::None);
            assert_eq!((none.volume, none.area), (all.volume, all.area), "{rule:?}");
            assert!(none.gradient.is_empty() && none.area_gradient.is_empty());
            assert_eq!(none.diagnostics.patches_skipped, all.diagnostics.patches_skipped);
        }
    }
}

#[test]
fn jittered_boxes_stay_close_to_the_exact_overlap() {
    let m = jitter(&two_boxes(Vec3::new(0.5, 0.5, 0.5), 4), 1e-9, 3).unwrap();
    let p = pen(&m, &GiaOptions::default());
    assert!((p.volume - 0.125).abs() < 1e-7, "{} {:?}", p.volume, p.diagnostics);
}

#[test]
fn separate_and_touching_boxes_have_zero_volume() {
    for offset in [Vec3::new(2.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)] {
        for n in [1, 3] {
            let p = pen(&two_boxes(offset, n), &GiaOptions::default());
            assert!(p.volume.abs() < 1e-12, "offset {offset:?}: {} {:?}", p.volume, p.diagnostics);
        }
    }
}

#[test]
fn volume_does_not_depend_on_the_origin_and_is_rigid_invariant() {
    let m = two_boxes(Vec3::new(0.3, 0.2, -0.1), 2);
    let base = pen(&m, &GiaOptions::default());
    let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let moved = rigid_transform(&m, &rot, &Vector3::new(10.0, -3.0, 7.0)).unwrap();
    let p = pen(&moved, &GiaOptions::default());
    assert!((p.volume - base.volume).abs() < 1e-9 * base.volume, "{} vs {}", p.volume, base.volume);
}

#[test]
fn overlapping_icospheres_are_close_to_the_lens_volume() {
    // Two spheres of radius r at distance d overlap in a lens of volume
    // π (4r + d)(2r − d)² / 12; the tessellation makes the mesh answer slightly smaller.
    let (r, d) = (1.0, 1.0);
    let a = icosphere(Vec3::zeros(), r, 3).unwrap();
    let b = icosphere(Vec3::new(d, 0.0, 0.0), r, 3).unwrap();
    let p = pen(&merge(&a, &b).unwrap(), &GiaOptions::default());
    let lens = std::f64::consts::PI * (4.0 * r + d) * (2.0 * r - d).powi(2) / 12.0;
    assert!((p.volume - lens).abs() < 0.03 * lens, "{} vs {lens} {:?}", p.volume, p.diagnostics);
}

fn gradient_check(m: &TriMesh, mode: GradientMode) {
    gradient_check_with_step(m, mode, 1e-6);
}

fn gradient_check_with_step(m: &TriMesh, mode: GradientMode, h: f64) {
    let opts = GiaOptions { gradient: mode, ..Default::default() };
    let base = pen(m, &opts);
    assert!(base.volume > 0.0);
    let scale = base.gradient.iter().map(|g| g.norm()).fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    for v in 0..m.n_vertices() {
        for k in 0..3 {
            let eval = |s: f64| {
                let mut p = m.positions().to_vec();
                p[v][k] += s;
                let mm = m.with_positions(p).unwrap();
                match mode {
                    GradientMode::Exact => pen(&mm, &opts).volume,
                    GradientMode::FixedBarycentric => fixed_weight_volume(m, &mm),
                }
            };
            let fd = (eval(h) - eval(-h)) / (2.0 * h);
            if (fd - base.gradient[v][k]).abs() > 1e-5 * scale {
                eprintln!("{mode:?} v {v} k {k}: fd {fd} analytic {}", base.gradient[v][k]);
            }
            worst = worst.max((fd - base.gradient[v][k]).abs());
        }
    }
    assert!(worst <= 1e-5 * scale, "{mode:?}: worst error {worst} vs gradient scale {scale}");
}

/// SENC's definition: the volume with the intersection points' weights frozen at `base`.
fn fixed_weight_volume(base: &TriMesh, moved: &TriMesh) -> f64 {
    let closure0 = close_holes(base, &HoleSelection::All).unwrap();
    let inter = senc_geom::intersect::self_intersections(closure0.mesh());
    let closure = close_holes(moved, &HoleSelection::All).unwrap();
    let opts = GiaOptions { gradient: GradientMode::FixedBarycentric, ..Default::default() };
    GiaWorkspace::new(&closure).analyse(&closure, &inter, &opts).volume
}

#[test]
fn exact_gradient_matches_finite_differences() {
    gradient_check(&two_boxes(Vec3::new(0.3, 0.2, -0.1), 1), GradientMode::Exact);
    gradient_check(&jitter(&two_boxes(Vec3::new(0.45, 0.35, 0.25), 2), 1e-3, 5).unwrap(), GradientMode::Exact);
}

#[test]
fn fixed_barycentric_gradient_matches_its_own_finite_differences() {
    gradient_check(&two_boxes(Vec3::new(0.3, 0.2, -0.1), 1), GradientMode::FixedBarycentric);
}

#[test]
fn gradient_has_no_net_force_or_torque() {
    let m = jitter(&two_boxes(Vec3::new(0.45, 0.35, 0.25), 2), 1e-3, 9).unwrap();
    for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
        let p = pen(&m, &GiaOptions { gradient: mode, ..Default::default() });
        let force: Vec3 = p.gradient.iter().sum();
        let torque: Vec3 = p.gradient.iter().zip(m.positions()).map(|(g, x)| x.cross(g)).sum();
        let scale = p.gradient.iter().map(|g| g.norm()).sum::<f64>();
        assert!(force.norm() < 1e-9 * scale, "{mode:?} force {force:?}");
        assert!(torque.norm() < 1e-9 * scale, "{mode:?} torque {torque:?}");
    }
}

/// `mesh` with every face turned over: winding −1 inside.
fn inverted(mesh: &TriMesh) -> TriMesh {
    turned_over(mesh).unwrap()
}

/// `mesh` with x and y swapped (the unit cube maps onto itself with its faces' diagonals
/// turned), turned over so that its normals stay outward.
fn mirrored(mesh: &TriMesh) -> TriMesh {
    inverted(&mesh.with_positions(mesh.positions().iter().map(|p| Vec3::new(p.y, p.x, p.z)).collect()).unwrap())
}

/// Exactly degenerate box arrangements whose volume is known by hand: surfaces that
/// coincide wholly (the same box twice, once with its diagonals turned, three times, once
/// inverted), boxes inside boxes sharing faces and corners, staggered stacks, and inverted
/// boxes (negative winding counts as penetration). Every one is exact with nothing skipped.
#[test]
fn coincident_and_stacked_boxes_give_their_hand_computed_volumes() {
    let cube = |lo: [f64; 3], hi: [f64; 3], n: usize| grid_box(Vec3::from(lo), Vec3::from(hi), n).unwrap();
    let union = |parts: &[TriMesh]| parts[1..].iter().fold(parts[0].clone(), |m, p| merge(&m, p).unwrap());
    let unit = cube([0.0; 3], [1.0; 3], 1);
    let cases: Vec<(&str, TriMesh, f64)> = vec![
        ("the same box twice", union(&[unit.clone(), unit.clone()]), 1.0),
        ("the same box, diagonals turned", union(&[unit.clone(), mirrored(&unit)]), 1.0),
        ("the same box three times", union(&[unit.clone(), mirrored(&unit), cube([0.0; 3], [1.0; 3], 2)]), 1.0),
        ("the same box, once inverted", union(&[unit.clone(), inverted(&unit)]), 0.0),
        ("an inverted box inside", union(&[unit.clone(), inverted(&cube([0.25; 3], [0.75; 3], 1))]), 0.0),
        ("an inverted box half out", union(&[unit.clone(), inverted(&cube([0.5, 0.0, 0.0], [1.5, 1.0, 1.0], 1))]), 0.5),
        ("a box in a corner of a box", union(&[cube([0.0; 3], [2.0; 3], 1), unit.clone()]), 1.0),
        (
            "a box on the floor of a box",
            union(&[cube([0.0; 3], [2.0; 3], 2), cube([0.5, 0.5, 0.0], [1.5, 1.5, 1.0], 1)]),
            1.0,
        ),
        ("a quarter, two faces shared", union(&[unit.clone(), cube([0.5, 0.5, 0.0], [1.5, 1.5, 1.0], 2)]), 0.25),
        ("corners on an edge", union(&[unit.clone(), mirrored(&cube([0.5; 3], [1.5; 3], 1))]), 0.125),
        (
            "three boxes, shared corners",
            union(&[unit.clone(), cube([0.5; 3], [1.5; 3], 1), cube([0.5, 0.0, 0.0], [1.5, 1.0, 1.0], 2)]),
            0.625,
        ),
        (
            "four staggered boxes",
            union(&[
                unit.clone(),
                cube([0.25, 0.0, 0.0], [1.25, 1.0, 1.0], 1),
                cube([0.5, 0.0, 0.0], [1.5, 1.0, 1.0], 2),
                cube([0.75, 0.0, 0.0], [1.75, 1.0, 1.0], 1),
            ]),
            1.25,
        ),
    ];
    for (name, mesh, expect) in cases {
        for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
            let p = pen(&mesh, &GiaOptions { gradient: mode, ..Default::default() });
            let d = &p.diagnostics;
            assert!((p.volume - expect).abs() <= 1e-9, "{name} ({mode:?}): {} vs {expect}, {d:?}", p.volume);
            assert_eq!(d.patches_skipped + d.groups_skipped + d.complex_faces, 0, "{name}: {d:?}");
            assert!(p.gradient.iter().all(|g| g.iter().all(|c| c.is_finite())), "{name}: gradient not finite");
        }
    }
}

/// Known limitation: exactly coplanar overlapping faces (boxes sharing face planes) give
/// interior loops whose host piece is found by a float point-in-polygon test, which is
/// unreliable when every point lies on the face's lines. The answer must never be a silent
/// wrong one: either the exact value or a reported skip.
#[test]
fn coplanar_overlaps_are_exact_or_reported() {
    for (offset, n) in [(Vec3::new(0.0, 0.5, 0.0), 1), (Vec3::new(0.0, 0.5, 0.0), 2), (Vec3::new(0.25, 0.5, 0.0), 2)] {
        let m = two_boxes(offset, n);
        let p = pen(&m, &GiaOptions::default());
        let d = &p.diagnostics;
        let exact = (p.volume - overlap(offset)).abs() <= 1e-9;
        assert!(
            exact || d.fills_met + d.fills_tied + d.groups_skipped + d.complex_faces + d.patches_skipped > 0,
            "{} {d:?}",
            p.volume
        );
    }
}

/// Central finite differences of the volume against the analytic gradient on a named
/// fixture, over a sample of vertices (every vertex of a crossing face and a stride of the
/// rest), in both gradient modes, with no net force and no net torque.
fn fixture_gradient_check(name: &str) {
    fixture_gradient_check_with(name, &HoleSelection::All, &[GradientMode::Exact, GradientMode::FixedBarycentric]);
}

/// [`fixture_gradient_check`] with the fixture's holes closed by `selection` (holes left open
/// are closed virtually, see senc_gia's docs) in the given modes. The fixed-weight mode is
/// checked against SENC's frozen-weight volume ([`fixed_weight_volume`]), which needs every
/// hole closed.
fn fixture_gradient_check_with(name: &str, selection: &HoleSelection, modes: &[GradientMode]) {
    gradient_check_on(name, &senc_testmesh::fixture(name).unwrap(), selection, modes, 60);
}

/// [`fixture_gradient_check_with`] on any mesh (`name` for the messages), sampling about
/// `samples` vertices of crossing faces.
fn gradient_check_on(name: &str, mesh: &TriMesh, selection: &HoleSelection, modes: &[GradientMode], samples: usize) {
    let pen_sel = |m: &TriMesh, opts: &GiaOptions| {
        let closure = close_holes(m, selection).unwrap();
        GiaWorkspace::new(&closure).penetration(&closure, opts).unwrap()
    };
    let closed = close_holes(mesh, &HoleSelection::All).unwrap();
    let inter = senc_geom::intersect::self_intersections(closed.mesh());
    let n = mesh.n_vertices() as u32;
    let mut crossing: Vec<u32> = inter
        .segments
        .iter()
        .flat_map(|s| s.faces)
        .flat_map(|f| closed.mesh().faces()[f as usize])
        .filter(|&v| v < n)
        .collect();
    crossing.sort_unstable();
    crossing.dedup();
    let sample: Vec<u32> = crossing.iter().copied().step_by(crossing.len().div_ceil(samples).max(1)).collect();
    for &mode in modes {
        let opts = GiaOptions { gradient: mode, ..Default::default() };
        let base = pen_sel(mesh, &opts);
        assert!(base.volume > 0.0 && base.diagnostics.patches_skipped == 0, "{name}: {:?}", base.diagnostics);
        let scale = base.gradient.iter().map(|g| g.norm()).fold(0.0, f64::max);
        let h = 1e-7;
        let mut worst: f64 = 0.0;
        for &v in &sample {
            for k in 0..3 {
                let eval = |s: f64| {
                    let mut p = mesh.positions().to_vec();
                    p[v as usize][k] += s;
                    let moved = mesh.with_positions(p).unwrap();
                    match mode {
                        GradientMode::Exact => pen_sel(&moved, &opts).volume,
                        GradientMode::FixedBarycentric => fixed_weight_volume(mesh, &moved),
                    }
                };
                let (hi, lo) = (eval(h), eval(-h));
                let fd = (hi - lo) / (2.0 * h);
                if (fd - base.gradient[v as usize][k]).abs() > 1e-5 * scale {
                    eprintln!("{name} {mode:?} v {v} k {k}: +h {hi} -h {lo} base {}", base.volume);
                }
                worst = worst.max((fd - base.gradient[v as usize][k]).abs());
            }
        }
        assert!(worst <= 1e-5 * scale, "{name} {mode:?}: worst error {worst} vs gradient scale {scale}");
        assert_rigid_invariant(name, mesh, &base.gradient);
    }
}

/// The volume does not change under translation and rotation, so its gradient has no net
/// force `Σ g_i` and no net torque `Σ x_i × g_i`.
fn assert_rigid_invariant(name: &str, mesh: &TriMesh, gradient: &[Vec3]) {
    let force: Vec3 = gradient.iter().sum();
    let torque: Vec3 = gradient.iter().zip(mesh.positions()).map(|(g, x)| x.cross(g)).sum();
    let total = gradient.iter().map(|g| g.norm()).sum::<f64>();
    assert!(total > 0.0, "{name}: zero gradient");
    assert!(force.norm() < 1e-9 * total, "{name} force {force:?}");
    assert!(torque.norm() < 1e-9 * total, "{name} torque {torque:?}");
}

/// The tangle fixtures: a tube through a box (an annulus between two contours), three
/// nested boxes (winding 3), a tube folded through its elbow, a crumpled sphere and tube
/// (triple points).
#[test]
fn gradients_of_the_tangle_fixtures_match_finite_differences() {
    for name in ["tube_through_box", "nested_boxes", "elbow_fold", "crumpled_sphere", "crumpled_tube"] {
        fixture_gradient_check(name);
    }
}

/// Simulated garment frames of garment types and a motion the other fixtures do not use
/// (`tests/fixtures/garment_frames/`: pants with 1,574 crossing pairs, a dress with 623),
/// every hole fanned.
#[test]
fn gradients_of_tangled_garment_frames_match_finite_differences() {
    for garment in ["pants", "dress"] {
        let mesh = senc_testmesh::garment_frame(garment, 90).unwrap();
        let modes = [GradientMode::Exact, GradientMode::FixedBarycentric];
        gradient_check_on(&format!("{garment} 90"), &mesh, &HoleSelection::All, &modes, 20);
    }
}

/// Boxes through a hole: with the hole fanned, and left open (closed by the virtual fan,
/// whose centroid's gradient is shared by the loop), exact mode. The fixed-weight mode is
/// checked for rigid invariance only: its reference, the volume with the crossings frozen
/// at the base positions, finds inconsistent walls at ±h here (the crossings with the
/// single large faces of the outer box change side tests when a corner moves), so it has no
/// usable finite difference.
#[test]
fn gradients_through_an_open_hole_match_finite_differences() {
    for selection in [HoleSelection::All, HoleSelection::None] {
        fixture_gradient_check_with("open_box_pierced", &selection, &[GradientMode::Exact]);
        let mesh = senc_testmesh::fixture("open_box_pierced").unwrap();
        let closure = close_holes(&mesh, &selection).unwrap();
        let opts = GiaOptions { gradient: GradientMode::FixedBarycentric, ..Default::default() };
        let p = GiaWorkspace::new(&closure).penetration(&closure, &opts).unwrap();
        assert_rigid_invariant("open_box_pierced", &mesh, &p.gradient);
    }
}

/// `equal_boxes_half` is not FD-checked: its boxes share face planes up to the 1e-9 jitter,
/// so the volume is not smooth on the scale of any usable finite-difference step (a step
/// of 1e-7 moves faces through each other's planes). Its gradient must still be free of net
/// force and torque in both modes, and point outward on the overlap's walls: moving the
/// second box's wall inside the first (x = 0.5) towards +x shrinks the overlap by its area.
#[test]
fn equal_boxes_gradient_has_no_net_force_or_torque() {
    let mesh = senc_testmesh::fixture("equal_boxes_half").unwrap();
    for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
        let p = pen(&mesh, &GiaOptions { gradient: mode, ..Default::default() });
        assert_rigid_invariant("equal_boxes_half", &mesh, &p.gradient);
        // Exactly: dV/dx summed over the vertices of the wall x ≈ 0.5 is −(its area inside
        // box A) = −1. (Fixed weights move part of it onto box A's vertices.)
        if mode == GradientMode::Exact {
            let wall: f64 = mesh
                .positions()
                .iter()
                .zip(&p.gradient)
                .filter(|(x, _)| (x.x - 0.5).abs() < 1e-6)
                .map(|(_, g)| g.x)
                .sum();
            assert!((wall + 1.0).abs() < 1e-6, "{mode:?}: wall force {wall}");
        }
    }
}

/// Equal boxes overlapping by half as in `equal_boxes_half` (5 cells a side), jittered by
/// 1e-4 of the diagonal instead of 1e-9: their coplanar faces (floor, ceiling, side walls)
/// now sit about 1e-4 m apart, so the volume is smooth within the finite-difference step
/// (1e-8 m; at 1e-6 m kinks of the jittered contours fall inside the stencil), while every
/// contour's two sides still nearly tie. Both gradient modes match central differences at
/// every vertex.
#[test]
fn equal_boxes_jittered_past_the_step_match_finite_differences() {
    let a = grid_box(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), 5).unwrap();
    let b = grid_box(Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.5, 1.0, 1.0), 5).unwrap();
    let m = jitter(&merge(&a, &b).unwrap(), 1e-4, 11).unwrap();
    assert!((pen(&m, &GiaOptions::default()).volume - 0.5).abs() < 1e-3);
    gradient_check_with_step(&m, GradientMode::Exact, 1e-8);
    gradient_check_with_step(&m, GradientMode::FixedBarycentric, 1e-8);
}

/// A flat sheet closed by the fan over its boundary: the fan lies in the sheet's plane and
/// overlaps it. Exactly flat, every crossing between the two is decided by the perturbation
/// alone and every probe point lies on a coplanar face, so the winding numbers are
/// unresolved and the query is re-run on jittered positions (`senc_gia::PERTURBATIONS`),
/// where the cells the sheet encloses with the fan are flat. Bent out of its plane by
/// rounding-level noise (1e-14 m) they are flat too (`winding::FLAT_THICKNESS`). Either
/// way: volume and gradient 0, nothing skipped. Bent by more, the
/// volume scales with the noise and the gradient stays bounded by the areas of the cells
/// (the one-sided derivative `dV/dn = area`), in both modes, never the inverse of a
/// vanishing angle.
#[test]
fn a_flat_sheet_closed_by_its_coplanar_fan_has_a_bounded_gradient() {
    let (n, size) = (6usize, 0.5);
    let h = size / n as f64;
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push(Vec3::new(i as f64 * h - 0.5 * size, 1.0, j as f64 * h - 0.5 * size));
        }
    }
    let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            if (i + j) % 2 == 0 {
                faces.extend([[a, d, c], [a, c, b]]);
            } else {
                faces.extend([[a, d, b], [b, d, c]]);
            }
        }
    }
    let flat = TriMesh::new(pos, faces).unwrap();
    let area = size * size;
    let mut rng = 12345u64;
    for noise in [0.0, 1e-14, 1e-9, 1e-6] {
        let moved: Vec<Vec3> = flat
            .positions()
            .iter()
            .map(|p| {
                rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let r = (rng >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
                p + Vec3::new(0.0, r * noise, 0.0)
            })
            .collect();
        let m = flat.with_positions(moved).unwrap();
        for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
            let p = pen(&m, &GiaOptions { gradient: mode, ..Default::default() });
            let g = p.gradient.iter().map(|v| v.norm()).fold(0.0, f64::max);
            let d = &p.diagnostics;
            assert!(p.volume >= 0.0 && p.volume <= noise * area, "{noise} {mode:?}: volume {} {d:?}", p.volume);
            assert!(g <= area, "{noise} {mode:?}: gradient {g} for volume {} {d:?}", p.volume);
            if noise < 1e-12 {
                assert!(p.volume == 0.0 && g == 0.0 && d.patches_skipped == 0 && d.flat_tangles > 0, "{d:?}");
                assert_eq!(d.perturbed_retries > 0, noise == 0.0, "{d:?}");
            } else {
                assert!(p.volume > 0.0 && g > 0.0 && d.patches_skipped == 0, "{noise} {mode:?}: {d:?}");
            }
        }
    }
}
