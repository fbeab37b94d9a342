//! Cutting a mesh along its self-intersection segments: every cut face is split into exact
//! polygonal pieces whose edges include every segment lying on that face, so that a flood
//! fill can walk the surface without crossing an intersection path.
//!
//! # Nodes
//! Piece corners are *nodes*: original vertices `0..n_vertices`, and for intersection point
//! `i` two distinct nodes, its **edge node** `n_vertices + 2i` (on the crossing edge, shared
//! by that edge's two faces) and its **face node** `n_vertices + 2i + 1` (inside the crossed
//! face). The two sheets stay apart at the cut: the same 3D point is two nodes, one per sheet.
//! Every node is a recorded combination of original vertices ([`node_weights`]).
//!
//! # Pieces
//! A cut face is split by its *chords* (runs of segments from perimeter to perimeter through
//! face nodes). Pieces are counterclockwise polygons, possibly with holes (a closed run of
//! face nodes inside one face). Each polygon edge is tagged as perimeter (shared with the
//! neighbouring face across an original edge) or chord (shared with the piece on the other
//! side of an intersection segment). Faces with no segment are not split and are not stored.
//! Chords that end inside a face (a path reaching an open boundary) do not split it; they are
//! counted in [`CutMesh::n_dangling_chords`].

use rayon::prelude::*;
use rustc_hash::FxHashMap;

mod crossing;

pub use crossing::ChordCrossing;

use crate::intersect::{SegmentEnd, SelfIntersections};
use crate::mesh::TriMesh;
use crate::topology::NO_FACE;

/// What lies across one polygon edge of a piece.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EdgeTag {
    /// Part of the face's perimeter, on the edge opposite corner `(slot + 2) % 3`, i.e.
    /// between corners `slot` and `slot + 1`.
    Perimeter {
        /// Perimeter side of the face (0, 1, 2).
        slot: u8,
    },
    /// An intersection segment (index into [`SelfIntersections::segments`]).
    Chord {
        /// The segment.
        segment: u32,
    },
}

/// A polygonal piece of a cut face.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    /// The original face it is part of.
    pub face: u32,
    /// Counterclockwise outer cycle first, then clockwise hole cycles; each entry is a node
    /// and the tag of the edge from it to the next node of its cycle.
    pub cycles: Vec<Vec<(u32, EdgeTag)>>,
}

/// The mesh cut along its intersection segments.
#[derive(Debug, Clone, Default)]
pub struct CutMesh {
    /// Number of original vertices (the first node ids).
    pub n_vertices: usize,
    /// Number of original faces. Fill ids `0..n_faces` are uncut faces, `n_faces + k` is
    /// piece `k`.
    pub n_faces: usize,
    /// All pieces, grouped by face in increasing face order.
    pub pieces: Vec<Piece>,
    /// For each face, the range of its pieces (empty for an uncut face).
    pub face_pieces: Vec<std::ops::Range<u32>>,
    /// Directed polygon edge `(from, to)` of a piece → fill id of that piece.
    directed: FxHashMap<(u32, u32), u32>,
    /// Chords that end inside a face (open paths); they do not split their face.
    pub n_dangling_chords: usize,
    /// Faces whose chords could not be ordered or traced; such a face is kept whole and its
    /// segments are not walls.
    pub n_complex_faces: usize,
    /// Number of intersection points (crossing nodes are numbered after their nodes).
    pub n_points: usize,
    /// Crossings of chords inside a face (triple points); crossing `k` is node
    /// [`CutMesh::crossing_node`]`(k)`.
    pub crossings: Vec<ChordCrossing>,
}

/// Edge node id of intersection point `i`.
pub fn edge_node(n_vertices: usize, i: u32) -> u32 {
    n_vertices as u32 + 2 * i
}

/// Face node id of intersection point `i`.
pub fn face_node(n_vertices: usize, i: u32) -> u32 {
    n_vertices as u32 + 2 * i + 1
}

