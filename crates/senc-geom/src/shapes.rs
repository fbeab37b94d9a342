//! Procedural, deterministic meshes for tests, fixtures and benchmarks: grid-made boxes,
//! icospheres, tubes, tori, a tube bent through itself, a sleeve pushed through a torso, flat
//! and folded sheets, plus jitter, rigid motion and disjoint union.
//!
//! Every generator returns a validated [`TriMesh`] whose faces are oriented outward (for open
//! surfaces: consistently, with the side named in each function's doc). Lengths are metres.
//! Grid-made meshes place vertices on exact lattices (`min + (max - min) * i / n`), so two
//! meshes built on a shared lattice meet in exact degeneracies (vertex on face, edge through
//! edge, coplanar faces); [`jitter`] removes them with seeded noise.
//!
//! The named fixtures in [`FIXTURES`] are the meshes whose reference answers (libigl's
//! intersecting face pairs, penetration volumes of the exact arrangement) are committed under
//! `tests/fixtures/` at the repository root: a fixture is its generator call here plus its
//! answer file there, so no mesh file needs to be committed.
//!
//! # Example
//! ```
//! use senc_geom::shapes;
//! let cube = shapes::grid_box([0.0; 3].into(), [1.0; 3].into(), 4).unwrap();
//! assert_eq!(cube.n_faces(), 6 * 4 * 4 * 2);
//! assert!((cube.signed_volume() - 1.0).abs() < 1e-12);
//! let sphere = shapes::icosphere([0.0; 3].into(), 1.0, 2).unwrap();
//! let both = shapes::merge(&cube, &sphere).unwrap();
//! assert_eq!(both.topology().n_components(), 2);
//! ```

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use nalgebra::Rotation3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::MeshError;
use crate::mesh::TriMesh;
use crate::Vec3;

/// Why a shape could not be generated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A parameter is out of its range.
    #[error("shape parameter `{name}` = {value} is invalid: {requirement}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// [`fixture`] was asked for a name that is not in [`FIXTURES`].
    #[error("unknown fixture `{name}`; the names are listed in senc_geom::shapes::FIXTURES")]
    UnknownFixture {
        /// The name asked for.
        name: String,
    },
    /// The generated mesh failed validation (a bug in the generator or parameters that
    /// collapse faces, e.g. a jitter larger than the faces).
    #[error("generated mesh is invalid: {0}")]
    Mesh(#[from] MeshError),
}

fn positive(name: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::InvalidParameter { name, value, requirement: "must be finite and > 0" })
    }
}

fn count(name: &'static str, value: usize, min: usize, max: usize) -> Result<usize, ShapeError> {
    if (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(ShapeError::InvalidParameter {
            name,
            value: value as f64,
            requirement: "count out of range (see the function's doc for the allowed range)",
        })
    }
}

/// Largest per-direction subdivision accepted by the generators (keeps meshes under a few
/// million faces and indices in `u32`).
pub const MAX_SUBDIVISION: usize = 2048;

/// Lattice coordinate `i / n` between `lo` and `hi`, hitting both ends exactly.
fn lattice(lo: f64, hi: f64, i: usize, n: usize) -> f64 {
    if i == n {
        hi
    } else {
        lo + (hi - lo) * (i as f64 / n as f64)
    }
}

