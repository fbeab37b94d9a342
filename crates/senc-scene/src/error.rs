//! Typed errors of senc-scene. Each variant names what was wrong and how to fix it.

use std::path::PathBuf;

use senc_geom::MeshError;

/// Why a scene, asset, motion or picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read or written.
    #[error("cannot access {path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A BVH file is malformed.
    #[error("cannot parse BVH {path}: line {line}: {message}")]
    Bvh {
        /// The file (or `<string>`).
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was expected.
        message: String,
    },
    /// A MessagePack asset could not be decoded or encoded.
    #[error("cannot decode asset {path}: {message}; rebuild it with `cargo xtask data`")]
    Asset {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A scene config could not be parsed (unknown keys are named here).
    #[error("invalid scene config {path}: {message}")]
    Config {
        /// The file.
        path: PathBuf,
        /// The TOML parser's message, naming the key.
        message: String,
    },
    /// A config or asset names a hole (boundary loop) the garment does not have.
    #[error("garment {garment} has no boundary loop named {name:?}; it has {available:?}")]
    NoSuchLoop {
        /// The garment.
        garment: String,
        /// The name asked for.
        name: String,
        /// The names it has.
        available: Vec<String>,
    },
    /// A named loop of an asset does not match any boundary loop of its mesh.
    #[error("loop {name:?} of garment {garment} is not a boundary loop of its mesh; rebuild the asset")]
    LoopMismatch {
        /// The garment.
        garment: String,
        /// The loop name.
        name: String,
    },
    /// A motion refers to a different number of bones than the skeleton.
    #[error("motion {motion} has {got} bones per frame but the skeleton has {expected}; the motion was made for another rig")]
    BoneCount {
        /// The motion's name.
        motion: String,
        /// Bones in the skeleton.
        expected: usize,
        /// Bones in the motion.
        got: usize,
    },
    /// Skinning weights refer to a bone or vertex that does not exist, or do not cover every vertex.
    #[error("skinning weights are invalid: {0}")]
    Weights(String),
    /// A frame index past the end of a motion.
    #[error("frame {frame} is past the end of motion {motion} ({n_frames} frames)")]
    FrameOutOfRange {
        /// The motion's name.
        motion: String,
        /// The frame asked for.
        frame: usize,
        /// Frames in the motion.
        n_frames: usize,
    },
    /// A BVH clip parses but cannot be used (no frames, a zero pose that does not stand
    /// upright, joint names that clash).
    #[error("BVH clip {path}: {message}")]
    Clip {
        /// The file.
        path: PathBuf,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// A motion clip leaves bones of the body's rig without a joint to follow.
    #[error(
        "{clip}: no joint of the clip drives the body bones {missing:?} (tried the {tried} joint map); the clip's joints are {joints:?}. Write a joint map beside it, {map_hint}, with `[joints]` lines `BodyBone = \"ClipJoint\"` (see senc_scene::clip)"
    )]
    UnmappedJoints {
        /// The clip.
        clip: PathBuf,
        /// Body bones without a source joint.
        missing: Vec<String>,
        /// The clip's joint names.
        joints: Vec<String>,
        /// The joint map tried (a built-in name or a file).
        tried: String,
        /// Where a joint map would be read from.
        map_hint: String,
    },
    /// A joint map names a joint the clip does not have or a bone the body's rig lacks.
    #[error("joint map {map}: {message}")]
    JointMap {
        /// The joint map (file or built-in name).
        map: String,
        /// What is wrong.
        message: String,
    },
    /// A motion named neither a scene motion, a file, nor a built-in motion.
    #[error("no motion {name:?}: it is not a motion of this scene ({scene:?}), not a file, and not a built-in motion ({builtin:?}); give a scene motion name, a .bvh or .msgpack path, or a built-in name")]
    NoSuchMotion {
        /// What was asked for.
        name: String,
        /// The scene's motion names.
        scene: Vec<String>,
        /// The built-in motions beside the body asset.
        builtin: Vec<String>,
    },
    /// A garment file could not be repaired into a valid mesh.
    #[error("garment {garment}: {source}")]
    Repair {
        /// The garment.
        garment: String,
        /// Why.
        source: senc_geom::repair::RepairError,
    },
    /// An OBJ has no `o`/`g` group of the name asked for.
    #[error("{path} has no object or group named {name:?}; it has {available:?}")]
    NoSuchComponent {
        /// The OBJ.
        path: PathBuf,
        /// The name asked for.
        name: String,
        /// Its group names.
        available: Vec<String>,
    },
    /// Two garment parts could not be joined along their seams.
    #[error(transparent)]
    Zip(#[from] crate::zipper::ZipError),
    /// A value out of its allowed range.
    #[error("{0}")]
    Invalid(String),
    /// A mesh was refused by senc-geom.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

impl SceneError {
    pub(crate) fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        SceneError::Io { path: path.into(), message: e.to_string() }
    }
}
