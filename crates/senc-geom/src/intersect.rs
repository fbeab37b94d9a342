//! Self-intersection of a triangle mesh: a BVH broad phase over triangle boxes (parry's
//! `Bvh`, self traversal, refit when only positions change) and an exact narrow phase of
//! edge-versus-face crossings decided by [`crate::predicates::orient3d_sos`].
//!
//! # Behavior
//! - Triangles sharing an edge are skipped (in the perturbed general position they meet only
//!   along that edge).
//! - Triangles sharing one vertex `s` can only cross through an edge opposite `s`; such a
//!   crossing gives one point and a segment ending at the **loop vertex** `s`.
//! - Other pairs give zero or two crossings, the two ends of one segment.
//! - Each crossing is an [`IntersectionPoint`] `(edge, face)`, reported once although both
//!   faces of the edge find it; it is the shared end of their two segments.
//! - Output is sorted (points by `(edge, face)`, segments by face pair) and so does not
//!   depend on the thread count or on whether the BVH was refit or rebuilt.

use std::cmp::Ordering;

use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector as PVec;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use rayon::prelude::*;

use crate::mesh::TriMesh;
use crate::predicates::{orient3d_sos, orient3d_value};
use crate::Vec3;

/// A crossing of mesh edge `edge` through the interior of face `face`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntersectionPoint {
    /// Edge index (see [`crate::Topology::edges`]).
    pub edge: u32,
    /// Face index.
    pub face: u32,
    /// Parameter along the edge from `edges[edge][0]` (t = 0) to `edges[edge][1]` (t = 1).
    pub t: f64,
    /// Barycentric coordinates in `face`, weights of `faces[face][0..3]`.
    pub bary: [f64; 3],
}

/// One end of an intersection segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SegmentEnd {
    /// An intersection point (index into [`SelfIntersections::points`]).
    Point(u32),
    /// A loop vertex: the vertex shared by the two faces.
    LoopVertex(u32),
}

/// The intersection of two faces: a segment lying on both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// The two faces, smaller index first.
    pub faces: [u32; 2],
    /// Its two ends. A loop vertex, if any, comes first.
    pub ends: [SegmentEnd; 2],
}

/// All crossings of a mesh with itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SelfIntersections {
    /// Crossing points, sorted by `(edge, face)`.
    pub points: Vec<IntersectionPoint>,
    /// Face-pair segments, sorted by `faces`.
    pub segments: Vec<Segment>,
    /// Candidate pairs the broad phase passed to the narrow phase.
    pub n_candidate_pairs: usize,
    /// Pairs whose crossing count was not 0 or 2 (0 expected: exact predicates make this
    /// impossible; counted rather than asserted).
    pub n_inconsistent_pairs: usize,
}

impl SelfIntersections {
    /// Sorted, deduplicated intersecting face pairs.
    pub fn face_pairs(&self) -> Vec<[u32; 2]> {
        let mut v: Vec<[u32; 2]> = self.segments.iter().map(|s| s.faces).collect();
        v.dedup();
        v
    }

    /// 3D position of point `i` on `mesh` (from its edge parameter).
    pub fn point_position(&self, mesh: &TriMesh, i: usize) -> Vec3 {
        let p = &self.points[i];
        let [a, b] = mesh.topology().edges()[p.edge as usize];
        let (a, b) = (mesh.positions()[a as usize], mesh.positions()[b as usize]);
        a + (b - a) * p.t
    }
}

/// Reusable broad phase: keeps the BVH between calls and refits it when positions change.
pub struct SelfIntersector {
    bvh: Bvh,
    workspace: BvhWorkspace,
    n_faces: usize,
    pairs: Vec<[u32; 2]>,
    /// Faces with the same nonzero group are never tested against each other.
    groups: Vec<u32>,
}

impl std::fmt::Debug for SelfIntersector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelfIntersector").field("n_faces", &self.n_faces).finish()
    }
}

fn face_aabb(mesh: &TriMesh, f: usize) -> Aabb {
    let [a, b, c] = mesh.triangle(f);
    let lo = a.inf(&b).inf(&c);
    let hi = a.sup(&b).sup(&c);
    Aabb::new(PVec::new(lo.x, lo.y, lo.z), PVec::new(hi.x, hi.y, hi.z))
}

