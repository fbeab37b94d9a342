//! Joining two open meshes along one boundary loop of each by a band of triangles (a
//! zipper), for garments sewn from parts: a dress is a top zipped to a skirt.
//!
//! # Behavior
//! The two seams (one boundary loop per part) are walked in the same rotational direction
//! around their common axis (the mean of their planes' normals), angles measured around each
//! seam's own centre, from the first seam's first vertex and the second seam's vertex
//! closest to it in angle; each step
//! emits one triangle that advances along one seam, the one whose new rung (the edge from
//! one seam to the other) is shorter, unless that rung was used before (possible when one
//! seam would be walked all the way round first): then it advances along the other. The
//! band has one triangle per seam edge, so seams of
//! different vertex counts, radii and heights are joined without new vertices. The band is
//! wound so that the joined surface keeps the parts' orientation: each seam edge is
//! traversed by the band against its part's faces.
//!
//! A seam's rotational direction is the one its faces give it (see
//! [`senc_geom::Topology`]'s boundary loop convention). Two parts oriented alike (normals
//! both outward) meet with seams running opposite ways around the axis, like the two ends
//! of a tube; seams running the same way would need a band that twists through itself, and
//! are refused ([`ZipError::SameDirection`]).
//!
//! # Example
//! ```
//! use senc_geom::{TriMesh, Vec3};
//! use senc_scene::zipper::{find_loop, zip_loops, LoopAt, Part};
//!
//! // An open tube around the y axis from `y0` to `y1`, normals outward.
//! let tube = |n: usize, r: f64, y0: f64, y1: f64| {
//!     let ring = |y: f64| (0..n).map(move |k| {
//!         let t = std::f64::consts::TAU * k as f64 / n as f64;
//!         Vec3::new(r * t.cos(), y, -r * t.sin())
//!     });
//!     let positions: Vec<Vec3> = ring(y0).chain(ring(y1)).collect();
//!     let n32 = n as u32;
//!     let faces = (0..n32)
//!         .flat_map(|k| {
//!             let (a, b) = (k, (k + 1) % n32);
//!             [[a, b, b + n32], [a, b + n32, a + n32]]
//!         })
//!         .collect();
//!     TriMesh::new(positions, faces).unwrap()
//! };
//! let (skirt, top) = (tube(12, 0.15, -0.3, 0.0), tube(8, 0.12, 0.03, 0.3));
//! let (ws, wt) = (vec![vec![(0, 1.0)]; 24], vec![vec![(1, 1.0)]; 16]);
//! let waist = find_loop(&skirt, LoopAt::Highest).unwrap();
//! let cut = find_loop(&top, LoopAt::Lowest).unwrap();
//! let dress = zip_loops(
//!     Part { mesh: &top, weights: &wt, seam: &cut },
//!     Part { mesh: &skirt, weights: &ws, seam: &waist },
//! )
//! .unwrap();
//! assert_eq!(dress.mesh.topology().n_components(), 1);
//! assert_eq!(dress.mesh.topology().boundary_loops().len(), 2);
//! assert_eq!(dress.band.len(), 12 + 8);
//! ```

use std::collections::HashSet;
use std::ops::Range;

use senc_geom::{MeshError, TriMesh, Vec3};

/// Largest angle between the planes of two seams that [`zip_loops`] joins, degrees. A
/// garment's seams face each other across a small gap (a skirt's waist and the cut of a top
/// are a few degrees apart); past 45° the loops no longer share an axis and the order by
/// angle around it means nothing.
pub const MAX_SEAM_TILT_DEG: f64 = 45.0;

/// Smallest ratio of a seam's enclosed (vector) area to its squared perimeter for which
/// [`zip_loops`] can order its vertices by angle. A circle has `1 / (4π) ≈ 0.08`, an
/// ellipse with axes 1:20 about 0.01; below `1e-4` the loop is flat or folded onto itself.
pub const MIN_SEAM_ROUNDNESS: f64 = 1e-4;

