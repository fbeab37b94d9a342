//! Checkpoint selection by rollout (`[train] select_every`): the network rolled out alone
//! on the training motions, scored by how far it strays from the skinned garment, among
//! the networks whose garment does not pass through itself.

use senc_geom::Vec3;

use super::sampling::scene_material;
use super::{Trainer, BEST};
use crate::error::TrainError;
use crate::eval::VolumeMeter;
use crate::metrics::mean;
use crate::rollout::rollout;

/// One row of `OUT/selection.csv`.
pub const SELECTION_FILE: &str = "selection.csv";

/// How one network's selection rollouts went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectionScore {
    /// The mean over every garment and training motion of
    /// [`Garment::departure`](crate::Garment::departure), cm; infinity where a rollout
    /// diverged.
    pub departure_cm: f64,
    /// The mean exact penetration volume over the same frames, cm³ (Table 1's
    /// `volume_cm3`); infinity where a rollout diverged.
    pub volume_cm3: f64,
}

impl SelectionScore {
    /// Whether this network may be selected: its rollouts stayed finite and its mean
    /// penetration volume is at most `max_volume_cm3`. Distance alone would pick a
    /// network that stays near the skinned garment by passing through itself.
    pub fn admissible(&self, max_volume_cm3: f64) -> bool {
        self.departure_cm.is_finite() && self.volume_cm3 <= max_volume_cm3
    }

    /// Whether this network replaces the best one so far (`best`: its departure, cm).
    pub fn beats(&self, best: Option<f64>, max_volume_cm3: f64) -> bool {
        self.admissible(max_volume_cm3) && best.is_none_or(|b| self.departure_cm < b)
    }
}

impl Trainer {
    /// The selection score of the current network: the rollouts of `select_frames`
    /// frames after the skinned start on every garment's training motions.
    pub fn selection_score(&self) -> Result<SelectionScore, TrainError> {
        let frames = self.config.train.select_frames;
        let model = self.model.valid();
        let (mut departures, mut volumes) = (Vec::new(), Vec::new());
        for g in self.garments.iter() {
            let material = scene_material(g)?;
            let mut meter = VolumeMeter::new(g)?;
            for motion in &g.scene.train {
                let r = match rollout(&model, g, motion, frames, Vec3::zeros(), &material) {
                    Ok(r) => r,
                    Err(TrainError::Diverged { .. }) => {
                        return Ok(SelectionScore { departure_cm: f64::INFINITY, volume_cm3: f64::INFINITY })
                    }
                    Err(e) => return Err(e),
                };
                departures.push(100.0 * g.departure(motion, &r.cloth)?);
                for x in &r.cloth[1..] {
                    volumes.push(1e6 * meter.volume(x)?);
                }
            }
        }
        Ok(SelectionScore { departure_cm: mean(&departures), volume_cm3: mean(&volumes) })
    }

    /// Scores the current phase-2 network; a new best is written to `OUT/best`.
    pub(super) fn select(&mut self) -> Result<(), TrainError> {
        let score = self.selection_score()?;
        let k = self.progress.iteration;
        let better = score.beats(self.progress.best.map(|(_, b)| b), self.config.train.select_max_volume_cm3);
        if better {
            self.progress.best = Some((k, score.departure_cm));
            self.checkpoint(&self.out.join(BEST))?;
        }
        // Rows at or past this iteration are from before a resume and are redone.
        let path = self.out.join(SELECTION_FILE);
        let old = std::fs::read_to_string(&path).unwrap_or_default();
        let mut text = String::from("iteration,score_cm,volume_cm3,best\n");
        for row in old.lines().skip(1) {
            if row.split(',').next().and_then(|i| i.parse::<u64>().ok()).is_some_and(|i| i < k) {
                text.push_str(row);
                text.push('\n');
            }
        }
        text.push_str(&format!("{k},{:.4},{:.4},{}\n", score.departure_cm, score.volume_cm3, u8::from(better)));
        std::fs::write(&path, text).map_err(|e| TrainError::io(&path, e))?;
        tracing::info!(
            iteration = k,
            score_cm = score.departure_cm,
            volume_cm3 = score.volume_cm3,
            best = ?self.progress.best,
            "selection rollout"
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::SelectionScore;

    #[test]
    fn a_network_that_passes_through_itself_is_never_selected() {
        let near_but_tangled = SelectionScore { departure_cm: 3.0, volume_cm3: 500.0 };
        let far_but_clean = SelectionScore { departure_cm: 9.0, volume_cm3: 2.0 };
        assert!(!near_but_tangled.beats(None, 100.0));
        assert!(!near_but_tangled.beats(Some(9.0), 100.0));
        assert!(far_but_clean.beats(None, 100.0));
        assert!(!far_but_clean.beats(Some(8.0), 100.0), "a closer admissible network stays");
        assert!(near_but_tangled.beats(Some(9.0), f64::INFINITY), "no cap: distance decides");
        let diverged = SelectionScore { departure_cm: f64::INFINITY, volume_cm3: f64::INFINITY };
        assert!(!diverged.beats(None, f64::INFINITY));
    }
}
