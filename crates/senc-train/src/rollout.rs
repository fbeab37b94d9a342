//! Running a trained model on a motion: the garment starts skinned at frame 0 with zero
//! velocity, then the network predicts each next frame from the two previous ones.

use std::time::Instant;

use senc_energy::Material;
use senc_geom::Vec3;
use senc_model::Model;
use senc_scene::Motion;

use crate::error::TrainError;
use crate::garment::Garment;

/// A simulated sequence.
#[derive(Debug, Clone)]
pub struct Rollout {
    /// Cloth positions per frame (frame 0 is the skinned start), m.
    pub cloth: Vec<Vec<Vec3>>,
    /// Proxy body positions per frame, m.
    pub body: Vec<Vec<Vec3>>,
    /// Seconds spent in the per-frame step: graph building and network, or the solver (no
    /// I/O, no skinning).
    pub infer_seconds: f64,
    /// Frames predicted.
    pub steps: usize,
    /// Per frame, what the Newton refinement of a network's answer did (empty without
    /// refinement; see [`network_rollout`]).
    pub refined: Vec<RefinedFrame>,
}

/// One step's view in [`roll`]: `x[t−1]`, `x[t]`, body at t and t+1, the skinned garment at
/// t+1 when the garment has pinned vertices, and whether this is the long first step.
pub(crate) struct StepInput<'a> {
    prev: &'a [Vec3],
    curr: &'a [Vec3],
    body_t: &'a [Vec3],
    body_next: &'a [Vec3],
    pins: Option<&'a [Vec3]>,
    first: bool,
}

/// The rollout loop shared by the network and the solver, as in training: the garment
/// starts at `x0` (the skinned garment at frame 0, unless a caller moves it) with zero
/// velocity, the first step is `[scene] first_step_dt`
/// long (the velocity it leaves is rescaled to 1/fps steps), and `step` gives each next
/// frame and is the only part timed. Pinned vertices of the answer are copied from the
/// skinned garment. A non-finite frame ends the rollout with [`TrainError::Diverged`],
/// which holds the frames before it.
fn roll(
    g: &Garment,
    motion: &Motion,
    frames: usize,
    x0: Vec<Vec3>,
    mut step: impl FnMut(StepInput<'_>) -> Result<Vec<Vec3>, TrainError>,
) -> Result<Rollout, TrainError> {
    let n = frames.min(motion.n_frames().saturating_sub(1));
    if x0.len() != g.rest.n_vertices() {
        return Err(TrainError::Invalid(format!(
            "the start state has {} vertices, the garment {}",
            x0.len(),
            g.rest.n_vertices()
        )));
    }
    let mut cloth = vec![x0.clone()];
    let mut body = vec![g.body_at(motion, 0)?];
    let mut prev = x0.clone();
    let mut curr = x0;
    let mut secs = 0.0;
    for f in 0..n {
        let b_next = g.body_at(motion, f + 1)?;
        let pins = if g.pinned.is_empty() { None } else { Some(g.skinned_at(motion, f + 1)?) };
        let t0 = Instant::now();
        let input = StepInput {
            prev: &prev,
            curr: &curr,
            body_t: &body[f],
            body_next: &b_next,
            pins: pins.as_deref(),
            first: f == 0,
        };
        let mut next = step(input)?;
        secs += t0.elapsed().as_secs_f64();
        if let Some(p) = &pins {
            g.pin_from(&mut next, p);
        }
        if !next.iter().all(|p| p.iter().all(|c| c.is_finite())) {
            let partial = Rollout { cloth, body, infer_seconds: secs, steps: f, refined: Vec::new() };
            return Err(TrainError::Diverged { frame: f + 1, partial: Box::new(partial) });
        }
        prev = std::mem::replace(&mut curr, next);
        if f == 0 {
            crate::garment::rescale_velocity(&mut prev, &curr, g.scene.dt() / g.scene.config.first_step_dt);
        }
        cloth.push(curr.clone());
        body.push(b_next);
    }
    Ok(Rollout { cloth, body, infer_seconds: secs, steps: n, refined: Vec::new() })
}

/// Simulates `frames` frames of `motion` (fewer if the motion is shorter) with `model`
/// (inference copy taken internally), gravity plus `external` m/s², and `material`.
pub fn rollout(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    external: Vec3,
    material: &Material,
) -> Result<Rollout, TrainError> {
    network_rollout(model, g, motion, frames, external, material, None)
}

/// Newton refinement of a network's answer: at most `iterations` iterations of the reference
/// solver on `energy` (the run's phase-2 energy), started from the network's prediction.
#[derive(Debug, Clone)]
pub struct Refine<'a> {
    /// The energy minimised (its `dt` and gravity are taken from the garment's scene).
    pub energy: &'a senc_energy::EnergyConfig,
    /// Newton iterations per frame (0 = the network alone).
    pub iterations: usize,
}

