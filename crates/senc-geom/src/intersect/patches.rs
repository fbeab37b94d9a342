//! Disk patches: nodes whose faces form a topological disk with normals in a narrow cone,
//! and the 2D segment tests that check their projected boundary is a simple curve.

use super::*;
use std::sync::{Mutex, PoisonError};

/// Box of the unit normals of a set of faces, for the normal-cone test of disk patches
/// (see [`Traversal::patch_is_embedded`]). A face whose float normal direction cannot be
/// trusted (the sine of its angle at its first vertex at most 1e-6, so the direction's
/// rounding error could exceed about 1e-9) widens the box to the whole cube `[−1, 1]³`,
/// which never passes the test.
#[derive(Debug, Clone, Copy)]
pub(super) struct NormalBox {
    pub(super) lo: [f64; 3],
    pub(super) hi: [f64; 3],
}

impl NormalBox {
    pub(super) const EMPTY: NormalBox = NormalBox { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };

    /// Adds the face with scaled normal `n = e1 × e2` (edges `e1`, `e2` from its first vertex);
    /// returns its unit normal, or `None` when its direction cannot be trusted.
    #[inline]
    pub(super) fn add_face(&mut self, n: Vec3, e1: Vec3, e2: Vec3) -> Option<Vec3> {
        let nn = n.norm_squared();
        let unit = if nn.is_finite() && nn > 1e-12 * e1.norm_squared() * e2.norm_squared() {
            n / nn.sqrt()
        } else {
            self.lo = [-1.0; 3];
            self.hi = [1.0; 3];
            return None;
        };
        for ax in 0..3 {
            self.lo[ax] = lesser(self.lo[ax], unit[ax]);
            self.hi[ax] = greater(self.hi[ax], unit[ax]);
        }
        Some(unit)
    }

    #[inline]
    pub(super) fn union(&self, o: &NormalBox) -> NormalBox {
        NormalBox {
            lo: [lesser(self.lo[0], o.lo[0]), lesser(self.lo[1], o.lo[1]), lesser(self.lo[2], o.lo[2])],
            hi: [greater(self.hi[0], o.hi[0]), greater(self.hi[1], o.hi[1]), greater(self.hi[2], o.hi[2])],
        }
    }

