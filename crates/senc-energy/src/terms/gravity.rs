//! Uniform acceleration fields: gravity and the external force.

use std::sync::Arc;

use senc_geom::Vec3;

use crate::terms::inertia::per_vertex_eval;

/// Potential of a uniform acceleration `a` (m/s²): `E = −Σ_i m_i a · x_i` (J), gradient
/// `−m_i a` (N), Hessian zero. Used twice: for gravity `g` and for the external
/// acceleration `a_ext`. Domain: every finite `x`.
#[derive(Debug, Clone)]
pub struct UniformField {
    mass: Arc<Vec<f64>>,
    acceleration: Vec3,
}

impl UniformField {
    /// The field with masses `mass` (kg) and acceleration (m/s²).
    pub fn new(mass: Arc<Vec<f64>>, acceleration: Vec3) -> Self {
        Self { mass, acceleration }
    }

    /// Energy (J) and gradient (N) of vertex `i` at `x`.
    #[inline(always)]
    pub fn vertex(&self, i: usize, x: &Vec3) -> (f64, Vec3) {
        let m = self.mass[i];
        (-m * self.acceleration.dot(x), self.acceleration * -m)
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        per_vertex_eval(x, grad, |i, x| self.vertex(i, x))
    }
}
