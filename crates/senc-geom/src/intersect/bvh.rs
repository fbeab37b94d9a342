//! The broad phase's bounding-volume hierarchy: boxes rounded outward to f32, leaf lanes
//! of four faces, the tree build (connected halves) and refit, and [`SelfIntersector`].

use super::*;
use std::sync::atomic::{AtomicU32, AtomicU64};

/// Levels of the tree build whose two halves are built in parallel (see [`Builder::node`]).
pub(super) const PAR_BUILD_DEPTH: u32 = 3;

/// Smallest node (in faces) whose halves are built in parallel.
pub(super) const PAR_BUILD_MIN: usize = 2048;

/// Fewest items per task of the parallel loops over faces in the tree build and the refit.
pub(super) const PAR_MIN_ITEMS: usize = 2048;

/// Faces per BVH leaf. Leaves of a few faces keep the tree shallow; the face pairs inside
/// a leaf pair are still each checked against their boxes before any other work.
pub(super) const LEAF_SIZE: usize = 4;

/// The smaller of two numbers that are not NaN (one `minsd`; `f64::min` also handles NaN).
/// Positions are finite (checked by [`TriMesh`]), and so are the bounds built from them.
#[inline(always)]
pub(super) fn lesser(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of two numbers that are not NaN (see [`lesser`]).
#[inline(always)]
pub(super) fn greater(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// Axis-aligned box, closed (touching boxes overlap).
#[derive(Debug, Clone, Copy)]
pub(super) struct Aabb3 {
    pub(super) lo: [f64; 3],
    pub(super) hi: [f64; 3],
}

impl Aabb3 {
    pub(super) const EMPTY: Aabb3 = Aabb3 { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };

    #[inline]
    pub(super) fn of_triangle(a: Vec3, b: Vec3, c: Vec3) -> Self {
        let lo = |ax: usize| lesser(lesser(a[ax], b[ax]), c[ax]);
        let hi = |ax: usize| greater(greater(a[ax], b[ax]), c[ax]);
        Aabb3 { lo: [lo(0), lo(1), lo(2)], hi: [hi(0), hi(1), hi(2)] }
    }

    /// Whether the boxes overlap: all six comparisons, combined without branches (the
    /// traversal's outcomes are unpredictable, so short-circuiting only adds mispredictions).
    #[inline]
    pub(super) fn overlaps(&self, o: &Aabb3) -> bool {
        (self.lo[0] <= o.hi[0])
            & (o.lo[0] <= self.hi[0])
            & (self.lo[1] <= o.hi[1])
            & (o.lo[1] <= self.hi[1])
            & (self.lo[2] <= o.hi[2])
            & (o.lo[2] <= self.hi[2])
    }

    #[inline]
    pub(super) fn union(&self, o: &Aabb3) -> Aabb3 {
        Aabb3 {
            lo: [lesser(self.lo[0], o.lo[0]), lesser(self.lo[1], o.lo[1]), lesser(self.lo[2], o.lo[2])],
            hi: [greater(self.hi[0], o.hi[0]), greater(self.hi[1], o.hi[1]), greater(self.hi[2], o.hi[2])],
        }
    }

    /// Half the box's surface-area measure (for choosing which node to descend).
    #[inline]
    pub(super) fn size(&self) -> f64 {
        let d = [self.hi[0] - self.lo[0], self.hi[1] - self.lo[1], self.hi[2] - self.lo[2]];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// The boxes of one leaf's (up to [`LEAF_SIZE`]) faces in single precision, rounded
/// outward (so never smaller than the true boxes), one array per bound and axis, for
/// testing one face against a whole leaf at once. Unused lanes hold empty boxes.
#[derive(Debug, Clone, Copy)]
pub(super) struct LeafBoxes {
    pub(super) lo: [[f32; LEAF_SIZE]; 3],
    pub(super) hi: [[f32; LEAF_SIZE]; 3],
}

impl LeafBoxes {
    pub(super) const EMPTY: LeafBoxes =
        LeafBoxes { lo: [[f32::INFINITY; LEAF_SIZE]; 3], hi: [[f32::NEG_INFINITY; LEAF_SIZE]; 3] };

    /// Bit `k` set when lane `k`'s box overlaps lane `lane`'s box of `other`: six 4-wide
    /// comparisons (`wide`, SSE on x86-64) and one move-mask.
    #[inline(always)]
    pub(super) fn overlap_mask(&self, other: &LeafBoxes, lane: usize) -> u32 {
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
pub(super) struct LeafVerts {
    pub(super) v: [[i32; LEAF_SIZE]; 3],
    pub(super) g: [i32; LEAF_SIZE],
}

impl LeafVerts {
    /// Per leaf group of `slot_faces` / `slot_groups` (empty: every group 0).
    pub(super) fn of_slots(slot_faces: &[[u32; 3]], slot_groups: &[u32]) -> Vec<LeafVerts> {
        slot_faces
            .chunks(LEAF_SIZE)
            .enumerate()
            .map(|(i, fs)| {
                let mut lv = LeafVerts { v: [[-1; LEAF_SIZE]; 3], g: [0; LEAF_SIZE] };
                for (k, f) in fs.iter().enumerate() {
                    for (c, &v) in f.iter().enumerate() {
                        lv.v[c][k] = v as i32;
                    }
                    lv.g[k] = slot_groups.get(i * LEAF_SIZE + k).map_or(0, |&g| g as i32);
                }
                lv
            })
            .collect()
    }

    /// For face `f` (vertex ids) of group `g`: the masks of lanes that share no vertex with
    /// it and of lanes that share exactly one, both without the lanes of the same nonzero
    /// group (pairs sharing an edge or in one group are never tested), and per corner `k`
    /// of `f` the mask of lanes holding vertex `f[k]`.
    #[inline(always)]
    pub(super) fn classify(&self, f: [u32; 3], g: u32) -> (u32, u32, [u32; 3]) {
        let corners = [i32x4::new(self.v[0]), i32x4::new(self.v[1]), i32x4::new(self.v[2])];
        // Minus the number of shared vertices per lane: a lane's corners are distinct, so
        // each vertex of `f` equals at most one of them (an equal comparison is −1).
        let mut neg_shared = i32x4::splat(0);
        let mut holds = [0u32; 3];
        for (k, v) in f.into_iter().enumerate() {
            let v = i32x4::splat(v as i32);
            let eq = v.cmp_eq(corners[0]) | v.cmp_eq(corners[1]) | v.cmp_eq(corners[2]);
            neg_shared += eq;
            holds[k] = eq.move_mask() as u32;
        }
        let same_group = if g == 0 { 0 } else { i32x4::splat(g as i32).cmp_eq(i32x4::new(self.g)).move_mask() as u32 };
        let none = neg_shared.cmp_eq(i32x4::splat(0)).move_mask() as u32;
        let one = neg_shared.cmp_eq(i32x4::splat(-1)).move_mask() as u32;
        (none & !same_group, one & !same_group, holds)
    }
}

/// Relative margin of [`f32_down`] / [`f32_up`]: just above the relative rounding error of
/// a conversion to `f32` (`2⁻²⁴ / (1 − 2⁻²⁴) ≈ 5.9605e-8`).
const F32_MARGIN: f64 = 6.0e-8;

/// Absolute margin of [`f32_down`] / [`f32_up`]: just above the absolute rounding error of
/// a conversion to a subnormal `f32` (half the smallest one, `7.006e-46`).
const F32_TINY: f64 = 7.5e-46;

/// `x` rounded to an `f32` not above it, without branches: `x` is moved down by more than
/// the rounding error of the conversion (relative [`F32_MARGIN`], absolute [`F32_TINY`])
/// and then rounded to nearest, so the result is at most about `1.2e-7 |x| + 1.5e-45` below
/// `x`. Beyond the `f32` range: `f32::MAX` (below a larger `x`) or `−∞`.
#[inline]
pub(super) fn f32_down(x: f64) -> f32 {
    ((x - x.abs() * F32_MARGIN - F32_TINY) as f32).min(f32::MAX)
}

/// `x` rounded to an `f32` not below it (see [`f32_down`]).
#[inline]
pub(super) fn f32_up(x: f64) -> f32 {
    ((x + x.abs() * F32_MARGIN + F32_TINY) as f32).max(f32::MIN)
}

/// A BVH node: an inner node with children `a`, `b`, or a leaf over slots `a..b`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    pub(super) bbox: Aabb3,
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) leaf: bool,
}

/// A node of the tree's shape, as [`Node`] without its box: a leaf over slots `a..b`, or an
/// inner node with children `a` and `b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct TreeNode {
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) leaf: bool,
}

/// The parts of a [`SelfIntersector`] that depend only on the faces, and on the positions
/// its tree was built for: the tree's shape and slot order, per-slot vertex ids, vertex
/// rings and the disk-patch boundaries. Built once per [`crate::Topology`] (see
/// [`SearchSlot`]) and shared, read-only, by every intersector of a mesh with that topology;
/// a tree built for other positions of the same faces stays correct after a refit (only its
/// boxes, refit per call, are tested).
#[derive(Debug)]
pub(crate) struct SearchTree {
    /// The nodes' shape (each intersector adds boxes and refits them).
    pub(super) nodes: Vec<TreeNode>,
    /// Slot → face.
    pub(super) order: Vec<u32>,
    /// Per slot: the face's vertex ids.
    pub(super) slot_faces: Vec<[u32; 3]>,
    /// Per group of [`LEAF_SIZE`] slots: the faces' vertex ids, all in group 0.
    pub(super) leaf_verts: Arc<Vec<LeafVerts>>,
    /// Per vertex: [`RING_CLOSED`], [`RING_OPEN`] or [`RING_OTHER`].
    pub(super) ring_kind: Vec<u8>,
    /// Per vertex `s`, its ring's wedges `(a, b)` (face `(s, a, b)`) in
    /// `ring_links[ring_start[s]..ring_start[s + 1]]` (topology, for [`ring_is_embedded`]).
    pub(super) ring_start: Vec<u32>,
    pub(super) ring_links: Vec<[u32; 2]>,
    /// Per node: its range in `patch_edges` when its faces form a topological disk of at
    /// least [`MIN_PATCH`] faces (empty otherwise); see [`Traversal::patch_is_embedded`].
    pub(super) patch_ranges: Vec<[u32; 2]>,
    /// Boundary edges (vertex pairs) of the disk nodes, node after node.
    pub(super) patch_edges: Vec<[u32; 2]>,
    /// Per node: its slots, `slots[0]..slots[1]`.
    pub(super) node_slots: Vec<[u32; 2]>,
}

/// The tree's nodes and slot order over faces with these centroid keys per axis (see
/// [`coordinate_key`]) and edge neighbours (see [`Builder::node`]; `par` levels of parallel
/// halves).
pub(super) fn build_tree(keys: [&[u64]; 3], nbrs: &[[u32; 3]], par: u32) -> (Vec<TreeNode>, Vec<u32>) {
    let n = nbrs.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut nodes = Vec::new();
    if n > 0 {
        // The faces sorted along each axis once; each split reads its faces' order along its
        // axis from their ranks.
        let (x, (y, z)) =
            rayon::join(|| radix_order(keys[0]), || rayon::join(|| radix_order(keys[1]), || radix_order(keys[2])));
        let mut rank = vec![[0u32; 3]; n];
        for (axis, list) in [&x, &y, &z].into_iter().enumerate() {
            for (r, &f) in list.iter().enumerate() {
                rank[f as usize][axis] = r as u32;
            }
        }
        let marks = FaceMarks::new(n);
        let mut b = Builder::new(nbrs, keys, &rank, [&x, &y, &z], &marks, 0);
        nodes = vec![TreeNode { a: 0, b: 0, leaf: true }; subtree_nodes(n)];
        b.node(&mut nodes, 0, &mut order, 0, n, par);
    }
    (nodes, order)
}

/// The number of nodes of the tree over `m > 0` faces: `2 ⌈m / LEAF_SIZE⌉ − 1`. A node
/// of at most [`LEAF_SIZE`] faces is a leaf, and a split gives its first half
/// `⌊l / 2⌋` of its `l = ⌈m / LEAF_SIZE⌉` leaves' worth of faces (a multiple of
/// `LEAF_SIZE`), so the halves have `⌊l / 2⌋` and `l − ⌊l / 2⌋` leaves: `l` leaves in all,
/// joined by `l − 1` splits.
pub(super) fn subtree_nodes(m: usize) -> usize {
    2 * m.div_ceil(LEAF_SIZE) - 1
}

/// The indices `0..keys.len()` sorted by `(keys[i], i)`: a stable least-significant-digit
/// radix sort of the keys, 11 bits per pass, skipping the passes where every key has the
/// same digit.
pub(super) fn radix_order(keys: &[u64]) -> Vec<u32> {
    const BITS: usize = 11;
    const PASSES: usize = 64usize.div_ceil(BITS);
    const MASK: u64 = (1 << BITS) - 1;
    let n = keys.len();
    let mut counts = vec![[0u32; 1 << BITS]; PASSES];
    for &k in keys {
        for (p, c) in counts.iter_mut().enumerate() {
            c[((k >> (p * BITS)) & MASK) as usize] += 1;
        }
    }
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut next = vec![0u32; n];
    for (p, c) in counts.iter_mut().enumerate() {
        if c.iter().any(|&x| x as usize == n) {
            continue;
        }
        let mut sum = 0;
        for x in c.iter_mut() {
            (*x, sum) = (sum, sum + *x);
        }
        for &i in &order {
            let d = ((keys[i as usize] >> (p * BITS)) & MASK) as usize;
            next[c[d] as usize] = i;
            c[d] += 1;
        }
        std::mem::swap(&mut order, &mut next);
    }
    order
}

/// A coordinate as bits that order as the numbers do (not NaN).
#[inline]
pub(super) fn coordinate_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}

/// The coordinate of a [`coordinate_key`].
#[inline]
pub(super) fn key_coordinate(key: u64) -> f64 {
    f64::from_bits(if key >> 63 == 1 { key & !(1 << 63) } else { !key })
}

impl SearchTree {
    /// Builds the tree over `mesh`'s faces at its current positions.
    fn build(mesh: &TriMesh) -> Self {
        let n = mesh.n_faces();
        // The tree on one side, the vertex rings (topology only) on the other.
        let ((nodes, order, nbrs), (ring_kind, (ring_start, ring_links), pinched)) = rayon::join(
            || {
                // Per axis, the key of every face's centroid coordinate, `(a + b + c) / 3`.
                let (pos, faces) = (mesh.positions(), mesh.faces());
                let keys_along = |axis: usize| -> Vec<u64> {
                    let c = |v: u32| pos[v as usize][axis];
                    faces.iter().map(|&[a, b, cc]| coordinate_key((c(a) + c(b) + c(cc)) / 3.0)).collect()
                };
                let ((x, y), (z, nbrs)) = rayon::join(
                    || rayon::join(|| keys_along(0), || keys_along(1)),
                    || rayon::join(|| keys_along(2), || face_neighbours(mesh)),
                );
                let (nodes, order) = build_tree([&x, &y, &z], &nbrs, PAR_BUILD_DEPTH);
                (nodes, order, nbrs)
            },
            || {
                let kinds = ring_kinds(mesh);
                let (start, links) = ring_links(mesh);
                let pinched = ring_fans(&kinds, &start, &links);
                (kinds, (start, links), pinched)
            },
        );
        let mut slot_of = vec![0u32; n];
        for (slot, &f) in order.iter().enumerate() {
            slot_of[f as usize] = slot as u32;
        }
        let (mut slot_faces, mut slot_nbrs) = (Vec::with_capacity(n), Vec::with_capacity(n));
        rayon::join(
            || {
                order
                    .par_iter()
                    .with_min_len(PAR_MIN_ITEMS)
                    .map(|&f| mesh.faces()[f as usize])
                    .collect_into_vec(&mut slot_faces)
            },
            || {
                order
                    .par_iter()
                    .with_min_len(PAR_MIN_ITEMS)
                    .map(|&f| nbrs[f as usize].map(|g| if g == NO_FACE { NO_FACE } else { slot_of[g as usize] }))
                    .collect_into_vec(&mut slot_nbrs)
            },
        );
        let (DiskPatches { ranges: patch_ranges, edges: patch_edges, slots: node_slots }, leaf_verts) = rayon::join(
            || disk_patches(mesh.n_vertices(), &nodes, &slot_faces, &slot_nbrs, &ring_kind, &pinched),
            || LeafVerts::of_slots(&slot_faces, &[]),
        );
        Self {
            leaf_verts: Arc::new(leaf_verts),
            nodes,
            order,
            slot_faces,
            ring_kind,
            ring_start,
            ring_links,
            patch_ranges,
            patch_edges,
            node_slots,
        }
    }
}

/// Where a [`crate::Topology`] keeps its [`SearchTree`]: empty until the first
/// [`SelfIntersector`] for a mesh with that topology builds it. Clones share the tree; two
/// slots always compare equal (the tree is derived data, not part of the connectivity).
#[derive(Default, Clone)]
pub(crate) struct SearchSlot(OnceLock<Arc<SearchTree>>);

impl PartialEq for SearchSlot {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for SearchSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.get().is_some() { "SearchSlot(built)" } else { "SearchSlot(empty)" })
    }
}