    /// A unit direction `d` with `n · d > 1e-6` for every point `n` of the box (so for every
    /// unit normal in it), or `None`. `d` is the box's normalised centre; the minimum of the
    /// linear function `n · d` over the box is at a corner, `Σ min(lo·d, hi·d)` per axis.
    pub(super) fn direction(&self) -> Option<Vec3> {
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

/// A cone of unit face normals, the second normal test of disk patches (see
/// [`Traversal::patch_is_embedded`]; it passes on curved patches whose normal box holds
/// points far from the unit sphere): every face's computed unit normal `n` has
/// `n · axis ≥ cos`. The axis is the normalised sum of the unit normals (`sum`, added up the
/// tree); a parent's bound comes from its children's cones by the triangle inequality on
/// the sphere, `∠(n, axis) ≤ ∠(axis, axis_child) + ∠(n, axis_child)`, evaluated as
/// `cos(θ + α) = cos θ cos α − sin θ sin α` with `cos θ = axis · axis_child`,
/// `sin θ = |axis × axis_child|` and `sin α ≤ √(1 − cos²α) + 2e-8` (the bound covers the
/// rounding of `1 − cos²α` near 1). Each level subtracts `1e-12` from the bound, far above
/// the rounding of these few operations on unit vectors (about `1e-15`). A cone with
/// `cos ≤ 0` is no cone (`cos = −1`): its parents have none either. A face whose direction
/// cannot be trusted (see [`NormalBox`]) leaves its leaf without a cone.
#[derive(Debug, Clone, Copy)]
pub(super) struct NormalCone {
    pub(super) sum: Vec3,
    pub(super) axis: Vec3,
    pub(super) cos: f64,
}

/// Slack subtracted from a cone's bound at each level (see [`NormalCone`]).
const CONE_SLACK: f64 = 1e-12;

impl NormalCone {
    pub(super) const NONE: NormalCone =
        NormalCone { sum: Vec3::new(0.0, 0.0, 0.0), axis: Vec3::new(0.0, 0.0, 0.0), cos: -1.0 };

    /// The cone of the given unit normals; no cone when `trusted` is false or the normals
    /// sum to zero.
    pub(super) fn of_units(units: &[Vec3], trusted: bool) -> NormalCone {
        let sum: Vec3 = units.iter().sum();
        let len = sum.norm();
        if !(trusted && len.is_finite() && len > 0.0) {
            return NormalCone { sum, ..Self::NONE };
        }
        let axis = sum / len;
        let cos = units.iter().fold(1.0, |c, u| lesser(c, u.dot(&axis))) - CONE_SLACK;
        NormalCone { sum, axis, cos: if cos > 0.0 { cos } else { -1.0 } }
    }

    /// The cone of two nodes' normals (see the type's docs).
    pub(super) fn merge(&self, o: &NormalCone) -> NormalCone {
        let sum = self.sum + o.sum;
        if !(self.cos > 0.0 && o.cos > 0.0) {
            return NormalCone { sum, ..Self::NONE };
        }
        let len = sum.norm();
        if !(len.is_finite() && len > 0.0) {
            return NormalCone { sum, ..Self::NONE };
        }
        let axis = sum / len;
        let bound = |c: &NormalCone| {
            let cos_t = axis.dot(&c.axis);
            if cos_t.is_nan() || cos_t <= 0.0 {
                return -1.0;
            }
            let sin_t = axis.cross(&c.axis).norm();
            let sin_a = (1.0 - c.cos * c.cos).max(0.0).sqrt() + 2e-8;
            cos_t * c.cos - sin_t * sin_a
        };
        let cos = lesser(bound(self), bound(o)) - CONE_SLACK;
        NormalCone { sum, axis, cos: if cos > 0.0 { cos } else { -1.0 } }
    }

    /// The axis when every unit normal `n` of the cone has `n · axis > 1e-6` (the margin of
    /// [`NormalBox::direction`]), else `None`.
    #[inline]
    pub(super) fn direction(&self) -> Option<Vec3> {
        (self.cos > 1e-6).then_some(self.axis)
    }
}

/// Smallest node (in faces) whose disk-patch test is tried: below it, checking the boundary
/// costs more than the pairs it would skip.
pub(super) const MIN_PATCH: u32 = 16;

/// The disk patches of a tree (see [`disk_patches`]).
pub(super) struct DiskPatches {
    /// Per node: its range in `edges` (empty when it is not a disk patch).
    pub(super) ranges: Vec<[u32; 2]>,
    /// Boundary edges (vertex pairs) of the disk nodes, node after node.
    pub(super) edges: Vec<[u32; 2]>,
    /// Per node: its slots, `slots[0]..slots[1]`.
    pub(super) slots: Vec<[u32; 2]>,
}

/// Per node, the range of its boundary edges in the returned list when its faces form a
/// topological disk of at least [`MIN_PATCH`] faces (an empty range otherwise), the list,
/// and per node its range of slots. Topology only, computed once per tree. A face set is a
/// disk when it is connected, every vertex's ring is one fan in the mesh ([`RING_CLOSED`] or
/// [`RING_OPEN`]) with zero or two boundary edges of the set at that vertex (so the set is a
/// surface with boundary), its boundary is not empty and its Euler characteristic
/// `V − E + F` is 1 (`2 − 2g − b = 1` with `b ≥ 1` gives genus 0 and one boundary loop).
///
/// # Performance
/// Computed bottom-up, each node from its children's [`NodeCount`] and boundary: the
/// boundary of `A ∪ B` is theirs less the edges between them (each edge of `A`'s boundary
/// whose face across lies in `B`, which also count as the union's interior edges); the
/// vertices `A` and `B` share lie on both boundaries (a vertex whose ring is one fan and
/// which lies inside `A` has its whole ring in `A`), so `V(A ∪ B) = V(A) + V(B) −` the
/// vertices common to the two boundaries; the union of two connected sets is connected when
/// they share an edge. Vertices whose ring is more than one fan ([`ring_fans`]) and
/// unions of sets not known to be connected are counted and searched face by face, as is
/// every leaf. Each node costs about its boundary, not its faces; the boundary edges are
/// listed in slot order, then per slot in the order of [`crate::Topology::face_edges`].
/// The top [`PAR_BUILD_DEPTH`] levels do their two children's subtrees as two rayon tasks
/// (see [`DiskBuilder::node`]).
pub(super) fn disk_patches(
    n_vertices: usize,
    nodes: &[TreeNode],
    slot_faces: &[[u32; 3]],
    slot_nbrs: &[[u32; 3]],
    kinds: &[u8],
    pinched: &[bool],
) -> DiskPatches {
    let mut range = vec![[0u32; 2]; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let nd = nodes[i];
        range[i] = if nd.leaf { [nd.a, nd.b] } else { [range[nd.a as usize][0], range[nd.b as usize][1]] };
    }
    let mut b = DiskBuilder::new(n_vertices, nodes, slot_faces, slot_nbrs, kinds, pinched, &range);
    if !nodes.is_empty() {
        b.node(0, PAR_BUILD_DEPTH, &Mutex::new(Vec::new()));
    }
    let DiskBuilder { ranges, edges, .. } = b;
    DiskPatches { ranges, edges, slots: range }
}

/// What [`disk_patches`] carries up the tree per node (its boundary lies on the builder's
/// stack): the counts of its Euler characteristic and what its disk test needs.
#[derive(Debug, Clone, Copy)]
struct NodeCount {
    /// Distinct vertices (exact where `ok`).
    n_vertices: u32,
    /// Edges between two of its faces.
    n_interior: u32,
    /// Every vertex's ring is one fan or an open fan in the mesh ([`RING_CLOSED`],
    /// [`RING_OPEN`]).
    ok: bool,
    /// Some vertex's ring has more than one fan ([`ring_fans`]).
    pinched: bool,
    /// Edge-connected: `Some` when known.
    connected: Option<bool>,
}

/// Scratch of [`disk_patches`].
struct DiskBuilder<'a> {
    nodes: &'a [TreeNode],
    slot_faces: &'a [[u32; 3]],
    slot_nbrs: &'a [[u32; 3]],
    kinds: &'a [u8],
    pinched: &'a [bool],
    range: &'a [[u32; 2]],
    ranges: Vec<[u32; 2]>,
    edges: Vec<[u32; 2]>,
    /// The boundaries of the nodes being merged, each node's in slot order, children
    /// before their parent replaces them.
    bnd: Vec<BoundaryEdge>,
    stamp_a: Vec<u32>,
    stamp_b: Vec<u32>,
    deg: Vec<u32>,
    reached_by: Vec<u32>,
    stack: Vec<u32>,
}

/// An edge of a node's boundary: the edge opposite corner `k` of the face in some slot,
/// its vertices `(fv[k + 1], fv[k + 2])` and the slot of the face across (or [`NO_FACE`]).
#[derive(Debug, Clone, Copy)]
struct BoundaryEdge {
    v: [u32; 2],
    across: u32,
}

impl<'a> DiskBuilder<'a> {
    fn new(
        n_vertices: usize,
        nodes: &'a [TreeNode],
        slot_faces: &'a [[u32; 3]],
        slot_nbrs: &'a [[u32; 3]],
        kinds: &'a [u8],
        pinched: &'a [bool],
        range: &'a [[u32; 2]],
    ) -> Self {
        DiskBuilder {
            nodes,
            slot_faces,
            slot_nbrs,
            kinds,
            pinched,
            range,
            ranges: vec![[0u32; 2]; nodes.len()],
            edges: Vec::new(),
            bnd: Vec::new(),
            stamp_a: vec![u32::MAX; n_vertices],
            stamp_b: vec![u32::MAX; n_vertices],
            deg: vec![0u32; n_vertices],
            reached_by: vec![u32::MAX; slot_faces.len()],
            stack: Vec::new(),
        }
    }

