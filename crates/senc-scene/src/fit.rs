//! The fit of a garment made elsewhere onto the senc body (`cargo xtask fit`, `eval` and
//! `simulate --garment`, and `cargo xtask data` for the committed garments).
//!
//! Steps: mesh repair (`senc_geom::repair`: duplicate vertices welded, windings made to
//! agree, tiny stray components and degenerate faces dropped; what cannot be repaired is
//! refused), sliver clean-up, the placement test (a garment whose vertices already lie within
//! a few cm of the body, hems that flare off the legs allowed for, is *placed*: it is neither
//! moved nor arm-corrected), otherwise an optional rigid alignment (the top opening, a neck
//! or a waist by its size against the body's neck and waist cross-sections, onto the body;
//! cross-sections below it centred) and the arm-angle correction for garments with sleeves
//! that hang at another angle than the body's arms (the body is posed with its arms at the
//! sleeves' angle, weights are transferred from that posed body and the garment is
//! un-skinned back to the rest pose), outward face orientation, then the geometric push-out
//! until no vertex is inside the body.
//!
//! An OBJ may hold several garments: [`Select`] fits all of it as one garment, a named
//! `o`/`g` group, the largest component, or each component as its own garment.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use senc_geom::obj::ObjData;
use senc_geom::repair::{repair, repair_parts, RepairConfig, RepairReport, Repaired};
use senc_geom::{TriMesh, Vec3};

use crate::assets::{BodyAsset, GarmentAsset, NamedLoop};
use crate::build::{face_points_inside, push_out, transfer_weights, PushOut, WeightLists};
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
    /// When a garment counts as already placed on the body.
    pub placed: PlacedTolerances,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            align: true,
            margin: PushOut::default().margin,
            repair: RepairConfig::default(),
            placed: PlacedTolerances::default(),
        }
    }
}

/// When a garment counts as already sitting on the body (see [`placement`]).
///
/// With `d` each vertex's unsigned distance to the body surface and `y_crotch` the height of
/// the thigh joints (`LeftUpLeg`): the median of `d` over the vertices above the crotch must
/// be at most `median`, and the `quantile`-th quantile of `e` over all vertices at most
/// `high`, where `e = max(0, d − flare_slope · max(0, y_crotch − y))` allows hems below the
/// crotch to stand off the legs (skirts, dresses, coats). A garment with no vertex above the
/// crotch takes the median of `e` instead. A garment moved by less than about 10 cm from
/// its place on the body can still count as placed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedTolerances {
    /// Largest median distance above the crotch, m. Default 4 cm: the loosest of 35
    /// MakeHuman garments made on this body (a jacket) has a median distance of 2.8 cm; a
    /// garment moved away by 15 cm or more has most vertices farther than that.
    pub median: f64,
    /// Largest excess distance at `quantile`, m. Default 7 cm (the same jacket: 5.1 cm).
    pub high: f64,
    /// The high quantile, 0..1. Default 0.9.
    pub quantile: f64,
    /// Allowed stand-off per metre below the crotch, m/m. Default 0.35: a hem 0.75 m below
    /// the crotch (an ankle-length skirt) may stand 26 cm off the legs.
    pub flare_slope: f64,
}

impl Default for PlacedTolerances {
    fn default() -> Self {
        Self { median: 0.04, high: 0.07, quantile: 0.9, flare_slope: 0.35 }
    }
}

/// The placement test's numbers: see [`PlacedTolerances`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Median distance to the body above the crotch, m.
    pub median: f64,
    /// Excess distance at the high quantile, m.
    pub high: f64,
    /// Whether the garment already sits on the body (then it is not moved).
    pub placed: bool,
}

/// How the top opening was read by [`align`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopOpening {
    /// A neck (a top, a dress): its centroid goes 3.5 cm below the body's neck joint.
    Neck,
    /// A neck opening that runs down an open front (a jacket, a coat): its highest point
    /// goes 1.5 cm above the body's neck joint.
    OpenFront,
    /// A waist (a skirt, trousers): its centroid goes to the lower-back joint's height.
    Waist,
}

/// What [`align`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// How the top opening was read.
    pub opening: TopOpening,
    /// Its radius (mean horizontal distance of its vertices from their centroid), m.
    pub radius: f64,
    /// The rigid translation applied, m.
    pub shift: Vec3,
}

