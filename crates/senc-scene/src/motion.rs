//! Motions on a skeleton: per-frame bone rotations, resampling, a lead-in from the rest pose,
//! and retargeting of BVH clips onto a skeleton by joint names.
//!
//! Retargeting: with `G_s` the global rotation of source joint `s` at a frame (identity in
//! the source rest pose) and `C_j` the minimal rotation taking the source segment's rest
//! direction to target bone `j`'s rest direction (`tail − head`), the target bone rotates by
//! `W_j = G_s C_j⁻¹`, so that it points where the source segment points. Bones without a
//! source joint (or without a usable direction) move rigidly with their parent. The root
//! translation is the source's scaled by the ratio of leg lengths, started at the rest
//! position and lifted so the lowest joint's lowest height over the clip equals its rest
//! height on the target.

use nalgebra::{Quaternion, UnitQuaternion};
use senc_geom::Vec3;
use serde::{Deserialize, Serialize};

use crate::bvh::Bvh;
use crate::error::SceneError;
use crate::skeleton::{Pose, Skeleton};

/// A motion on a skeleton, stored compactly (f32).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Motion {
    /// Name (e.g. `cmu_01_01`).
    pub name: String,
    /// Frames per second.
    pub fps: f64,
    /// Bone names, in skeleton order (checked against the skeleton at use).
    pub bone_names: Vec<String>,
    /// Root translation per frame, m.
    pub root_translation: Vec<[f32; 3]>,
    /// `W_j` per frame and bone (frame-major), quaternion `[i, j, k, w]`.
    pub rotations: Vec<[f32; 4]>,
}

fn to_q(q: &UnitQuaternion<f64>) -> [f32; 4] {
    let c = q.coords;
    [c.x as f32, c.y as f32, c.z as f32, c.w as f32]
}

fn from_q(a: &[f32; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(a[3] as f64, a[0] as f64, a[1] as f64, a[2] as f64))
}