/// The original vertices and weights a node is a combination of (with the intersection's
/// current edge parameter and barycentrics held fixed); empty for a crossing node, whose
/// fixed weights are [`ChordCrossing::bary`] in its face.
pub fn node_weights(mesh: &TriMesh, inter: &SelfIntersections, node: u32) -> Vec<(u32, f64)> {
    let nv = mesh.n_vertices() as u32;
    if node < nv {
        return vec![(node, 1.0)];
    }
    let i = ((node - nv) / 2) as usize;
    let Some(p) = inter.points.get(i) else {
        // A crossing node: see `CutMesh::crossings` for its weights.
        return Vec::new();
    };
    if (node - nv) % 2 == 0 {
        let [a, b] = mesh.topology().edges()[p.edge as usize];
        vec![(a, 1.0 - p.t), (b, p.t)]
    } else {
        let f = mesh.faces()[p.face as usize];
        (0..3).map(|k| (f[k], p.bary[k])).collect()
    }
}

/// One preimage of a segment on one face: two nodes.
#[derive(Clone, Copy)]
struct HalfSeg {
    a: u32,
    b: u32,
    segment: u32,
}

impl CutMesh {
    /// Cuts `mesh` along `inter`'s segments.
    pub fn new(mesh: &TriMesh, inter: &SelfIntersections) -> Self {
        let nv = mesh.n_vertices();
        let nf = mesh.n_faces();
        // Preimage of a segment end on face `face`.
        let node_on = |end: SegmentEnd, face: u32| -> u32 {
            match end {
                SegmentEnd::LoopVertex(v) => v,
                SegmentEnd::Point(i) => {
                    if inter.points[i as usize].face == face {
                        face_node(nv, i)
                    } else {
                        edge_node(nv, i)
                    }
                }
            }
        };
        let mut halves: Vec<(u32, HalfSeg)> = Vec::with_capacity(inter.segments.len() * 2);
        for (s, seg) in inter.segments.iter().enumerate() {
            for &face in &seg.faces {
                halves.push((
                    face,
                    HalfSeg { a: node_on(seg.ends[0], face), b: node_on(seg.ends[1], face), segment: s as u32 },
                ));
            }
        }
        halves.sort_by_key(|h| (h.0, h.1.segment));
        let mut cut = CutMesh {
            n_vertices: nv,
            n_faces: nf,
            n_points: inter.points.len(),
            face_pieces: vec![0..0; nf],
            ..Default::default()
        };
        // Faces are split independently: in chunks on rayon's threads, each numbering its
        // crossing nodes from the chunk's own start, then joined in face order with those
        // numbers shifted, so the result is the sequential one.
        let mut groups: Vec<(u32, usize, usize)> = Vec::new();
        let mut i = 0;
        while i < halves.len() {
            let face = halves[i].0;
            let mut j = i;
            while j < halves.len() && halves[j].0 == face {
                j += 1;
            }
            groups.push((face, i, j));
            i = j;
        }
        let base = cut.crossing_base();
        let chunk = groups.len().div_ceil(4 * rayon::current_num_threads()).max(16);
        let parts: Vec<Split> = groups
            .par_chunks(chunk)
            .map(|faces| {
                let mut part = Split { n_vertices: nv as u32, crossing_base: base, ..Default::default() };
                let mut segs: Vec<HalfSeg> = Vec::new();
                for &(face, i, j) in faces {
                    segs.clear();
                    segs.extend(halves[i..j].iter().map(|h| h.1));
                    let start = part.pieces.len() as u32;
                    part.split_face(mesh, inter, face, &segs);
                    part.ranges.push((face, start..part.pieces.len() as u32));
                }
                part
            })
            .collect();
        let n_pieces = parts.iter().map(|p| p.pieces.len()).sum();
        cut.pieces.reserve(n_pieces);
        for part in parts {
            let (piece_shift, node_shift) = (cut.pieces.len() as u32, cut.crossings.len() as u32);
            for (face, r) in part.ranges {
                cut.face_pieces[face as usize] = r.start + piece_shift..r.end + piece_shift;
            }
            for mut piece in part.pieces {
                if node_shift > 0 {
                    for node in piece.cycles.iter_mut().flatten().map(|c| &mut c.0) {
                        if *node >= base {
                            *node += node_shift;
                        }
                    }
                }
                cut.pieces.push(piece);
            }
            cut.crossings.extend(part.crossings);
            cut.n_dangling_chords += part.n_dangling_chords;
            cut.n_complex_faces += part.n_complex_faces;
        }
        cut.directed.reserve(cut.pieces.iter().flat_map(|p| &p.cycles).map(Vec::len).sum());
        for (k, piece) in cut.pieces.iter().enumerate() {
            for cycle in &piece.cycles {
                for w in 0..cycle.len() {
                    let from = cycle[w].0;
                    let to = cycle[(w + 1) % cycle.len()].0;
                    cut.directed.insert((from, to), (nf + k) as u32);
                }
            }
        }
        cut
    }

