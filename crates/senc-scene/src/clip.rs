//! Motion clips from files: BVH clips retargeted by joint name onto the body's rig, motion
//! assets, and the "name or file" resolution shared by scene configs and `simulate --motion`.
//!
//! A BVH clip is read ([`Bvh`]), namespace prefixes are dropped from its joint names
//! (`mixamorig:Hips` → `Hips`), and a [`JointMap`] says which clip joint drives which bone of
//! the body's CMU-named rig. The map is, in this order: the one given by the caller; a TOML
//! file beside the clip, `<stem>.joints.toml` or `joints.toml`; else the built-in map
//! ([`JointMap::builtin`]: CMU names, Mixamo, the Biovision boxing skeleton, MocapBank) that
//! drives the most bones. Every bone in [`REQUIRED_BONES`] must be driven; otherwise the
//! error names the undriven bones and the clip's joints. The other bones follow their parent.
//!
//! Joint map file:
//! ```toml
//! same_names = true          # bones not listed follow the clip joint of the same name
//! [joints]                   # body bone = clip joint
//! LowerBack = "Spine"
//! Spine = "Spine1"
//! ```
//!
//! A scene then prepares every motion the same way ([`prepare`]): resampled to the scene's
//! fps, turned to the rest pose's heading (`Motion::aligned_to_rest_heading`) and led in
//! from the rest pose.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::assets::read_msgpack;
use crate::bvh::Bvh;
use crate::config::SceneConfig;
use crate::error::SceneError;
use crate::motion::{retarget, source_of, Motion, BOXING_TO_CMU_MB, CMU_TO_CMU_MB};
use crate::skeleton::Skeleton;

/// Bones of the body's rig that a clip must drive: pelvis, chest, head and every limb
/// segment a garment covers. The others (hip joints, lower back, neck, fingers, toes)
/// follow their parent when the clip has no joint for them.
pub const REQUIRED_BONES: &[&str] = &[
    "Hips",
    "Spine1",
    "Head",
    "LeftArm",
    "LeftForeArm",
    "LeftHand",
    "RightArm",
    "RightForeArm",
    "RightHand",
    "LeftUpLeg",
    "LeftLeg",
    "LeftFoot",
    "RightUpLeg",
    "RightLeg",
    "RightFoot",
];

/// Mixamo's names (after dropping the `mixamorig:` namespace) differ from CMU's only in
/// the spine.
const MIXAMO_TO_CMU_MB: &[(&str, &str)] = &[("LowerBack", "Spine"), ("Spine", "Spine1"), ("Spine1", "Spine2")];

/// Which clip joint drives which body bone.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JointMap {
    /// Name, for messages (a built-in name or the file's path).
    pub name: String,
    /// `(body bone, clip joint)` pairs.
    pub pairs: Vec<(String, String)>,
    /// Bones not in `pairs` follow the clip joint of the same name.
    pub same_names: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JointMapFile {
    #[serde(default)]
    same_names: bool,
    #[serde(default)]
    joints: BTreeMap<String, String>,
}

impl JointMap {
    fn from_table(name: &str, table: &[(&str, &str)], same_names: bool) -> Self {
        let pairs = table.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
        Self { name: name.to_string(), pairs, same_names }
    }

    /// The built-in maps, tried in this order: `cmu` (CMU names, as the rig's), `mixamo`,
    /// `biovision-boxing` (assimp's Boxing_Toes skeleton), `mocapbank`.
    pub fn builtin() -> Vec<Self> {
        // MocapBank's Biovision-style skeleton is the boxing one with `Chest`, `Chest2` for
        // `Ab`, `Chest`, and without toes.
        let mocapbank: Vec<(&str, &str)> = BOXING_TO_CMU_MB
            .iter()
            .filter(|(bone, _)| !bone.ends_with("ToeBase"))
            .map(|&(bone, joint)| match bone {
                "LowerBack" => (bone, "Chest"),
                "Spine1" => (bone, "Chest2"),
                _ => (bone, joint),
            })
            .collect();
        vec![
            Self::from_table("cmu", CMU_TO_CMU_MB, true),
            Self::from_table("mixamo", MIXAMO_TO_CMU_MB, true),
            Self::from_table("biovision-boxing", BOXING_TO_CMU_MB, false),
            Self::from_table("mocapbank", &mocapbank, false),
        ]
    }

