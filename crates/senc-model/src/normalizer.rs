//! Running mean / standard deviation normalisers for the network's inputs and output, in
//! f64, saved with every checkpoint (HOOD collects them during the first training
//! iterations and then freezes them).

use serde::{Deserialize, Serialize};

use crate::graph::{EdgeType, GraphInputs, EDGE_FEATURES, NODE_FEATURES, N_EDGE_TYPES};
use crate::ModelError;

/// Floor on the standard deviation, so that a constant column (a one-hot type on a body-less
/// scene) normalises to 0 instead of dividing by 0. HOOD uses 1e-8.
pub const STD_EPSILON: f64 = 1e-8;

/// Per-column running statistics over the rows seen so far.
///
/// `mean_k = Σ x_k / n`, `std_k = max(sqrt(Σ x_k² / n − mean_k²), STD_EPSILON)`; before any
/// row is seen the normaliser is the identity (mean 0, std 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunningStats {
    count: u64,
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

impl RunningStats {
    /// Empty statistics over `width` columns.
    pub fn new(width: usize) -> Self {
        Self { count: 0, sum: vec![0.0; width], sum_sq: vec![0.0; width] }
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.sum.len()
    }

    /// Number of rows accumulated.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Adds the rows of a row-major `[n, width]` array. Rows with a non-finite entry are
    /// skipped, so one diverged frame cannot poison the statistics.
    pub fn update(&mut self, rows: &[f64]) {
        let w = self.width();
        if w == 0 {
            return;
        }
        for row in rows.chunks_exact(w) {
            if !row.iter().all(|v| v.is_finite()) {
                continue;
            }
            self.count += 1;
            for k in 0..w {
                self.sum[k] += row[k];
                self.sum_sq[k] += row[k] * row[k];
            }
        }
    }

    /// Column means (0 before any update).
    pub fn mean(&self) -> Vec<f64> {
        if self.count == 0 {
            return vec![0.0; self.width()];
        }
        let n = self.count as f64;
        self.sum.iter().map(|s| s / n).collect()
    }

    /// Column standard deviations, floored at [`STD_EPSILON`] (1 before any update).
    pub fn std(&self) -> Vec<f64> {
        if self.count == 0 {
            return vec![1.0; self.width()];
        }
        let n = self.count as f64;
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                let mean = s / n;
                (q / n - mean * mean).max(0.0).sqrt().max(STD_EPSILON)
            })
            .collect()
    }

    /// `(x − mean) / std`, in place, on a row-major `[n, width]` array.
    pub fn normalize(&self, rows: &mut [f64]) {
        let (mean, std) = (self.mean(), self.std());
        let w = self.width();
        if w == 0 {
            return;
        }
        for row in rows.chunks_exact_mut(w) {
            for k in 0..w {
                row[k] = (row[k] - mean[k]) / std[k];
            }
        }
    }

    fn check(&self, what: String, expected: usize) -> Result<(), ModelError> {
        if self.width() != expected || self.sum_sq.len() != expected {
            return Err(ModelError::NormalizerWidth { what, got: self.width(), expected });
        }
        Ok(())
    }
}

/// All normalisers of the model: node features, each edge type's features, and the output
/// acceleration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalizers {
    /// Node features, [`NODE_FEATURES`] columns (more with elastic features).
    pub node: RunningStats,
    /// Edge features per [`EdgeType::index`] (mesh, body, self, coarse levels),
    /// [`EDGE_FEATURES`] columns each.
    pub edges: Vec<RunningStats>,
    /// The output, 3 columns: the network's acceleration term `Δt² a` in metres. Its mean and
    /// std de-normalise the decoder's output. The trainer feeds it (for example with the
    /// inertia-free step `Δt² (g + a_ext)` or the reference solver's answer) during warm-up;
    /// until then it is the identity.
    pub output: RunningStats,
}

impl Default for Normalizers {
    /// Identity normalisers for a model without coarse levels.
    fn default() -> Self {
        Self::new(0, NODE_FEATURES)
    }
}

impl Normalizers {
    /// Identity normalisers for a model with `coarse_levels` coarse levels and
    /// `node_features` node feature columns.
    pub fn new(coarse_levels: usize, node_features: usize) -> Self {
        Self {
            node: RunningStats::new(node_features),
            edges: (0..N_EDGE_TYPES + coarse_levels).map(|_| RunningStats::new(EDGE_FEATURES)).collect(),
            output: RunningStats::new(3),
        }
    }

    /// Accumulates the node and edge features of one graph (warm-up).
    pub fn update_inputs(&mut self, graph: &GraphInputs) {
        self.node.update(&graph.nodes);
        for (k, stats) in self.edges.iter_mut().enumerate() {
            stats.update(&graph.edge_set(EdgeType::from_index(k)).features);
        }
    }

    /// Checks every width and the number of edge normalisers (after loading a checkpoint).
    pub fn validate(&self, coarse_levels: usize, node_features: usize) -> Result<(), ModelError> {
        self.node.check("node".into(), node_features)?;
        if self.edges.len() != N_EDGE_TYPES + coarse_levels {
            return Err(ModelError::NormalizerWidth {
                what: "edge normaliser count".into(),
                got: self.edges.len(),
                expected: N_EDGE_TYPES + coarse_levels,
            });
        }
        for (k, stats) in self.edges.iter().enumerate() {
            stats.check(EdgeType::from_index(k).name(), EDGE_FEATURES)?;
        }
        self.output.check("output".into(), 3)
    }
}
