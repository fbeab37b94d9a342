//! Checkpoints: a directory holding the weights in burn's own format (`weights.bpk`, written
//! by `save_file`) and everything of ours in MessagePack beside them (`model.msgpack`: model
//! config, graph config, normalisers), so that loading rebuilds exactly what was saved.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::tensor::Device;
use serde::{Deserialize, Serialize};

use crate::graph::GraphConfig;
use crate::model::Model;
use crate::network::ModelConfig;
use crate::normalizer::Normalizers;
use crate::ModelError;

/// File name of the weights inside a checkpoint directory.
pub const WEIGHTS_FILE: &str = "weights.bpk";
/// File name of the MessagePack metadata inside a checkpoint directory.
pub const META_FILE: &str = "model.msgpack";
/// Version of [`META_FILE`]'s layout and of the output's meaning; bumped when either
/// changes (2: the network outputs an acceleration, m/s², not a displacement).
pub const META_VERSION: u32 = 2;

#[derive(Serialize, Deserialize)]
struct Meta {
    version: u32,
    config: ModelConfig,
    graph: GraphConfig,
    normalizers: Normalizers,
}

fn err(path: &Path, message: impl ToString) -> ModelError {
    ModelError::Checkpoint { path: path.to_path_buf(), message: message.to_string() }
}

impl Model {
    /// Writes the checkpoint directory `dir` (created if missing; existing files replaced).
    pub fn save(&self, dir: &Path) -> Result<(), ModelError> {
        std::fs::create_dir_all(dir).map_err(|e| err(dir, e))?;
        let meta = Meta {
            version: META_VERSION,
            config: self.config.clone(),
            graph: self.graph,
            normalizers: self.normalizers.clone(),
        };
        let meta_path = dir.join(META_FILE);
        let bytes = rmp_serde::to_vec_named(&meta).map_err(|e| err(&meta_path, e))?;
        std::fs::write(&meta_path, bytes).map_err(|e| err(&meta_path, e))?;
        let weights: PathBuf = dir.join(WEIGHTS_FILE);
        self.network.clone().save_file(&weights).map_err(|e| err(&weights, format!("{e:?}")))
    }

    /// Reads a checkpoint directory onto `device` (plain or autodiff).
    pub fn load(dir: &Path, device: &Device) -> Result<Self, ModelError> {
        let meta_path = dir.join(META_FILE);
        let bytes = std::fs::read(&meta_path).map_err(|e| err(&meta_path, e))?;
        let meta: Meta = rmp_serde::from_slice(&bytes).map_err(|e| err(&meta_path, e))?;
        if meta.version != META_VERSION {
            return Err(err(
                &meta_path,
                format!("layout version {} but this build reads version {META_VERSION}", meta.version),
            ));
        }
        meta.normalizers.validate(meta.config.coarse_levels, meta.graph.node_features())?;
        let weights = dir.join(WEIGHTS_FILE);
        let network = crate::model::init_network(&meta.config, meta.graph.node_features(), None, device)
            .try_load_file(&weights)
            .map_err(|e| err(&weights, format!("{e:?}")))?;
        Ok(Model {
            network,
            config: meta.config,
            graph: meta.graph,
            normalizers: meta.normalizers,
            device: device.clone(),
        })
    }
}