impl SelfIntersector {
    /// Builds the BVH over `mesh`'s faces.
    pub fn new(mesh: &TriMesh) -> Self {
        let leaves: Vec<Aabb> = (0..mesh.n_faces()).map(|f| face_aabb(mesh, f)).collect();
        Self {
            bvh: Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves),
            workspace: BvhWorkspace::default(),
            n_faces: mesh.n_faces(),
            pairs: Vec::new(),
            groups: Vec::new(),
        }
    }

    /// Faces sharing a nonzero `groups[f]` are not tested against each other. Used for the
    /// fan caps of closed holes: a fan's triangles share its centroid and are (nearly)
    /// coplanar, so testing them against each other is all exact-zero work and could only
    /// report crossings of the virtual cap with itself. Fans are still tested against every
    /// other face.
    pub fn with_groups(mut self, groups: Vec<u32>) -> Self {
        self.groups = groups;
        self
    }

    /// Crossings of `mesh` with itself. If `mesh` has the faces this intersector was built
    /// for, the BVH is refit to the new positions; otherwise it is rebuilt.
    pub fn find(&mut self, mesh: &TriMesh) -> SelfIntersections {
        if mesh.n_faces() != self.n_faces {
            let groups = std::mem::take(&mut self.groups);
            *self = Self::new(mesh);
            if groups.len() == mesh.n_faces() {
                self.groups = groups;
            }
        } else {
            for f in 0..mesh.n_faces() {
                self.bvh.insert_or_update_partially(face_aabb(mesh, f), f as u32, 0.0);
            }
            self.bvh.refit_parallel(&mut self.workspace);
        }
        let faces = mesh.faces();
        // Parallel traversal; its pairs come in the sequential traversal's order, and the
        // filter below keeps that order, so the output stays deterministic.
        let bvh = &self.bvh;
        let (raw, rings) = rayon::join(|| bvh.traverse_bvtt_single_tree_parallel::<false>(), || embedded_rings(mesh));
        let groups = &self.groups;
        let same_group =
            |a: u32, b: u32| !groups.is_empty() && groups[a as usize] != 0 && groups[a as usize] == groups[b as usize];
        self.pairs = raw
            .par_iter()
            .with_min_len(1024)
            .filter_map(|&(a, b)| {
                let (fa, fb) = (faces[a as usize], faces[b as usize]);
                let keep =
                    a != b && !shares_edge(fa, fb) && !same_group(a, b) && !shared_vertex_is_flat(fa, fb, &rings);
                keep.then(|| [a.min(b), a.max(b)])
            })
            .collect();
        narrow_phase(mesh, &self.pairs)
    }
}

/// One-shot self-intersection (builds a BVH; use [`SelfIntersector`] across frames).
pub fn self_intersections(mesh: &TriMesh) -> SelfIntersections {
    SelfIntersector::new(mesh).find(mesh)
}

/// Whether `f` and `g` share exactly one vertex whose ring of faces is embedded (see
/// [`embedded_rings`]); such a pair cannot cross.
fn shared_vertex_is_flat(f: [u32; 3], g: [u32; 3], rings: &[bool]) -> bool {
    let mut shared = None;
    for v in f {
        if g.contains(&v) {
            if shared.is_some() {
                return false;
            }
            shared = Some(v);
        }
    }
    shared.is_some_and(|v| rings[v as usize])
}