    /// First crossing node id: `n_vertices + 2 n_points`.
    pub fn crossing_base(&self) -> u32 {
        (self.n_vertices + 2 * self.n_points) as u32
    }

    /// Node id of crossing `k`.
    pub fn crossing_node(&self, k: usize) -> u32 {
        self.crossing_base() + k as u32
    }

    /// Total number of nodes: vertices, two per intersection point, one per crossing.
    pub fn n_nodes(&self) -> usize {
        self.n_vertices + 2 * self.n_points + self.crossings.len()
    }

    /// Whether face `f` was split.
    pub fn is_cut(&self, f: u32) -> bool {
        !self.face_pieces[f as usize].is_empty()
    }

    /// The fill id of the piece whose boundary runs `from → to` (the piece on the left of
    /// that directed edge).
    pub fn piece_with_directed_edge(&self, from: u32, to: u32) -> Option<u32> {
        self.directed.get(&(from, to)).copied()
    }

    /// The original face of fill id `id` (an uncut face is its own).
    pub fn face_of(&self, id: u32) -> u32 {
        if (id as usize) < self.n_faces {
            id
        } else {
            self.pieces[id as usize - self.n_faces].face
        }
    }

    /// Total number of fill ids (`n_faces + pieces`).
    pub fn n_fill_ids(&self) -> usize {
        self.n_faces + self.pieces.len()
    }

    /// Calls `visit(neighbour, wall)` for each neighbour of fill id `id`; `wall` is the
    /// intersection segment between them, if any.
    pub fn for_each_neighbour(&self, mesh: &TriMesh, id: u32, mut visit: impl FnMut(u32, Option<u32>)) {
        let topo = mesh.topology();
        let faces = mesh.faces();
        if (id as usize) < self.n_faces {
            let f = faces[id as usize];
            for k in 0..3 {
                let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                let e = topo.face_edges()[id as usize][k];
                let ef = topo.edge_faces()[e as usize];
                let g = if ef[0] == id { ef[1] } else { ef[0] };
                if g == NO_FACE {
                    continue;
                }
                if self.is_cut(g) {
                    if let Some(&p) = self.directed.get(&(b, a)) {
                        visit(p, None);
                    }
                } else {
                    visit(g, None);
                }
            }
            return;
        }
        let piece = &self.pieces[id as usize - self.n_faces];
        let face = piece.face as usize;
        for cycle in &piece.cycles {
            for w in 0..cycle.len() {
                let (from, tag) = cycle[w];
                let to = cycle[(w + 1) % cycle.len()].0;
                match tag {
                    EdgeTag::Chord { segment } => {
                        if let Some(&p) = self.directed.get(&(to, from)) {
                            visit(p, Some(segment));
                        }
                    }
                    EdgeTag::Perimeter { slot } => {
                        // Original edge between corners slot and slot+1: opposite corner slot+2.
                        let e = topo.face_edges()[face][(slot as usize + 2) % 3];
                        let ef = topo.edge_faces()[e as usize];
                        let g = if ef[0] == piece.face { ef[1] } else { ef[0] };
                        if g == NO_FACE || from == to {
                            continue;
                        }
                        if self.is_cut(g) {
                            if let Some(&p) = self.directed.get(&(to, from)) {
                                visit(p, None);
                            }
                        } else {
                            visit(g, None);
                        }
                    }
                }
            }
        }
    }
}

/// The pieces of some cut faces, split apart from the rest (see [`CutMesh::new`]): their
/// crossing nodes are numbered from `crossing_base` as if they were the first.
#[derive(Default)]
struct Split {
    n_vertices: u32,
    crossing_base: u32,
    pieces: Vec<Piece>,
    /// Each split face and the range of its pieces in `pieces`.
    ranges: Vec<(u32, std::ops::Range<u32>)>,
    crossings: Vec<ChordCrossing>,
    n_dangling_chords: usize,
    n_complex_faces: usize,
    /// Buffers reused from face to face.
    buf: FaceBuffers,
}