    /// Node `id`'s counts; its boundary is pushed on `bnd`, and its range set. At the first
    /// `par` levels, nodes of at least [`PAR_BUILD_MIN`] faces do their second child as a
    /// separate rayon task, with a builder taken from `spare` (or a new one), whose
    /// boundary, edges and ranges are then copied into this one's before it goes back to
    /// `spare`: the same output as without (stamps are node ids, unique in the tree, and
    /// the degrees are left zero, so a builder's scratch needs no clearing).
    fn node(&mut self, id: usize, par: u32, spare: &Mutex<Vec<DiskBuilder<'a>>>) -> NodeCount {
        let nd = self.nodes[id];
        let [lo, hi] = self.range[id];
        let start = self.bnd.len();
        let count = if nd.leaf {
            self.leaf(id as u32, lo, hi)
        } else if par > 0 && (hi - lo) as usize >= PAR_BUILD_MIN {
            let (ia, ib) = (nd.a as usize, nd.b as usize);
            let n_vertices = self.deg.len();
            let (nodes, slot_faces, slot_nbrs, kinds, pinched, range) =
                (self.nodes, self.slot_faces, self.slot_nbrs, self.kinds, self.pinched, self.range);
            let (a, (b, mut other)) = rayon::join(
                || self.node(ia, par - 1, spare),
                || {
                    let taken = spare.lock().unwrap_or_else(PoisonError::into_inner).pop();
                    let mut other = taken.unwrap_or_else(|| {
                        DiskBuilder::new(n_vertices, nodes, slot_faces, slot_nbrs, kinds, pinched, range)
                    });
                    (other.node(ib, par - 1, spare), other)
                },
            );
            // The second child's subtree is the nodes `ib..end` (parents before children,
            // each node's first subtree before its second).
            let mut end = ib;
            while !self.nodes[end].leaf {
                end = self.nodes[end].b as usize;
            }
            let offset = self.edges.len() as u32;
            for (r, o) in self.ranges[ib..=end].iter_mut().zip(&other.ranges[ib..=end]) {
                *r = o.map(|x| x + offset);
            }
            self.edges.extend_from_slice(&other.edges);
            let split = self.bnd.len();
            self.bnd.extend_from_slice(&other.bnd);
            other.edges.clear();
            other.bnd.clear();
            spare.lock().unwrap_or_else(PoisonError::into_inner).push(other);
            self.merge(id as u32, [lo, self.range[ia][1], hi], a, b, start, split)
        } else {
            let a = self.node(nd.a as usize, 0, spare);
            let split = self.bnd.len();
            let b = self.node(nd.b as usize, 0, spare);
            self.merge(id as u32, [lo, self.range[nd.a as usize][1], hi], a, b, start, split)
        };
        let mut count = count;
        self.ranges[id] = [self.edges.len() as u32; 2];
        if hi - lo >= MIN_PATCH && self.is_disk(id as u32, lo, hi, &mut count, start) {
            let first = self.edges.len();
            self.edges.extend(self.bnd[start..].iter().map(|e| e.v));
            self.ranges[id] = [first as u32, self.edges.len() as u32];
        }
        count
    }

