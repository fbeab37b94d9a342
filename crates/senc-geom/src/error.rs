//! Typed errors for mesh construction and I/O. Each variant names the offending element and
//! says how to fix the input.

use std::path::PathBuf;

/// Why a mesh was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// A coordinate is NaN or infinite.
    #[error(
        "vertex {vertex} has a non-finite coordinate {value:?}; remove or repair the vertex before building the mesh"
    )]
    NonFiniteVertex {
        /// Index of the vertex.
        vertex: usize,
        /// Its coordinates.
        value: [f64; 3],
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the mesh has only {n_vertices} vertices; check the face indices (OBJ indices are 1-based)")]
    IndexOutOfRange {
        /// Index of the face.
        face: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} repeats a vertex: {indices:?}; drop collapsed faces before building the mesh")]
    RepeatedIndex {
        /// Index of the face.
        face: usize,
        /// Its vertex indices.
        indices: [u32; 3],
    },
    /// A face has (numerically) zero area.
    #[error("face {face} {indices:?} has zero area (its vertices are collinear or coincide); remove it or move its vertices apart")]
    ZeroAreaFace {
        /// Index of the face.
        face: usize,
        /// Its vertex indices.
        indices: [u32; 3],
    },
    /// More than two faces share an edge.
    #[error("edge ({a}, {b}) is shared by {n_faces} faces (first ones: {faces:?}); senc needs a manifold mesh, split the edge or remove a face")]
    NonManifoldEdge {
        /// First vertex of the edge (smaller index).
        a: u32,
        /// Second vertex of the edge.
        b: u32,
        /// Number of faces on the edge.
        n_faces: usize,
        /// Up to three of those faces.
        faces: Vec<usize>,
    },
    /// Two faces on one edge traverse it in the same direction (inconsistent winding).
    #[error("faces {face_a} and {face_b} traverse edge ({a}, {b}) in the same direction; orient the mesh consistently (flip one side)")]
    InconsistentOrientation {
        /// First vertex of the edge.
        a: u32,
        /// Second vertex of the edge.
        b: u32,
        /// One face.
        face_a: usize,
        /// The other face.
        face_b: usize,
    },
    /// A mesh with no faces.
    #[error("the mesh has no faces")]
    Empty,
    /// The point-query structure (parry's BVH with pseudo-normals) refused the surface.
    #[error("the surface cannot be prepared for point queries: {0}; give a consistently oriented triangle mesh")]
    QueryStructure(String),
    /// New positions with a different vertex count.
    #[error("got {got} positions for a mesh of {expected} vertices")]
    PositionCount {
        /// Vertices in the mesh.
        expected: usize,
        /// Positions given.
        got: usize,
    },
    /// A hole index that does not exist.
    #[error("hole {index} does not exist: the mesh has {n_loops} boundary loops (numbered 0..{n_loops})")]
    NoSuchHole {
        /// The index asked for.
        index: usize,
        /// Number of boundary loops.
        n_loops: usize,
    },
    /// A file could not be read or written.
    #[error("cannot access {path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A file could be read but not parsed.
    #[error("cannot parse {path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}
