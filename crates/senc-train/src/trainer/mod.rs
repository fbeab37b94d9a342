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
//! With `[train] select_every`, phase 2's network is rolled out alone on the training
//! motions every so many iterations; the one that strays least from the skinned garment,
//! among those that do not pass through themselves, becomes `OUT/phase2` (`select`).
//!
//! Checkpoints (`OUT/latest`, then `OUT/phase1`, `OUT/phase2` at the end of each phase) are
//! directories written under a temporary name and renamed into place; they hold the model
//! (weights, sizes, graph config, normalisers), Adam's state (`optim.bpk`), the trainer's
//! progress including the RNG position and the running sequence (`trainer.msgpack`) and the
//! config text (`config.toml`). [`Trainer::resume`] continues exactly where it stopped.

mod checkpoint;
mod log;
mod sampling;
mod select;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use senc_energy::EnergyModel;
use senc_geom::Vec3;
use senc_model::burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer, OptimizerRecord};
use senc_model::burn::tensor::Device;
use senc_model::{GraphInputs, Model};

pub use checkpoint::{Progress, BEST, CONFIG_FILE, LATEST, OPTIM_FILE, PROGRESS_FILE};
pub use log::{StepReport, CSV_FILE};
pub use sampling::{material_from_config, scene_material, Sequence};
pub use select::SELECTION_FILE;

use crate::config::{Phase, RunConfig};
use crate::error::TrainError;
use crate::garment::Garment;
use sampling::{advance, build_start, finite, frame_state};

/// The trainer.
pub struct Trainer {
    /// The run's config.
    pub config: RunConfig,
    config_text: String,
    garments: Arc<Vec<Garment>>,
    /// The model (on an autodiff device).
    pub model: Model,
    optim: ModuleOptimizer,
    rng: ChaCha8Rng,
    /// Progress.
    pub progress: Progress,
    out: PathBuf,
    energy_cache: Option<(u64, EnergyModel)>,
    /// Per garment: the phase-1 energy with the scene's material that relaxes starts.
    relax_energy: Vec<Option<Arc<EnergyModel>>>,
    sequence_id: u64,
}