/// What the refinement did to one frame of [`network_rollout`] (energies of the refined
/// energy, J).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefinedFrame {
    /// `E` of the network's answer.
    pub network: f64,
    /// `E` of the inertial target `2x[t] − x[t−1]` (the solver's own start).
    pub inertial: f64,
    /// `E` of the refined answer (at most the smaller of the two).
    pub refined: f64,
    /// The network's answer was worse than the inertial target, so the solver started from
    /// the target instead.
    pub rejected: bool,
}

/// Where the refinement of a network's answer starts: `(E(network), E(target), rejected)`,
/// rejected (start from the inertial `target`) when the network's answer has the higher
/// energy or is not finite.
pub(crate) fn refine_start(
    fe: &senc_energy::FrameEnergy<'_>,
    network: &[Vec3],
    target: &[Vec3],
) -> Result<(f64, f64, bool), TrainError> {
    let finite = network.iter().all(|p| p.iter().all(|c| c.is_finite()));
    let e_net = if finite { fe.evaluate(network, None)?.total } else { f64::NAN };
    let e_target = fe.evaluate(target, None)?.total;
    Ok((e_net, e_target, e_net.is_nan() || e_net > e_target))
}

/// [`rollout`] with each predicted frame refined by a few Newton iterations of the reference
/// solver, started from the network's answer instead of the inertial target: a point
/// between the network (fast, approximate) and the solver (slow, converged) on the
/// error-against-run-time curve. Each frame is pulled towards the minimum of the energy the
/// network was trained on, so the network's errors cannot compound freely. Where the
/// network's answer has a higher energy than the inertial target (or a non-finite one), the
/// solver starts from the target instead, so the refined frame's energy is never above
/// either. The timed step includes the refinement; [`Rollout::refined`] records each frame.
/// `refine: None` (or 0 iterations) is [`rollout`].
pub fn network_rollout(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    external: Vec3,
    material: &Material,
    refine: Option<Refine<'_>>,
) -> Result<Rollout, TrainError> {
    network_rollout_from(model, g, motion, frames, external, material, refine, g.skinned_at(motion, 0)?)
}

/// [`network_rollout`] from the start state `x0` (at rest) instead of the skinned garment.
pub fn network_rollout_from(
    model: &Model,
    g: &Garment,
    motion: &Motion,
    frames: usize,
    external: Vec3,
    material: &Material,
    refine: Option<Refine<'_>>,
    x0: Vec<Vec3>,
) -> Result<Rollout, TrainError> {
    let stepper = model.stepper();
    let accel = Vec3::from(g.scene.config.external_force.gravity) + external;
    let model_mat = *material;
    let refine = refine.filter(|r| r.iterations > 0);
    let energies = match &refine {
        Some(r) => Some((
            g.energy_model(r.energy.clone(), g.scene.dt())?,
            g.energy_model(r.energy.clone(), g.scene.config.first_step_dt)?,
        )),
        None => None,
    };
    let opts = senc_energy::SolverOptions {
        max_iterations: refine.as_ref().map_or(1, |r| r.iterations),
        ..Default::default()
    };
    let mut record = Vec::new();
    let mut r = roll(g, motion, frames, x0, |s| {
        let dt = if s.first { g.scene.config.first_step_dt } else { g.scene.dt() };
        let frame = g.frame_state([s.prev, s.curr], [s.body_t, s.body_next], model_mat, accel, dt);
        let mut next = stepper.step(&frame)?;
        let Some((em, em_first)) = &energies else { return Ok(next) };
        let fe = (if s.first { em_first } else { em }).frame(s.curr, s.prev, Some((s.body_t, s.body_next)))?;
        let mut target: Vec<Vec3> = fe.inertial_target().map(|t| t.to_vec()).unwrap_or_else(|| s.curr.to_vec());
        if let Some(p) = s.pins {
            g.pin_from(&mut next, p);
            g.pin_from(&mut target, p);
        }
        let (network, inertial, rejected) = refine_start(&fe, &next, &target)?;
        let (x, rep) = senc_energy::solve(&fe, if rejected { &target } else { &next }, &opts)?;
        record.push(RefinedFrame { network, inertial, refined: rep.energy, rejected });
        Ok(x)
    })?;
    r.refined = record;
    Ok(r)
}

