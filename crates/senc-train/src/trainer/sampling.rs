//! Training sequences: where each starts and what it draws. A sequence starts from a
//! skinned garment (mid-motion, relaxed out of the body; or at frame 0 with the long first
//! step) or from a state of the visited-state pool, with a random garment, motion, window,
//! material and external force and noise on its positions, and moves on one frame per
//! training step.

use rand::Rng;
use rand_distr::{Distribution, Normal};
use senc_energy::Material;
use senc_geom::Vec3;
use senc_model::FrameState;
use serde::{Deserialize, Serialize};

use super::Trainer;
use crate::config::Phase;
use crate::error::TrainError;
use crate::garment::Garment;

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

/// The network's view of one step of a sequence (shared by warm-up and training steps).
pub(super) fn frame_state<'a>(
    g: &'a Garment,
    seq: &'a Sequence,
    body_t: &'a [Vec3],
    body_n: &'a [Vec3],
    accel: Vec3,
    dt: f64,
) -> FrameState<'a> {
    g.frame_state([&seq.prev, &seq.curr], [body_t, body_n], seq.material, accel, dt)
}

/// The scene's own material as an energy material.
pub fn scene_material(g: &Garment) -> Result<Material, TrainError> {
    material_from_config(&g.scene.config.material)
}

/// The material a `[scene.material]` table describes: HOOD's defaults (`Material::default`)
/// where it gives no number, the Lamé pair or Young's modulus and Poisson's ratio where it
/// does.
pub fn material_from_config(mc: &senc_scene::config::MaterialConfig) -> Result<Material, TrainError> {
    mc.validate()?;
    let mut m = match (mc.lame_mu, mc.lame_lambda, mc.young, mc.poisson) {
        (Some(mu), Some(lambda), _, _) => Material { mu, lambda, ..Material::default() },
        (_, _, Some(young), Some(poisson)) => Material::from_young_poisson(young, poisson)?,
        _ => Material::default(),
    };
    m.density = mc.density.unwrap_or(m.density);
    m.thickness = mc.thickness.unwrap_or(m.thickness);
    m.bending_stiffness = mc.bending.unwrap_or(m.bending_stiffness);
    Ok(m)
}

/// Moves a sequence one frame on to `next`. After the long first step the velocity is
/// kept, not the displacement: the next steps are 1/fps long.
pub(super) fn advance(s: &mut Sequence, next: Vec<Vec3>, g: &Garment) {
    s.prev = std::mem::replace(&mut s.curr, next);
    if s.first_step {
        let k = g.scene.dt() / g.scene.config.first_step_dt;
        crate::garment::rescale_velocity(&mut s.prev, &s.curr, k);
    }
    s.frame += 1;
    s.first_step = false;
}

/// Whether every coordinate is finite.
pub(super) fn finite(v: &[Vec3]) -> bool {
    v.iter().all(|p| p.iter().all(|c| c.is_finite()))
}

impl Trainer {
    /// A new training sequence of `len` steps: from the visited-state pool with
    /// probability `[train] pool_share` when `pooled` allows it (never in warm-up), else
    /// from a skinned garment.
    pub(super) fn start_sequence(&mut self, len: usize, pooled: bool) -> Result<Sequence, TrainError> {
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
                let ec = self.config.energy_for(Phase::One, scene_material(g)?, [0.0; 3]);
                self.relax_energy[gi] = Some(g.energy_model(ec, t.relax_start_dt)?);
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

    /// Rolls the current network out alone for `[train] pool_frames` frames from a fresh
    /// skinned start (a random garment, motion, material and force, as a training sequence
    /// draws them) and puts every `pool_stride`-th state it reaches into the pool, replacing
    /// the oldest once the pool holds `pool_size`. A rollout that turns non-finite stops
    /// there. Inference only (no optimiser step, no energy).
    pub(super) fn fill_pool(&mut self) -> Result<(), TrainError> {
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
}
