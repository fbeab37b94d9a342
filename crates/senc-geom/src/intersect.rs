//! Self-intersection of a triangle mesh: a BVH broad phase over triangle boxes (our own
//! flat tree with leaves of a few faces, self traversal, refit when only positions change)
//! and an exact narrow phase of edge-versus-face crossings decided by
//! [`crate::predicates::orient3d_sos`], behind conservative float filters.
//!
//! # Performance
//! Each face pair whose boxes overlap is filtered where the traversal finds it, with no pair
//! list: faces sharing an edge, or one vertex whose ring is embedded (see
//! [`embedded_rings`]), are dropped by comparing vertex ids; the rest take the sides of each
//! face's vertices against the other face's float plane (exact predicate only when the float
//! value is within its rounding bound) and reuse them for the edge tests. Before that, a
//! node whose faces form a topological disk with all normals in a cone narrower than a
//! hemisphere and whose boundary projects to a simple curve is skipped whole: such a patch
//! cannot cross itself (see [`Traversal::patch_is_embedded`]).
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
use std::sync::atomic::{AtomicU8, Ordering as AtomicOrdering};

use rayon::prelude::*;
use wide::{f32x4, i32x4, CmpEq, CmpLe};

use crate::mesh::TriMesh;
use crate::predicates::{orient3d_sos, orient3d_value};
use crate::topology::NO_FACE;
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

/// Faces per BVH leaf. Leaves of a few faces keep the tree shallow; the face pairs inside
/// a leaf pair are still each checked against their boxes before any other work.
const LEAF_SIZE: usize = 4;

