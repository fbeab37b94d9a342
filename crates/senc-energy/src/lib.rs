//! senc-energy: cloth energies with analytic gradients, scene-driven assembly, and a
//! reference solver.
//!
//! Terms (see [`terms`]): StVK stretching, discrete-shell bending, inertia, gravity and
//! external acceleration, body collision and friction, SENC's self-collision (penetration
//! volume from senc-gia) with the area ablation, and the repulsive baseline. Every term
//! returns a value in joules and a gradient with respect to `x[t+1]` in f64, and none panics
//! on a degenerate triangle.
//!
//! [`EnergyModel`] assembles only the terms a scene needs (no body: no collision, friction or
//! body queries; self-collision and area weights 0, or nothing closed: no GIA), and
//! [`solver::solve`] minimises one frame's incremental potential.
//!
//! # Example
//! ```
//! use senc_energy::{EnergyConfig, EnergyModel};
//! use senc_geom::{TriMesh, Vec3};
//! let rest = TriMesh::new(
//!     vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
//!     vec![[0, 1, 2]],
//! )
//! .unwrap();
//! let mut config = EnergyConfig::default();
//! config.self_collision.weight = 0.0; // no GIA for this example
//! let model = EnergyModel::new(&rest, &config, None).unwrap();
//! let x = rest.positions();
//! let frame = model.frame(x, x, None).unwrap();
//! let b = frame.evaluate(x, None).unwrap();
//! assert_eq!(b.get("stretching"), Some(0.0));
//! ```

pub mod config;
pub mod error;
pub mod fd;
pub mod hessian;
pub mod material;
pub mod model;
pub mod rest;
pub mod scatter;
pub mod solver;
pub mod terms;

pub use config::{BendingRest, EnergyConfig};
pub use error::EnergyError;
pub use material::Material;
pub use model::{Breakdown, EnergyModel, FrameEnergy};
pub use solver::{solve, SolveReport, SolverOptions, StopReason};