/// Reusable self-intersection finder: keeps its BVH between calls and refits it when only
/// the positions change.
///
/// The BVH is built once over the faces (median splits of face centroids along the longest
/// axis, leaves of [`LEAF_SIZE`] faces) and stores, per leaf slot, the face's vertex ids and
/// group, so the self-traversal rejects neighbouring faces by comparing ids, without
/// touching the mesh. The tree and every other structure that depends only on the faces
/// ([`SearchTree`]) is built once per [`crate::Topology`] and shared by all intersectors of
/// meshes with that topology (clones of one mesh, or meshes made from it with
/// [`TriMesh::with_positions`]); each intersector owns only its refit boxes and planes. At
/// the leaves, one face's box is tested against a whole leaf's boxes at once, in single
/// precision rounded outward (boxes only ever grow, so no overlapping pair is missed; a few
/// touching pairs more reach the exact test). Each face pair whose boxes overlap goes
/// straight through the filters and the exact test; no pair list is materialised.
pub struct SelfIntersector {
    /// The topology of the mesh the tree was made for (a mesh sharing it has these faces).
    pub(super) topology: Arc<Topology>,
    pub(super) tree: Arc<SearchTree>,
    /// Faces with the same nonzero group are never tested against each other.
    pub(super) groups: Vec<u32>,
    /// The tree's nodes with the boxes of the last refit.
    pub(super) nodes: Vec<Node>,
    /// Per slot: the face's group (0 = none).
    pub(super) slot_groups: Vec<u32>,
    /// Per node: the group shared by all its faces when that is nonzero, else 0. A node
    /// with a group is never traversed within itself, nor against a node of the same group
    /// (every pair there is skipped by group anyway).
    pub(super) node_groups: Vec<u32>,
    /// Whether some node has a nonzero group (otherwise the traversal skips the checks).
    pub(super) grouped: bool,
    // Per-call buffers, reused.
    /// Per group of [`LEAF_SIZE`] slots (every leaf is one such group): the box of its
    /// faces.
    pub(super) group_boxes: Vec<Aabb3>,
    /// Per group of [`LEAF_SIZE`] slots (every leaf is one such group).
    pub(super) lanes: Vec<LeafBoxes>,
    /// Per group of [`LEAF_SIZE`] slots: the faces' vertex ids and groups (topology; the
    /// tree's own when there are no groups).
    pub(super) leaf_verts: Arc<Vec<LeafVerts>>,
    pub(super) planes: Vec<FacePlane>,
    /// Per vertex, whether its ring is embedded ([`RING_YES`] / [`RING_NO`]), or
    /// [`RING_UNKNOWN`] until a pair sharing only that vertex asks (computed lazily: most
    /// vertices lie inside skipped patches and are never asked about).
    pub(super) rings: Vec<AtomicU8>,
    /// Per leaf group, then per node: the box of the unit face normals.
    pub(super) group_normals: Vec<NormalBox>,
    pub(super) node_normals: Vec<NormalBox>,
    /// Per leaf group, then per node: the cone of the unit face normals.
    pub(super) group_cones: Vec<NormalCone>,
    pub(super) node_cones: Vec<NormalCone>,
    /// Per slot: the face's unit normal, or zero where its direction cannot be trusted
    /// (see [`NormalBox::add_face`]).
    pub(super) units: Vec<Vec3>,
}

