//! Faces whose chords cross: triple points, where a third sheet passes through the
//! intersection curve of two others inside one face. Each crossing of two chord edges
//! becomes a *crossing node* of that face, the chord edges are split there, and the pieces
//! are the faces of the resulting planar graph, traced by turning as far left as possible at
//! every node.

use rustc_hash::FxHashMap;

use super::{point_in_polygon, EdgeTag, Split};
use super::{signed_area, Event, FaceFrame, Piece};

/// A crossing of two chord edges inside one face: a triple point of the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChordCrossing {
    /// The face it lies in.
    pub face: u32,
    /// The first chord edge (two nodes on one intersection segment).
    pub first: [u32; 2],
    /// The second chord edge.
    pub second: [u32; 2],
    /// The intersection segments the two chord edges lie on.
    pub segments: [u32; 2],
    /// Barycentric coordinates in the face when found (the fixed-weight position).
    pub bary: [f64; 3],
}

/// The chord edges of a face, `(from, to, segment, run)`, into `edges`.
pub(super) fn run_edges(
    chords: &[Vec<(u32, u32)>],
    loops: &[Vec<(u32, u32)>],
    edges: &mut Vec<(u32, u32, u32, usize)>,
) {
    edges.clear();
    for (r, c) in chords.iter().enumerate() {
        edges.extend(c.windows(2).map(|w| (w[0].0, w[1].0, w[0].1, r)));
    }
    for (r, l) in loops.iter().enumerate() {
        let r = chords.len() + r;
        edges.extend((0..l.len()).map(|i| (l[i].0, l[(i + 1) % l.len()].0, l[i].1, r)));
    }
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Proper crossings between edges of different runs, `(edge i, edge j, parameter on i,
/// parameter on j, local point)`, into `out` (`ends`: scratch).
pub(super) fn find_crossings(
    frame: &FaceFrame,
    edges: &[(u32, u32, u32, usize)],
    ends: &mut Vec<[[f64; 2]; 2]>,
    out: &mut Vec<(usize, usize, f64, f64, [f64; 2])>,
) {
    out.clear();
    // Each edge's ends in the face's local coordinates, computed once.
    ends.clear();
    ends.extend(edges.iter().map(|&(a, b, _, _)| [frame.local(a), frame.local(b)]));
    for i in 0..edges.len() {
        for j in i + 1..edges.len() {
            let ((a, b, _, _), (c, d, _, _)) = (edges[i], edges[j]);
            if a == c || a == d || b == c || b == d {
                continue;
            }
            let ([pa, pb], [pc, pd]) = (ends[i], ends[j]);
            let (o1, o2) = (orient(pa, pb, pc), orient(pa, pb, pd));
            let (o3, o4) = (orient(pc, pd, pa), orient(pc, pd, pb));
            if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
                let s = o3 / (o3 - o4);
                let t = o1 / (o1 - o2);
                let x = [pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1])];
                out.push((i, j, s, t, x));
            }
        }
    }
}

/// The connected part of the graph of half-edges `half` that each node belongs to (a
/// representative node per part).
fn connected_parts(half: &[(u32, u32, EdgeTag)]) -> FxHashMap<u32, u32> {
    let mut parent: FxHashMap<u32, u32> = FxHashMap::default();
    fn root(parent: &mut FxHashMap<u32, u32>, mut n: u32) -> u32 {
        while let Some(&p) = parent.get(&n) {
            if p == n {
                break;
            }
            let gp = parent[&p];
            parent.insert(n, gp);
            n = p;
        }
        n
    }
    for &(u, v, _) in half {
        parent.entry(u).or_insert(u);
        parent.entry(v).or_insert(v);
        let (ru, rv) = (root(&mut parent, u), root(&mut parent, v));
        if ru != rv {
            parent.insert(ru, rv);
        }
    }
    let nodes: Vec<u32> = parent.keys().copied().collect();
    nodes.into_iter().map(|n| (n, root(&mut parent, n))).collect()
}