/// What fitting did, for the log.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// What the mesh repair changed.
    pub repair: RepairReport,
    /// The placement test, on the repaired and cleaned garment.
    pub placement: Placement,
    /// The rigid alignment, when there was one (not for a placed garment nor with
    /// `FitOptions::align` off).
    pub alignment: Option<Alignment>,
    /// Vertices inside the body before the push-out.
    pub inside_before: usize,
    /// Vertices inside after.
    pub inside_after: usize,
    /// Points of the faces inside the body after the push-out
    /// ([`crate::build::face_points_inside`]): faces through the body between vertices
    /// outside it.
    pub face_points_inside: usize,
    /// Smallest signed distance to the body after fitting, m.
    pub min_distance: f64,
    /// Arm correction applied, degrees (0 for a placed garment, for sleeves that already lie
    /// along the arms and for corrections of 2° or less).
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

/// A boundary loop with its centroid, its radius (mean distance of its vertices from the
/// centroid) and its highest point's height, m.
struct Loop {
    vertices: Vec<u32>,
    centroid: Vec3,
    radius: f64,
    top: f64,
}

/// The boundary loops of a mesh.
fn loops_of(mesh: &TriMesh) -> Vec<Loop> {
    let p = mesh.positions();
    mesh.topology()
        .boundary_loops()
        .iter()
        .map(|l| {
            let n = l.len() as f64;
            let centroid = l.iter().fold(Vec3::zeros(), |s, &v| s + p[v as usize]) / n;
            let radius = l.iter().map(|&v| (p[v as usize] - centroid).norm()).sum::<f64>() / n;
            let top = l.iter().map(|&v| p[v as usize].y).fold(f64::NEG_INFINITY, f64::max);
            Loop { vertices: l.clone(), centroid, radius, top }
        })
        .collect()
}

/// Loops smaller than this radius are holes (button, belt and strap holes), m; the narrowest
/// sleeve cuff of 35 MakeHuman garments is 2.5 cm.
pub const HOLE_RADIUS: f64 = 0.015;

/// Loops whose centroids lie within this height of the highest torso loop's are parts of the
/// same opening (a waistband cut at the front and the back), m.
const SAME_OPENING: f64 = 0.03;