/// Why two parts could not be zipped or a seam could not be found. Each variant says how
/// to fix the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZipError {
    /// The mesh has no boundary loop.
    #[error("the mesh has no boundary loop (a closed surface has no seam); cut it open first")]
    NoLoop,
    /// A seam is not one of its mesh's boundary loops, in the winding order of its faces.
    #[error("the seam of the {part} part is not a boundary loop of its mesh in its faces' winding order ({detail}); take it from `find_loop` or `mesh.topology().boundary_loops()`")]
    NotABoundaryLoop {
        /// `"first"` or `"second"`.
        part: &'static str,
        /// Where it fails.
        detail: String,
    },
    /// A seam has too few vertices, passes twice through a vertex, or encloses no area.
    #[error("the seam of the {part} part is degenerate: {reason}; zip a loop that goes once around an opening")]
    DegenerateLoop {
        /// `"first"` or `"second"`.
        part: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The seams' planes are too far from parallel to share an axis.
    #[error("the seams' planes are {tilt_deg:.1}° apart (at most {MAX_SEAM_TILT_DEG}°): they do not face each other along a common axis; zip loops that do (a waist to a waist, not a waist to an armhole)")]
    NotCoaxial {
        /// Angle between the two seams' planes, degrees.
        tilt_deg: f64,
    },
    /// Seen along the common axis, a seam does not go once around its own centre.
    #[error("seen along the common axis, the seam of the {part} part goes {turns} times around its centre instead of once (a strongly non-convex loop); zip loops that go once around the axis")]
    NotAroundAxis {
        /// `"first"` or `"second"`.
        part: &'static str,
        /// Signed number of turns around the centre.
        turns: i64,
    },
    /// Both seams run the same way around their common axis, so the parts are oriented
    /// against each other.
    #[error("both seams run the same way around their common axis: the parts are oriented against each other and the band would twist through itself; reverse the winding of every face of one part (`[a, b, c]` to `[a, c, b]`) and take its seam again")]
    SameDirection,
    /// A part's weight lists do not match its vertices.
    #[error("the {part} part has {vertices} vertices but {weights} weight lists; give one list per vertex")]
    WeightCount {
        /// `"first"` or `"second"`.
        part: &'static str,
        /// Its vertices.
        vertices: usize,
        /// Its weight lists.
        weights: usize,
    },
    /// The joined mesh is not valid (a band triangle with zero area: seam vertices that
    /// coincide).
    #[error("the joined mesh is invalid: {0}; move the seams apart (coinciding seam vertices give zero-area band triangles)")]
    Mesh(#[from] MeshError),
}

/// Which boundary loop [`find_loop`] picks, by its height: the mean `y` of its vertices
/// (Y is up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoopAt {
    /// The loop with the lowest mean height.
    Lowest,
    /// The loop with the highest mean height.
    Highest,
    /// The loop whose mean height is closest to this one, m.
    NearestHeight(f64),
}

/// The boundary loop of `mesh` that `at` picks, in the winding order of its faces (as
/// [`senc_geom::Topology::boundary_loops`] gives it). Ties go to the first loop in that
/// list. Fails with [`ZipError::NoLoop`] on a closed mesh.
pub fn find_loop(mesh: &TriMesh, at: LoopAt) -> Result<Vec<u32>, ZipError> {
    let loops = mesh.topology().boundary_loops();
    let height = |l: &Vec<u32>| l.iter().map(|&v| mesh.positions()[v as usize].y).sum::<f64>() / l.len() as f64;
    let key = |l: &Vec<u32>| match at {
        LoopAt::Lowest => height(l),
        LoopAt::Highest => -height(l),
        LoopAt::NearestHeight(y) => (height(l) - y).abs(),
    };
    loops.iter().min_by(|a, b| key(a).total_cmp(&key(b))).cloned().ok_or(ZipError::NoLoop)
}

/// One part of a zip: a mesh, its per-vertex weight lists and the boundary loop to join.
#[derive(Debug, Clone, Copy)]
pub struct Part<'a> {
    /// The part's surface.
    pub mesh: &'a TriMesh,
    /// One weight list per vertex of `mesh` (see [`crate::build::WeightLists`]).
    pub weights: &'a [Vec<(u16, f32)>],
    /// A boundary loop of `mesh` in its faces' winding order, starting at any of its
    /// vertices (from [`find_loop`] or `mesh.topology().boundary_loops()`).
    pub seam: &'a [u32],
}

/// Two parts joined by [`zip_loops`].
#[derive(Debug, Clone)]
pub struct Zipped {
    /// The joined surface: the first part's vertices, then the second's (numbered from the
    /// first's vertex count); the first part's faces, then the second's (renumbered), then
    /// the band's.
    pub mesh: TriMesh,
    /// The weight lists of `mesh`'s vertices, carried with them.
    pub weights: Vec<Vec<(u16, f32)>>,
    /// Face indices of the band in `mesh.faces()`.
    pub band: Range<usize>,
}

