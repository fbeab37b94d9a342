//! Stiff and extreme cases on a network's rollout: the checks that a trained network stays
//! finite, with numbers, where its inputs leave the training range.
//!
//! Each [`StressCase`] changes one thing of the scene's own setting: the material (μ and
//! k_b ×100), the motion (played three times faster), the external force (a 50 m/s²
//! horizontal wind), or the start (the garment moved 2 cm towards the body, so that the
//! cloth near it starts inside). The network runs alone; every frame's phase-2 energy (of
//! the case's own material and force) and the distance from the skinned garment are
//! recorded. A rollout that turns non-finite is reported as such, never as a panic.

use senc_energy::{EnergyConfig, Material};
use senc_geom::Vec3;
use senc_model::Model;
use senc_scene::{BodyQuery, Motion};
use serde::Serialize;

use crate::error::TrainError;
use crate::garment::Garment;
use crate::metrics::{mean, mean_distance};
use crate::rollout::{network_rollout_from, Rollout};

/// One stress case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StressCase {
    /// The scene's own material, motion and force.
    Default,
    /// μ and k_b ×100.
    Stiff,
    /// The motion played three times faster.
    Fast,
    /// A 50 m/s² horizontal wind (along +x) on top of gravity.
    Wind,
    /// The garment started 2 cm towards the body.
    Inside,
}

impl StressCase {
    /// Every case, in report order.
    pub const ALL: [StressCase; 5] = [Self::Default, Self::Stiff, Self::Fast, Self::Wind, Self::Inside];

    /// What the case changes, in words.
    pub fn description(self) -> &'static str {
        match self {
            Self::Default => "the scene's material, motion and force",
            Self::Stiff => "mu and k_b x100",
            Self::Fast => "the motion played 3x faster",
            Self::Wind => "50 m/s^2 horizontal wind",
            Self::Inside => "start moved 2 cm towards the body",
        }
    }
}

/// Factor on μ and k_b of [`StressCase::Stiff`].
pub const STIFF_FACTOR: f64 = 100.0;
/// Playback speed of [`StressCase::Fast`].
pub const FAST_FACTOR: f64 = 3.0;
/// Wind of [`StressCase::Wind`], m/s².
pub const WIND: [f64; 3] = [50.0, 0.0, 0.0];
/// How far [`StressCase::Inside`] moves the start towards the body, m.
pub const INSIDE_OFFSET: f64 = 0.02;

/// What one case's rollout did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StressRow {
    /// The case.
    pub case: StressCase,
    /// Frames simulated (fewer than asked when the rollout turned non-finite).
    pub frames: usize,
    /// Whether every frame stayed finite.
    pub finite: bool,
    /// Why the rollout stopped early, if it did.
    pub error: Option<String>,
    /// Mean phase-2 energy per frame (the case's material and force), J.
    pub energy_mean_j: f64,
    /// Largest phase-2 energy of a frame, J.
    pub energy_max_j: f64,
    /// Mean distance from the skinned garment over the frames, cm.
    pub departure_cm: f64,
    /// Largest mean vertex speed of a frame, cm per frame.
    pub max_speed_cm: f64,
}

/// The motion `motion` played `factor` times faster at the same frame rate.
pub fn faster(motion: &Motion, factor: f64) -> Result<Motion, TrainError> {
    let mut m = motion.resample(motion.fps / factor)?;
    m.fps = motion.fps;
    m.name = format!("{}_x{factor}", motion.name);
    Ok(m)
}

/// `x` with every vertex moved `offset` metres towards its closest point on the body
/// `body` (away from it for a vertex already inside, so that every vertex ends deeper).
pub fn towards_body(x: &[Vec3], body: &BodyQuery, offset: f64) -> Vec<Vec3> {
    x.iter()
        .map(|p| {
            let c = body.closest(p);
            let d = c.point - p;
            let n = d.norm();
            if n == 0.0 || !n.is_finite() {
                return *p;
            }
            let dir = if c.inside { -d / n } else { d / n };
            p + dir * offset
        })
        .collect()
}

/// Runs every [`StressCase`] on `motion` for `frames` frames with `model` on `g`, with
/// `energy` the run's phase-2 energy and `material` the scene's material.
pub fn stress(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    energy: &EnergyConfig,
    material: &Material,
) -> Result<Vec<StressRow>, TrainError> {
    StressCase::ALL.iter().map(|&case| run_case(case, model, g, motion, frames, energy, material)).collect()
}

fn run_case(
    case: StressCase,
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    energy: &EnergyConfig,
    material: &Material,
) -> Result<StressRow, TrainError> {
    let mut material = *material;
    let mut external = Vec3::from(g.scene.config.external_force.acceleration);
    let mut motion = motion.clone();
    let mut start = g.skinned_at(&motion, 0)?;
    match case {
        StressCase::Default => {}
        StressCase::Stiff => {
            material.mu *= STIFF_FACTOR;
            material.bending_stiffness *= STIFF_FACTOR;
        }
        StressCase::Fast => motion = faster(&motion, FAST_FACTOR)?,
        StressCase::Wind => external += Vec3::from(WIND),
        StressCase::Inside => {
            let body = g.scene.body_at(&motion, 0)?;
            let q = BodyQuery::new(&body, &g.scene.body.faces)?;
            start = towards_body(&start, &q, INSIDE_OFFSET);
        }
    }
    let mut energy = energy.clone();
    energy.material = material;
    energy.external_acceleration = external.into();
    let (rollout, error) = match network_rollout_from(model, g, &motion, frames, external, &material, None, start) {
        Ok(r) => (r, None),
        Err(e @ TrainError::Diverged { .. }) => {
            let message = e.to_string();
            let TrainError::Diverged { partial, .. } = e else { unreachable!("matched above") };
            (*partial, Some(message))
        }
        Err(e) => return Err(e),
    };
    measure(case, g, &motion, &rollout, &energy, error)
}

fn measure(
    case: StressCase,
    g: &Garment,
    motion: &Motion,
    r: &Rollout,
    energy: &EnergyConfig,
    error: Option<String>,
) -> Result<StressRow, TrainError> {
    let em = g.energy_model(energy.clone(), g.scene.dt())?;
    let em_first = g.energy_model(energy.clone(), g.scene.config.first_step_dt)?;
    let (mut energies, mut speed) = (Vec::new(), Vec::new());
    for f in 1..r.cloth.len() {
        // The state each step started from, as the rollout saw it: at rest before the first
        // step (of `first_step_dt`), and its velocity rescaled to 1/fps after it.
        let mut prev = r.cloth[f.saturating_sub(2)].clone();
        if f == 2 {
            crate::garment::rescale_velocity(&mut prev, &r.cloth[1], g.scene.dt() / g.scene.config.first_step_dt);
        }
        let em = if f == 1 { &em_first } else { &em };
        let fe = em.frame(&r.cloth[f - 1], &prev, Some((&r.body[f - 1], &r.body[f])))?;
        energies.push(fe.evaluate(&r.cloth[f], None)?.total);
        speed.push(mean_distance(&r.cloth[f], &r.cloth[f - 1]));
    }
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    Ok(StressRow {
        case,
        frames: r.cloth.len() - 1,
        finite: error.is_none(),
        error,
        energy_mean_j: mean(&energies),
        energy_max_j: max(&energies),
        departure_cm: 100.0 * g.departure(motion, &r.cloth)?,
        max_speed_cm: 100.0 * max(&speed),
    })
}