/// Axis-aligned box `[min, max]`, each side an `n × n` grid of quads split along the same
/// diagonal (`12 n²` faces, `6 n² + 2` vertices), normals outward.
///
/// Vertices sit on the lattice `min + (max - min) * i / n` (ends exact), so boxes built on
/// a shared lattice touch and cross in exact degeneracies. `1 <= n <= MAX_SUBDIVISION`;
/// `max` must exceed `min` on every axis. Volume: exactly `Π (max - min)` up to rounding.
pub fn grid_box(min: Vec3, max: Vec3, n: usize) -> Result<TriMesh, ShapeError> {
    count("n", n, 1, MAX_SUBDIVISION)?;
    for a in 0..3 {
        if !(min[a].is_finite() && max[a].is_finite() && max[a] > min[a]) {
            return Err(ShapeError::InvalidParameter {
                name: "max - min",
                value: max[a] - min[a],
                requirement: "every coordinate finite and max > min on each axis",
            });
        }
    }
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut vertex = |ijk: [usize; 3], positions: &mut Vec<Vec3>| -> u32 {
        *index.entry(ijk).or_insert_with(|| {
            positions.push(Vec3::new(
                lattice(min.x, max.x, ijk[0], n),
                lattice(min.y, max.y, ijk[1], n),
                lattice(min.z, max.z, ijk[2], n),
            ));
            (positions.len() - 1) as u32
        })
    };
    let mut faces = Vec::with_capacity(12 * n * n);
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, n] {
            for iu in 0..n {
                for iv in 0..n {
                    let mut q = [0u32; 4];
                    for (c, (du, dv)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                        let mut ijk = [0; 3];
                        ijk[a] = side;
                        ijk[u] = iu + du;
                        ijk[v] = iv + dv;
                        q[c] = vertex(ijk, &mut positions);
                    }
                    // e_u × e_v = +e_a: keep the winding on the max side, flip it on the min side.
                    if side == n {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Ok(TriMesh::new(positions, faces)?)
}

/// Icosphere: the regular icosahedron subdivided `level` times (each triangle into four,
/// midpoints pushed to the sphere), `20 · 4^level` faces, all vertices at distance `radius`
/// from `center`, normals outward. `level <= 8`.
///
/// Its volume lies between the balls of radius `r_in` (the smallest face-plane distance)
/// and `radius`; at level 4 it is about 0.3 % below `4/3 π radius³`.
pub fn icosphere(center: Vec3, radius: f64, level: usize) -> Result<TriMesh, ShapeError> {
    positive("radius", radius)?;
    count("level", level, 0, 8)?;
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut unit: Vec<Vec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    // Orient every base face outward (the icosahedron is convex around the origin).
    for f in &mut faces {
        let [a, b, c] = f.map(|i| unit[i as usize]);
        if (b - a).cross(&(c - a)).dot(&(a + b + c)) < 0.0 {
            f.swap(1, 2);
        }
    }
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let mut m = |i: u32, j: u32| -> u32 {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    unit.push((unit[i as usize] + unit[j as usize]).normalize());
                    (unit.len() - 1) as u32
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let positions = unit.iter().map(|u| center + u * radius).collect();
    Ok(TriMesh::new(positions, faces)?)
}

/// How the ends of a [`tube`] are finished.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Caps {
    /// Both ends open: two boundary loops.
    Open,
    /// Each end closed by a fan around a centre vertex on the axis: a closed surface.
    Fan,
}

/// Cylindrical tube of `radius` around the z axis from `z = 0` to `z = length`:
/// `n_along` rings of quads, `n_around` vertices per ring (a regular polygon, vertex 0 on
/// +x), normals pointing away from the axis. `3 <= n_around`, `1 <= n_along`, both at most
/// [`MAX_SUBDIVISION`]. `2 · n_around · n_along` faces, plus `2 · n_around` with
/// [`Caps::Fan`].
///
/// Capped volume: exactly the polygonal prism `n_around / 2 · radius² · sin(2π / n_around)
/// · length` (m³).
pub fn tube(radius: f64, length: f64, n_around: usize, n_along: usize, caps: Caps) -> Result<TriMesh, ShapeError> {
    positive("radius", radius)?;
    positive("length", length)?;
    count("n_around", n_around, 3, MAX_SUBDIVISION)?;
    count("n_along", n_along, 1, MAX_SUBDIVISION)?;
    let ring = ring_directions(n_around);
    let mut positions = Vec::with_capacity((n_along + 1) * n_around + 2);
    for k in 0..=n_along {
        let z = lattice(0.0, length, k, n_along);
        positions.extend(ring.iter().map(|&(c, s)| Vec3::new(radius * c, radius * s, z)));
    }
    let id = |k: usize, j: usize| (k * n_around + j % n_around) as u32;
    let mut faces = Vec::with_capacity(2 * n_around * (n_along + 1));
    for k in 0..n_along {
        for j in 0..n_around {
            let (a, b, c, d) = (id(k, j), id(k, j + 1), id(k + 1, j + 1), id(k + 1, j));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    if caps == Caps::Fan {
        let bottom = positions.len() as u32;
        positions.push(Vec3::new(0.0, 0.0, 0.0));
        let top = positions.len() as u32;
        positions.push(Vec3::new(0.0, 0.0, length));
        for j in 0..n_around {
            faces.push([bottom, id(0, j + 1), id(0, j)]);
            faces.push([top, id(n_along, j), id(n_along, j + 1)]);
        }
    }
    Ok(TriMesh::new(positions, faces)?)
}

/// `(cos θ_j, sin θ_j)` for `θ_j = 2π j / n`, with the quarter turns exact.
fn ring_directions(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|j| {
            if 4 * j % n == 0 {
                [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][4 * j / n]
            } else {
                let t = TAU * j as f64 / n as f64;
                (t.cos(), t.sin())
            }
        })
        .collect()
}

/// Torus around the z axis: tube radius `minor` around a circle of radius `major` in the
/// xy plane, `n_major × n_minor` quads, normals outward. `0 < minor < major`; counts at
/// least 3. Volume `2π² · major · minor²` (m³) for the smooth torus; the tessellation is
/// below that by about `(2π / n)² / 6` relative for each of the two counts.
pub fn torus(major: f64, minor: f64, n_major: usize, n_minor: usize) -> Result<TriMesh, ShapeError> {
    positive("major", major)?;
    positive("minor", minor)?;
    if minor >= major {
        return Err(ShapeError::InvalidParameter { name: "minor", value: minor, requirement: "must be below major" });
    }
    count("n_major", n_major, 3, MAX_SUBDIVISION)?;
    count("n_minor", n_minor, 3, MAX_SUBDIVISION)?;
    let big = ring_directions(n_major);
    let small = ring_directions(n_minor);
    let mut positions = Vec::with_capacity(n_major * n_minor);
    for &(cp, sp) in &big {
        for &(ct, st) in &small {
            let rho = major + minor * ct;
            positions.push(Vec3::new(rho * cp, rho * sp, minor * st));
        }
    }
    let id = |i: usize, j: usize| ((i % n_major) * n_minor + j % n_minor) as u32;
    let mut faces = Vec::with_capacity(2 * n_major * n_minor);
    for i in 0..n_major {
        for j in 0..n_minor {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    Ok(TriMesh::new(positions, faces)?)
}

/// A closed (fan-capped) tube bent at a sharp elbow so that it passes through itself.
///
/// The straight tube of `radius` runs along z from `-leg_length` to `+leg_length`
/// (`n_along_per_leg` rings of quads on each leg, a ring at `z = 0`); every vertex with
/// `z > 0` is then rotated by `bend_angle` (radians) about the y axis through the origin and
/// shifted by `offset` along y. For a bend above 90° the second leg folds back through the
/// first near the elbow (the quads between the ring at `z = 0` and the first rotated ring
/// form the sharp, wedge-shaped elbow). `offset = 0` bends in a plane: two equal cylinders
/// whose axes meet are tangent to the same two planes, so their intersection curves touch
/// each other at the elbow, a non-generic configuration; a small offset (e.g. `0.2 ·
/// radius`) makes the crossing transversal. `0 < bend_angle < π`; `leg_length` should exceed
/// about `3 · radius / sin(π - bend_angle)` so that the caps stay clear of the other leg.
pub fn bent_tube(
    radius: f64,
    leg_length: f64,
    bend_angle: f64,
    offset: f64,
    n_around: usize,
    n_along_per_leg: usize,
) -> Result<TriMesh, ShapeError> {
    positive("leg_length", leg_length)?;
    if !(bend_angle.is_finite() && bend_angle > 0.0 && bend_angle < PI) {
        return Err(ShapeError::InvalidParameter {
            name: "bend_angle",
            value: bend_angle,
            requirement: "must be in (0, π) radians",
        });
    }
    if !offset.is_finite() {
        return Err(ShapeError::InvalidParameter { name: "offset", value: offset, requirement: "must be finite" });
    }
    count("n_along_per_leg", n_along_per_leg, 1, MAX_SUBDIVISION / 2)?;
    let straight = tube(radius, 2.0 * leg_length, n_around, 2 * n_along_per_leg, Caps::Fan)?;
    let rot = Rotation3::from_axis_angle(&Vec3::y_axis(), bend_angle);
    let positions = straight
        .positions()
        .iter()
        .map(|p| {
            let q = p - Vec3::new(0.0, 0.0, leg_length);
            if q.z > 0.0 {
                rot * q + Vec3::new(0.0, offset, 0.0)
            } else {
                q
            }
        })
        .collect();
    Ok(TriMesh::new(positions, straight.faces().to_vec())?)
}

/// Parameters of [`sleeve_through_torso`] (metres and counts).
#[derive(Debug, Clone, PartialEq)]
pub struct SleeveTorso {
    /// Radius of the torso, an open tube around the z axis.
    pub torso_radius: f64,
    /// Height of the torso, centred on `z = 0`.
    pub torso_height: f64,
    /// Vertices per torso ring.
    pub torso_around: usize,
    /// Quad rings along the torso.
    pub torso_along: usize,
    /// Radius of the sleeve, an open tube along the x axis at `y = z = 0`.
    pub sleeve_radius: f64,
    /// x of the sleeve's inner end (inside the torso when below `torso_radius`).
    pub sleeve_inner_x: f64,
    /// x of the sleeve's outer end.
    pub sleeve_outer_x: f64,
    /// Vertices per sleeve ring.
    pub sleeve_around: usize,
    /// Quad rings along the sleeve.
    pub sleeve_along: usize,
}

impl Default for SleeveTorso {
    /// A 7,168-face pair: torso radius 0.15 m and height 0.6 m (96 × 32 quads), sleeve
    /// radius 0.05 m from x = 0.08 m to 0.35 m (32 × 16 quads), so the sleeve's inner end is
    /// 7 cm inside the torso wall.
    fn default() -> Self {
        Self {
            torso_radius: 0.15,
            torso_height: 0.6,
            torso_around: 96,
            torso_along: 32,
            sleeve_radius: 0.05,
            sleeve_inner_x: 0.08,
            sleeve_outer_x: 0.35,
            sleeve_around: 32,
            sleeve_along: 16,
        }
    }
}

/// An open "sleeve" tube pushed through the wall of an open "torso" tube: two components
/// and four boundary loops (torso hem and neck, sleeve cuff and inner end), the garment-like
/// case where holes are closed by fans before measuring the penetration volume. Faces: torso
/// first, then sleeve; normals away from each tube's axis.
pub fn sleeve_through_torso(p: &SleeveTorso) -> Result<TriMesh, ShapeError> {
    let torso = tube(p.torso_radius, p.torso_height, p.torso_around, p.torso_along, Caps::Open)?;
    let torso = rigid_transform(&torso, &Rotation3::identity(), &Vec3::new(0.0, 0.0, -0.5 * p.torso_height))?;
    if !(p.sleeve_inner_x.is_finite() && p.sleeve_outer_x.is_finite() && p.sleeve_outer_x > p.sleeve_inner_x) {
        return Err(ShapeError::InvalidParameter {
            name: "sleeve_outer_x",
            value: p.sleeve_outer_x,
            requirement: "must be finite and greater than sleeve_inner_x",
        });
    }
    let sleeve =
        tube(p.sleeve_radius, p.sleeve_outer_x - p.sleeve_inner_x, p.sleeve_around, p.sleeve_along, Caps::Open)?;
    let to_x = Rotation3::from_axis_angle(&Vec3::y_axis(), 0.5 * PI);
    let sleeve = rigid_transform(&sleeve, &to_x, &Vec3::new(p.sleeve_inner_x, 0.0, 0.0))?;
    merge(&torso, &sleeve)
}

/// The garment-like benchmark mesh (13,152 faces, fixed parameters): an open torso tube
/// (radius 0.16 m, height 0.7 m, 112 × 48 quads, radius modulated by a seeded low-frequency
/// wobble of ±3 %) and an open sleeve tube (radius 0.055 m, length 0.45 m, 40 × 30 quads)
/// lying against the torso's +x side, tilted 40° from vertical towards +y and pressed 2 cm
/// into the torso wall around its middle; both sleeve ends stay outside the torso, so the
/// four holes can be closed by fans without creating further crossings.
pub fn garment_benchmark() -> Result<TriMesh, ShapeError> {
    let (torso_r, torso_h, sleeve_r, sleeve_len, depth) = (0.16, 0.7, 0.055, 0.45, 0.02);
    let torso = tube(torso_r, torso_h, 112, 48, Caps::Open)?;
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let phases: [f64; 4] = std::array::from_fn(|_| rng.random_range(0.0..TAU));
    let wobble: Vec<Vec3> = torso
        .positions()
        .iter()
        .map(|p| {
            let theta = p.y.atan2(p.x);
            let s = p.z / torso_h;
            let f = 1.0
                + 0.015 * (2.0 * theta + phases[0]).sin() * (PI * s + phases[1]).cos()
                + 0.015 * (3.0 * theta + phases[2]).cos() * (2.0 * PI * s + phases[3]).sin();
            Vec3::new(p.x * f, p.y * f, p.z - 0.5 * torso_h)
        })
        .collect();
    let torso = torso.with_positions(wobble)?;
    let sleeve = tube(sleeve_r, sleeve_len, 40, 30, Caps::Open)?;
    // Centre the sleeve on its own origin, tilt it 40° about x, then move its axis to pass
    // at distance torso_r + sleeve_r - depth from the torso axis.
    let sleeve = rigid_transform(&sleeve, &Rotation3::identity(), &Vec3::new(0.0, 0.0, -0.5 * sleeve_len))?;
    let tilt = Rotation3::from_axis_angle(&Vec3::x_axis(), -40f64.to_radians());
    let sleeve = rigid_transform(&sleeve, &tilt, &Vec3::new(torso_r + sleeve_r - depth, 0.0, 0.0))?;
    merge(&torso, &sleeve)
}

/// Flat sheet in the `z = 0` plane over `[0, size_x] × [0, size_y]`, an `nx × ny` grid of
/// quads split along one diagonal, normals +z, one boundary loop. Counts in
/// `1..=MAX_SUBDIVISION`.
pub fn grid_sheet(size_x: f64, size_y: f64, nx: usize, ny: usize) -> Result<TriMesh, ShapeError> {
    positive("size_x", size_x)?;
    positive("size_y", size_y)?;
    count("nx", nx, 1, MAX_SUBDIVISION)?;
    count("ny", ny, 1, MAX_SUBDIVISION)?;
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push(Vec3::new(lattice(0.0, size_x, i, nx), lattice(0.0, size_y, j, ny), 0.0));
        }
    }
    Ok(TriMesh::new(positions, grid_faces(nx, ny))?)
}

fn grid_faces(nx: usize, ny: usize) -> Vec<[u32; 3]> {
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    faces
}

/// A square sheet of side `size` folded back over itself so that part of the fold passes
/// through the lower layer: the surface-folded-through-itself case (intersection path closed
/// through two loop vertices on the fold line).
///
/// A `2n × n` grid over `u ∈ [0, size]`, `y ∈ [-size/4, size/4]`, with the fold at
/// `u = size/2`: the lower layer (`u <= size/2`) lies at `z = 0`; the flap at distance
/// `s = u - size/2` past the fold maps to `x = size/2 - s`, `z = 0.2 · s · k(y, s)` with
/// `k = 0.3 (1 + (s / s0)²) - exp(-(y / σ)²)`, `σ = size/24`, `s0 = size/6`. The flap lies
/// above the lower layer where `k > 0` and below it inside the closed curve `k = 0`, which
/// meets the fold line at `y = ±σ √ln(1/0.3)` and reaches `s ≈ 0.26 · size`. One boundary
/// loop; the lower layer's normals point to +z. `2 <= n <= MAX_SUBDIVISION / 2`.
pub fn folded_sheet(size: f64, n: usize) -> Result<TriMesh, ShapeError> {
    positive("size", size)?;
    count("n", n, 2, MAX_SUBDIVISION / 2)?;
    let (nx, ny) = (2 * n, n);
    let half = 0.5 * size;
    let (sigma, s0) = (size / 24.0, size / 6.0);
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            let u = lattice(0.0, size, i, nx);
            let y = lattice(-0.25 * size, 0.25 * size, j, ny);
            if i <= n {
                positions.push(Vec3::new(u, y, 0.0));
            } else {
                let s = u - half;
                let k = 0.3 * (1.0 + (s / s0).powi(2)) - (-(y / sigma).powi(2)).exp();
                positions.push(Vec3::new(half - s, y, 0.2 * s * k));
            }
        }
    }
    Ok(TriMesh::new(positions, grid_faces(nx, ny))?)
}

/// Moves each vertex by an independent uniform offset in `[-1, 1]³ · rel · d`, where `d` is
/// the mesh's bounding-box diagonal (m); seeded (ChaCha8), so the same call gives the same
/// mesh on every machine. Faces are re-validated, so a jitter large enough to collapse a
/// face is an error. `rel` finite and `>= 0`.
pub fn jitter(mesh: &TriMesh, rel: f64, seed: u64) -> Result<TriMesh, ShapeError> {
    if !(rel.is_finite() && rel >= 0.0) {
        return Err(ShapeError::InvalidParameter { name: "rel", value: rel, requirement: "must be finite and >= 0" });
    }
    let scale = rel * mesh.bounding_diagonal();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let positions = mesh
        .positions()
        .iter()
        .map(|p| {
            let d = Vec3::new(rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0));
            p + d * scale
        })
        .collect();
    Ok(TriMesh::new(positions, mesh.faces().to_vec())?)
}

/// `p ↦ rotation · p + translation` applied to every vertex; faces and topology are kept
/// (orientation is preserved, a rotation having determinant +1).
pub fn rigid_transform(mesh: &TriMesh, rotation: &Rotation3<f64>, translation: &Vec3) -> Result<TriMesh, ShapeError> {
    let positions = mesh.positions().iter().map(|p| rotation * p + translation).collect();
    Ok(mesh.with_positions(positions)?)
}

/// Disjoint union: `a`'s vertices and faces first, then `b`'s with indices shifted by
/// `a.n_vertices()`. Shared positions are not welded.
pub fn merge(a: &TriMesh, b: &TriMesh) -> Result<TriMesh, ShapeError> {
    let offset = u32::try_from(a.n_vertices()).map_err(|_| ShapeError::InvalidParameter {
        name: "a.n_vertices",
        value: a.n_vertices() as f64,
        requirement: "the union must index its vertices with u32",
    })?;
    let mut positions = a.positions().to_vec();
    positions.extend_from_slice(b.positions());
    let mut faces = a.faces().to_vec();
    faces.extend(b.faces().iter().map(|f| f.map(|i| i + offset)));
    Ok(TriMesh::new(positions, faces)?)
}

/// A named mesh whose reference answers live in `tests/fixtures/<name>.json` at the
/// repository root (see `tests/fixtures/README.md`).
#[derive(Debug, Clone, Copy)]
pub struct Fixture {
    /// The name, also the answer file's stem.
    pub name: &'static str,
    /// Generator call and parameters, in words.
    pub description: &'static str,
    /// Whether penetration volumes are measured after closing every hole with a fan.
    pub close_holes: bool,
    make: fn() -> Result<TriMesh, ShapeError>,
}

impl Fixture {
    /// Generates the mesh.
    pub fn build(&self) -> Result<TriMesh, ShapeError> {
        (self.make)()
    }
}

/// Relative jitter of the `*_jitter` fixtures (of the bounding-box diagonal).
pub const FIXTURE_JITTER: f64 = 1e-9;
/// Seed of the `*_jitter` fixtures.
pub const FIXTURE_SEED: u64 = 7;

fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}
fn unit_box() -> Result<TriMesh, ShapeError> {
    grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 8)
}
fn boxes_at(x0: f64) -> Result<TriMesh, ShapeError> {
    let b = grid_box(v(x0, 0.25, 0.125), v(x0 + 1.0, 1.25, 1.125), 8)?;
    merge(&unit_box()?, &b)
}
fn jittered(m: Result<TriMesh, ShapeError>) -> Result<TriMesh, ShapeError> {
    jitter(&m?, FIXTURE_JITTER, FIXTURE_SEED)
}
fn boxes_overlap_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(0.5)
}
fn boxes_touch_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(1.0)
}
fn boxes_apart_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(1.25)
}
fn icospheres_overlap_grid() -> Result<TriMesh, ShapeError> {
    merge(&icosphere(v(0.0, 0.0, 0.0), 1.0, 4)?, &icosphere(v(1.2, 0.0, 0.0), 1.0, 4)?)
}
fn bent_tube_grid() -> Result<TriMesh, ShapeError> {
    bent_tube(0.1, 0.6, 135f64.to_radians(), 0.02, 64, 24)
}
fn sleeve_torso_grid() -> Result<TriMesh, ShapeError> {
    sleeve_through_torso(&SleeveTorso::default())
}
fn folded_sheet_grid() -> Result<TriMesh, ShapeError> {
    folded_sheet(1.0, 40)
}
fn sphere_l5() -> Result<TriMesh, ShapeError> {
    icosphere(v(0.0, 0.0, 0.0), 1.0, 5)
}
fn torus_bench() -> Result<TriMesh, ShapeError> {
    torus(1.0, 0.3, 128, 48)
}

