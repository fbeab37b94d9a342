//! Inertia of the implicit-Euler incremental potential.

use std::sync::Arc;

use rayon::prelude::*;

use senc_geom::Vec3;

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

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let e: f64 = x
            .par_iter()
            .zip(&self.target)
            .zip(self.mass.par_iter())
            .map(|((x, t), m)| 0.5 * m * self.inv_dt2 * (x - t).norm_squared())
            .sum();
        if let Some(g) = grad {
            g.par_iter_mut()
                .zip(x)
                .zip(&self.target)
                .zip(self.mass.par_iter())
                .for_each(|(((g, x), t), m)| *g += (x - t) * (m * self.inv_dt2));
        }
        e
    }
}
