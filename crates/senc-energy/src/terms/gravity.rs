//! Uniform acceleration fields: gravity and the external force.

use std::sync::Arc;

use rayon::prelude::*;

use senc_geom::Vec3;

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

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let a = self.acceleration;
        let e: f64 = x.par_iter().zip(self.mass.par_iter()).map(|(x, m)| -m * a.dot(x)).sum();
        if let Some(g) = grad {
            g.par_iter_mut().zip(self.mass.par_iter()).for_each(|(g, m)| *g -= a * *m);
        }
        e
    }
}
