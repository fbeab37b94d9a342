//! StVK membrane stretching with the rest shape.

use std::sync::Arc;

use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector3};
use rayon::prelude::*;

use senc_geom::Vec3;

use crate::hessian::project_spd_translation_invariant;
use crate::rest::RestState;
use crate::scatter::{ordered_sum, Scatter, ELEMENT_CHUNK};

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
    scatter: Arc<Scatter<3>>,
    /// Per-face constants in one flat array (struct of the data each face needs).
    data: Vec<FaceData>,
    mu: f64,
    lambda: f64,
}

/// What one face needs, contiguous: its vertices, `Dm⁻¹` (column-major `[i00, i10, i01,
/// i11]`) and `A_f h` (m³).
#[derive(Debug, Clone, Copy)]
struct FaceData {
    vertices: [u32; 3],
    dm_inv: [f64; 4],
    scale: f64,
}

impl Stretching {
    /// The term with Lamé parameters `mu`, `lambda` (Pa) and thickness (m).
    pub fn new(rest: Arc<RestState>, scatter: Arc<Scatter<3>>, mu: f64, lambda: f64, thickness: f64) -> Self {
        let data = rest
            .faces
            .iter()
            .zip(&rest.dm_inv)
            .zip(&rest.face_area)
            .map(|((f, d), a)| FaceData {
                vertices: *f,
                dm_inv: [d[(0, 0)], d[(1, 0)], d[(0, 1)], d[(1, 1)]],
                scale: a * thickness,
            })
            .collect();
        Self { scatter, data, mu, lambda }
    }

    /// `F`'s columns and the Green strain `G` (`[g00, g01, g11]`) of a face.
    #[inline(always)]
    fn strain(fd: &FaceData, x: &[Vec3]) -> (Vec3, Vec3, [f64; 3]) {
        let [i0, i1, i2] = fd.vertices.map(|i| i as usize);
        let p2 = x[i2];
        let (d0, d1) = (x[i0] - p2, x[i1] - p2);
        let [a00, a10, a01, a11] = fd.dm_inv;
        let f0 = d0 * a00 + d1 * a10;
        let f1 = d0 * a01 + d1 * a11;
        let g = [0.5 * (f0.dot(&f0) - 1.0), 0.5 * f0.dot(&f1), 0.5 * (f1.dot(&f1) - 1.0)];
        (f0, f1, g)
    }

    #[inline(always)]
    fn psi(&self, g: &[f64; 3]) -> f64 {
        let tr = g[0] + g[2];
        self.mu * (g[0] * g[0] + 2.0 * g[1] * g[1] + g[2] * g[2]) + 0.5 * self.lambda * tr * tr
    }

    /// Energy of one face (J).
    #[inline(always)]
    fn face_energy(&self, fd: &FaceData, x: &[Vec3]) -> f64 {
        let (_, _, g) = Self::strain(fd, x);
        fd.scale * self.psi(&g)
    }

    /// Energy of one face (J) and the gradients of its first two corners (the third is minus
    /// their sum).
    #[inline(always)]
    fn face_gradient(&self, fd: &FaceData, x: &[Vec3]) -> (f64, Vec3, Vec3) {
        let (f0, f1, g) = Self::strain(fd, x);
        let e = fd.scale * self.psi(&g);
        let tr = g[0] + g[2];
        let (m2, lt) = (2.0 * self.mu, self.lambda * tr);
        let (s00, s01, s11) = (m2 * g[0] + lt, m2 * g[1], m2 * g[2] + lt);
        // P = F S, then ∂E/∂Ds = A h P Dm⁻ᵀ.
        let p0 = (f0 * s00 + f1 * s01) * fd.scale;
        let p1 = (f0 * s01 + f1 * s11) * fd.scale;
        let [a00, a10, a01, a11] = fd.dm_inv;
        (e, p0 * a00 + p1 * a01, p0 * a10 + p1 * a11)
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.data.len()
    }