/// Per-face working lists of [`Split::split_face`], kept between faces so that each face
/// does not allocate them again (each use clears them first).
#[derive(Default)]
struct FaceBuffers {
    /// [`walk_segments`]: node adjacency, used half segments, chord starts.
    adj: FxHashMap<u32, smallvec::SmallVec<[(u32, u32); 2]>>,
    used: Vec<bool>,
    starts: Vec<u32>,
    /// [`perimeter_events`].
    events: Vec<Event>,
    /// [`crossing::run_edges`], [`crossing::find_crossings`] (and its edge ends).
    edges: Vec<(u32, u32, u32, usize)>,
    ends: Vec<[[f64; 2]; 2]>,
    crossings: Vec<(usize, usize, f64, f64, [f64; 2])>,
    /// [`trace_cycles`]: each chord's events, visited events.
    chord_event: Vec<[usize; 2]>,
    visited: Vec<bool>,
}

impl Split {
    /// Splits face `face` along its half segments `segs`: walks them into chords and closed
    /// loops, orders the chord ends around the perimeter, traces the pieces between chords,
    /// then places each closed loop as a disk piece and a hole of the piece around it. A
    /// face whose segments cannot be ordered is kept whole and counted as complex.
    fn split_face(&mut self, mesh: &TriMesh, inter: &SelfIntersections, face: u32, segs: &[HalfSeg]) {
        let frame = FaceFrame { mesh, inter, nv: self.n_vertices, fv: mesh.faces()[face as usize] };
        let mut buf = std::mem::take(&mut self.buf);
        self.split_face_with(&frame, face, segs, &mut buf);
        self.buf = buf;
    }

    fn split_face_with(&mut self, frame: &FaceFrame, face: u32, segs: &[HalfSeg], buf: &mut FaceBuffers) {
        let walk = walk_segments(frame, segs, buf);
        let mut proper: Vec<Vec<(u32, u32)>> = Vec::new();
        for c in walk.chords {
            let end = c.last().map(|x| x.0).unwrap_or(0);
            if frame.is_perimeter(end) && c.len() >= 2 && !(c.len() == 2 && c[0].0 == end) {
                proper.push(c);
            } else {
                self.n_dangling_chords += 1;
            }
        }
        if walk.complex {
            self.n_complex_faces += 1;
            return self.push_whole(face, frame.fv);
        }
        perimeter_events(frame, &proper, &mut buf.events);
        crossing::run_edges(&proper, &walk.loops, &mut buf.edges);
        crossing::find_crossings(frame, &buf.edges, &mut buf.ends, &mut buf.crossings);
        let (events, edges, crossings) = (&buf.events, &buf.edges, &buf.crossings);
        if !crossings.is_empty() {
            if !self.split_crossing_face(frame, face, events, edges, crossings) {
                self.n_complex_faces += 1;
                self.push_whole(face, frame.fv);
            }
            return;
        }
        let first_piece = self.pieces.len();
        for cycle in trace_cycles(events, &proper, &mut buf.chord_event, &mut buf.visited) {
            self.pieces.push(Piece { face, cycles: vec![cycle] });
        }
        self.place_loops(frame, face, first_piece, walk.loops);
        if self.pieces.len() == first_piece {
            self.n_complex_faces += 1;
            self.push_whole(face, frame.fv);
        }
    }

    /// Closed loops inside the face: each becomes a disk piece (counterclockwise) and a
    /// clockwise hole of the smallest piece around it.
    fn place_loops(&mut self, frame: &FaceFrame, face: u32, first_piece: usize, loops: Vec<Vec<(u32, u32)>>) {
        for lp in loops {
            let mut ring: Vec<(u32, EdgeTag)> = lp.iter().map(|&(n, s)| (n, EdgeTag::Chord { segment: s })).collect();
            let pts: Vec<[f64; 2]> = ring.iter().map(|r| frame.local(r.0)).collect();
            if signed_area(&pts) < 0.0 {
                ring = reverse_cycle(&ring);
            }
            let probe = frame.local(ring[0].0);
            let outer =
                |p: usize| -> Vec<[f64; 2]> { self.pieces[p].cycles[0].iter().map(|r| frame.local(r.0)).collect() };
            let host = (first_piece..self.pieces.len())
                .filter(|&p| point_in_polygon(probe, &outer(p)))
                .min_by(|&a, &b| signed_area(&outer(a)).total_cmp(&signed_area(&outer(b))));
            if let Some(h) = host {
                self.pieces[h].cycles.push(reverse_cycle(&ring));
            }
            self.pieces.push(Piece { face, cycles: vec![ring] });
        }
    }

