//! Discrete-shell bending on interior edges.

use std::sync::Arc;

use nalgebra::Matrix3;
use rayon::prelude::*;

use senc_geom::Vec3;

use crate::rest::{corners, Hinge};
use crate::scatter::Scatter;

/// Below this `|n|² / l⁴` a hinge's face counts as collapsed and its gradient is dropped.
const COLLAPSED: f64 = 1e-24;
/// Orientation of the gradient formula relative to the atan2 convention.
const SIGN: f64 = -1.0;

/// Dihedral angle of a hinge `[a, b, c, d]` (edge `a → b`, faces `(a, b, c)` and
/// `(b, a, d)`): `θ = atan2(ê·(n0×n1), n0·n1)` in (−π, π], 0 when flat.
pub fn dihedral_angle(p: &[Vec3; 4]) -> f64 {
    let [a, b, c, d] = *p;
    let e = b - a;
    let n0 = e.cross(&(c - a));
    let n1 = (a - b).cross(&(d - b));
    let le = e.norm();
    if le == 0.0 {
        return 0.0;
    }
    (e.dot(&n0.cross(&n1)) / le).atan2(n0.dot(&n1))
}

/// θ and ∂θ/∂[a, b, c, d]; the gradient is zero on a collapsed hinge.
pub fn dihedral_angle_gradient(p: &[Vec3; 4]) -> (f64, [Vec3; 4]) {
    let [a, b, c, d] = *p;
    let e = b - a;
    let n0 = e.cross(&(c - a));
    let n1 = (a - b).cross(&(d - b));
    let le2 = e.norm_squared();
    let (m0, m1) = (n0.norm_squared(), n1.norm_squared());
    let theta = dihedral_angle(p);
    if le2 == 0.0 || m0 <= COLLAPSED * le2 * le2 || m1 <= COLLAPSED * le2 * le2 {
        return (theta, [Vec3::zeros(); 4]);
    }
    let le = le2.sqrt();
    let eh = e / le;
    let (q0, q1) = (n0 / m0, n1 / m1);
    // Bridson et al. 2003: the angle moves c and d along their face normals, scaled by the
    // edge length over the face's double area; a and b balance them (translation and
    // rotation invariance).
    let gc = le * q0;
    let gd = le * q1;
    let ga = (c - b).dot(&eh) * q0 + (d - b).dot(&eh) * q1;
    let gb = -(c - a).dot(&eh) * q0 - (d - a).dot(&eh) * q1;
    (theta, [ga * SIGN, gb * SIGN, gc * SIGN, gd * SIGN])
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
    stiffness: f64,
    use_rest_angle: bool,
}

impl Bending {
    /// The term with stiffness `k_b` (J); `use_rest_angle` picks the rest mesh's angles.
    pub fn new(hinges: Arc<Vec<Hinge>>, scatter: Arc<Scatter<4>>, stiffness: f64, use_rest_angle: bool) -> Self {
        Self { hinges, scatter, stiffness, use_rest_angle }
    }

    fn coefficient(&self, h: &Hinge) -> (f64, f64) {
        (self.stiffness * h.geometric_weight, if self.use_rest_angle { h.rest_angle } else { 0.0 })
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        match grad {
            None => self
                .hinges
                .par_iter()
                .map(|h| {
                    let (k, rest) = self.coefficient(h);
                    let t = dihedral_angle(&corners(x, &h.vertices)) - rest;
                    0.5 * k * t * t
                })
                .sum(),
            Some(grad) => {
                let (e, per): (Vec<f64>, Vec<[Vec3; 4]>) = self
                    .hinges
                    .par_iter()
                    .map(|h| {
                        let (k, rest) = self.coefficient(h);
                        let (theta, g) = dihedral_angle_gradient(&corners(x, &h.vertices));
                        let t = theta - rest;
                        (0.5 * k * t * t, g.map(|g| g * (k * t)))
                    })
                    .unzip();
                self.scatter.add_to(&per, 1.0, grad);
                e.iter().sum()
            }
        }
    }

    /// Gauss–Newton Hessians `k ∇θ ∇θᵀ` per hinge (positive semi-definite by construction).
    pub fn hessians(&self, x: &[Vec3]) -> Vec<[[Matrix3<f64>; 4]; 4]> {
        self.hinges
            .par_iter()
            .map(|h| {
                let (k, _) = self.coefficient(h);
                let (_, g) = dihedral_angle_gradient(&corners(x, &h.vertices));
                let mut m = [[Matrix3::zeros(); 4]; 4];
                for i in 0..4 {
                    for j in 0..4 {
                        m[i][j] = k * g[i] * g[j].transpose();
                    }
                }
                m
            })
            .collect()
    }

    /// The hinges.
    pub fn hinges(&self) -> &[Hinge] {
        &self.hinges
    }
}