/// For each vertex, whether its ring of faces projects without overlap onto the plane normal
/// to the ring's summed normal: every face spans a wedge around the vertex of angle in
/// (1e-9, π − 1e-9), the faces form one fan (closed, or one open chain), and the wedges add
/// up to one turn (closed ring) or less (open chain). The
/// projection of face `(s, a, b)` lies inside its wedge, so two faces of an embedded ring
/// that share only `s` have disjoint projections and cannot cross: the broad phase drops
/// them before any predicate. The margins are far above the rounding of the angles, so the
/// test never drops a pair the exact predicates would report. This removes most pairs on
/// smooth or flat (even exactly coplanar) tessellations, where exact predicates are slow.
pub fn embedded_rings(mesh: &TriMesh) -> Vec<bool> {
    let topo = mesh.topology();
    let pos = mesh.positions();
    let faces = mesh.faces();
    (0..mesh.n_vertices() as u32)
        .into_par_iter()
        .with_min_len(512)
        .map(|s| {
            let ring = topo.vertex_faces(s);
            if ring.is_empty() {
                return false;
            }
            let n: Vec3 = ring.iter().map(|&f| mesh.face_normal_scaled(f as usize)).sum();
            let nn = n.norm();
            if nn.is_nan() || nn <= 0.0 || !nn.is_finite() {
                return false;
            }
            let n = n / nn;
            let helper = if n.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
            let u = n.cross(&helper).normalize();
            let w = n.cross(&u);
            let ps = pos[s as usize];
            let mut total = 0.0;
            let mut neighbour_count: smallvec::SmallVec<[(u32, u8); 16]> = smallvec::SmallVec::new();
            for &f in ring {
                let fv = faces[f as usize];
                let k = fv.iter().position(|&v| v == s).unwrap_or(0);
                let (a, b) = (fv[(k + 1) % 3], fv[(k + 2) % 3]);
                let (da, db) = (pos[a as usize] - ps, pos[b as usize] - ps);
                let (xa, ya) = (da.dot(&u), da.dot(&w));
                let (xb, yb) = (db.dot(&u), db.dot(&w));
                let angle = (xa * yb - ya * xb).atan2(xa * xb + ya * yb);
                if angle.is_nan() || angle <= 1e-9 || angle >= std::f64::consts::PI - 1e-9 {
                    return false;
                }
                total += angle;
                for v in [a, b] {
                    match neighbour_count.iter_mut().find(|e| e.0 == v) {
                        Some(e) => e.1 += 1,
                        None => neighbour_count.push((v, 1)),
                    }
                }
            }
            // One fan only: a closed ring (every neighbour twice) or a single open chain
            // (exactly two neighbours once); anything else (a pinched vertex) is not used.
            let n_once = neighbour_count.iter().filter(|e| e.1 == 1).count();
            if neighbour_count.iter().any(|e| e.1 > 2) || (n_once != 0 && n_once != 2) {
                return false;
            }
            let closed = n_once == 0;
            let turn = std::f64::consts::TAU;
            if closed {
                total < turn + 1e-6
            } else {
                total < turn - 1e-6
            }
        })
        .collect()
}

fn shares_edge(f: [u32; 3], g: [u32; 3]) -> bool {
    f.iter().filter(|v| g.contains(v)).count() >= 2
}

/// A crossing found by one face pair: (edge as sorted vertex pair, face).
#[derive(Clone, Copy)]
struct Crossing {
    edge: [u32; 2],
    face: u32,
}

struct PairResult {
    faces: [u32; 2],
    loop_vertex: Option<u32>,
    crossings: [Option<Crossing>; 2],
    inconsistent: bool,
}

/// Float plane of a face for the conservative side filter: a point `v` is certainly on the
/// side `sign(n · (v − p))` when `(n · (v − p))² > tol2 · |v − p|²`. The tolerance bounds
/// the rounding of the cross and dot products (a few ulp of `|q−p| |r−p| |v−p|`; we use
/// 1e-13, far above it), so the filter never contradicts the exact predicate.
#[derive(Clone, Copy)]
struct FacePlane {
    p: Vec3,
    n: Vec3,
    tol2: f64,
}

fn face_planes(mesh: &TriMesh) -> Vec<FacePlane> {
    (0..mesh.n_faces())
        .into_par_iter()
        .with_min_len(1024)
        .map(|f| {
            let [p, q, r] = mesh.triangle(f);
            let (a, b) = (q - p, r - p);
            let tol = 1e-13 * a.norm() * b.norm();
            FacePlane { p, n: a.cross(&b), tol2: tol * tol }
        })
        .collect()
}

/// Side of `v` relative to the plane when the float evaluation is certain: `Some(true)` on
/// the positive side, `Some(false)` on the negative side, `None` when too close to tell.
#[inline]
fn certain_side(plane: &FacePlane, v: Vec3) -> Option<bool> {
    let d = v - plane.p;
    let s = plane.n.dot(&d);
    if s * s > plane.tol2 * d.norm_squared() && s.is_finite() {
        Some(s > 0.0)
    } else {
        None
    }
}

/// Whether all given points are certainly on one side of the plane.
#[inline]
fn certainly_one_side(plane: &FacePlane, pts: &[Vec3]) -> bool {
    let mut side = None;
    for &v in pts {
        match (certain_side(plane, v), side) {
            (None, _) => return false,
            (Some(s), None) => side = Some(s),
            (Some(s), Some(t)) if s != t => return false,
            _ => {}
        }
    }
    true
}