/// The smaller of two numbers that are not NaN (one `minsd`; `f64::min` also handles NaN).
/// Positions are finite (checked by [`TriMesh`]), and so are the bounds built from them.
#[inline(always)]
fn lesser(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of two numbers that are not NaN (see [`lesser`]).
#[inline(always)]
fn greater(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// Axis-aligned box, closed (touching boxes overlap).
#[derive(Debug, Clone, Copy)]
struct Aabb3 {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Aabb3 {
    const EMPTY: Aabb3 = Aabb3 { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };

    #[inline]
    fn of_triangle(a: Vec3, b: Vec3, c: Vec3) -> Self {
        let lo = |ax: usize| lesser(lesser(a[ax], b[ax]), c[ax]);
        let hi = |ax: usize| greater(greater(a[ax], b[ax]), c[ax]);
        Aabb3 { lo: [lo(0), lo(1), lo(2)], hi: [hi(0), hi(1), hi(2)] }
    }

    #[inline]
    fn overlaps(&self, o: &Aabb3) -> bool {
        self.lo[0] <= o.hi[0]
            && o.lo[0] <= self.hi[0]
            && self.lo[1] <= o.hi[1]
            && o.lo[1] <= self.hi[1]
            && self.lo[2] <= o.hi[2]
            && o.lo[2] <= self.hi[2]
    }

    #[inline]
    fn union(&self, o: &Aabb3) -> Aabb3 {
        Aabb3 {
            lo: [lesser(self.lo[0], o.lo[0]), lesser(self.lo[1], o.lo[1]), lesser(self.lo[2], o.lo[2])],
            hi: [greater(self.hi[0], o.hi[0]), greater(self.hi[1], o.hi[1]), greater(self.hi[2], o.hi[2])],
        }
    }

    /// Half the box's surface-area measure (for choosing which node to descend).
    #[inline]
    fn size(&self) -> f64 {
        let d = [self.hi[0] - self.lo[0], self.hi[1] - self.lo[1], self.hi[2] - self.lo[2]];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// The boxes of one leaf's (up to [`LEAF_SIZE`]) faces in single precision, rounded
/// outward (so never smaller than the true boxes), one array per bound and axis, for
/// testing one face against a whole leaf at once. Unused lanes hold empty boxes.
#[derive(Debug, Clone, Copy)]
struct LeafBoxes {
    lo: [[f32; LEAF_SIZE]; 3],
    hi: [[f32; LEAF_SIZE]; 3],
}

impl LeafBoxes {
    const EMPTY: LeafBoxes = LeafBoxes { lo: [[f32::INFINITY; LEAF_SIZE]; 3], hi: [[f32::NEG_INFINITY; LEAF_SIZE]; 3] };

    /// Bit `k` set when lane `k`'s box overlaps lane `lane`'s box of `other`: six 4-wide
    /// comparisons (`wide`, SSE on x86-64) and one move-mask.
    #[inline(always)]
    fn overlap_mask(&self, other: &LeafBoxes, lane: usize) -> u32 {
        let ok = |ax: usize| {
            let (lo, hi) = (f32x4::new(self.lo[ax]), f32x4::new(self.hi[ax]));
            f32x4::splat(other.lo[ax][lane]).cmp_le(hi) & lo.cmp_le(f32x4::splat(other.hi[ax][lane]))
        };
        (ok(0) & ok(1) & ok(2)).move_mask() as u32
    }
}

/// The vertex ids and groups of one leaf's (up to [`LEAF_SIZE`]) faces, one array per
/// corner, for classifying one face against a whole leaf at once. Ids are compared as bit
/// patterns (`u32` stored as `i32`). Unused lanes hold copies of no face (they are never in
/// a box mask).
#[derive(Debug, Clone, Copy)]
struct LeafVerts {
    v: [[i32; LEAF_SIZE]; 3],
    g: [i32; LEAF_SIZE],
}

impl LeafVerts {
    /// Per leaf group of `slot_faces` / `slot_groups`.
    fn of_slots(slot_faces: &[[u32; 3]], slot_groups: &[u32]) -> Vec<LeafVerts> {
        slot_faces
            .chunks(LEAF_SIZE)
            .zip(slot_groups.chunks(LEAF_SIZE))
            .map(|(fs, gs)| {
                let mut lv = LeafVerts { v: [[-1; LEAF_SIZE]; 3], g: [0; LEAF_SIZE] };
                for (k, (f, &g)) in fs.iter().zip(gs).enumerate() {
                    for (c, &v) in f.iter().enumerate() {
                        lv.v[c][k] = v as i32;
                    }
                    lv.g[k] = g as i32;
                }
                lv
            })
            .collect()
    }

    /// For face `f` (vertex ids) of group `g`: the masks of lanes that share no vertex with
    /// it and of lanes that share exactly one, both without the lanes of the same nonzero
    /// group (pairs sharing an edge or in one group are never tested).
    #[inline(always)]
    fn classify(&self, f: [u32; 3], g: u32) -> (u32, u32) {
        let corners = [i32x4::new(self.v[0]), i32x4::new(self.v[1]), i32x4::new(self.v[2])];
        // Minus the number of shared vertices per lane (an equal comparison is −1).
        let mut neg_shared = i32x4::splat(0);
        for v in f {
            let v = i32x4::splat(v as i32);
            for c in corners {
                neg_shared += v.cmp_eq(c);
            }
        }
        let same_group = if g == 0 { 0 } else { i32x4::splat(g as i32).cmp_eq(i32x4::new(self.g)).move_mask() as u32 };
        let none = neg_shared.cmp_eq(i32x4::splat(0)).move_mask() as u32;
        let one = neg_shared.cmp_eq(i32x4::splat(-1)).move_mask() as u32;
        (none & !same_group, one & !same_group)
    }
}

/// `x` rounded to an `f32` not above it.
#[inline]
fn f32_down(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) > x {
        f32_step(y, false)
    } else {
        y
    }
}

/// `x` rounded to an `f32` not below it.
#[inline]
fn f32_up(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) < x {
        f32_step(y, true)
    } else {
        y
    }
}

/// The neighbouring `f32` of a non-NaN `y` upward or downward (`f32::next_up` /
/// `next_down`, which are newer than this crate's minimum Rust version).
#[inline]
fn f32_step(y: f32, up: bool) -> f32 {
    if y == 0.0 {
        let tiny = f32::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let bits = y.to_bits();
    // Away from zero increments the magnitude bits; toward zero decrements them.
    if (y > 0.0) == up {
        f32::from_bits(bits + 1)
    } else {
        f32::from_bits(bits - 1)
    }
}

/// Box of the unit normals of a set of faces, for the normal-cone test of disk patches
/// (see [`Traversal::patch_is_embedded`]). A face whose float normal direction cannot be
/// trusted (the sine of its angle at its first vertex at most 1e-6, so the direction's
/// rounding error could exceed about 1e-9) widens the box to the whole cube `[−1, 1]³`,
/// which never passes the test.
#[derive(Debug, Clone, Copy)]
struct NormalBox {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl NormalBox {
    const EMPTY: NormalBox = NormalBox { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };

    /// Adds the face with scaled normal `n = e1 × e2` (edges `e1`, `e2` from its first vertex).
    #[inline]
    fn add_face(&mut self, n: Vec3, e1: Vec3, e2: Vec3) {
        let nn = n.norm_squared();
        let unit = if nn.is_finite() && nn > 1e-12 * e1.norm_squared() * e2.norm_squared() {
            n / nn.sqrt()
        } else {
            self.lo = [-1.0; 3];
            self.hi = [1.0; 3];
            return;
        };
        for ax in 0..3 {
            self.lo[ax] = lesser(self.lo[ax], unit[ax]);
            self.hi[ax] = greater(self.hi[ax], unit[ax]);
        }
    }

    #[inline]
    fn union(&self, o: &NormalBox) -> NormalBox {
        NormalBox {
            lo: [lesser(self.lo[0], o.lo[0]), lesser(self.lo[1], o.lo[1]), lesser(self.lo[2], o.lo[2])],
            hi: [greater(self.hi[0], o.hi[0]), greater(self.hi[1], o.hi[1]), greater(self.hi[2], o.hi[2])],
        }
    }

    /// A unit direction `d` with `n · d > 1e-6` for every point `n` of the box (so for every
    /// unit normal in it), or `None`. `d` is the box's normalised centre; the minimum of the
    /// linear function `n · d` over the box is at a corner, `Σ min(lo·d, hi·d)` per axis.
    fn direction(&self) -> Option<Vec3> {
        let c = Vec3::new(self.lo[0] + self.hi[0], self.lo[1] + self.hi[1], self.lo[2] + self.hi[2]);
        let cn = c.norm();
        if !(cn.is_finite() && cn > 0.0) {
            return None;
        }
        let d = c / cn;
        let m: f64 = (0..3).map(|ax| (self.lo[ax] * d[ax]).min(self.hi[ax] * d[ax])).sum();
        (m > 1e-6).then_some(d)
    }
}

/// Smallest node (in faces) whose disk-patch test is tried: below it, checking the boundary
/// costs more than the pairs it would skip.
const MIN_PATCH: u32 = 16;

/// Per node, the range of its boundary edges in the returned list when its faces form a
/// topological disk of at least [`MIN_PATCH`] faces (an empty range otherwise). Topology
/// only, computed once per tree. A face set is a disk when it is connected, every vertex's
/// ring is one fan in the mesh ([`RING_CLOSED`] or [`RING_OPEN`]) with zero or two boundary
/// edges of the set at that vertex (so the set is a surface with boundary), its boundary is
/// not empty and its Euler characteristic `V − E + F` is 1 (`2 − 2g − b = 1` with `b ≥ 1`
/// gives genus 0 and one boundary loop).
fn disk_patches(
    mesh: &TriMesh,
    nodes: &[Node],
    order: &[u32],
    slot_of: &[u32],
    kinds: &[u8],
) -> (Vec<[u32; 2]>, Vec<[u32; 2]>) {
    let topo = mesh.topology();
    let (faces, face_edges, edge_faces) = (mesh.faces(), topo.face_edges(), topo.edge_faces());
    let mut range = vec![[0u32; 2]; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let nd = nodes[i];
        range[i] = if nd.leaf { [nd.a, nd.b] } else { [range[nd.a as usize][0], range[nd.b as usize][1]] };
    }
    let mut out = vec![[0u32; 2]; nodes.len()];
    let mut edges: Vec<[u32; 2]> = Vec::new();
    let mut deg = vec![0u32; mesh.n_vertices()];
    let mut seen = vec![u32::MAX; mesh.n_vertices()];
    let mut reached_by = vec![u32::MAX; faces.len()];
    let (mut verts, mut stack) = (Vec::new(), Vec::new());
    for (id, &[lo, hi]) in range.iter().enumerate() {
        let id32 = id as u32;
        let start = edges.len();
        out[id] = [start as u32; 2];
        if hi - lo < MIN_PATCH {
            continue;
        }
        let inside = |f: u32| f != NO_FACE && (lo..hi).contains(&slot_of[f as usize]);
        let other = |f: u32, e: u32| {
            let [g0, g1] = edge_faces[e as usize];
            if g0 == f {
                g1
            } else {
                g0
            }
        };
        let mut half_interior = 0usize;
        let mut manifold = true;
        verts.clear();
        for &f in &order[lo as usize..hi as usize] {
            let fv = faces[f as usize];
            for k in 0..3 {
                let v = fv[k] as usize;
                if seen[v] != id32 {
                    seen[v] = id32;
                    verts.push(v);
                    manifold &= kinds[v] != RING_OTHER;
                }
                if inside(other(f, face_edges[f as usize][k])) {
                    half_interior += 1;
                } else {
                    let (a, b) = (fv[(k + 1) % 3], fv[(k + 2) % 3]);
                    edges.push([a, b]);
                    deg[a as usize] += 1;
                    deg[b as usize] += 1;
                }
            }
        }
        let n_boundary = edges.len() - start;
        for &v in &verts {
            manifold &= deg[v] == 0 || deg[v] == 2;
            deg[v] = 0;
        }
        let euler = verts.len() as i64 - (half_interior / 2 + n_boundary) as i64 + (hi - lo) as i64;
        let mut disk = manifold && euler == 1 && n_boundary > 0;
        if disk {
            let f0 = order[lo as usize];
            reached_by[f0 as usize] = id32;
            stack.clear();
            stack.push(f0);
            let mut reached = 1;
            while let Some(f) = stack.pop() {
                for e in face_edges[f as usize] {
                    let g = other(f, e);
                    if inside(g) && reached_by[g as usize] != id32 {
                        reached_by[g as usize] = id32;
                        reached += 1;
                        stack.push(g);
                    }
                }
            }
            disk = reached == hi - lo;
        }
        if disk {
            out[id] = [start as u32, edges.len() as u32];
        } else {
            edges.truncate(start);
        }
    }
    (out, edges)
}

/// A boundary edge of a patch projected to the plane: its vertex ids, end points and
/// smallest `x`.
#[derive(Debug, Clone, Copy)]
struct Seg2 {
    ids: [u32; 2],
    p: [f64; 2],
    q: [f64; 2],
    xmin: f64,
}

/// `(b − a) × (c − a)` in the plane.
#[inline]
fn cross2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[inline]
fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (x, y) = (b[0] - a[0], b[1] - a[1]);
    (x * x + y * y).sqrt()
}

/// Whether two projected boundary edges certainly meet at most in a shared end: with one
/// shared vertex `v`, the other ends must leave `v` in directions that are not the same
/// (the second more than `tol` from the first's line, or pointing backwards); with none,
/// one segment's ends must both lie more than `tol` on one side of the other's line. Every
/// segment is at least `1000 tol` long, and `tol` is far above the rounding of the
/// projected coordinates, so the answer holds for the exact projection too.
fn segments_apart(s: &Seg2, t: &Seg2, tol: f64) -> bool {
    let shared = |x: u32| t.ids[0] == x || t.ids[1] == x;
    match (shared(s.ids[0]), shared(s.ids[1])) {
        (true, true) => false,
        (false, false) => {
            // `t` beside `s`'s line, or (on a common line) before or after `s` along it.
            let one_side = |s: &Seg2, t: &Seg2| {
                let len = dist2(s.p, s.q);
                let (c0, c1) = (cross2(s.p, s.q, t.p), cross2(s.p, s.q, t.q));
                let e = [s.q[0] - s.p[0], s.q[1] - s.p[1]];
                let along = |x: [f64; 2]| (x[0] - s.p[0]) * e[0] + (x[1] - s.p[1]) * e[1];
                let (a0, a1) = (along(t.p), along(t.q));
                let (lo, hi) = (-tol * len, len * len + tol * len);
                (c0 > tol * len && c1 > tol * len)
                    || (c0 < -tol * len && c1 < -tol * len)
                    || (a0 < lo && a1 < lo)
                    || (a0 > hi && a1 > hi)
            };
            one_side(s, t) || one_side(t, s)
        }
        (sh0, _) => {
            let (v, x) = if sh0 { (s.p, s.q) } else { (s.q, s.p) };
            let v_id = if sh0 { s.ids[0] } else { s.ids[1] };
            let y = if t.ids[0] == v_id { t.q } else { t.p };
            let (lx, ly) = (dist2(v, x), dist2(v, y));
            let cross = cross2(v, x, y);
            let dot = (x[0] - v[0]) * (y[0] - v[0]) + (x[1] - v[1]) * (y[1] - v[1]);
            cross.abs() > tol * lx || dot < -1e-6 * lx * ly
        }
    }
}

/// A BVH node: an inner node with children `a`, `b`, or a leaf over slots `a..b`.
#[derive(Debug, Clone, Copy)]
struct Node {
    bbox: Aabb3,
    a: u32,
    b: u32,
    leaf: bool,
}

/// Vertex-ring shapes that decide which ring test applies (topology only).
const RING_OTHER: u8 = 0;
const RING_CLOSED: u8 = 1;
const RING_OPEN: u8 = 2;

/// Cached answers of the lazy ring test ([`Traversal::ring_embedded`]).
const RING_UNKNOWN: u8 = 0;
const RING_YES: u8 = 1;
const RING_NO: u8 = 2;

/// Float plane of a face for the conservative side filter: a point `v` is certainly on the
/// side `sign(n · (v − p))` when `(n · (v − p))² > tol2 · |v − p|²`. The tolerance bounds
/// the rounding of the cross and dot products (a few ulp of `|q−p| |r−p| |v−p|`; we use
/// 1e-13, far above it), so the filter never contradicts the exact predicate.
#[derive(Debug, Clone, Copy)]
struct FacePlane {
    p: Vec3,
    n: Vec3,
    tol2: f64,
}

impl FacePlane {
    const ZERO: FacePlane = FacePlane { p: Vec3::new(0.0, 0.0, 0.0), n: Vec3::new(0.0, 0.0, 0.0), tol2: 0.0 };

    #[inline]
    fn of_triangle(p: Vec3, q: Vec3, r: Vec3) -> Self {
        let (a, b) = (q - p, r - p);
        // (1e-13 |a| |b|)², without the square roots.
        FacePlane { p, n: a.cross(&b), tol2: 1e-26 * a.norm_squared() * b.norm_squared() }
    }
}

/// Reusable self-intersection finder: keeps its BVH between calls and refits it when only
/// the positions change.
///
/// The BVH is built once over the faces (median splits of face centroids along the longest
/// axis, leaves of [`LEAF_SIZE`] faces) and stores, per leaf slot, the face's vertex ids and
/// group, so the self-traversal rejects neighbouring faces by comparing ids, without
/// touching the mesh. At the leaves, one face's box is tested against a whole leaf's boxes
/// at once, in single precision rounded outward (boxes only ever grow, so no overlapping
/// pair is missed; a few touching pairs more reach the exact test). Each face pair whose boxes overlap goes straight through the filters
/// and the exact test; no pair list is materialised.
pub struct SelfIntersector {
    /// The faces the tree was built for (rebuilt when a mesh with other faces comes).
    faces: Vec<[u32; 3]>,
    /// Faces with the same nonzero group are never tested against each other.
    groups: Vec<u32>,
    nodes: Vec<Node>,
    /// Slot → face.
    order: Vec<u32>,
    /// Per slot: the face's vertex ids and group (0 = none).
    slot_faces: Vec<[u32; 3]>,
    slot_groups: Vec<u32>,
    /// Per node: the group shared by all its faces when that is nonzero, else 0. A node
    /// with a group is never traversed within itself, nor against a node of the same group
    /// (every pair there is skipped by group anyway).
    node_groups: Vec<u32>,
    /// Per vertex: [`RING_CLOSED`], [`RING_OPEN`] or [`RING_OTHER`].
    ring_kind: Vec<u8>,
    /// Per vertex `s`, its ring's wedges `(a, b, slot)` (face `(s, a, b)` in slot `slot`) in
    /// `ring_links[ring_start[s]..ring_start[s + 1]]` (topology, for [`ring_is_embedded`]).
    ring_start: Vec<u32>,
    ring_links: Vec<[u32; 3]>,
    /// Per node: its range in `patch_edges` when its faces form a topological disk of at
    /// least [`MIN_PATCH`] faces (empty otherwise); see [`Traversal::patch_is_embedded`].
    patch_ranges: Vec<[u32; 2]>,
    /// Boundary edges (vertex pairs) of the disk nodes, node after node.
    patch_edges: Vec<[u32; 2]>,
    // Per-call buffers, reused.
    boxes: Vec<Aabb3>,
    /// Per group of [`LEAF_SIZE`] slots (every leaf is one such group).
    lanes: Vec<LeafBoxes>,
    /// Per group of [`LEAF_SIZE`] slots: the faces' vertex ids and groups (topology).
    leaf_verts: Vec<LeafVerts>,
    planes: Vec<FacePlane>,
    /// Per vertex, whether its ring is embedded ([`RING_YES`] / [`RING_NO`]), or
    /// [`RING_UNKNOWN`] until a pair sharing only that vertex asks (computed lazily: most
    /// vertices lie inside skipped patches and are never asked about).
    rings: Vec<AtomicU8>,
    /// Per leaf group, then per node: the box of the unit face normals.
    group_normals: Vec<NormalBox>,
    node_normals: Vec<NormalBox>,
}

impl std::fmt::Debug for SelfIntersector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelfIntersector")
            .field("n_faces", &self.faces.len())
            .field("n_nodes", &self.nodes.len())
            .finish()
    }
}

impl SelfIntersector {
    /// Builds the BVH over `mesh`'s faces.
    pub fn new(mesh: &TriMesh) -> Self {
        let n = mesh.n_faces();
        let centroids: Vec<Vec3> = (0..n)
            .map(|f| {
                let [a, b, c] = mesh.triangle(f);
                (a + b + c) / 3.0
            })
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = Vec::with_capacity(2 * n / LEAF_SIZE + 2);
        if n > 0 {
            let mut b = Builder {
                mesh,
                centroids: &centroids,
                mark: vec![u32::MAX; n],
                queued: vec![u32::MAX; n],
                sorted: Vec::new(),
                heap: std::collections::BinaryHeap::new(),
                strays: [Vec::new(), Vec::new()],
                notches: [Vec::new(), Vec::new()],
            };
            b.node(&mut nodes, &mut order, 0, n);
        }
        let mut slot_of = vec![0u32; n];
        for (slot, &f) in order.iter().enumerate() {
            slot_of[f as usize] = slot as u32;
        }
        let faces = mesh.faces().to_vec();
        let slot_faces: Vec<[u32; 3]> = order.iter().map(|&f| faces[f as usize]).collect();
        let ring_kind = ring_kinds(mesh);
        let (ring_start, ring_links) = ring_links(mesh, |f| slot_of[f as usize]);
        let (patch_ranges, patch_edges) = disk_patches(mesh, &nodes, &order, &slot_of, &ring_kind);
        Self {
            slot_groups: vec![0; n],
            leaf_verts: LeafVerts::of_slots(&slot_faces, &vec![0; n]),
            node_groups: vec![0; nodes.len()],
            ring_kind,
            ring_start,
            ring_links,
            patch_ranges,
            patch_edges,
            faces,
            groups: Vec::new(),
            nodes,
            order,
            slot_faces,
            boxes: Vec::new(),
            lanes: Vec::new(),
            planes: Vec::new(),
            rings: Vec::new(),
            group_normals: Vec::new(),
            node_normals: Vec::new(),
        }
    }

    /// Faces sharing a nonzero `groups[f]` are not tested against each other. Used for the
    /// fan caps of closed holes: a fan's triangles share its centroid and are (nearly)
    /// coplanar, so testing them against each other is all exact-zero work and could only
    /// report crossings of the virtual cap with itself. Fans are still tested against every
    /// other face. A `groups` of the wrong length is ignored.
    pub fn with_groups(mut self, groups: Vec<u32>) -> Self {
        if groups.len() == self.faces.len() {
            self.slot_groups = self.order.iter().map(|&f| groups[f as usize]).collect();
            self.leaf_verts = LeafVerts::of_slots(&self.slot_faces, &self.slot_groups);
            self.node_groups = node_groups(&self.nodes, &self.slot_groups);
        }
        self.groups = groups;
        self
    }

    /// Crossings of `mesh` with itself. If `mesh` has the faces this intersector was built
    /// for, the BVH is refit to the new positions; otherwise it is rebuilt.
    pub fn find(&mut self, mesh: &TriMesh) -> SelfIntersections {
        if mesh.faces() != self.faces.as_slice() {
            let groups = std::mem::take(&mut self.groups);
            let mut fresh = Self::new(mesh);
            if groups.len() == mesh.n_faces() {
                fresh = fresh.with_groups(groups);
            }
            *self = fresh;
        }
        self.refit(mesh);
        let ctx = self.traversal(mesh);
        let tasks = ctx.tasks(64);
        let acc = tasks
            .par_iter()
            .fold(Acc::default, |mut acc, &t| {
                ctx.run(t, &mut acc);
                acc
            })
            .reduce(Acc::default, |mut a, mut b| {
                if a.results.len() < b.results.len() {
                    std::mem::swap(&mut a, &mut b);
                }
                a.results.append(&mut b.results);
                a.candidates += b.candidates;
                a
            });
        assemble(mesh, acc.results, acc.candidates)
    }

    /// The traversal over this tree for `mesh` (refit to its positions).
    fn traversal<'a>(&'a self, mesh: &'a TriMesh) -> Traversal<'a> {
        Traversal {
            mesh,
            nodes: &self.nodes,
            order: &self.order,
            slot_faces: &self.slot_faces,
            slot_groups: &self.slot_groups,
            node_groups: &self.node_groups,
            lanes: &self.lanes,
            leaf_verts: &self.leaf_verts,
            planes: &self.planes,
            rings: &self.rings,
            ring_kind: &self.ring_kind,
            ring_start: &self.ring_start,
            ring_links: &self.ring_links,
            patch_ranges: &self.patch_ranges,
            patch_edges: &self.patch_edges,
            normals: &self.node_normals,
        }
    }

    /// Face boxes and planes (slot order), node boxes (bottom-up) and vertex rings for the
    /// current positions.
    fn refit(&mut self, mesh: &TriMesh) {
        let n = self.order.len();
        self.boxes.resize(n, Aabb3::EMPTY);
        self.planes.resize(n, FacePlane::ZERO);
        let n_groups = n.div_ceil(LEAF_SIZE);
        self.lanes.resize(n_groups, LeafBoxes::EMPTY);
        self.group_normals.resize(n_groups, NormalBox::EMPTY);
        self.node_normals.resize(self.nodes.len(), NormalBox::EMPTY);
        let pos = mesh.positions();
        let slot_faces = &self.slot_faces;
        // One parallel pass over leaf groups: f64 boxes and planes per slot, then the
        // group's f32 lanes (unused lanes keep their empty boxes) and normal box.
        self.lanes
            .par_iter_mut()
            .zip(self.group_normals.par_iter_mut())
            .zip(self.boxes.par_chunks_mut(LEAF_SIZE))
            .zip(self.planes.par_chunks_mut(LEAF_SIZE))
            .enumerate()
            .with_min_len(256)
            .for_each(|(group, (((lanes, nbox), boxes), planes))| {
                *nbox = NormalBox::EMPTY;
                for (k, (bx, pl)) in boxes.iter_mut().zip(planes.iter_mut()).enumerate() {
                    let [a, b, c] = slot_faces[group * LEAF_SIZE + k].map(|v| pos[v as usize]);
                    *bx = Aabb3::of_triangle(a, b, c);
                    *pl = FacePlane::of_triangle(a, b, c);
                    nbox.add_face(pl.n, b - a, c - a);
                    for ax in 0..3 {
                        lanes.lo[ax][k] = f32_down(bx.lo[ax]);
                        lanes.hi[ax][k] = f32_up(bx.hi[ax]);
                    }
                }
            });
        for i in (0..self.nodes.len()).rev() {
            let nd = self.nodes[i];
            if nd.leaf {
                // A leaf is exactly one group (leaf sizes are multiples of LEAF_SIZE but
                // the last, and never more than LEAF_SIZE).
                self.nodes[i].bbox =
                    self.boxes[nd.a as usize..nd.b as usize].iter().fold(Aabb3::EMPTY, |acc, b| acc.union(b));
                self.node_normals[i] = self.group_normals[nd.a as usize / LEAF_SIZE];
            } else {
                let (ca, cb) = (nd.a as usize, nd.b as usize);
                self.nodes[i].bbox = self.nodes[ca].bbox.union(&self.nodes[cb].bbox);
                self.node_normals[i] = self.node_normals[ca].union(&self.node_normals[cb]);
            }
        }
        self.rings.resize_with(mesh.n_vertices(), || AtomicU8::new(RING_UNKNOWN));
        for r in &mut self.rings {
            *r.get_mut() = RING_UNKNOWN;
        }
    }
}

/// Tree construction state: the mesh (for edge neighbours), face centroids and scratch.
struct Builder<'a> {
    mesh: &'a TriMesh,
    centroids: &'a [Vec3],
    /// Per face: `2 node + side` of the split being made.
    mark: Vec<u32>,
    /// Per face: the node whose growing split has queued it.
    queued: Vec<u32>,
    sorted: Vec<u32>,
    heap: std::collections::BinaryHeap<std::cmp::Reverse<(u64, u32)>>,
    strays: [Vec<usize>; 2],
    notches: [Vec<usize>; 2],
}

impl Builder<'_> {
    /// Builds the subtree over `order[lo..hi]` (split in two halves along the longest axis of
    /// the centroids, the first half grown across edges from the smallest centroid so that
    /// it stays connected, see [`Self::grow_split`]; leaf sizes a multiple of [`LEAF_SIZE`]
    /// except the last); returns its node index. Parents come before their children in
    /// `nodes`. Connected halves make more nodes topological disks that the traversal can
    /// skip whole (on the garment benchmark, 87% of the nodes of 17 to 1024 faces instead
    /// of 70% with a plain median split).
    ///
    /// After the split, faces with no edge neighbour on their own side ("strays", typical
    /// where the split line zigzags through a triangulated grid) are swapped pairwise with
    /// strays of the other side that have an edge neighbour there, so that more nodes are
    /// topological disks (see [`disk_patches`]); the sizes of both sides are unchanged.
    fn node(&mut self, nodes: &mut Vec<Node>, order: &mut [u32], lo: usize, hi: usize) -> u32 {
        let id = nodes.len();
        nodes.push(Node { bbox: Aabb3::EMPTY, a: lo as u32, b: hi as u32, leaf: true });
        if hi - lo <= LEAF_SIZE {
            return id as u32;
        }
        let centroids = self.centroids;
        let (mut cmin, mut cmax) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
        for &f in &order[lo..hi] {
            cmin = cmin.inf(&centroids[f as usize]);
            cmax = cmax.sup(&centroids[f as usize]);
        }
        let ext = cmax - cmin;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let n_leaves = (hi - lo).div_ceil(LEAF_SIZE);
        let mid = lo + (n_leaves / 2) * LEAF_SIZE;
        self.grow_split(order, lo, mid, hi, axis, id as u32);
        self.swap_strays(order, lo, mid, hi, id as u32);
        let l = self.node(nodes, order, lo, mid);
        let r = self.node(nodes, order, mid, hi);
        nodes[id] = Node { bbox: Aabb3::EMPTY, a: l, b: r, leaf: false };
        id as u32
    }

    /// Splits `order[lo..hi]` into a first part of `mid − lo` faces grown face by face
    /// across edges from the face with the smallest centroid coordinate along `axis`, always
    /// taking the queued face that is smallest along `axis` (so the cut follows the median
    /// plane, as in a median split, while the first part stays edge-connected where the
    /// faces allow); when the queue runs dry (another component), growth restarts from the
    /// smallest face not taken.
    fn grow_split(&mut self, order: &mut [u32], lo: usize, mid: usize, hi: usize, axis: usize, id: u32) {
        let topo = self.mesh.topology();
        let (face_edges, edge_faces) = (topo.face_edges(), topo.edge_faces());
        let centroids = self.centroids;
        let key = |f: u32| {
            let b = centroids[f as usize][axis].to_bits();
            (if b >> 63 == 1 { !b } else { b | (1 << 63) }, f)
        };
        let (unassigned, left) = (2 * id + 1, 2 * id);
        self.sorted.clear();
        self.sorted.extend_from_slice(&order[lo..hi]);
        self.sorted.sort_unstable_by_key(|&f| key(f));
        for &f in &self.sorted {
            self.mark[f as usize] = unassigned;
        }
        self.heap.clear();
        let (mut taken, mut next_seed) = (0, 0);
        while taken < mid - lo {
            let f = match self.heap.pop() {
                Some(std::cmp::Reverse((_, f))) => f,
                None => {
                    while self.mark[self.sorted[next_seed] as usize] != unassigned {
                        next_seed += 1;
                    }
                    self.sorted[next_seed]
                }
            };
            if self.mark[f as usize] != unassigned {
                continue;
            }
            self.mark[f as usize] = left;
            taken += 1;
            for e in face_edges[f as usize] {
                let [g0, g1] = edge_faces[e as usize];
                let g = if g0 == f { g1 } else { g0 };
                if g != NO_FACE && self.mark[g as usize] == unassigned && self.queued[g as usize] != id {
                    self.queued[g as usize] = id;
                    self.heap.push(std::cmp::Reverse(key(g)));
                }
            }
        }
        let (mut a, mut b) = (lo, mid);
        for &f in &self.sorted {
            if self.mark[f as usize] == left {
                order[a] = f;
                a += 1;
            } else {
                order[b] = f;
                b += 1;
            }
        }
    }

    fn swap_strays(&mut self, order: &mut [u32], lo: usize, mid: usize, hi: usize, id: u32) {
        let topo = self.mesh.topology();
        let (face_edges, edge_faces) = (topo.face_edges(), topo.edge_faces());
        for (k, &f) in order[lo..hi].iter().enumerate() {
            self.mark[f as usize] = 2 * id + (lo + k >= mid) as u32;
        }
        // Strays first, then notches (one neighbour on their side, two on the other),
        // per side; a stray is swapped with a stray of the other side, else with a notch.
        for _ in 0..2 {
            let mark = &self.mark;
            let count = |f: u32| {
                let own = mark[f as usize];
                let (mut same, mut other) = (0, 0);
                for e in face_edges[f as usize] {
                    let [g0, g1] = edge_faces[e as usize];
                    let g = if g0 == f { g1 } else { g0 };
                    if g != NO_FACE {
                        let m = mark[g as usize];
                        same += (m == own) as u32;
                        other += (m == own ^ 1) as u32;
                    }
                }
                (same, other)
            };
            for (side, range) in [(0, lo..mid), (1, mid..hi)] {
                self.strays[side].clear();
                self.notches[side].clear();
                for slot in range {
                    match count(order[slot]) {
                        (0, o) if o > 0 => self.strays[side].push(slot),
                        (1, 2) => self.notches[side].push(slot),
                        _ => {}
                    }
                }
            }
            let [sl, sr] = [self.strays[0].len(), self.strays[1].len()];
            if sl + sr == 0 {
                break;
            }
            let m = sl.min(sr);
            let mut pairs: Vec<(usize, usize)> =
                self.strays[0].iter().copied().zip(self.strays[1].iter().copied()).collect();
            pairs.extend(self.strays[0][m..].iter().copied().zip(self.notches[1].iter().copied()));
            pairs.extend(self.notches[0].iter().copied().zip(self.strays[1][m..].iter().copied()));
            for (a, b) in pairs {
                order.swap(a, b);
                self.mark[order[a] as usize] = 2 * id;
                self.mark[order[b] as usize] = 2 * id + 1;
            }
        }
    }
}