    /// Energy (J) with each face's corner gradients written to `out` (`3 × n_faces` slots,
    /// face-major). Parallel over fixed chunks of faces; the energy is summed in chunk order.
    pub fn element_gradients(&self, x: &[Vec3], out: &mut [Vec3]) -> f64 {
        assert_eq!(out.len(), 3 * self.data.len(), "stretching gradient buffer has the wrong length");
        ordered_sum(
            out.par_chunks_mut(3 * ELEMENT_CHUNK)
                .zip(self.data.par_chunks(ELEMENT_CHUNK))
                .map(|(out, data)| {
                    let mut e = 0.0;
                    for (o, fd) in out.chunks_exact_mut(3).zip(data) {
                        let (ef, g0, g1) = self.face_gradient(fd, x);
                        o[0] = g0;
                        o[1] = g1;
                        o[2] = -g0 - g1;
                        e += ef;
                    }
                    e
                })
                .collect(),
        )
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        match grad {
            None => ordered_sum(
                self.data
                    .par_chunks(ELEMENT_CHUNK)
                    .map(|data| data.iter().map(|fd| self.face_energy(fd, x)).sum())
                    .collect(),
            ),
            Some(grad) => {
                let mut per = vec![Vec3::zeros(); 3 * self.data.len()];
                let e = self.element_gradients(x, &mut per);
                self.scatter.add_flat(&per, 1.0, grad);
                e
            }
        }
    }

    /// Per-face Hessians (exact, then projected to positive semi-definite), as 3×3 blocks.
    pub fn hessians(&self, x: &[Vec3]) -> Vec<[[Matrix3<f64>; 3]; 3]> {
        let mut out = vec![[[Matrix3::zeros(); 3]; 3]; self.data.len()];
        self.hessians_into(x, &mut out);
        out
    }

    /// As [`Stretching::hessians`], into `out` (one entry per face), in parallel; no heap
    /// allocation per face (fixed-size matrices and eigen decomposition).
    pub fn hessians_into(&self, x: &[Vec3], out: &mut [[[Matrix3<f64>; 3]; 3]]) {
        assert_eq!(out.len(), self.data.len(), "stretching Hessian buffer has the wrong length");
        out.par_iter_mut().zip(&self.data).with_min_len(64).for_each(|(h, fd)| {
            *h = self.face_hessian(fd, x);
        });
    }

    /// The exact Hessian of one face, projected to positive semi-definite (the energy depends
    /// on edge vectors only, so the 6×6 reduced projection applies): for each unit
    /// direction of `x_k` (corner k, axis a), the directional derivative of
    /// `∂E/∂Ds = A h F S Dm⁻ᵀ` gives column (k, a).
    fn face_hessian(&self, fd: &FaceData, x: &[Vec3]) -> [[Matrix3<f64>; 3]; 3] {
        let (f0, f1, g) = Self::strain(fd, x);
        let f_ = Matrix3x2::from_columns(&[f0, f1]);
        let [a00, a10, a01, a11] = fd.dm_inv;
        let dm_inv = Matrix2::new(a00, a01, a10, a11);
        let tr = g[0] + g[2];
        let s = Matrix2::new(
            2.0 * self.mu * g[0] + self.lambda * tr,
            2.0 * self.mu * g[1],
            2.0 * self.mu * g[1],
            2.0 * self.mu * g[2] + self.lambda * tr,
        );
        let mut h = [[Matrix3::zeros(); 3]; 3];
        for k in 0..3 {
            // Row of Dm⁻¹ that corner k's displacement is multiplied by: dF = e_a ⊗ r_k.
            let r = match k {
                0 => dm_inv.row(0).into_owned(),
                1 => dm_inv.row(1).into_owned(),
                _ => -(dm_inv.row(0) + dm_inv.row(1)),
            };
            for a in 0..3 {
                let d_f = Vector3::ith(a, 1.0) * r;
                let d_g = 0.5 * (d_f.transpose() * f_ + f_.transpose() * d_f);
                let d_s = 2.0 * self.mu * d_g + self.lambda * d_g.trace() * Matrix2::identity();
                let d_h = fd.scale * (d_f * s + f_ * d_s) * dm_inv.transpose();
                let (c0, c1) = (d_h.column(0).into_owned(), d_h.column(1).into_owned());
                let rows = [c0, c1, -c0 - c1];
                for (j, r) in rows.iter().enumerate() {
                    // Column (k, a) of the Hessian, rows of vertex j.
                    h[j][k].set_column(a, r);
                }
            }
        }
        project_spd_translation_invariant(&mut h);
        h
    }
}
