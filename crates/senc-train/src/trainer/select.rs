//! Checkpoint selection by rollout (`[train] select_every`): the network rolled out alone
//! on the training motions, scored by how far it strays from the skinned garment.

use senc_geom::Vec3;

use super::sampling::scene_material;
use super::{Trainer, BEST};
use crate::error::TrainError;
use crate::metrics::mean;
use crate::rollout::rollout;

/// One row of `OUT/selection.csv`.
pub const SELECTION_FILE: &str = "selection.csv";

impl Trainer {
    /// The selection score of the current network, cm: the mean over every garment and
    /// training motion of [`Garment::departure`](crate::Garment::departure) over the
    /// `select_frames` frames after the skinned start of the network's rollout. A rollout
    /// that diverges scores infinity.
    pub fn selection_score(&self) -> Result<f64, TrainError> {
        let frames = self.config.train.select_frames;
        let model = self.model.valid();
        let mut scores = Vec::new();
        for g in self.garments.iter() {
            let material = scene_material(g)?;
            for motion in &g.scene.train {
                let r = match rollout(&model, g, motion, frames, Vec3::zeros(), &material) {
                    Ok(r) => r,
                    Err(TrainError::Diverged { .. }) => return Ok(f64::INFINITY),
                    Err(e) => return Err(e),
                };
                scores.push(100.0 * g.departure(motion, &r.cloth)?);
            }
        }
        Ok(mean(&scores))
    }

    /// Scores the current phase-2 network; a new best is written to `OUT/best`.
    pub(super) fn select(&mut self) -> Result<(), TrainError> {
        let score = self.selection_score()?;
        let k = self.progress.iteration;
        let better = score.is_finite() && self.progress.best.is_none_or(|(_, b)| score < b);
        if better {
            self.progress.best = Some((k, score));
            self.checkpoint(&self.out.join(BEST))?;
        }
        // Rows at or past this iteration are from before a resume and are redone.
        let path = self.out.join(SELECTION_FILE);
        let old = std::fs::read_to_string(&path).unwrap_or_default();
        let mut text = String::from("iteration,score_cm,best\n");
        for row in old.lines().skip(1) {
            if row.split(',').next().and_then(|i| i.parse::<u64>().ok()).is_some_and(|i| i < k) {
                text.push_str(row);
                text.push('\n');
            }
        }
        text.push_str(&format!("{k},{score:.4},{}\n", u8::from(better)));
        std::fs::write(&path, text).map_err(|e| TrainError::io(&path, e))?;
        tracing::info!(iteration = k, score_cm = score, best = ?self.progress.best, "selection rollout");
        Ok(())
    }
}