/// Per node, the nonzero group shared by all its faces, or 0 (see
/// [`SelfIntersector::with_groups`]). Parents come before children in `nodes`.
fn node_groups(nodes: &[Node], slot_groups: &[u32]) -> Vec<u32> {
    let mut out = vec![0u32; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let nd = nodes[i];
        out[i] = if nd.leaf {
            let g = &slot_groups[nd.a as usize..nd.b as usize];
            if g.iter().all(|&x| x == g[0]) {
                g[0]
            } else {
                0
            }
        } else {
            let (ga, gb) = (out[nd.a as usize], out[nd.b as usize]);
            if ga == gb {
                ga
            } else {
                0
            }
        };
    }
    out
}

/// A unit of traversal work: the face pairs within one subtree, or between two subtrees
/// whose boxes overlap.
#[derive(Debug, Clone, Copy)]
enum Task {
    Within(u32),
    Between(u32, u32),
}

#[derive(Default)]
struct Acc {
    results: Vec<PairResult>,
    candidates: usize,
    /// Scratch for [`Traversal::patch_is_embedded`].
    segs: Vec<Seg2>,
}

struct Traversal<'a> {
    mesh: &'a TriMesh,
    nodes: &'a [Node],
    order: &'a [u32],
    slot_faces: &'a [[u32; 3]],
    slot_groups: &'a [u32],
    node_groups: &'a [u32],
    lanes: &'a [LeafBoxes],
    leaf_verts: &'a [LeafVerts],
    planes: &'a [FacePlane],
    rings: &'a [AtomicU8],
    ring_kind: &'a [u8],
    ring_start: &'a [u32],
    ring_links: &'a [[u32; 3]],
    patch_ranges: &'a [[u32; 2]],
    patch_edges: &'a [[u32; 2]],
    normals: &'a [NormalBox],
}

