//! Intersection paths: linking the two surface preimages of every intersection segment
//! into contours on the surface, and classifying them.
//!
//! Every segment of a face pair `(g, f)` has a preimage on `g` and one on `f`. An
//! intersection point `(e, h)` has a preimage on edge `e` (its edge node) and one inside `h`
//! (its face node). Each preimage node has exactly two incident preimage segments away from
//! open boundaries, so the preimages form closed contours: one per sheet when two sheets
//! cross, or one through two loop vertices when a surface is folded through itself.

use rustc_hash::FxHashMap;

use senc_geom::cut::{edge_node, face_node};
use senc_geom::intersect::{SegmentEnd, SelfIntersections};
use smallvec::SmallVec;

/// What kind of curve a contour is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PathKind {
    /// A closed curve on one sheet (two sheets crossing give two of these, twins).
    Closed,
    /// A closed curve through loop vertices: a surface folded through itself.
    ThroughLoopVertices,
    /// A curve that ends at an open boundary (a hole left open): nothing is filled.
    OpenBoundary,
}

/// One step of a contour: a segment's preimage on one face, walked from `from` to `to`
/// (geometric node ids as in `senc_geom::cut`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContourStep {
    /// The intersection segment.
    pub segment: u32,
    /// Which of the segment's two faces this preimage lies on (0 or 1).
    pub side: u8,
    /// Start node.
    pub from: u32,
    /// End node.
    pub to: u32,
}

/// A contour: an ordered walk of segment preimages.
#[derive(Debug, Clone, PartialEq)]
pub struct Contour {
    /// Its kind.
    pub kind: PathKind,
    /// Its steps, in walking order (for a closed contour `to` of the last is `from` of the
    /// first).
    pub steps: Vec<ContourStep>,
    /// Intersection points it passes through (sorted, deduplicated).
    pub points: Vec<u32>,
}

/// Builds the contours of an intersection set over a mesh of `n_vertices` vertices.
pub fn contours(n_vertices: usize, inter: &SelfIntersections) -> Vec<Contour> {
    let np = inter.points.len() as u32;
    let loop_base = n_vertices as u32 + 2 * np;
    // Walk keys: geometric nodes, except that each loop-vertex end gets its own key (one per
    // segment), so that every key has two incident preimages.
    let key_of = |end: SegmentEnd, face: u32, seg: u32| -> (u32, u32) {
        match end {
            SegmentEnd::LoopVertex(v) => (loop_base + seg, v),
            SegmentEnd::Point(i) => {
                let n = if inter.points[i as usize].face == face {
                    face_node(n_vertices, i)
                } else {
                    edge_node(n_vertices, i)
                };
                (n, n)
            }
        }
    };
    // Half segments: (key_a, key_b, node_a, node_b).
    let mut halves: Vec<[u32; 4]> = Vec::with_capacity(inter.segments.len() * 2);
    let mut adj: FxHashMap<u32, SmallVec<[u32; 2]>> =
        FxHashMap::with_capacity_and_hasher(inter.segments.len() * 4, Default::default());
    for (s, seg) in inter.segments.iter().enumerate() {
        for &face in &seg.faces {
            let (ka, na) = key_of(seg.ends[0], face, s as u32);
            let (kb, nb) = key_of(seg.ends[1], face, s as u32);
            let h = halves.len() as u32;
            halves.push([ka, kb, na, nb]);
            adj.entry(ka).or_default().push(h);
            adj.entry(kb).or_default().push(h);
        }
    }
    let step_of = |h: u32, forward: bool| -> ContourStep {
        let [_, _, na, nb] = halves[h as usize];
        let (from, to) = if forward { (na, nb) } else { (nb, na) };
        ContourStep { segment: h / 2, side: (h % 2) as u8, from, to }
    };
    let mut used = vec![false; halves.len()];
    let mut out = Vec::new();
    for h0 in 0..halves.len() as u32 {
        if used[h0 as usize] {
            continue;
        }
        used[h0 as usize] = true;
        let start_key = halves[h0 as usize][0];
        let mut steps = vec![step_of(h0, true)];
        let mut cur = halves[h0 as usize][1];
        let mut closed = false;
        // Forward from h0.
        loop {
            if cur == start_key {
                closed = true;
                break;
            }
            let Some(h) = adj[&cur].iter().copied().find(|&h| !used[h as usize]) else { break };
            used[h as usize] = true;
            let fwd = halves[h as usize][0] == cur;
            steps.push(step_of(h, fwd));
            cur = if fwd { halves[h as usize][1] } else { halves[h as usize][0] };
        }
        if !closed {
            // Backward from the start, prepending.
            let mut back = Vec::new();
            let mut cur = start_key;
            while let Some(h) = adj[&cur].iter().copied().find(|&h| !used[h as usize]) {
                used[h as usize] = true;
                let fwd = halves[h as usize][1] == cur;
                back.push(step_of(h, fwd));
                cur = if fwd { halves[h as usize][0] } else { halves[h as usize][1] };
            }
            back.reverse();
            back.extend(steps);
            steps = back;
        }
        let through_loop = steps.iter().any(|s| s.from < n_vertices as u32 || s.to < n_vertices as u32);
        let kind = if !closed {
            PathKind::OpenBoundary
        } else if through_loop {
            PathKind::ThroughLoopVertices
        } else {
            PathKind::Closed
        };
        let mut points: Vec<u32> = steps
            .iter()
            .flat_map(|s| [s.from, s.to])
            .filter(|&n| n >= n_vertices as u32)
            .map(|n| (n - n_vertices as u32) / 2)
            .collect();
        points.sort_unstable();
        points.dedup();
        out.push(Contour { kind, steps, points });
    }
    out
}
