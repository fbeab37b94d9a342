//! The typed errors of senc-model: what was wrong with the input and how to fix it.

use std::path::PathBuf;

/// Everything that can go wrong when building a graph, converting it, or reading and writing
/// a checkpoint. No function of this crate panics on user input.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// A per-vertex array does not have one entry per vertex.
    #[error("{what} has {got} entries but the mesh has {expected} vertices; pass one entry per vertex")]
    LengthMismatch {
        /// Which array was wrong (for example "cloth x[t-1]").
        what: &'static str,
        /// Its length.
        got: usize,
        /// The vertex count it must match.
        expected: usize,
    },
    /// A position, material parameter or acceleration is NaN or infinite.
    #[error("{what} is not finite (entry {index}); the simulation diverged or the input is corrupt")]
    NotFinite {
        /// Which input.
        what: &'static str,
        /// The first offending entry.
        index: usize,
    },
    /// A material parameter or the time step is outside its domain.
    #[error("{what} = {value} must be positive and finite")]
    BadMaterial {
        /// The parameter name.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A body face indexes past the body's vertex array.
    #[error("body face {face} references vertex {vertex} but the body has {n_vertices} vertices")]
    BadBodyFace {
        /// The face index.
        face: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Body vertex count.
        n_vertices: usize,
    },
    /// Normaliser statistics of the wrong width (a corrupt or foreign checkpoint).
    #[error("normaliser `{what}` has width {got}, the model expects {expected}; the checkpoint belongs to another model version")]
    NormalizerWidth {
        /// Which normaliser.
        what: String,
        /// Stored width.
        got: usize,
        /// Expected width.
        expected: usize,
    },
    /// A gradient passed to the surrogate loss does not match the prediction's shape.
    #[error("gradient has {got} rows but the prediction has {expected}; pass dE/dx for every cloth vertex")]
    GradientShape {
        /// Rows given.
        got: usize,
        /// Rows expected.
        expected: usize,
    },
    /// The garment's elastic model (the elastic-acceleration node features) could not be
    /// built or evaluated.
    #[error("elastic forces of the garment: {0}")]
    Elastic(#[from] senc_energy::EnergyError),
    /// A tensor read back as points does not have 3 columns.
    #[error("tensor has {columns} columns; points need exactly 3")]
    NotPoints {
        /// Its column count.
        columns: usize,
    },
    /// Reading or writing a checkpoint file failed.
    #[error("checkpoint file {path}: {message}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// A device name that is unknown or whose backend this build leaves out.
    #[error("device {name:?}: {message}")]
    Device {
        /// The name given.
        name: String,
        /// Why it cannot be used and how to fix it.
        message: String,
    },
}