impl Traversal<'_> {
    /// Whether vertex `s`'s ring is embedded ([`ring_is_embedded`] for the current
    /// positions), computed on first use and cached for this call. Threads racing on one
    /// vertex compute the same value.
    #[inline]
    fn ring_embedded(&self, s: u32) -> bool {
        let cell = &self.rings[s as usize];
        match cell.load(AtomicOrdering::Relaxed) {
            RING_YES => true,
            RING_NO => false,
            _ => {
                let planes = self.planes;
                let links =
                    &self.ring_links[self.ring_start[s as usize] as usize..self.ring_start[s as usize + 1] as usize];
                let r = ring_is_embedded(self.mesh.positions(), s, self.ring_kind[s as usize], links, |slot| {
                    planes[slot as usize].n
                });
                cell.store(if r { RING_YES } else { RING_NO }, AtomicOrdering::Relaxed);
                r
            }
        }
    }

    /// Whether all faces of nodes `x` and `y` have one nonzero group.
    #[inline]
    fn same_group(&self, x: u32, y: u32) -> bool {
        let g = self.node_groups[x as usize];
        g != 0 && g == self.node_groups[y as usize]
    }

    /// Whether node `n`'s faces certainly cannot cross or touch each other (beyond the edges
    /// and vertices they share), so the node's whole self-traversal can be skipped.
    ///
    /// The faces must form a topological disk `S` (see [`disk_patches`]) and there must be
    /// a direction `d` with `n_f · d > 0` for every face normal (from the node's
    /// [`NormalBox`]). Then the projection `π` along `d` keeps every face's orientation, and
    /// for a point `x` of the plane off `π(∂S)` and off the projected edges, the number of
    /// its preimages equals the winding number of `π(∂S)` around it (degree theory: each
    /// preimage counts +1). If `π(∂S)` is a simple closed curve (checked here with float
    /// margins, see [`segments_apart`]), that number is 0 or 1; so `π` is a local
    /// homeomorphism inside `S` (a vertex whose ring wound twice would have points with two
    /// preimages nearby) and, with a simple boundary, injective on all of `S`. An injective
    /// projection means `S` is embedded: two faces meet only in their shared vertices and
    /// edges, and are otherwise a positive distance apart, which no symbolic perturbation
    /// changes. (The known-answer and brute-force tests cover folded patches, where the
    /// normal test fails and nothing is skipped.)
    fn patch_is_embedded(&self, n: u32, segs: &mut Vec<Seg2>) -> bool {
        let [start, end] = self.patch_ranges[n as usize];
        if start == end {
            return false;
        }
        let Some(d) = self.normals[n as usize].direction() else {
            return false;
        };
        let helper = if d.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
        let u0 = d.cross(&helper).normalize();
        let w0 = d.cross(&u0);
        // The sweep below runs along `u`: turned 45° from the frame built on a coordinate
        // axis, since the tree's splits are planes normal to coordinate axes, and a patch
        // side along one of them would put all its edges into one stretch of the sweep.
        let u = (u0 + w0) * std::f64::consts::FRAC_1_SQRT_2;
        let w = (w0 - u0) * std::f64::consts::FRAC_1_SQRT_2;
        let bb = self.nodes[n as usize].bbox;
        let lo = Vec3::new(bb.lo[0], bb.lo[1], bb.lo[2]);
        let hi = Vec3::new(bb.hi[0], bb.hi[1], bb.hi[2]);
        let c = (lo + hi) * 0.5;
        let diag = (hi - lo).norm();
        let tol = 1e-8 * diag;
        if !(tol > 0.0 && tol.is_finite()) {
            return false;
        }
        let pos = self.mesh.positions();
        segs.clear();
        for &[a, b] in &self.patch_edges[start as usize..end as usize] {
            let (da, db) = (pos[a as usize] - c, pos[b as usize] - c);
            let (p, q) = ([da.dot(&u), da.dot(&w)], [db.dot(&u), db.dot(&w)]);
            let len = dist2(p, q);
            if len.is_nan() || len <= 1000.0 * tol {
                return false;
            }
            segs.push(Seg2 { ids: [a, b], p, q, xmin: p[0].min(q[0]) });
        }
        segs.sort_unstable_by(|x, y| x.xmin.total_cmp(&y.xmin));
        for (i, s) in segs.iter().enumerate() {
            let xmax = s.p[0].max(s.q[0]) + tol;
            for t in &segs[i + 1..] {
                if t.xmin > xmax {
                    break;
                }
                if !segments_apart(s, t, tol) {
                    return false;
                }
            }
        }
        true
    }

    /// Splits the root's work into at least `min_tasks` tasks where the tree allows, for
    /// rayon to spread over the threads.
    fn tasks(&self, min_tasks: usize) -> Vec<Task> {
        if self.nodes.is_empty() {
            return Vec::new();
        }
        let mut tasks = vec![Task::Within(0)];
        let mut segs = Vec::new();
        loop {
            let mut next = Vec::with_capacity(tasks.len() * 3);
            let mut split_any = false;
            for &t in &tasks {
                split_any |= self.expand(t, &mut next, &mut segs);
            }
            tasks = next;
            if !split_any || tasks.len() >= min_tasks {
                return tasks;
            }
        }
    }

    /// Pushes the sub-tasks of `t` (or `t` itself when it is leaf-level); returns whether it
    /// was split.
    fn expand(&self, t: Task, out: &mut Vec<Task>, segs: &mut Vec<Seg2>) -> bool {
        let nodes = self.nodes;
        match t {
            Task::Within(n) => {
                let nd = nodes[n as usize];
                if self.node_groups[n as usize] != 0 {
                    return true;
                }
                if nd.leaf {
                    out.push(t);
                    return false;
                }
                if self.patch_is_embedded(n, segs) {
                    return true;
                }
                out.push(Task::Within(nd.a));
                out.push(Task::Within(nd.b));
                if nodes[nd.a as usize].bbox.overlaps(&nodes[nd.b as usize].bbox) {
                    out.push(Task::Between(nd.a, nd.b));
                }
                true
            }
            Task::Between(x, y) => {
                let (nx, ny) = (nodes[x as usize], nodes[y as usize]);
                if self.same_group(x, y) {
                    return true;
                }
                if nx.leaf && ny.leaf {
                    out.push(t);
                    return false;
                }
                // Descend the node that is not a leaf, or the bigger one.
                let split_x = !nx.leaf && (ny.leaf || nx.bbox.size() >= ny.bbox.size());
                let (keep, split) = if split_x { (y, nx) } else { (x, ny) };
                let kb = nodes[keep as usize].bbox;
                for c in [split.a, split.b] {
                    if nodes[c as usize].bbox.overlaps(&kb) {
                        out.push(Task::Between(keep.min(c), keep.max(c)));
                    }
                }
                true
            }
        }
    }

    /// Runs one task to the leaves.
    fn run(&self, t: Task, acc: &mut Acc) {
        let nodes = self.nodes;
        let mut stack = Vec::with_capacity(64);
        stack.push(t);
        while let Some(t) = stack.pop() {
            match t {
                Task::Within(n) => {
                    let nd = nodes[n as usize];
                    if self.node_groups[n as usize] != 0 {
                        continue;
                    }
                    if nd.leaf {
                        self.leaf_within(nd.a, nd.b, acc);
                    } else if !self.patch_is_embedded(n, &mut acc.segs) {
                        stack.push(Task::Within(nd.a));
                        stack.push(Task::Within(nd.b));
                        if nodes[nd.a as usize].bbox.overlaps(&nodes[nd.b as usize].bbox) {
                            stack.push(Task::Between(nd.a, nd.b));
                        }
                    }
                }
                Task::Between(x, y) => {
                    let (nx, ny) = (nodes[x as usize], nodes[y as usize]);
                    if self.same_group(x, y) {
                        continue;
                    }
                    if nx.leaf && ny.leaf {
                        self.leaf_between(nx.a, nx.b, ny.a, acc);
                        continue;
                    }
                    let split_x = !nx.leaf && (ny.leaf || nx.bbox.size() >= ny.bbox.size());
                    let (keep, split) = if split_x { (y, nx) } else { (x, ny) };
                    let kb = nodes[keep as usize].bbox;
                    for c in [split.a, split.b] {
                        if nodes[c as usize].bbox.overlaps(&kb) {
                            stack.push(Task::Between(keep, c));
                        }
                    }
                }
            }
        }
    }

    /// Face pairs inside the leaf over slots `a..b`.
    #[inline]
    fn leaf_within(&self, a: u32, b: u32, acc: &mut Acc) {
        let group = a as usize / LEAF_SIZE;
        let lanes = &self.lanes[group];
        for i in a..b {
            let lane = i as usize % LEAF_SIZE;
            // Lanes after `i` only; empty lanes never overlap.
            let mask = lanes.overlap_mask(lanes, lane) & !((2u32 << lane) - 1);
            self.pairs(i, a, group, mask, acc);
        }
    }

    /// Face pairs between the leaf over slots `a..b` and the leaf starting at slot `c`.
    #[inline]
    fn leaf_between(&self, a: u32, b: u32, c: u32, acc: &mut Acc) {
        let la = &self.lanes[a as usize / LEAF_SIZE];
        let group = c as usize / LEAF_SIZE;
        let lc = &self.lanes[group];
        for i in a..b {
            let mask = lc.overlap_mask(la, i as usize % LEAF_SIZE);
            self.pairs(i, c, group, mask, acc);
        }
    }

    /// The pairs of the face in slot `i` with the lanes in `mask` (boxes overlapping) of the
    /// leaf group `group` starting at slot `c`: pairs sharing an edge or a nonzero group are
    /// dropped, pairs sharing one vertex whose ring is embedded too (they cannot cross);
    /// the rest go to the pair test.
    #[inline(always)]
    fn pairs(&self, i: u32, c: u32, group: usize, mask: u32, acc: &mut Acc) {
        if mask == 0 {
            return;
        }
        let fa = self.slot_faces[i as usize];
        let (none, one) = self.leaf_verts[group].classify(fa, self.slot_groups[i as usize]);
        let mut m = mask & none;
        while m != 0 {
            let k = m.trailing_zeros();
            m &= m - 1;
            acc.candidates += 1;
            self.test(i as usize, (c + k) as usize, acc);
        }
        let mut m = mask & one;
        while m != 0 {
            let k = m.trailing_zeros();
            m &= m - 1;
            let j = (c + k) as usize;
            let fb = self.slot_faces[j];
            let shared = if fb.contains(&fa[0]) {
                fa[0]
            } else if fb.contains(&fa[1]) {
                fa[1]
            } else {
                fa[2]
            };
            if !self.ring_embedded(shared) {
                acc.candidates += 1;
                self.test(i as usize, j, acc);
            }
        }
    }

    #[inline(never)]
    fn test(&self, i: usize, j: usize, acc: &mut Acc) {
        let (f, g) = (self.order[i], self.order[j]);
        let (pf, pg) = (&self.planes[i], &self.planes[j]);
        let r =
            if f < g { test_pair_planes(self.mesh, f, g, pf, pg) } else { test_pair_planes(self.mesh, g, f, pg, pf) };
        if let Some(r) = r {
            acc.results.push(r);
        }
    }
}