/// Names loops by where they are on the body (the garment in the body's frame):
/// - `hole` for loops smaller than [`HOLE_RADIUS`];
/// - `left_leg`/`right_leg` off-centre (|x| > 4 cm) below the knees, or off-centre
///   (|x| > 6 cm) below the crotch (5 cm under the thigh joints: shorts);
/// - `left_sleeve`/`right_sleeve` far from the body's axis (|x| > 18 cm), or off-centre
///   (|x| > 8 cm) and above the armpits (10 cm under the shoulder joints: armholes);
/// - the other (torso) loops from the top: `neck` when the highest reaches within 15 cm of
///   the neck joint (an open front's loop runs from the neck down to the hem), `waist`
///   otherwise, with loops at its height (within 3 cm) as its parts
///   (`neck_2`, `waist_2`); then `hem`, `hem_2`, ...
pub fn name_loops(mesh: &TriMesh, body: &BodyAsset) -> Result<Vec<NamedLoop>, SceneError> {
    let y_neck = bone_head(body, "Neck")?.y;
    let y_knee = bone_head(body, "LeftLeg")?.y;
    let y_crotch = bone_head(body, "LeftUpLeg")?.y - 0.05;
    let y_armpit = bone_head(body, "LeftArm")?.y - 0.10;
    let mut named = Vec::new();
    let mut torso = Vec::new();
    let mut holes = 0;
    for l in loops_of(mesh) {
        let c = l.centroid;
        let side = if c.x > 0.0 { "left" } else { "right" };
        if l.radius < HOLE_RADIUS {
            holes += 1;
            let name = if holes == 1 { "hole".to_string() } else { format!("hole_{holes}") };
            named.push(NamedLoop { name, vertices: l.vertices });
        } else if (c.y < y_knee && c.x.abs() > 0.04) || (c.y < y_crotch && c.x.abs() > 0.06) {
            named.push(NamedLoop { name: format!("{side}_leg"), vertices: l.vertices });
        } else if c.x.abs() > 0.18 || (c.x.abs() > 0.08 && c.y > y_armpit) {
            named.push(NamedLoop { name: format!("{side}_sleeve"), vertices: l.vertices });
        } else {
            torso.push(l);
        }
    }
    torso.sort_by(|a, b| b.centroid.y.total_cmp(&a.centroid.y));
    let top_y = torso.first().map_or(0.0, |l| l.centroid.y);
    let top = if torso.first().is_some_and(|l| l.top > y_neck - 0.15) { "neck" } else { "waist" };
    let (mut n_top, mut n_hem) = (0, 0);
    for l in torso {
        let name = if top_y - l.centroid.y < SAME_OPENING {
            n_top += 1;
            if n_top == 1 {
                top.to_string()
            } else {
                format!("{top}_{n_top}")
            }
        } else {
            n_hem += 1;
            if n_hem == 1 {
                "hem".to_string()
            } else {
                format!("hem_{n_hem}")
            }
        };
        named.push(NamedLoop { name, vertices: l.vertices });
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

/// Radius of the body's cross-section at height `y` (vertices within 1 cm of it and within
/// `half_x` of the axis): mean horizontal distance from their centroid, m.
fn body_section_radius(body: &BodyAsset, y: f64, half_x: f64) -> Option<f64> {
    let pts: Vec<&Vec3> = body.positions.iter().filter(|p| (p.y - y).abs() < 0.01 && p.x.abs() < half_x).collect();
    if pts.is_empty() {
        return None;
    }
    let n = pts.len() as f64;
    let c = pts.iter().fold(Vec3::zeros(), |s, p| s + **p) / n;
    Some(pts.iter().map(|p| (p.x - c.x).hypot(p.z - c.z)).sum::<f64>() / n)
}

/// Whether the garment already sits on the body: see [`PlacedTolerances`].
pub fn placement(
    positions: &[Vec3],
    body: &BodyAsset,
    query: &BodyQuery,
    tol: &PlacedTolerances,
) -> Result<Placement, SceneError> {
    use rayon::prelude::*;
    let y_crotch = bone_head(body, "LeftUpLeg")?.y;
    // (distance, excess beyond the flare allowance, above the crotch)
    let d: Vec<(f64, f64, bool)> = positions
        .par_iter()
        .map(|p| {
            let d = query.closest(p).signed_distance.abs();
            (d, (d - tol.flare_slope * (y_crotch - p.y).max(0.0)).max(0.0), p.y >= y_crotch)
        })
        .collect();
    let quantile = |mut v: Vec<f64>, q: f64| {
        v.sort_by(|a, b| a.total_cmp(b));
        v.get(((v.len().max(1) - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize).copied().unwrap_or(f64::INFINITY)
    };
    let upper: Vec<f64> = d.iter().filter(|x| x.2).map(|x| x.0).collect();
    let median = if upper.is_empty() { quantile(d.iter().map(|x| x.1).collect(), 0.5) } else { quantile(upper, 0.5) };
    let high = quantile(d.iter().map(|x| x.1).collect(), tol.quantile);
    Ok(Placement { median, high, placed: median <= tol.median && high <= tol.high })
}

/// Mean horizontal distance of a boundary loop's vertices from its centroid above which the
/// loop is a waist (a bottom: skirt, trousers) rather than a neck when the body has no neck
/// or waist cross-section to compare with, m. The registry garments' necks are 5-7 cm,
/// their waists 13-14 cm.
pub const WAIST_RADIUS: f64 = 0.10;

/// An opening whose vertices span more than this height runs down an open front, m.
const OPEN_FRONT: f64 = 0.2;

/// The top opening: among the garment's central loops (centroid within a quarter of the
/// garment's half-width of its middle in x, radius at least a tenth of that half-width: no
/// sleeves, armholes, legs, pocket or belt holes) the highest, joined by those within 3 cm of
/// its height (a waistband cut in two). Falls back to the highest loop when none is central.
/// Returns its vertices, their centroid, horizontal radius and height span, and whether the
/// garment has arm openings (off-centre loops above its lowest central loop).
fn top_opening(positions: &[Vec3], loops: &[Loop]) -> Option<(Vec<u32>, Vec3, f64, f64, bool)> {
    let lo = positions.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
    let hi = positions.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    let (x_mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let big = |l: &&Loop| l.radius >= 0.1 * half && l.radius >= HOLE_RADIUS;
    let central = |l: &&Loop| (l.centroid.x - x_mid).abs() <= 0.25 * half;
    let mut cands: Vec<&Loop> = loops.iter().filter(big).filter(central).collect();
    if cands.is_empty() {
        cands = loops.iter().collect();
    }
    cands.sort_by(|a, b| b.centroid.y.total_cmp(&a.centroid.y));
    let first = *cands.first()?;
    let lowest = cands.last().map_or(first.centroid.y, |l| l.centroid.y);
    let arms = loops.iter().any(|l| l.radius >= HOLE_RADIUS && !central(&l) && l.centroid.y > lowest);
    let vertices: Vec<u32> = cands
        .iter()
        .filter(|l| first.centroid.y - l.centroid.y < SAME_OPENING)
        .flat_map(|l| l.vertices.iter().copied())
        .collect();
    let n = vertices.len() as f64;
    let c = vertices.iter().fold(Vec3::zeros(), |s, &v| s + positions[v as usize]) / n;
    let radius = vertices
        .iter()
        .map(|&v| {
            let d = positions[v as usize] - c;
            d.x.hypot(d.z)
        })
        .sum::<f64>()
        / n;
    let ys = vertices.iter().map(|&v| positions[v as usize].y);
    let span = ys.clone().fold(f64::NEG_INFINITY, f64::max) - ys.fold(f64::INFINITY, f64::min);
    Some((vertices, c, radius, span, arms))
}

/// Rigid alignment by the top opening (see `top_opening`), x centred. It is a neck when
/// the garment has arm openings, when it spans more than 20 cm in height (an open front), when
/// the garment reaches farther below it than the body's waist is above its soles (overalls),
/// or when its radius is nearer (in ratio) the body's neck
/// cross-section (3.5 cm under the neck joint) than its waist cross-section (at the
/// lower-back joint), else a waist ([`WAIST_RADIUS`] splits them when the body has no such
/// sections). A neck's centroid goes 3.5 cm below the body's neck joint (an open front's
/// highest point 1.5 cm above it), and chest cross-sections 10-25 cm below it share their z
/// centre with the body's. A waist goes to the height of the lower-back joint, and hip
/// cross-sections 5-20 cm below it share their z centre with the body's.
pub fn align(positions: &mut [Vec3], mesh: &TriMesh, body: &BodyAsset) -> Result<Alignment, SceneError> {
    let loops = loops_of(&mesh.with_positions(positions.to_vec())?);
    let Some((_, top, radius, span, arms)) = top_opening(positions, &loops) else {
        return Err(SceneError::Invalid(
            "the garment has no boundary loop to align by (a closed surface is no garment); align it yourself and fit with --no-align".into(),
        ));
    };
    let neck = bone_head(body, "Neck")?.y;
    let waist = bone_head(body, "LowerBack")?.y;
    // A garment reaching farther below its opening than the waist is above the soles
    // (overalls) does not hang from the waist.
    let y_sole = body.positions.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let y_low = positions.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let is_waist = !arms
        && span <= OPEN_FRONT
        && top.y - y_low <= waist - y_sole + 0.05
        && match (body_section_radius(body, neck - 0.035, 0.08), body_section_radius(body, waist, 0.25)) {
            (Some(rn), Some(rw)) => (radius / rn).ln().abs() > (radius / rw).ln().abs(),
            _ => radius > WAIST_RADIUS,
        };
    let open_front = span > OPEN_FRONT;
    // (the opening, the garment height that goes to the target, the target, the body
    // height the cross-sections hang from, the first drop)
    let (opening, garment_ref, target_y, body_ref, first_drop) = if is_waist {
        (TopOpening::Waist, top.y, waist, waist, 0.05)
    } else if open_front {
        let y_top = positions.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
        (TopOpening::OpenFront, y_top, neck + 0.015, neck, 0.10)
    } else {
        (TopOpening::Neck, top.y, neck - 0.035, neck, 0.10)
    };
    let x_mid = {
        let lo = positions.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let hi = positions.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    };
    let dy = target_y - garment_ref;
    let centred: Vec<Vec3> = positions.iter().map(|p| Vec3::new(p.x - x_mid, p.y, p.z)).collect();
    let mut dzs = Vec::new();
    for k in 0..4 {
        let drop = first_drop + 0.05 * k as f64;
        if let (Some(b), Some(g)) =
            (body_z_centre(&body.positions, body_ref - drop, 0.12), body_z_centre(&centred, garment_ref - drop, 0.12))
        {
            dzs.push(b - g);
        }
    }
    let dz = if dzs.is_empty() { 0.0 } else { dzs.iter().sum::<f64>() / dzs.len() as f64 };
    let d = Vec3::new(-x_mid, dy, dz);
    for p in positions.iter_mut() {
        *p += d;
    }
    Ok(Alignment { opening, radius, shift: d })
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

/// A sleeve opening nearer the shoulder joint than this (in the xy plane) is an armhole,
/// with no angle to correct, m.
pub const MIN_SLEEVE: f64 = 0.08;

/// How far past the elbow (in the xy plane) a sleeve opening must reach before it is
/// compared with the forearm rather than the upper arm, m: a sleeve ending about the elbow
/// hangs from the upper arm.
pub const ELBOW_REACH: f64 = 0.05;

/// The point of the body's left arm chain (shoulder, elbow, wrist joints, in the xy plane)
/// at distance `s` from the shoulder: along the upper arm when `s` is at most its length
/// plus [`ELBOW_REACH`], else on the forearm, else (beyond the wrist) the wrist.
fn arm_point_at(sh: Vec3, el: Vec3, wr: Vec3, s: f64) -> Vec3 {
    let flat = |v: Vec3| Vec3::new(v.x, v.y, 0.0);
    let (sh, el, wr) = (flat(sh), flat(el), flat(wr));
    let upper = (el - sh).norm();
    if s <= upper + ELBOW_REACH {
        return sh + (el - sh) * (s / upper.max(1e-9));
    }
    // |el + t (wr − el) − sh| = s, the root with t ≥ 0.
    let (a, b) = (wr - el, el - sh);
    let (qa, qb, qc) = (a.norm_squared(), 2.0 * a.dot(&b), b.norm_squared() - s * s);
    if qa < 1e-12 {
        return wr;
    }
    let t = (-qb + (qb * qb - 4.0 * qa * qc).max(0.0).sqrt()) / (2.0 * qa);
    el + a * t.clamp(0.0, 1.0)
}

/// Angle (degrees, in the xy plane, seen from the left shoulder joint) by which the left
/// sleeve hangs lower than the body's arm: the sleeve loop's centroid against the point of
/// the arm chain at the same distance from the shoulder (on the upper arm for a short
/// sleeve, on the forearm or at the wrist for a long one). `None` without a left sleeve and
/// for an armhole (a loop not beyond the shoulder joint by [`MIN_SLEEVE`]). A wide short
/// sleeve can hang well below the arm with the arm still through it, so that is no reason
/// to skip the correction.
fn sleeve_angle(named: &[NamedLoop], positions: &[Vec3], body: &BodyAsset) -> Result<Option<f64>, SceneError> {
    let sh = bone_head(body, "LeftArm")?;
    let el = bone_head(body, "LeftForeArm")?;
    let wr = bone_head(body, "LeftHand")?;
    let Some(l) = named.iter().find(|l| l.name == "left_sleeve") else { return Ok(None) };
    let n = l.vertices.len() as f64;
    let c = l.vertices.iter().fold(Vec3::zeros(), |s, &v| s + positions[v as usize]) / n;
    let s = (c.x - sh.x).hypot(c.y - sh.y);
    if c.x <= sh.x || s < MIN_SLEEVE {
        return Ok(None);
    }
    let p = arm_point_at(sh, el, wr, s);
    let arm = (p.y - sh.y).atan2(p.x - sh.x);
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
    let placement = placement(&positions, body, &query, &opts.placed)?;
    let alignment = if opts.align && !placement.placed { Some(align(&mut positions, &mesh, body)?) } else { None };
    let mesh = mesh.with_positions(positions.clone())?;
    let mut arm_correction_deg = 0.0;
    let weights = match weights {
        Some(w) => w,
        None => {
            let named = name_loops(&mesh, body)?;
            let angle = if placement.placed { None } else { sleeve_angle(&named, &positions, body)? };
            match angle {
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
    let face_points_inside = face_points_inside(&positions, &faces, &query);
    let min_distance = query.min_signed_distance(&positions);
    let mesh = TriMesh::new(positions.clone(), faces.clone())?;
    let loops = name_loops(&mesh, body)?;
    let asset = GarmentAsset { name: name.to_string(), positions, faces, weights, loops };
    asset.loop_indices()?;
    Ok((
        asset,
        FitReport {
            repair,
            placement,
            alignment,
            inside_before,
            inside_after,
            face_points_inside,
            min_distance,
            arm_correction_deg,
            remesh_ops: (ops0.0 + ops1.0, ops0.1 + ops1.1),
            quality: (quality_in, quality_out),
        },
    ))
}

/// One line about a fitted garment, for the log.
pub fn describe(asset: &GarmentAsset, rep: &FitReport) -> String {
    let pl = &rep.placement;
    let placed = match (&rep.alignment, pl.placed) {
        (_, true) => "placed on the body, not moved".to_string(),
        (Some(a), _) => format!(
            "aligned by its {} (radius {:.3} m), moved ({:.3}, {:.3}, {:.3}) m",
            match a.opening {
                TopOpening::Neck => "neck",
                TopOpening::OpenFront => "open front",
                TopOpening::Waist => "waist",
            },
            a.radius,
            a.shift.x,
            a.shift.y,
            a.shift.z
        ),
        (None, false) => "not on the body, not aligned".to_string(),
    };
    format!(
        "{}: {} vertices, {} faces, loops {:?}; {placed} (distance to the body: median above the crotch {:.3} m, high quantile beyond the hem allowance {:.3} m); repair: {}; thin triangles: {} collapses, {} flips, worst quality {:.3} -> {:.3}; arm correction {:.1} deg; inside the body before push-out {}, after {} (face points {}); min distance to body {:.4} m",
        asset.name,
        asset.positions.len(),
        asset.faces.len(),
        asset.loop_names(),
        pl.median,
        pl.high,
        rep.repair,
        rep.remesh_ops.0,
        rep.remesh_ops.1,
        rep.quality.0,
        rep.quality.1,
        rep.arm_correction_deg,
        rep.inside_before,
        rep.inside_after,
        rep.face_points_inside,
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

    /// An arm chain along x then y (upper arm 0.3, forearm 0.4, both in the xy plane): the
    /// point at distance s from the shoulder is along the upper arm up to 0.3 + ELBOW_REACH,
    /// then on the forearm where |p − shoulder| = s (a right triangle: 0.3² + t² = s²), then
    /// the wrist.
    #[test]
    fn the_arm_point_at_a_distance_follows_the_chain() {
        let (sh, el, wr) = (Vec3::zeros(), Vec3::new(0.3, 0.0, 0.1), Vec3::new(0.3, -0.4, 0.2));
        let p = arm_point_at(sh, el, wr, 0.15);
        assert!((p - Vec3::new(0.15, 0.0, 0.0)).norm() < 1e-12, "{p}");
        let p = arm_point_at(sh, el, wr, 0.3 + 0.5 * ELBOW_REACH);
        assert!((p - Vec3::new(0.3 + 0.5 * ELBOW_REACH, 0.0, 0.0)).norm() < 1e-12, "{p}");
        let p = arm_point_at(sh, el, wr, 0.5);
        assert!((p - Vec3::new(0.3, -0.4, 0.0)).norm() < 1e-12, "{p}");
        let p = arm_point_at(sh, el, wr, (0.3f64.powi(2) + 0.2f64.powi(2)).sqrt());
        assert!((p - Vec3::new(0.3, -0.2, 0.0)).norm() < 1e-12, "{p}");
        let p = arm_point_at(sh, el, wr, 0.9);
        assert!((p - Vec3::new(0.3, -0.4, 0.0)).norm() < 1e-12, "{p}");
    }
}
