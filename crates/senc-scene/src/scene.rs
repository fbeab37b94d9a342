//! A loaded scene: body, garment, motions (train/test), material, external force, and the
//! garment's initial state at the first frame.
//!
//! First frame (HOOD-style): every motion starts with `lead_in_frames` frames blending from
//! the rest pose, so at frame 0 the body is in the pose the garment was fitted in; the
//! garment is placed by skinning its rest mesh with its weights, with zero velocity
//! (`x[-1] = x[0]`), the body is static in the first step (`body[-1] = body[0]`), and the
//! first step takes `first_step_dt` seconds.

use std::path::Path;

use senc_geom::{HoleSelection, TriMesh, Vec3};

use crate::assets::{BodyAsset, GarmentAsset};
use crate::config::SceneConfig;
use crate::error::SceneError;
use crate::motion::Motion;
use crate::skeleton::skin;

/// Which split a motion belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Split {
    /// Seen in training.
    Train,
    /// Never seen in training.
    Test,
}

/// A scene ready for simulation.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The config it was loaded from (paths resolved).
    pub config: SceneConfig,
    /// The body asset.
    pub body: BodyAsset,
    /// The garment asset.
    pub garment: GarmentAsset,
    /// The garment rest mesh.
    pub garment_mesh: TriMesh,
    /// The body rest mesh.
    pub body_mesh: TriMesh,
    /// Training motions, resampled to `config.fps`, with the lead-in.
    pub train: Vec<Motion>,
    /// Test motions, likewise.
    pub test: Vec<Motion>,
}

/// The simulation state at the first step.
#[derive(Debug, Clone)]
pub struct InitialState {
    /// Garment positions at frame −1 (equal to `x`: zero velocity), m.
    pub x_prev: Vec<Vec3>,
    /// Garment positions at frame 0 (skinned rest mesh), m.
    pub x: Vec<Vec3>,
    /// Body positions at frame −1 (equal to `body`: static body), m.
    pub body_prev: Vec<Vec3>,
    /// Body positions at frame 0, m.
    pub body: Vec<Vec3>,
    /// Length of the first step, s.
    pub first_step_dt: f64,
}

impl Scene {
    /// Reads a config file and everything it names.
    pub fn load(config_path: impl AsRef<Path>) -> Result<Self, SceneError> {
        Self::from_config(SceneConfig::read(config_path)?)
    }

    /// Loads the assets a (path-resolved) config names.
    pub fn from_config(config: SceneConfig) -> Result<Self, SceneError> {
        let body = BodyAsset::load(&config.body)?;
        let garment = GarmentAsset::load(&config.garment)?;
        garment.weights.validate(garment.positions.len(), body.skeleton.len())?;
        garment.hole_selection(&config.close_holes)?;
        garment.loop_vertices(&config.pin)?;
        let load = |paths: &[std::path::PathBuf]| -> Result<Vec<Motion>, SceneError> {
            paths.iter().map(|p| crate::clip::load_for_scene(p, &config, &body.skeleton, &[])).collect()
        };
        let train = load(&config.motions.train)?;
        let test = load(&config.motions.test)?;
        let garment_mesh = garment.mesh()?;
        let body_mesh = body.mesh()?;
        Ok(Self { config, body, garment, garment_mesh, body_mesh, train, test })
    }

    /// The motions of one split.
    pub fn motions(&self, split: Split) -> &[Motion] {
        match split {
            Split::Train => &self.train,
            Split::Test => &self.test,
        }
    }

    /// Finds a motion by name in either split.
    pub fn motion(&self, name: &str) -> Option<(&Motion, Split)> {
        self.train
            .iter()
            .map(|m| (m, Split::Train))
            .chain(self.test.iter().map(|m| (m, Split::Test)))
            .find(|(m, _)| m.name == name)
    }

    /// A motion by scene name, or else from a file (`.bvh` clip or `.msgpack` motion,
    /// relative to the working directory) or a built-in name, prepared as the scene's own
    /// motions are (see [`crate::clip`]).
    pub fn resolve_motion(&self, name_or_path: &str) -> Result<Motion, SceneError> {
        if let Some((m, _)) = self.motion(name_or_path) {
            return Ok(m.clone());
        }
        let names: Vec<String> = self.train.iter().chain(&self.test).map(|m| m.name.clone()).collect();
        crate::clip::load_for_scene(Path::new(name_or_path), &self.config, &self.body.skeleton, &names)
    }

    /// Body vertex positions at `frame` of `motion`, m.
    pub fn body_at(&self, motion: &Motion, frame: usize) -> Result<Vec<Vec3>, SceneError> {
        let tr = self.body.skeleton.bone_transforms(&motion.pose(frame)?)?;
        Ok(skin(&self.body.positions, &self.body.weights, &tr))
    }

    /// The garment skinned to `frame` of `motion` (no dynamics), m.
    pub fn garment_skinned_at(&self, motion: &Motion, frame: usize) -> Result<Vec<Vec3>, SceneError> {
        let tr = self.body.skeleton.bone_transforms(&motion.pose(frame)?)?;
        Ok(skin(&self.garment.positions, &self.garment.weights, &tr))
    }

    /// The first-step state for `motion` (see the module doc).
    pub fn initial_state(&self, motion: &Motion) -> Result<InitialState, SceneError> {
        let x = self.garment_skinned_at(motion, 0)?;
        let body = self.body_at(motion, 0)?;
        Ok(InitialState {
            x_prev: x.clone(),
            x,
            body_prev: body.clone(),
            body,
            first_step_dt: self.config.first_step_dt,
        })
    }

    /// The holes the config closes, as a senc-geom selection.
    pub fn hole_selection(&self) -> Result<HoleSelection, SceneError> {
        self.garment.hole_selection(&self.config.close_holes)
    }

    /// The garment vertices the config pins (`[scene] pin`), sorted.
    pub fn pinned_vertices(&self) -> Result<Vec<usize>, SceneError> {
        self.garment.loop_vertices(&self.config.pin)
    }

    /// Time step, s.
    pub fn dt(&self) -> f64 {
        1.0 / self.config.fps
    }
}
