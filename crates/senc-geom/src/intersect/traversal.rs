//! The BVH self-traversal: subtree and subtree-pair tasks, disk-patch and ring skips, and
//! the per-pair filters before the exact test.

use super::*;

/// A unit of traversal work: the face pairs within one subtree, or between two subtrees
/// whose boxes overlap.
#[derive(Debug, Clone, Copy)]
pub(super) enum Task {
    Within(u32),
    Between(u32, u32),
}

#[derive(Default)]
pub(super) struct Acc {
    pub(super) results: Vec<PairResult>,
    pub(super) candidates: usize,
    /// Scratch for [`Traversal::patch_is_embedded`].
    pub(super) segs: Vec<Seg2>,
}

pub(super) struct Traversal<'a> {
    pub(super) mesh: &'a TriMesh,
    pub(super) nodes: &'a [Node],
    pub(super) order: &'a [u32],
    pub(super) slot_faces: &'a [[u32; 3]],
    pub(super) slot_groups: &'a [u32],
    pub(super) node_groups: &'a [u32],
    /// Whether any entry of `node_groups` is nonzero.
    pub(super) grouped: bool,
    pub(super) lanes: &'a [LeafBoxes],
    pub(super) leaf_verts: &'a [LeafVerts],
    pub(super) planes: &'a [FacePlane],
    pub(super) rings: &'a [AtomicU8],
    pub(super) ring_kind: &'a [u8],
    pub(super) ring_start: &'a [u32],
    pub(super) ring_links: &'a [[u32; 2]],
    pub(super) patch_ranges: &'a [[u32; 2]],
    pub(super) patch_edges: &'a [[u32; 2]],
    pub(super) node_slots: &'a [[u32; 2]],
    pub(super) units: &'a [Vec3],
    pub(super) normals: &'a [NormalBox],
    pub(super) cones: &'a [NormalCone],
}

