//! The network against the reference solver on one motion, frame by frame: the check of
//! the resting case (a body that holds still, where the physics is to sag a little and
//! hang still) and of any other motion where the classical answer is the yardstick.

use senc_energy::{EnergyConfig, Material};
use senc_geom::Vec3;
use senc_model::Model;
use senc_scene::Motion;
use serde::Serialize;

use crate::error::TrainError;
use crate::garment::Garment;
use crate::metrics::{mean_distance, mean_rise};
use crate::rollout::{network_rollout, solver_rollout, solver_step, Rollout};

/// How far a network's rollout is from the reference solver's on the same motion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolverComparison {
    /// Frames simulated after frame 0.
    pub frames: usize,
    /// Mean vertex distance between the two garments at the last frame, cm.
    pub final_distance_cm: f64,
    /// Largest mean vertex distance over all frames, cm.
    pub max_distance_cm: f64,
    /// Mean vertical offset of the network's garment above the solver's at the last frame, cm.
    pub final_rise_cm: f64,
    /// Mean vertical displacement of the network's garment in the first (long) step, cm.
    pub first_step_rise_cm: f64,
    /// The solver's, cm.
    pub solver_first_step_rise_cm: f64,
    /// Mean vertex speed over the last `STILL_FRAMES` frames of the network's rollout, cm
    /// per frame (0 for a garment at rest).
    pub final_speed_cm: f64,
    /// The solver's, cm per frame.
    pub solver_final_speed_cm: f64,
    /// Mean distance per frame, cm (frame 0 first).
    pub distance_cm: Vec<f64>,
    /// The network's one-step error on the solver's own states: from pairs of the solver's
    /// frames (frame 2 on, past the long first step), the network's next frame against the
    /// solver's.
    pub on_solver_states: OneStepError,
    /// The network's one-step error on its own states: from pairs of the network's frames,
    /// its next frame against one solver step from the same pair.
    pub on_network_states: OneStepError,
}

/// The mean one-step error of a network against the solver from the same states.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct OneStepError {
    /// Steps compared.
    pub steps: usize,
    /// Mean vertex distance of the network's next frame from the solver's, cm.
    pub distance_cm: f64,
    /// Mean vertical offset of the network's next frame above the solver's, cm: a
    /// consistent sign is a bias that a rollout integrates into a drift.
    pub rise_cm: f64,
}

/// Frames (at most, evenly spaced) at which the one-step errors are measured.
pub const ONE_STEP_SAMPLES: usize = 15;

/// Frames over which [`SolverComparison::final_speed_cm`] is averaged.
pub const STILL_FRAMES: usize = 10;

fn final_speed(r: &Rollout) -> f64 {
    let n = r.cloth.len();
    let k = STILL_FRAMES.min(n.saturating_sub(1));
    if k == 0 {
        return 0.0;
    }
    (n - k..n).map(|f| mean_distance(&r.cloth[f], &r.cloth[f - 1])).sum::<f64>() / k as f64
}

/// Compares two rollouts of the same garment and motion (`network` against `reference`);
/// the one-step errors are left at zero (see [`against_solver`]).
pub fn compare(network: &Rollout, reference: &Rollout) -> SolverComparison {
    let n = network.cloth.len().min(reference.cloth.len());
    let distance_cm: Vec<f64> = (0..n).map(|f| 100.0 * mean_distance(&network.cloth[f], &reference.cloth[f])).collect();
    let first = |r: &Rollout| if r.cloth.len() > 1 { 100.0 * mean_rise(&r.cloth[1], &r.cloth[0]) } else { 0.0 };
    SolverComparison {
        frames: n.saturating_sub(1),
        final_distance_cm: distance_cm.last().copied().unwrap_or(0.0),
        max_distance_cm: distance_cm.iter().copied().fold(0.0, f64::max),
        final_rise_cm: if n > 0 { 100.0 * mean_rise(&network.cloth[n - 1], &reference.cloth[n - 1]) } else { 0.0 },
        first_step_rise_cm: first(network),
        solver_first_step_rise_cm: first(reference),
        final_speed_cm: 100.0 * final_speed(network),
        solver_final_speed_cm: 100.0 * final_speed(reference),
        distance_cm,
        on_solver_states: OneStepError::default(),
        on_network_states: OneStepError::default(),
    }
}

/// The mean one-step error of `model` against `iterations` Newton iterations of `em` from
/// at most [`ONE_STEP_SAMPLES`] evenly spaced frame pairs of `states` (frame 2 on), each
/// step taken on `states`' own body frames.
fn one_step_error(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    states: &Rollout,
    material: &Material,
    accel: Vec3,
    em: &senc_energy::EnergyModel,
    iterations: usize,
) -> Result<OneStepError, TrainError> {
    let stepper = model.stepper();
    let opts = senc_energy::SolverOptions { max_iterations: iterations.max(1), ..Default::default() };
    let (mut distance, mut rise, mut steps) = (0.0, 0.0, 0);
    let last = states.cloth.len().saturating_sub(1);
    let stride = last.saturating_sub(2).div_ceil(ONE_STEP_SAMPLES).max(1);
    for f in (2..last).step_by(stride) {
        let (prev, curr) = (&states.cloth[f - 1], &states.cloth[f]);
        let (body_t, body_n) = (&states.body[f], &states.body[f + 1]);
        let frame = g.frame_state([prev, curr], [body_t, body_n], *material, accel, g.scene.dt());
        let mut net = stepper.step(&frame)?;
        let fe = em.frame(curr, prev, Some((body_t, body_n)))?;
        let pins = if g.pinned.is_empty() { None } else { Some(g.skinned_at(motion, f + 1)?) };
        if let Some(p) = &pins {
            g.pin_from(&mut net, p);
        }
        let sol = solver_step(g, &fe, curr, pins.as_deref(), &opts)?;
        distance += 100.0 * mean_distance(&net, &sol);
        rise += 100.0 * mean_rise(&net, &sol);
        steps += 1;
    }
    let n = steps.max(1) as f64;
    Ok(OneStepError { steps, distance_cm: distance / n, rise_cm: rise / n })
}

/// Rolls `model` and the reference solver (`iterations` Newton iterations per frame on
/// `energy`, from its own previous frames) out on `motion` and compares them, with the
/// network's one-step error on both rollouts' states (which tells a bias the network has on
/// physical states from one it has only on the states its own errors lead to).
pub fn against_solver(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    material: &Material,
    energy: &EnergyConfig,
    iterations: usize,
) -> Result<(SolverComparison, Rollout, Rollout), TrainError> {
    let external = Vec3::from(energy.external_acceleration);
    let network = network_rollout(model, g, motion, frames, external, material, None)?;
    let reference = solver_rollout(g, motion, frames, energy, iterations)?;
    let mut c = compare(&network, &reference);
    let accel = Vec3::from(g.scene.config.external_force.gravity) + external;
    let em = g.energy_model(energy.clone(), g.scene.dt())?;
    c.on_solver_states = one_step_error(model, g, motion, &reference, material, accel, &em, iterations)?;
    c.on_network_states = one_step_error(model, g, motion, &network, material, accel, &em, iterations)?;
    Ok((c, network, reference))
}
