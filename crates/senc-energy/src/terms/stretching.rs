//! StVK membrane stretching with the rest shape.

use std::sync::Arc;

use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector3};
use rayon::prelude::*;

use senc_geom::Vec3;

use crate::hessian::project_spd;
use crate::rest::{corners, RestState};
use crate::scatter::Scatter;

/// Saint Venant–Kirchhoff stretching.
///
/// Per face with rest shape matrix `Dm` (2×2, rest edges `X0 − X2`, `X1 − X2` in an
/// orthonormal basis of the rest triangle) and current `Ds = [x0 − x2, x1 − x2]` (3×2):
///
/// `F = Ds Dm⁻¹`, `G = ½(FᵀF − I)`, `ψ = μ‖G‖²_F + ½λ tr(G)²` (J/m³),
/// `E = Σ_f A_f h ψ_f` (J) with rest area `A_f` (m²) and thickness `h` (m).
///
/// Gradient: `∂E_f/∂Ds = A_f h P Dm⁻ᵀ` with `P = F(2μG + λ tr(G) I)`; the columns are the
/// gradients of `x0` and `x1`, and `x2` gets minus their sum.
///
/// Domain: every finite `x`; collapsed or inverted current triangles are fine (StVK stays
/// finite there). Zero energy and gradient exactly when each face is a rigid motion of its
/// rest shape.
#[derive(Debug, Clone)]
pub struct Stretching {
    rest: Arc<RestState>,
    scatter: Arc<Scatter<3>>,
    mu: f64,
    lambda: f64,
    thickness: f64,
}

impl Stretching {
    /// The term with Lamé parameters `mu`, `lambda` (Pa) and thickness (m).
    pub fn new(rest: Arc<RestState>, scatter: Arc<Scatter<3>>, mu: f64, lambda: f64, thickness: f64) -> Self {
        Self { rest, scatter, mu, lambda, thickness }
    }

    fn face(&self, f: usize, x: &[Vec3]) -> (f64, Matrix3x2<f64>, Matrix3x2<f64>) {
        let [p0, p1, p2] = corners(x, &self.rest.faces[f]);
        let ds = Matrix3x2::from_columns(&[p0 - p2, p1 - p2]);
        let f_ = ds * self.rest.dm_inv[f];
        let g = 0.5 * (f_.transpose() * f_ - Matrix2::identity());
        let tr = g.trace();
        let psi = self.mu * g.norm_squared() + 0.5 * self.lambda * tr * tr;
        let s = 2.0 * self.mu * g + self.lambda * tr * Matrix2::identity();
        let scale = self.rest.face_area[f] * self.thickness;
        let h = scale * f_ * s * self.rest.dm_inv[f].transpose();
        (scale * psi, h, f_)
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        let n = self.rest.faces.len();
        match grad {
            None => (0..n).into_par_iter().map(|f| self.face(f, x).0).sum(),
            Some(grad) => {
                let (e, per): (Vec<f64>, Vec<[Vec3; 3]>) = (0..n)
                    .into_par_iter()
                    .map(|f| {
                        let (e, h, _) = self.face(f, x);
                        let (g0, g1) = (h.column(0).into_owned(), h.column(1).into_owned());
                        (e, [g0, g1, -g0 - g1])
                    })
                    .unzip();
                self.scatter.add_to(&per, 1.0, grad);
                e.iter().sum()
            }
        }
    }

    /// Per-face Hessians (exact, then projected to positive semi-definite), as 3×3 blocks.
    pub fn hessians(&self, x: &[Vec3]) -> Vec<[[Matrix3<f64>; 3]; 3]> {
        (0..self.rest.faces.len())
            .into_par_iter()
            .map(|f| {
                let (_, _, f_) = self.face(f, x);
                let dm_inv = self.rest.dm_inv[f];
                let scale = self.rest.face_area[f] * self.thickness;
                let g = 0.5 * (f_.transpose() * f_ - Matrix2::identity());
                let s = 2.0 * self.mu * g + self.lambda * g.trace() * Matrix2::identity();
                let mut h = [[Matrix3::zeros(); 3]; 3];
                for k in 0..3 {
                    for a in 0..3 {
                        let unit = Vector3::ith(a, 1.0);
                        let d_ds = match k {
                            0 => Matrix3x2::from_columns(&[unit, Vector3::zeros()]),
                            1 => Matrix3x2::from_columns(&[Vector3::zeros(), unit]),
                            _ => Matrix3x2::from_columns(&[-unit, -unit]),
                        };
                        let d_f = d_ds * dm_inv;
                        let d_g = 0.5 * (d_f.transpose() * f_ + f_.transpose() * d_f);
                        let d_s = 2.0 * self.mu * d_g + self.lambda * d_g.trace() * Matrix2::identity();
                        let d_h = scale * (d_f * s + f_ * d_s) * dm_inv.transpose();
                        let cols = [d_h.column(0).into_owned(), d_h.column(1).into_owned()];
                        let rows = [cols[0], cols[1], -cols[0] - cols[1]];
                        for (j, r) in rows.iter().enumerate() {
                            // Column (k, a) of the Hessian, rows of vertex j.
                            h[j][k].set_column(a, r);
                        }
                    }
                }
                project_spd(&mut h);
                h
            })
            .collect()
    }
}
