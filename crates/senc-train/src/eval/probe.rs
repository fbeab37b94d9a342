//! The one-step probe: on skinned training states, how far above a converged solve the
//! next frame of each simple predictor (free flight, the skinned garment, short solves) and
//! of a network lands, per energy term.

use std::path::Path;

use senc_energy::{solve, SolverOptions};
use senc_geom::Vec3;
use senc_model::burn::tensor::Device;
use senc_model::Model;
use serde::Serialize;

use super::method::first_scene;
use crate::config::{Phase, RunConfig};
use crate::error::TrainError;
use crate::garment::Garment;
use crate::trainer::scene_material;

/// One predictor's mean energy above the converged reference over the probe states.
#[derive(Debug, Clone, Serialize)]
pub struct ProbeRow {
    /// "free flight", "skinned", "solver N it" or "network".
    pub predictor: String,
    /// Mean `E(x) − E(x*)`, J.
    pub gap: f64,
    /// Mean energy per term, J.
    pub terms: Vec<(String, f64)>,
}

/// One-step probe on the training distribution: from `states` skinned states `(x[t−1],
/// x[t])` of the config's training motions (relaxed as training starts are when `[train]
/// relax_start_iterations` > 0; the scene's material, gravity, no random
/// force), the energy of the next frame predicted by free flight `2x[t] − x[t−1] + Δt² g`,
/// by the skinned garment, by the network of `checkpoint` (if given) and by the reference
/// solver at `budgets`, each as a gap above the converged solve (`converged` iterations).
///
/// A network that has learned anything beats free flight here; the converged solver's
/// terms say which energies a good step still pays. Phase-1 energy (no self-collision).
pub fn one_step_probe(
    config: &Path,
    checkpoint: Option<&Path>,
    states: usize,
    budgets: &[usize],
    converged: usize,
) -> Result<(Vec<ProbeRow>, ProbeRow), TrainError> {
    let cfg = RunConfig::read(config)?;
    let g = Garment::load(&first_scene(&cfg)?, cfg.train.body_margin)?;
    let model = checkpoint.map(|c| Model::load(c, &Device::flex())).transpose()?.map(|m| m.stepper());
    let material = scene_material(&g)?;
    let ext = g.scene.config.external_force.acceleration;
    let dt = g.scene.dt();
    let em = g.energy_model(cfg.energy_for(Phase::One, material, ext), dt)?;
    let accel = Vec3::from(g.scene.config.external_force.gravity) + Vec3::from(ext);
    let mat = material;
    let mut names: Vec<String> = vec!["free flight".into(), "skinned".into()];
    names.extend(budgets.iter().map(|b| format!("solver {b} it")));
    if model.is_some() {
        names.push("network".into());
    }
    let mut rows: Vec<ProbeRow> =
        names.into_iter().map(|predictor| ProbeRow { predictor, gap: 0.0, terms: Vec::new() }).collect();
    let mut reference =
        ProbeRow { predictor: format!("solver {converged} it (reference)"), gap: 0.0, terms: Vec::new() };
    let add = |row: &mut ProbeRow, b: &senc_energy::Breakdown, e_star: f64| {
        row.gap += b.total - e_star;
        for (k, (name, v)) in b.terms.iter().enumerate() {
            match row.terms.get_mut(k) {
                Some(t) => t.1 += v,
                None => row.terms.push((name.to_string(), *v)),
            }
        }
    };
    let motions: Vec<_> = g.scene.train.iter().filter(|m| m.n_frames() >= 4).collect();
    if motions.is_empty() {
        return Err(TrainError::Invalid(format!("garment {}: no training motion has 4 frames", g.name())));
    }
    let k = states.max(1);
    for i in 0..k {
        let motion = motions[i % motions.len()];
        let f = 1 + (i / motions.len() * 7919 + 13 * i) % (motion.n_frames() - 2);
        let (mut prev, mut curr, skinned) =
            (g.skinned_at(motion, f - 1)?, g.skinned_at(motion, f)?, g.skinned_at(motion, f + 1)?);
        let (bt, bn) = (g.body_at(motion, f)?, g.body_at(motion, f + 1)?);
        if cfg.train.relax_start_iterations > 0 {
            g.relax_start(&em, &mut prev, &mut curr, &bt, cfg.train.relax_start_iterations)?;
        }
        let fe = em.frame(&curr, &prev, Some((&bt, &bn)))?;
        let mut flight: Vec<Vec3> = curr.iter().zip(&prev).map(|(c, p)| c * 2.0 - p + accel * dt * dt).collect();
        g.pin_from(&mut flight, &skinned);
        let (x_star, _) = solve(&fe, &flight, &SolverOptions { max_iterations: converged, ..Default::default() })?;
        let b_star = fe.evaluate(&x_star, None)?;
        add(&mut reference, &b_star, 0.0);
        let mut answers = vec![flight.clone(), skinned];
        for &b in budgets {
            answers.push(solve(&fe, &flight, &SolverOptions { max_iterations: b, ..Default::default() })?.0);
        }
        if let Some(m) = &model {
            let frame = g.frame_state([&prev, &curr], [&bt, &bn], mat, accel, dt);
            let mut x = m.step(&frame)?;
            g.pin_from(&mut x, &answers[1]);
            answers.push(x);
        }
        for (row, x) in rows.iter_mut().zip(&answers) {
            add(row, &fe.evaluate(x, None)?, b_star.total);
        }
    }
    let n = k as f64;
    for r in rows.iter_mut().chain(std::iter::once(&mut reference)) {
        r.gap /= n;
        r.terms.iter_mut().for_each(|t| t.1 /= n);
    }
    Ok((rows, reference))
}
