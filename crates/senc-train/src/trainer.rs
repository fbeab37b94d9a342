//! The two-phase autoregressive trainer (HOOD's schedule, SENC's phases).
//!
//! One iteration is one optimiser step on one rollout step:
//! 1. If no sequence is running, start one: a random garment, training motion and window,
//!    a random material (HOOD's ranges) and external acceleration (|a| uniform in
//!    `[0, external_max]` m/s², uniform direction), σ noise on the initial positions; with
//!    probability `first_step_probability` the sequence starts at frame 0 from the skinned
//!    rest pose with the long first step (`[scene] first_step_dt`, the velocity rescaled to
//!    1/fps after it), else mid-motion from the skinned state relaxed out of the body
//!    (`Garment::relax_start`). It runs for `min(1 + ⌊k / rollout_growth⌋, rollout_max)`
//!    steps.
//! 2. The network predicts `x[t+1]` (pinned vertices are then set to the skinned garment);
//!    senc-energy evaluates `E(x[t+1])` and `g = ∂E/∂x[t+1]`
//!    in f64; the surrogate loss `Σ x ⊙ g` is backpropagated; gradients are clipped by their
//!    global norm; Adam steps with `lr · (0.5^⌊k/lr_halving⌋ + 0.01)`.
//! 3. `x[t+1]` (f64, detached) becomes the next state.
//!
//! Warm-up iterations before phase 1 only feed the normalisers (inputs from graphs of
//! skinned states, outputs from the skinned garment's acceleration beyond gravity,
//! `(x̂[t+1] − 2x̂[t] + x̂[t−1]) / Δt² − g`). Phase 1 trains without the self-collision, area
//! and repulsion energies; phase 2 starts from phase 1's weights (saved in `OUT/phase1`) with a fresh Adam
//! state and all energies of `[energy]`. A step whose energy, energy gradient or parameter
//! gradient is not finite is skipped (no optimiser step), counted, and ends its sequence.
//!
//! Checkpoints (`OUT/latest`, then `OUT/phase1`, `OUT/phase2` at the end of each phase) are
//! directories written under a temporary name and renamed into place; they hold the model
//! (weights, sizes, graph config, normalisers), Adam's state (`optim.bpk`), the trainer's
//! progress including the RNG position and the running sequence (`trainer.msgpack`) and the
//! config text (`config.toml`). [`Trainer::resume`] continues exactly where it stopped.

use std::io::Write;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use senc_energy::{EnergyModel, Material};
use senc_geom::Vec3;
use senc_model::burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer, OptimizerRecord};
use senc_model::burn::tensor::Device;
use senc_model::{BodyState, FrameState, GraphInputs, Model};
use serde::{Deserialize, Serialize};

use crate::config::RunConfig;
use crate::error::TrainError;
use crate::garment::Garment;

/// Name of the rolling checkpoint directory inside the output directory.
pub const LATEST: &str = "latest";
/// Adam's state inside a checkpoint directory.
pub const OPTIM_FILE: &str = "optim.bpk";
/// The trainer's progress inside a checkpoint directory.
pub const PROGRESS_FILE: &str = "trainer.msgpack";
/// The config text inside a checkpoint directory.
pub const CONFIG_FILE: &str = "config.toml";
/// The loss log inside the output directory.
pub const CSV_FILE: &str = "losses.csv";

/// A running rollout sequence (part of the checkpoint, so resume is exact).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Sequence {
    /// Index into the run's garments.
    pub garment: usize,
    /// Index into that garment's training motions.
    pub motion: usize,
    /// Frame of `curr` in the motion.
    pub frame: usize,
    /// Steps left in this rollout.
    pub steps_left: usize,
    /// Material of this sequence.
    pub material: Material,
    /// External acceleration a_ext, m/s².
    pub external: [f64; 3],
    /// Cloth at t−1, m.
    pub prev: Vec<Vec3>,
    /// Cloth at t, m.
    pub curr: Vec<Vec3>,
    /// Whether the next step is the long first step.
    pub first_step: bool,
}

