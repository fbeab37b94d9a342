//! The training config: the `[train]`, `[model]`, `[energy]` and `[eval]` tables of a scene
//! config file (the `[scene]` table belongs to senc-scene). Every key has a default, so a
//! plain scene file trains with the defaults below. Unknown keys are refused, naming them.
//! A file may extend another and change only what differs (`extends = "tshirt.toml"`, see
//! [`senc_scene::config::ConfigDocument`]); `cargo xtask train --seed N --set key=value` changes
//! the resolved config, and the run saves the result beside its checkpoints.
//!
//! ```toml
//! [train]
//! seed = 0
//! phase1_iterations = 2000     # without the self-collision energy
//! phase2_iterations = 1000     # from phase 1's weights, all energies
//! [model]
//! latent = 32
//! blocks = 4
//! self_edges = "exclude_mesh"  # "none" (HOOD), "keep_mesh" (ablation)
//! [energy.self_collision]
//! weight = 30000.0             # phase 2 only; 0 gives the HOOD-like baseline
//! ```

use std::path::{Path, PathBuf};

use senc_energy::EnergyConfig;
use senc_model::{GraphConfig, ModelConfig, SelfEdges};
use senc_scene::config::ConfigDocument;
use serde::{Deserialize, Serialize};

use crate::error::TrainError;

/// A stage of training. Logs and checkpoints store it as its number (0, 1, 2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub enum Phase {
    /// Normaliser statistics are gathered; no optimiser step.
    WarmUp,
    /// HOOD's energy: everything but self-collision, area and repulsion.
    #[default]
    One,
    /// The full energy, with SENC's self-collision term.
    Two,
}

impl Phase {
    /// The phase's number: 0 (warm-up), 1 or 2.
    pub fn number(self) -> u8 {
        self.into()
    }
}

impl From<Phase> for u8 {
    fn from(p: Phase) -> u8 {
        match p {
            Phase::WarmUp => 0,
            Phase::One => 1,
            Phase::Two => 2,
        }
    }
}

impl TryFrom<u8> for Phase {
    type Error = String;

    fn try_from(n: u8) -> Result<Self, String> {
        match n {
            0 => Ok(Phase::WarmUp),
            1 => Ok(Phase::One),
            2 => Ok(Phase::Two),
            _ => Err(format!("training phase {n} does not exist (0 = warm-up, 1 or 2)")),
        }
    }
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Phase::WarmUp => f.write_str("warm-up"),
            p => write!(f, "phase {}", p.number()),
        }
    }
}