/// Cheap float rejection: the (non-shared) vertices of one face are certainly on one side
/// of the other face's plane. Never rejects a pair the exact test would accept.
fn quick_reject(mesh: &TriMesh, planes: &[FacePlane], f: u32, g: u32) -> bool {
    let fv = mesh.faces()[f as usize];
    let gv = mesh.faces()[g as usize];
    let pos = mesh.positions();
    let mut own_f = [Vec3::zeros(); 3];
    let mut own_g = [Vec3::zeros(); 3];
    let (mut nf, mut ng) = (0, 0);
    for k in 0..3 {
        if !gv.contains(&fv[k]) {
            own_f[nf] = pos[fv[k] as usize];
            nf += 1;
        }
        if !fv.contains(&gv[k]) {
            own_g[ng] = pos[gv[k] as usize];
            ng += 1;
        }
    }
    let f_clear = certainly_one_side(&planes[g as usize], &own_f[..nf]);
    let g_clear = certainly_one_side(&planes[f as usize], &own_g[..ng]);
    if nf == 3 {
        // No shared vertex: one triangle wholly on one side of the other's plane.
        f_clear || g_clear
    } else {
        // Shared vertex: only an opposite edge can cross; reject when neither can.
        f_clear && g_clear
    }
}

fn narrow_phase(mesh: &TriMesh, pairs: &[[u32; 2]]) -> SelfIntersections {
    let planes = face_planes(mesh);
    let results: Vec<PairResult> = pairs
        .par_iter()
        .with_min_len(256)
        .filter_map(|&[f, g]| if quick_reject(mesh, &planes, f, g) { None } else { test_pair(mesh, f, g) })
        .collect();
    let topo = mesh.topology();
    let mut keys: Vec<(u32, u32)> = Vec::with_capacity(results.len() * 2);
    for r in &results {
        for c in r.crossings.iter().flatten() {
            let e = topo.find_edge(c.edge[0], c.edge[1]).expect("crossing edge belongs to the mesh");
            keys.push((e, c.face));
        }
    }
    keys.sort_unstable();
    keys.dedup();
    let points: Vec<IntersectionPoint> = keys.iter().map(|&(e, f)| crossing_point(mesh, e, f)).collect();
    let point_index = |c: &Crossing| -> u32 {
        let e = topo.find_edge(c.edge[0], c.edge[1]).expect("edge exists");
        keys.binary_search(&(e, c.face)).expect("point was collected") as u32
    };
    let mut segments = Vec::with_capacity(results.len());
    let mut n_inconsistent = 0;
    for r in &results {
        if r.inconsistent {
            n_inconsistent += 1;
            continue;
        }
        let ends = match (r.loop_vertex, r.crossings) {
            (Some(s), [Some(c), None]) => [SegmentEnd::LoopVertex(s), SegmentEnd::Point(point_index(&c))],
            (None, [Some(c0), Some(c1)]) => {
                let (a, b) = (point_index(&c0), point_index(&c1));
                [SegmentEnd::Point(a.min(b)), SegmentEnd::Point(a.max(b))]
            }
            _ => continue,
        };
        segments.push(Segment { faces: r.faces, ends });
    }
    segments.sort_unstable_by_key(|s| (s.faces, s.ends));
    SelfIntersections { points, segments, n_candidate_pairs: pairs.len(), n_inconsistent_pairs: n_inconsistent }
}

fn sos(mesh: &TriMesh, idx: [u32; 4]) -> Ordering {
    orient3d_sos(idx.map(|i| mesh.positions()[i as usize]), idx)
}

/// Whether edge `{a, b}` crosses the interior of face `face` (no shared vertices).
fn edge_crosses_face(mesh: &TriMesh, edge: [u32; 2], face: [u32; 3]) -> bool {
    let [a, b] = edge;
    let [p, q, r] = face;
    let sa = sos(mesh, [p, q, r, a]);
    let sb = sos(mesh, [p, q, r, b]);
    if sa == sb {
        return false;
    }
    let s1 = sos(mesh, [a, b, p, q]);
    let s2 = sos(mesh, [a, b, q, r]);
    s1 == s2 && s2 == sos(mesh, [a, b, r, p])
}