/// Where training stands.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Progress {
    /// Warm-up iterations done.
    pub warmup_done: u64,
    /// Current phase (1 or 2).
    pub phase: u8,
    /// Iterations done in the current phase.
    pub iteration: u64,
    /// Steps skipped for non-finite values, per phase.
    pub skipped: [u64; 2],
    /// The RNG's position (ChaCha word position).
    pub rng_word_pos: u128,
    /// The running sequence.
    pub sequence: Option<Sequence>,
    /// Whether both phases are done.
    pub finished: bool,
    /// States the network reached when rolled out alone (`[train] pool_share`), as
    /// sequences at the frame they reached; a training sequence may start from one.
    #[serde(default)]
    pub pool: Vec<Sequence>,
    /// Where the next pooled state goes once the pool is full.
    #[serde(default)]
    pub pool_next: usize,
}

/// What one iteration did.
#[derive(Debug, Clone)]
pub struct StepReport {
    /// 0 for warm-up, else 1 or 2.
    pub phase: u8,
    /// Iteration within the phase (after this step), or warm-up iterations done.
    pub iteration: u64,
    /// Iterations of this phase.
    pub phase_iterations: u64,
    /// Total energy E(x[t+1]), J (NaN in warm-up or when skipped).
    pub loss: f64,
    /// Energy terms, J.
    pub terms: Vec<(&'static str, f64)>,
    /// Global parameter-gradient norm before clipping.
    pub grad_norm: f64,
    /// Learning rate used.
    pub lr: f64,
    /// Rollout length of the current schedule.
    pub rollout_len: usize,
    /// Whether the step was skipped for a non-finite value.
    pub skipped: bool,
    /// Steps skipped so far in this phase.
    pub skipped_total: u64,
}

/// The trainer.
pub struct Trainer {
    /// The run's config.
    pub config: RunConfig,
    config_text: String,
    garments: Vec<Garment>,
    /// The model (on an autodiff device).
    pub model: Model,
    optim: ModuleOptimizer,
    rng: ChaCha8Rng,
    /// Progress.
    pub progress: Progress,
    out: PathBuf,
    energy_cache: Option<(u64, EnergyModel)>,
    /// Per garment: the phase-1 energy with the scene's material that relaxes starts.
    relax_energy: Vec<Option<EnergyModel>>,
    sequence_id: u64,
}

/// The network's view of one step of a sequence (shared by warm-up and training steps).
fn frame_state<'a>(
    g: &'a Garment,
    seq: &'a Sequence,
    body_t: &'a [Vec3],
    body_n: &'a [Vec3],
    accel: Vec3,
    dt: f64,
) -> FrameState<'a> {
    FrameState {
        rest: &g.rest,
        prev: &seq.prev,
        curr: &seq.curr,
        material: model_material(&seq.material),
        accel,
        dt,
        body: Some(BodyState { faces: g.body_faces(), curr: body_t, next: body_n }),
        pinned: &g.pinned,
    }
}

/// The network's view of an energy material.
pub fn model_material(m: &Material) -> senc_model::Material {
    senc_model::Material { mu: m.mu, lambda: m.lambda, bending: m.bending_stiffness, density: m.density }
}

/// The scene's own material as an energy material.
pub fn scene_material(g: &Garment) -> Result<Material, TrainError> {
    let mc = &g.scene.config.material;
    let (mu, lambda) = mc.lame()?;
    Ok(Material { mu, lambda, thickness: mc.thickness, bending_stiffness: mc.bending, density: mc.density })
}

/// Moves a sequence one frame on to `next`. After the long first step the velocity is
/// kept, not the displacement: the next steps are 1/fps long.
fn advance(s: &mut Sequence, next: Vec<Vec3>, g: &Garment) {
    s.prev = std::mem::replace(&mut s.curr, next);
    if s.first_step {
        let k = g.scene.dt() / g.scene.config.first_step_dt;
        crate::garment::rescale_velocity(&mut s.prev, &s.curr, k);
    }
    s.frame += 1;
    s.first_step = false;
}

fn finite(v: &[Vec3]) -> bool {
    v.iter().all(|p| p.iter().all(|c| c.is_finite()))
}