/// The `[train]` table: schedule, optimiser, randomisation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Seed of every random choice (windows, materials, forces, noise, weights). Default 0.
    pub seed: u64,
    /// Iterations that only collect normaliser statistics, before phase 1 (HOOD: 100).
    pub warmup_iterations: u64,
    /// Optimiser steps of phase 1 (no self-collision, area or repulsion energy).
    pub phase1_iterations: u64,
    /// Optimiser steps of phase 2 (all energies of `[energy]`).
    pub phase2_iterations: u64,
    /// A checkpoint every this many iterations (and at the end of each phase). Default 100.
    pub checkpoint_every: u64,
    /// Base learning rate (HOOD: 5e-5; short CPU runs use more).
    pub learning_rate: f64,
    /// Learning rate at step k: `lr · (0.5^⌊k / lr_halving⌋ + 0.01)` (HOOD: 50000).
    pub lr_halving: u64,
    /// Global gradient-norm clip (HOOD: 1).
    pub grad_clip: f64,
    /// Longest rollout (HOOD: 5).
    pub rollout_max: usize,
    /// Rollout length `min(1 + ⌊k / rollout_growth⌋, rollout_max)` (HOOD: 5000).
    pub rollout_growth: u64,
    /// σ of the Gaussian noise added to the initial positions, m (HOOD: 3e-3).
    pub noise_std: f64,
    /// Probability that a sequence starts at frame 0 with the long first step
    /// (`[scene] first_step_dt`) from the skinned rest pose.
    pub first_step_probability: f64,
    /// Largest share of cloth vertices inside the (proxy) body in the skinned state a
    /// mid-motion sequence starts from; windows above it are redrawn (up to
    /// `start_tries` times, then the least penetrating one drawn is used). Linear blend
    /// skinning pushes loose garments deep into the body where limbs meet the torso, and
    /// such starts teach only how to undo skinning artefacts (hundreds of joules of
    /// collision energy against about one joule for a physical step). 1 disables the test.
    pub max_start_penetration: f64,
    /// Windows drawn at most per sequence for `max_start_penetration`.
    pub start_tries: usize,
    /// Newton iterations that relax each mid-motion start out of the body before use (see
    /// `Garment::relax_start`: the scene's material, phase-1 energy, zero velocity, static
    /// body; the skinned velocity is kept). Default 4; 0 uses the skinned state as it is.
    pub relax_start_iterations: usize,
    /// Length of the one implicit step that relaxes a start, s. One frame (1/30 s) leaves
    /// the garment partly settled; a long step weakens the inertia term, so the relaxed
    /// garment hangs near its static equilibrium in the start's pose.
    pub relax_start_dt: f64,
    /// Draw each sequence's material from HOOD's ranges (else the scene's material).
    pub random_material: bool,
    /// Largest magnitude of the random external acceleration per sequence, m/s² (SENC: 10).
    pub external_max: f64,
    /// Body vertices farther than this from every rest garment vertex are left out of the
    /// graph and the collision queries (a proxy body), m. Default 0.12.
    pub body_margin: f64,
    /// Extra scene configs whose `[scene]` garments are sampled per sequence besides this
    /// file's own (one model for many garments, `all.toml`). Relative to this file.
    pub scenes: Vec<PathBuf>,
    /// HOOD's collision-weight ramp: the body-collision weight starts at this value (J/m³)
    /// and grows linearly to `[energy.collision] weight` over `collision_ramp_iterations`
    /// training iterations (phase 1 then phase 2, counted together). HOOD: 5e3 → 5e5.
    /// Unset (the default): the full weight from the start.
    pub collision_weight_start: Option<f64>,
    /// Length of the collision-weight ramp, iterations (HOOD ramps over 100k; ours are
    /// shorter). Ignored without `collision_weight_start`.
    pub collision_ramp_iterations: u64,
    /// Probability that a mid-motion training sequence (not in warm-up) starts from a state
    /// the network itself reached in an earlier rollout (the visited-state pool) instead of
    /// a skinned one. Skinned starts show only cloth that hangs on the body; rolled out
    /// alone, the network reaches states it never trained on (lifted, swinging, crumpled)
    /// and its errors compound there. Default 0: off.
    pub pool_share: f64,
    /// States the pool keeps (the oldest is replaced first). Default 64.
    pub pool_size: usize,
    /// Every this many training iterations the current network is rolled out alone from a
    /// fresh skinned start for `pool_frames` frames, and every `pool_stride`-th state it
    /// reaches enters the pool. Default 50.
    pub pool_every: u64,
    /// Frames of each pool rollout. Default 60.
    pub pool_frames: usize,
    /// Every this many frames of a pool rollout, the state enters the pool. Default 5.
    pub pool_stride: usize,
    /// `β`, the weight of the Newton step in the inertia's metric added to the energy
    /// gradient in the training signal, `g + β (M / Δt²) H⁻¹ g` (see `signal`): errors of
    /// the soft global modes (a drift) weigh `1 + β` times more next to the stiff ones.
    /// Default 0: the plain gradient, no Hessian.
    pub newton_weight: f64,
    /// PCG iterations of the Newton signal. Default 20.
    pub signal_cg_iterations: usize,
    /// Relative residual at which the Newton signal's PCG stops. Default 1e-4.
    pub signal_cg_tolerance: f64,
    /// Every this many phase-2 iterations the network is rolled out alone on the training
    /// motions (`select_frames` frames of each, from the skinned garment at frame 0, the
    /// scene's material, no external force) and scored by its mean distance from the
    /// skinned garment over all frames; `OUT/phase2` holds the best-scoring network among
    /// those under `select_max_volume_cm3`
    /// (`OUT/best` while training; scores in `OUT/selection.csv`; `OUT/latest` keeps the
    /// last one). One-step losses do not
    /// show how far a network drifts when its steps compound, and networks of one run
    /// differ widely in that. The test motions are never used. Default 0: the last
    /// network.
    pub select_every: u64,
    /// Frames of each selection rollout. Default 60.
    pub select_frames: usize,
    /// A network whose selection rollouts average more exact penetration volume than
    /// this, cm³, is not selected, however close it stays: a garment can stay near the
    /// skinned one by passing through itself. Default 100 (the networks that keep their
    /// cloth apart stay below 30 on the shipped garments' motions; one that has passed
    /// through itself reaches thousands).
    pub select_max_volume_cm3: f64,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            warmup_iterations: 100,
            phase1_iterations: 2000,
            phase2_iterations: 1000,
            checkpoint_every: 100,
            learning_rate: 5e-4,
            lr_halving: 50_000,
            grad_clip: 1.0,
            rollout_max: 5,
            rollout_growth: 500,
            noise_std: 3e-3,
            first_step_probability: 0.1,
            max_start_penetration: 0.005,
            start_tries: 20,
            relax_start_iterations: 4,
            relax_start_dt: 1.0 / 30.0,
            random_material: true,
            external_max: 10.0,
            body_margin: 0.12,
            scenes: Vec::new(),
            collision_weight_start: None,
            collision_ramp_iterations: 1000,
            pool_share: 0.0,
            pool_size: 64,
            pool_every: 50,
            pool_frames: 60,
            pool_stride: 5,
            newton_weight: 0.0,
            signal_cg_iterations: 20,
            signal_cg_tolerance: 1e-4,
            select_every: 0,
            select_frames: 60,
            select_max_volume_cm3: 100.0,
        }
    }
}

