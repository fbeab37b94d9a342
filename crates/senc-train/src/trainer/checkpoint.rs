//! Checkpoint directories (`OUT/latest`, `OUT/phase1`, `OUT/phase2`): the model, Adam's
//! state, the trainer's progress (RNG position, running sequence, pool) and the resolved
//! config, written under a temporary name and renamed into place.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::sampling::Sequence;
use super::Trainer;
use crate::config::Phase;
use crate::error::TrainError;

/// Name of the rolling checkpoint directory inside the output directory.
pub const LATEST: &str = "latest";
/// Adam's state inside a checkpoint directory.
pub const OPTIM_FILE: &str = "optim.bpk";
/// The trainer's progress inside a checkpoint directory.
pub const PROGRESS_FILE: &str = "trainer.msgpack";
/// The best-scoring phase-2 network so far (`[train] select_every`).
pub const BEST: &str = "best";
/// The config text inside a checkpoint directory.
pub const CONFIG_FILE: &str = "config.toml";

/// Where training stands.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Progress {
    /// Warm-up iterations done.
    pub warmup_done: u64,
    /// Current training phase ([`Phase::One`] or [`Phase::Two`]).
    pub phase: Phase,
    /// Iterations done in the current phase.
    pub iteration: u64,
    /// Steps skipped for non-finite values, per phase.
    pub skipped: [u64; 2],
    /// The RNG's position (ChaCha word position).
    pub rng_word_pos: u128,
    /// The running sequence.
    pub sequence: Option<Sequence>,
    /// The next sequence, when the running one ends at the next iteration: started beside
    /// the step that ends the running one, its draws already made.
    #[serde(default)]
    pub next_sequence: Option<Sequence>,
    /// Whether both phases are done.
    pub finished: bool,
    /// States the network reached when rolled out alone (`[train] pool_share`), as
    /// sequences at the frame they reached; a training sequence may start from one.
    #[serde(default)]
    pub pool: Vec<Sequence>,
    /// Where the next pooled state goes once the pool is full.
    #[serde(default)]
    pub pool_next: usize,
    /// The best selection score so far in phase 2 and its iteration (`[train]
    /// select_every`); the network is in `OUT/best`.
    #[serde(default)]
    pub best: Option<(u64, f64)>,
}

/// Writes a directory atomically: filled under a temporary name, then renamed into place.
pub(super) fn write_atomic_dir(
    dir: &Path,
    fill: impl FnOnce(&Path) -> Result<(), TrainError>,
) -> Result<(), TrainError> {
    let parent = dir.parent().unwrap_or(Path::new("."));
    let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("ckpt");
    let tmp = parent.join(format!(".{name}.tmp"));
    let old = parent.join(format!(".{name}.old"));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| TrainError::io(&tmp, e))?;
    fill(&tmp)?;
    let _ = std::fs::remove_dir_all(&old);
    if dir.exists() {
        std::fs::rename(dir, &old).map_err(|e| TrainError::io(dir, e))?;
    }
    std::fs::rename(&tmp, dir).map_err(|e| TrainError::io(dir, e))?;
    let _ = std::fs::remove_dir_all(&old);
    Ok(())
}

impl Trainer {
    /// Writes a checkpoint directory atomically (temporary directory, then rename). Refuses
    /// to write non-finite weights.
    pub fn checkpoint(&self, dir: &Path) -> Result<(), TrainError> {
        let mut progress = self.progress.clone();
        progress.rng_word_pos = self.rng.get_word_pos();
        let probe = crate::clip::param_norm(&self.model.network);
        if !probe.is_finite() {
            return Err(TrainError::Checkpoint {
                path: dir.to_path_buf(),
                message: "the weights are not finite; refusing to write them".into(),
            });
        }
        let source = self.config.path.canonicalize().unwrap_or_else(|_| self.config.path.clone());
        write_atomic_dir(dir, |tmp| {
            self.model.save(tmp)?;
            let o = tmp.join(OPTIM_FILE);
            self.optim.to_record().save(&o).map_err(|e| TrainError::io(&o, format!("{e:?}")))?;
            let p = tmp.join(PROGRESS_FILE);
            let bytes = rmp_serde::to_vec_named(&progress).map_err(|e| TrainError::io(&p, e))?;
            std::fs::write(&p, bytes).map_err(|e| TrainError::io(&p, e))?;
            let c = tmp.join(CONFIG_FILE);
            std::fs::write(&c, &self.config_text).map_err(|e| TrainError::io(&c, e))?;
            let s = tmp.join("source.txt");
            std::fs::write(&s, source.display().to_string()).map_err(|e| TrainError::io(&s, e))?;
            let r = tmp.join("resolved.json");
            let json = serde_json::to_string_pretty(&self.config).map_err(|e| TrainError::io(&r, e))?;
            std::fs::write(&r, json).map_err(|e| TrainError::io(&r, e))
        })
    }
}
