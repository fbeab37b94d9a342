//! The loss log, `OUT/losses.csv` (one row per training iteration, written with the csv
//! crate), and [`StepReport`], what one iteration did.

use std::path::Path;

use crate::config::Phase;
use crate::error::TrainError;

/// The loss log inside the output directory.
pub const CSV_FILE: &str = "losses.csv";

/// The log's columns.
const HEADER: [&str; 8] = ["phase", "iteration", "lr", "rollout_len", "loss", "grad_norm", "skipped", "terms"];

/// What one iteration did.
#[derive(Debug, Clone)]
pub struct StepReport {
    /// The phase this iteration belongs to.
    pub phase: Phase,
    /// Iteration within the phase (after this step), or warm-up iterations done.
    pub iteration: u64,
    /// Iterations of this phase.
    pub phase_iterations: u64,
    /// Total energy E(x[t+1]), J (NaN in warm-up or when skipped).
    pub loss: f64,
    /// Energy terms, J.
    pub terms: Vec<(&'static str, f64)>,
    /// Global parameter-gradient norm before clipping.
    pub grad_norm: f64,
    /// Learning rate used.
    pub lr: f64,
    /// Rollout length of the current schedule.
    pub rollout_len: usize,
    /// Whether the step was skipped for a non-finite value.
    pub skipped: bool,
    /// Steps skipped so far in this phase.
    pub skipped_total: u64,
}

/// Starts an empty log at `path` (the header only).
pub(super) fn create(path: &Path) -> Result<(), TrainError> {
    let mut w = csv::Writer::from_path(path).map_err(|e| TrainError::io(path, e))?;
    w.write_record(HEADER).map_err(|e| TrainError::io(path, e))?;
    w.flush().map_err(|e| TrainError::io(path, e))
}

/// Appends the row of `r` to the log at `path`.
pub(super) fn append(path: &Path, r: &StepReport) -> Result<(), TrainError> {
    let file = std::fs::OpenOptions::new().append(true).create(true).open(path).map_err(|e| TrainError::io(path, e))?;
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(file);
    let terms: Vec<String> = r.terms.iter().map(|(n, v)| format!("{n}={v:.6e}")).collect();
    w.write_record([
        r.phase.number().to_string(),
        r.iteration.to_string(),
        format!("{:.6e}", r.lr),
        r.rollout_len.to_string(),
        format!("{:.6e}", r.loss),
        format!("{:.6e}", r.grad_norm),
        u8::from(r.skipped).to_string(),
        terms.join(";"),
    ])
    .map_err(|e| TrainError::io(path, e))?;
    w.flush().map_err(|e| TrainError::io(path, e))
}

/// Drops the rows logged after `(phase, iteration)` (a resumed run redoes them). A missing
/// log is left missing.
pub(super) fn truncate_after(path: &Path, phase: Phase, iteration: u64) -> Result<(), TrainError> {
    let Ok(mut reader) = csv::Reader::from_path(path) else { return Ok(()) };
    let mut keep = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| TrainError::io(path, e))?;
        let p = record.get(0).and_then(|p| p.parse::<u8>().ok());
        let i = record.get(1).and_then(|i| i.parse::<u64>().ok());
        if p.zip(i).is_none_or(|key| key <= (phase.number(), iteration)) {
            keep.push(record);
        }
    }
    let mut w = csv::Writer::from_path(path).map_err(|e| TrainError::io(path, e))?;
    w.write_record(HEADER).map_err(|e| TrainError::io(path, e))?;
    for record in &keep {
        w.write_record(record).map_err(|e| TrainError::io(path, e))?;
    }
    w.flush().map_err(|e| TrainError::io(path, e))
}
