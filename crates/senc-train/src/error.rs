//! [`TrainError`]: everything that can go wrong while training, evaluating or simulating.

use std::path::PathBuf;

/// Errors of senc-train. Each names what was wrong and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The config file is unreadable or has a bad `[train]`, `[model]` or `[energy]` table.
    #[error("config {path}: {message}")]
    Config {
        /// The config file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// A file could not be read or written.
    #[error("cannot access {path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A checkpoint directory is missing a file or holds an incompatible state.
    #[error(
        "checkpoint {path}: {message}; train again or point --checkpoint at a directory written by `cargo xtask train`"
    )]
    Checkpoint {
        /// The checkpoint directory or file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// Scene loading failed.
    #[error(transparent)]
    Scene(#[from] senc_scene::SceneError),
    /// An energy could not be built or evaluated.
    #[error(transparent)]
    Energy(#[from] senc_energy::EnergyError),
    /// The network or its graph failed.
    #[error(transparent)]
    Model(#[from] senc_model::ModelError),
    /// A mesh operation failed.
    #[error(transparent)]
    Mesh(#[from] senc_geom::MeshError),
    /// Penetration volume failed.
    #[error(transparent)]
    Gia(#[from] senc_gia::GiaError),
    /// A rollout turned non-finite; `partial` holds the frames before it.
    #[error("the rollout diverged (non-finite positions) at frame {frame}")]
    Diverged {
        /// The first non-finite frame.
        frame: usize,
        /// The rollout up to the frame before.
        partial: Box<crate::rollout::Rollout>,
    },
    /// A request that cannot be served (empty motion list, motion too short, ...).
    #[error("{0}")]
    Invalid(String),
}

impl TrainError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, e: impl ToString) -> Self {
        Self::Io { path: path.into(), message: e.to_string() }
    }
}