impl TrainConfig {
    /// Learning rate of global step `k` (HOOD's step decay with a floor).
    pub fn lr(&self, k: u64) -> f64 {
        self.learning_rate * (0.5f64.powi((k / self.lr_halving.max(1)) as i32) + 0.01)
    }

    /// Body-collision weight at training iteration `k` (phase 1 and 2 counted together),
    /// given the full weight `end` (HOOD's linear ramp; `end` when no ramp is configured).
    pub fn collision_weight(&self, k: u64, end: f64) -> f64 {
        match self.collision_weight_start {
            None => end,
            Some(start) => {
                let s = (k as f64 / self.collision_ramp_iterations.max(1) as f64).min(1.0);
                start + (end - start) * s
            }
        }
    }

    /// Rollout length at phase iteration `k`.
    pub fn rollout_len(&self, k: u64) -> usize {
        ((1 + k / self.rollout_growth.max(1)) as usize).min(self.rollout_max.max(1))
    }
}

/// The `[model]` table: the network's sizes and the graph's construction, which a
/// checkpoint saves, and the start of the decoder. Written flat in TOML ([`ModelTable`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "ModelTable", into = "ModelTable")]
pub struct ModelSection {
    /// The network's sizes.
    pub network: ModelConfig,
    /// How the graph is built.
    pub graph: GraphConfig,
    /// Start the decoder's last layer at zero, so the untrained network takes a smooth
    /// free-flight step (HOOD: no, random).
    pub zero_init_output: bool,
}

impl Default for ModelSection {
    fn default() -> Self {
        ModelTable::default().into()
    }
}

