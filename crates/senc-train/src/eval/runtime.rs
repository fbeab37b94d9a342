//! The error against run time: from states of a network's own rollout, the reference
//! solver (senc-energy, Newton/PCG, the run's phase-2 energy and the scene's material) runs
//! with several iteration budgets; the "converged" answer uses `[eval]
//! converged_iterations`. Gap = E(answer) − E(converged), J (negative where an answer ends
//! below the converged one). The same solver started from the network's answer instead
//! (`[eval] refine_budgets`) gives the network's own curve, "network + N it", on the same
//! states.

use std::time::Instant;

use senc_energy::{solve, SolverOptions};
use senc_geom::Vec3;
use senc_model::Model;
use serde::Serialize;

use super::method::Method;
use super::table1::VolumeMeter;
use crate::config::{Phase, RunConfig};
use crate::error::TrainError;
use crate::garment::Garment;
use crate::rollout::{refine_start, Rollout};
use crate::trainer::scene_material;

/// The curve a [`CurvePoint`] belongs to.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Series {
    /// The reference solver from the inertial target, at several iteration budgets.
    Solver,
    /// A network alone and refined by more and more iterations, by its label.
    Network(String),
}

impl Series {
    /// The legend's name of the curve.
    pub fn name(&self) -> &str {
        match self {
            Series::Solver => "reference solver from the inertial target",
            Series::Network(label) => label,
        }
    }
}

/// One point of the error-against-run-time comparison (averaged over the test states).
#[derive(Debug, Clone, Serialize)]
pub struct CurvePoint {
    /// "solver N it" or the method label.
    pub method: String,
    /// Garment name.
    pub garment: String,
    /// Milliseconds per frame.
    pub ms_per_frame: f64,
    /// Mean energy gap to the converged reference, J.
    pub energy_gap: f64,
    /// The curve this point belongs to (a network's refined points share its curve).
    pub series: Series,
    /// Mean penetration volume of the answers, cm³.
    pub volume_cm3: f64,
}

/// The error-against-run-time points of `method` on states of its rollout `r` (the first
/// test motion's): the solver at `[eval] solver_budgets`, then the network alone (or refined
/// as the method's rollout was) and refined by each larger `[eval] refine_budgets`.
pub(crate) fn error_vs_runtime(
    method: &Method,
    cfg: &RunConfig,
    g: &Garment,
    model: &Model,
    r: &Rollout,
    meter: &mut VolumeMeter,
) -> Result<Vec<CurvePoint>, TrainError> {
    let material = scene_material(g)?;
    let ext = g.scene.config.external_force.acceleration;
    let dt = g.scene.dt();
    let em = g.energy_model(cfg.energy_for(Phase::Two, material, ext), dt)?;
    // States from frame 2 on: frame 1's stored predecessor is the start, whose difference
    // to frame 1 spans the long first step, not a 1/fps velocity.
    if r.steps < 3 {
        return Err(TrainError::Invalid("the error-against-run-time curve needs [eval] frames >= 3".into()));
    }
    let k = cfg.eval.curve_states.max(1).min(r.steps - 2);
    let states: Vec<usize> = (0..k).map(|i| 2 + i * (r.steps - 2) / k).collect();
    let budgets = &cfg.eval.solver_budgets;
    // The network's points: alone (or refined as the method's rollout was), then refined
    // by each of `[eval] refine_budgets` more.
    let mut refine = vec![method.refine()];
    refine.extend(cfg.eval.refine_budgets.iter().filter(|&&k| k > method.refine()));
    let mut acc = vec![(0.0, 0.0, 0.0); budgets.len() + refine.len()];
    let accel = Vec3::from(g.scene.config.external_force.gravity) + Vec3::from(ext);
    let mat = material;
    let stepper = model.stepper();
    for &s in &states {
        let (prev, curr) = (&r.cloth[s - 1], &r.cloth[s]);
        let (bt, bn) = (&r.body[s], &r.body[s + 1]);
        let fe = em.frame(curr, prev, Some((bt, bn)))?;
        let mut x0: Vec<Vec3> = fe.inertial_target().map(|t| t.to_vec()).unwrap_or_else(|| curr.clone());
        g.pin_from(&mut x0, &r.cloth[s + 1]);
        let conv = SolverOptions { max_iterations: cfg.eval.converged_iterations, ..Default::default() };
        let (_, rep) = solve(&fe, &x0, &conv)?;
        let e_star = rep.energy;
        for (i, &b) in budgets.iter().enumerate() {
            let (x, rep) = solve(&fe, &x0, &SolverOptions { max_iterations: b, ..Default::default() })?;
            acc[i].0 += rep.seconds * 1e3;
            acc[i].1 += rep.energy - e_star;
            acc[i].2 += meter.volume(&x)? * 1e6;
        }
        let t0 = Instant::now();
        let frame = g.frame_state([prev, curr], [bt, bn], mat, accel, dt);
        let mut x = stepper.step(&frame)?;
        g.pin_from(&mut x, &r.cloth[s + 1]);
        let net_ms = t0.elapsed().as_secs_f64() * 1e3;
        // Refined as in `network_rollout`: from the better of the network's answer and the
        // inertial target (the comparison is timed with the refinement).
        let t1 = Instant::now();
        let (e_net, _, rejected) = refine_start(&fe, &x, &x0)?;
        let pick_ms = t1.elapsed().as_secs_f64() * 1e3;
        for (j, &k) in refine.iter().enumerate() {
            let (answer, e, ms) = if k == 0 {
                (x.clone(), e_net, net_ms)
            } else {
                let start = if rejected { &x0 } else { &x };
                let (answer, rep) = solve(&fe, start, &SolverOptions { max_iterations: k, ..Default::default() })?;
                (answer, rep.energy, net_ms + pick_ms + rep.seconds * 1e3)
            };
            let a = &mut acc[budgets.len() + j];
            a.0 += ms;
            a.1 += e - e_star;
            a.2 += meter.volume(&answer)? * 1e6;
        }
    }
    let n = states.len() as f64;
    let base = method.label.strip_suffix(&format!(" + {} it", method.refine())).unwrap_or(&method.label);
    let names = budgets.iter().map(|b| (format!("solver {b} it"), Series::Solver)).chain(refine.iter().map(|&k| {
        let name = if k == 0 { base.to_string() } else { format!("{base} + {k} it") };
        (name, Series::Network(base.to_string()))
    }));
    let out = names
        .zip(&acc)
        .map(|((method, series), a)| CurvePoint {
            method,
            garment: g.name().to_string(),
            ms_per_frame: a.0 / n,
            energy_gap: a.1 / n,
            series,
            volume_cm3: a.2 / n,
        })
        .collect();
    Ok(out)
}
