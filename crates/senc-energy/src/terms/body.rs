//! The body: nearest-face queries (senc-geom's [`NearestFaces`]), the cubic collision
//! penalty and friction against the moving body.

use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::Matrix3;
use rayon::prelude::*;

use senc_geom::{NearestFaces, TriMesh, Vec3};

use crate::error::EnergyError;
use crate::terms::inertia::per_vertex_eval;

/// The contact data of one cloth vertex for one frame: its nearest body face at time t,
/// that face's plane at t+1, and the body's displacement at the nearest point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Nearest body face at t.
    pub face: u32,
    /// A point of the face's plane at t+1 (the nearest point's barycentric image), m.
    pub point: Vec3,
    /// Unit outward normal of the face at t+1.
    pub normal: Vec3,
    /// Body displacement from t to t+1 at the nearest point, m.
    pub body_displacement: Vec3,
    /// Signed distance of `x[t]` to the face's plane at t, m.
    pub distance_t: f64,
}

/// Finds, for each cloth vertex at time t, its nearest body face (at t) and builds the
/// per-frame [`Contact`]s. Only built for scenes with a body.
#[derive(Debug)]
pub struct BodyQueries {
    faces: Vec<[u32; 3]>,
    n_vertices: usize,
    queries: AtomicU64,
}

impl BodyQueries {
    /// Queries against `body`'s faces (positions come per frame).
    pub fn new(body: &TriMesh) -> Self {
        Self { faces: body.faces().to_vec(), n_vertices: body.n_vertices(), queries: AtomicU64::new(0) }
    }

    /// How many nearest-face query batches ran (one per frame).
    pub fn query_count(&self) -> u64 {
        self.queries.load(Ordering::Relaxed)
    }

    /// Contacts of cloth positions `x_t` against the body at `body_t` and `body_next`.
    pub fn contacts(&self, x_t: &[Vec3], body_t: &[Vec3], body_next: &[Vec3]) -> Result<Vec<Contact>, EnergyError> {
        for (what, b) in [("body at t", body_t), ("body at t+1", body_next)] {
            if b.len() != self.n_vertices {
                return Err(EnergyError::VertexCount { what, expected: self.n_vertices, got: b.len() });
            }
            if let Some(v) = b.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
                return Err(EnergyError::NonFinite { what, vertex: v, value: b[v].into() });
            }
        }
        self.queries.fetch_add(1, Ordering::Relaxed);
        let query = NearestFaces::new(body_t, &self.faces)
            .map_err(|e| EnergyError::Body(format!("cannot build the body's BVH: {e}")))?;
        Ok(x_t
            .par_iter()
            .map(|x| {
                let (q, face) = query.nearest(x);
                let face = face as usize;
                let [a, b, c] = self.faces[face].map(|i| body_t[i as usize]);
                let beta = barycentric(&q, &a, &b, &c);
                let n_t = (b - a).cross(&(c - a));
                let n_t = n_t / n_t.norm().max(f64::MIN_POSITIVE);
                let [a1, b1, c1] = self.faces[face].map(|i| body_next[i as usize]);
                let n1 = (b1 - a1).cross(&(c1 - a1));
                let normal = if n1.norm() > 0.0 { n1.normalize() } else { n_t };
                let point = a1 * beta[0] + b1 * beta[1] + c1 * beta[2];
                Contact {
                    face: face as u32,
                    point,
                    normal,
                    body_displacement: point - q,
                    distance_t: (x - q).dot(&n_t),
                }
            })
            .collect())
    }
}