    fn push_whole(&mut self, face: u32, fv: [u32; 3]) {
        let cycle = (0..3).map(|k| (fv[k], EdgeTag::Perimeter { slot: k as u8 })).collect();
        self.pieces.push(Piece { face, cycles: vec![cycle] });
    }
}

/// One face being split: its corners and the local coordinates of its nodes.
pub(crate) struct FaceFrame<'a> {
    mesh: &'a TriMesh,
    inter: &'a SelfIntersections,
    nv: u32,
    fv: [u32; 3],
}

impl FaceFrame<'_> {
    /// Local 2D coordinates of a node of this face: corner 0 = (0,0), corner 1 = (1,0),
    /// corner 2 = (0,1).
    pub(crate) fn local(&self, node: u32) -> [f64; 2] {
        let (nv, fv) = (self.nv, self.fv);
        let bary: [f64; 3] = if node < nv {
            let k = fv.iter().position(|&v| v == node).unwrap_or(0);
            let mut b = [0.0; 3];
            b[k] = 1.0;
            b
        } else {
            let i = ((node - nv) / 2) as usize;
            let p = &self.inter.points[i];
            if (node - nv) % 2 == 1 {
                p.bary
            } else {
                let [a, b] = self.mesh.topology().edges()[p.edge as usize];
                let mut w = [0.0; 3];
                for (k, &v) in fv.iter().enumerate() {
                    if v == a {
                        w[k] = 1.0 - p.t;
                    } else if v == b {
                        w[k] = p.t;
                    }
                }
                w
            }
        };
        [bary[1], bary[2]]
    }

    /// Whether a node lies on the face's perimeter (a corner or an edge node).
    fn is_perimeter(&self, node: u32) -> bool {
        node < self.nv || (node - self.nv) % 2 == 0
    }

    /// The edge (global vertex pair) of an edge node.
    fn edge_of(&self, node: u32) -> [u32; 2] {
        let i = ((node - self.nv) / 2) as usize;
        self.mesh.topology().edges()[self.inter.points[i].edge as usize]
    }

    /// Position along the perimeter (`k + fraction` on the side from corner k to k+1) and
    /// the side k.
    fn perimeter_position(&self, node: u32) -> (f64, usize) {
        let fv = self.fv;
        let [u, v] = self.local(node);
        let b = [1.0 - u - v, u, v];
        if node < self.nv {
            let k = fv.iter().position(|&x| x == node).unwrap_or(0);
            return (k as f64, k);
        }
        // On the side between corners k and k+1, decided by the edge's identity (the
        // weights alone are ambiguous when the crossing sits exactly at a corner).
        let [ea, eb] = self.edge_of(node);
        let k = (0..3)
            .find(|&k| {
                let (p, q) = (fv[k], fv[(k + 1) % 3]);
                (p == ea && q == eb) || (p == eb && q == ea)
            })
            .unwrap_or(0);
        // Strictly inside the side, so that corners order before and after it.
        let frac = b[(k + 1) % 3].clamp(1e-12, 1.0 - 1e-12);
        (k as f64 + frac, k)
    }
}

/// The segments of one face walked into runs: chords (from a perimeter node, through face
/// nodes, to a perimeter node or a dangling end) and closed loops of face nodes. Each run
/// is a list of `(node, segment to the next node)`; a chord's last entry has `u32::MAX`.
struct Walk {
    chords: Vec<Vec<(u32, u32)>>,
    loops: Vec<Vec<(u32, u32)>>,
    /// A face node of degree above two, or a loop that does not close (triple points).
    complex: bool,
}

