//! The fit of a garment made elsewhere onto the senc body (`cargo xtask fit`, `eval` and
//! `simulate --garment`, and `cargo xtask data` for the committed garments).
//!
//! Steps: mesh repair (`senc_geom::repair`: duplicate vertices welded, windings made to
//! agree, tiny stray components and degenerate faces dropped; what cannot be repaired is
//! refused), sliver clean-up, optional rigid alignment (neck loop onto the body's neck base,
//! chest cross-sections centred), arm-angle correction for garments with sleeves (the body
//! is posed with its arms at the garment's sleeve angle, weights are transferred from that
//! posed body and the garment is un-skinned back to the rest pose), outward face
//! orientation, then the geometric push-out until no vertex is inside the body.
//!
//! An OBJ may hold several garments: [`Select`] fits all of it as one garment, a named
//! `o`/`g` group, the largest component, or each component as its own garment.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use senc_geom::obj::ObjData;
use senc_geom::repair::{repair, repair_parts, RepairConfig, RepairReport, Repaired};
use senc_geom::{TriMesh, Vec3};

use crate::assets::{BodyAsset, GarmentAsset, NamedLoop};
use crate::build::{push_out, transfer_weights, PushOut, WeightLists};
use crate::error::SceneError;
use crate::skeleton::{skin, Pose, SkinWeights};
use senc_geom::BodyQuery;

/// Settings of [`fit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Align the garment rigidly to the body first (garments modelled elsewhere).
    pub align: bool,
    /// Clearance from the body, m. Default 5 mm.
    pub margin: f64,
    /// Mesh repair settings.
    pub repair: RepairConfig,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self { align: true, margin: PushOut::default().margin, repair: RepairConfig::default() }
    }
}

/// What fitting did, for the log.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// What the mesh repair changed.
    pub repair: RepairReport,
    /// Vertices inside the body before the push-out.
    pub inside_before: usize,
    /// Vertices inside after.
    pub inside_after: usize,
    /// Smallest signed distance to the body after fitting, m.
    pub min_distance: f64,
    /// Arm correction applied, degrees.
    pub arm_correction_deg: f64,
    /// Edge collapses and flips of the sliver clean-up (`senc_geom::remesh`), before and
    /// after the push-out together.
    pub remesh_ops: (usize, usize),
    /// Worst triangle quality (`senc_geom::remesh::quality`) of the input and of the result.
    pub quality: (f64, f64),
}

/// What [`clean`] did: (collapses, flips) and the worst quality (before, after).
type Cleaned = ((usize, usize), (f64, f64));

/// Removes slivers (`senc_geom::remesh::improve`, default settings), carrying the weights
/// along. Returns the operations done and the worst quality before and after.
fn clean(
    positions: &mut Vec<Vec3>,
    faces: &mut Vec<[u32; 3]>,
    weights: Option<&mut WeightLists>,
) -> Result<Cleaned, SceneError> {
    let mesh = TriMesh::new(positions.clone(), faces.clone())?;
    let r = senc_geom::remesh::improve(&mesh, &senc_geom::remesh::RemeshConfig::default())?;
    if let Some(w) = weights {
        *w = r.source.iter().map(|&v| w[v as usize].clone()).collect();
    }
    *positions = r.mesh.positions().to_vec();
    *faces = r.mesh.faces().to_vec();
    Ok(((r.collapses, r.flips), (r.worst_before, r.worst_after)))
}

fn bone_head(body: &BodyAsset, name: &str) -> Result<Vec3, SceneError> {
    let j = body.skeleton.find(name).ok_or_else(|| {
        SceneError::Invalid(format!("the body skeleton has no bone {name}; fit needs the cmu_mb rig"))
    })?;
    Ok(body.skeleton.bones[j].head)
}

/// Boundary loops as vertex lists, with centroids.
fn loops_of(mesh: &TriMesh) -> Vec<(Vec<u32>, Vec3)> {
    mesh.topology()
        .boundary_loops()
        .iter()
        .map(|l| {
            let c = l.iter().fold(Vec3::zeros(), |s, &v| s + mesh.positions()[v as usize]) / l.len() as f64;
            (l.clone(), c)
        })
        .collect()
}