/// One-shot self-intersection (builds a BVH; use [`SelfIntersector`] across frames).
pub fn self_intersections(mesh: &TriMesh) -> SelfIntersections {
    SelfIntersector::new(mesh).find(mesh)
}

/// Per vertex, the shape of its ring of faces (topology only): one closed fan (every
/// neighbour in exactly two ring faces), one open fan (exactly two neighbours once, the rest
/// twice), or anything else (a pinched or empty ring).
fn ring_kinds(mesh: &TriMesh) -> Vec<u8> {
    let topo = mesh.topology();
    let faces = mesh.faces();
    (0..mesh.n_vertices() as u32)
        .into_par_iter()
        .with_min_len(512)
        .map(|s| {
            let ring = topo.vertex_faces(s);
            if ring.is_empty() {
                return RING_OTHER;
            }
            let mut count: smallvec::SmallVec<[(u32, u8); 16]> = smallvec::SmallVec::new();
            for &f in ring {
                for v in faces[f as usize] {
                    if v == s {
                        continue;
                    }
                    match count.iter_mut().find(|e| e.0 == v) {
                        Some(e) => e.1 = e.1.saturating_add(1),
                        None => count.push((v, 1)),
                    }
                }
            }
            let n_once = count.iter().filter(|e| e.1 == 1).count();
            if count.iter().any(|e| e.1 > 2) {
                RING_OTHER
            } else if n_once == 0 {
                RING_CLOSED
            } else if n_once == 2 {
                RING_OPEN
            } else {
                RING_OTHER
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
    let normals: Vec<Vec3> = (0..mesh.n_faces()).map(|f| mesh.face_normal_scaled(f)).collect();
    let (start, links) = ring_links(mesh, |f| f);
    (0..mesh.n_vertices() as u32)
        .into_par_iter()
        .with_min_len(512)
        .map(|s| {
            let links = &links[start[s as usize] as usize..start[s as usize + 1] as usize];
            ring_is_embedded(mesh.positions(), s, kinds[s as usize], links, |f| normals[f as usize])
        })
        .collect()
}

/// Per vertex `s`, the wedges `(a, b, id(f))` of the faces `f = (s, a, b)` of its ring (in
/// the mesh's vertex-face order), as `links[start[s]..start[s + 1]]`. Topology only.
fn ring_links(mesh: &TriMesh, id: impl Fn(u32) -> u32) -> (Vec<u32>, Vec<[u32; 3]>) {
    let topo = mesh.topology();
    let faces = mesh.faces();
    let mut start = Vec::with_capacity(mesh.n_vertices() + 1);
    let mut links = Vec::with_capacity(3 * faces.len());
    start.push(0);
    for s in 0..mesh.n_vertices() as u32 {
        for &f in topo.vertex_faces(s) {
            let fv = faces[f as usize];
            let k = fv.iter().position(|&v| v == s).unwrap_or(0);
            links.push([fv[(k + 1) % 3], fv[(k + 2) % 3], id(f)]);
        }
        start.push(links.len() as u32);
    }
    (start, links)
}

/// `sin` of the smallest wedge angle accepted (1e-9 rad); far above the rounding of the
/// projected coordinates, so a wedge accepted in floats is a true, positive wedge.
const MIN_WEDGE_SIN: f64 = 1e-9;

/// Whether the ring of `s` is embedded in the projection along its summed normal `n`
/// (`links` are its wedges `(a, b, id)` from [`ring_links`], `normal(id)` gives the scaled
/// normal of face `(s, a, b)`): every face `(s, a, b)` spans a wedge of
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
fn ring_is_embedded(pos: &[Vec3], s: u32, kind: u8, links: &[[u32; 3]], normal: impl Fn(u32) -> Vec3) -> bool {
    if kind == RING_OTHER {
        return false;
    }
    let n: Vec3 = links.iter().map(|l| normal(l[2])).sum();
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
    let ps = pos[s as usize];
    let mut winding = 0u32;
    let mut total = 0.0;
    for &[a, b, _] in links {
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

/// A crossing found by one face pair: (edge as sorted vertex pair, face).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Crossing {
    edge: [u32; 2],
    face: u32,
}

#[derive(Debug, PartialEq)]
struct PairResult {
    faces: [u32; 2],
    loop_vertex: Option<u32>,
    crossings: [Option<Crossing>; 2],
    inconsistent: bool,
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

/// Points and segments from the per-pair results, sorted (independent of their order).
fn assemble(mesh: &TriMesh, results: Vec<PairResult>, n_candidate_pairs: usize) -> SelfIntersections {
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
    SelfIntersections { points, segments, n_candidate_pairs, n_inconsistent_pairs: n_inconsistent }
}

fn sos(mesh: &TriMesh, idx: [u32; 4]) -> Ordering {
    orient3d_sos(idx.map(|i| mesh.positions()[i as usize]), idx)
}

/// Whether edge `{a, b}` crosses the interior of face `face` (no shared vertices).
#[cfg(test)]
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

/// Sign of `orient3d(t[0], t[1], t[2], v)` (as [`orient3d_sos`]), where `plane` is face
/// `t`'s float plane: from the plane when [`certain_side`] is sure (`n · (v − p) > 0`
/// means `v` above, where `orient3d` is negative), from the exact predicate otherwise.
#[inline]
fn plane_side(mesh: &TriMesh, plane: &FacePlane, t: [u32; 3], v: u32) -> Ordering {
    match certain_side(plane, mesh.positions()[v as usize]) {
        Some(true) => Ordering::Less,
        Some(false) => Ordering::Greater,
        None => sos(mesh, [t[0], t[1], t[2], v]),
    }
}

/// Whether two faces sharing no vertex are certainly apart: along the in-plane normal
/// `a = n × e` of some edge `e = q − p` of either face (pointing away from that face's third
/// vertex), every vertex `w` of the other face has `a · (w − p) > 1e-12 |a| (|w − p| + |e|)`.
/// The face itself reaches at most about `3 ε |a| |e|` along `a` (exactly 0 at `p`, and `a`
/// is perpendicular to `e` up to rounding), and the rounding of each dot product is a few
/// `ε |a| |w − p|`, so the faces are a positive distance apart and no perturbation can make
/// them cross. Used for nearly coplanar pairs, where the plane sides are undecided.
fn separated_by_edge_normal(pos: &[Vec3], fv: [u32; 3], gv: [u32; 3], pf: &FacePlane, pg: &FacePlane) -> bool {
    for (t, o, pl) in [(fv, gv, pf), (gv, fv, pg)] {
        let tp = t.map(|v| pos[v as usize]);
        let op = o.map(|v| pos[v as usize]);
        'edges: for k in 0..3 {
            let (p, q, r) = (tp[k], tp[(k + 1) % 3], tp[(k + 2) % 3]);
            let e = q - p;
            let mut a = pl.n.cross(&e);
            let an = a.norm_squared();
            let dr = r - p;
            let sr = a.dot(&dr);
            // The third vertex must be clearly on the inner side (non-degenerate face).
            let inner_clear = sr * sr > 1e-24 * an * dr.norm_squared();
            if !inner_clear {
                continue;
            }
            if sr > 0.0 {
                a = -a;
            }
            let en = e.norm_squared();
            for w in op {
                let d = w - p;
                let s = a.dot(&d);
                if !(s > 0.0 && s * s > 4e-24 * an * d.norm_squared().max(en)) {
                    continue 'edges;
                }
            }
            return true;
        }
    }
    false
}

/// Whether the signs of `orient3d(a, b, p, q)`, `(a, b, q, r)` and `(a, b, r, p)` agree,
/// that is, whether edge `{a, b}`, whose ends lie on opposite sides of face `(p, q, r)`,
/// crosses its interior. Each sign is first taken from the float value
/// `orient3d(a, b, x, y) = −(b − a) · ((x − a) × (y − a))` when it exceeds 1e-13 times the
/// product of the three difference lengths (the rounding is below 50 ε of that product), and
/// from [`orient3d_sos`] otherwise: the same decision as [`edge_crosses_face`].
#[inline]
fn edge_orients_agree(mesh: &TriMesh, edge: [u32; 2], face: [u32; 3]) -> bool {
    let pos = mesh.positions();
    let [a, b] = edge;
    let pa = pos[a as usize];
    let d = pos[b as usize] - pa;
    let dn = d.norm_squared();
    let w = face.map(|v| pos[v as usize] - pa);
    let orient = |i: usize, j: usize| -> Ordering {
        let v = d.dot(&w[i].cross(&w[j]));
        let bound2 = 1e-26 * dn * w[i].norm_squared() * w[j].norm_squared();
        if v * v > bound2 && v.is_finite() {
            if v < 0.0 {
                Ordering::Greater
            } else {
                Ordering::Less
            }
        } else {
            sos(mesh, [a, b, face[i], face[j]])
        }
    };
    let s1 = orient(0, 1);
    s1 == orient(1, 2) && s1 == orient(2, 0)
}

/// [`test_pair`] for faces `f < g` with their float planes: the same result, with the signs
/// of each face's vertices against the other face's plane taken once, from the planes where
/// certain, and reused for the edges.
fn test_pair_planes(mesh: &TriMesh, f: u32, g: u32, pf: &FacePlane, pg: &FacePlane) -> Option<PairResult> {
    let fv = mesh.faces()[f as usize];
    let gv = mesh.faces()[g as usize];
    let mut shared = None;
    let mut n_shared = 0;
    for &v in &fv {
        if gv.contains(&v) {
            shared = Some(v);
            n_shared += 1;
        }
    }
    match (n_shared, shared) {
        (0, _) => {
            let pos = mesh.positions();
            let cg = gv.map(|v| certain_side(pf, pos[v as usize]));
            let cf = fv.map(|v| certain_side(pg, pos[v as usize]));
            for c in [cg, cf] {
                if let [Some(a), Some(b), Some(c)] = c {
                    if a == b && b == c {
                        return None;
                    }
                }
            }
            // Nearly coplanar: try to separate the faces within the plane before any exact
            // predicate.
            if (cg.contains(&None) || cf.contains(&None)) && separated_by_edge_normal(pos, fv, gv, pf, pg) {
                return None;
            }
            let resolve = |c: Option<bool>, t: [u32; 3], v: u32| match c {
                Some(true) => Ordering::Less,
                Some(false) => Ordering::Greater,
                None => sos(mesh, [t[0], t[1], t[2], v]),
            };
            let sg = [0, 1, 2].map(|k| resolve(cg[k], fv, gv[k]));
            if sg[0] == sg[1] && sg[1] == sg[2] {
                return None;
            }
            let sf = [0, 1, 2].map(|k| resolve(cf[k], gv, fv[k]));
            if sf[0] == sf[1] && sf[1] == sf[2] {
                return None;
            }
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, signs) in [(fv, gv, g, sf), (gv, fv, f, sg)] {
                for k in 0..3 {
                    if signs[(k + 1) % 3] == signs[(k + 2) % 3] {
                        continue;
                    }
                    let e = sorted(tri[(k + 1) % 3], tri[(k + 2) % 3]);
                    if edge_orients_agree(mesh, e, other) {
                        if n < 2 {
                            found[n] = Some(Crossing { edge: e, face: other_id });
                        }
                        n += 1;
                    }
                }
            }
            match n {
                0 => None,
                _ => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: n != 2 }),
            }
        }
        (1, Some(s)) => {
            let opposite = |t: [u32; 3]| {
                let k = t.iter().position(|&v| v == s).unwrap_or(0);
                sorted(t[(k + 1) % 3], t[(k + 2) % 3])
            };
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, plane) in [(fv, gv, g, pg), (gv, fv, f, pf)] {
                let e = opposite(tri);
                if plane_side(mesh, plane, other, e[0]) == plane_side(mesh, plane, other, e[1]) {
                    continue;
                }
                if edge_orients_agree(mesh, e, other) {
                    if n < 2 {
                        found[n] = Some(Crossing { edge: e, face: other_id });
                    }
                    n += 1;
                }
            }
            match n {
                0 => None,
                _ => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: n != 1 }),
            }
        }
        _ => None,
    }
}

