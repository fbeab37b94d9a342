//! Training sequences: where each starts and what it draws. A sequence starts from a
//! skinned garment (mid-motion, relaxed out of the body; or at frame 0 with the long first
//! step) or from a state of the visited-state pool, with a random garment, motion, window,
//! material and external force and noise on its positions, and moves on one frame per
//! training step.

use std::sync::Arc;

use rand::Rng;
use rand_distr::{Distribution, Normal};
use senc_energy::{EnergyModel, Material};
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

/// A pool rollout stops once the garment's mean distance from the skinned garment passes
/// this, m: it has left the body, and training on such states (energies of 1e10 J and
/// more) swamps the loss instead of teaching the network to come back.
const POOL_MAX_DEPARTURE: f64 = 0.25;

/// A pool rollout also stops once the garment's area differs from its rest area by more
/// than this share: cloth that has stretched or shrunk that far is torn, not worn.
const POOL_MAX_AREA_CHANGE: f64 = 0.5;

/// Whether `x`, frame `frame` of a rollout of `motion`, has strayed too far to enter the
/// visited-state pool ([`POOL_MAX_DEPARTURE`], [`POOL_MAX_AREA_CHANGE`]).
pub(super) fn strayed(g: &Garment, motion: &senc_scene::Motion, frame: usize, x: &[Vec3]) -> Result<bool, TrainError> {
    let departure = crate::metrics::mean_distance(x, &g.skinned_at(motion, frame)?);
    let area = crate::metrics::area_growth(&g.rest, x);
    Ok(!(departure <= POOL_MAX_DEPARTURE && area.abs() <= POOL_MAX_AREA_CHANGE))
}

/// What a sequence start draws from the RNG, drawn in one go ([`Trainer::draw_start`]).
/// Building the start from it ([`build_start`]: skinning, relaxing out of the body, adding
/// the drawn noise) uses no randomness, so the trainer can build the next sequence's start
/// on another thread beside a training step and still follow the RNG exactly as a
/// sequential run does.
#[derive(Debug, Clone)]
pub(super) enum StartPlan {
    /// A state of the visited-state pool, continued as it is.
    Pooled(Sequence),
    /// A skinned start.
    Skinned(SkinnedStart),
}

/// The draws of a start from a skinned garment.
#[derive(Debug, Clone)]
pub(super) struct SkinnedStart {
    garment: usize,
    motion: usize,
    frame: usize,
    len: usize,
    first: bool,
    material: Material,
    external: [f64; 3],
    /// Per vertex, the noise added to both of the start's frames (empty: none).
    noise: Vec<Vec3>,
    /// The phase-1 energy that relaxes the start (`None`: not relaxed).
    relax: Option<Arc<EnergyModel>>,
}

/// Builds the start a plan describes on `garments` (deterministic: no RNG).
pub(super) fn build_start(
    plan: StartPlan,
    garments: &[Garment],
    relax_iterations: usize,
) -> Result<Sequence, TrainError> {
    let s = match plan {
        StartPlan::Pooled(s) => return Ok(s),
        StartPlan::Skinned(s) => s,
    };
    let g = &garments[s.garment];
    let m = &g.scene.train[s.motion];
    let (mut prev, mut curr) = if s.first {
        let x = g.skinned_at(m, 0)?;
        (x.clone(), x)
    } else {
        (g.skinned_at(m, s.frame - 1)?, g.skinned_at(m, s.frame)?)
    };
    if let Some(em) = &s.relax {
        g.relax_start(em, &mut prev, &mut curr, &g.body_at(m, s.frame)?, relax_iterations)?;
    }
    for ((p, c), d) in prev.iter_mut().zip(curr.iter_mut()).zip(&s.noise) {
        *p += d;
        *c += d;
    }
    Ok(Sequence {
        garment: s.garment,
        motion: s.motion,
        frame: s.frame,
        steps_left: s.len,
        material: s.material,
        external: s.external,
        prev,
        curr,
        first_step: s.first,
    })
}

