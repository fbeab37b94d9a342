//! The garment fit (`senc_scene::fit`) on OBJ files made from the committed garments (built
//! from registry meshes): broken the way exported files are broken, they are repaired,
//! reported and fitted as the clean ones are; several garments in one file are picked by
//! name, by size or one by one; what cannot be repaired is refused. Garments already on the
//! body stay where they are; garments moved away are aligned by their top opening, with
//! small holes ignored, and their sleeves turned to the arms only when they hang otherwise.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use senc_geom::repair::RepairError;
use senc_geom::{TriMesh, Vec3};
use senc_scene::build::{face_points_inside, push_out, PushOut};
use senc_scene::fit::{align, fit, fit_obj, name_loops, FitOptions, Select, TopOpening};
use senc_scene::{BodyAsset, BodyQuery, GarmentAsset, SceneError};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn body() -> BodyAsset {
    BodyAsset::load(root().join("data/body.msgpack")).unwrap()
}

fn garment(name: &str) -> GarmentAsset {
    GarmentAsset::load(root().join(format!("data/garments/{name}.msgpack"))).unwrap()
}

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("senc-fit-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// OBJ text: all positions, then each named group's faces (indices into `positions`).
fn obj(positions: &[Vec3], groups: &[(&str, Vec<[u32; 3]>)]) -> String {
    let mut s = String::new();
    for p in positions {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for (name, faces) in groups {
        let _ = writeln!(s, "o {name}");
        for f in faces {
            let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
        }
    }
    s
}

/// Already fitted assets: no alignment, so a clean file comes back where it was.
fn in_place() -> FitOptions {
    FitOptions { align: false, ..FitOptions::default() }
}

#[test]
fn a_broken_export_is_repaired_and_fits_as_the_clean_file_does() {
    let body = body();
    let skirt = garment("skirt");
    let dir = scratch("broken");
    let clean_path = dir.join("skirt.obj");
    std::fs::write(&clean_path, obj(&skirt.positions, &[("skirt", skirt.faces.clone())])).unwrap();
    let (clean, clean_rep) = fit_obj(&clean_path, &Select::All, 1.0, &body, &in_place()).unwrap().remove(0);
    assert!(clean_rep.repair.is_clean(), "{}", clean_rep.repair);

    // Every third face wound the other way; the faces of the left half use their own copies
    // of their vertices (as exporters split at UV seams); a stray 1 mm triangle.
    let mut positions = skirt.positions.clone();
    let mut faces = skirt.faces.clone();
    let mut copy = vec![u32::MAX; positions.len()];
    let mut flipped = 0;
    for (k, f) in faces.iter_mut().enumerate() {
        if k % 3 == 0 {
            f.swap(1, 2);
            flipped += 1;
        }
        let c = f.iter().fold(Vec3::zeros(), |s, &v| s + positions[v as usize]) / 3.0;
        if c.x > 0.0 {
            for v in f.iter_mut() {
                if copy[*v as usize] == u32::MAX {
                    positions.push(positions[*v as usize]);
                    copy[*v as usize] = (positions.len() - 1) as u32;
                }
                *v = copy[*v as usize];
            }
        }
    }
    let copies = copy.iter().filter(|&&c| c != u32::MAX).count();
    // Seam vertices: copied, and the original still used on the other side.
    let seam = (0..skirt.positions.len())
        .filter(|&v| copy[v] != u32::MAX && faces.iter().flatten().any(|&w| w as usize == v))
        .count();
    let n = positions.len() as u32;
    positions.extend([Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.001, 2.0, 0.0), Vec3::new(0.0, 2.001, 0.0)]);
    faces.push([n, n + 1, n + 2]);
    let broken = dir.join("skirt_broken.obj");
    std::fs::write(&broken, obj(&positions, &[("skirt", faces)])).unwrap();

    let (fixed, rep) = fit_obj(&broken, &Select::All, 1.0, &body, &in_place()).unwrap().remove(0);
    let r = &rep.repair;
    assert!(copies > 500 && seam > 20, "{copies} {seam}");
    // Copies of seam vertices are welded; the others only renumbered (their originals are
    // unused).
    assert_eq!(r.welded, seam, "{r}");
    assert_eq!(r.unused_vertices, copies - seam, "{r}");
    assert_eq!(r.flipped, flipped, "{r}");
    assert_eq!((r.dropped_components, r.dropped_faces), (1, 1), "{r}");
    assert_eq!(fixed.name, "skirt_broken");
    assert_eq!(fixed.positions.len(), clean.positions.len());
    assert_eq!(fixed.loop_names(), clean.loop_names());
    // The same fitted surface (vertices are numbered differently: the copies come last).
    let sorted = |g: &GarmentAsset| {
        let mut p: Vec<[f64; 3]> = g.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
        p.sort_by(|a, b| a.partial_cmp(b).unwrap());
        p
    };
    let gap = sorted(&fixed)
        .iter()
        .zip(&sorted(&clean))
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(gap < 1e-9, "repaired and clean fits differ by {gap} m");
    assert_eq!(fixed.faces.len(), clean.faces.len());
    assert!(rep.min_distance >= 0.99 * in_place().margin, "{}", rep.min_distance);
    assert_eq!(rep.face_points_inside, 0);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn several_garments_in_one_file_are_picked_by_name_by_size_or_each() {
    let body = body();
    let (skirt, pants) = (garment("skirt"), garment("pants"));
    let mut positions = skirt.positions.clone();
    let off = positions.len() as u32;
    positions.extend(&pants.positions);
    let pants_faces: Vec<[u32; 3]> = pants.faces.iter().map(|f| f.map(|v| v + off)).collect();
    let dir = scratch("several");
    let path = dir.join("outfit.obj");
    std::fs::write(&path, obj(&positions, &[("skirt", skirt.faces.clone()), ("pants", pants_faces)])).unwrap();
    let area = |g: &GarmentAsset| g.mesh().unwrap().area();
    let opts = in_place();

    let named = fit_obj(&path, &Select::Named("pants".into()), 1.0, &body, &opts).unwrap();
    assert_eq!(named.len(), 1);
    assert_eq!(named[0].0.name, "outfit_pants");
    assert_eq!(named[0].0.positions.len(), pants.positions.len());
    assert_eq!(named[0].0.loop_names(), pants.loop_names());
    assert_eq!(named[0].1.repair.unused_vertices, skirt.positions.len(), "the skirt's vertices are not the pants'");

    let largest = fit_obj(&path, &Select::Largest, 1.0, &body, &opts).unwrap();
    let bigger = if area(&skirt) > area(&pants) { &skirt } else { &pants };
    assert_eq!(largest.len(), 1);
    assert_eq!(largest[0].0.positions.len(), bigger.positions.len());

    let each = fit_obj(&path, &Select::Each, 1.0, &body, &opts).unwrap();
    let mut names: Vec<&str> = each.iter().map(|(a, _)| a.name.as_str()).collect();
    names.sort_unstable();
    assert_eq!(names, ["outfit_pants", "outfit_skirt"]);
    for (a, rep) in &each {
        let q = BodyQuery::new(&body.positions, &body.faces).unwrap();
        assert!(q.inside(&a.positions).is_empty(), "{}", a.name);
        assert!(rep.min_distance > 0.0);
    }

    let e = fit_obj(&path, &Select::Named("dress".into()), 1.0, &body, &opts).unwrap_err();
    match &e {
        SceneError::NoSuchComponent { name, available, .. } => {
            assert_eq!(name, "dress");
            assert_eq!(available, &["skirt", "pants"]);
        }
        other => panic!("expected NoSuchComponent, got {other:?}"),
    }
    // The argument form `FILE#WHICH`.
    assert_eq!(
        Select::from_arg(Path::new("a/outfit.obj#pants")),
        (PathBuf::from("a/outfit.obj"), Select::Named("pants".into()))
    );
    assert_eq!(Select::from_arg(Path::new("outfit.obj#each")).1, Select::Each);
    assert_eq!(Select::from_arg(Path::new("outfit.obj#largest")).1, Select::Largest);
    assert_eq!(Select::from_arg(&path), (path.clone(), Select::All));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn what_cannot_be_repaired_is_refused_with_the_reason() {
    let body = body();
    let skirt = garment("skirt_coarse");
    let dir = scratch("refused");
    // A sheet glued onto an inner edge: three faces on one edge.
    let mut positions = skirt.positions.clone();
    let mut faces = skirt.faces.clone();
    let f0 = faces[0];
    positions.push(positions[f0[0] as usize] + Vec3::new(0.0, 0.0, 0.05));
    let extra = (positions.len() - 1) as u32;
    let (a, b) = (0..3)
        .map(|k| (f0[k], f0[(k + 1) % 3]))
        .find(|&(a, b)| faces.iter().filter(|f| f.contains(&a) && f.contains(&b)).count() == 2)
        .expect("an inner edge");
    faces.push([a, b, extra]);
    let p = dir.join("branching.obj");
    std::fs::write(&p, obj(&positions, &[("g", faces)])).unwrap();
    let e = fit_obj(&p, &Select::All, 1.0, &body, &in_place()).unwrap_err();
    assert!(matches!(&e, SceneError::Repair { source: RepairError::NonManifoldEdge { faces: 3, .. }, .. }), "{e:?}");
    assert!(e.to_string().contains("branches"), "{e}");
    // NaN and a short vertex line are parse errors naming the line.
    let text = obj(&skirt.positions, &[("g", skirt.faces.clone())]);
    let lines: Vec<String> =
        text.lines().enumerate().map(|(i, l)| if i == 3 { "v 0.1 nan 0.2".into() } else { l.into() }).collect();
    let p = dir.join("nan.obj");
    std::fs::write(&p, lines.join("\n")).unwrap();
    let e = fit_obj(&p, &Select::All, 1.0, &body, &in_place()).unwrap_err();
    assert!(matches!(e, SceneError::Mesh(_)) && e.to_string().contains("line 4"), "{e}");
    // A closed surface has no opening to align by.
    let cube_v = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
    ];
    let cube: Vec<Vec3> =
        cube_v.iter().map(|c| Vec3::new(c[0], c[1], c[2]) * 0.2 + Vec3::new(-0.1, 0.3, -0.1)).collect();
    let quads = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [0, 4, 7, 3]];
    let tris: Vec<[u32; 3]> = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    let p = dir.join("box.obj");
    std::fs::write(&p, obj(&cube, &[("box", tris)])).unwrap();
    let e = fit_obj(&p, &Select::All, 1.0, &body, &FitOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no boundary loop"), "{e}");
    // A missing file.
    let e = fit_obj(&dir.join("none.obj"), &Select::All, 1.0, &body, &in_place()).unwrap_err();
    assert!(e.to_string().contains("none.obj"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Centroid of loop `loop_name` of a garment.
fn loop_centroid(a: &GarmentAsset, loop_name: &str) -> Vec3 {
    let l = a.loops.iter().find(|l| l.name == loop_name).unwrap_or_else(|| panic!("{}: no loop {loop_name}", a.name));
    l.vertices.iter().fold(Vec3::zeros(), |s, &v| s + a.positions[v as usize]) / l.vertices.len() as f64
}

fn sorted_names(a: &GarmentAsset) -> Vec<String> {
    let mut names = a.loop_names();
    names.sort_unstable();
    names
}

/// Garments placed anywhere are aligned by their top opening: the committed skirt and
/// trousers (a waist), t-shirt and long sleeves (a neck), moved 0.4 m up, 0.3 m sideways and
/// 0.2 m back, are not taken for placed, come back with that loop within 4 cm of where the
/// committed asset has it, their loops named as the committed ones are, and nothing left
/// inside the body. The long sleeves' cuffs, at the wrists, lie along the arms: no arm
/// correction (against the upper arm's direction they would look 4° lower).
#[test]
fn tops_and_bottoms_moved_away_are_aligned_by_their_top_opening() {
    let body = body();
    let q = BodyQuery::new(&body.positions, &body.faces).unwrap();
    let opts = FitOptions::default();
    for (name, top, opening) in [
        ("skirt", "waist", TopOpening::Waist),
        ("pants", "waist", TopOpening::Waist),
        ("tshirt", "neck", TopOpening::Neck),
        ("longsleeve", "neck", TopOpening::Neck),
    ] {
        let g = garment(name);
        let moved: Vec<Vec3> = g.positions.iter().map(|p| p + Vec3::new(0.3, 0.4, -0.2)).collect();
        let (fitted, rep) = fit(name, &moved, &g.faces, &body, None, &opts).unwrap();
        assert!(!rep.placement.placed, "{name}: {:?}", rep.placement);
        assert_eq!(rep.alignment.map(|a| a.opening), Some(opening), "{name}");
        let shift = (loop_centroid(&fitted, top) - loop_centroid(&g, top)).norm();
        assert!(shift < 0.04, "{name}: {top} lands {shift} m from the committed asset's");
        assert_eq!(sorted_names(&fitted), sorted_names(&g), "{name}");
        assert!(q.inside(&fitted.positions).is_empty(), "{name}: vertices inside the body");
        if name == "longsleeve" {
            // Sleeves along the arms: at most the few degrees the alignment's own offset gives.
            assert!(rep.arm_correction_deg.abs() < 8.0, "arm correction {}", rep.arm_correction_deg);
        }
    }
}

/// The committed garments sit on the body: with the default options (alignment on) they are
/// taken for placed, neither aligned nor arm-corrected, and come back where they were, with
/// their loop names.
#[test]
fn a_garment_already_on_the_body_comes_back_unmoved() {
    let body = body();
    for name in ["skirt", "pants", "tshirt", "longsleeve"] {
        let g = garment(name);
        let (fitted, rep) = fit(name, &g.positions, &g.faces, &body, None, &FitOptions::default()).unwrap();
        assert!(rep.placement.placed, "{name}: {:?}", rep.placement);
        assert!(rep.placement.median < 0.02, "{name}: {:?}", rep.placement);
        assert_eq!(rep.alignment, None, "{name}");
        assert_eq!(rep.arm_correction_deg, 0.0, "{name}");
        assert!(senc_scene::fit::describe(&fitted, &rep).contains("placed on the body, not moved"));
        // Every fitted vertex lies where a committed one is (the clean-up may drop a few).
        let far = fitted
            .positions
            .iter()
            .map(|p| g.positions.iter().map(|r| (p - r).norm()).fold(f64::INFINITY, f64::min))
            .fold(0.0, f64::max);
        assert!(far < 2e-3, "{name}: a vertex moved {far} m");
        assert_eq!(sorted_names(&fitted), sorted_names(&g), "{name}");
    }
}

/// The committed trousers with a belt loop (an open 1 cm tube, 4 cm above the waist in
/// front), moved away: the belt loop is the highest opening, but it is small, so the
/// alignment takes the waist and puts it where the committed asset has it; the loop names
/// call the two ends of the tube holes.
#[test]
fn a_belt_loop_above_the_waist_is_not_taken_for_the_top_opening() {
    let body = body();
    let pants = garment("pants");
    let waist = loop_centroid(&pants, "waist");
    let tube = senc_testmesh::tube(0.01, 0.01, 8, 1, senc_testmesh::Caps::Open).unwrap();
    let at = waist + Vec3::new(0.0, 0.04, 0.12);
    let tube = senc_testmesh::rigid_transform(&tube, &nalgebra::Rotation3::identity(), &at).unwrap();
    let mesh = senc_testmesh::merge(&pants.mesh().unwrap(), &tube).unwrap();
    let names = {
        let mut n: Vec<String> = name_loops(&mesh, &body).unwrap().into_iter().map(|l| l.name).collect();
        n.sort_unstable();
        n
    };
    assert_eq!(names, ["hole", "hole_2", "left_leg", "right_leg", "waist"]);
    let shift = Vec3::new(0.3, 0.4, -0.2);
    let mut moved: Vec<Vec3> = mesh.positions().iter().map(|p| p + shift).collect();
    let moved_mesh = mesh.with_positions(moved.clone()).unwrap();
    let a = align(&mut moved, &moved_mesh, &body).unwrap();
    assert_eq!(a.opening, TopOpening::Waist);
    let n = pants.positions.len();
    let l = &pants.loops.iter().find(|l| l.name == "waist").unwrap().vertices;
    let c = l.iter().fold(Vec3::zeros(), |s, &v| s + moved[v as usize]) / l.len() as f64;
    assert!((c - waist).norm() < 0.04, "the waist lands {} m off", (c - waist).norm());
    assert!((moved[n] - tube.positions()[0]).norm() < 0.04, "the tube moves with the trousers");
}

/// The committed trousers cut 15 cm below the crotch are shorts: their leg openings, above
/// the knees, are legs (below the crotch and off-centre), not hems.
#[test]
fn shorts_leg_openings_above_the_knees_are_legs() {
    let body = body();
    let pants = garment("pants");
    let shorts = cut(&pants.mesh().unwrap(), |c| c.y > -0.15);
    let mut names: Vec<String> = name_loops(&shorts, &body).unwrap().into_iter().map(|l| l.name).collect();
    names.sort_unstable();
    assert_eq!(names, ["left_leg", "right_leg", "waist"]);
}

/// The committed long sleeves opened down the front (a cardigan): neck and hem become one
/// loop, which reaches up to the neck and is called `neck` (its centroid is at the chest).
/// Moved away, the garment is aligned by that open front and lands within 4 cm of where the
/// committed garment is.
#[test]
fn an_open_front_is_a_neck() {
    let body = body();
    let g = garment("longsleeve");
    let open = cut(&g.mesh().unwrap(), |c| !(c.x.abs() < 0.012 && c.z > 0.0));
    assert_eq!(open.topology().boundary_loops().len(), 3, "neck and hem joined");
    let mut names: Vec<String> = name_loops(&open, &body).unwrap().into_iter().map(|l| l.name).collect();
    names.sort_unstable();
    assert_eq!(names, ["left_sleeve", "neck", "right_sleeve"]);
    let shift = Vec3::new(0.3, 0.4, -0.2);
    let mut moved: Vec<Vec3> = open.positions().iter().map(|p| p + shift).collect();
    let moved_mesh = open.with_positions(moved.clone()).unwrap();
    let a = align(&mut moved, &moved_mesh, &body).unwrap();
    assert_eq!(a.opening, TopOpening::OpenFront);
    let back = (moved[0] - open.positions()[0]).norm();
    assert!(back < 0.04, "lands {back} m off");
}

/// The committed long sleeves with both arms raised 20° about the shoulder joints: the
/// sleeves stand off the arms, so the garment is not taken for placed; fitted without
/// alignment, it is arm-corrected by about −20° (the sleeves hang higher than the arms),
/// which brings the cuffs back near the wrists.
#[test]
fn sleeves_raised_off_the_arms_are_corrected_by_their_angle() {
    let body = body();
    let g = garment("longsleeve");
    let sh = body.skeleton.bones[body.skeleton.find("LeftArm").unwrap()].head;
    let raise = 20f64.to_radians();
    let raised: Vec<Vec3> = g
        .positions
        .iter()
        .map(|p| {
            if p.x.abs() <= sh.x {
                return *p;
            }
            let s = p.x.signum();
            let pivot = Vec3::new(s * sh.x, sh.y, p.z);
            let d = p - pivot;
            let a = s * raise;
            pivot + Vec3::new(d.x * a.cos() - d.y * a.sin(), d.x * a.sin() + d.y * a.cos(), 0.0)
        })
        .collect();
    let (fitted, rep) = fit("raised", &raised, &g.faces, &body, None, &in_place()).unwrap();
    assert!(!rep.placement.placed, "{:?}", rep.placement);
    assert!((rep.arm_correction_deg + 20.0).abs() < 3.0, "arm correction {}", rep.arm_correction_deg);
    let off = (loop_centroid(&fitted, "left_sleeve") - loop_centroid(&g, "left_sleeve")).norm();
    assert!(off < 0.03, "the left cuff lands {off} m from the committed one");
}

/// The faces of `mesh` whose centroid passes `keep`, with the unused vertices dropped.
fn cut(mesh: &TriMesh, keep: impl Fn(&Vec3) -> bool) -> TriMesh {
    let p = mesh.positions();
    let mut index = vec![u32::MAX; p.len()];
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for f in mesh.faces() {
        let c = f.iter().fold(Vec3::zeros(), |s, &v| s + p[v as usize]) / 3.0;
        if keep(&c) {
            faces.push(f.map(|v| {
                if index[v as usize] == u32::MAX {
                    index[v as usize] = positions.len() as u32;
                    positions.push(p[v as usize]);
                }
                index[v as usize]
            }));
        }
    }
    TriMesh::new(positions, faces).unwrap()
}

/// A garment fitted too low on a shoulder: a cap whose top lies 3 cm deep in a box, and
/// whose deep vertices near the box's side walls are closer to the walls than to the top.
/// Pushed to the closest surface point, those would go sideways and leave faces spanning the
/// box's edge; the push-out moves them along the cap's own normal, up over the top, so that
/// no face crosses the box, no face turns over and no edge more than doubles.
#[test]
fn a_cap_sunk_into_a_shoulder_is_pushed_up_over_it_not_through_it() {
    let h = 0.1;
    let cube = senc_testmesh::grid_box(Vec3::repeat(-h), Vec3::repeat(h), 4).unwrap();
    let body = BodyQuery::new(cube.positions(), cube.faces()).unwrap();
    assert!(body.closest(&Vec3::zeros()).inside && !body.closest(&Vec3::new(0.0, 0.2, 0.0)).inside);
    let n = 24;
    let (mut pos, mut faces) = (Vec::new(), Vec::new());
    for i in 0..=n {
        for j in 0..=n {
            let (x, z) = (-0.15 + 0.3 * i as f64 / n as f64, -0.15 + 0.3 * j as f64 / n as f64);
            pos.push(Vec3::new(x, 0.07 - 1.5 * (x * x + z * z), z));
        }
    }
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    for i in 0..n {
        for j in 0..n {
            // Counter-clockwise seen from +y: normals up, out of the box's top.
            faces.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    let rest = pos.clone();
    let longest = |p: &[Vec3]| {
        faces
            .iter()
            .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
            .map(|(a, b)| (p[a as usize] - p[b as usize]).norm())
            .fold(0.0, f64::max)
    };
    assert!(body.inside(&pos).len() > 100, "the cap must start deep in the box");
    push_out(&mut pos, &faces, &body, PushOut::default());
    assert!(body.inside(&pos).is_empty());
    assert!(body.min_signed_distance(&pos) >= 0.99 * PushOut::default().margin);
    let through = face_points_inside(&pos, &faces, &body);
    assert_eq!(through, 0, "face points inside the box");
    for f in &faces {
        let [a, b, c] = f.map(|i| pos[i as usize]);
        let [ra, rb, rc] = f.map(|i| rest[i as usize]);
        let (nn, nr) = ((b - a).cross(&(c - a)), (rb - ra).cross(&(rc - ra)));
        assert!(nn.dot(&nr) > 0.0, "face {f:?} turned over");
    }
    assert!(longest(&pos) < 2.0 * longest(&rest), "{} against {}", longest(&pos), longest(&rest));
}
