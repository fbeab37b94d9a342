//! Discrete-shell bending on interior edges.

use std::sync::Arc;

use nalgebra::Matrix3;
use rayon::prelude::*;

use senc_geom::Vec3;

use crate::rest::{corners, Hinge};
use crate::scatter::{ordered_sum, Scatter, ELEMENT_CHUNK};

/// Below this `|n|² / l⁴` a hinge's face counts as collapsed and its gradient is dropped.
const COLLAPSED: f64 = 1e-24;

/// Dihedral angle of a hinge `[a, b, c, d]` (edge `a → b`, faces `(a, b, c)` and
/// `(b, a, d)`): `θ = atan2(ê·(n0×n1), n0·n1)` in (−π, π], 0 when flat.
pub fn dihedral_angle(p: &[Vec3; 4]) -> f64 {
    let [a, b, c, d] = *p;
    let e = b - a;
    let n0 = e.cross(&(c - a));
    let n1 = (d - a).cross(&e);
    let le2 = e.norm_squared();
    if le2 == 0.0 {
        return 0.0;
    }
    (e.dot(&n0.cross(&n1)) / le2.sqrt()).atan2(n0.dot(&n1))
}

/// θ and ∂θ/∂[a, b, c, d]; the gradient is zero on a collapsed hinge.
pub fn dihedral_angle_gradient(p: &[Vec3; 4]) -> (f64, [Vec3; 4]) {
    let (theta, g) = angle_and_scaled_gradient(p, |_| 1.0);
    (theta, g.unwrap_or([Vec3::zeros(); 4]))
}

/// θ and `s(θ) ∂θ/∂[a, b, c, d]` in one pass (`None` on a collapsed hinge). The same
/// arithmetic as [`dihedral_angle`] for θ, sharing the edge vector and both face normals.
///
/// With `e = b − a`, `n0 = e × (c − a)`, `n1 = (d − a) × e` (the normals of faces
/// `(a, b, c)` and `(b, a, d)`), `l = ‖e‖` and `α0 = (c − a)·e / l`, `α1 = (d − a)·e / l`
/// (Bridson et al. 2003, in this crate's sign convention):
/// `∂θ/∂c = −l n0/‖n0‖²`, `∂θ/∂d = −l n1/‖n1‖²`, `∂θ/∂b = α0 n0/‖n0‖² + α1 n1/‖n1‖²`,
/// `∂θ/∂a = (l − α0) n0/‖n0‖² + (l − α1) n1/‖n1‖²` (they sum to zero).
#[inline(always)]
pub(crate) fn angle_and_scaled_gradient(p: &[Vec3; 4], s: impl FnOnce(f64) -> f64) -> (f64, Option<[Vec3; 4]>) {
    let [a, b, c, d] = *p;
    let e = b - a;
    let (ac, ad) = (c - a, d - a);
    let n0 = e.cross(&ac);
    let n1 = ad.cross(&e);
    let le2 = e.norm_squared();
    if le2 == 0.0 {
        return (0.0, None);
    }
    let le = le2.sqrt();
    let theta = (e.dot(&n0.cross(&n1)) / le).atan2(n0.dot(&n1));
    let (m0, m1) = (n0.norm_squared(), n1.norm_squared());
    let tiny = COLLAPSED * le2 * le2;
    if m0 <= tiny || m1 <= tiny {
        return (theta, None);
    }
    let s = s(theta);
    let inv_le = 1.0 / le;
    let (a0, a1) = (ac.dot(&e) * inv_le, ad.dot(&e) * inv_le);
    let q0 = n0 * (s / m0);
    let q1 = n1 * (s / m1);
    (theta, Some([q0 * (le - a0) + q1 * (le - a1), q0 * a0 + q1 * a1, q0 * -le, q1 * -le]))
}

/// Discrete-shell bending.
///
/// Per interior edge e with rest length `l_e` (m) and rest areas `A_0`, `A_1` (m²) of its
/// faces: `E = Σ_e k_b l_e² / (4(A_0 + A_1)) · (θ_e − θ̄_e)² / 2` (J), with `θ_e` the
/// dihedral angle of [`dihedral_angle`] (rad), `k_b` the bending stiffness (J) and `θ̄_e`
/// the rest angle (0, HOOD's choice, or the rest mesh's own).
///
/// Domain: every finite `x`. A hinge whose face has collapsed to a segment contributes its
/// energy but no gradient (the angle is undefined there).
#[derive(Debug, Clone)]
pub struct Bending {
    hinges: Arc<Vec<Hinge>>,
    scatter: Arc<Scatter<4>>,
    /// Per-hinge constants in one flat array.
    data: Vec<HingeData>,
}