impl std::fmt::Debug for SelfIntersector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelfIntersector")
            .field("n_faces", &self.tree.order.len())
            .field("n_nodes", &self.nodes.len())
            .finish()
    }
}

impl SelfIntersector {
    /// An intersector for `mesh`'s faces: its topology's search tree, built here over the
    /// current positions if no intersector for that topology was made before.
    pub fn new(mesh: &TriMesh) -> Self {
        let topology = mesh.topology_arc();
        let tree = Arc::clone(topology.search.0.get_or_init(|| Arc::new(SearchTree::build(mesh))));
        let n = tree.order.len();
        let mut ix = Self {
            slot_groups: vec![0; n],
            leaf_verts: Arc::clone(&tree.leaf_verts),
            node_groups: vec![0; tree.nodes.len()],
            grouped: false,
            nodes: tree.nodes.iter().map(|t| Node { bbox: Aabb3::EMPTY, a: t.a, b: t.b, leaf: t.leaf }).collect(),
            groups: Vec::new(),
            topology,
            tree,
            group_boxes: Vec::new(),
            lanes: Vec::new(),
            planes: Vec::new(),
            rings: Vec::new(),
            group_normals: Vec::new(),
            node_normals: Vec::new(),
            group_cones: Vec::new(),
            node_cones: Vec::new(),
            units: Vec::new(),
        };
        // The refit's buffers are allocated here, by the caller's thread.
        ix.size_buffers();
        ix
    }