/// Barycentric coordinates of `q` (assumed in the triangle's plane) on `(a, b, c)`; the
/// centroid for a degenerate triangle.
fn barycentric(q: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> [f64; 3] {
    let (v0, v1, v2) = (b - a, c - a, q - a);
    let (d00, d01, d11) = (v0.dot(&v0), v0.dot(&v1), v1.dot(&v1));
    let (d20, d21) = (v2.dot(&v0), v2.dot(&v1));
    let den = d00 * d11 - d01 * d01;
    if den.is_nan() || den.abs() <= 1e-300 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    [1.0 - v - w, v, w]
}

/// Body collision: `E = w Σ_i max(ε − d_i, 0)³` (J) with `d_i = (x_i − p_i) · n_i` (m) the
/// signed distance of the cloth vertex to the plane at t+1 of its nearest body face found
/// at t, weight `w` (J/m³) and margin `ε` (m). Gradient `−3w max(ε − d_i, 0)² n_i`, Hessian
/// `6w max(ε − d_i, 0) n_i n_iᵀ` (positive semi-definite). Domain: every finite `x`.
#[derive(Debug, Clone)]
pub struct Collision {
    contacts: Vec<(Vec3, Vec3)>,
    weight: f64,
    epsilon: f64,
}

impl Collision {
    /// The term for this frame's contacts.
    pub fn new(contacts: &[Contact], weight: f64, epsilon: f64) -> Self {
        Self { contacts: contacts.iter().map(|c| (c.point, c.normal)).collect(), weight, epsilon }
    }

    fn gap(&self, i: usize, x: &Vec3) -> f64 {
        let (p, n) = &self.contacts[i];
        (self.epsilon - (x - p).dot(n)).max(0.0)
    }

    /// Energy (J) and gradient (N) of vertex `i` at `x`.
    #[inline(always)]
    pub fn vertex(&self, i: usize, x: &Vec3) -> (f64, Vec3) {
        let s = self.gap(i, x);
        if s > 0.0 {
            (self.weight * s * s * s, self.contacts[i].1 * (-3.0 * self.weight * s * s))
        } else {
            (0.0, Vec3::zeros())
        }
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> f64 {
        per_vertex_eval(x, grad, |i, x| self.vertex(i, x))
    }

    /// The diagonal Hessian block of vertex `i`.
    pub fn hessian(&self, i: usize, x: &Vec3) -> Matrix3<f64> {
        let n = self.contacts[i].1;
        n * n.transpose() * (6.0 * self.weight * self.gap(i, x))
    }
}

/// Friction (HOOD's form): for cloth vertices in contact at t (`d_i(x[t]) < distance`),
/// `E = μ_f |g| Σ_i m_i (sqrt(‖Δ_T,i‖² + η²) − η)` (J), where
/// `Δ_i = (x_i − x_i[t]) − u_i` is the slip relative to the body displacement `u_i` at the
/// contact point, `Δ_T = (I − n nᵀ) Δ` its tangential part (m), `m_i` the vertex mass (kg),
/// `|g|` the gravity magnitude (m/s²) and η a smoothing length (m) that makes the term
/// differentiable at zero slip (HOOD uses `‖Δ_T‖` directly). Gradient
/// `μ_f |g| m_i Δ_T / sqrt(‖Δ_T‖² + η²)`. Domain: every finite `x`.
#[derive(Debug, Clone)]
pub struct Friction {
    /// (vertex, x[t] + u, normal, μ |g| m).
    active: Vec<(u32, Vec3, Vec3, f64)>,
    smoothing: f64,
}

impl Friction {
    /// The term for this frame: vertices of `contacts` closer than `distance` at t.
    pub fn new(
        contacts: &[Contact],
        x_t: &[Vec3],
        mass: &[f64],
        mu: f64,
        gravity: f64,
        distance: f64,
        smoothing: f64,
    ) -> Self {
        let active = contacts
            .iter()
            .enumerate()
            .filter(|(_, c)| c.distance_t < distance)
            .map(|(i, c)| (i as u32, x_t[i] + c.body_displacement, c.normal, mu * gravity * mass[i]))
            .collect();
        Self { active, smoothing }
    }

    /// Number of vertices in contact.
    pub fn n_active(&self) -> usize {
        self.active.len()
    }

    /// Energy (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], mut grad: Option<&mut [Vec3]>) -> f64 {
        let eta = self.smoothing;
        let mut e = 0.0;
        for &(i, anchor, n, k) in &self.active {
            let d = x[i as usize] - anchor;
            let dt = d - n * n.dot(&d);
            let s = (dt.norm_squared() + eta * eta).sqrt();
            e += k * (s - eta);
            if let Some(g) = grad.as_deref_mut() {
                g[i as usize] += dt * (k / s);
            }
        }
        e
    }

    /// Hessian blocks `k (P/s − Δ_T Δ_Tᵀ / s³)` per active vertex (positive semi-definite).
    pub fn hessians(&self, x: &[Vec3]) -> Vec<(u32, Matrix3<f64>)> {
        let eta = self.smoothing;
        self.active
            .iter()
            .map(|&(i, anchor, n, k)| {
                let d = x[i as usize] - anchor;
                let dt = d - n * n.dot(&d);
                let s = (dt.norm_squared() + eta * eta).sqrt();
                let p = Matrix3::identity() - n * n.transpose();
                (i, (p / s - dt * dt.transpose() / (s * s * s)) * k)
            })
            .collect()
    }
}