impl Split {
    /// Splits a face whose chords cross (see the module docs). Returns false, adding
    /// nothing, when the planar graph cannot be traced (the caller keeps the face whole).
    pub(super) fn split_crossing_face(
        &mut self,
        frame: &FaceFrame,
        face: u32,
        events: &[Event],
        edges: &[(u32, u32, u32, usize)],
        crossings: &[(usize, usize, f64, f64, [f64; 2])],
    ) -> bool {
        let base = self.crossing_base;
        let first_crossing = self.crossings.len() as u32;
        let mut local: FxHashMap<u32, [f64; 2]> = FxHashMap::default();
        let mut splits: Vec<Vec<(f64, u32)>> = vec![Vec::new(); edges.len()];
        let mut new_crossings = Vec::with_capacity(crossings.len());
        for (k, &(i, j, s, t, x)) in crossings.iter().enumerate() {
            let node = base + first_crossing + k as u32;
            local.insert(node, x);
            splits[i].push((s, node));
            splits[j].push((t, node));
            let (ei, ej) = (edges[i], edges[j]);
            new_crossings.push(ChordCrossing {
                face,
                first: [ei.0, ei.1],
                second: [ej.0, ej.1],
                segments: [ei.2, ej.2],
                bary: [1.0 - x[0] - x[1], x[0], x[1]],
            });
        }
        let pos = |n: u32| -> [f64; 2] { local.get(&n).copied().unwrap_or_else(|| frame.local(n)) };
        // Half-edges: (from, to, tag); chord pieces both ways, the perimeter counterclockwise.
        let mut half: Vec<(u32, u32, EdgeTag)> = Vec::new();
        for (e, &(a, b, seg, _)) in edges.iter().enumerate() {
            let mut chain = std::mem::take(&mut splits[e]);
            chain.sort_by(|p, q| p.0.total_cmp(&q.0));
            let mut prev = a;
            for node in chain.into_iter().map(|c| c.1).chain(std::iter::once(b)) {
                half.push((prev, node, EdgeTag::Chord { segment: seg }));
                half.push((node, prev, EdgeTag::Chord { segment: seg }));
                prev = node;
            }
        }
        let m = events.len();
        let slot = |i: usize| -> u8 { (events[i].s.floor() as i64).rem_euclid(3) as u8 };
        for i in 0..m {
            let (u, v) = (events[i].node, events[(i + 1) % m].node);
            if u != v {
                half.push((u, v, EdgeTag::Perimeter { slot: slot(i) }));
            }
        }
        let mut out_of: FxHashMap<u32, Vec<usize>> = FxHashMap::default();
        for (h, &(u, _, _)) in half.iter().enumerate() {
            out_of.entry(u).or_default().push(h);
        }
        let angle = |from: u32, to: u32| {
            let (p, q) = (pos(from), pos(to));
            (q[1] - p[1]).atan2(q[0] - p[0])
        };
        // Each half-edge's direction, computed once.
        let direction: Vec<f64> = half.iter().map(|&(u, v, _)| angle(u, v)).collect();
        // Next half-edge: at the head, the first outgoing one clockwise from the way back.
        let next = |h: usize| -> Option<usize> {
            let (u, v, _) = half[h];
            let back = angle(v, u);
            let tau = std::f64::consts::TAU;
            out_of
                .get(&v)?
                .iter()
                .copied()
                .map(|g| {
                    let turn = (back - direction[g]).rem_euclid(tau);
                    (if half[g].1 == u || turn == 0.0 { tau } else { turn }, g)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, g)| g)
        };
        let mut used = vec![false; half.len()];
        let mut outer: Vec<Vec<(u32, EdgeTag)>> = Vec::new();
        let mut holes: Vec<Vec<(u32, EdgeTag)>> = Vec::new();
        for h0 in 0..half.len() {
            if used[h0] {
                continue;
            }
            let mut cycle = Vec::new();
            let mut h = h0;
            loop {
                if used[h] || cycle.len() > half.len() {
                    return false;
                }
                used[h] = true;
                cycle.push((half[h].0, half[h].2));
                let Some(g) = next(h) else { return false };
                h = g;
                if h == h0 {
                    break;
                }
            }
            let pts: Vec<[f64; 2]> = cycle.iter().map(|c| pos(c.0)).collect();
            if signed_area(&pts) > 0.0 {
                outer.push(cycle);
            } else {
                holes.push(cycle);
            }
        }
        if outer.is_empty() {
            return false;
        }
        let first_piece = self.pieces.len();
        for cycle in outer {
            self.pieces.push(Piece { face, cycles: vec![cycle] });
        }
        // A clockwise cycle is the outside of a part not joined to the perimeter (a loop and
        // whatever crosses it): a hole of the smallest piece around it. The pieces inside
        // that part are bounded by its own nodes, and a vertex of the hole, the point tested,
        // lies on their outlines, where a point-in-polygon test can say anything: so only
        // pieces whose outline shares no node with the hole's part are hosts. The host's outer
        // cycle never does (a part joined to it would be traced into that cycle).
        let part = connected_parts(&half);
        for hole in holes {
            let ring: Vec<[f64; 2]> = hole.iter().map(|c| pos(c.0)).collect();
            if ring.len() < 3 {
                continue;
            }
            let probe = ring[0];
            let hole_part = part[&hole[0].0];
            let outline = |p: usize| -> Vec<[f64; 2]> { self.pieces[p].cycles[0].iter().map(|c| pos(c.0)).collect() };
            let apart = |p: usize| self.pieces[p].cycles[0].iter().all(|c| part[&c.0] != hole_part);
            let host = (first_piece..self.pieces.len())
                .filter(|&p| apart(p) && point_in_polygon(probe, &outline(p)))
                .min_by(|&a, &b| signed_area(&outline(a)).total_cmp(&signed_area(&outline(b))));
            if let Some(p) = host {
                self.pieces[p].cycles.push(hole);
            }
        }
        self.crossings.extend(new_crossings);
        true
    }
}