    /// Whether `mesh` has the faces the tree was made for (the same topology, or equal
    /// faces).
    pub(super) fn fits(&self, mesh: &TriMesh) -> bool {
        let (order, faces) = (&self.tree.order, mesh.faces());
        std::ptr::eq(mesh.topology(), Arc::as_ptr(&self.topology))
            || (faces.len() == order.len()
                && order.iter().zip(&self.tree.slot_faces).all(|(&f, sf)| faces[f as usize] == *sf))
    }

    /// Faces sharing a nonzero `groups[f]` are not tested against each other, e.g. the fan
    /// caps of closed holes when crossings of a cap with itself are not wanted (a fan's
    /// triangles share its centroid; over a tangled hole they can cross each other, and a
    /// winding-number analysis needs those crossings, so senc-gia does not use groups).
    /// Grouped faces are still tested against every other face. A `groups` of the wrong
    /// length is ignored.
    pub fn with_groups(mut self, groups: Vec<u32>) -> Self {
        if groups.len() == self.tree.order.len() {
            self.slot_groups = self.tree.order.iter().map(|&f| groups[f as usize]).collect();
            self.leaf_verts = Arc::new(LeafVerts::of_slots(&self.tree.slot_faces, &self.slot_groups));
            self.node_groups = node_groups(&self.nodes, &self.slot_groups);
            self.grouped = self.node_groups.iter().any(|&g| g != 0);
        }
        self.groups = groups;
        self
    }