/// The `[model]` table as written, with the defaults for 2 CPU cores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct ModelTable {
    /// Latent width (HOOD: 128). Default 32 (CPU).
    latent: usize,
    /// Message-passing blocks (HOOD: 15). Default 4 (CPU).
    blocks: usize,
    /// Hidden layers per MLP (HOOD: 2). Default 1.
    hidden_layers: usize,
    /// LayerNorm after every MLP but the decoder.
    layer_norm: bool,
    /// HOOD's coarse levels (0: none).
    coarse_levels: usize,
    /// Self-collision edges.
    self_edges: SelfEdges,
    /// Self-collision edge radius, m (SENC: 0.02).
    self_radius: f64,
    /// Body edge radius, m (HOOD: 0.03).
    body_radius: f64,
    /// See [`ModelSection::zero_init_output`]. Default true.
    zero_init_output: bool,
    /// Give the nodes the cloth's elastic acceleration at `x[t]` (stretching and bending
    /// force per unit mass): whether a vertex is held up by its neighbours, which the edge
    /// lengths show only as tiny strains. HOOD: no. Default true.
    elastic_features: bool,
    /// Measure velocities in the body's frame (its mean velocity subtracted; see
    /// `senc_model::GraphConfig::comoving`), so that a garment carried by a walking body
    /// looks as it does on a body moving in place. HOOD: no. Default true.
    comoving: bool,
}

impl Default for ModelTable {
    fn default() -> Self {
        Self {
            latent: 32,
            blocks: 4,
            hidden_layers: 1,
            layer_norm: true,
            coarse_levels: 0,
            self_edges: SelfEdges::ExcludeMesh,
            self_radius: 0.02,
            body_radius: 0.03,
            zero_init_output: true,
            elastic_features: true,
            comoving: true,
        }
    }
}

impl From<ModelTable> for ModelSection {
    fn from(t: ModelTable) -> Self {
        let network = ModelConfig::new()
            .with_latent(t.latent)
            .with_blocks(t.blocks)
            .with_hidden_layers(t.hidden_layers)
            .with_layer_norm(t.layer_norm)
            .with_coarse_levels(t.coarse_levels);
        let graph = GraphConfig {
            self_radius: t.self_radius,
            body_radius: t.body_radius,
            self_edges: t.self_edges,
            coarse_levels: t.coarse_levels,
            elastic_features: t.elastic_features,
            comoving: t.comoving,
        };
        Self { network, graph, zero_init_output: t.zero_init_output }
    }
}

impl From<ModelSection> for ModelTable {
    fn from(m: ModelSection) -> Self {
        Self {
            latent: m.network.latent,
            blocks: m.network.blocks,
            hidden_layers: m.network.hidden_layers,
            layer_norm: m.network.layer_norm,
            coarse_levels: m.network.coarse_levels,
            self_edges: m.graph.self_edges,
            self_radius: m.graph.self_radius,
            body_radius: m.graph.body_radius,
            zero_init_output: m.zero_init_output,
            elastic_features: m.graph.elastic_features,
            comoving: m.graph.comoving,
        }
    }
}

/// The `[eval]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EvalConfig {
    /// Frames simulated per test motion (after frame 0). Default 90.
    pub frames: usize,
    /// Reference-solver iteration budgets of the error-against-run-time curve.
    pub solver_budgets: Vec<usize>,
    /// Iterations of the "converged" reference. Default 50.
    pub converged_iterations: usize,
    /// Test states (frames of the network's rollout) the error-against-run-time curve uses.
    pub curve_states: usize,
    /// Newton iterations refining the network's answer on the same states (one curve point
    /// each, "network + N it"); empty leaves the refined points out. Default `[1, 2, 4]`.
    pub refine_budgets: Vec<usize>,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            frames: 90,
            solver_budgets: vec![1, 2, 4, 8, 16],
            converged_iterations: 50,
            curve_states: 5,
            refine_budgets: vec![1, 2, 4],
        }
    }
}