    /// The counts of the faces in slots `lo..hi` (a leaf, at most [`LEAF_SIZE`] faces),
    /// counted face by face (pushes their boundary).
    fn leaf(&mut self, id: u32, lo: u32, hi: u32) -> NodeCount {
        let mut count = NodeCount { n_vertices: 0, n_interior: 0, ok: true, pinched: false, connected: None };
        let mut half_interior = 0;
        // Per face, the smallest face (slot offset) it is linked to so far.
        let mut root: [u32; LEAF_SIZE] = std::array::from_fn(|i| i as u32);
        for slot in lo..hi {
            let fv = self.slot_faces[slot as usize];
            for k in 0..3 {
                let v = fv[k] as usize;
                if self.stamp_a[v] != id {
                    self.stamp_a[v] = id;
                    count.n_vertices += 1;
                    count.ok &= self.kinds[v] != RING_OTHER;
                    count.pinched |= self.pinched[v];
                }
                let across = self.slot_nbrs[slot as usize][k];
                if (lo..hi).contains(&across) {
                    half_interior += 1;
                    let (x, y) = (root[(slot - lo) as usize], root[(across - lo) as usize]);
                    for r in &mut root {
                        if *r == x || *r == y {
                            *r = x.min(y);
                        }
                    }
                } else {
                    self.bnd.push(BoundaryEdge { v: [fv[(k + 1) % 3], fv[(k + 2) % 3]], across });
                }
            }
        }
        count.n_interior = half_interior / 2;
        count.connected = Some(root[..(hi - lo) as usize].iter().all(|&r| r == 0));
        count
    }

