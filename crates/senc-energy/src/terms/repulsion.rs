//! The repulsive baseline from the SENC paper.

use std::sync::Arc;

use rayon::prelude::*;

use senc_geom::neighbors::radius_pairs;
use senc_geom::{Topology, Vec3};

/// Candidate pairs per parallel task.
const PAIR_CHUNK: usize = 2048;

/// A pair and the gradient of its term at its first vertex (minus at the second), N.
type PairForce = ([u32; 2], Vec3);

/// Repulsion: `E = −w Σ_{(i,j)} log(‖x_i − x_j‖² / τ²)` (J) over vertex pairs closer
/// than τ (m) that share no mesh edge; the pairs are found at the evaluated `x`.
///
/// The paper writes `−Σ log(‖x_i − x_j‖²)`; dividing by τ² only shifts each pair by a
/// constant, leaves the gradient unchanged and makes the energy continuous (zero) as a pair
/// crosses τ. Gradient: `∂E/∂x_i = −2w (x_i − x_j) / ‖x_i − x_j‖²`.
///
/// Domain: every finite `x`; coincident vertices are floored at `‖x_i − x_j‖ = 1e-6 τ` so
/// the value stays finite (the gradient is then zero for that pair).
#[derive(Debug, Clone)]
pub struct Repulsion {
    topology: Arc<Topology>,
    weight: f64,
    threshold: f64,
}

impl Repulsion {
    /// The term with weight `w` (J) and threshold `τ` (m).
    pub fn new(topology: Arc<Topology>, weight: f64, threshold: f64) -> Self {
        Self { topology, weight, threshold }
    }

    /// The non-adjacent pairs closer than τ at `x`.
    pub fn pairs(&self, x: &[Vec3]) -> Vec<[u32; 2]> {
        let mut p = radius_pairs(x, self.threshold);
        p.retain(|&[i, j]| self.topology.find_edge(i, j).is_none());
        p
    }

    /// Energy (J), adding the gradient into `grad` when given.
    ///
    /// The candidate pairs come from the parallel hash grid; the edge filter, the logarithms
    /// and the per-pair gradients run in parallel over fixed chunks of pairs, and the chunk
    /// results are reduced in chunk order (energy) and added pair by pair in pair order
    /// (gradient), so the result does not depend on thread scheduling.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let tau2 = self.threshold * self.threshold;
        let floor = 1e-12 * tau2;
        let with_grad = grad.is_some();
        let candidates = radius_pairs(x, self.threshold);
        let chunks: Vec<(f64, Vec<PairForce>)> = candidates
            .par_chunks(PAIR_CHUNK)
            .map(|chunk| {
                let mut e = 0.0;
                let mut forces = Vec::new();
                for &[i, j] in chunk {
                    if self.topology.find_edge(i, j).is_some() {
                        continue;
                    }
                    let d = x[i as usize] - x[j as usize];
                    let d2 = d.norm_squared();
                    e -= self.weight * (d2.max(floor) / tau2).ln();
                    if with_grad && d2 > floor {
                        forces.push(([i, j], d * (-2.0 * self.weight / d2)));
                    }
                }
                (e, forces)
            })
            .collect();
        if let Some(g) = grad {
            for (_, forces) in &chunks {
                for &([i, j], gi) in forces {
                    g[i as usize] += gi;
                    g[j as usize] -= gi;
                }
            }
        }
        chunks.iter().map(|c| c.0).sum()
    }
}
