//! Typed errors of senc-energy: what was wrong and how to fix it.

use senc_geom::MeshError;
use senc_gia::GiaError;

/// Why an energy could not be built or evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnergyError {
    /// A position array has the wrong length.
    #[error(
        "{what} has {got} vertices but the garment has {expected}; pass positions with the rest mesh's vertex order"
    )]
    VertexCount {
        /// Which array.
        what: &'static str,
        /// Expected count.
        expected: usize,
        /// Count given.
        got: usize,
    },
    /// A pinned vertex index is not a garment vertex.
    #[error("pinned vertex {vertex} does not exist: the garment has {n} vertices; pin vertices of the rest mesh")]
    PinnedOutOfRange {
        /// The index given.
        vertex: usize,
        /// Number of garment vertices.
        n: usize,
    },
    /// A position is NaN or infinite.
    #[error("{what}: vertex {vertex} is not finite ({value:?}); positions must be finite metres")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// The vertex.
        vertex: usize,
        /// Its value.
        value: [f64; 3],
    },
    /// A material or config value is out of its domain.
    #[error("invalid parameter {name} = {value}: {why}")]
    InvalidParameter {
        /// Parameter name as in the config.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Its domain.
        why: &'static str,
    },
    /// The body positions do not match the body mesh, or the body mesh is unusable.
    #[error("body: {0}")]
    Body(String),
    /// Mesh operation (closure update) failed.
    #[error("mesh: {0}")]
    Mesh(#[from] MeshError),
    /// The penetration query failed.
    #[error("self-collision (senc-gia): {0}; set self_collision.weight = 0 and area.weight = 0 to run without it")]
    Gia(#[from] GiaError),
}