impl Traversal<'_> {
    /// Whether vertex `s`'s ring is embedded ([`ring_is_embedded`] for the current
    /// positions), computed on first use and cached for this call. Threads racing on one
    /// vertex compute the same value.
    #[inline]
    pub(super) fn ring_embedded(&self, s: u32) -> bool {
        let cell = &self.rings[s as usize];
        match cell.load(AtomicOrdering::Relaxed) {
            RING_YES => true,
            RING_NO => false,
            _ => {
                let links =
                    &self.ring_links[self.ring_start[s as usize] as usize..self.ring_start[s as usize + 1] as usize];
                let r = ring_is_embedded(self.mesh.positions(), s, self.ring_kind[s as usize], links);
                cell.store(if r { RING_YES } else { RING_NO }, AtomicOrdering::Relaxed);
                r
            }
        }
    }

    /// Whether all faces of nodes `x` and `y` have one nonzero group.
    #[inline]
    pub(super) fn same_group(&self, x: u32, y: u32) -> bool {
        if !self.grouped {
            return false;
        }
        let g = self.node_groups[x as usize];
        g != 0 && g == self.node_groups[y as usize]
    }

    /// Whether node `n`'s faces certainly cannot cross or touch each other (beyond the edges
    /// and vertices they share), so the node's whole self-traversal can be skipped.
    ///
    /// The faces must form a topological disk `S` (see [`disk_patches`]) and there must be
    /// a direction `d` with `n_f · d > 0` for every face normal (from the node's
    /// [`NormalCone`], else its [`NormalBox`]). Then the projection `π` along `d` keeps every face's orientation, and
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
    pub(super) fn patch_is_embedded(&self, n: u32, segs: &mut Vec<Seg2>) -> bool {
        let [start, end] = self.patch_ranges[n as usize];
        if start == end {
            return false;
        }
        let Some(d) = self.normal_direction(n) else {
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

    /// A unit direction `d` with `n · d > 1e-6` for the computed unit normal `n` of every
    /// face of node `n` (so `n · d > 0` for its true normal, whose direction differs by at
    /// most about `1e-9`, see [`NormalBox::add_face`]), or `None`. Tried in order of cost:
    /// the node's [`NormalCone`] (a bound carried up the tree), its [`NormalBox`], and
    /// last every face's unit normal against the cone's axis (the normalised sum of the
    /// unit normals; a face whose direction cannot be trusted has a zero normal and fails).
    pub(super) fn normal_direction(&self, n: u32) -> Option<Vec3> {
        let cone = &self.cones[n as usize];
        if let Some(d) = cone.direction().or_else(|| self.normals[n as usize].direction()) {
            return Some(d);
        }
        let len = cone.sum.norm();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        let d = cone.sum / len;
        let [lo, hi] = self.node_slots[n as usize];
        self.units[lo as usize..hi as usize].iter().all(|u| u.dot(&d) > 1e-6).then_some(d)
    }

    /// Splits the root's work into at least `min_tasks` tasks where the tree allows, for
    /// rayon to spread over the threads.
    pub(super) fn tasks(&self, min_tasks: usize) -> Vec<Task> {
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
    pub(super) fn expand(&self, t: Task, out: &mut Vec<Task>, segs: &mut Vec<Seg2>) -> bool {
        let nodes = self.nodes;
        match t {
            Task::Within(n) => {
                let nd = nodes[n as usize];
                if self.grouped && self.node_groups[n as usize] != 0 {
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
    pub(super) fn run(&self, t: Task, acc: &mut Acc) {
        let nodes = self.nodes;
        let mut stack = Vec::with_capacity(64);
        stack.push(t);
        while let Some(t) = stack.pop() {
            match t {
                Task::Within(n) => {
                    let nd = &nodes[n as usize];
                    if self.grouped && self.node_groups[n as usize] != 0 {
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
                    let (nx, ny) = (&nodes[x as usize], &nodes[y as usize]);
                    if self.same_group(x, y) {
                        continue;
                    }
                    if nx.leaf && ny.leaf {
                        self.leaf_between(nx.a, nx.b, ny.a, acc);
                        continue;
                    }
                    if !nx.leaf && !ny.leaf {
                        // Both inner: the pairs of their children whose boxes overlap (a child
                        // of `x` clear of `y` is dropped before its two pairs).
                        for cx in [nx.a, nx.b] {
                            let bx = &nodes[cx as usize].bbox;
                            if !bx.overlaps(&ny.bbox) {
                                continue;
                            }
                            for cy in [ny.a, ny.b] {
                                if nodes[cy as usize].bbox.overlaps(bx) {
                                    stack.push(Task::Between(cx, cy));
                                }
                            }
                        }
                        continue;
                    }
                    // One leaf: descend the other node.
                    let (keep, split) = if nx.leaf { (x, ny) } else { (y, nx) };
                    let kb = &nodes[keep as usize].bbox;
                    for c in [split.a, split.b] {
                        if nodes[c as usize].bbox.overlaps(kb) {
                            stack.push(Task::Between(keep, c));
                        }
                    }
                }
            }
        }
    }

    /// Face pairs inside the leaf over slots `a..b`.
    #[inline]
    pub(super) fn leaf_within(&self, a: u32, b: u32, acc: &mut Acc) {
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
    pub(super) fn leaf_between(&self, a: u32, b: u32, c: u32, acc: &mut Acc) {
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
    pub(super) fn pairs(&self, i: u32, c: u32, group: usize, mask: u32, acc: &mut Acc) {
        if mask == 0 {
            return;
        }
        let fa = self.slot_faces[i as usize];
        let (none, one, holds) = self.leaf_verts[group].classify(fa, self.slot_groups[i as usize]);
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
            let bit = 1 << k;
            let shared = if holds[0] & bit != 0 {
                fa[0]
            } else if holds[1] & bit != 0 {
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
    pub(super) fn test(&self, i: usize, j: usize, acc: &mut Acc) {
        let (f, g) = (self.order[i], self.order[j]);
        let (pf, pg) = (&self.planes[i], &self.planes[j]);
        let r =
            if f < g { test_pair_planes(self.mesh, f, g, pf, pg) } else { test_pair_planes(self.mesh, g, f, pg, pf) };
        if let Some(r) = r {
            acc.results.push(r);
        }
    }
}