/// Names loops by where they are on the body: legs (below the knees, off-centre), sleeves
/// (far from the body's axis), then the torso loops from the top: `neck` (near the neck) or
/// `waist`, then `hem`.
pub fn name_loops(mesh: &TriMesh, body: &BodyAsset) -> Result<Vec<NamedLoop>, SceneError> {
    let y_neck = bone_head(body, "Neck")?.y;
    let y_knee = bone_head(body, "LeftLeg")?.y;
    let mut named = Vec::new();
    let mut torso = Vec::new();
    for (l, c) in loops_of(mesh) {
        let side = if c.x > 0.0 { "left" } else { "right" };
        if c.y < y_knee && c.x.abs() > 0.04 {
            named.push(NamedLoop { name: format!("{side}_leg"), vertices: l });
        } else if c.x.abs() > 0.18 {
            named.push(NamedLoop { name: format!("{side}_sleeve"), vertices: l });
        } else {
            torso.push((l, c));
        }
    }
    torso.sort_by(|a, b| b.1.y.total_cmp(&a.1.y));
    for (k, (l, c)) in torso.into_iter().enumerate() {
        let name = match k {
            0 if c.y > y_neck - 0.15 => "neck".to_string(),
            0 => "waist".to_string(),
            1 => "hem".to_string(),
            k => format!("hem_{k}"),
        };
        named.push(NamedLoop { name, vertices: l });
    }
    for i in 0..named.len() {
        if named[..i].iter().any(|n| n.name == named[i].name) {
            named[i].name = format!("{}_{i}", named[i].name);
        }
    }
    Ok(named)
}

/// Flips every face when the garment's normals point into the body on average.
pub fn orient_outward(positions: &[Vec3], faces: &mut [[u32; 3]], query: &BodyQuery) {
    let mut s = 0.0;
    for f in faces.iter() {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let n = (b - a).cross(&(c - a));
        let m = (a + b + c) / 3.0;
        let cl = query.closest(&m);
        let out = if cl.inside { cl.point - m } else { m - cl.point };
        s += n.dot(&out);
    }
    if s < 0.0 {
        for f in faces.iter_mut() {
            f.swap(1, 2);
        }
    }
}

fn body_z_centre(points: &[Vec3], y: f64, half_x: f64) -> Option<f64> {
    let zs: Vec<f64> = points.iter().filter(|p| (p.y - y).abs() < 0.01 && p.x.abs() < half_x).map(|p| p.z).collect();
    if zs.is_empty() {
        return None;
    }
    let lo = zs.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = zs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Some(0.5 * (lo + hi))
}

/// Mean horizontal distance of a boundary loop's vertices from its centroid above which the
/// loop is a waist (a bottom: skirt, trousers) rather than a neck, m. The registry garments'
/// necks are 5-7 cm, their waists 13-14 cm.
pub const WAIST_RADIUS: f64 = 0.10;

/// Rigid alignment by the highest boundary loop, x centred. A top's highest loop (narrower
/// than [`WAIST_RADIUS`]: a neck) goes 3.5 cm below the body's neck joint, and chest
/// cross-sections 10-25 cm below it share their z centre with the body's. A bottom's (a
/// waist) goes to the height of the lower-back joint, and hip cross-sections 5-20 cm below
/// it share their z centre with the body's.
pub fn align(positions: &mut [Vec3], mesh: &TriMesh, body: &BodyAsset) -> Result<(), SceneError> {
    let loops = loops_of(mesh);
    let Some((top_loop, top)) = loops.iter().max_by(|a, b| a.1.y.total_cmp(&b.1.y)) else {
        return Err(SceneError::Invalid(
            "the garment has no boundary loop to align by (a closed surface is no garment); align it yourself and fit with --no-align".into(),
        ));
    };
    let radius = top_loop
        .iter()
        .map(|&v| {
            let d = positions[v as usize] - top;
            d.x.hypot(d.z)
        })
        .sum::<f64>()
        / top_loop.len() as f64;
    // (where the loop goes, the body height the cross-sections hang from, the first drop)
    let (target_y, body_ref, first_drop) = if radius > WAIST_RADIUS {
        let waist = bone_head(body, "LowerBack")?.y;
        (waist, waist, 0.05)
    } else {
        let neck = bone_head(body, "Neck")?.y;
        (neck - 0.035, neck, 0.10)
    };
    let x_mid = {
        let lo = positions.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let hi = positions.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    };
    let dy = target_y - top.y;
    let mut dzs = Vec::new();
    for k in 0..4 {
        let drop = first_drop + 0.05 * k as f64;
        if let (Some(b), Some(g)) =
            (body_z_centre(&body.positions, body_ref - drop, 0.12), body_z_centre(positions, top.y - drop, 0.12))
        {
            dzs.push(b - g);
        }
    }
    let dz = if dzs.is_empty() { 0.0 } else { dzs.iter().sum::<f64>() / dzs.len() as f64 };
    let d = Vec3::new(-x_mid, dy, dz);
    for p in positions.iter_mut() {
        *p += d;
    }
    Ok(())
}