impl Trainer {
    /// A fresh trainer for the config file `config_path`, writing into `out`.
    pub fn new(config_path: &Path, out: &Path) -> Result<Self, TrainError> {
        let config = RunConfig::read(config_path)?;
        // The resolved config (its `extends` chain merged) is what the checkpoints keep.
        let config_text = RunConfig::resolve(config_path, None, &[])?.to_toml();
        let garments = Self::load_garments(&config)?;
        let device = Device::flex().autodiff();
        let mut model = Model::new(config.model.network.clone(), config.model.graph, config.train.seed, &device);
        if config.model.zero_init_output {
            model.network = model.network.with_zero_output();
        }
        let rng = ChaCha8Rng::seed_from_u64(config.train.seed);
        std::fs::create_dir_all(out).map_err(|e| TrainError::io(out, e))?;
        log::create(&out.join(CSV_FILE))?;
        Ok(Self {
            config,
            config_text,
            garments,
            model,
            optim: AdamConfig::new().init(),
            rng,
            progress: Progress { phase: Phase::One, ..Default::default() },
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
        if progress.finished && progress.phase == Phase::Two && progress.iteration < config.train.phase2_iterations {
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
        let optim = if progress.phase == Phase::Two && progress.iteration == 0 {
            AdamConfig::new().init()
        } else {
            AdamConfig::new().init().load_record(record)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(config.train.seed);
        rng.set_word_pos(progress.rng_word_pos);
        // Drop loss rows logged after the checkpoint (they are about to be redone).
        log::truncate_after(&out.join(CSV_FILE), progress.phase, progress.iteration)?;
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

    fn load_garments(config: &RunConfig) -> Result<Arc<Vec<Garment>>, TrainError> {
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
        Ok(Arc::new(garments))
    }

    /// The garments of this run.
    pub fn garments(&self) -> &[Garment] {
        &self.garments
    }

    /// Iterations of phase `p`.
    pub fn phase_iterations(&self, p: Phase) -> u64 {
        match p {
            Phase::WarmUp => self.config.train.warmup_iterations,
            Phase::One => self.config.train.phase1_iterations,
            Phase::Two => self.config.train.phase2_iterations,
        }
    }

    /// Whether training is finished.
    pub fn finished(&self) -> bool {
        self.progress.finished
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
            phase: Phase::WarmUp,
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
            let s = match self.progress.next_sequence.take() {
                Some(s) => {
                    self.sequence_id += 1;
                    s
                }
                None => self.start_sequence(len, true)?,
            };
            self.progress.sequence = Some(s);
            self.energy_cache = None;
        }
        // When this step ends the running sequence, the next one's start is drawn now (the
        // RNG is drawn in the same order as when it is started at the next iteration) and
        // built (skinned, relaxed out of the body) beside this step, on a second thread
        // where rayon has one.
        let next_k = k + 1;
        let prefetch = self.progress.sequence.as_ref().is_some_and(|s| s.steps_left == 1)
            && next_k < self.phase_iterations(phase)
            && !(self.config.train.pool_share > 0.0 && next_k % self.config.train.pool_every == 0);
        if !prefetch {
            return self.sequence_step(len);
        }
        let plan = self.draw_start(self.config.train.rollout_len(next_k), true)?;
        let (garments, relax_iterations) = (Arc::clone(&self.garments), self.config.train.relax_start_iterations);
        let (report, next) =
            rayon::join(|| self.sequence_step(len), move || build_start(plan, &garments, relax_iterations));
        self.progress.next_sequence = Some(next?);
        report
    }

    /// One optimiser step on the running sequence's next step (`len`: the rollout length
    /// of this iteration, for the report).
    fn sequence_step(&mut self, len: usize) -> Result<StepReport, TrainError> {
        let phase = self.progress.phase;
        let k = self.progress.iteration;
        let seq = self.progress.sequence.clone().expect("sequence started above");
        let garments = Arc::clone(&self.garments);
        let g = &garments[seq.garment];
        let motion = &g.scene.train[seq.motion];
        let body_t = if seq.first_step { g.body_at(motion, 0)? } else { g.body_at(motion, seq.frame)? };
        let body_n = g.body_at(motion, seq.frame + 1)?;
        let accel = self.gravity(g) + Vec3::from(seq.external);
        // The long first step uses its own Δt (in the forcing and in the energy).
        let dt = if seq.first_step { g.scene.config.first_step_dt } else { g.scene.dt() };
        let frame = frame_state(g, &seq, &body_t, &body_n, accel, dt);
        let graph = GraphInputs::build(&frame, &self.model.graph)?;
        let (accel_t, mut next) = self.model.predict(&graph, &frame)?;
        // Pinned vertices follow the skinned garment (their energy gradient is zero, so the
        // network's output there gets no training signal).
        g.pin_at(&mut next, motion, seq.frame + 1)?;
        let key = self.sequence_id.wrapping_mul(2) + u64::from(seq.first_step);
        if self.energy_cache.as_ref().is_none_or(|(k, _)| *k != key) {
            let mut ec = self.config.energy_for(phase, seq.material, seq.external);
            // HOOD's collision ramp, per sequence (counted over both phases).
            let global = if phase == Phase::One { k } else { self.config.train.phase1_iterations + k };
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
                    )?;
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
            advance(s, next, g);
            s.steps_left -= 1;
        } else {
            self.progress.skipped[usize::from(phase == Phase::Two)] += 1;
            s.steps_left = 0;
            tracing::warn!(%phase, iteration = k, "non-finite energy or gradient: step skipped");
        }
        report.skipped_total = self.progress.skipped[usize::from(phase == Phase::Two)];
        self.progress.iteration += 1;
        Ok(report)
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
        log::append(&self.out.join(CSV_FILE), &r)?;
        let every = self.config.train.select_every;
        if self.progress.phase == Phase::Two && every > 0 && self.progress.iteration % every == 0 {
            self.select()?;
        }
        if self.progress.iteration % self.config.train.checkpoint_every == 0 {
            self.checkpoint(&self.out.join(LATEST))?;
        }
        Ok(Some(r))
    }

    fn end_phase(&mut self) -> Result<(), TrainError> {
        let p = self.progress.phase;
        self.progress.sequence = None;
        self.progress.next_sequence = None;
        let dir = self.out.join(format!("phase{}", p.number()));
        if p == Phase::One {
            self.progress.phase = Phase::Two;
            self.progress.iteration = 0;
            // Phase 2 starts from phase 1's weights with a fresh Adam state; OUT/phase1 is
            // saved with it, so that phase 2 can be (re)started from a copy of it exactly.
            self.optim = AdamConfig::new().init();
            self.energy_cache = None;
            self.checkpoint(&dir)?;
            tracing::info!(dir = %dir.display(), skipped = self.progress.skipped[0], "phase 1 done");
            self.checkpoint(&self.out.join(LATEST))
        } else {
            let every = self.config.train.select_every;
            if every > 0 && self.progress.iteration % every != 0 {
                self.select()?;
            }
            self.progress.finished = true;
            // OUT/latest keeps the last network (a run extended later continues from it);
            // OUT/phase2 is the best-scoring one where networks were selected.
            self.checkpoint(&self.out.join(LATEST))?;
            if let Some((k, score)) = self.progress.best {
                self.model = Model::load(&self.out.join(BEST), &self.model.device)?;
                tracing::info!(iteration = k, score_cm = score, "phase 2 keeps the best-scoring network");
            }
            self.checkpoint(&dir)?;
            tracing::info!(dir = %dir.display(), skipped = self.progress.skipped[1], "phase 2 done");
            Ok(())
        }
    }

    /// Runs to the end (or until `stop_after` training iterations in total, counting both
    /// phases, for tests that simulate a kill), calling `on_step` after each iteration.
    pub fn run(&mut self, stop_after: Option<u64>, mut on_step: impl FnMut(&StepReport)) -> Result<(), TrainError> {
        let mut done = 0u64;
        while let Some(r) = self.step()? {
            on_step(&r);
            if r.phase != Phase::WarmUp {
                done += 1;
                if stop_after.is_some_and(|s| done >= s) {
                    break;
                }
            }
        }
        Ok(())
    }
}