/// Simulates `frames` frames of `motion` with the reference solver instead of a network:
/// each frame minimises the incremental potential `E(x[t+1])` of `energy` (Newton, at most
/// `iterations` iterations, started from the inertial target `2x[t] − x[t−1]`). The energy's
/// `dt`, gravity and open holes are taken from the garment's scene; `energy.material` and
/// `energy.external_acceleration` are used as given.
///
/// This is the classical simulation the network is trained to imitate: if it does not keep
/// the garment on the body, no amount of training will.
pub fn solver_rollout(
    g: &Garment,
    motion: &Motion,
    frames: usize,
    energy: &senc_energy::EnergyConfig,
    iterations: usize,
) -> Result<Rollout, TrainError> {
    let em = g.energy_model(energy.clone(), g.scene.dt())?;
    let em_first = g.energy_model(energy.clone(), g.scene.config.first_step_dt)?;
    let opts = senc_energy::SolverOptions { max_iterations: iterations.max(1), ..Default::default() };
    roll(g, motion, frames, g.skinned_at(motion, 0)?, |s| {
        let em = if s.first { &em_first } else { &em };
        let fe = em.frame(s.curr, s.prev, Some((s.body_t, s.body_next)))?;
        solver_step(g, &fe, s.curr, s.pins, &opts)
    })
}

/// One step of the reference solver on the frame energy `fe` of the state whose current
/// positions are `curr`: Newton from the inertial target (from `curr` when the energy has
/// no inertia), with the pinned vertices at `pins` when the garment has any.
pub(crate) fn solver_step(
    g: &Garment,
    fe: &senc_energy::FrameEnergy<'_>,
    curr: &[Vec3],
    pins: Option<&[Vec3]>,
    opts: &senc_energy::SolverOptions,
) -> Result<Vec<Vec3>, TrainError> {
    let mut start: Vec<Vec3> = fe.inertial_target().map(|t| t.to_vec()).unwrap_or_else(|| curr.to_vec());
    if let Some(p) = pins {
        g.pin_from(&mut start, p);
    }
    Ok(senc_energy::solve(fe, &start, opts)?.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smoke_garment() -> Garment {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let cfg = crate::RunConfig::read(root.join("configs/smoke.toml")).unwrap();
        Garment::load(&crate::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap()
    }

    /// A non-finite frame ends the rollout with `TrainError::Diverged`, which keeps the
    /// frames before it; a start state of the wrong size is refused.
    #[test]
    fn a_diverged_rollout_is_a_typed_error_with_its_frames() {
        let g = smoke_garment();
        let motion = &g.scene.test[0];
        let x0 = g.skinned_at(motion, 0).unwrap();
        // A free vertex (pinned ones are overwritten by the skinned garment).
        let free = (0..x0.len()).find(|i| !g.pinned.contains(i)).unwrap();
        let result = roll(&g, motion, 5, x0.clone(), |s| {
            let mut next = s.curr.to_vec();
            if !s.first {
                next[free].y = f64::NAN;
            }
            Ok(next)
        });
        match result {
            Err(TrainError::Diverged { frame, partial }) => {
                assert_eq!(frame, 2);
                assert_eq!(partial.cloth.len(), 2);
                assert_eq!(partial.body.len(), 2);
                assert_eq!(partial.cloth[0], x0);
            }
            other => panic!("expected a divergence, got {:?}", other.map(|r| r.steps)),
        }
        let short = x0[..3].to_vec();
        assert!(matches!(roll(&g, motion, 5, short, |s| Ok(s.curr.to_vec())), Err(TrainError::Invalid(_))));
    }
}
