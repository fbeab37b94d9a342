//! senc-geom: the bottom layer of senc. Triangle meshes with validated topology, OBJ input
//! and output, hole closure, exact self-intersection detection, and cutting along
//! intersection segments.
//!
//! Conventions: positions are `f64` metres, faces are counter-clockwise `[u32; 3]` seen from
//! the side the normal `(p1 - p0) × (p2 - p0)` points to. Nothing here knows about burn,
//! energies or training.
//!
//! # Example
//! ```
//! use senc_geom::{TriMesh, Vec3};
//! let mesh = TriMesh::new(
//!     vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
//!     vec![[0, 1, 2]],
//! )
//! .unwrap();
//! assert_eq!(mesh.topology().boundary_loops().len(), 1);
//! ```

pub mod body_query;
pub mod closure;
pub mod cut;
pub mod error;
pub mod gather;
pub mod intersect;
pub mod mesh;
pub mod neighbors;
pub mod obj;
pub mod predicates;
pub mod remesh;
pub mod repair;
pub mod topology;

pub use body_query::{BodyQuery, Closest, NearestFaces};
pub use closure::{close_holes, Closure, HoleSelection};
pub use error::MeshError;
pub use mesh::{vertex_normals, TriMesh};
pub use topology::Topology;

// The test meshes live in senc-testmesh, which depends on this crate; the unit tests here
// compile its source as a module, with `senc_geom` naming this crate.
#[cfg(test)]
extern crate self as senc_geom;
#[cfg(test)]
#[path = "../../senc-testmesh/src/lib.rs"]
#[allow(dead_code, unused_imports)]
mod shapes;

/// The one vector type of the geometry layers: f64 metres.
pub type Vec3 = nalgebra::Vector3<f64>;
