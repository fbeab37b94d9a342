//! senc-train: the two-phase autoregressive trainer, Table-1 evaluation and rollouts.
//!
//! - [`config`]: the `[train]`, `[model]`, `[energy]`, `[eval]` tables of a config file,
//!   resolved with its `extends` chain and command-line overrides.
//! - [`garment`]: a scene with its proxy body (body vertices near the garment).
//! - [`trainer`]: HOOD's schedule and SENC's two phases, checkpoints and exact resume.
//! - [`clip`]: global gradient-norm clipping.
//! - [`rollout`]: running a trained model on a motion (evaluation, simulation).
//! - [`resting`]: a network's rollout against the reference solver's (the resting case).
//! - [`eval`]: Table-1 metrics (a network's row and the reference solver's), the
//!   error-against-run-time comparison, the report files and the one-step probe.

pub mod clip;
pub mod config;
pub mod error;
pub mod eval;
pub mod garment;
pub mod metrics;
pub mod resting;
pub mod rollout;
pub mod signal;
pub mod stress;
pub mod trainer;

pub use config::{EvalConfig, ModelSection, Phase, RunConfig, TrainConfig};
pub use error::TrainError;
pub use garment::Garment;
pub use trainer::{Progress, StepReport, Trainer};