impl Motion {
    /// Builds a motion from poses.
    pub fn from_poses(name: &str, fps: f64, bone_names: Vec<String>, poses: &[Pose]) -> Self {
        let mut rotations = Vec::with_capacity(poses.len() * bone_names.len());
        let mut root_translation = Vec::with_capacity(poses.len());
        for p in poses {
            rotations.extend(p.rotations.iter().map(to_q));
            let t = p.root_translation;
            root_translation.push([t.x as f32, t.y as f32, t.z as f32]);
        }
        Self { name: name.to_string(), fps, bone_names, root_translation, rotations }
    }

    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.root_translation.len()
    }

    /// Number of bones.
    pub fn n_bones(&self) -> usize {
        self.bone_names.len()
    }

    /// Duration, s: `(n_frames − 1) / fps`.
    pub fn duration(&self) -> f64 {
        self.n_frames().saturating_sub(1) as f64 / self.fps
    }

    /// Checks the layout and that the bone names equal the skeleton's.
    pub fn check(&self, skeleton: &Skeleton) -> Result<(), SceneError> {
        let names: Vec<&str> = skeleton.bones.iter().map(|b| b.name.as_str()).collect();
        if self.bone_names.len() != names.len() || self.rotations.len() != self.n_frames() * self.n_bones() {
            return Err(SceneError::BoneCount {
                motion: self.name.clone(),
                expected: names.len(),
                got: self.bone_names.len(),
            });
        }
        if let Some((a, b)) = self.bone_names.iter().zip(&names).find(|(a, b)| a.as_str() != **b) {
            return Err(SceneError::Invalid(format!(
                "motion {} names bone {a:?} where the skeleton has {b:?}; it was made for another rig",
                self.name
            )));
        }
        if !(self.fps > 0.0) || self.n_frames() == 0 {
            return Err(SceneError::Invalid(format!("motion {} has no frames or a non-positive fps", self.name)));
        }
        Ok(())
    }

    /// The pose at `frame`.
    pub fn pose(&self, frame: usize) -> Result<Pose, SceneError> {
        if frame >= self.n_frames() {
            return Err(SceneError::FrameOutOfRange { motion: self.name.clone(), frame, n_frames: self.n_frames() });
        }
        let nb = self.n_bones();
        let rotations = self.rotations[frame * nb..(frame + 1) * nb].iter().map(from_q).collect();
        let t = self.root_translation[frame];
        Ok(Pose { rotations, root_translation: Vec3::new(t[0] as f64, t[1] as f64, t[2] as f64) })
    }

    /// The pose at time `t` seconds (clamped to the clip), interpolated: slerp for rotations,
    /// linear for the root.
    pub fn pose_at(&self, t: f64) -> Pose {
        let s = (t * self.fps).clamp(0.0, (self.n_frames() - 1) as f64);
        let i = (s.floor() as usize).min(self.n_frames() - 1);
        let j = (i + 1).min(self.n_frames() - 1);
        let a = s - i as f64;
        let (p, q) = (self.pose(i).unwrap_or_else(|_| Pose::identity(self.n_bones())), self.pose(j));
        let q = q.unwrap_or_else(|_| p.clone());
        blend(&p, &q, a)
    }

    /// The same clip at `fps` frames per second: frames at `k / fps` for `k = 0..n` with
    /// `n = ⌊duration · fps⌋ + 1`, so the duration changes by less than one new frame.
    pub fn resample(&self, fps: f64) -> Result<Self, SceneError> {
        if !(fps > 0.0) {
            return Err(SceneError::Invalid(format!("resampling rate must be positive, got {fps}")));
        }
        let n = (self.duration() * fps + 1e-9).floor() as usize + 1;
        let poses: Vec<Pose> = (0..n).map(|k| self.pose_at(k as f64 / fps)).collect();
        Ok(Self::from_poses(&self.name, fps, self.bone_names.clone(), &poses))
    }

    /// The largest per-frame change from frame `k` to `k + 1`: the largest bone rotation
    /// angle (rad) and the root's displacement (m).
    fn jump(&self, k: usize) -> (f64, f64) {
        let nb = self.n_bones();
        let angle = (0..nb)
            .map(|j| from_q(&self.rotations[k * nb + j]).angle_to(&from_q(&self.rotations[(k + 1) * nb + j])))
            .fold(0.0, f64::max);
        let [a, b] = [k, k + 1].map(|f| Vec3::from(self.root_translation[f].map(|c| c as f64)));
        (angle, (a - b).norm())
    }

    /// The clip without the frames at its start that jump to the next one: a frame `k` of
    /// the first [`LEADING_JUMP_WINDOW`] whose change to frame `k + 1` is more than
    /// [`JUMP_FACTOR`] times the clip's median change and more than [`MIN_JUMP_ANGLE`] rad
    /// (any bone) or [`MIN_JUMP_ROOT`] m (the root) is dropped, with every frame before it.
    /// CMU's BVH conversions start with a T-pose frame that the next frame leaves in one
    /// step (arms swung down by over a radian); led into from the rest pose, that frame
    /// would make the body jump through the garment at the end of the lead-in. Returns the
    /// clip unchanged when nothing jumps, and always keeps at least two frames.
    pub fn without_leading_jumps(&self) -> Self {
        let n = self.n_frames();
        if n < 4 || self.n_bones() == 0 {
            return self.clone();
        }
        let jumps: Vec<(f64, f64)> = (0..n - 1).map(|k| self.jump(k)).collect();
        let median = |f: fn(&(f64, f64)) -> f64| {
            let mut v: Vec<f64> = jumps.iter().map(f).collect();
            let mid = v.len() / 2;
            *v.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        let (angle_limit, root_limit) =
            ((JUMP_FACTOR * median(|j| j.0)).max(MIN_JUMP_ANGLE), (JUMP_FACTOR * median(|j| j.1)).max(MIN_JUMP_ROOT));
        let cut = (0..LEADING_JUMP_WINDOW.min(n - 2))
            .filter(|&k| jumps[k].0 > angle_limit || jumps[k].1 > root_limit)
            .map(|k| k + 1)
            .max();
        match cut {
            Some(c) => self.slice(c, n),
            None => self.clone(),
        }
    }

    /// Prepends `n` frames leading in from the rest pose to the first frame, so that frame 0
    /// is the rest pose, where garments are fitted, and the body arrives at the clip's first
    /// frame with the clip's own velocity.
    ///
    /// Each bone's rotation and the root translation follow a cubic Hermite curve in the
    /// tangent space at the first frame `P₀`: with `a = k / n` for lead-in frame `k`,
    /// `offset(a) = (1 − s(a)) (rest ⊖ P₀) + h(a) n (P₁ ⊖ P₀)`, where `s(a) = 3a² − 2a³`
    /// (smoothstep), `h(a) = a³ − a²` (the Hermite basis of the end tangent), `⊖` the
    /// rotation vector `log(q₀⁻¹ q)` (a difference for the translation) and `P₁` the clip's
    /// second frame. At `a = 0` the offset is the rest pose with zero velocity; at `a = 1` it
    /// is zero with derivative `P₁ ⊖ P₀` per frame, the clip's first step. Without that
    /// second term (a smoothstep to a standstill) a clip that starts in motion jumps from
    /// rest to full speed in one frame at the lead-in's end, which flings a garment. The
    /// velocity term moves the body at most `4/27 · n` first steps away from the smoothstep.
    pub fn with_lead_in(&self, n: usize) -> Result<Self, SceneError> {
        if n == 0 {
            return Ok(self.clone());
        }
        let first = self.pose(0)?;
        let second = if self.n_frames() > 1 { self.pose(1)? } else { first.clone() };
        let rest = Pose::identity(self.n_bones());
        let log = |q0: &UnitQuaternion<f64>, q: &UnitQuaternion<f64>| (q0.inverse() * q).scaled_axis();
        let to_rest: Vec<Vec3> = first.rotations.iter().zip(&rest.rotations).map(|(q0, r)| log(q0, r)).collect();
        let step: Vec<Vec3> = first.rotations.iter().zip(&second.rotations).map(|(q0, q1)| log(q0, q1)).collect();
        let (t0, t1) = (first.root_translation, second.root_translation);
        let mut poses: Vec<Pose> = (0..n)
            .map(|k| {
                if k == 0 {
                    return rest.clone(); // exactly, not through log and exp
                }
                let a = k as f64 / n as f64;
                let back = 1.0 - a * a * (3.0 - 2.0 * a);
                let ahead = (a * a * a - a * a) * n as f64;
                let rotations = first
                    .rotations
                    .iter()
                    .zip(to_rest.iter().zip(&step))
                    .map(|(q0, (r, v))| q0 * UnitQuaternion::from_scaled_axis(r * back + v * ahead))
                    .collect();
                let root_translation = t0 + (rest.root_translation - t0) * back + (t1 - t0) * ahead;
                Pose { rotations, root_translation }
            })
            .collect();
        for f in 0..self.n_frames() {
            poses.push(self.pose(f)?);
        }
        Ok(Self::from_poses(&self.name, self.fps, self.bone_names.clone(), &poses))
    }

    /// The same motion turned about the vertical (Y) axis through the root so that its first
    /// frame faces the way the rest pose faces, and shifted horizontally so that its first
    /// frame's root stands where the rest pose's root stands.
    ///
    /// The lead-in blends from the rest pose to the first frame; a clip whose first frame
    /// faces backwards would otherwise spin the whole body by up to 180° in half a second
    /// (about 9 rad/s at the peak of the smoothstep), far faster than the motion itself, and
    /// drag the garment through the body. Heading: the yaw of the root's rotated rest
    /// forward axis +Z (its +X axis when +Z points nearly straight up or down).
    pub fn aligned_to_rest_heading(&self) -> Self {
        let Ok(first) = self.pose(0) else { return self.clone() };
        let Some(root) = first.rotations.first() else { return self.clone() };
        let f = root * Vec3::z();
        let yaw = if f.x.hypot(f.z) > 0.2 {
            f.x.atan2(f.z)
        } else {
            let x = root * Vec3::x();
            (-x.z).atan2(x.x)
        };
        let turn = UnitQuaternion::from_axis_angle(&Vec3::y_axis(), -yaw);
        let t0 = turn * first.root_translation;
        let shift = Vec3::new(t0.x, 0.0, t0.z);
        let poses: Vec<Pose> = (0..self.n_frames())
            .filter_map(|k| self.pose(k).ok())
            .map(|p| Pose {
                rotations: p.rotations.iter().map(|w| turn * w).collect(),
                root_translation: turn * p.root_translation - shift,
            })
            .collect();
        Self::from_poses(&self.name, self.fps, self.bone_names.clone(), &poses)
    }

    /// Frames `start..end` (clamped) as a new motion.
    pub fn slice(&self, start: usize, end: usize) -> Self {
        let end = end.min(self.n_frames());
        let start = start.min(end);
        let nb = self.n_bones();
        Self {
            name: self.name.clone(),
            fps: self.fps,
            bone_names: self.bone_names.clone(),
            root_translation: self.root_translation[start..end].to_vec(),
            rotations: self.rotations[start * nb..end * nb].to_vec(),
        }
    }
}

