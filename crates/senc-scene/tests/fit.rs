//! The garment fit (`senc_scene::fit`) on OBJ files made from the committed garments (built
//! from registry meshes): broken the way exported files are broken, they are repaired,
//! reported and fitted as the clean ones are; several garments in one file are picked by
//! name, by size or one by one; what cannot be repaired is refused.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use senc_geom::repair::RepairError;
use senc_geom::Vec3;
use senc_scene::fit::{fit_obj, FitOptions, Select};
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

/// Garments placed anywhere are aligned by their highest loop: the committed skirt and
/// trousers (a waist) and t-shirt (a neck), moved 0.4 m up, 0.3 m sideways and 0.2 m back,
/// come back with that loop within 4 cm of where the committed asset has it, their loops
/// named as the committed ones are, and nothing left inside the body.
#[test]
fn tops_and_bottoms_moved_away_are_aligned_by_their_highest_loop() {
    let body = body();
    let q = BodyQuery::new(&body.positions, &body.faces).unwrap();
    let opts = FitOptions::default();
    for (name, top) in [("skirt", "waist"), ("pants", "waist"), ("tshirt", "neck")] {
        let g = garment(name);
        let moved: Vec<Vec3> = g.positions.iter().map(|p| p + Vec3::new(0.3, 0.4, -0.2)).collect();
        let (fitted, _) = senc_scene::fit::fit(name, &moved, &g.faces, &body, None, &opts).unwrap();
        let centroid = |a: &GarmentAsset, loop_name: &str| {
            let l =
                a.loops.iter().find(|l| l.name == loop_name).unwrap_or_else(|| panic!("{name}: no loop {loop_name}"));
            l.vertices.iter().fold(Vec3::zeros(), |s, &v| s + a.positions[v as usize]) / l.vertices.len() as f64
        };
        let shift = (centroid(&fitted, top) - centroid(&g, top)).norm();
        assert!(shift < 0.04, "{name}: {top} lands {shift} m from the committed asset's");
        let mut names: Vec<&str> = fitted.loops.iter().map(|l| l.name.as_str()).collect();
        let mut want: Vec<&str> = g.loops.iter().map(|l| l.name.as_str()).collect();
        names.sort_unstable();
        want.sort_unstable();
        assert_eq!(names, want, "{name}");
        assert!(q.inside(&fitted.positions).is_empty(), "{name}: vertices inside the body");
    }
}
