//! The arguments that name a trained network, shared by the commands that roll one out.

use std::path::PathBuf;

use anyhow::Result;
use senc_train::eval::Method;

/// A checkpoint and the config its scene comes from.
#[derive(clap::Args)]
pub struct NetworkArgs {
    /// Checkpoint directory.
    #[arg(long)]
    pub checkpoint: PathBuf,
    /// Config (default: the checkpoint's own).
    #[arg(long)]
    pub config: Option<PathBuf>,
}

impl NetworkArgs {
    /// The checkpoint as a method on its config.
    pub fn method(&self) -> Result<Method> {
        Ok(Method::new(&self.checkpoint, self.config.as_deref())?)
    }
}