    /// The counts of the union of the children over slots `lo..mid` and `mid..hi`
    /// (`[lo, mid, hi]`), whose boundaries are `bnd[start..split]` and `bnd[split..]`;
    /// replaces them by the union's boundary.
    fn merge(
        &mut self,
        id: u32,
        [lo, mid, hi]: [u32; 3],
        a: NodeCount,
        b: NodeCount,
        start: usize,
        split: usize,
    ) -> NodeCount {
        let ok = a.ok && b.ok;
        let pinched = a.pinched || b.pinched;
        // Shared vertices, from the two boundaries (the vertex count matters only when
        // every ring is one fan or an open fan, `ok`).
        let mut shared_vertices = 0;
        if ok && !pinched {
            for e in &self.bnd[start..split] {
                for v in e.v {
                    self.stamp_a[v as usize] = id;
                }
            }
            for e in &self.bnd[split..] {
                for v in e.v {
                    let v = v as usize;
                    if self.stamp_a[v] == id && self.stamp_b[v] != id {
                        self.stamp_b[v] = id;
                        shared_vertices += 1;
                    }
                }
            }
        }
        // The union's boundary, in place: each child's edges whose face across is not in
        // the other child.
        let mut shared_edges = 0;
        let mut w = start;
        for i in start..self.bnd.len() {
            let e = self.bnd[i];
            let other = if i < split { (mid..hi).contains(&e.across) } else { (lo..mid).contains(&e.across) };
            shared_edges += (i < split && other) as u32;
            self.bnd[w] = e;
            w += !other as usize;
        }
        self.bnd.truncate(w);
        let n_vertices = if ok && pinched {
            self.count_vertices(id, lo, hi)
        } else {
            (a.n_vertices + b.n_vertices).wrapping_sub(shared_vertices)
        };
        let connected = match (a.connected, b.connected) {
            (Some(true), Some(true)) => Some(shared_edges > 0),
            _ => None,
        };
        NodeCount { n_vertices, n_interior: a.n_interior + b.n_interior + shared_edges, ok, pinched, connected }
    }

    /// Distinct vertices of the faces in slots `lo..hi`, counted face by face.
    fn count_vertices(&mut self, id: u32, lo: u32, hi: u32) -> u32 {
        let mut n = 0;
        for slot in lo..hi {
            for v in self.slot_faces[slot as usize] {
                if self.stamp_a[v as usize] != id {
                    self.stamp_a[v as usize] = id;
                    n += 1;
                }
            }
        }
        n
    }