    /// Parses a joint map file (see the module doc); `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let f: JointMapFile = toml::from_str(text)
            .map_err(|e| SceneError::JointMap { map: path.display().to_string(), message: e.to_string() })?;
        Ok(Self { name: path.display().to_string(), pairs: f.joints.into_iter().collect(), same_names: f.same_names })
    }

    /// Reads a joint map file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// The map file that belongs to a clip, if there is one: `<stem>.joints.toml`, else
    /// `joints.toml` in the clip's folder.
    pub fn beside(clip: &Path) -> Option<PathBuf> {
        let dir = clip.parent().unwrap_or(Path::new(""));
        let stem = clip.file_stem()?.to_string_lossy();
        [dir.join(format!("{stem}.joints.toml")), dir.join("joints.toml")].into_iter().find(|p| p.is_file())
    }

    fn table(&self) -> Vec<(&str, &str)> {
        self.pairs.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect()
    }

    /// Per body bone, the clip joint that drives it.
    pub fn sources(&self, bvh: &Bvh, skeleton: &Skeleton) -> Vec<Option<usize>> {
        source_of(bvh, skeleton, &self.table(), self.same_names)
    }

    /// The [`REQUIRED_BONES`] this map leaves without a clip joint.
    pub fn missing(&self, bvh: &Bvh, skeleton: &Skeleton) -> Vec<String> {
        let src = self.sources(bvh, skeleton);
        REQUIRED_BONES
            .iter()
            .filter(|b| skeleton.find(b).is_none_or(|j| src[j].is_none()))
            .map(|b| b.to_string())
            .collect()
    }

    /// Checks that every pair names a bone of the rig and a joint of the clip.
    pub fn check(&self, bvh: &Bvh, skeleton: &Skeleton) -> Result<(), SceneError> {
        let err = |message: String| SceneError::JointMap { map: self.name.clone(), message };
        for (bone, joint) in &self.pairs {
            if skeleton.find(bone).is_none() {
                let names: Vec<&str> = skeleton.bones.iter().map(|b| b.name.as_str()).collect();
                return Err(err(format!("the body's rig has no bone {bone:?}; its bones are {names:?}")));
            }
            if bvh.find(joint).is_none() {
                let names: Vec<&str> = bvh.joints.iter().map(|j| j.name.as_str()).collect();
                return Err(err(format!(
                    "bone {bone} follows joint {joint:?}, which the clip lacks; its joints are {names:?}"
                )));
            }
        }
        Ok(())
    }
}

/// Retargets a parsed clip onto `skeleton` (see the module doc for how the map is chosen).
/// `path` names the clip in errors and gives the motion its name (the file stem).
pub fn retarget_clip(
    bvh: &Bvh,
    path: &Path,
    skeleton: &Skeleton,
    map: Option<&JointMap>,
) -> Result<Motion, SceneError> {
    let mut bvh = bvh.clone();
    bvh.strip_namespaces(path)?;
    if bvh.frames.is_empty() {
        return Err(SceneError::Clip { path: path.to_owned(), message: "the clip has no frames".into() });
    }
    let beside = JointMap::beside(path);
    let given = match (map, &beside) {
        (Some(m), _) => Some(m.clone()),
        (None, Some(file)) => Some(JointMap::read(file)?),
        (None, None) => None,
    };
    if let Some(m) = &given {
        m.check(&bvh, skeleton)?;
    }
    let map = match given {
        Some(m) => m,
        None => {
            // Built-in tables list joints a clip may have; they are not checked.
            let driven = |m: &JointMap| m.sources(&bvh, skeleton).iter().filter(|s| s.is_some()).count();
            let all = JointMap::builtin();
            let complete = all.iter().filter(|m| m.missing(&bvh, skeleton).is_empty()).max_by_key(|m| {
                // Most bones driven; ties go to the earlier map.
                (driven(m), std::cmp::Reverse(all.iter().position(|a| a == *m)))
            });
            match complete {
                Some(m) => m.clone(),
                None => all
                    .iter()
                    .min_by_key(|m| m.missing(&bvh, skeleton).len())
                    .cloned()
                    .unwrap_or_else(|| JointMap { name: "none".into(), pairs: Vec::new(), same_names: true }),
            }
        }
    };
    let missing = map.missing(&bvh, skeleton);
    if !missing.is_empty() {
        let stem = path.file_stem().map_or("clip".into(), |s| s.to_string_lossy().into_owned());
        return Err(SceneError::UnmappedJoints {
            clip: path.to_owned(),
            missing,
            joints: bvh.joints.iter().map(|j| j.name.clone()).collect(),
            tried: map.name.clone(),
            map_hint: format!("{stem}.joints.toml or joints.toml"),
        });
    }
    check_rest_pose(&bvh, path, &map.sources(&bvh, skeleton), skeleton)?;
    let name = path.file_stem().map_or("clip".into(), |s| s.to_string_lossy().into_owned());
    let m = retarget(&bvh, skeleton, &map.table(), map.same_names, &name)?;
    if m.rotations.iter().flatten().chain(m.root_translation.iter().flatten()).any(|x| !x.is_finite()) {
        return Err(SceneError::Clip {
            path: path.to_owned(),
            message: "retargeting gave non-finite values (are the joint offsets degenerate?)".into(),
        });
    }
    Ok(m)
}