/// The pose rotating bone `name` and all its descendants by `rot` (world rotation).
fn pose_with_subtree(
    body: &BodyAsset,
    pose: &mut Pose,
    name: &str,
    rot: UnitQuaternion<f64>,
) -> Result<(), SceneError> {
    let j =
        body.skeleton.find(name).ok_or_else(|| SceneError::Invalid(format!("the body skeleton has no bone {name}")))?;
    for k in 0..body.skeleton.bones.len() {
        let mut a = Some(k);
        while let Some(i) = a {
            if i == j {
                pose.rotations[k] = rot;
                break;
            }
            a = body.skeleton.bones[i].parent;
        }
    }
    Ok(())
}

/// Angle (degrees, in the xy plane) by which the sleeves hang lower than the body's arms:
/// from the shoulder joint, the sleeve loop centroid against the elbow.
fn sleeve_angle(named: &[NamedLoop], positions: &[Vec3], body: &BodyAsset) -> Result<Option<f64>, SceneError> {
    let sh = bone_head(body, "LeftArm")?;
    let el = bone_head(body, "LeftForeArm")?;
    let Some(l) = named.iter().find(|l| l.name == "left_sleeve") else { return Ok(None) };
    let c = l.vertices.iter().fold(Vec3::zeros(), |s, &v| s + positions[v as usize]) / l.vertices.len() as f64;
    let arm = (el.y - sh.y).atan2(el.x - sh.x);
    let sleeve = (c.y - sh.y).atan2(c.x - sh.x);
    Ok(Some((arm - sleeve).to_degrees()))
}

/// Fits a garment (positions in metres) to the body: repairs it, then fits it (see the
/// module doc). `weights`: keep these, one list per input vertex (a garment made on this
/// body); otherwise weights come from the nearest body vertices.
pub fn fit(
    name: &str,
    positions: &[Vec3],
    faces: &[[u32; 3]],
    body: &BodyAsset,
    weights: Option<WeightLists>,
    opts: &FitOptions,
) -> Result<(GarmentAsset, FitReport), SceneError> {
    let repaired =
        repair(positions, faces, &opts.repair).map_err(|source| SceneError::Repair { garment: name.into(), source })?;
    fit_repaired(name, repaired, body, weights, opts)
}