fn write_atomic_dir(dir: &Path, fill: impl FnOnce(&Path) -> Result<(), TrainError>) -> Result<(), TrainError> {
    let parent = dir.parent().unwrap_or(Path::new("."));
    let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("ckpt");
    let tmp = parent.join(format!(".{name}.tmp"));
    let old = parent.join(format!(".{name}.old"));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| TrainError::io(&tmp, e))?;
    fill(&tmp)?;
    let _ = std::fs::remove_dir_all(&old);
    if dir.exists() {
        std::fs::rename(dir, &old).map_err(|e| TrainError::io(dir, e))?;
    }
    std::fs::rename(&tmp, dir).map_err(|e| TrainError::io(dir, e))?;
    let _ = std::fs::remove_dir_all(&old);
    Ok(())
}

impl Trainer {
    /// A fresh trainer for the config file `config_path`, writing into `out`.
    pub fn new(config_path: &Path, out: &Path) -> Result<Self, TrainError> {
        let config = RunConfig::read(config_path)?;
        // The resolved config (its `extends` chain merged) is what the checkpoints keep.
        let config_text = RunConfig::resolve(config_path, None, &[])?.to_toml();
        let garments = Self::load_garments(&config)?;
        let device = Device::flex().autodiff();
        let mut model =
            Model::new(config.model.model_config(), config.model.graph_config(), config.train.seed, &device);
        if config.model.zero_init_output {
            model.network = model.network.with_zero_output();
        }
        let rng = ChaCha8Rng::seed_from_u64(config.train.seed);
        std::fs::create_dir_all(out).map_err(|e| TrainError::io(out, e))?;
        let csv = out.join(CSV_FILE);
        std::fs::write(&csv, "phase,iteration,lr,rollout_len,loss,grad_norm,skipped,terms\n")
            .map_err(|e| TrainError::io(&csv, e))?;
        Ok(Self {
            config,
            config_text,
            garments,
            model,
            optim: AdamConfig::new().init(),
            rng,
            progress: Progress { phase: 1, ..Default::default() },
            out: out.to_path_buf(),
            energy_cache: None,
            relax_energy: Vec::new(),
            sequence_id: 0,
        })
    }

