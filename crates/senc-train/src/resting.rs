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
use crate::rollout::{network_rollout, solver_rollout, Rollout};

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
}

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

/// Compares two rollouts of the same garment and motion (`network` against `reference`).
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
    }
}

/// Rolls `model` and the reference solver (`iterations` Newton iterations per frame on
/// `energy`, from its own previous frames) out on `motion` and compares them.
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
    Ok((compare(&network, &reference), network, reference))
}