/// [`fit`] of a mesh [`senc_geom::repair`] made (its `source` maps `weights`).
fn fit_repaired(
    name: &str,
    repaired: Repaired,
    body: &BodyAsset,
    weights: Option<WeightLists>,
    opts: &FitOptions,
) -> Result<(GarmentAsset, FitReport), SceneError> {
    let Repaired { mesh, source, report: repair, .. } = repaired;
    let mut positions = mesh.positions().to_vec();
    let mut faces = mesh.faces().to_vec();
    let mut weights: Option<WeightLists> = match weights {
        Some(w) => Some(
            source
                .iter()
                .map(|&v| {
                    w.get(v as usize).cloned().ok_or_else(|| {
                        SceneError::Weights(format!("garment vertex {v} has no weight list ({} given)", w.len()))
                    })
                })
                .collect::<Result<_, _>>()?,
        ),
        None => None,
    };
    let query = BodyQuery::new(&body.positions, &body.faces)?;
    let (ops0, (quality_in, _)) = clean(&mut positions, &mut faces, weights.as_mut())?;
    let mesh = TriMesh::new(positions.clone(), faces.clone())?;
    if opts.align {
        align(&mut positions, &mesh, body)?;
    }
    let mesh = mesh.with_positions(positions.clone())?;
    let mut arm_correction_deg = 0.0;
    let weights = match weights {
        Some(w) => w,
        None => {
            let named = name_loops(&mesh, body)?;
            match sleeve_angle(&named, &positions, body)? {
                Some(deg) if deg.abs() > 2.0 => {
                    // Pose the body with its arms at the sleeves' angle, take weights there,
                    // and un-skin the garment to the rest pose.
                    arm_correction_deg = deg;
                    let mut pose = Pose::identity(body.skeleton.len());
                    let z = Vector3::z_axis();
                    pose_with_subtree(
                        body,
                        &mut pose,
                        "LeftArm",
                        UnitQuaternion::from_axis_angle(&z, -deg.to_radians()),
                    )?;
                    pose_with_subtree(
                        body,
                        &mut pose,
                        "RightArm",
                        UnitQuaternion::from_axis_angle(&z, deg.to_radians()),
                    )?;
                    let tr = body.skeleton.bone_transforms(&pose)?;
                    let posed_body = skin(&body.positions, &body.weights, &tr);
                    let w = transfer_weights(&positions, &posed_body, &body.weights, 4);
                    let sw = SkinWeights::from_lists(&w)?;
                    for (v, p) in positions.iter_mut().enumerate() {
                        let mut m = Matrix3::zeros();
                        let mut t = Vec3::zeros();
                        for (b, wt) in sw.of(v) {
                            m += wt * tr[b].rotation.to_rotation_matrix().matrix();
                            t += wt * tr[b].translation.vector;
                        }
                        let inv = m.try_inverse().ok_or_else(|| {
                            SceneError::Invalid(format!("vertex {v}: degenerate blended skinning transform"))
                        })?;
                        *p = inv * (*p - t);
                    }
                    w
                }
                _ => transfer_weights(&positions, &body.positions, &body.weights, 4),
            }
        }
    };
    let mut weights = weights;
    orient_outward(&positions, &mut faces, &query);
    let inside_before = query.inside(&positions).len();
    push_out(&mut positions, &faces, &query, PushOut { margin: opts.margin, ..PushOut::default() });
    // The push-out can squash triangles against the body: clean up once more.
    let (ops1, (_, quality_out)) = clean(&mut positions, &mut faces, Some(&mut weights))?;
    let weights = SkinWeights::from_lists(&weights)?;
    let inside_after = query.inside(&positions).len();
    let min_distance = query.min_signed_distance(&positions);
    let mesh = TriMesh::new(positions.clone(), faces.clone())?;
    let loops = name_loops(&mesh, body)?;
    let asset = GarmentAsset { name: name.to_string(), positions, faces, weights, loops };
    asset.loop_indices()?;
    Ok((
        asset,
        FitReport {
            repair,
            inside_before,
            inside_after,
            min_distance,
            arm_correction_deg,
            remesh_ops: (ops0.0 + ops1.0, ops0.1 + ops1.1),
            quality: (quality_in, quality_out),
        },
    ))
}

/// One line about a fitted garment, for the log.
pub fn describe(asset: &GarmentAsset, rep: &FitReport) -> String {
    format!(
        "{}: {} vertices, {} faces, loops {:?}; repair: {}; thin triangles: {} collapses, {} flips, worst quality {:.3} -> {:.3}; arm correction {:.1} deg; inside the body before push-out {}, after {}; min distance to body {:.4} m",
        asset.name,
        asset.positions.len(),
        asset.faces.len(),
        asset.loop_names(),
        rep.repair,
        rep.remesh_ops.0,
        rep.remesh_ops.1,
        rep.quality.0,
        rep.quality.1,
        rep.arm_correction_deg,
        rep.inside_before,
        rep.inside_after,
        rep.min_distance
    )
}

/// Which garment(s) of an OBJ to fit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Select {
    /// Everything but stray components, as one garment.
    All,
    /// The faces of the `o`/`g` groups of this name.
    Named(String),
    /// The component with the largest area.
    Largest,
    /// Every component (but strays) as its own garment, largest first.
    Each,
}