/// How many frames at a clip's start [`Motion::without_leading_jumps`] inspects.
pub const LEADING_JUMP_WINDOW: usize = 3;
/// A leading frame jumps when its change is more than this many times the clip's median.
pub const JUMP_FACTOR: f64 = 8.0;
/// ... and some bone turns by more than this, rad, ...
pub const MIN_JUMP_ANGLE: f64 = 0.5;
/// ... or the root moves by more than this, m.
pub const MIN_JUMP_ROOT: f64 = 0.15;

/// Interpolates two poses: slerp per bone, linear root translation; `a = 0` gives `p`.
pub fn blend(p: &Pose, q: &Pose, a: f64) -> Pose {
    let rotations = p.rotations.iter().zip(&q.rotations).map(|(x, y)| x.try_slerp(y, a, 1e-9).unwrap_or(*x)).collect();
    Pose { rotations, root_translation: p.root_translation * (1.0 - a) + q.root_translation * a }
}

/// Joint-name map from the CMU BVH skeleton (01_01, 01_03) onto the `cmu_mb` rig: identical
/// names except the finger bones.
pub const CMU_TO_CMU_MB: &[(&str, &str)] = &[("LeftHandFinger1", "LFingers"), ("RightHandFinger1", "RFingers")];

/// Joint-name map (target bone, source joint) for `Boxing_Toes.bvh`'s 21-joint skeleton.
pub const BOXING_TO_CMU_MB: &[(&str, &str)] = &[
    ("Hips", "Hips"),
    ("LowerBack", "Ab"),
    ("Spine1", "Chest"),
    ("Neck", "Neck"),
    ("Head", "Head"),
    ("LeftShoulder", "LeftCollar"),
    ("LeftArm", "LeftShoulder"),
    ("LeftForeArm", "LeftElbow"),
    ("LeftHand", "LeftWrist"),
    ("RightShoulder", "RightCollar"),
    ("RightArm", "RightShoulder"),
    ("RightForeArm", "RightElbow"),
    ("RightHand", "RightWrist"),
    ("LeftUpLeg", "LeftHip"),
    ("LeftLeg", "LeftKnee"),
    ("LeftFoot", "LeftAnkle"),
    ("LeftToeBase", "LeftToes"),
    ("RightUpLeg", "RightHip"),
    ("RightLeg", "RightKnee"),
    ("RightFoot", "RightAnkle"),
    ("RightToeBase", "RightToes"),
];