/// Joins `a` and `b` along their seams by a band of triangles (see the module doc). No
/// vertex is added or moved; every face of both parts is kept with its winding.
///
/// Fails when a seam is not a boundary loop of its mesh, is degenerate, the seams do not
/// share an axis or run the same way around it ([`ZipError`]), or when the weight lists do
/// not match the vertices.
///
/// # Performance
/// `O(n_vertices + n_faces)` to copy the parts; the seams are checked and walked in
/// `O(seam length)` plus one pass over the boundary loops of each part.
pub fn zip_loops(a: Part<'_>, b: Part<'_>) -> Result<Zipped, ZipError> {
    for (part, p) in [("first", &a), ("second", &b)] {
        if p.weights.len() != p.mesh.n_vertices() {
            return Err(ZipError::WeightCount { part, vertices: p.mesh.n_vertices(), weights: p.weights.len() });
        }
        check_seam(part, p.mesh, p.seam)?;
    }
    let pa: Vec<Vec3> = a.seam.iter().map(|&v| a.mesh.positions()[v as usize]).collect();
    let pb: Vec<Vec3> = b.seam.iter().map(|&v| b.mesh.positions()[v as usize]).collect();
    let na = vector_area("first", &pa)?;
    let nb = vector_area("second", &pb)?;
    let cos = na.dot(&nb);
    let tilt_deg = cos.abs().min(1.0).acos().to_degrees();
    if tilt_deg > MAX_SEAM_TILT_DEG {
        return Err(ZipError::NotCoaxial { tilt_deg });
    }
    // The axis along which both seams are seen: their normals agree up to sign.
    let axis = (na + nb * cos.signum()).normalize();
    let (u, v) = plane_basis(&axis);
    let angle_a = angles(&pa, &u, &v);
    let angle_b = angles(&pb, &u, &v);
    let turns_a = turns(&angle_a);
    let turns_b = turns(&angle_b);
    for (part, t) in [("first", turns_a), ("second", turns_b)] {
        if t.abs() != 1 {
            return Err(ZipError::NotAroundAxis { part, turns: t });
        }
    }
    if turns_a == turns_b {
        return Err(ZipError::SameDirection);
    }

    // Seam b reversed runs the same way as seam a; it starts at the vertex closest in
    // angle to a's first.
    let m = b.seam.len();
    let start = (0..m)
        .min_by(|&i, &j| wrap(angle_b[i] - angle_a[0]).abs().total_cmp(&wrap(angle_b[j] - angle_a[0]).abs()))
        .unwrap_or(0);
    let offset = a.mesh.n_vertices() as u32;
    let seam_b: Vec<u32> = (0..m).map(|k| b.seam[(start + m - k) % m]).collect();
    let pos_b: Vec<Vec3> = (0..m).map(|k| pb[(start + m - k) % m]).collect();
    let n = a.seam.len();
    let mut band = Vec::with_capacity(n + m);
    // Rungs used so far, as (i mod n, j mod m): a step onto one of them (other than the
    // closing rung (n, m), which is (0, 0)) would give an edge four faces.
    let mut used = HashSet::with_capacity(n + m);
    used.insert((0, 0));
    let free =
        |used: &HashSet<(usize, usize)>, i: usize, j: usize| (i == n && j == m) || !used.contains(&(i % n, j % m));
    let (mut i, mut j) = (0, 0);
    while i < n || j < m {
        let can_a = i < n && free(&used, i + 1, j);
        let can_b = j < m && free(&used, i, j + 1);
        let advance_a = if can_a && can_b {
            (pa[(i + 1) % n] - pos_b[j % m]).norm() <= (pa[i % n] - pos_b[(j + 1) % m]).norm()
        } else {
            can_a
        };
        let (ai, bj) = (a.seam[i % n], seam_b[j % m] + offset);
        if advance_a {
            band.push([a.seam[(i + 1) % n], ai, bj]);
            i += 1;
        } else {
            band.push([bj, seam_b[(j + 1) % m] + offset, ai]);
            j += 1;
        }
        used.insert((i % n, j % m));
    }

    let mut positions = a.mesh.positions().to_vec();
    positions.extend_from_slice(b.mesh.positions());
    let mut faces = a.mesh.faces().to_vec();
    faces.extend(b.mesh.faces().iter().map(|f| f.map(|x| x + offset)));
    let band_range = faces.len()..faces.len() + band.len();
    faces.extend(band);
    let mut weights = a.weights.to_vec();
    weights.extend_from_slice(b.weights);
    Ok(Zipped { mesh: TriMesh::new(positions, faces)?, weights, band: band_range })
}