impl Select {
    /// Splits a garment argument `FILE.obj#WHICH` into the file and the selection:
    /// `#largest`, `#each`, or `#NAME` for a group name; no `#` (or a file whose name
    /// really contains `#`) selects [`Select::All`].
    pub fn from_arg(arg: &Path) -> (PathBuf, Select) {
        let text = arg.to_string_lossy();
        match text.rsplit_once('#') {
            Some((file, which)) if !arg.exists() => {
                let sel = match which {
                    "largest" => Select::Largest,
                    "each" => Select::Each,
                    name => Select::Named(name.to_string()),
                };
                (PathBuf::from(file), sel)
            }
            _ => (arg.to_path_buf(), Select::All),
        }
    }
}

/// The group a face of the OBJ belongs to (the last group range holding it).
fn group_of(data: &ObjData, face: usize) -> Option<&str> {
    data.groups.iter().rev().find(|(_, r)| r.contains(&face)).map(|(n, _)| n.as_str())
}

fn safe_name(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

/// Fits the garment(s) `select` picks from an OBJ (positions times `scale`, to metres).
/// Garments are named after the file stem, with the group name (or the component's rank)
/// appended when a file gives several.
pub fn fit_obj(
    path: &Path,
    select: &Select,
    scale: f64,
    body: &BodyAsset,
    opts: &FitOptions,
) -> Result<Vec<(GarmentAsset, FitReport)>, SceneError> {
    let data = ObjData::read(path)?;
    let positions: Vec<Vec3> = data.positions.iter().map(|p| p * scale).collect();
    let stem = safe_name(&path.file_stem().map_or("garment".into(), |s| s.to_string_lossy()));
    let rep_err = |garment: &str| {
        let garment = garment.to_string();
        move |source| SceneError::Repair { garment, source }
    };
    match select {
        Select::All => Ok(vec![fit(&stem, &positions, &data.faces, body, None, opts)?]),
        Select::Named(name) => {
            let faces = data.group_faces(name).ok_or_else(|| SceneError::NoSuchComponent {
                path: path.to_owned(),
                name: name.clone(),
                available: data.group_names().iter().map(|s| s.to_string()).collect(),
            })?;
            Ok(vec![fit(&format!("{stem}_{}", safe_name(name)), &positions, &faces, body, None, opts)?])
        }
        Select::Largest | Select::Each => {
            let mut parts = repair_parts(&positions, &data.faces, &opts.repair).map_err(rep_err(&stem))?;
            if *select == Select::Largest {
                parts.truncate(1);
                return Ok(vec![fit_repaired(&stem, parts.remove(0), body, None, opts)?]);
            }
            let n = parts.len();
            parts
                .into_iter()
                .enumerate()
                .map(|(k, part)| {
                    let name = match part.face_source.first().and_then(|&f| group_of(&data, f as usize)) {
                        Some(g) if n > 1 => format!("{stem}_{}", safe_name(g)),
                        _ if n > 1 => format!("{stem}_{k}"),
                        _ => stem.clone(),
                    };
                    fit_repaired(&name, part, body, None, opts)
                })
                .collect()
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    /// A sheet with one needle: `clean` removes it and carries each surviving vertex's
    /// weight list along (here the list names the vertex's input index).
    #[test]
    fn clean_carries_weights_with_the_vertices() {
        let sheet = senc_testmesh::grid_sheet(1.0, 1.0, 6, 6).unwrap();
        let mut positions = sheet.positions().to_vec();
        positions[3 * 7 + 3] = positions[3 * 7 + 4] - Vec3::new(1e-3, 0.0, 0.0);
        let mut faces = sheet.faces().to_vec();
        let before = positions.clone();
        let mut weights: WeightLists = (0..positions.len()).map(|v| vec![(v as u16, 1.0)]).collect();
        let ((collapses, _), (q0, q1)) = clean(&mut positions, &mut faces, Some(&mut weights)).unwrap();
        assert!(collapses >= 1);
        assert!(q0 < 0.05 && q1 >= 0.2, "quality {q0} -> {q1}");
        assert_eq!(positions.len(), before.len() - collapses);
        assert_eq!(weights.len(), positions.len());
        for (p, w) in positions.iter().zip(&weights) {
            assert_eq!(*p, before[w[0].0 as usize]);
        }
    }
}