fn walk_segments(frame: &FaceFrame, segs: &[HalfSeg], buf: &mut FaceBuffers) -> Walk {
    // Adjacency of this face's nodes through its half segments.
    let adj = &mut buf.adj;
    adj.clear();
    for (k, s) in segs.iter().enumerate() {
        adj.entry(s.a).or_default().push((s.b, k as u32));
        adj.entry(s.b).or_default().push((s.a, k as u32));
    }
    // Interior (face) nodes must have degree 2; a degree-1 face node is a dangling end.
    let mut complex = adj.iter().any(|(&n, list)| !frame.is_perimeter(n) && list.len() > 2);
    // Walk chords from perimeter nodes.
    let used = &mut buf.used;
    used.clear();
    used.resize(segs.len(), false);
    let mut chords: Vec<Vec<(u32, u32)>> = Vec::new();
    let starts = &mut buf.starts;
    starts.clear();
    starts.extend(adj.keys().copied().filter(|&n| frame.is_perimeter(n)));
    starts.sort_unstable();
    for &s in starts.iter() {
        for &(next0, k0) in adj[&s].clone().iter() {
            if used[k0 as usize] {
                continue;
            }
            let mut chord = vec![(s, segs[k0 as usize].segment)];
            used[k0 as usize] = true;
            let mut cur = next0;
            loop {
                if frame.is_perimeter(cur) {
                    chord.push((cur, u32::MAX));
                    break;
                }
                let nxt = adj[&cur].iter().find(|(_, k)| !used[*k as usize]).copied();
                match nxt {
                    Some((n, k)) => {
                        used[k as usize] = true;
                        chord.push((cur, segs[k as usize].segment));
                        cur = n;
                    }
                    None => {
                        chord.push((cur, u32::MAX));
                        break;
                    }
                }
            }
            chords.push(chord);
        }
    }
    // Closed loops of face nodes.
    let mut loops: Vec<Vec<(u32, u32)>> = Vec::new();
    for k in 0..segs.len() {
        if used[k] {
            continue;
        }
        let start = segs[k].a;
        let mut lp = vec![(start, segs[k].segment)];
        used[k] = true;
        let mut cur = segs[k].b;
        while cur != start {
            match adj[&cur].iter().find(|(_, j)| !used[*j as usize]).copied() {
                Some((n, j)) => {
                    used[j as usize] = true;
                    lp.push((cur, segs[j as usize].segment));
                    cur = n;
                }
                None => {
                    complex = true;
                    break;
                }
            }
        }
        loops.push(lp);
    }
    Walk { chords, loops, complex }
}

/// A corner or chord end on the perimeter, at position `s` (see
/// [`FaceFrame::perimeter_position`]), ordered by `(s, tie, node)`.
pub(crate) struct Event {
    pub(crate) s: f64,
    tie: f64,
    pub(crate) node: u32,
    /// Chord index, and whether this is its start.
    chord: Option<(usize, bool)>,
}

/// The three corners and both ends of every chord, sorted counterclockwise along the
/// perimeter.
fn perimeter_events(frame: &FaceFrame, proper: &[Vec<(u32, u32)>], events: &mut Vec<Event>) {
    let (nv, fv) = (frame.nv, frame.fv);
    events.clear();
    for k in 0..3u32 {
        events.push(Event { s: k as f64, tie: f64::INFINITY, node: fv[k as usize], chord: None });
    }
    for (ci, c) in proper.iter().enumerate() {
        for (at_start, (node, other)) in [(true, (c[0].0, c[1].0)), (false, (c[c.len() - 1].0, c[c.len() - 2].0))] {
            let (s, k) = frame.perimeter_position(node);
            let tie = if node < nv {
                // Chords at a corner: ordered by decreasing angle from the outgoing side.
                let o = frame.local(node);
                let nx = frame.local(fv[(k + 1) % 3]);
                let d = frame.local(other);
                let out = [nx[0] - o[0], nx[1] - o[1]];
                let dir = [d[0] - o[0], d[1] - o[1]];
                -(out[0] * dir[1] - out[1] * dir[0]).atan2(out[0] * dir[0] + out[1] * dir[1])
            } else {
                // Edge nodes at the same position (exactly coincident crossings): chords
                // of a planar cut nest, so the node whose chord ends farther along the
                // perimeter (counterclockwise) comes first. Exact ties in that too are
                // ordered along the global edge direction, so both faces agree.
                let far = c_other_end(c, at_start);
                let d =
                    if frame.is_perimeter(far) { (frame.perimeter_position(far).0 - s).rem_euclid(3.0) } else { 0.0 };
                let [a, _] = frame.edge_of(node);
                let along = if fv[k] == a { node as f64 } else { -(node as f64) };
                -d * 1e12 + along * 1e-3
            };
            events.push(Event { s, tie, node, chord: Some((ci, at_start)) });
        }
    }
    events.sort_by(|a, b| a.s.total_cmp(&b.s).then(a.tie.total_cmp(&b.tie)).then(a.node.cmp(&b.node)));
}