/// Retargeting compares directions with the clip's all-angles-zero pose, so that pose must
/// stand as the body's rest pose does: Y up (hips to head within 45° of +y) and facing +z
/// (right hip to left hip within 45° of +x). Clips from tools whose zero pose lies, faces
/// sideways or is Z-up are refused rather than retargeted wrongly.
fn check_rest_pose(bvh: &Bvh, path: &Path, src: &[Option<usize>], skeleton: &Skeleton) -> Result<(), SceneError> {
    let mut rest: Vec<senc_geom::Vec3> = Vec::with_capacity(bvh.joints.len());
    for j in &bvh.joints {
        let base = j.parent.map_or(senc_geom::Vec3::zeros(), |p| rest[p]);
        rest.push(base + j.offset);
    }
    let at = |bone: &str| skeleton.find(bone).and_then(|b| src[b]).map(|s| rest[s]);
    let (Some(hips), Some(head), Some(left), Some(right)) = (at("Hips"), at("Head"), at("LeftUpLeg"), at("RightUpLeg"))
    else {
        return Ok(());
    };
    let (up, side) = (head - hips, left - right);
    let cos45 = std::f64::consts::FRAC_1_SQRT_2;
    if up.normalize().y < cos45 || side.normalize().x < cos45 || !up.iter().chain(side.iter()).all(|c| c.is_finite()) {
        return Err(SceneError::Clip { path: path.to_owned(), message: format!(
                "the clip's zero pose does not stand Y-up facing +z (hips to head ({:.2}, {:.2}, {:.2}), right to left hip ({:.2}, {:.2}, {:.2})); retargeting needs the zero pose upright, as CMU, Mixamo and Biovision files have it: re-export the clip with a T-pose or A-pose rest",
                up.x, up.y, up.z, side.x, side.y, side.z
            ),
        });
    }
    Ok(())
}

/// Reads a motion file for `skeleton`: a `.bvh` clip (retargeted, see the module doc) or a
/// `.msgpack` motion asset (checked against the skeleton). Not yet resampled or led in.
pub fn read_motion(path: &Path, skeleton: &Skeleton) -> Result<Motion, SceneError> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("bvh") => retarget_clip(&Bvh::read(path)?, path, skeleton, None),
        Some("msgpack") => {
            let m: Motion = read_msgpack(path)?;
            m.check(skeleton)?;
            Ok(m)
        }
        _ => Err(SceneError::Invalid(format!(
            "motion file {}: give a .bvh clip or a .msgpack motion asset",
            path.display()
        ))),
    }
}

/// The built-in motions: the `.msgpack` files in `motions/` beside the body asset, by name.
pub fn builtin_motions(body: &Path) -> Vec<(String, PathBuf)> {
    let dir = body.parent().unwrap_or(Path::new("")).join("motions");
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "msgpack"))
        .filter_map(|p| Some((p.file_stem()?.to_string_lossy().into_owned(), p)))
        .collect();
    out.sort();
    out
}

/// A motion given as a file or as a built-in name: an existing file is itself; otherwise a
/// path without extension whose last component names a built-in motion (a config entry
/// `"cmu_01_01"`, which the config reader made relative to the config's folder) is that
/// motion. `scene` lists the scene's own motion names for the error.
pub fn motion_path(given: &Path, body: &Path, scene: &[String]) -> Result<PathBuf, SceneError> {
    if given.is_file() {
        return Ok(given.to_owned());
    }
    let builtin = builtin_motions(body);
    if given.extension().is_none() {
        if let Some(name) = given.file_name().map(|n| n.to_string_lossy()) {
            if let Some((_, p)) = builtin.iter().find(|(n, _)| *n == name) {
                return Ok(p.clone());
            }
        }
    }
    Err(SceneError::NoSuchMotion {
        name: given.display().to_string(),
        scene: scene.to_vec(),
        builtin: builtin.into_iter().map(|(n, _)| n).collect(),
    })
}

/// Prepares a motion for a scene: without the frames at its start that jump
/// ([`Motion::without_leading_jumps`], e.g. a T-pose), resampled to `config.fps` (a clip
/// within 0.01% of it is taken as is), turned to the rest heading when
/// `config.align_heading`, and led in from the rest pose over `config.lead_in_frames`.
pub fn prepare(m: Motion, config: &SceneConfig) -> Result<Motion, SceneError> {
    let m = m.without_leading_jumps();
    // Files round the frame time (0.033333 s): rates within 0.01% count as equal.
    let m = if (m.fps - config.fps).abs() > 1e-4 * config.fps {
        m.resample(config.fps)?
    } else {
        Motion { fps: config.fps, ..m }
    };
    let m = if config.align_heading { m.aligned_to_rest_heading() } else { m };
    m.with_lead_in(config.lead_in_frames)
}

/// Reads, resolves and prepares one motion of a scene (see [`motion_path`], [`read_motion`],
/// [`prepare`]).
pub fn load_for_scene(
    given: &Path,
    config: &SceneConfig,
    skeleton: &Skeleton,
    scene: &[String],
) -> Result<Motion, SceneError> {
    let path = motion_path(given, &config.body, scene)?;
    prepare(read_motion(&path, skeleton)?, config)
}
