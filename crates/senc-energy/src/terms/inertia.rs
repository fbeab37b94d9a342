//! Inertia of the implicit-Euler incremental potential.

use std::sync::Arc;

use rayon::prelude::*;

use senc_geom::Vec3;

use crate::scatter::{ordered_sum, VERTEX_CHUNK};

/// Inertia: `E = Σ_i m_i ‖x_i − x̃_i‖² / (2Δt²)` (J) with the lumped mass
/// `m_i = ρ Σ_{f∋i} A_f / 3` (kg) and the inertial target `x̃ = 2x[t] − x[t−1]` (m).
/// Gradient `m_i (x_i − x̃_i) / Δt²`; Hessian `m_i / Δt² I`. Domain: every finite `x`.
#[derive(Debug, Clone)]
pub struct Inertia {
    mass: Arc<Vec<f64>>,
    target: Vec<Vec3>,
    inv_dt2: f64,
}

impl Inertia {
    /// The term for masses `mass` (kg), states `x_cur = x[t]`, `x_prev = x[t−1]` and step
    /// `dt` (s).
    pub fn new(mass: Arc<Vec<f64>>, x_cur: &[Vec3], x_prev: &[Vec3], dt: f64) -> Self {
        let target = x_cur.iter().zip(x_prev).map(|(c, p)| 2.0 * c - p).collect();
        Self { mass, target, inv_dt2: 1.0 / (dt * dt) }
    }

    /// The inertial target `x̃`.
    pub fn target(&self) -> &[Vec3] {
        &self.target
    }

    /// `m_i / Δt²` per vertex (the Hessian's diagonal), kg/s².
    pub fn stiffness(&self, i: usize) -> f64 {
        self.mass[i] * self.inv_dt2
    }

    /// Energy (J) and gradient (N) of vertex `i` at `x`.
    #[inline(always)]
    pub fn vertex(&self, i: usize, x: &Vec3) -> (f64, Vec3) {
        let k = self.mass[i] * self.inv_dt2;
        let d = x - self.target[i];
        (0.5 * k * d.norm_squared(), d * k)
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        per_vertex_eval(x, grad, |i, x| self.vertex(i, x))
    }
}

/// Sums a per-vertex term `f(i, x_i) = (E_i, ∂E_i/∂x_i)` over vertices in fixed chunks (the
/// energy in chunk order) and adds the gradients into `grad` when given.
pub(crate) fn per_vertex_eval(
    x: &[Vec3],
    grad: Option<&mut [Vec3]>,
    f: impl Fn(usize, &Vec3) -> (f64, Vec3) + Sync,
) -> f64 {
    let partials: Vec<f64> = match grad {
        None => x
            .par_chunks(VERTEX_CHUNK)
            .enumerate()
            .map(|(c, xs)| {
                let mut e = 0.0;
                for (j, x) in xs.iter().enumerate() {
                    e += f(c * VERTEX_CHUNK + j, x).0;
                }
                e
            })
            .collect(),
        Some(g) => g
            .par_chunks_mut(VERTEX_CHUNK)
            .zip(x.par_chunks(VERTEX_CHUNK))
            .enumerate()
            .map(|(c, (gs, xs))| {
                let mut e = 0.0;
                for (j, (g, x)) in gs.iter_mut().zip(xs).enumerate() {
                    let (ei, gi) = f(c * VERTEX_CHUNK + j, x);
                    e += ei;
                    *g += gi;
                }
                e
            })
            .collect(),
    };
    ordered_sum(partials)
}