    /// Resumes from `OUT/latest` (the config is the one saved in the checkpoint).
    pub fn resume(out: &Path) -> Result<Self, TrainError> {
        let dir = out.join(LATEST);
        let cfg_path = dir.join(CONFIG_FILE);
        let config_text = std::fs::read_to_string(&cfg_path).map_err(|e| TrainError::Checkpoint {
            path: dir.clone(),
            message: format!("cannot read {CONFIG_FILE}: {e}"),
        })?;
        // Relative paths in the saved config refer to the original config's directory,
        // recorded in the progress file's neighbour `source.txt`.
        let source = std::fs::read_to_string(dir.join("source.txt"))
            .map(|s| PathBuf::from(s.trim()))
            .unwrap_or_else(|_| cfg_path.clone());
        let mut config = RunConfig::parse(&config_text, &source)?;
        config.path = source;
        let garments = Self::load_garments(&config)?;
        let device = Device::flex().autodiff();
        let model = Model::load(&dir, &device)?;
        let opath = dir.join(OPTIM_FILE);
        let record = OptimizerRecord::load(&opath)
            .map_err(|e| TrainError::Checkpoint { path: opath.clone(), message: format!("{e:?}") })?;

        let ppath = dir.join(PROGRESS_FILE);
        let bytes = std::fs::read(&ppath).map_err(|e| TrainError::io(&ppath, e))?;
        let mut progress: Progress = rmp_serde::from_slice(&bytes)
            .map_err(|e| TrainError::Checkpoint { path: ppath.clone(), message: e.to_string() })?;
        // A finished run whose config now asks for more phase-2 iterations goes on training
        // (extending a run: raise `phase2_iterations` in OUT/latest/config.toml, then resume).
        if progress.finished && progress.phase == 2 && progress.iteration < config.train.phase2_iterations {
            tracing::info!(
                done = progress.iteration,
                target = config.train.phase2_iterations,
                "finished run extended: phase 2 continues"
            );
            progress.finished = false;
        }
        // Phase 2 starts with a fresh Adam state (see `end_phase`); a checkpoint taken at
        // that start by older code (a copy of OUT/phase1) may still hold phase 1's moments,
        // which must not leak into phase 2.
        let optim = if progress.phase == 2 && progress.iteration == 0 {
            AdamConfig::new().init()
        } else {
            AdamConfig::new().init().load_record(record)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(config.train.seed);
        rng.set_word_pos(progress.rng_word_pos);
        // Drop loss rows logged after the checkpoint (they are about to be redone).
        let csv = out.join(CSV_FILE);
        if let Ok(text) = std::fs::read_to_string(&csv) {
            let keep: Vec<&str> = text
                .lines()
                .filter(|l| {
                    let mut f = l.split(',');
                    match (f.next().and_then(|p| p.parse::<u8>().ok()), f.next().and_then(|i| i.parse::<u64>().ok())) {
                        (Some(p), Some(i)) => (p, i) <= (progress.phase, progress.iteration),
                        _ => true,
                    }
                })
                .collect();
            std::fs::write(&csv, keep.join("\n") + "\n").map_err(|e| TrainError::io(&csv, e))?;
        }
        Ok(Self {
            config,
            config_text,
            garments,
            model,
            optim,
            rng,
            progress,
            out: out.to_path_buf(),
            energy_cache: None,
            relax_energy: Vec::new(),
            sequence_id: u64::MAX / 2,
        })
    }

    fn load_garments(config: &RunConfig) -> Result<Vec<Garment>, TrainError> {
        let files = config.scene_files();
        if files.is_empty() {
            return Err(TrainError::Config {
                path: config.path.clone(),
                message: "no [scene] table and no [train] scenes; give at least one garment".into(),
            });
        }
        let garments =
            files.iter().map(|f| Garment::load(f, config.train.body_margin)).collect::<Result<Vec<_>, _>>()?;
        for g in &garments {
            if g.scene.train.iter().all(|m| m.n_frames() < 3) {
                return Err(TrainError::Invalid(format!("garment {}: no training motion has 3 frames", g.name())));
            }
        }
        Ok(garments)
    }

    /// The garments of this run.
    pub fn garments(&self) -> &[Garment] {
        &self.garments
    }

    /// Iterations of phase `p`.
    pub fn phase_iterations(&self, p: u8) -> u64 {
        if p == 1 {
            self.config.train.phase1_iterations
        } else {
            self.config.train.phase2_iterations
        }
    }

    /// Whether training is finished.
    pub fn finished(&self) -> bool {
        self.progress.finished
    }

    /// A new training sequence of `len` steps: from the visited-state pool with
    /// probability `[train] pool_share` when `pooled` allows it (never in warm-up), else
    /// from a skinned garment.
    fn start_sequence(&mut self, len: usize, pooled: bool) -> Result<Sequence, TrainError> {
        let t = self.config.train.clone();
        let warm = self.progress.warmup_done < t.warmup_iterations;
        if pooled
            && !warm
            && t.pool_share > 0.0
            && !self.progress.pool.is_empty()
            && self.rng.random::<f64>() < t.pool_share
        {
            let p = &self.progress.pool[self.rng.random_range(0..self.progress.pool.len())];
            if p.frame + len + 1 < self.garments[p.garment].scene.train[p.motion].n_frames() {
                self.sequence_id += 1;
                return Ok(Sequence { steps_left: len, first_step: false, ..p.clone() });
            }
        }
        let gi = self.rng.random_range(0..self.garments.len());
        let g = &self.garments[gi];
        let usable: Vec<usize> = (0..g.scene.train.len()).filter(|&i| g.scene.train[i].n_frames() >= len + 3).collect();
        if usable.is_empty() {
            return Err(TrainError::Invalid(format!(
                "garment {}: no training motion has {} frames",
                g.name(),
                len + 3
            )));
        }
        let mi = usable[self.rng.random_range(0..usable.len())];
        let motion = &g.scene.train[mi];
        let n = motion.n_frames();
        let first = self.rng.random::<f64>() < t.first_step_probability;
        let frame = if first {
            0
        } else if t.max_start_penetration >= 1.0 {
            self.rng.random_range(1..n - len - 1)
        } else {
            // The least penetrating of up to `start_tries` windows (the first one that is
            // clean enough ends the search).
            let limit = t.max_start_penetration * g.rest.n_vertices() as f64;
            let mut best = (usize::MAX, 1);
            for _ in 0..t.start_tries.max(1) {
                let f = self.rng.random_range(1..n - len - 1);
                let body = g.body_at(motion, f)?;
                let q = senc_scene::BodyQuery::new(&body, g.body_faces())?;
                let inside = q.inside(&g.skinned_at(motion, f)?).len();
                if inside < best.0 {
                    best = (inside, f);
                }
                if inside as f64 <= limit {
                    break;
                }
            }
            best.1
        };
        let material = if t.random_material { Material::sample_hood(&mut self.rng) } else { scene_material(g)? };
        let mag = self.rng.random::<f64>() * t.external_max;
        let dir = loop {
            let v = Vec3::new(
                self.rng.random::<f64>() * 2.0 - 1.0,
                self.rng.random::<f64>() * 2.0 - 1.0,
                self.rng.random::<f64>() * 2.0 - 1.0,
            );
            let n2 = v.norm_squared();
            if n2 > 1e-6 && n2 <= 1.0 {
                break v / n2.sqrt();
            }
        };
        let ext = Vec3::from(g.scene.config.external_force.acceleration) + dir * mag;
        let (mut prev, mut curr) = if first {
            let x = g.skinned_at(motion, 0)?;
            (x.clone(), x)
        } else {
            (g.skinned_at(motion, frame - 1)?, g.skinned_at(motion, frame)?)
        };
        if t.relax_start_iterations > 0 && !first {
            if self.relax_energy.len() <= gi {
                self.relax_energy.resize_with(self.garments.len(), || None);
            }
            if self.relax_energy[gi].is_none() {
                let ec = self.config.energy_for(1, scene_material(g)?, [0.0; 3]);
                self.relax_energy[gi] = Some(g.energy_model(ec, g.scene.dt())?);
            }
            let em = self.relax_energy[gi].as_ref().expect("built above");
            g.relax_start(em, &mut prev, &mut curr, &g.body_at(motion, frame)?, t.relax_start_iterations)?;
        }
        if t.noise_std > 0.0 {
            let normal = Normal::new(0.0, t.noise_std).map_err(|e| TrainError::Invalid(e.to_string()))?;
            for (p, c) in prev.iter_mut().zip(curr.iter_mut()) {
                let d =
                    Vec3::new(normal.sample(&mut self.rng), normal.sample(&mut self.rng), normal.sample(&mut self.rng));
                *p += d;
                *c += d;
            }
        }
        self.sequence_id += 1;
        Ok(Sequence {
            garment: gi,
            motion: mi,
            frame,
            steps_left: len,
            material,
            external: ext.into(),
            prev,
            curr,
            first_step: first,
        })
    }

    fn gravity(&self, g: &Garment) -> Vec3 {
        Vec3::from(g.scene.config.external_force.gravity)
    }

    fn warmup_step(&mut self) -> Result<StepReport, TrainError> {
        let seq = self.start_sequence(1, false)?;
        let g = &self.garments[seq.garment];
        let motion = &g.scene.train[seq.motion];
        let body_t = g.body_at(motion, seq.frame)?;
        let body_n = g.body_at(motion, seq.frame + 1)?;
        let accel = self.gravity(g) + Vec3::from(seq.external);
        let dt = g.scene.dt();
        let frame = frame_state(g, &seq, &body_t, &body_n, accel, dt);
        let graph = GraphInputs::build(&frame, &self.model.graph)?;
        self.model.normalizers.update_inputs(&graph);
        // The response acceleration the skinned garment would need on top of free flight
        // under gravity alone, m/s² (the random external force is left out so it cannot
        // bias the mean).
        let next = g.skinned_at(motion, seq.frame + 1)?;
        let (g_acc, inv_dt2) = (self.gravity(g), 1.0 / (dt * dt));
        let rows: Vec<f64> = next
            .iter()
            .zip(&seq.curr)
            .zip(&seq.prev)
            .flat_map(|((n, c), p)| {
                let a = (n - c * 2.0 + p) * inv_dt2 - g_acc;
                [a.x, a.y, a.z]
            })
            .collect();
        self.model.normalizers.output.update(&rows);
        self.progress.warmup_done += 1;
        Ok(StepReport {
            phase: 0,
            iteration: self.progress.warmup_done,
            phase_iterations: self.config.train.warmup_iterations,
            loss: f64::NAN,
            terms: Vec::new(),
            grad_norm: f64::NAN,
            lr: 0.0,
            rollout_len: 1,
            skipped: false,
            skipped_total: 0,
        })
    }

    fn train_step(&mut self) -> Result<StepReport, TrainError> {
        let phase = self.progress.phase;
        let k = self.progress.iteration;
        let len = self.config.train.rollout_len(k);
        let t = &self.config.train;
        if t.pool_share > 0.0 && k % t.pool_every == 0 {
            self.fill_pool()?;
        }
        if self.progress.sequence.as_ref().is_none_or(|s| s.steps_left == 0) {
            let s = self.start_sequence(len, true)?;
            self.progress.sequence = Some(s);
            self.energy_cache = None;
        }
        let seq = self.progress.sequence.clone().expect("sequence started above");
        let g = self.garments[seq.garment].clone();
        let motion = &g.scene.train[seq.motion];
        let body_t = if seq.first_step { g.body_at(motion, 0)? } else { g.body_at(motion, seq.frame)? };
        let body_n = g.body_at(motion, seq.frame + 1)?;
        let accel = self.gravity(&g) + Vec3::from(seq.external);
        // The long first step uses its own Δt (in the forcing and in the energy).
        let dt = if seq.first_step { g.scene.config.first_step_dt } else { g.scene.dt() };
        let frame = frame_state(&g, &seq, &body_t, &body_n, accel, dt);
        let graph = GraphInputs::build(&frame, &self.model.graph)?;
        let (accel_t, mut next) = self.model.predict(&graph, &frame)?;
        // Pinned vertices follow the skinned garment (their energy gradient is zero, so the
        // network's output there gets no training signal).
        g.pin_at(&mut next, motion, seq.frame + 1)?;
        let key = self.sequence_id.wrapping_mul(2) + u64::from(seq.first_step);
        if self.energy_cache.as_ref().is_none_or(|(k, _)| *k != key) {
            let mut ec = self.config.energy_for(phase, seq.material, seq.external);
            // HOOD's collision ramp, per sequence (counted over both phases).
            let global = if phase == 1 { k } else { self.config.train.phase1_iterations + k };
            ec.collision.weight = self.config.train.collision_weight(global, ec.collision.weight);
            self.energy_cache = Some((key, g.energy_model(ec, dt)?));
        }
        let em = &self.energy_cache.as_ref().expect("built above").1;
        let mut grad = vec![Vec3::zeros(); next.len()];
        let fe = if finite(&next) { em.frame(&seq.curr, &seq.prev, Some((&body_t, &body_n))).ok() } else { None };
        let evaluated = fe.as_ref().and_then(|fe| fe.evaluate(&next, Some(&mut grad)).ok());
        let lr = self.config.train.lr(k);
        let mut report = StepReport {
            phase,
            iteration: k + 1,
            phase_iterations: self.phase_iterations(phase),
            loss: f64::NAN,
            terms: Vec::new(),
            grad_norm: f64::NAN,
            lr,
            rollout_len: len,
            skipped: true,
            skipped_total: 0,
        };
        let ok = evaluated.filter(|b| b.total.is_finite() && finite(&grad));
        let mut stepped = false;
        if let Some(b) = ok {
            report.loss = b.total;
            report.terms = b.terms.clone();
            if self.config.train.newton_weight > 0.0 {
                if let Some(fe) = &fe {
                    let t = &self.config.train;
                    crate::signal::newton_signal(
                        fe,
                        &next,
                        em.masses(),
                        dt,
                        t.newton_weight,
                        &mut grad,
                        t.signal_cg_iterations,
                        t.signal_cg_tolerance,
                    );
                }
            }
            let grads = senc_model::surrogate_backward(accel_t, &grad)?;
            let mut gp = GradientsParams::from_grads(grads, &self.model.network);
            let norm = crate::clip::clip_global_norm(&self.model.network, &mut gp, self.config.train.grad_clip);
            report.grad_norm = norm;
            if norm.is_finite() {
                let net = self.model.network.clone();
                self.model.network = self.optim.step(lr, net, gp);
                stepped = true;
            }
        }
        let s = self.progress.sequence.as_mut().expect("running");
        if stepped {
            report.skipped = false;
            advance(s, next, &g);
            s.steps_left -= 1;
        } else {
            self.progress.skipped[usize::from(phase - 1)] += 1;
            s.steps_left = 0;
            tracing::warn!(phase, iteration = k, "non-finite energy or gradient: step skipped");
        }
        report.skipped_total = self.progress.skipped[usize::from(phase - 1)];
        self.progress.iteration += 1;
        Ok(report)
    }

    /// Rolls the current network out alone for `[train] pool_frames` frames from a fresh
    /// skinned start (a random garment, motion, material and force, as a training sequence
    /// draws them) and puts every `pool_stride`-th state it reaches into the pool, replacing
    /// the oldest once the pool holds `pool_size`. A rollout that turns non-finite stops
    /// there. Inference only (no optimiser step, no energy).
    fn fill_pool(&mut self) -> Result<(), TrainError> {
        let t = self.config.train.clone();
        let mut s = self.start_sequence(t.pool_frames, false)?;
        let g = self.garments[s.garment].clone();
        let motion = &g.scene.train[s.motion];
        let stepper = self.model.valid().stepper();
        let accel = self.gravity(&g) + Vec3::from(s.external);
        for step in 1..=t.pool_frames {
            let body_t = if s.first_step { g.body_at(motion, 0)? } else { g.body_at(motion, s.frame)? };
            let body_n = g.body_at(motion, s.frame + 1)?;
            let dt = if s.first_step { g.scene.config.first_step_dt } else { g.scene.dt() };
            let mut next = stepper.step(&frame_state(&g, &s, &body_t, &body_n, accel, dt))?;
            g.pin_at(&mut next, motion, s.frame + 1)?;
            if !finite(&next) {
                break;
            }
            advance(&mut s, next, &g);
            if step % t.pool_stride == 0 {
                let state = Sequence { steps_left: 0, ..s.clone() };
                let pool = &mut self.progress.pool;
                if pool.len() < t.pool_size {
                    pool.push(state);
                } else {
                    let i = self.progress.pool_next % pool.len();
                    pool[i] = state;
                }
                self.progress.pool_next = (self.progress.pool_next + 1) % t.pool_size;
            }
        }
        Ok(())
    }

    /// Runs one iteration (warm-up or training) and handles phase ends and checkpoints.
    /// Returns `None` once both phases are done.
    pub fn step(&mut self) -> Result<Option<StepReport>, TrainError> {
        if self.progress.finished {
            return Ok(None);
        }
        if self.progress.warmup_done < self.config.train.warmup_iterations {
            let r = self.warmup_step()?;
            if self.progress.warmup_done == self.config.train.warmup_iterations {
                tracing::info!(count = self.model.normalizers.node.count(), "warm-up done: normalisers fixed");
            }
            return Ok(Some(r));
        }
        if self.progress.iteration >= self.phase_iterations(self.progress.phase) {
            self.end_phase()?;
            if self.progress.finished {
                return Ok(None);
            }
            return self.step();
        }
        let r = self.train_step()?;
        self.log_csv(&r)?;
        if self.progress.iteration % self.config.train.checkpoint_every == 0 {
            self.checkpoint(&self.out.join(LATEST))?;
        }
        Ok(Some(r))
    }

    fn end_phase(&mut self) -> Result<(), TrainError> {
        let p = self.progress.phase;
        self.progress.sequence = None;
        let dir = self.out.join(format!("phase{p}"));
        if p == 1 {
            self.progress.phase = 2;
            self.progress.iteration = 0;
            // Phase 2 starts from phase 1's weights with a fresh Adam state; OUT/phase1 is
            // saved with it, so that phase 2 can be (re)started from a copy of it exactly.
            self.optim = AdamConfig::new().init();
            self.energy_cache = None;
            self.checkpoint(&dir)?;
            tracing::info!(dir = %dir.display(), skipped = self.progress.skipped[0], "phase 1 done");
        } else {
            self.progress.finished = true;
            self.checkpoint(&dir)?;
            tracing::info!(dir = %dir.display(), skipped = self.progress.skipped[1], "phase 2 done");
        }
        self.checkpoint(&self.out.join(LATEST))
    }

    fn log_csv(&self, r: &StepReport) -> Result<(), TrainError> {
        let path = self.out.join(CSV_FILE);
        let mut f =
            std::fs::OpenOptions::new().append(true).create(true).open(&path).map_err(|e| TrainError::io(&path, e))?;
        let terms: Vec<String> = r.terms.iter().map(|(n, v)| format!("{n}={v:.6e}")).collect();
        writeln!(
            f,
            "{},{},{:.6e},{},{:.6e},{:.6e},{},{}",
            r.phase,
            r.iteration,
            r.lr,
            r.rollout_len,
            r.loss,
            r.grad_norm,
            u8::from(r.skipped),
            terms.join(";")
        )
        .map_err(|e| TrainError::io(&path, e))
    }

    /// Writes a checkpoint directory atomically (temporary directory, then rename). Refuses
    /// to write non-finite weights.
    pub fn checkpoint(&self, dir: &Path) -> Result<(), TrainError> {
        let mut progress = self.progress.clone();
        progress.rng_word_pos = self.rng.get_word_pos();
        let probe = crate::clip::param_norm(&self.model.network);
        if !probe.is_finite() {
            return Err(TrainError::Checkpoint {
                path: dir.to_path_buf(),
                message: "the weights are not finite; refusing to write them".into(),
            });
        }
        let source = self.config.path.canonicalize().unwrap_or_else(|_| self.config.path.clone());
        write_atomic_dir(dir, |tmp| {
            self.model.save(tmp)?;
            let o = tmp.join(OPTIM_FILE);
            self.optim.to_record().save(&o).map_err(|e| TrainError::io(&o, format!("{e:?}")))?;
            let p = tmp.join(PROGRESS_FILE);
            let bytes = rmp_serde::to_vec_named(&progress).map_err(|e| TrainError::io(&p, e))?;
            std::fs::write(&p, bytes).map_err(|e| TrainError::io(&p, e))?;
            let c = tmp.join(CONFIG_FILE);
            std::fs::write(&c, &self.config_text).map_err(|e| TrainError::io(&c, e))?;
            let s = tmp.join("source.txt");
            std::fs::write(&s, source.display().to_string()).map_err(|e| TrainError::io(&s, e))?;
            let r = tmp.join("resolved.json");
            let json = serde_json::to_string_pretty(&self.config).map_err(|e| TrainError::io(&r, e))?;
            std::fs::write(&r, json).map_err(|e| TrainError::io(&r, e))
        })
    }

    /// Runs to the end (or until `stop_after` training iterations in total, counting both
    /// phases, for tests that simulate a kill), calling `on_step` after each iteration.
    pub fn run(&mut self, stop_after: Option<u64>, mut on_step: impl FnMut(&StepReport)) -> Result<(), TrainError> {
        let mut done = 0u64;
        while let Some(r) = self.step()? {
            on_step(&r);
            if r.phase > 0 {
                done += 1;
                if stop_after.is_some_and(|s| done >= s) {
                    break;
                }
            }
        }
        Ok(())
    }
}