/// The outer cycles of the pieces: walk the perimeter counterclockwise and, at each chord
/// end, follow the chord to its other end.
fn trace_cycles(
    events: &[Event],
    proper: &[Vec<(u32, u32)>],
    chord_event: &mut Vec<[usize; 2]>,
    visited: &mut Vec<bool>,
) -> Vec<Vec<(u32, EdgeTag)>> {
    let m = events.len();
    // Where each chord end sits among the events.
    chord_event.clear();
    chord_event.resize(proper.len(), [usize::MAX; 2]);
    for (i, ev) in events.iter().enumerate() {
        if let Some((ci, at_start)) = ev.chord {
            chord_event[ci][if at_start { 0 } else { 1 }] = i;
        }
    }
    let slot_of = |i: usize| -> u8 { (events[i].s.floor() as i64).rem_euclid(3) as u8 };
    let push = |cycle: &mut Vec<(u32, EdgeTag)>, node: u32, tag: EdgeTag| {
        if let Some(last) = cycle.last_mut() {
            if last.0 == node {
                last.1 = tag;
                return;
            }
        }
        cycle.push((node, tag));
    };
    visited.clear();
    visited.resize(m, false);
    let mut out = Vec::new();
    for j0 in 0..m {
        if visited[j0] {
            continue;
        }
        let mut cycle: Vec<(u32, EdgeTag)> = Vec::new();
        let mut j = j0;
        let mut guard = 0;
        loop {
            guard += 1;
            if guard > 4 * m + 8 {
                break;
            }
            visited[j] = true;
            push(&mut cycle, events[j].node, EdgeTag::Perimeter { slot: slot_of(j) });
            let k = (j + 1) % m;
            if k == j0 {
                break;
            }
            if let Some((ci, at_start)) = events[k].chord {
                // Follow the chord to its other end, all but its last node; backwards, the
                // segment to the next node is the one stored one step back.
                let c = &proper[ci];
                if at_start {
                    for &(node, seg) in &c[..c.len() - 1] {
                        push(&mut cycle, node, EdgeTag::Chord { segment: seg });
                    }
                } else {
                    for w in (1..c.len()).rev() {
                        push(&mut cycle, c[w].0, EdgeTag::Chord { segment: c[w - 1].1 });
                    }
                }
                let other = chord_event[ci][if at_start { 1 } else { 0 }];
                if other == j0 || visited[other] {
                    break;
                }
                j = other;
            } else {
                j = k;
            }
        }
        if let (Some(f), Some(l)) = (cycle.first(), cycle.last()) {
            if cycle.len() > 1 && f.0 == l.0 {
                cycle.pop();
            }
        }
        if cycle.len() >= 3 {
            out.push(cycle);
        }
    }
    out
}

/// The node at the other end of a chord.
fn c_other_end(c: &[(u32, u32)], at_start: bool) -> u32 {
    if at_start {
        c[c.len() - 1].0
    } else {
        c[0].0
    }
}

/// Reverses a tagged cycle: the tag of edge (a → b) moves to the reversed edge (b → a).
fn reverse_cycle(c: &[(u32, EdgeTag)]) -> Vec<(u32, EdgeTag)> {
    let n = c.len();
    (0..n)
        .map(|i| {
            let node = c[n - 1 - i].0;
            // Edge from node to the previous one in the original order.
            let tag = c[(2 * n - 2 - i) % n].1;
            (node, tag)
        })
        .collect()
}

fn signed_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let a = p[i];
            let b = p[(i + 1) % n];
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        / 2.0
}

fn point_in_polygon(q: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a[1] > q[1]) != (b[1] > q[1]) {
            let x = a[0] + (q[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if q[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}