/// Every named fixture and benchmark mesh. Grid-made ones (`*_grid`) have exact
/// degeneracies; each `*_jitter` twin is the same mesh after
/// `jitter(mesh, FIXTURE_JITTER, FIXTURE_SEED)`.
pub const FIXTURES: &[Fixture] = &[
    Fixture {
        name: "boxes_overlap_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((0.5,0.25,0.125),(1.5,1.25,1.125),8)); overlap 0.5*0.75*0.875 = 0.328125 m^3",
        close_holes: false,
        make: boxes_overlap_grid,
    },
    Fixture {
        name: "boxes_overlap_jitter",
        description: "boxes_overlap_grid jittered",
        close_holes: false,
        make: || jittered(boxes_overlap_grid()),
    },
    Fixture {
        name: "boxes_touch_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((1,0.25,0.125),(2,1.25,1.125),8)); coplanar contact at x=1, volume 0",
        close_holes: false,
        make: boxes_touch_grid,
    },
    Fixture {
        name: "boxes_touch_jitter",
        description: "boxes_touch_grid jittered",
        close_holes: false,
        make: || jittered(boxes_touch_grid()),
    },
    Fixture {
        name: "boxes_apart_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((1.25,0.25,0.125),(2.25,1.25,1.125),8)); 0.25 m gap, volume 0",
        close_holes: false,
        make: boxes_apart_grid,
    },
    Fixture {
        name: "boxes_apart_jitter",
        description: "boxes_apart_grid jittered",
        close_holes: false,
        make: || jittered(boxes_apart_grid()),
    },
    Fixture {
        name: "icospheres_overlap_grid",
        description: "merge(icosphere((0,0,0),1,4), icosphere((1.2,0,0),1,4)); 10,240 faces",
        close_holes: false,
        make: icospheres_overlap_grid,
    },
    Fixture {
        name: "icospheres_overlap_jitter",
        description: "icospheres_overlap_grid jittered",
        close_holes: false,
        make: || jittered(icospheres_overlap_grid()),
    },
    Fixture {
        name: "bent_tube_grid",
        description: "bent_tube(radius 0.1, leg_length 0.6, bend 135 deg, offset 0.02, n_around 64, n_along_per_leg 24); 6,272 faces",
        close_holes: false,
        make: bent_tube_grid,
    },
    Fixture {
        name: "bent_tube_jitter",
        description: "bent_tube_grid jittered",
        close_holes: false,
        make: || jittered(bent_tube_grid()),
    },
    Fixture {
        name: "sleeve_torso_grid",
        description: "sleeve_through_torso(&SleeveTorso::default()); 7,168 faces, 4 holes closed by fans for volumes",
        close_holes: true,
        make: sleeve_torso_grid,
    },
    Fixture {
        name: "sleeve_torso_jitter",
        description: "sleeve_torso_grid jittered",
        close_holes: true,
        make: || jittered(sleeve_torso_grid()),
    },
    Fixture {
        name: "folded_sheet_grid",
        description: "folded_sheet(size 1, n 40); 6,400 faces, open sheet (face pairs only, no volume)",
        close_holes: false,
        make: folded_sheet_grid,
    },
    Fixture {
        name: "folded_sheet_jitter",
        description: "folded_sheet_grid jittered",
        close_holes: false,
        make: || jittered(folded_sheet_grid()),
    },
    Fixture {
        name: "garment_benchmark",
        description: "garment_benchmark(); 13,152 faces, sleeve pressed 2 cm into torso, 4 holes closed by fans for volumes",
        close_holes: true,
        make: garment_benchmark,
    },
    Fixture {
        name: "sphere_l5",
        description: "icosphere((0,0,0),1,5); 20,480 faces, no crossings (benchmark)",
        close_holes: false,
        make: sphere_l5,
    },
    Fixture {
        name: "torus_bench",
        description: "torus(1, 0.3, 128, 48); 12,288 faces, no crossings (benchmark)",
        close_holes: false,
        make: torus_bench,
    },
];

