//! Disk patches: nodes whose faces form a topological disk with normals in a narrow cone,
//! and the 2D segment tests that check their projected boundary is a simple curve.

use super::*;

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
/// and per node its range of slots. Topology only, computed once per tree. A face set is a disk when it is connected, every vertex's
/// ring is one fan in the mesh ([`RING_CLOSED`] or [`RING_OPEN`]) with zero or two boundary
/// edges of the set at that vertex (so the set is a surface with boundary), its boundary is
/// not empty and its Euler characteristic `V − E + F` is 1 (`2 − 2g − b = 1` with `b ≥ 1`
/// gives genus 0 and one boundary loop).
pub(super) fn disk_patches(
    n_vertices: usize,
    nodes: &[Node],
    slot_faces: &[[u32; 3]],
    slot_nbrs: &[[u32; 3]],
    kinds: &[u8],
) -> DiskPatches {
    let mut range = vec![[0u32; 2]; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let nd = nodes[i];
        range[i] = if nd.leaf { [nd.a, nd.b] } else { [range[nd.a as usize][0], range[nd.b as usize][1]] };
    }
    let mut out = vec![[0u32; 2]; nodes.len()];
    let mut edges: Vec<[u32; 2]> = Vec::new();
    let mut deg = vec![0u32; n_vertices];
    let mut seen = vec![u32::MAX; n_vertices];
    let mut reached_by = vec![u32::MAX; slot_faces.len()];
    let (mut verts, mut stack) = (Vec::new(), Vec::new());
    for (id, &[lo, hi]) in range.iter().enumerate() {
        let id32 = id as u32;
        let start = edges.len();
        out[id] = [start as u32; 2];
        if hi - lo < MIN_PATCH {
            continue;
        }
        // Slots are contiguous per node; `NO_FACE` is never inside.
        let inside = |slot: u32| (lo..hi).contains(&slot);
        let mut half_interior = 0usize;
        let mut manifold = true;
        verts.clear();
        for slot in lo as usize..hi as usize {
            let fv = slot_faces[slot];
            for k in 0..3 {
                let v = fv[k] as usize;
                if seen[v] != id32 {
                    seen[v] = id32;
                    verts.push(v);
                    manifold &= kinds[v] != RING_OTHER;
                }
                if inside(slot_nbrs[slot][k]) {
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
            reached_by[lo as usize] = id32;
            stack.clear();
            stack.push(lo);
            let mut reached = 1;
            while let Some(slot) = stack.pop() {
                for g in slot_nbrs[slot as usize] {
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
    DiskPatches { ranges: out, edges, slots: range }
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