fn sorted(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// The reference pair test, all from [`orient3d_sos`] (kept for tests of the faster path).
#[cfg(test)]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;
    use rand::{Rng, SeedableRng};

    /// Every face pair with overlapping boxes through the reference test: no BVH, no ring or
    /// plane filters.
    fn brute_force(mesh: &TriMesh) -> SelfIntersections {
        let n = mesh.n_faces();
        let boxes: Vec<Aabb3> = (0..n)
            .map(|f| {
                let [a, b, c] = mesh.triangle(f);
                Aabb3::of_triangle(a, b, c)
            })
            .collect();
        let mut results = Vec::new();
        for f in 0..n {
            for g in f + 1..n {
                if boxes[f].overlaps(&boxes[g]) {
                    results.extend(test_pair(mesh, f as u32, g as u32));
                }
            }
        }
        assemble(mesh, results, 0)
    }

    #[test]
    fn bvh_and_filters_find_every_crossing_of_the_brute_force() {
        let mut meshes: Vec<(String, TriMesh)> = Vec::new();
        for name in [
            "boxes_overlap_grid",
            "boxes_touch_grid",
            "bent_tube_jitter",
            "folded_sheet_grid",
            "icospheres_overlap_grid",
        ] {
            let m = shapes::fixture(name).unwrap();
            let closed = crate::close_holes(&m, &crate::HoleSelection::All).unwrap().mesh().clone();
            meshes.push((name.to_string(), m));
            meshes.push((format!("{name} closed"), closed));
        }
        // Crumpled, grid-snapped spheres: many exact degeneracies and self-crossings.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for k in 0..4 {
            let s = shapes::icosphere(Vec3::zeros(), 1.0, 2).unwrap();
            let p: Vec<Vec3> = s
                .positions()
                .iter()
                .map(|p| {
                    let q = p + Vec3::new(
                        rng.random_range(-0.4..0.4),
                        rng.random_range(-0.4..0.4),
                        rng.random_range(-0.4..0.4),
                    );
                    if k % 2 == 0 {
                        (q * 4.0).map(f64::round) / 4.0
                    } else {
                        q
                    }
                })
                .collect();
            meshes.push((format!("crumpled {k}"), s.with_positions(p).unwrap()));
        }
        let mut total_segments = 0;
        let mut compared = 0;
        for (name, m) in &meshes {
            if m.n_faces() > 12_000 {
                continue;
            }
            compared += 1;
            let fast = self_intersections(m);
            let slow = brute_force(m);
            assert_eq!(fast.points, slow.points, "{name}");
            assert_eq!(fast.segments, slow.segments, "{name}");
            assert_eq!(fast.n_inconsistent_pairs, slow.n_inconsistent_pairs, "{name}");
            total_segments += fast.segments.len();
        }
        assert!(compared >= 14, "{compared} meshes compared");
        assert!(total_segments > 500, "the meshes should cross themselves: {total_segments}");
    }

    #[test]
    fn f32_rounding_is_outward() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        for _ in 0..10_000 {
            let x: f64 = rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-40..38));
            assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x, "{x}");
            assert!(f32_up(x) as f64 - f32_down(x) as f64 <= 2.0 * (x.abs() * 1.2e-7 + 1.5e-45), "{x}");
        }
        for x in [0.0, -0.0, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY] {
            assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x, "{x}");
        }
    }

    #[test]
    fn plane_pair_test_matches_the_reference() {
        // Random pairs sharing no or one vertex, half snapped to a coarse grid (exact
        // coplanarities, vertices on faces, collinear edges).
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut hits = 0;
        for case in 0..20_000 {
            let snap = case % 2 == 0;
            let p: Vec<Vec3> = (0..6)
                .map(|_| {
                    let v = Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    );
                    if snap {
                        (v * 2.0).map(f64::round) / 2.0
                    } else {
                        v
                    }
                })
                .collect();
            let shared = case % 3 == 0;
            let f1 = [0u32, 1, 2];
            let f2 = if shared { [0u32, 4, 5] } else { [3u32, 4, 5] };
            let Ok(m) = TriMesh::new(p, vec![f1, f2]) else { continue };
            let planes: Vec<FacePlane> = (0..2)
                .map(|f| {
                    let [a, b, c] = m.triangle(f);
                    FacePlane::of_triangle(a, b, c)
                })
                .collect();
            let want = test_pair(&m, 0, 1);
            hits += want.is_some() as usize;
            assert_eq!(test_pair_planes(&m, 0, 1, &planes[0], &planes[1]), want, "case {case}");
        }
        assert!(hits > 1000, "{hits}");
    }

    #[test]
    fn closed_ring_winding_test_agrees_with_angle_sums() {
        // On smooth and crumpled closed meshes, the winding count accepts a closed ring
        // exactly when the wedge angles (each in (1e-9, π − 1e-9)) add up to one turn.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut accepted = 0;
        let mut rejected = 0;
        for amp in [0.0, 0.05, 0.3, 0.8] {
            let s = shapes::icosphere(Vec3::zeros(), 1.0, 3).unwrap();
            let p: Vec<Vec3> = s
                .positions()
                .iter()
                .map(|p| {
                    p + Vec3::new(
                        rng.random_range(-amp..=amp),
                        rng.random_range(-amp..=amp),
                        rng.random_range(-amp..=amp),
                    )
                })
                .collect();
            let m = s.with_positions(p).unwrap();
            let rings = embedded_rings(&m);
            for (v, &r) in rings.iter().enumerate() {
                let v = v as u32;
                let ring = m.topology().vertex_faces(v);
                let n: Vec3 = ring.iter().map(|&f| m.face_normal_scaled(f as usize)).sum::<Vec3>().normalize();
                let helper = if n.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
                let u = n.cross(&helper).normalize();
                let w = n.cross(&u);
                let ps = m.positions()[v as usize];
                let mut total = 0.0;
                let mut ok = true;
                for &f in ring {
                    let fv = m.faces()[f as usize];
                    let k = fv.iter().position(|&x| x == v).unwrap();
                    let (da, db) =
                        (m.positions()[fv[(k + 1) % 3] as usize] - ps, m.positions()[fv[(k + 2) % 3] as usize] - ps);
                    let (xa, ya, xb, yb) = (da.dot(&u), da.dot(&w), db.dot(&u), db.dot(&w));
                    let angle = (xa * yb - ya * xb).atan2(xa * xb + ya * yb);
                    ok &= angle > 1e-9 && angle < std::f64::consts::PI - 1e-9;
                    total += angle;
                }
                let want = ok && (total - std::f64::consts::TAU).abs() < 1e-6;
                assert_eq!(r, want, "vertex {v}, amplitude {amp}, total {total}");
                if r {
                    accepted += 1
                } else {
                    rejected += 1
                }
            }
        }
        assert!(accepted > 100 && rejected > 100, "{accepted} {rejected}");
    }

    /// Internal nodes whose self-traversal [`Traversal::patch_is_embedded`] skips, for the
    /// positions `ix` was last refit to.
    fn skipped_nodes(ix: &SelfIntersector, mesh: &TriMesh) -> Vec<u32> {
        let ctx = ix.traversal(mesh);
        let mut segs = Vec::new();
        (0..ix.nodes.len() as u32)
            .filter(|&n| !ix.nodes[n as usize].leaf && ctx.patch_is_embedded(n, &mut segs))
            .collect()
    }

    /// A flat strip wound 1.25 times around the z axis, climbing 0.02 per turn, tilted
    /// about its centre line from +0.3 rad at the start to −0.3 rad at the end: every
    /// normal is within 0.3 rad of z (a narrow cone) and the strip is one disk, but its last
    /// quarter turn crosses its first (the tilts differ by more than the climb allows).
    fn crossing_spiral_strip(n_around: usize, n_across: usize) -> TriMesh {
        let turns = 1.25;
        let (w, climb, tilt) = (0.3, 0.02, 0.3);
        let mut pos = Vec::new();
        for i in 0..=n_around {
            let u = i as f64 / n_around as f64;
            let th = u * turns * std::f64::consts::TAU;
            let a = tilt * (1.0 - 2.0 * u);
            for j in 0..=n_across {
                let s = w * (j as f64 / n_across as f64 - 0.5);
                let r = 1.0 + s * a.cos();
                pos.push(Vec3::new(r * th.cos(), r * th.sin(), climb * u * turns + s * a.sin()));
            }
        }
        let id = |i: usize, j: usize| (i * (n_across + 1) + j) as u32;
        let mut faces = Vec::new();
        for i in 0..n_around {
            for j in 0..n_across {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        TriMesh::new(pos, faces).unwrap()
    }

    #[test]
    fn embedded_patches_are_skipped_and_overlapping_ones_are_not() {
        // A gently curved height-field sheet: no crossings, and whole subtrees skipped.
        let sheet = shapes::grid_sheet(1.0, 1.0, 40, 40).unwrap();
        let p: Vec<Vec3> = sheet
            .positions()
            .iter()
            .map(|p| Vec3::new(p.x, p.y, 0.1 * (3.0 * p.x).sin() * (2.0 * p.y).cos()))
            .collect();
        let sheet = sheet.with_positions(p).unwrap();
        let mut ix = SelfIntersector::new(&sheet);
        let found = ix.find(&sheet);
        assert!(found.segments.is_empty() && found.n_candidate_pairs == 0, "{found:?}");
        let skipped = skipped_nodes(&ix, &sheet);
        assert!(skipped.contains(&0), "the root patch of a height field should be skipped: {skipped:?}");

        // The spiral strip: narrow normal cone, one disk, but it crosses itself, so the
        // root must not be skipped (its projected boundary overlaps itself) while smaller
        // patches are.
        let strip = crossing_spiral_strip(240, 6);
        let mut ix = SelfIntersector::new(&strip);
        let found = ix.find(&strip);
        assert!(ix.patch_ranges[0][0] < ix.patch_ranges[0][1], "the strip is one disk");
        assert!(ix.node_normals[0].direction().is_some(), "the strip's normals lie in a narrow cone");
        let skipped = skipped_nodes(&ix, &strip);
        assert!(!skipped.contains(&0) && skipped.len() > 5, "{skipped:?}");
        assert!(found.segments.len() > 20, "{} segments", found.segments.len());
        let slow = brute_force(&strip);
        assert_eq!(found.points, slow.points);
        assert_eq!(found.segments, slow.segments);

        // Folded through itself (wide normal cone): nothing that crosses is skipped.
        let folded = shapes::folded_sheet(1.0, 24).unwrap();
        let found = self_intersections(&folded);
        assert_eq!(found.segments, brute_force(&folded).segments);
    }

    /// [`brute_force`] without the pairs of faces that share a nonzero group.
    fn brute_force_grouped(mesh: &TriMesh, groups: &[u32]) -> SelfIntersections {
        let n = mesh.n_faces();
        let mut results = Vec::new();
        for f in 0..n {
            let [a, b, c] = mesh.triangle(f);
            let bf = Aabb3::of_triangle(a, b, c);
            for g in f + 1..n {
                let [a, b, c] = mesh.triangle(g);
                if (groups[f] == 0 || groups[f] != groups[g]) && bf.overlaps(&Aabb3::of_triangle(a, b, c)) {
                    results.extend(test_pair(mesh, f as u32, g as u32));
                }
            }
        }
        assemble(mesh, results, 0)
    }

    #[test]
    fn nodes_of_one_fan_are_skipped_but_fans_still_meet_other_faces() {
        // An open tube closed by two fans, each pierced by a small box: the fans' own pairs
        // are skipped whole (nodes of one group), the fans' crossings with the boxes are not.
        let tube = shapes::tube(0.5, 1.0, 48, 12, shapes::Caps::Open).unwrap();
        let top = shapes::grid_box(Vec3::new(-0.2, -0.1, 0.8), Vec3::new(0.1, 0.2, 1.2), 3).unwrap();
        let bottom = shapes::grid_box(Vec3::new(0.05, -0.25, -0.15), Vec3::new(0.3, 0.0, 0.1), 3).unwrap();
        let m = shapes::merge(&shapes::merge(&tube, &top).unwrap(), &bottom).unwrap();
        let closure = crate::close_holes(&m, &crate::HoleSelection::All).unwrap();
        let (closed, groups) = (closure.mesh(), closure.fan_groups());
        let mut ix = SelfIntersector::new(closed).with_groups(groups.clone());
        let found = ix.find(closed);
        let grouped_nodes = ix.node_groups.iter().filter(|&&g| g != 0).count();
        assert!(grouped_nodes >= 4, "{grouped_nodes} nodes lie in one fan");
        let slow = brute_force_grouped(closed, &groups);
        assert_eq!(found.points, slow.points);
        assert_eq!(found.segments, slow.segments);
        let fan_hits =
            |group: u32| found.segments.iter().filter(|s| s.faces.iter().any(|&f| groups[f as usize] == group)).count();
        assert!(fan_hits(1) >= 4 && fan_hits(2) >= 4, "{} {}", fan_hits(1), fan_hits(2));
    }

    #[test]
    fn grown_splits_make_most_nodes_disks() {
        // A sleeve pushed into a torso (grid-made): with halves grown across edges, 85% of
        // the nodes large enough to be tried are topological disks (79% with plain median
        // splits).
        let m = shapes::fixture("sleeve_torso_grid").unwrap();
        let ix = SelfIntersector::new(&m);
        let mut sizes = vec![0u32; ix.nodes.len()];
        for i in (0..ix.nodes.len()).rev() {
            let nd = ix.nodes[i];
            sizes[i] = if nd.leaf { nd.b - nd.a } else { sizes[nd.a as usize] + sizes[nd.b as usize] };
        }
        let tried: Vec<usize> = (0..ix.nodes.len()).filter(|&n| sizes[n] >= MIN_PATCH).collect();
        let disks = tried.iter().filter(|&&n| ix.patch_ranges[n][0] < ix.patch_ranges[n][1]).count();
        assert!(disks * 100 >= tried.len() * 83, "{disks} of {} nodes are disks", tried.len());
    }

    #[test]
    fn boundary_segment_tests_separate_only_with_margin() {
        let seg = |ids: [u32; 2], p: [f64; 2], q: [f64; 2]| Seg2 { ids, p, q, xmin: p[0].min(q[0]) };
        let tol = 1e-9;
        // Collinear, disjoint along the line.
        assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [2.0, 0.0], [3.0, 0.0]), tol));
        // Collinear, overlapping.
        assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [0.5, 0.0], [3.0, 0.0]), tol));
        // Crossing.
        assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 1.0]), &seg([2, 3], [0.0, 1.0], [1.0, 0.0]), tol));
        // Touching at a vertex of the other (not shared): not certainly apart.
        assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [0.5, 0.0], [0.5, 1.0]), tol));
        // Sharing a vertex: apart unless they leave it in the same direction.
        assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [2.0, 0.0]), tol));
        assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [0.0, 1.0]), tol));
        assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [0.5, 0.0]), tol));
        assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([0, 1], [0.0, 0.0], [1.0, 0.0]), tol));
    }
}
