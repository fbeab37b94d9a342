//! senc-model: the self-collision-aware graph neural network of SENC (section 3.1), in burn.
//!
//! Data flow, one frame:
//! 1. [`GraphInputs::build`] turns f64 state ([`FrameState`]: cloth `x[t−1]`, `x[t]`, rest
//!    mesh, material, `g + a_ext`, optional body `b[t]`, `b[t+1]`) into a graph with raw f64
//!    features (module [`graph`]).
//! 2. [`Normalizers`] hold running mean/std per feature; the trainer calls
//!    [`Normalizers::update_inputs`] during warm-up.
//! 3. [`GraphTensors::new`] normalises and casts to f32 on the device: the only f64 → f32
//!    conversion (module [`convert`], which also converts back).
//! 4. [`Model::forward`] runs the [`Network`] and returns `Δt² a` per cloth vertex,
//!    `[n_cloth, 3]`.
//! 5. Training: the energies' gradient `g = ∂E/∂x[t+1]` comes back from f64 code and
//!    [`surrogate_backward`] backpropagates `Σ x ⊙ g`.
//!
//! Backends: the CPU `flex` backend (`Device::flex()`, `.autodiff()` for training) is always
//! built; the Cargo feature `gpu` adds wgpu/Vulkan ([`device_named`] picks a device by name).
//!
//! # Example
//! ```
//! use senc_model::{FrameState, GraphConfig, Material, Model, ModelConfig};
//! use senc_geom::{TriMesh, Vec3};
//! use burn::tensor::Device;
//!
//! let rest = TriMesh::new(
//!     vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.0, 0.1, 0.0)],
//!     vec![[0, 1, 2]],
//! )
//! .unwrap();
//! let x = rest.positions().to_vec();
//! let frame = FrameState {
//!     rest: &rest, prev: &x, curr: &x, material: Material::default(),
//!     accel: Vec3::new(0.0, -9.81, 0.0), dt: 1.0 / 30.0, body: None, pinned: &[],
//! };
//! let config = ModelConfig::small_cpu().with_blocks(1);
//! let model = Model::new(config, GraphConfig::default(), 7, &Device::flex());
//! let next = model.step(&frame).unwrap();
//! assert_eq!(next.len(), 3);
//! ```

pub mod bench;
pub mod checkpoint;
pub mod convert;
pub mod device;
pub mod error;
pub mod fused;
pub mod graph;
pub mod layer_norm;
pub mod model;
pub mod network;
pub mod normalizer;
pub mod surrogate;
pub mod synthetic;

pub use convert::{tensor_to_vec3, vec3_tensor, GraphTensors, HostGraph};
pub use device::device_named;
pub use error::ModelError;
pub use fused::FusedNetwork;
pub use graph::{BodyState, EdgeSet, EdgeType, FrameState, GraphConfig, GraphInputs, Material, SelfEdges};
pub use model::{Model, Stepper};
pub use network::{ModelConfig, Network};
pub use normalizer::{Normalizers, RunningStats};
pub use surrogate::{surrogate_backward, surrogate_loss};

/// burn, re-exported so that dependants use exactly this crate's version and features.
pub use burn;