    /// Whether node `id` over slots `lo..hi`, with these counts and its boundary at
    /// `bnd[start..]`, is a disk (see [`disk_patches`]); settles `count.connected` where it
    /// searches the faces.
    fn is_disk(&mut self, id: u32, lo: u32, hi: u32, count: &mut NodeCount, start: usize) -> bool {
        let n_boundary = self.bnd.len() - start;
        if !count.ok || n_boundary == 0 {
            return false;
        }
        let mut manifold = true;
        for e in &self.bnd[start..] {
            for v in e.v {
                self.deg[v as usize] += 1;
            }
        }
        for e in &self.bnd[start..] {
            for v in e.v {
                let d = &mut self.deg[v as usize];
                manifold &= *d == 0 || *d == 2;
                *d = 0;
            }
        }
        let euler = i64::from(count.n_vertices) - i64::from(count.n_interior) - n_boundary as i64 + i64::from(hi - lo);
        if !(manifold && euler == 1) {
            return false;
        }
        if count.connected.is_none() {
            self.reached_by[lo as usize] = id;
            self.stack.clear();
            self.stack.push(lo);
            let mut reached = 1;
            while let Some(slot) = self.stack.pop() {
                for g in self.slot_nbrs[slot as usize] {
                    if (lo..hi).contains(&g) && self.reached_by[g as usize] != id {
                        self.reached_by[g as usize] = id;
                        reached += 1;
                        self.stack.push(g);
                    }
                }
            }
            count.connected = Some(reached == hi - lo);
        }
        count.connected == Some(true)
    }
}

/// Per vertex, whether its ring of faces is more than one fan (faces around it linked
/// through the edges at it), from its wedges `links[start[s]..start[s + 1]]` (see
/// [`ring_links`]; in a consistently oriented mesh, the wedge `(a, b)` is followed by the
/// wedge `(b, c)` around the vertex). Topology only; only rings of kind [`RING_CLOSED`] or
/// [`RING_OPEN`] are walked (the others are never part of a disk).
pub(super) fn ring_fans(kinds: &[u8], start: &[u32], links: &[[u32; 2]]) -> Vec<bool> {
    kinds
        .iter()
        .enumerate()
        .map(|(s, &kind)| {
            if kind == RING_OTHER {
                return false;
            }
            let ring = &links[start[s] as usize..start[s + 1] as usize];
            // Walk from a wedge whose `a` ends no wedge (an open fan's first), or any.
            let first = if kind == RING_CLOSED {
                0
            } else {
                ring.iter().position(|w| !ring.iter().any(|x| x[1] == w[0])).unwrap_or(0)
            };
            let mut at = ring[first];
            let mut steps = 1;
            while let Some(next) = ring.iter().find(|x| x[0] == at[1]) {
                if *next == ring[first] || steps > ring.len() {
                    break;
                }
                at = *next;
                steps += 1;
            }
            steps != ring.len()
        })
        .collect()
}

/// Per face, the face across each of its edges (`[k]`: across the edge opposite vertex `k`,
/// see [`crate::Topology::face_edges`]), or [`NO_FACE`] at a boundary edge. Topology only.
pub(super) fn face_neighbours(mesh: &TriMesh) -> Vec<[u32; 3]> {
    let topo = mesh.topology();
    let edge_faces = topo.edge_faces();
    topo.face_edges()
        .iter()
        .enumerate()
        .map(|(f, es)| {
            es.map(|e| {
                let [g0, g1] = edge_faces[e as usize];
                if g0 == f as u32 {
                    g1
                } else {
                    g0
                }
            })
        })
        .collect()
}

/// A boundary edge of a patch projected to the plane: its vertex ids, end points and
/// smallest `x`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Seg2 {
    pub(super) ids: [u32; 2],
    pub(super) p: [f64; 2],
    pub(super) q: [f64; 2],
    pub(super) xmin: f64,
}

/// `(b − a) × (c − a)` in the plane.
#[inline]
pub(super) fn cross2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[inline]
pub(super) fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (x, y) = (b[0] - a[0], b[1] - a[1]);
    (x * x + y * y).sqrt()
}

/// Whether two projected boundary edges certainly meet at most in a shared end: with one
/// shared vertex `v`, the other ends must leave `v` in directions that are not the same
/// (the second more than `tol` from the first's line, or pointing backwards); with none,
/// one segment's ends must both lie more than `tol` on one side of the other's line. Every
/// segment is at least `1000 tol` long, and `tol` is far above the rounding of the
/// projected coordinates, so the answer holds for the exact projection too.
pub(super) fn segments_apart(s: &Seg2, t: &Seg2, tol: f64) -> bool {
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
