//! The repulsive baseline from the SENC paper.

use std::sync::Arc;

use senc_geom::neighbors::radius_pairs;
use senc_geom::{Topology, Vec3};

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
    pub fn eval(&self, x: &[Vec3], mut grad: Option<&mut [Vec3]>) -> f64 {
        let tau2 = self.threshold * self.threshold;
        let floor = 1e-12 * tau2;
        let mut e = 0.0;
        for [i, j] in self.pairs(x) {
            let d = x[i as usize] - x[j as usize];
            let d2 = d.norm_squared();
            e -= self.weight * (d2.max(floor) / tau2).ln();
            if let Some(g) = grad.as_deref_mut() {
                if d2 > floor {
                    let gi = d * (-2.0 * self.weight / d2);
                    g[i as usize] += gi;
                    g[j as usize] -= gi;
                }
            }
        }
        e
    }
}