impl Trainer {
    /// A new training sequence of `len` steps: from the visited-state pool with
    /// probability `[train] pool_share` when `pooled` allows it (never in warm-up), else
    /// from a skinned garment.
    pub(super) fn start_sequence(&mut self, len: usize, pooled: bool) -> Result<Sequence, TrainError> {
        let plan = self.draw_start(len, pooled)?;
        self.sequence_id += 1;
        build_start(plan, &self.garments, self.config.train.relax_start_iterations)
    }

    /// Every random draw of a new sequence start (see [`StartPlan`]), in the order a start
    /// has always drawn them.
    pub(super) fn draw_start(&mut self, len: usize, pooled: bool) -> Result<StartPlan, TrainError> {
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
                return Ok(StartPlan::Pooled(Sequence { steps_left: len, first_step: false, ..p.clone() }));
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
        let relax = if t.relax_start_iterations > 0 && !first {
            if self.relax_energy.len() <= gi {
                self.relax_energy.resize_with(self.garments.len(), || None);
            }
            if self.relax_energy[gi].is_none() {
                let ec = self.config.energy_for(Phase::One, scene_material(g)?, [0.0; 3]);
                self.relax_energy[gi] = Some(Arc::new(g.energy_model(ec, t.relax_start_dt)?));
            }
            self.relax_energy[gi].clone()
        } else {
            None
        };
        let n_vertices = g.rest.n_vertices();
        let mut noise = Vec::new();
        if t.noise_std > 0.0 {
            let normal = Normal::new(0.0, t.noise_std).map_err(|e| TrainError::Invalid(e.to_string()))?;
            noise.extend((0..n_vertices).map(|_| {
                Vec3::new(normal.sample(&mut self.rng), normal.sample(&mut self.rng), normal.sample(&mut self.rng))
            }));
        }
        Ok(StartPlan::Skinned(SkinnedStart {
            garment: gi,
            motion: mi,
            frame,
            len,
            first,
            material,
            external: ext.into(),
            noise,
            relax,
        }))
    }

    /// Rolls the current network out alone for `[train] pool_frames` frames from a fresh
    /// skinned start (a random garment, motion, material and force, as a training sequence
    /// draws them) and puts every `pool_stride`-th state it reaches into the pool, replacing
    /// the oldest once the pool holds `pool_size`. A rollout that turns non-finite or strays
    /// off the body ([`strayed`]) stops there. Inference only (no optimiser step, no energy).
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
            if !finite(&next) || strayed(&g, motion, s.frame + 1, &next)? {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_garment_off_the_body_or_torn_is_kept_out_of_the_pool() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let cfg = crate::RunConfig::read(root.join("configs/smoke.toml")).unwrap();
        let g = Garment::load(&crate::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
        let motion = &g.scene.train[0];
        let skinned = g.skinned_at(motion, 3).unwrap();
        assert!(!strayed(&g, motion, 3, &skinned).unwrap());
        let lifted: Vec<Vec3> = skinned.iter().map(|p| p + Vec3::new(0.0, 0.3, 0.0)).collect();
        assert!(strayed(&g, motion, 3, &lifted).unwrap());
        let near: Vec<Vec3> = skinned.iter().map(|p| p + Vec3::new(0.0, 0.2, 0.0)).collect();
        assert!(!strayed(&g, motion, 3, &near).unwrap(), "a garment lifted 20 cm is still near the body");
        // Blown up 1.3 times about its centroid: 69 % more area, though its mean distance
        // from the skinned garment is small.
        let c = skinned.iter().sum::<Vec3>() / skinned.len() as f64;
        let blown: Vec<Vec3> = skinned.iter().map(|p| c + (p - c) * 1.3).collect();
        assert!(crate::metrics::mean_distance(&blown, &skinned) < POOL_MAX_DEPARTURE);
        assert!(strayed(&g, motion, 3, &blown).unwrap());
        let nan = vec![Vec3::new(f64::NAN, 0.0, 0.0); skinned.len()];
        assert!(strayed(&g, motion, 3, &nan).unwrap(), "NaN never enters the pool");
    }
}