/// What one hinge needs, contiguous: its vertices, `k = k_b l_e² / (4(A_0 + A_1))` (J) and
/// its rest angle (rad).
#[derive(Debug, Clone, Copy)]
struct HingeData {
    vertices: [u32; 4],
    k: f64,
    rest: f64,
}

impl Bending {
    /// The term with stiffness `k_b` (J); `use_rest_angle` picks the rest mesh's angles.
    pub fn new(hinges: Arc<Vec<Hinge>>, scatter: Arc<Scatter<4>>, stiffness: f64, use_rest_angle: bool) -> Self {
        let data = hinges
            .iter()
            .map(|h| HingeData {
                vertices: h.vertices,
                k: stiffness * h.geometric_weight,
                rest: if use_rest_angle { h.rest_angle } else { 0.0 },
            })
            .collect();
        Self { hinges, scatter, data }
    }

    /// Number of hinges.
    pub fn n_hinges(&self) -> usize {
        self.data.len()
    }

    /// Energy (J) with each hinge's corner gradients written to `out` (`4 × n_hinges` slots,
    /// hinge-major; zeros on a collapsed hinge). Parallel over fixed chunks of hinges; the
    /// energy is summed in chunk order.
    pub fn element_gradients(&self, x: &[Vec3], out: &mut [Vec3]) -> f64 {
        assert_eq!(out.len(), 4 * self.data.len(), "bending gradient buffer has the wrong length");
        ordered_sum(
            out.par_chunks_mut(4 * ELEMENT_CHUNK)
                .zip(self.data.par_chunks(ELEMENT_CHUNK))
                .map(|(out, data)| {
                    let mut e = 0.0;
                    for (o, h) in out.chunks_exact_mut(4).zip(data) {
                        let (theta, g) =
                            angle_and_scaled_gradient(&corners(x, &h.vertices), |theta| h.k * (theta - h.rest));
                        let t = theta - h.rest;
                        o.copy_from_slice(&g.unwrap_or([Vec3::zeros(); 4]));
                        e += 0.5 * h.k * t * t;
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
                    .map(|data| {
                        let mut e = 0.0;
                        for h in data {
                            let t = dihedral_angle(&corners(x, &h.vertices)) - h.rest;
                            e += 0.5 * h.k * t * t;
                        }
                        e
                    })
                    .collect(),
            ),
            Some(grad) => {
                let mut per = vec![Vec3::zeros(); 4 * self.data.len()];
                let e = self.element_gradients(x, &mut per);
                self.scatter.add_flat(&per, 1.0, grad);
                e
            }
        }
    }

    /// Gauss–Newton Hessians `k ∇θ ∇θᵀ` per hinge (positive semi-definite by construction).
    pub fn hessians(&self, x: &[Vec3]) -> Vec<[[Matrix3<f64>; 4]; 4]> {
        let mut w = vec![[Vec3::zeros(); 4]; self.data.len()];
        self.gauss_newton_factors(x, &mut w);
        w.iter()
            .map(|w| {
                let mut m = [[Matrix3::zeros(); 4]; 4];
                for i in 0..4 {
                    for j in 0..4 {
                        m[i][j] = w[i] * w[j].transpose();
                    }
                }
                m
            })
            .collect()
    }

    /// The rank-one factors of the Gauss–Newton Hessians: `w = √k ∇θ` per hinge (so the
    /// hinge's block `(i, j)` is `w_i w_jᵀ`), zero on a collapsed hinge; into `out`, one
    /// entry per hinge, in parallel.
    pub fn gauss_newton_factors(&self, x: &[Vec3], out: &mut [[Vec3; 4]]) {
        assert_eq!(out.len(), self.data.len(), "bending factor buffer has the wrong length");
        out.par_iter_mut().zip(&self.data).with_min_len(256).for_each(|(w, h)| {
            let k = h.k.max(0.0).sqrt();
            *w = angle_and_scaled_gradient(&corners(x, &h.vertices), |_| k).1.unwrap_or([Vec3::zeros(); 4]);
        });
    }

    /// The hinges.
    pub fn hinges(&self) -> &[Hinge] {
        &self.hinges
    }
}