/// Which source joint drives each target bone: `map` entries `(target, source)` first, then
/// equal names when `same_names` is set.
pub(crate) fn source_of(bvh: &Bvh, skeleton: &Skeleton, map: &[(&str, &str)], same_names: bool) -> Vec<Option<usize>> {
    skeleton
        .bones
        .iter()
        .map(|b| {
            map.iter().find(|(t, _)| *t == b.name).and_then(|(_, s)| bvh.find(s)).or_else(|| {
                if same_names {
                    bvh.find(&b.name)
                } else {
                    None
                }
            })
        })
        .collect()
}

/// Retargets a BVH clip onto `skeleton` (see the module doc). `map` lists `(target bone,
/// source joint)` pairs; with `same_names`, unmapped bones also match source joints of the
/// same name. The source must be Y-up and face +z in its rest pose, as the target does.
pub fn retarget(
    bvh: &Bvh,
    skeleton: &Skeleton,
    map: &[(&str, &str)],
    same_names: bool,
    name: &str,
) -> Result<Motion, SceneError> {
    skeleton.validate()?;
    if bvh.frames.is_empty() {
        return Err(SceneError::Invalid(format!("BVH clip {name} has no frames")));
    }
    let src = source_of(bvh, skeleton, map, same_names);
    if src.first().copied().flatten().is_none() {
        return Err(SceneError::Invalid(format!("the root bone of the skeleton has no source joint in {name}")));
    }
    // Rest corrections C_j.
    let mut c: Vec<UnitQuaternion<f64>> = Vec::with_capacity(skeleton.len());
    for (j, b) in skeleton.bones.iter().enumerate() {
        let d_t = b.tail - b.head;
        let own = src[j]
            .and_then(|s| bvh.rest_direction(s))
            .filter(|_| d_t.norm() > 1e-9 && b.parent.is_some())
            .and_then(|d_b| UnitQuaternion::rotation_between(&d_b, &d_t));
        c.push(own.unwrap_or_else(|| b.parent.map_or(UnitQuaternion::identity(), |p| c[p])));
    }
    // Scale: target leg (thigh + shin) over the source's.
    let leg = |t: &str, s_next: &str| -> Option<(f64, f64)> {
        let j = skeleton.find(t)?;
        let k = skeleton.find(s_next)?;
        let sk = src[k]?;
        Some(((skeleton.bones[k].head - skeleton.bones[j].head).norm(), bvh.joints[sk].offset.norm()))
    };
    let (lt, ls) = [("LeftUpLeg", "LeftLeg"), ("LeftLeg", "LeftFoot")]
        .iter()
        .filter_map(|(a, b)| leg(a, b))
        .fold((0.0, 0.0), |acc, x| (acc.0 + x.0, acc.1 + x.1));
    let scale = if lt > 0.0 && ls > 0.0 { lt / ls } else { 1.0 };
    // Vertical placement: lowest joint over the clip on the source ~ lowest joint head at rest.
    let src_root: Vec<Vec3> = (0..bvh.frames.len()).map(|f| bvh.root_position(f)).collect();
    let src_low = (0..bvh.frames.len())
        .map(|f| {
            let pos = bvh.joint_positions(f);
            let low = pos.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
            low - src_root[f].y
        })
        .zip(&src_root)
        .map(|(rel, r)| r.y + rel)
        .fold(f64::INFINITY, f64::min);
    let root_head = skeleton.bones[0].head;
    let tgt_low = skeleton.bones.iter().map(|b| b.head.y).fold(f64::INFINITY, f64::min);
    let mut poses = Vec::with_capacity(bvh.frames.len());
    for f in 0..bvh.frames.len() {
        let g = bvh.global_rotations(f);
        let mut r: Vec<UnitQuaternion<f64>> = Vec::with_capacity(skeleton.len());
        for (j, b) in skeleton.bones.iter().enumerate() {
            let rj = match (src[j], b.parent) {
                (Some(s), _) => g[s],
                (None, Some(p)) => r[p],
                (None, None) => UnitQuaternion::identity(),
            };
            r.push(rj);
        }
        let rotations = r.iter().zip(&c).map(|(rj, cj)| rj * cj.inverse()).collect();
        let d = src_root[f] - src_root[0];
        let y = tgt_low + scale * (src_root[f].y - src_low) - root_head.y;
        let root_translation = Vec3::new(scale * d.x, y, scale * d.z);
        poses.push(Pose { rotations, root_translation });
    }
    let names = skeleton.bones.iter().map(|b| b.name.clone()).collect();
    Ok(Motion::from_poses(name, 1.0 / bvh.frame_time, names, &poses))
}