fn sorted(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

fn test_pair(mesh: &TriMesh, f: u32, g: u32) -> Option<PairResult> {
    let fv = mesh.faces()[f as usize];
    let gv = mesh.faces()[g as usize];
    let mut shared = [0u32; 3];
    let mut n_shared = 0;
    for &v in &fv {
        if gv.contains(&v) {
            shared[n_shared] = v;
            n_shared += 1;
        }
    }
    match n_shared {
        0 => {
            // Early out: all of one triangle strictly on one side of the other's plane.
            let side = |t: [u32; 3], v: u32| sos(mesh, [t[0], t[1], t[2], v]);
            let sg = gv.map(|v| side(fv, v));
            if sg[0] == sg[1] && sg[1] == sg[2] {
                return None;
            }
            let sf = fv.map(|v| side(gv, v));
            if sf[0] == sf[1] && sf[1] == sf[2] {
                return None;
            }
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, signs) in [(fv, gv, g, sf), (gv, fv, f, sg)] {
                for k in 0..3 {
                    let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
                    // An edge can only cross if its ends are on opposite sides.
                    if signs[(k + 1) % 3] == signs[(k + 2) % 3] {
                        continue;
                    }
                    if edge_crosses_face(mesh, sorted(a, b), other) {
                        if n < 2 {
                            found[n] = Some(Crossing { edge: sorted(a, b), face: other_id });
                        }
                        n += 1;
                    }
                }
            }
            match n {
                0 => None,
                2 => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: false }),
                _ => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: true }),
            }
        }
        1 => {
            let s = shared[0];
            let opposite = |t: [u32; 3]| {
                let k = t.iter().position(|&v| v == s).unwrap_or(0);
                sorted(t[(k + 1) % 3], t[(k + 2) % 3])
            };
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id) in [(fv, gv, g), (gv, fv, f)] {
                let e = opposite(tri);
                if edge_crosses_face(mesh, e, other) {
                    if n < 2 {
                        found[n] = Some(Crossing { edge: e, face: other_id });
                    }
                    n += 1;
                }
            }
            match n {
                0 => None,
                1 => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: false }),
                _ => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: true }),
            }
        }
        _ => None,
    }
}

/// Float position data of crossing `(e, f)`: edge parameter and face barycentrics, clamped
/// to their valid ranges (the exact predicates decided that the crossing exists).
fn crossing_point(mesh: &TriMesh, e: u32, f: u32) -> IntersectionPoint {
    let [ia, ib] = mesh.topology().edges()[e as usize];
    let pos = mesh.positions();
    let (a, b) = (pos[ia as usize], pos[ib as usize]);
    let [p, q, r] = mesh.triangle(f as usize);
    let t = edge_parameter(a, b, p, q, r);
    let x = a + (b - a) * t;
    IntersectionPoint { edge: e, face: f, t, bary: barycentric(x, p, q, r) }
}

/// Parameter of the crossing of segment `a → b` with the plane of `(p, q, r)`, in `[0, 1]`.
pub fn edge_parameter(a: Vec3, b: Vec3, p: Vec3, q: Vec3, r: Vec3) -> f64 {
    let oa = orient3d_value(p, q, r, a);
    let ob = orient3d_value(p, q, r, b);
    let denom = oa - ob;
    if denom == 0.0 || !denom.is_finite() {
        return 0.5;
    }
    (oa / denom).clamp(0.0, 1.0)
}

/// Barycentric coordinates of `x` (projected on the plane) in `(p, q, r)`, clamped to be
/// non-negative and renormalised; the centroid for a degenerate triangle.
pub fn barycentric(x: Vec3, p: Vec3, q: Vec3, r: Vec3) -> [f64; 3] {
    let n = (q - p).cross(&(r - p));
    let nn = n.norm_squared();
    if nn == 0.0 || !nn.is_finite() {
        return [1.0 / 3.0; 3];
    }
    let b0 = ((q - x).cross(&(r - x))).dot(&n) / nn;
    let b1 = ((r - x).cross(&(p - x))).dot(&n) / nn;
    let b = [b0.max(0.0), b1.max(0.0), (1.0 - b0 - b1).max(0.0)];
    let s = b[0] + b[1] + b[2];
    if s > 0.0 {
        b.map(|v| v / s)
    } else {
        [1.0 / 3.0; 3]
    }
}
