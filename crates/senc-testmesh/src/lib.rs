//! senc-testmesh: procedural, deterministic meshes for senc's tests, fixtures, benchmarks
//! and examples, and nothing else (every crate takes it as a dev-dependency): grid-made
//! boxes, icospheres, tubes, tori, a tube bent through itself, a sleeve pushed through a
//! torso, flat and folded sheets, plus jitter, rigid motion and disjoint union; a jittered
//! sheet, a UV sphere and the energy benchmark's scene ([`scenes`]).
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
//! answer file there, so no mesh file needs to be committed. The garment frames simulated by
//! the project's networks (`tests/fixtures/garment_frames/`) are read by [`garment_frame`].
//!
//! # Example
//! ```
//! use senc_testmesh as shapes;
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

use senc_geom::{MeshError, TriMesh, Vec3};

mod fixtures;
pub mod scenes;
#[cfg(test)]
mod tests;

#[cfg(test)]
use fixtures::*;
pub use fixtures::{fixture, Fixture, FIXTURES, FIXTURE_JITTER, FIXTURE_SEED};
pub use scenes::{bench_scene, sheet, sphere, BenchScene};

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
    #[error("unknown fixture `{name}`; the names are listed in senc_testmesh::FIXTURES")]
    UnknownFixture {
        /// The name asked for.
        name: String,
    },
    /// The generated mesh failed validation (a bug in the generator or parameters that
    /// collapse faces, e.g. a jitter larger than the faces).
    #[error("generated mesh is invalid: {0}")]
    Mesh(#[from] MeshError),
    /// A committed garment frame could not be read ([`garment_frame`]).
    #[error("cannot read the garment frame file {path}: {reason} (the frames are in tests/fixtures/garment_frames/)")]
    GarmentFrame {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
}

/// The positions and faces of a committed garment frame,
/// `tests/fixtures/garment_frames/{garment}_faces.msgpack` and `{garment}_{frame:04}.msgpack`
/// (e.g. `garment_frame_parts("tshirt", 20)`), as stored: not validated as a mesh.
pub fn garment_frame_parts(garment: &str, frame: u32) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ShapeError> {
    fn read<T: serde::de::DeserializeOwned>(path: String) -> Result<T, ShapeError> {
        let bytes =
            std::fs::read(&path).map_err(|e| ShapeError::GarmentFrame { path: path.clone(), reason: e.to_string() })?;
        rmp_serde::from_slice(&bytes).map_err(|e| ShapeError::GarmentFrame { path, reason: e.to_string() })
    }
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/garment_frames");
    let faces: Vec<[u32; 3]> = read(format!("{dir}/{garment}_faces.msgpack"))?;
    let pos: Vec<[f64; 3]> = read(format!("{dir}/{garment}_{frame:04}.msgpack"))?;
    Ok((pos.into_iter().map(Vec3::from).collect(), faces))
}

/// A committed garment frame as a validated mesh (see [`garment_frame_parts`]).
pub fn garment_frame(garment: &str, frame: u32) -> Result<TriMesh, ShapeError> {
    let (pos, faces) = garment_frame_parts(garment, frame)?;
    Ok(TriMesh::new(pos, faces)?)
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
    let positions = offset_positions(mesh, rel * mesh.bounding_diagonal(), seed);
    Ok(TriMesh::new(positions, mesh.faces().to_vec())?)
}

/// Each vertex of `mesh` moved by an independent uniform offset in `[-1, 1]³ · scale`
/// (ChaCha8 seeded by `seed`).
fn offset_positions(mesh: &TriMesh, scale: f64, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    mesh.positions()
        .iter()
        .map(|p| {
            let d = Vec3::new(rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0));
            p + d * scale
        })
        .collect()
}

/// Crumples `mesh`: each vertex moves by an independent uniform offset in `[-1, 1]³ · amp`
/// (m), then every coordinate is rounded to a multiple of `grid` (m), so that exact
/// coincidences abound: coincident vertices, faces of zero area, coplanar faces crossing.
/// Seeded (ChaCha8). Faces are kept as they are (zero-area faces included); `amp` finite
/// and `>= 0`, `grid` finite and `> 0`.
pub fn crumple_snapped(mesh: &TriMesh, amp: f64, grid: f64, seed: u64) -> Result<TriMesh, ShapeError> {
    if !(amp.is_finite() && amp >= 0.0) {
        return Err(ShapeError::InvalidParameter { name: "amp", value: amp, requirement: "must be finite and >= 0" });
    }
    if !(grid.is_finite() && grid > 0.0) {
        return Err(ShapeError::InvalidParameter { name: "grid", value: grid, requirement: "must be finite and > 0" });
    }
    let mut positions = offset_positions(mesh, amp, seed);
    for p in &mut positions {
        *p = p.map(|c| (c / grid).round() * grid);
    }
    Ok(mesh.with_positions(positions)?)
}

/// `p ↦ rotation · p + translation` applied to every vertex; faces and topology are kept
/// (orientation is preserved, a rotation having determinant +1).
pub fn rigid_transform(mesh: &TriMesh, rotation: &Rotation3<f64>, translation: &Vec3) -> Result<TriMesh, ShapeError> {
    let positions = mesh.positions().iter().map(|p| rotation * p + translation).collect();
    Ok(mesh.with_positions(positions)?)
}

/// The same mesh with every face turned over (normals reversed, winding −1 inside a closed
/// surface that had +1).
pub fn turned_over(mesh: &TriMesh) -> Result<TriMesh, ShapeError> {
    Ok(TriMesh::new(mesh.positions().to_vec(), mesh.faces().iter().map(|&[a, b, c]| [a, c, b]).collect())?)
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
