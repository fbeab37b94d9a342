//! Scene configs (TOML). A scene is the `[scene]` table of a config file, so one file can
//! also hold the training agent's `[train]` and `[model]` tables; the scene loader reads only
//! `[scene]` and refuses unknown keys inside it, naming them. Paths are relative to the
//! config file's directory.
//!
//! ```toml
//! [scene]
//! garment = "../data/garments/tshirt.msgpack"
//! body = "../data/body.msgpack"
//! close_holes = ["hem", "left_sleeve", "right_sleeve"]   # the neck stays open
//! [scene.motions]
//! train = ["../data/motions/cmu_01_01.msgpack"]
//! test = ["../data/motions/boxing_toes.msgpack"]
//! [scene.material]
//! density = 0.20022
//! thickness = 4.7e-4
//! lame_mu = 23600.0
//! lame_lambda = 44400.0
//! bending = 3.9626e-5
//! [scene.external_force]
//! gravity = [0.0, -9.81, 0.0]
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// The `[scene]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// Garment asset (MessagePack from `cargo xtask data` or `cargo xtask fit`).
    pub garment: PathBuf,
    /// Body asset.
    pub body: PathBuf,
    /// Names of the garment's boundary loops to close for self-collision (GIA); the others
    /// stay open. Names are listed in `data/README.md` per garment.
    #[serde(default)]
    pub close_holes: Vec<String>,
    /// Names of boundary loops whose vertices are pinned: they follow the skinned garment
    /// exactly (prescribed positions, no dynamics), as HOOD pins skirt waists. A skirt
    /// fitted as wide as the hips has nothing else holding it up. Default: none.
    #[serde(default)]
    pub pin: Vec<String>,
    /// Simulation frame rate, frames/s (motions are resampled to it). Default 30.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Frames blending from the rest pose (where the garment is fitted) to each motion's
    /// first frame. Default 15 (0.5 s at 30 fps).
    #[serde(default = "default_lead_in")]
    pub lead_in_frames: usize,
    /// Turn and shift each motion so that its first frame faces and stands where the rest
    /// pose does (see `Motion::aligned_to_rest_heading`), so the lead-in never spins or
    /// slides the body. Default true; false keeps the clips' world heading.
    #[serde(default = "default_true")]
    pub align_heading: bool,
    /// Time step of the first simulated step, s. HOOD starts from a static body and takes a
    /// long first step so the garment settles under gravity; default 0.1 s (our choice,
    /// three frames at 30 fps). Set it to `1 / fps` for no special first step.
    #[serde(default = "default_first_step")]
    pub first_step_dt: f64,
    /// Training and test motions.
    pub motions: MotionsConfig,
    /// Cloth material.
    #[serde(default)]
    pub material: MaterialConfig,
    /// Gravity and external force.
    #[serde(default)]
    pub external_force: ExternalForceConfig,
}

fn default_fps() -> f64 {
    30.0
}
fn default_true() -> bool {
    true
}
fn default_lead_in() -> usize {
    15
}
fn default_first_step() -> f64 {
    0.1
}

/// Motion files: `train` are seen in training, `test` never are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionsConfig {
    /// Training motions.
    pub train: Vec<PathBuf>,
    /// Test motions (unseen in training).
    #[serde(default)]
    pub test: Vec<PathBuf>,
}

/// Cloth material as plain numbers. Give either `lame_mu` and `lame_lambda` or `young` and
/// `poisson`. senc-energy turns this into its own material type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    /// Area density ρ, kg/m². Default 0.20022.
    #[serde(default = "d_density")]
    pub density: f64,
    /// Thickness h, m. Default 4.7e-4.
    #[serde(default = "d_thickness")]
    pub thickness: f64,
    /// Lamé μ, Pa. Default 23600 when neither pair is given.
    #[serde(default)]
    pub lame_mu: Option<f64>,
    /// Lamé λ, Pa. Default 44400 when neither pair is given.
    #[serde(default)]
    pub lame_lambda: Option<f64>,
    /// Young's modulus E, Pa (instead of the Lamé pair).
    #[serde(default)]
    pub young: Option<f64>,
    /// Poisson's ratio ν (instead of the Lamé pair), in (−1, 0.5).
    #[serde(default)]
    pub poisson: Option<f64>,
    /// Bending stiffness k_b, N·m. Default 3.9626e-5.
    #[serde(default = "d_bending")]
    pub bending: f64,
}

fn d_density() -> f64 {
    0.20022
}
fn d_thickness() -> f64 {
    4.7e-4
}
fn d_bending() -> f64 {
    3.9626e-5
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self {
            density: d_density(),
            thickness: d_thickness(),
            lame_mu: None,
            lame_lambda: None,
            young: None,
            poisson: None,
            bending: d_bending(),
        }
    }
}