    /// Crossings of `mesh` with itself. If `mesh` has the faces this intersector was built
    /// for, the BVH is refit to the new positions; otherwise it is rebuilt.
    pub fn find(&mut self, mesh: &TriMesh) -> SelfIntersections {
        if !self.fits(mesh) {
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
    pub(super) fn traversal<'a>(&'a self, mesh: &'a TriMesh) -> Traversal<'a> {
        Traversal {
            mesh,
            nodes: &self.nodes,
            order: &self.tree.order,
            slot_faces: &self.tree.slot_faces,
            slot_groups: &self.slot_groups,
            node_groups: &self.node_groups,
            grouped: self.grouped,
            lanes: &self.lanes,
            leaf_verts: &self.leaf_verts,
            planes: &self.planes,
            rings: &self.rings,
            ring_kind: &self.tree.ring_kind,
            ring_start: &self.tree.ring_start,
            ring_links: &self.tree.ring_links,
            patch_ranges: &self.tree.patch_ranges,
            patch_edges: &self.tree.patch_edges,
            node_slots: &self.tree.node_slots,
            units: &self.units,
            normals: &self.node_normals,
            cones: &self.node_cones,
        }
    }

    /// Sizes the per-call buffers of [`Self::refit`] (a no-op once sized), in parallel
    /// chunks (the first writes to fresh memory).
    fn size_buffers(&mut self) {
        let n = self.tree.order.len();
        let n_groups = n.div_ceil(LEAF_SIZE);
        rayon::join(
            || grow_par(&mut self.planes, n, FacePlane::ZERO),
            || {
                grow_par(&mut self.units, n, Vec3::zeros());
                grow_par(&mut self.group_boxes, n_groups, Aabb3::EMPTY);
                grow_par(&mut self.lanes, n_groups, LeafBoxes::EMPTY);
                grow_par(&mut self.group_normals, n_groups, NormalBox::EMPTY);
                grow_par(&mut self.group_cones, n_groups, NormalCone::NONE);
                grow_par(&mut self.node_normals, self.nodes.len(), NormalBox::EMPTY);
                grow_par(&mut self.node_cones, self.nodes.len(), NormalCone::NONE);
            },
        );
    }

    /// Face boxes and planes (slot order), node boxes (bottom-up) and vertex rings for the
    /// current positions.
    pub(super) fn refit(&mut self, mesh: &TriMesh) {
        self.size_buffers();
        let pos = mesh.positions();
        let slot_faces = &self.tree.slot_faces;
        // One parallel pass over leaf groups: planes per slot, then the group's box, f32
        // lanes (unused lanes keep their empty boxes), normal box and cone.
        self.lanes
            .par_iter_mut()
            .zip(self.group_boxes.par_iter_mut())
            .zip(self.group_normals.par_iter_mut())
            .zip(self.group_cones.par_iter_mut())
            .zip(self.planes.par_chunks_mut(LEAF_SIZE))
            .zip(self.units.par_chunks_mut(LEAF_SIZE))
            .enumerate()
            .with_min_len(256)
            .for_each(|(group, (((((lanes, gbox), nbox), cone), planes), units))| {
                *nbox = NormalBox::EMPTY;
                *gbox = Aabb3::EMPTY;
                let mut trusted = true;
                for (k, pl) in planes.iter_mut().enumerate() {
                    let [a, b, c] = map3(slot_faces[group * LEAF_SIZE + k], |v| pos[v as usize]);
                    let bx = Aabb3::of_triangle(a, b, c);
                    *gbox = gbox.union(&bx);
                    *pl = FacePlane::of_triangle(a, b, c);
                    match nbox.add_face(pl.n, b - a, c - a) {
                        Some(u) => units[k] = u,
                        None => {
                            units[k] = Vec3::zeros();
                            trusted = false;
                        }
                    }
                    for ax in 0..3 {
                        lanes.lo[ax][k] = f32_down(bx.lo[ax]);
                        lanes.hi[ax][k] = f32_up(bx.hi[ax]);
                    }
                }
                *cone = NormalCone::of_units(units, trusted);
            });
        if !self.nodes.is_empty() {
            let leaves = LeafData { boxes: &self.group_boxes, normals: &self.group_normals, cones: &self.group_cones };
            refit_subtree(&mut self.nodes, &mut self.node_normals, &mut self.node_cones, 0, &leaves, PAR_BUILD_DEPTH);
        }
        self.rings.resize_with(mesh.n_vertices(), || AtomicU8::new(RING_UNKNOWN));
        for r in &mut self.rings {
            *r.get_mut() = RING_UNKNOWN;
        }
    }
}

/// `v` made `n` long: elements already there are kept, new ones are `fill`, written in
/// parallel chunks.
fn grow_par<T: Copy + Send + Sync>(v: &mut Vec<T>, n: usize, fill: T) {
    if v.len() > n {
        v.truncate(n);
    } else if v.len() < n {
        let extra = n - v.len();
        v.par_extend(rayon::iter::repeat_n(fill, extra).with_min_len(PAR_MIN_ITEMS));
    }
}

/// What the refit's bottom-up pass reads per leaf group.
struct LeafData<'a> {
    boxes: &'a [Aabb3],
    normals: &'a [NormalBox],
    cones: &'a [NormalCone],
}

/// Boxes, normal boxes and cones of one subtree, bottom-up from the leaf groups: the
/// subtree of node `base`, whose nodes are `nodes[0..]` (and the same indices of `normals`
/// and `cones`): parents come before children and a node's first subtree before its
/// second, so a subtree is one range of nodes, its root first. At the first `par` levels,
/// subtrees of at least [`PAR_BUILD_MIN`] faces (by node count) do their two children's
/// subtrees on two threads (rayon); every value is computed as in one pass from the last
/// node to the first.
fn refit_subtree(
    nodes: &mut [Node],
    normals: &mut [NormalBox],
    cones: &mut [NormalCone],
    base: usize,
    leaves: &LeafData,
    par: u32,
) {
    let nd = nodes[0];
    if par == 0 || nd.leaf || nodes.len() < 2 * PAR_BUILD_MIN / LEAF_SIZE {
        for i in (0..nodes.len()).rev() {
            let nd = nodes[i];
            if nd.leaf {
                // A leaf is exactly one group (leaf sizes are multiples of LEAF_SIZE but
                // the last, and never more than LEAF_SIZE).
                nodes[i].bbox = leaves.boxes[nd.a as usize / LEAF_SIZE];
                normals[i] = leaves.normals[nd.a as usize / LEAF_SIZE];
                cones[i] = leaves.cones[nd.a as usize / LEAF_SIZE];
            } else {
                let (ca, cb) = (nd.a as usize - base, nd.b as usize - base);
                nodes[i].bbox = nodes[ca].bbox.union(&nodes[cb].bbox);
                normals[i] = normals[ca].union(&normals[cb]);
                cones[i] = cones[ca].merge(&cones[cb]);
            }
        }
        return;
    }
    // The first child is node `base + 1`; the second's subtree starts at node `nd.b`.
    let split = nd.b as usize - base;
    let (nodes_a, nodes_b) = nodes[1..].split_at_mut(split - 1);
    let (normals_a, normals_b) = normals[1..].split_at_mut(split - 1);
    let (cones_a, cones_b) = cones[1..].split_at_mut(split - 1);
    rayon::join(
        || refit_subtree(nodes_a, normals_a, cones_a, base + 1, leaves, par - 1),
        || refit_subtree(nodes_b, normals_b, cones_b, base + split, leaves, par - 1),
    );
    nodes[0].bbox = nodes[1].bbox.union(&nodes[split].bbox);
    normals[0] = normals[1].union(&normals[split]);
    cones[0] = cones[1].merge(&cones[split]);
}

/// Tree construction state: edge neighbours (see [`face_neighbours`]), face centroids, each
/// face's rank along each axis (by centroid key, then index: a total order, so each node's
/// faces have one sorted order along each axis) and the faces by rank, and
/// scratch.
pub(super) struct Builder<'a> {
    pub(super) nbrs: &'a [[u32; 3]],
    /// Slot of `order[0]` of the slice this builder is given (nonzero for the builders of
    /// second halves built as separate tasks).
    pub(super) base: usize,
    /// Per axis and face: the key of its centroid coordinate ([`coordinate_key`]).
    pub(super) keys: [&'a [u64]; 3],
    /// Per face: its position in `by_rank[axis]`, per axis.
    pub(super) rank: &'a [[u32; 3]],
    /// Per axis: all faces sorted by centroid key along it, then by index.
    pub(super) by_rank: [&'a [u32]; 3],
    /// Per-face marks, shared with the builders of the other tasks.
    pub(super) marks: &'a FaceMarks,
    /// One bit per rank along the split axis: the faces of the node being split that are
    /// not (yet) in its first half (see [`Self::grow_split`]); all clear between splits.
    pub(super) rest: Vec<u64>,
    /// The words of `rest` over the node's ranks before the split (all its faces).
    pub(super) all: Vec<u64>,
    /// Ranks along the split axis of the faces queued by [`Self::grow_split`].
    pub(super) queue: RankQueue,
    pub(super) strays: [Vec<usize>; 2],
    pub(super) notches: [Vec<usize>; 2],
    pub(super) pairs: Vec<(usize, usize)>,
    /// The faces along the split being made and their neighbours (see
    /// [`Self::swap_strays`]).
    pub(super) cut: Vec<u32>,
    /// Scratch of [`Self::small_subtree`].
    pub(super) small: Box<SmallSubtree>,
}

/// Per-face marks of the tree build, one set shared by the builders of all tasks. Each
/// entry holds a stamp made from a node id, which is unique in the tree; a task writes only
/// the entries of its own faces and reads other faces' entries only to compare them with
/// stamps of its own nodes, so relaxed atomic loads and stores (plain moves) suffice, and
/// an entry left by an earlier node never matches.
pub(super) struct FaceMarks {
    /// Per face: `2 node + side` of the split being made.
    mark: Vec<AtomicU32>,
    /// Per face: the node whose growing split has queued it.
    queued: Vec<AtomicU32>,
    /// Per face: the node whose split has listed it in [`Builder::cut`].
    cut_stamp: Vec<AtomicU32>,
    /// Per face listed in [`Builder::cut`]: its slot (in the slice its builder is given).
    slot_of: Vec<AtomicU32>,
    /// Per face: `SMALL_MAX × (root node) + index` within the small subtree being built
    /// (see [`Builder::small_subtree`]).
    small_index: Vec<AtomicU64>,
}

impl FaceMarks {
    fn new(n: usize) -> Self {
        let none = || (0..n).map(|_| AtomicU32::new(u32::MAX)).collect();
        FaceMarks {
            mark: none(),
            queued: none(),
            cut_stamp: none(),
            slot_of: none(),
            small_index: (0..n).map(|_| AtomicU64::new(u64::MAX)).collect(),
        }
    }
}

/// Entry `f` of a per-face mark.
#[inline(always)]
fn get(v: &[AtomicU32], f: u32) -> u32 {
    v[f as usize].load(AtomicOrdering::Relaxed)
}

/// Sets entry `f` of a per-face mark.
#[inline(always)]
fn set(v: &[AtomicU32], f: u32, x: u32) {
    v[f as usize].store(x, AtomicOrdering::Relaxed);
}

/// Largest subtree (in faces) that [`Builder::small_subtree`] builds on bit masks.
pub(super) const SMALL_MAX: usize = 64;

/// A set of at most [`SMALL_MAX`] faces of a small subtree, one bit each.
type SmallSet = u64;

/// The faces of a small subtree (at most [`SMALL_MAX`]) indexed `0..m`, and per axis their
/// order along it: sets of faces along an axis are bit masks over positions in that order,
/// so the smallest face of a set is its lowest bit.
pub(super) struct SmallSubtree {
    /// Index → face.
    faces: [u32; SMALL_MAX],
    /// Per axis: position → index, and index → position (in the order of the ranks).
    at: [[u8; SMALL_MAX]; 3],
    pos: [[u8; SMALL_MAX]; 3],
    /// Per axis and position: the positions of the face's edge neighbours in the subtree.
    nbrs: [[SmallSet; SMALL_MAX]; 3],
}

impl SmallSubtree {
    fn new() -> Box<Self> {
        Box::new(SmallSubtree {
            faces: [0; SMALL_MAX],
            at: [[0; SMALL_MAX]; 3],
            pos: [[0; SMALL_MAX]; 3],
            nbrs: [[0; SMALL_MAX]; 3],
        })
    }

    /// `set` (indices) as positions along `axis`.
    #[inline]
    fn along(&self, axis: usize, set: SmallSet) -> SmallSet {
        bits(set).fold(0, |acc, i| acc | 1 << self.pos[axis][i])
    }
}

/// The number of bits set in `set`, or 3 when there are more (a face has at most three
/// neighbours; without a population count instruction on the baseline x86-64 target).
#[inline]
fn few(set: SmallSet) -> u32 {
    let rest = set & set.wrapping_sub(1);
    let rest2 = rest & rest.wrapping_sub(1);
    (set != 0) as u32 + (rest != 0) as u32 + (rest2 != 0) as u32
}

/// The set bits of `set`, lowest first.
#[inline]
fn bits(mut set: SmallSet) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (set != 0).then(|| {
            let i = set.trailing_zeros() as usize;
            set &= set - 1;
            i
        })
    })
}