/// Everything senc-train reads from one config file, plus the file itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    /// The config file (for resolving relative paths and for the record).
    pub path: PathBuf,
    /// `[train]`.
    pub train: TrainConfig,
    /// `[model]`.
    pub model: ModelSection,
    /// `[energy]`: phase 2's energy (phase 1 zeroes self-collision, area and repulsion).
    /// Its material is replaced per sequence.
    pub energy: EnergyConfig,
    /// `[eval]`.
    pub eval: EvalConfig,
    /// Whether the file (with its `extends` chain) has a `[scene]` table of its own.
    #[serde(default)]
    pub has_scene: bool,
}

/// The top-level tables of a run config; any other top-level key is refused.
pub const TABLES: &[&str] = &["scene", "train", "model", "energy", "eval"];

/// The dotted keys of a run config that hold file paths relative to the file.
pub const PATH_KEYS: &[&str] =
    &["scene.garment", "scene.body", "scene.motions.train", "scene.motions.test", "train.scenes"];

/// A config document's error as senc-train's (a bad file, `extends` or override is a
/// config error, not a scene error).
fn config_error(e: senc_scene::SceneError) -> TrainError {
    match e {
        senc_scene::SceneError::Config { path, message } => TrainError::Config { path, message },
        e => TrainError::Scene(e),
    }
}

fn section<T: for<'de> Deserialize<'de> + Default>(
    table: &toml::Table,
    name: &str,
    path: &Path,
) -> Result<T, TrainError> {
    match table.get(name) {
        None => Ok(T::default()),
        Some(v) => v.clone().try_into().map_err(|e: toml::de::Error| TrainError::Config {
            path: path.to_path_buf(),
            message: format!("[{name}]: {e}"),
        }),
    }
}

impl RunConfig {
    /// Parses the tables of `text` (the file `path`; an `extends` in it is read relative to
    /// `path`'s directory).
    pub fn parse(text: &str, path: &Path) -> Result<Self, TrainError> {
        Self::from_document(&ConfigDocument::parse(text, path, PATH_KEYS).map_err(config_error)?)
    }

