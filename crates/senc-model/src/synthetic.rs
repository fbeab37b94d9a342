//! Seeded synthetic scenes for tests and benchmarks: a square garment folded over itself and
//! draped on a sphere, so that every edge type occurs.
//!
//! The rest garment is a flat `n × n` grid of spacing `h` (metres) in the xz plane. Its
//! current shape lies on a sphere of radius `R` centred at the origin: the half `u < 0` at
//! radius `R + 1 cm`, the half `u > 0` folded back over it at `R + 2.2 cm`, so the two layers
//! are 1.2 cm apart (self-collision edges at r = 2 cm) and the lower one is within 3 cm of
//! the body (body edges). Positions carry a seeded jitter of up to 1 mm; the body translates
//! 5 mm along z between `t` and `t+1`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::{TriMesh, Vec3};

use crate::graph::{BodyState, FrameState, Material};

/// A self-contained scene: garment, one state, body.
#[derive(Debug, Clone)]
pub struct SyntheticScene {
    /// Rest garment.
    pub rest: TriMesh,
    /// Cloth at `t−1`.
    pub prev: Vec<Vec3>,
    /// Cloth at `t`.
    pub curr: Vec<Vec3>,
    /// Body triangles.
    pub body_faces: Vec<[u32; 3]>,
    /// Body at `t`.
    pub body_curr: Vec<Vec3>,
    /// Body at `t+1`.
    pub body_next: Vec<Vec3>,
    /// Material.
    pub material: Material,
    /// `g + a_ext`, m/s².
    pub accel: Vec3,
}

/// Triangulated `n × n` vertex grid (row-major, index `i * n + j`) with alternating
/// diagonals, counter-clockwise seen from +y when vertex `i * n + j` is at `(j h, 0, i h)`.
pub fn grid_faces(n: usize) -> Vec<[u32; 3]> {
    let mut faces = Vec::with_capacity(2 * (n - 1) * (n - 1));
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let a = (i * n + j) as u32;
            let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
            if (i + j) % 2 == 0 {
                faces.push([a, c, b]);
                faces.push([b, c, d]);
            } else {
                faces.push([a, c, d]);
                faces.push([a, d, b]);
            }
        }
    }
    faces
}

/// A UV sphere of radius `r` with `n_lat × n_lon` vertices (no poles; caps left open).
fn sphere(r: f64, n_lat: usize, n_lon: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(n_lat * n_lon);
    for i in 0..n_lat {
        let theta = std::f64::consts::PI * (i as f64 + 0.5) / n_lat as f64;
        for j in 0..n_lon {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
            v.push(Vec3::new(r * theta.sin() * phi.cos(), r * theta.cos(), r * theta.sin() * phi.sin()));
        }
    }
    let mut f = Vec::new();
    for i in 0..n_lat - 1 {
        for j in 0..n_lon {
            let a = (i * n_lon + j) as u32;
            let b = (i * n_lon + (j + 1) % n_lon) as u32;
            let c = a + n_lon as u32;
            let d = b + n_lon as u32;
            f.push([a, b, c]);
            f.push([b, d, c]);
        }
    }
    (v, f)
}

impl SyntheticScene {
    /// A garment of `n × n` vertices at spacing `h` metres and a sphere body of about
    /// `body_vertices` vertices (0 for none), seeded.
    pub fn new(n: usize, h: f64, body_vertices: usize, seed: u64) -> Self {
        let n = n.max(2);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let half = 0.5 * (n - 1) as f64 * h;
        let rest_pos: Vec<Vec3> =
            (0..n * n).map(|k| Vec3::new((k % n) as f64 * h - half, 0.0, (k / n) as f64 * h - half)).collect();
        let rest = TriMesh::new(rest_pos.clone(), grid_faces(n)).expect("a regular grid is a valid mesh");
        // Sphere radius so that the folded half-width spans about 60 degrees.
        let radius = (half * 0.5 / std::f64::consts::FRAC_PI_6).max(0.05);
        let mut jitter = |s: f64| Vec3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s));
        let curr: Vec<Vec3> = rest_pos
            .iter()
            .map(|p| {
                // Fold the half u > 0 back over u < 0 (fold line at u = 0).
                let (u, layer) = if p.x > 0.0 { (-p.x, 1.0) } else { (p.x, 0.0) };
                let dir = Vec3::new(u, radius, p.z).normalize();
                dir * (radius + 0.01 + 0.012 * layer) + jitter(1e-3)
            })
            .collect();
        let prev: Vec<Vec3> = curr.iter().map(|c| c - Vec3::new(0.0, 0.002, 0.0) + jitter(5e-4)).collect();
        let (body_curr, body_faces) = if body_vertices > 0 {
            let n_lat = ((body_vertices as f64 / 2.0).sqrt().round() as usize).max(3);
            sphere(radius, n_lat, 2 * n_lat)
        } else {
            (Vec::new(), Vec::new())
        };
        let body_next = body_curr.iter().map(|b| b + Vec3::new(0.0, 0.0, 0.005)).collect();
        Self {
            rest,
            prev,
            curr,
            body_faces,
            body_curr,
            body_next,
            material: Material::default(),
            accel: Vec3::new(0.0, -9.81, 0.0),
        }
    }

    /// The frame as the model's input type.
    pub fn frame(&self) -> FrameState<'_> {
        FrameState {
            rest: &self.rest,
            prev: &self.prev,
            curr: &self.curr,
            material: self.material,
            accel: self.accel,
            dt: 1.0 / 30.0,
            body: (!self.body_curr.is_empty()).then_some(BodyState {
                faces: &self.body_faces,
                curr: &self.body_curr,
                next: &self.body_next,
            }),
            pinned: &[],
        }
    }
}
