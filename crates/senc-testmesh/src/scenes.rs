//! Seeded procedural meshes for tests and benchmarks: a square sheet and a UV sphere.

use rand::{Rng, SeedableRng};

use senc_geom::{TriMesh, Vec3};

/// A square sheet of `n × n` quads (2n² faces) of side `size` metres in the XZ plane at
/// height `y`, each interior vertex jittered in-plane by up to `jitter` × cell size
/// (seeded), alternating diagonals.
pub fn sheet(n: usize, size: f64, y: f64, jitter: f64, seed: u64) -> TriMesh {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let h = size / n as f64;
    let mut p = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && j > 0 && i < n && j < n;
            let (dx, dz) = if interior && jitter > 0.0 {
                (rng.random_range(-jitter..jitter) * h, rng.random_range(-jitter..jitter) * h)
            } else {
                (0.0, 0.0)
            };
            p.push(Vec3::new(i as f64 * h - 0.5 * size + dx, y, j as f64 * h - 0.5 * size + dz));
        }
    }
    let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut f = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            // Normals point +y: (b − a) × (d − a) = x̂ × ẑ = −ŷ, so use (a, d, b).
            if (i + j) % 2 == 0 {
                f.push([a, d, c]);
                f.push([a, c, b]);
            } else {
                f.push([a, d, b]);
                f.push([b, d, c]);
            }
        }
    }
    TriMesh::new(p, f).expect("sheet is a valid mesh")
}

/// A closed UV sphere of radius `r` centred at `c`, outward normals, with `n_lat` rings and
/// `n_lon` segments.
pub fn sphere(c: Vec3, r: f64, n_lat: usize, n_lon: usize) -> TriMesh {
    let mut p = vec![c + Vec3::new(0.0, r, 0.0)];
    for i in 1..n_lat {
        let th = std::f64::consts::PI * i as f64 / n_lat as f64;
        for j in 0..n_lon {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
            p.push(c + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
        }
    }
    p.push(c - Vec3::new(0.0, r, 0.0));
    let bottom = (p.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut f = Vec::new();
    for j in 0..n_lon {
        f.push([0, ring(1, j + 1), ring(1, j)]);
        for i in 1..n_lat - 1 {
            let (a, b, cc, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
            f.push([a, b, cc]);
            f.push([a, cc, d]);
        }
        f.push([bottom, ring(n_lat - 1, j), ring(n_lat - 1, j + 1)]);
    }
    let m = TriMesh::new(p, f).expect("sphere is a valid mesh");
    if m.signed_volume() < 0.0 {
        let faces = m.faces().iter().map(|f| [f[0], f[2], f[1]]).collect();
        return TriMesh::new(m.positions().to_vec(), faces).expect("sphere is a valid mesh");
    }
    m
}

/// The seeded scene the energy benchmark and profile share: a jittered 72×72-quad sheet
/// (10,368 faces) hanging 1 mm above a sphere of radius 0.3 m, at rest at t, with x[t+1]
/// the rest positions jittered by up to 1 mm, and the sphere moving 1 mm in x.
pub struct BenchScene {
    /// Rest mesh of the sheet (also x[t] and x[t−1]).
    pub rest: TriMesh,
    /// The body (a UV sphere) at t.
    pub body: TriMesh,
    /// Body positions at t+1.
    pub body_next: Vec<Vec3>,
    /// The evaluated x[t+1].
    pub x: Vec<Vec3>,
}

/// Builds [`BenchScene`] (seeded, the same on every call).
pub fn bench_scene() -> BenchScene {
    let rest = sheet(72, 1.0, 0.301, 0.3, 1);
    let body = sphere(Vec3::zeros(), 0.3, 32, 48);
    let mut rng = rand::rngs::StdRng::seed_from_u64(2);
    let mut jitter = || rng.random_range(-1e-3..1e-3);
    let x = rest.positions().iter().map(|p| p + Vec3::new(jitter(), jitter(), jitter())).collect();
    let body_next = body.positions().iter().map(|p| p + Vec3::new(1e-3, 0.0, 0.0)).collect();
    BenchScene { rest, body, body_next, x }
}
