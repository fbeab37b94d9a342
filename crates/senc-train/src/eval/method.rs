//! [`Method`]: what one Table-1 row runs (a checkpoint, its config, a garment, refinement),
//! and the row's name, taken from the checkpoint's training config.

use std::path::{Path, PathBuf};

use senc_model::burn::tensor::Device;
use senc_model::Model;

use senc_energy::{EnergyConfig, Material};

use crate::config::{Phase, RunConfig};
use crate::error::TrainError;
use crate::garment::Garment;
use crate::trainer::scene_material;
use crate::trainer::CONFIG_FILE;

/// The file of a checkpoint naming the config it was trained from (relative paths of the
/// saved config are relative to that file's directory); a relative name in it is relative
/// to the checkpoint directory (`config.toml` for a self-contained checkpoint).
pub const SOURCE_FILE: &str = "source.txt";

/// What produces a method's frames.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Predictor {
    /// A trained network.
    Network {
        /// Checkpoint directory.
        checkpoint: PathBuf,
        /// Newton iterations (phase-2 energy) refining each network frame; 0 = the network
        /// alone.
        refine: usize,
    },
    /// The reference solver: Newton from its own previous frames, no checkpoint.
    Solver,
}

/// A network or the reference solver to evaluate, with the row label and the config whose
/// scene it runs on.
#[derive(Debug, Clone)]
pub struct Method {
    /// Row label: the method the checkpoint was trained as (see [`RunConfig::method_name`]),
    /// or [`SOLVER_LABEL`].
    pub label: String,
    /// The network (with its refinement) or the solver.
    pub predictor: Predictor,
    /// Config file (scene, energy, eval settings).
    pub config: PathBuf,
    /// A garment asset that replaces the scene's garment (an unseen garment, fitted to the
    /// body first); `None` runs the scene's own garment.
    pub garment: Option<PathBuf>,
    /// Compute the error-against-run-time points (default true; `xtask eval` turns it off
    /// for a checkpoint's second and later rows, whose curve would repeat the first's).
    pub curve: bool,
}

/// The config a checkpoint was trained with: its saved `config.toml`, read as the file
/// named in `source.txt` (whose directory its relative paths refer to).
pub fn training_config(checkpoint: &Path) -> Result<RunConfig, TrainError> {
    let saved = checkpoint.join(CONFIG_FILE);
    let text = std::fs::read_to_string(&saved).map_err(|e| TrainError::Checkpoint {
        path: checkpoint.to_path_buf(),
        message: format!("cannot read {CONFIG_FILE}: {e}"),
    })?;
    let source = source_file(checkpoint).unwrap_or(saved);
    RunConfig::parse(&text, &source)
}

fn source_file(checkpoint: &Path) -> Option<PathBuf> {
    std::fs::read_to_string(checkpoint.join(SOURCE_FILE)).ok().map(|s| checkpoint.join(s.trim()))
}

impl Method {
    /// A method for `checkpoint`; the config defaults to the one the checkpoint was trained
    /// with. The label is the trained method's name, with " (phase 1)" for a `phase1`
    /// checkpoint (trained without the self-collision energy).
    pub fn new(checkpoint: &Path, config: Option<&Path>) -> Result<Self, TrainError> {
        if !checkpoint.join(CONFIG_FILE).exists() && !checkpoint.join(senc_model::checkpoint::META_FILE).exists() {
            return Err(TrainError::Checkpoint { path: checkpoint.to_path_buf(), message: "not a checkpoint".into() });
        }
        let config = match config {
            Some(c) => c.to_path_buf(),
            None => source_file(checkpoint).ok_or_else(|| TrainError::Checkpoint {
                path: checkpoint.to_path_buf(),
                message: format!("no {SOURCE_FILE}; give --config"),
            })?,
        };
        let trained = match checkpoint.join(CONFIG_FILE).exists() {
            true => training_config(checkpoint)?,
            false => RunConfig::read(&config)?,
        };
        let mut label = trained.method_name();
        if checkpoint.file_name().is_some_and(|n| n == "phase1") {
            label += " (phase 1)";
        }
        let predictor = Predictor::Network { checkpoint: checkpoint.to_path_buf(), refine: 0 };
        Ok(Self { label, predictor, config, garment: None, curve: true })
    }

    /// The reference solver on the config `config`'s scene (no checkpoint; used by
    /// `xtask simulate --solver`).
    pub fn solver(config: &Path) -> Self {
        Self {
            label: SOLVER_LABEL.into(),
            predictor: Predictor::Solver,
            config: config.to_path_buf(),
            garment: None,
            curve: true,
        }
    }

    /// The same method with each network frame refined by at most `iterations` Newton
    /// iterations of the reference solver; the label gains " + N it". The solver is
    /// returned as it is.
    pub fn with_refine(mut self, iterations: usize) -> Self {
        if let Predictor::Network { refine, .. } = &mut self.predictor {
            if iterations > 0 {
                self.label = format!("{} + {iterations} it", self.label);
            }
            *refine = iterations;
        }
        self
    }

    /// Newton iterations refining each network frame (0 for the network alone and for the
    /// solver).
    pub fn refine(&self) -> usize {
        match self.predictor {
            Predictor::Network { refine, .. } => refine,
            Predictor::Solver => 0,
        }
    }

    /// The network of a [`Predictor::Network`] method, loaded on the CPU backend.
    pub fn load_model(&self) -> Result<Model, TrainError> {
        match &self.predictor {
            Predictor::Network { checkpoint, .. } => Ok(Model::load(checkpoint, &Device::flex())?),
            Predictor::Solver => {
                Err(TrainError::Invalid("the reference solver has no network to load; give a checkpoint".into()))
            }
        }
    }

    /// The same method run on another garment asset (see [`Garment::load_unseen`]).
    pub fn with_garment(mut self, asset: &Path) -> Self {
        self.garment = Some(asset.to_path_buf());
        self
    }

    /// Everything a run of this method needs: its config, garment, the scene's material and
    /// the phase-2 energy with the scene's external force.
    pub fn scenario(&self) -> Result<Scenario, TrainError> {
        let cfg = RunConfig::read(&self.config)?;
        let garment = self.load_garment(&cfg)?;
        let material = scene_material(&garment)?;
        let energy = cfg.energy_for(Phase::Two, material, garment.scene.config.external_force.acceleration);
        Ok(Scenario { cfg, garment, material, energy })
    }

    /// The garment this method runs on: the config's first scene, or that scene with
    /// [`Method::garment`] in place of its garment.
    pub fn load_garment(&self, cfg: &RunConfig) -> Result<Garment, TrainError> {
        let scene = first_scene(cfg)?;
        match &self.garment {
            None => Garment::load(&scene, cfg.train.body_margin),
            Some(asset) => Garment::load_unseen(&scene, asset, cfg.train.body_margin),
        }
    }
}

/// What [`Method::scenario`] prepares.
#[derive(Debug)]
pub struct Scenario {
    /// The method's config.
    pub cfg: RunConfig,
    /// The garment on its scene.
    pub garment: Garment,
    /// The scene's material.
    pub material: Material,
    /// The run's phase-2 energy with the scene's material and external force.
    pub energy: EnergyConfig,
}

/// The row label of the reference solver.
pub const SOLVER_LABEL: &str = "reference solver";

/// The first scene file of a config (its own `[scene]`, else the first of `[train] scenes`).
pub fn first_scene(cfg: &RunConfig) -> Result<PathBuf, TrainError> {
    cfg.scene_files().into_iter().next().ok_or_else(|| TrainError::Config {
        path: cfg.path.clone(),
        message: "no [scene] table and no [train] scenes".into(),
    })
}