    /// Reads a config file and the files it extends.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, TrainError> {
        Self::from_document(&ConfigDocument::read(path.as_ref(), PATH_KEYS).map_err(config_error)?)
    }

    /// The config of a resolved document. Unknown top-level tables and unknown keys in
    /// any table are refused, naming them; the `[scene]` table, if any, is checked too.
    pub fn from_document(doc: &ConfigDocument) -> Result<Self, TrainError> {
        let path = doc.path.as_path();
        if let Some(k) = doc.table.keys().find(|k| !TABLES.contains(&k.as_str())) {
            return Err(TrainError::Config {
                path: path.to_path_buf(),
                message: format!("unknown top-level key `{k}`; a config has the tables {}", TABLES.join(", ")),
            });
        }
        let has_scene = doc.table.contains_key("scene");
        if has_scene {
            senc_scene::SceneConfig::from_document(doc)?;
        }
        let cfg = Self {
            path: path.to_path_buf(),
            train: section(&doc.table, "train", path)?,
            model: section(&doc.table, "model", path)?,
            energy: section(&doc.table, "energy", path)?,
            eval: section(&doc.table, "eval", path)?,
            has_scene,
        };
        cfg.validate()?;
        Ok(cfg)
    }

    /// The fully resolved document of the config file `path` (its `extends` chain merged),
    /// with `[train] seed` replaced by `seed` if given and each `key=value` of `overrides`
    /// applied in order (dotted keys, TOML values: `train.phase2_iterations=100`). The result
    /// is checked as [`RunConfig::read`] checks a file, so an unknown key is refused here.
    pub fn resolve(path: &Path, seed: Option<u64>, overrides: &[String]) -> Result<ConfigDocument, TrainError> {
        let mut doc = ConfigDocument::read(path, PATH_KEYS).map_err(config_error)?;
        if let Some(seed) = seed {
            doc.set(&format!("train.seed={seed}")).map_err(config_error)?;
        }
        for o in overrides {
            doc.set(o).map_err(config_error)?;
        }
        Self::from_document(&doc)?;
        Ok(doc)
    }

    /// The method this config trains, by what it changes against SENC: "SENC" (volume
    /// loss, self-collision edges without mesh edges), "baseline" (HOOD: neither),
    /// "w/o self-col edges", "w. mesh edges", "w. area loss" or "repulsive" (the paper's
    /// ablations), or a list of the deciding settings for any other mix. A run over several
    /// scenes says how many garments it trains on ("SENC, 5 garments"), and a seed other
    /// than 0 is appended ("SENC, seed 1").
    pub fn method_name(&self) -> String {
        let e = &self.energy;
        let on = |w: f64| w > 0.0;
        let losses = (on(e.self_collision.weight), on(e.area_weight), on(e.repulsion.weight));
        let name = match (losses, self.model.graph.self_edges) {
            ((true, false, false), SelfEdges::ExcludeMesh) => "SENC".to_string(),
            ((false, false, false), SelfEdges::None) => "baseline".to_string(),
            ((true, false, false), SelfEdges::None) => "w/o self-col edges".to_string(),
            ((true, false, false), SelfEdges::KeepMesh) => "w. mesh edges".to_string(),
            ((false, true, false), SelfEdges::ExcludeMesh) => "w. area loss".to_string(),
            ((false, false, true), SelfEdges::ExcludeMesh) => "repulsive".to_string(),
            (_, edges) => format!(
                "volume {}, area {}, repulsion {}, self edges {edges:?}",
                e.self_collision.weight, e.area_weight, e.repulsion.weight
            ),
        };
        let scenes = self.scene_files().len();
        let name = if scenes > 1 { format!("{name}, {scenes} garments") } else { name };
        match self.train.seed {
            0 => name,
            s => format!("{name}, seed {s}"),
        }
    }

    /// The scene config files of this run: this file if it has a `[scene]` table, then
    /// `[train] scenes`.
    pub fn scene_files(&self) -> Vec<PathBuf> {
        let dir = self.path.parent().unwrap_or(Path::new("."));
        let own = self.has_scene.then(|| self.path.clone());
        own.into_iter().chain(self.train.scenes.iter().map(|p| dir.join(p))).collect()
    }

    /// Checks the values.
    pub fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config { path: self.path.clone(), message: m });
        let t = &self.train;
        if !(t.learning_rate.is_finite() && t.learning_rate > 0.0) {
            return bad(format!("[train] learning_rate = {} must be > 0", t.learning_rate));
        }
        if !(t.grad_clip.is_finite() && t.grad_clip > 0.0) {
            return bad(format!("[train] grad_clip = {} must be > 0", t.grad_clip));
        }
        if !(t.noise_std.is_finite() && t.noise_std >= 0.0) {
            return bad(format!("[train] noise_std = {} must be >= 0", t.noise_std));
        }
        if !(t.external_max.is_finite() && t.external_max >= 0.0) {
            return bad(format!("[train] external_max = {} must be >= 0", t.external_max));
        }
        if !(t.relax_start_dt.is_finite() && t.relax_start_dt > 0.0) {
            return bad(format!("[train] relax_start_dt = {} must be a positive number of seconds", t.relax_start_dt));
        }
        if !(0.0..=1.0).contains(&t.first_step_probability) {
            return bad(format!("[train] first_step_probability = {} must be in [0, 1]", t.first_step_probability));
        }
        if !(0.0..=1.0).contains(&t.max_start_penetration) {
            return bad(format!("[train] max_start_penetration = {} must be in [0, 1]", t.max_start_penetration));
        }
        if t.checkpoint_every == 0 {
            return bad("[train] checkpoint_every must be >= 1".into());
        }
        if !(t.newton_weight.is_finite() && t.newton_weight >= 0.0) {
            return bad(format!("[train] newton_weight = {} must be finite and >= 0", t.newton_weight));
        }
        if t.select_every > 0 && t.select_frames == 0 {
            return bad("[train] select_frames must be >= 1 when select_every > 0".into());
        }
        if t.select_max_volume_cm3.is_nan() || t.select_max_volume_cm3 < 0.0 {
            return bad(format!("[train] select_max_volume_cm3 = {} must be >= 0", t.select_max_volume_cm3));
        }
        if !(0.0..=1.0).contains(&t.pool_share) {
            return bad(format!("[train] pool_share = {} must be in [0, 1] (0: off)", t.pool_share));
        }
        if t.pool_share > 0.0 && (t.pool_size == 0 || t.pool_every == 0 || t.pool_frames == 0 || t.pool_stride == 0) {
            return bad(
                "[train] pool_size, pool_every, pool_frames and pool_stride must be >= 1 when pool_share > 0".into()
            );
        }
        if let Some(w) = self.train.collision_weight_start {
            if !(w.is_finite() && w >= 0.0) {
                return bad(format!("[train] collision_weight_start = {w}: give a finite weight >= 0 (HOOD: 5e3)"));
            }
        }
        if self.model.network.latent == 0 || self.model.network.blocks == 0 {
            return bad("[model] latent and blocks must be >= 1".into());
        }
        self.energy.validate().map_err(|e| TrainError::Config { path: self.path.clone(), message: e.to_string() })?;
        Ok(())
    }

    /// The energy config of a phase for a material and external acceleration: the run's
    /// `[energy]`, without self-collision, area and repulsion before [`Phase::Two`].
    pub fn energy_for(&self, phase: Phase, material: senc_energy::Material, external: [f64; 3]) -> EnergyConfig {
        let mut e = self.energy.clone();
        e.material = material;
        e.external_acceleration = external;
        if phase < Phase::Two {
            e.self_collision.weight = 0.0;
            e.area_weight = 0.0;
            e.repulsion.weight = 0.0;
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "[scene]\ngarment = \"g\"\nbody = \"b\"\n[scene.motions]\ntrain = [\"m\"]\n";

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("senc-run-config-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn resolve_applies_extends_seed_and_overrides_and_names_unknown_keys() {
        let d = temp_dir("resolve");
        std::fs::write(d.join("base.toml"), format!("{SCENE}[train]\nphase2_iterations = 50\n[model]\nlatent = 8\n"))
            .unwrap();
        let top = d.join("ablation.toml");
        std::fs::write(&top, "extends = \"base.toml\"\n[model]\nself_edges = \"none\"\n").unwrap();
        let sets = vec!["train.phase1_iterations=7".to_string(), "energy.self_collision.weight=0.0".to_string()];
        let doc = RunConfig::resolve(&top, Some(3), &sets).unwrap();
        let c = RunConfig::from_document(&doc).unwrap();
        assert_eq!((c.train.seed, c.train.phase1_iterations, c.train.phase2_iterations), (3, 7, 50));
        assert_eq!((c.model.network.latent, c.model.graph.self_edges), (8, SelfEdges::None));
        assert_eq!(c.method_name(), "baseline, seed 3");
        assert!(c.has_scene, "the scene comes from the base");
        // the saved text parses back to the same config
        let again = RunConfig::parse(&doc.to_toml(), &top).unwrap();
        assert_eq!(again, c);
        for (bad, named) in [
            ("train.sede=1", "sede"),
            ("trian.seed=1", "trian"),
            ("scene.wind=3", "wind"),
            ("model.self_edges=\"all\"", "all"),
            ("train.seed=\"one\"", "seed"),
            ("train.seed=one", "one"),
        ] {
            let e = RunConfig::resolve(&top, None, &[bad.to_string()]).unwrap_err().to_string();
            assert!(e.contains(named), "{bad}: {e}");
        }
        let e = RunConfig::resolve(&d.join("missing.toml"), None, &[]).unwrap_err().to_string();
        assert!(e.contains("missing.toml"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn method_names_follow_the_deciding_settings() {
        let mut c = RunConfig::parse(SCENE, Path::new("a.toml")).unwrap();
        assert_eq!(c.method_name(), "SENC");
        c.model.graph.self_edges = SelfEdges::KeepMesh;
        assert_eq!(c.method_name(), "w. mesh edges");
        c.model.graph.self_edges = SelfEdges::None;
        assert_eq!(c.method_name(), "w/o self-col edges");
        c.model.graph.self_edges = SelfEdges::ExcludeMesh;
        c.energy.self_collision.weight = 0.0;
        c.energy.area_weight = 1.0;
        assert_eq!(c.method_name(), "w. area loss");
        c.energy.area_weight = 0.0;
        c.energy.repulsion.weight = 1e-3;
        assert_eq!(c.method_name(), "repulsive");
        c.energy.area_weight = 1.0;
        c.train.seed = 2;
        let mixed = c.method_name();
        assert!(mixed.contains("area 1") && mixed.ends_with("seed 2"), "{mixed}");
    }

    #[test]
    fn parses_tables_and_rejects_unknown_keys() {
        let text = format!(
            "{SCENE}[train]\nseed = 7\n[model]\nself_edges = \"none\"\n[energy.self_collision]\nweight = 0.0\n"
        );
        let c = RunConfig::parse(&text, Path::new("a.toml")).unwrap();
        assert_eq!(c.train.seed, 7);
        assert_eq!(c.model.graph.self_edges, SelfEdges::None);
        assert_eq!(c.energy.self_collision.weight, 0.0);
        assert!(c.has_scene);
        assert_eq!(c.scene_files(), vec![PathBuf::from("a.toml")]);
        let e = RunConfig::parse("[train]\nsede = 1\n", Path::new("a.toml")).unwrap_err();
        assert!(e.to_string().contains("sede"), "{e}");
        // unknown top-level tables and unknown keys of the scene are named too
        let e = RunConfig::parse("[trian]\nseed = 1\n", Path::new("a.toml")).unwrap_err();
        assert!(e.to_string().contains("trian"), "{e}");
        let e = RunConfig::parse(&format!("{SCENE}wind = 3\n"), Path::new("a.toml")).unwrap_err();
        assert!(e.to_string().contains("wind"), "{e}");
    }

    #[test]
    fn schedules_follow_hood() {
        let t =
            TrainConfig { learning_rate: 1.0, lr_halving: 10, rollout_growth: 5, rollout_max: 3, ..Default::default() };
        assert!((t.lr(0) - 1.01).abs() < 1e-12);
        assert!((t.lr(10) - 0.51).abs() < 1e-12);
        assert!((t.lr(25) - 0.26).abs() < 1e-12);
        assert_eq!(t.rollout_len(0), 1);
        assert_eq!(t.rollout_len(5), 2);
        assert_eq!(t.rollout_len(100), 3);
    }

    #[test]
    fn collision_weight_ramps_linearly_then_holds() {
        let t = TrainConfig { collision_weight_start: Some(5e3), collision_ramp_iterations: 100, ..Default::default() };
        assert_eq!(t.collision_weight(0, 5e5), 5e3);
        assert!((t.collision_weight(50, 5e5) - 2.525e5).abs() < 1e-6);
        assert_eq!(t.collision_weight(100, 5e5), 5e5);
        assert_eq!(t.collision_weight(10_000, 5e5), 5e5);
        let none = TrainConfig::default();
        assert_eq!(none.collision_weight(0, 5e5), 5e5);
        let bad = "[train]\ncollision_weight_start = -1.0\n";
        let e = RunConfig::parse(bad, Path::new("a.toml")).and_then(|c| c.validate()).unwrap_err();
        assert!(e.to_string().contains("collision_weight_start"), "{e}");
    }
}