/// Generates the named fixture (see [`FIXTURES`]).
pub fn fixture(name: &str) -> Result<TriMesh, ShapeError> {
    FIXTURES
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| ShapeError::UnknownFixture { name: name.to_owned() })?
        .build()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn box_is_closed_with_exact_volume_and_counts() {
        let m = grid_box(v(-0.5, 0.0, 1.0), v(1.5, 0.75, 1.5), 5).unwrap();
        assert_eq!(m.n_faces(), 12 * 25);
        assert_eq!(m.n_vertices(), 6 * 25 + 2);
        assert!(m.topology().boundary_loops().is_empty());
        assert_eq!(m.topology().n_components(), 1);
        assert!(rel(m.signed_volume(), 2.0 * 0.75 * 0.5) < 1e-14, "{}", m.signed_volume());
        // n = 1: the 12-triangle cube.
        let c = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 1).unwrap();
        assert_eq!((c.n_faces(), c.n_vertices()), (12, 8));
        assert_eq!(c.signed_volume(), 1.0);
    }

    #[test]
    fn box_vertices_are_on_the_exact_lattice() {
        let m = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 8).unwrap();
        for p in m.positions() {
            for x in p.iter() {
                assert_eq!((x * 8.0).fract(), 0.0, "{p:?}");
            }
        }
    }

    #[test]
    fn icosphere_volume_between_inscribed_and_circumscribed_balls() {
        for level in 0..=4 {
            let (r, c) = (0.7, v(1.0, -2.0, 0.5));
            let m = icosphere(c, r, level).unwrap();
            assert_eq!(m.n_faces(), 20 * 4usize.pow(level as u32));
            assert!(m.topology().boundary_loops().is_empty());
            // Smallest distance from the centre to a face plane.
            let r_in = (0..m.n_faces())
                .map(|f| {
                    let n = m.face_normal_scaled(f).normalize();
                    let d = n.dot(&(m.triangle(f)[0] - c));
                    assert!(d > 0.0, "face {f} not outward");
                    d
                })
                .fold(f64::INFINITY, f64::min);
            let vol = m.signed_volume();
            let ball = |x: f64| 4.0 / 3.0 * PI * x.powi(3);
            assert!(vol > ball(r_in) && vol < ball(r), "level {level}: {vol}");
            if level == 4 {
                assert!(rel(vol, ball(r)) < 0.004, "{}", rel(vol, ball(r)));
            }
        }
    }

    #[test]
    fn capped_tube_is_the_polygonal_prism() {
        let (r, l, n) = (0.3, 2.0, 17);
        let m = tube(r, l, n, 5, Caps::Fan).unwrap();
        assert!(m.topology().boundary_loops().is_empty());
        let prism = 0.5 * n as f64 * r * r * (TAU / n as f64).sin() * l;
        assert!(rel(m.signed_volume(), prism) < 1e-13);
        let open = tube(r, l, n, 5, Caps::Open).unwrap();
        assert_eq!(open.topology().boundary_loops().len(), 2);
        assert_eq!(open.n_faces(), 2 * 17 * 5);
        // Outward: every side face's normal points away from the axis.
        for f in 0..open.n_faces() {
            let [a, b, c] = open.triangle(f);
            let mid = (a + b + c) / 3.0;
            assert!(open.face_normal_scaled(f).dot(&v(mid.x, mid.y, 0.0)) > 0.0);
        }
    }

    #[test]
    fn torus_volume_close_to_analytic() {
        let (big, small, n1, n2) = (1.0, 0.3, 64, 24);
        let m = torus(big, small, n1, n2).unwrap();
        assert!(m.topology().boundary_loops().is_empty());
        assert_eq!(m.n_faces(), 2 * n1 * n2);
        let exact = 2.0 * PI * PI * big * small * small;
        let tol = 1.5 * ((TAU / n1 as f64).powi(2) + (TAU / n2 as f64).powi(2)) / 6.0;
        let e = rel(m.signed_volume(), exact);
        assert!(e < tol, "{e} vs {tol}");
        // A finer torus is closer.
        let fine = torus(big, small, 2 * n1, 2 * n2).unwrap();
        assert!(rel(fine.signed_volume(), exact) < e / 3.0);
        assert!(torus(1.0, 1.0, 8, 8).is_err());
    }

    #[test]
    fn bent_tube_is_closed_and_each_ring_sits_on_its_leg() {
        let m = bent_tube_grid().unwrap();
        assert!(m.topology().boundary_loops().is_empty());
        assert_eq!(m.n_faces(), 64 * 48 * 2 + 128);
        // Leg A: the z <= 0 half of the straight tube; leg B: the rest, rotated 135° about y
        // and shifted 0.02 along y.
        let d_b = Rotation3::from_axis_angle(&Vec3::y_axis(), 135f64.to_radians()) * Vec3::z();
        let (mut on_a, mut on_b) = (0, 0);
        for p in m.positions() {
            let q = p - Vec3::new(0.0, 0.02, 0.0);
            let to_b = q - d_b * q.dot(&d_b);
            if p.z <= 0.0 && (p.xy().norm() - 0.1).abs() < 1e-12 {
                on_a += 1;
            } else if q.dot(&d_b) > 0.0 && (to_b.norm() - 0.1).abs() < 1e-12 {
                on_b += 1;
            }
        }
        assert_eq!((on_a, on_b), (64 * 25, 64 * 24), "ring vertices off their leg");
        // The elbow's wedge changes the volume a little from the straight prism (each leg
        // keeps its own), never its sign.
        let prism = 0.5 * 64.0 * 0.01 * (TAU / 64.0).sin() * 1.2;
        assert!(rel(m.signed_volume(), prism) < 0.05, "{} vs {prism}", m.signed_volume());
        assert!(bent_tube(0.1, 0.6, PI, 0.0, 8, 2).is_err());
    }

    #[test]
    fn sleeve_torso_has_four_holes_and_two_components() {
        let m = sleeve_torso_grid().unwrap();
        assert_eq!(m.topology().boundary_loops().len(), 4);
        assert_eq!(m.topology().n_components(), 2);
        assert_eq!(m.n_faces(), 96 * 32 * 2 + 32 * 16 * 2);
        // Closed by fans: both tubes become prisms; the signed volume is their sum.
        let closed = crate::close_holes(&m, &crate::HoleSelection::All).unwrap();
        let p = SleeveTorso::default();
        let prism = |r: f64, l: f64, n: usize| 0.5 * n as f64 * r * r * (TAU / n as f64).sin() * l;
        let expect = prism(p.torso_radius, p.torso_height, 96) + prism(p.sleeve_radius, 0.27, 32);
        assert!(rel(closed.mesh().signed_volume(), expect) < 1e-12);
    }

    #[test]
    fn garment_benchmark_is_big_open_and_closable() {
        let m = garment_benchmark().unwrap();
        assert!(m.n_faces() >= 10_000);
        assert_eq!(m.n_faces(), 13_152);
        assert_eq!(m.topology().boundary_loops().len(), 4);
        assert_eq!(m.topology().n_components(), 2);
        let closed = crate::close_holes(&m, &crate::HoleSelection::All).unwrap();
        assert!(closed.mesh().signed_volume() > 0.0);
        // Deterministic.
        assert_eq!(garment_benchmark().unwrap().positions(), m.positions());
    }

    #[test]
    fn sheets_have_one_loop_and_the_fold_dips_below() {
        let s = grid_sheet(2.0, 1.0, 4, 3).unwrap();
        assert_eq!(s.topology().boundary_loops().len(), 1);
        assert_eq!(s.topology().boundary_loops()[0].len(), 2 * (4 + 3));
        assert!((s.area() - 2.0).abs() < 1e-14);
        assert!((0..s.n_faces()).all(|f| s.face_normal_scaled(f).z > 0.0));
        let f = folded_sheet_grid().unwrap();
        assert_eq!(f.topology().boundary_loops().len(), 1);
        let zs: Vec<f64> = f.positions().iter().map(|p| p.z).collect();
        assert!(zs.iter().any(|&z| z < 0.0) && zs.iter().any(|&z| z > 0.0));
    }

    #[test]
    fn jitter_is_seeded_small_and_validated() {
        let m = unit_box().unwrap();
        let a = jitter(&m, 1e-3, 5).unwrap();
        assert_eq!(a.positions(), jitter(&m, 1e-3, 5).unwrap().positions());
        assert_ne!(a.positions(), jitter(&m, 1e-3, 6).unwrap().positions());
        let d = m.bounding_diagonal();
        for (p, q) in m.positions().iter().zip(a.positions()) {
            assert!((p - q).amax() <= 1e-3 * d);
            assert!(p != q);
        }
        assert_eq!(jitter(&m, 0.0, 1).unwrap().positions(), m.positions());
        assert!(jitter(&m, f64::NAN, 1).is_err());
    }

    #[test]
    fn rigid_transform_and_merge_keep_volumes() {
        let m = icosphere(v(0.0, 0.0, 0.0), 1.0, 2).unwrap();
        let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let t = rigid_transform(&m, &rot, &v(3.0, -4.0, 5.0)).unwrap();
        assert!(rel(t.signed_volume(), m.signed_volume()) < 1e-12);
        let both = merge(&m, &t).unwrap();
        assert_eq!(both.n_faces(), 2 * m.n_faces());
        assert_eq!(both.topology().n_components(), 2);
        assert!(rel(both.signed_volume(), 2.0 * m.signed_volume()) < 1e-12);
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        assert!(matches!(grid_box(v(0.0, 0.0, 0.0), v(1.0, 0.0, 1.0), 2), Err(ShapeError::InvalidParameter { .. })));
        assert!(grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 0).is_err());
        assert!(icosphere(v(0.0, 0.0, 0.0), -1.0, 2).is_err());
        assert!(icosphere(v(0.0, 0.0, 0.0), f64::NAN, 2).is_err());
        assert!(tube(1.0, 1.0, 2, 1, Caps::Open).is_err());
        assert!(folded_sheet(1.0, 1).is_err());
        assert!(matches!(fixture("nope"), Err(ShapeError::UnknownFixture { .. })));
    }

    #[test]
    fn every_fixture_builds_and_names_are_unique() {
        let mut names: Vec<&str> = FIXTURES.iter().map(|f| f.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), FIXTURES.len());
        for f in FIXTURES {
            let m = f.build().unwrap();
            assert!(m.n_faces() > 1000, "{}", f.name);
        }
    }

    /// The committed answer files record each fixture's size and coordinate sums; a change
    /// of generator that would silently invalidate the answers fails here.
    #[test]
    fn committed_fixture_answers_match_the_generators() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures");
        let mut checked = 0;
        for f in FIXTURES {
            let path = dir.join(format!("{}.json", f.name));
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}; regenerate with tools/libigl_answers.py", path.display()));
            let json: serde_json::Value = serde_json::from_str(&text).unwrap();
            let m = f.build().unwrap();
            assert_eq!(json["n_vertices"].as_u64(), Some(m.n_vertices() as u64), "{}", f.name);
            assert_eq!(json["n_faces"].as_u64(), Some(m.n_faces() as u64), "{}", f.name);
            let sum: f64 = m.positions().iter().map(|p| p.x + 2.0 * p.y + 3.0 * p.z).sum();
            let scale: f64 = m.positions().iter().map(|p| p.x.abs() + 2.0 * p.y.abs() + 3.0 * p.z.abs()).sum();
            let want = json["coordinate_checksum"].as_f64().unwrap();
            // Rounding and libm differences stay far below this; a 1e-9 jitter does not.
            assert!((sum - want).abs() <= 1e-13 * (1.0 + scale), "{}: {sum} vs {want}", f.name);
            // The answers themselves: pairs sorted, unique, in range; exact volumes match.
            let pairs: Vec<[u64; 2]> = json["intersecting_face_pairs"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [p[0].as_u64().unwrap(), p[1].as_u64().unwrap()])
                .collect();
            assert_eq!(pairs.len() as u64, json["n_intersecting_face_pairs"].as_u64().unwrap());
            assert!(pairs.windows(2).all(|w| w[0] < w[1]), "{}: pairs not sorted", f.name);
            assert!(pairs.iter().all(|p| p[0] < p[1] && p[1] < m.n_faces() as u64), "{}", f.name);
            if let (Some(vol), Some(exact)) =
                (json["penetration_volume_m3"].as_f64(), json["analytic_volume_m3"].as_f64())
            {
                assert!((vol - exact).abs() <= 1e-12 * exact.max(1.0), "{}: {vol} vs {exact}", f.name);
            }
            checked += 1;
        }
        assert_eq!(checked, FIXTURES.len());
    }
}
