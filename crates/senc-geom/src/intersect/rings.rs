//! Vertex rings: which rings of faces project without overlap, so that faces sharing only
//! that vertex cannot cross ([`embedded_rings`]).

use super::*;

/// Vertex-ring shapes that decide which ring test applies (topology only).
pub(super) const RING_OTHER: u8 = 0;
pub(super) const RING_CLOSED: u8 = 1;
pub(super) const RING_OPEN: u8 = 2;

/// Cached answers of the lazy ring test ([`Traversal::ring_embedded`]).
pub(super) const RING_UNKNOWN: u8 = 0;
pub(super) const RING_YES: u8 = 1;
pub(super) const RING_NO: u8 = 2;

/// Per vertex, the shape of its ring of faces (topology only): one closed fan (every
/// neighbour in exactly two ring faces), one open fan (exactly two neighbours once, the rest
/// twice), or anything else (a pinched or empty ring).
///
/// A neighbour `v` of `s` lies in as many ring faces as the edge `(s, v)` has faces (one or
/// two: a [`Topology`] has no edge of more), so the kind follows from the number of
/// boundary edges at `s`: none (closed), two (open), any other number (other); a vertex of
/// no face is other.
pub(super) fn ring_kinds(mesh: &TriMesh) -> Vec<u8> {
    let topo = mesh.topology();
    let mut n_boundary = vec![0u8; mesh.n_vertices()];
    for (&[a, b], &[_, g]) in topo.edges().iter().zip(topo.edge_faces()) {
        if g == NO_FACE {
            n_boundary[a as usize] = n_boundary[a as usize].saturating_add(1);
            n_boundary[b as usize] = n_boundary[b as usize].saturating_add(1);
        }
    }
    n_boundary
        .iter()
        .enumerate()
        .map(|(s, &nb)| {
            if topo.vertex_faces(s as u32).is_empty() {
                RING_OTHER
            } else {
                match nb {
                    0 => RING_CLOSED,
                    2 => RING_OPEN,
                    _ => RING_OTHER,
                }
            }
        })
        .collect()
}

/// For each vertex, whether its ring of faces projects without overlap onto the plane normal
/// to the ring's summed normal (see [`ring_is_embedded`]); two faces of an embedded ring
/// that share only that vertex cannot cross, and the broad phase drops them before any
/// predicate. This removes most pairs on smooth or flat (even exactly coplanar)
/// tessellations, where exact predicates are slow.
pub fn embedded_rings(mesh: &TriMesh) -> Vec<bool> {
    let kinds = ring_kinds(mesh);
    let (start, links) = ring_links(mesh);
    (0..mesh.n_vertices() as u32)
        .into_par_iter()
        .with_min_len(512)
        .map(|s| {
            let links = &links[start[s as usize] as usize..start[s as usize + 1] as usize];
            ring_is_embedded(mesh.positions(), s, kinds[s as usize], links)
        })
        .collect()
}

/// Per vertex `s`, the wedges `(a, b)` of the faces `(s, a, b)` of its ring (in the mesh's
/// vertex-face order), as `links[start[s]..start[s + 1]]`. Topology only.
pub(super) fn ring_links(mesh: &TriMesh) -> (Vec<u32>, Vec<[u32; 2]>) {
    let topo = mesh.topology();
    let faces = mesh.faces();
    let mut start = Vec::with_capacity(mesh.n_vertices() + 1);
    let mut links = Vec::with_capacity(3 * faces.len());
    start.push(0);
    for s in 0..mesh.n_vertices() as u32 {
        for &f in topo.vertex_faces(s) {
            let fv = faces[f as usize];
            let k = fv.iter().position(|&v| v == s).unwrap_or(0);
            links.push([fv[(k + 1) % 3], fv[(k + 2) % 3]]);
        }
        start.push(links.len() as u32);
    }
    (start, links)
}

/// `sin` of the smallest wedge angle accepted (1e-9 rad); far above the rounding of the
/// projected coordinates, so a wedge accepted in floats is a true, positive wedge.
pub(super) const MIN_WEDGE_SIN: f64 = 1e-9;

/// Whether the ring of `s` is embedded in the projection along its summed normal
/// `n = Σ (a − s) × (b − s)` (`links` are its wedges `(a, b)` from [`ring_links`]; the
/// sum is taken from the positions that the wedge test reads anyway, so the test touches
/// no per-face data; any direction `n` makes the test sound, this one makes it pass on
/// smooth rings): every face `(s, a, b)` spans a wedge of
/// angle in (1e-9, π − 1e-9) around `s`, and the wedges cover the plane once (closed fan)
/// or less than once with a margin of 1e-6 rad (open fan).
///
/// The projection of a face lies in its wedge, and a projection injective on each face maps
/// a crossing point other than `s` to a point in two wedges, so two faces of an embedded
/// ring that share only `s` cannot cross.
///
/// Closed fans are tested without trigonometry: with every wedge positive (checked with the
/// margin `sin > 1e-9` on the cross product), the number of faces whose projected `a` lies
/// on or below the positive `u` axis and whose `b` lies above it is the winding number of
/// the projected link polygon around `s`, exact for the float-projected points, and equal
/// to the true one because every edge of that polygon stays ≥ 1e-9 · (shorter side) away
/// from `s`, far beyond the rounding. The fans cover the plane once exactly when it is 1.
/// Open fans (boundary vertices) add the angles with `atan2`.
pub(super) fn ring_is_embedded(pos: &[Vec3], s: u32, kind: u8, links: &[[u32; 2]]) -> bool {
    if kind == RING_OTHER {
        return false;
    }
    let ps = pos[s as usize];
    let n: Vec3 = links.iter().map(|&[a, b]| (pos[a as usize] - ps).cross(&(pos[b as usize] - ps))).sum();
    let nn2 = n.norm_squared();
    if !(nn2.is_finite() && nn2 > 0.0) {
        return false;
    }
    // An orthogonal frame of the plane normal to `n` with |u| = |w| = |n| |n × helper|: the
    // unit frame scaled by one positive factor, which changes no sign and no ratio below
    // (and saves two square roots and the divisions of normalising).
    let helper = if n.x * n.x < 0.81 * nn2 { Vec3::x() } else { Vec3::y() };
    let u = n.cross(&helper);
    let w = n.cross(&u);
    let u = u * nn2.sqrt();
    let mut winding = 0u32;
    let mut total = 0.0;
    for &[a, b] in links {
        let (da, db) = (pos[a as usize] - ps, pos[b as usize] - ps);
        let (xa, ya) = (da.dot(&u), da.dot(&w));
        let (xb, yb) = (db.dot(&u), db.dot(&w));
        let cross = xa * yb - ya * xb;
        let bound = MIN_WEDGE_SIN * MIN_WEDGE_SIN * (xa * xa + ya * ya) * (xb * xb + yb * yb);
        // NaN fails both comparisons.
        if !(cross > 0.0 && cross * cross > bound) {
            return false;
        }
        if kind == RING_CLOSED {
            winding += (ya <= 0.0 && yb > 0.0) as u32;
        } else {
            let angle = cross.atan2(xa * xb + ya * yb);
            if !(angle > 1e-9 && angle < std::f64::consts::PI - 1e-9) {
                return false;
            }
            total += angle;
        }
    }
    if kind == RING_CLOSED {
        winding == 1
    } else {
        total < std::f64::consts::TAU - 1e-6
    }
}