impl<'a> Builder<'a> {
    pub(super) fn new(
        nbrs: &'a [[u32; 3]],
        keys: [&'a [u64]; 3],
        rank: &'a [[u32; 3]],
        by_rank: [&'a [u32]; 3],
        marks: &'a FaceMarks,
        base: usize,
    ) -> Self {
        let n = nbrs.len();
        Builder {
            nbrs,
            keys,
            rank,
            by_rank,
            marks,
            base,
            rest: vec![0; n.div_ceil(64)],
            all: Vec::new(),
            queue: RankQueue::new(n),
            strays: [Vec::new(), Vec::new()],
            notches: [Vec::new(), Vec::new()],
            pairs: Vec::new(),
            cut: Vec::new(),
            small: SmallSubtree::new(),
        }
    }

    /// Builds the subtree over `order[lo..hi]` (split in two halves along the longest axis of
    /// the centroids, the first half grown across edges from the smallest centroid so that
    /// it stays connected, see [`Self::grow_split`]; leaf sizes a multiple of [`LEAF_SIZE`]
    /// except the last) into `nodes`, the subtree's [`subtree_nodes`] nodes, whose first is
    /// node `id` of the tree: each node is followed by its first half's subtree, then its
    /// second's, so node ids are known before the halves are built. Connected halves make more nodes topological disks that the traversal can
    /// skip whole (on the garment benchmark, 87% of the nodes of 17 to 1024 faces instead
    /// of 70% with a plain median split).
    ///
    /// After the split, faces with no edge neighbour on their own side ("strays", typical
    /// where the split line zigzags through a triangulated grid) are swapped pairwise with
    /// strays of the other side that have an edge neighbour there, so that more nodes are
    /// topological disks (see [`disk_patches`]); the sizes of both sides are unchanged.
    ///
    /// Subtrees of at most [`SMALL_MAX`] faces are built by [`Self::small_subtree`] (the
    /// same splits, on bit masks). At the first `par` levels, nodes of at least
    /// [`PAR_BUILD_MIN`] faces build their second half as a separate rayon task, with its
    /// own builder (scratch of a few words per 64 faces; the per-face marks are shared, see
    /// [`FaceMarks`]); the tree is the same as without.
    pub(super) fn node(
        &mut self,
        nodes: &mut [TreeNode],
        id: usize,
        order: &mut [u32],
        lo: usize,
        hi: usize,
        par: u32,
    ) {
        if hi - lo <= LEAF_SIZE {
            nodes[0] = TreeNode { a: (self.base + lo) as u32, b: (self.base + hi) as u32, leaf: true };
            return;
        }
        if hi - lo <= SMALL_MAX {
            return self.small_subtree(nodes, id, order, lo, hi);
        }
        let (axis, ranks) = self.split_axis(&order[lo..hi]);
        let n_leaves = (hi - lo).div_ceil(LEAF_SIZE);
        let mid = lo + (n_leaves / 2) * LEAF_SIZE;
        self.grow_split(order, [lo, mid, hi], axis, ranks, id as u32);
        self.swap_strays(order, lo, mid, hi, id as u32);
        // The node, then its first half's subtree, then its second's (see `subtree_nodes`).
        let (first_nodes, second_nodes) = nodes[1..].split_at_mut(subtree_nodes(mid - lo));
        let (l, r) = (id + 1, id + 1 + first_nodes.len());
        if par > 0 && hi - lo >= PAR_BUILD_MIN {
            // The second half as its own task (the halves share no face).
            let (first, second) = order[..hi].split_at_mut(mid);
            let (nbrs, keys, rank, by_rank, marks) = (self.nbrs, self.keys, self.rank, self.by_rank, self.marks);
            let base = self.base + mid;
            rayon::join(
                || self.node(first_nodes, l, first, lo, mid, par - 1),
                || {
                    let mut other = Builder::new(nbrs, keys, rank, by_rank, marks, base);
                    other.node(second_nodes, r, second, 0, hi - mid, par - 1);
                },
            );
        } else {
            self.node(first_nodes, l, order, lo, mid, 0);
            self.node(second_nodes, r, order, mid, hi, 0);
        }
        nodes[0] = TreeNode { a: l as u32, b: r as u32, leaf: false };
    }

    /// Builds the subtree over `order[lo..hi]` (at most [`SMALL_MAX`] faces) as
    /// [`Self::node`] does, on bit masks over its faces ([`SmallSubtree`]): the growing
    /// split pops the lowest bit of the queue, and the stray swaps count neighbours on each
    /// side by population counts.
    pub(super) fn small_subtree(&mut self, nodes: &mut [TreeNode], id: usize, order: &mut [u32], lo: usize, hi: usize) {
        let m = hi - lo;
        let root = id as u64;
        let sm = &mut *self.small;
        sm.faces[..m].copy_from_slice(&order[lo..hi]);
        let small_index = &self.marks.small_index;
        for (i, &f) in order[lo..hi].iter().enumerate() {
            small_index[f as usize].store(root * SMALL_MAX as u64 + i as u64, AtomicOrdering::Relaxed);
        }
        let mut keys = [0u64; SMALL_MAX];
        for axis in 0..3 {
            for (k, &f) in keys.iter_mut().zip(&sm.faces[..m]) {
                *k = u64::from(self.rank[f as usize][axis]) * SMALL_MAX as u64;
            }
            for (i, k) in keys[..m].iter_mut().enumerate() {
                *k += i as u64;
            }
            keys[..m].sort_unstable();
            for (p, k) in keys[..m].iter().enumerate() {
                let i = (k % SMALL_MAX as u64) as usize;
                sm.at[axis][p] = i as u8;
                sm.pos[axis][i] = p as u8;
            }
        }
        for i in 0..m {
            let mut local = [SmallSet::default(); 3];
            for g in self.nbrs[sm.faces[i] as usize] {
                if g == NO_FACE {
                    continue;
                }
                let key = small_index[g as usize].load(AtomicOrdering::Relaxed);
                if key / SMALL_MAX as u64 == root {
                    let j = (key % SMALL_MAX as u64) as usize;
                    for (axis, l) in local.iter_mut().enumerate() {
                        *l |= 1 << sm.pos[axis][j];
                    }
                }
            }
            for (axis, l) in local.into_iter().enumerate() {
                sm.nbrs[axis][sm.pos[axis][i] as usize] = l;
            }
        }
        let all = if m == SMALL_MAX { SmallSet::MAX } else { (1 << m) - 1 };
        self.small_node(nodes, id, order, lo, hi, all)
    }

    /// The node over `order[lo..hi]`, whose faces are the indices in `set` (see
    /// [`Self::small_subtree`]).
    fn small_node(
        &mut self,
        nodes: &mut [TreeNode],
        id: usize,
        order: &mut [u32],
        lo: usize,
        hi: usize,
        set: SmallSet,
    ) {
        if hi - lo <= LEAF_SIZE {
            nodes[0] = TreeNode { a: (self.base + lo) as u32, b: (self.base + hi) as u32, leaf: true };
            return;
        }
        let sm = &*self.small;
        let along = [sm.along(0, set), sm.along(1, set), sm.along(2, set)];
        // The extreme positions along each axis hold the extreme coordinates.
        let coord =
            |ax: usize, p: u32| key_coordinate(self.keys[ax][sm.faces[sm.at[ax][p as usize] as usize] as usize]);
        let ext = Vec3::from_fn(|ax, _| {
            coord(ax, SmallSet::BITS - 1 - along[ax].leading_zeros()) - coord(ax, along[ax].trailing_zeros())
        });
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let n_leaves = (hi - lo).div_ceil(LEAF_SIZE);
        let mid = lo + (n_leaves / 2) * LEAF_SIZE;
        // The growing split (as in `grow_split`), in positions along `axis`.
        let nbrs = &sm.nbrs[axis];
        let (mut rest, mut first, mut queue) = (along[axis], 0 as SmallSet, 0 as SmallSet);
        for _ in lo..mid {
            let p = if queue != 0 { queue.trailing_zeros() } else { rest.trailing_zeros() };
            first |= 1 << p;
            rest &= !(1 << p);
            queue = (queue | nbrs[p as usize]) & rest;
        }
        // Each part's positions in slot order, and the stray swaps (as in `swap_strays`).
        let mut slots = [[0u8; SMALL_MAX]; 2];
        for (side, part) in [first, rest].into_iter().enumerate() {
            for (k, p) in bits(part).enumerate() {
                slots[side][k] = p as u8;
            }
        }
        let mut sides = [first, rest];
        let lens = [mid - lo, hi - mid];
        let (mut strays, mut notches) = ([[0u8; SMALL_MAX]; 2], [[0u8; SMALL_MAX]; 2]);
        for _ in 0..2 {
            let mut counts = [[0usize; 2]; 2];
            for side in 0..2 {
                let (own, other) = (sides[side], sides[1 - side]);
                for (k, &p) in slots[side][..lens[side]].iter().enumerate() {
                    let n = nbrs[p as usize];
                    match (few(n & own), few(n & other)) {
                        (0, o) if o > 0 => {
                            strays[side][counts[side][0]] = k as u8;
                            counts[side][0] += 1;
                        }
                        (1, 2) => {
                            notches[side][counts[side][1]] = k as u8;
                            counts[side][1] += 1;
                        }
                        _ => {}
                    }
                }
            }
            let [sl, sr] = [counts[0][0], counts[1][0]];
            if sl + sr == 0 {
                break;
            }
            let m = sl.min(sr);
            let pairs = strays[0][..m]
                .iter()
                .zip(&strays[1][..m])
                .chain(strays[0][m..sl].iter().zip(&notches[1][..counts[1][1]]))
                .chain(notches[0][..counts[0][1]].iter().zip(&strays[1][m..sr]));
            for (&a, &b) in pairs {
                let (a, b) = (a as usize, b as usize);
                let (pa, pb) = (slots[0][a], slots[1][b]);
                (slots[0][a], slots[1][b]) = (pb, pa);
                sides[0] = sides[0] & !(1 << pa) | 1 << pb;
                sides[1] = sides[1] & !(1 << pb) | 1 << pa;
            }
        }
        let at = &sm.at[axis];
        let mut children = [0 as SmallSet; 2];
        for (side, start) in [lo, mid].into_iter().enumerate() {
            for (k, &p) in slots[side][..lens[side]].iter().enumerate() {
                let i = at[p as usize];
                order[start + k] = sm.faces[i as usize];
                children[side] |= 1 << i;
            }
        }
        let (first_nodes, second_nodes) = nodes[1..].split_at_mut(subtree_nodes(mid - lo));
        let (l, r) = (id + 1, id + 1 + first_nodes.len());
        self.small_node(first_nodes, l, order, lo, mid, children[0]);
        self.small_node(second_nodes, r, order, mid, hi, children[1]);
        nodes[0] = TreeNode { a: l as u32, b: r as u32, leaf: false };
    }

    /// The axis along which the centroids of `faces` extend furthest (the first of equal
    /// extents), and the smallest and largest rank of the faces along it.
    pub(super) fn split_axis(&self, faces: &[u32]) -> (usize, [u32; 2]) {
        let (mut first, mut last) = ([u32::MAX; 3], [0u32; 3]);
        for &f in faces {
            let r = self.rank[f as usize];
            for ax in 0..3 {
                first[ax] = first[ax].min(r[ax]);
                last[ax] = last[ax].max(r[ax]);
            }
        }
        // The faces of the extreme ranks have the extreme coordinates.
        let (keys, by_rank) = (self.keys, self.by_rank);
        let coord = |ax: usize, r: u32| key_coordinate(keys[ax][by_rank[ax][r as usize] as usize]);
        let ext = Vec3::from_fn(|ax, _| coord(ax, last[ax]) - coord(ax, first[ax]));
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        (axis, [first[axis], last[axis]])
    }

    /// Splits `order[lo..hi]` (`[lo, mid, hi]`; `ranks`: the smallest and largest rank of
    /// its faces along `axis`) into a first part of `mid − lo` faces grown face by face
    /// across edges from the face with the smallest centroid coordinate along `axis`,
    /// always taking the queued face that is smallest along `axis` (so the cut follows the
    /// median plane, as in a median split, while the first part stays edge-connected where
    /// the faces allow); when the queue runs dry (another component), growth restarts from
    /// the smallest face not taken. Both parts are written in rank order
    /// along `axis`, read from the rank bits of [`Self::rest`].
    pub(super) fn grow_split(
        &mut self,
        order: &mut [u32],
        [lo, mid, hi]: [usize; 3],
        axis: usize,
        [first, last]: [u32; 2],
        id: u32,
    ) {
        let nbrs = self.nbrs;
        let (rank, by_rank) = (self.rank, self.by_rank[axis]);
        let (unassigned, left) = (2 * id + 1, 2 * id);
        let words = first as usize / 64..last as usize / 64 + 1;
        let FaceMarks { mark, queued, cut_stamp, slot_of, .. } = self.marks;
        for &f in &order[lo..hi] {
            set(mark, f, unassigned);
            let r = rank[f as usize][axis] as usize;
            self.rest[r / 64] |= 1 << (r % 64);
        }
        self.all.clear();
        self.all.extend_from_slice(&self.rest[words.clone()]);
        self.queue.clear();
        let (mut taken, mut seed_word) = (0, words.start);
        while taken < mid - lo {
            let r = match self.queue.pop() {
                Some(r) => r as usize,
                None => {
                    while self.rest[seed_word] == 0 {
                        seed_word += 1;
                    }
                    seed_word * 64 + self.rest[seed_word].trailing_zeros() as usize
                }
            };
            let f = by_rank[r];
            debug_assert_eq!(get(mark, f), unassigned);
            set(mark, f, left);
            self.rest[r / 64] &= !(1 << (r % 64));
            taken += 1;
            for g in nbrs[f as usize] {
                if g != NO_FACE && get(mark, g) == unassigned && get(queued, g) != id {
                    set(queued, g, id);
                    self.queue.push(rank[g as usize][axis]);
                }
            }
        }
        // The faces along the cut and their neighbours in the node, for `swap_strays`:
        // the second part's faces left in the queue (every one with a neighbour in the
        // first part was queued), their neighbours in the first part, and the neighbours
        // of those.
        self.cut.clear();
        for r in self.queue.iter() {
            let g = by_rank[r as usize];
            for h in std::iter::once(g).chain(nbrs[g as usize]) {
                if h != NO_FACE && (h == g || get(mark, h) == left) && get(cut_stamp, h) != id {
                    set(cut_stamp, h, id);
                    self.cut.push(h);
                }
            }
        }
        for i in 0..self.cut.len() {
            for h in nbrs[self.cut[i] as usize] {
                if h != NO_FACE && get(mark, h) >> 1 == id && get(cut_stamp, h) != id {
                    set(cut_stamp, h, id);
                    self.cut.push(h);
                }
            }
        }
        // Each part in rank order: the first part's ranks are the node's less `rest`.
        let (mut a, mut b) = (lo, mid);
        for (k, w) in words.enumerate() {
            let second = std::mem::take(&mut self.rest[w]);
            for (mut bits, at) in [(self.all[k] & !second, &mut a), (second, &mut b)] {
                while bits != 0 {
                    let f = by_rank[w * 64 + bits.trailing_zeros() as usize];
                    bits &= bits - 1;
                    order[*at] = f;
                    if get(cut_stamp, f) == id {
                        set(slot_of, f, *at as u32);
                    }
                    *at += 1;
                }
            }
        }
        debug_assert_eq!((a, b), (mid, hi));
    }

    /// Expects the marks [`Self::grow_split`] leaves: `2 id` on `order[lo..mid]`,
    /// `2 id + 1` on `order[mid..hi]`.
    pub(super) fn swap_strays(&mut self, order: &mut [u32], lo: usize, mid: usize, hi: usize, id: u32) {
        let nbrs = self.nbrs;
        debug_assert!(order[lo..hi]
            .iter()
            .enumerate()
            .all(|(k, &f)| get(&self.marks.mark, f) == 2 * id + (lo + k >= mid) as u32
                && (get(&self.marks.cut_stamp, f) != id || get(&self.marks.slot_of, f) as usize == lo + k)));
        // Strays first, then notches (one neighbour on their side, two on the other),
        // per side; a stray is swapped with a stray of the other side, else with a notch.
        // Both have a neighbour on the other side, so only the faces along the cut and
        // their neighbours (`self.cut`, from `grow_split`; a swap moves faces of the cut,
        // so the second pass's strays and notches are among them too) are counted; each
        // list is then put in slot order.
        for _ in 0..2 {
            let FaceMarks { mark, slot_of, .. } = self.marks;
            let count = |f: u32| {
                let own = get(mark, f);
                let (mut same, mut other) = (0, 0);
                for g in nbrs[f as usize] {
                    if g != NO_FACE {
                        let m = get(mark, g);
                        same += (m == own) as u32;
                        other += (m == own ^ 1) as u32;
                    }
                }
                (same, other)
            };
            for side in 0..2 {
                self.strays[side].clear();
                self.notches[side].clear();
            }
            for &f in &self.cut {
                let slot = get(slot_of, f) as usize;
                let side = (slot >= mid) as usize;
                match count(f) {
                    (0, o) if o > 0 => self.strays[side].push(slot),
                    (1, 2) => self.notches[side].push(slot),
                    _ => {}
                }
            }
            for list in self.strays.iter_mut().chain(self.notches.iter_mut()) {
                list.sort_unstable();
            }
            let [sl, sr] = [self.strays[0].len(), self.strays[1].len()];
            if sl + sr == 0 {
                break;
            }
            let m = sl.min(sr);
            let mut pairs = std::mem::take(&mut self.pairs);
            pairs.clear();
            pairs.extend(self.strays[0].iter().copied().zip(self.strays[1].iter().copied()));
            pairs.extend(self.strays[0][m..].iter().copied().zip(self.notches[1].iter().copied()));
            pairs.extend(self.notches[0].iter().copied().zip(self.strays[1][m..].iter().copied()));
            for &(a, b) in &pairs {
                order.swap(a, b);
                let (fa, fb) = (order[a], order[b]);
                set(mark, fa, 2 * id);
                set(mark, fb, 2 * id + 1);
                set(slot_of, fa, a as u32);
                set(slot_of, fb, b as u32);
            }
            self.pairs = pairs;
        }
    }
}

/// A set of face ranks (below the number of faces), smallest first: one bit per rank, and
/// the first word that may hold one. The split's queue grows along the split axis, so the
/// ranks it pops mostly increase and each pop scans few words.
pub(super) struct RankQueue {
    words: Vec<u64>,
    len: usize,
    /// No rank lies in the words before it.
    first: usize,
    /// No rank lies in the words from it on.
    end: usize,
}

impl RankQueue {
    pub(super) fn new(n: usize) -> Self {
        let words = vec![0; n.div_ceil(64)];
        RankQueue { first: words.len(), words, len: 0, end: 0 }
    }

    /// Adds `r` (not in the set).
    #[inline]
    pub(super) fn push(&mut self, r: u32) {
        let w = r as usize / 64;
        self.words[w] |= 1 << (r % 64);
        self.len += 1;
        self.first = self.first.min(w);
        self.end = self.end.max(w + 1);
    }

    /// Removes and returns the smallest rank.
    #[inline]
    pub(super) fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        while self.words[self.first] == 0 {
            self.first += 1;
        }
        let w = self.words[self.first];
        self.words[self.first] = w & (w - 1);
        self.len -= 1;
        Some((self.first * 64) as u32 + w.trailing_zeros())
    }

    /// The ranks in the set, smallest first.
    pub(super) fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        let words = if self.len > 0 { &self.words[self.first..self.end] } else { &[] };
        words.iter().enumerate().flat_map(move |(i, &w)| {
            let base = ((self.first + i) * 64) as u32;
            std::iter::successors((w != 0).then_some(w), |&x| (x & (x - 1) != 0).then_some(x & (x - 1)))
                .map(move |x| base + x.trailing_zeros())
        })
    }

    pub(super) fn clear(&mut self) {
        if self.len > 0 {
            self.words[self.first..self.end].fill(0);
        }
        self.len = 0;
        self.first = self.words.len();
        self.end = 0;
    }
}

/// Per node, the nonzero group shared by all its faces, or 0 (see
/// [`SelfIntersector::with_groups`]). Parents come before children in `nodes`.
pub(super) fn node_groups(nodes: &[Node], slot_groups: &[u32]) -> Vec<u32> {
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