/// Checks that `seam` is a boundary loop of `mesh` (any start, the faces' winding order).
fn check_seam(part: &'static str, mesh: &TriMesh, seam: &[u32]) -> Result<(), ZipError> {
    if seam.len() < 3 {
        return Err(ZipError::DegenerateLoop { part, reason: format!("{} vertices, at least 3 needed", seam.len()) });
    }
    let mut seen = HashSet::with_capacity(seam.len());
    for &v in seam {
        if !seen.insert(v) {
            return Err(ZipError::DegenerateLoop { part, reason: format!("it passes twice through vertex {v}") });
        }
    }
    let Some(found) = mesh.topology().boundary_loops().iter().find(|l| l.contains(&seam[0])) else {
        return Err(ZipError::NotABoundaryLoop { part, detail: format!("vertex {} is not on the boundary", seam[0]) });
    };
    let at = found.iter().position(|&v| v == seam[0]).unwrap_or(0);
    if found.len() != seam.len() {
        return Err(ZipError::NotABoundaryLoop {
            part,
            detail: format!(
                "the boundary loop through vertex {} has {} vertices, the seam {}",
                seam[0],
                found.len(),
                seam.len()
            ),
        });
    }
    for (k, &v) in seam.iter().enumerate() {
        let expected = found[(at + k) % found.len()];
        if v != expected {
            return Err(ZipError::NotABoundaryLoop {
                part,
                detail: format!("seam vertex {k} is {v}, the boundary loop has {expected} there"),
            });
        }
    }
    Ok(())
}

/// Unit normal of a closed polygon from its vector area `½ Σ (p_k - c) × (p_{k+1} - c)`;
/// refuses loops whose area is below [`MIN_SEAM_ROUNDNESS`] times the squared perimeter.
fn vector_area(part: &'static str, points: &[Vec3]) -> Result<Vec3, ZipError> {
    let c = centroid(points);
    let n = points.len();
    let mut area = Vec3::zeros();
    let mut perimeter = 0.0;
    for k in 0..n {
        let (p, q) = (points[k] - c, points[(k + 1) % n] - c);
        area += p.cross(&q) * 0.5;
        perimeter += (q - p).norm();
    }
    let ratio = area.norm() / (perimeter * perimeter);
    if !(ratio >= MIN_SEAM_ROUNDNESS) {
        return Err(ZipError::DegenerateLoop {
            part,
            reason: format!(
                "it encloses almost no area (area / perimeter² = {ratio:.2e}, at least {MIN_SEAM_ROUNDNESS:e})"
            ),
        });
    }
    Ok(area / area.norm())
}

fn centroid(points: &[Vec3]) -> Vec3 {
    points.iter().fold(Vec3::zeros(), |s, p| s + p) / points.len() as f64
}

/// Two unit vectors that make a right-handed frame `(u, v, axis)`.
fn plane_basis(axis: &Vec3) -> (Vec3, Vec3) {
    let k = axis.iamin();
    let mut e = Vec3::zeros();
    e[k] = 1.0;
    let u = (e - axis * axis.dot(&e)).normalize();
    (u, axis.cross(&u))
}

/// Angle of each point around the points' centroid in the plane `(u, v)`, radians.
fn angles(points: &[Vec3], u: &Vec3, v: &Vec3) -> Vec<f64> {
    let c = centroid(points);
    points.iter().map(|p| (p - c).dot(v).atan2((p - c).dot(u))).collect()
}

/// An angle difference brought into `(-π, π]`.
fn wrap(d: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = d.rem_euclid(t);
    if r > std::f64::consts::PI {
        r - t
    } else {
        r
    }
}

/// Signed number of turns of a closed polygon around the origin of its angles.
fn turns(angle: &[f64]) -> i64 {
    let n = angle.len();
    let total: f64 = (0..n).map(|k| wrap(angle[(k + 1) % n] - angle[k])).sum();
    (total / std::f64::consts::TAU).round() as i64
}