impl MaterialConfig {
    /// Lamé parameters (μ, λ) in Pa. From Young/Poisson HOOD's conversion is used:
    /// `μ = E / (2(1 + ν))`, `λ = E ν / ((1 + ν)(1 − 2ν))`.
    pub fn lame(&self) -> Result<(f64, f64), SceneError> {
        match (self.lame_mu, self.lame_lambda, self.young, self.poisson) {
            (None, None, None, None) => Ok((23600.0, 44400.0)),
            (Some(mu), Some(la), None, None) => Ok((mu, la)),
            (None, None, Some(e), Some(nu)) if nu > -1.0 && nu < 0.5 => {
                Ok((e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))))
            }
            (None, None, Some(_), Some(nu)) => {
                Err(SceneError::Invalid(format!("material.poisson = {nu} must lie in (-1, 0.5)")))
            }
            _ => Err(SceneError::Invalid(
                "material: give both lame_mu and lame_lambda, or both young and poisson, not a mix".into(),
            )),
        }
    }

    /// Checks that every number is finite and positive where it must be.
    pub fn validate(&self) -> Result<(), SceneError> {
        let (mu, la) = self.lame()?;
        for (k, v) in
            [("density", self.density), ("thickness", self.thickness), ("bending", self.bending), ("lame_mu", mu)]
        {
            if !(v > 0.0 && v.is_finite()) {
                return Err(SceneError::Invalid(format!("material.{k} = {v} must be a positive number")));
            }
        }
        if !(la >= 0.0 && la.is_finite()) {
            return Err(SceneError::Invalid(format!("material lame_lambda = {la} must be a non-negative number")));
        }
        Ok(())
    }
}

/// Gravity and an external acceleration (wind-like), m/s².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalForceConfig {
    /// Gravity g, m/s². Default (0, −9.81, 0).
    #[serde(default = "d_gravity")]
    pub gravity: [f64; 3],
    /// Fixed external acceleration a_ext, m/s². Default zero.
    #[serde(default)]
    pub acceleration: [f64; 3],
    /// SENC samples a_ext per sequence with magnitude uniform in [0, random_max] and a
    /// uniform direction; 0 disables sampling. Default 0.
    #[serde(default)]
    pub random_max: f64,
}

fn d_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

impl Default for ExternalForceConfig {
    fn default() -> Self {
        Self { gravity: d_gravity(), acceleration: [0.0; 3], random_max: 0.0 }
    }
}

impl SceneConfig {
    /// Parses the `[scene]` table of TOML text (other top-level tables are left to their
    /// owners). `path` names the source in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let err = |m: String| SceneError::Config { path: path.to_owned(), message: m };
        let mut table: toml::Table = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        let scene = table.remove("scene").ok_or_else(|| err("no [scene] table".into()))?;
        let cfg: SceneConfig = scene.try_into().map_err(|e: toml::de::Error| err(format!("[scene]: {e}")))?;
        cfg.validate().map_err(|e| err(e.to_string()))?;
        Ok(cfg)
    }

    /// Reads a config file; relative paths inside are resolved against its directory.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
        let mut cfg = Self::parse(&text, path)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = dir.join(&*p);
            }
        };
        fix(&mut cfg.garment);
        fix(&mut cfg.body);
        cfg.motions.train.iter_mut().for_each(fix);
        cfg.motions.test.iter_mut().for_each(fix);
        Ok(cfg)
    }

    /// Checks numbers and the train/test split (no motion in both).
    pub fn validate(&self) -> Result<(), SceneError> {
        self.material.validate()?;
        if !(self.fps > 0.0 && self.fps.is_finite()) {
            return Err(SceneError::Invalid(format!("fps = {} must be positive", self.fps)));
        }
        if !(self.first_step_dt > 0.0 && self.first_step_dt.is_finite()) {
            return Err(SceneError::Invalid(format!("first_step_dt = {} must be positive", self.first_step_dt)));
        }
        if self.motions.train.is_empty() {
            return Err(SceneError::Invalid("motions.train is empty; give at least one training motion".into()));
        }
        if let Some(p) = self.motions.test.iter().find(|p| self.motions.train.contains(p)) {
            return Err(SceneError::Invalid(format!(
                "motion {} is both in motions.train and motions.test; test motions must be unseen",
                p.display()
            )));
        }
        let e = &self.external_force;
        if e.gravity.iter().chain(&e.acceleration).any(|x| !x.is_finite()) || !(e.random_max >= 0.0) {
            return Err(SceneError::Invalid("external_force values must be finite, random_max >= 0".into()));
        }
        Ok(())
    }
}
