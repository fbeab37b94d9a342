//! The penetration volume by winding numbers: the default rule.
//!
//! # Patches
//! Cutting the closed surface along every intersection segment at once splits it into
//! *patches*: connected sets of uncut faces and cut pieces that meet across original edges,
//! never across an intersection segment. No other part of the surface passes through the
//! inside of a patch, so the winding number `w(x)` of the surface around a point `x` is
//! constant on each side of it: `w_out` on the side its normals point to and `w_in` on the
//! other. Crossing the surface against its normal enters it once more, so `w_in = w_out + 1`.
//! An exact ray query ([`senc_geom::intersect::AxisRay`], from a point inside one of a
//! patch's faces, leaving on the outward side) gives its `w_out`; the differences across
//! intersection segments give the rest of its group, and a second probe must agree.
//!
//! # Weights
//! The penetration volume is `V = ∫ f(w(x)) dx` with `f(w) = 1` where `w ≥ 2` or `w ≤ −1`
//! (space that the surface covers twice or more, or inside out) and `0` elsewhere. The cells
//! of constant `w` are bounded by patches, and by the divergence theorem the volume of a
//! cell `C` is `⅓ ∮_{∂C} x · n_C dA`, the signed volume of the tetrahedra its boundary spans
//! with the origin. A patch `P` with outward normal `n_P` bounds two cells: the one on its
//! inward side (winding `w_in`), for which `n_P` points out of the cell, and the one on its
//! outward side (`w_out`), for which `−n_P` does. With `T_P = Σ (p0 · (p1 × p2)) / 6` over
//! its triangles, oriented as the surface,
//!
//! `V = Σ_cells f(w_C) vol(C) = Σ_P [f(w_in) − f(w_out)] T_P = Σ_P [f(w_out + 1) − f(w_out)] T_P`.
//!
//! The weight `f(w_out + 1) − f(w_out)` is `+1` for `w_out = 1` (the patch bounds a doubly
//! covered region from outside it), `−1` for `w_out = −1` (it bounds an inverted region from
//! inside it) and `0` for every other `w_out`: most of a garment (`w_out = 0`) costs nothing
//! beyond its patch label. The sum is exact, independent of the origin on a closed surface,
//! and needs no flood fill and no tie rule. Its gradient is `Σ_P weight_P ∂T_P/∂x`, through
//! the cut nodes as in the flood-fill rule (winding numbers are locally constant).
//!
//! # Checks
//! A wall (one side of an intersection segment) is *inconsistent* when it has the same
//! patch on both sides (a face whose chords could not be ordered, or a chord ending inside a
//! face, left the surface uncut there), when no piece lies across it, or when the winding numbers across it do not differ
//! as its exact side test says. Every patch of a tangle (patches linked through walls and
//! shared segments) that holds an inconsistent wall gets weight 0 and is counted
//! ([`crate::Diagnostics::patches_skipped`]): no partial sum is reported, nothing guessed.
//!
//! Two probes per group must give the same winding numbers (a probe point is rounded onto
//! its face's plane, and a coplanar face can then be on the wrong side of it); a group whose
//! probes disagree is skipped. The weighted patches of each tangle must close up (their
//! weighted vector area vanishes: they bound the penetrated set), or the tangle is skipped; and a
//! negative total, which no volume can be, is dropped whole
//! ([`crate::Diagnostics::negative_sums`]).

use senc_geom::cut::{edge_node, face_node, CutMesh, EdgeTag};
use std::cmp::Ordering;

use senc_geom::intersect::{AxisRay, SegmentEnd, SelfIntersections};
use senc_geom::predicates::orient3d_sos;
use senc_geom::topology::NO_FACE;
use senc_geom::{TriMesh, Vec3};

use crate::volume;

/// One patch of the cut surface and its classification.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Patch {
    /// Winding number on the side its normals point to (`w_in = w_out + 1`).
    pub winding_outside: i64,
    /// `f(w_out + 1) − f(w_out)`: +1, −1 or 0 (also 0 when skipped).
    pub weight: i8,
    /// Whether it was skipped as inconsistent (see the module docs).
    pub skipped: bool,
    /// Uncut faces in it.
    pub n_faces: usize,
    /// Cut pieces in it.
    pub n_pieces: usize,
    /// Its contribution to the volume, `weight · T_P`, m³.
    pub volume: f64,
    /// Its area where its weight is nonzero (else 0), m².
    pub area: f64,
}

/// Reusable buffers of the patch labelling.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    /// Union-find over the components of uncut faces (`component`) and the pieces.
    parent: Vec<u32>,
    /// Per fill id: its patch, or `u32::MAX` for the ids of cut faces (replaced by pieces).
    pub(crate) patch_of: Vec<u32>,
    root_patch: Vec<u32>,
    /// Per face: whether an intersection segment lies on it (the faces the cut splits).
    crossed: Vec<bool>,
    /// Per face that is not `crossed`: its component among those faces, joined across
    /// their shared edges (numbered from 0 in the order of their smallest faces);
    /// `u32::MAX` for crossed faces.
    component: Vec<u32>,
    n_components: u32,
    /// Union-find over the faces for `component`.
    face_parent: Vec<u32>,
    /// Per face: its squared doubled area, `|(b − a) × (c − a)|²` (ranks the probes).
    area2: Vec<f64>,
    /// Whether `crossed`, `component` and `area2` are [`prelabel`]'s for the current call.
    prelabelled: bool,
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// The fill ids in use: uncut faces and pieces.
fn live_ids(cut: &CutMesh) -> impl Iterator<Item = u32> + '_ {
    (0..cut.n_fill_ids() as u32).filter(move |&id| id as usize >= cut.n_faces || !cut.is_cut(id))
}

/// The part of the patch labelling that needs no cut, so that it can run beside
/// [`CutMesh::new`]: the faces an intersection segment lies on (those the cut splits), the
/// unions of the other faces across their shared edges, and every face's squared doubled
/// area for the probes of [`classify`].
pub(crate) fn prelabel(mesh: &TriMesh, inter: &SelfIntersections, scratch: &mut Scratch) {
    let crossed = &mut scratch.crossed;
    crossed.clear();
    crossed.resize(mesh.n_faces(), false);
    for seg in &inter.segments {
        for &f in &seg.faces {
            if let Some(c) = crossed.get_mut(f as usize) {
                *c = true;
            }
        }
    }
    label_uncut(mesh, scratch);
    face_areas(mesh, &mut scratch.area2);
    scratch.prelabelled = true;
}

/// The components of the faces that are not `scratch.crossed`, joined across their shared
/// edges, into `scratch.component`: a union-find over the edges (independent steps, which
/// the processor overlaps, unlike the dependent loads of a search), each set's root its
/// smallest face, which numbers the components in face order.
fn label_uncut(mesh: &TriMesh, scratch: &mut Scratch) {
    let Scratch { crossed, component, n_components, face_parent, .. } = scratch;
    face_parent.clear();
    face_parent.extend(0..mesh.n_faces() as u32);
    for &[g, h] in mesh.topology().edge_faces() {
        if g != NO_FACE && h != NO_FACE && !crossed[g as usize] && !crossed[h as usize] {
            union(face_parent, g, h);
        }
    }
    component.clear();
    component.resize(mesh.n_faces(), u32::MAX);
    let mut n = 0u32;
    for f in 0..mesh.n_faces() {
        if crossed[f] {
            continue;
        }
        let r = find(face_parent, f as u32) as usize;
        component[f] = if r == f {
            n += 1;
            n - 1
        } else {
            component[r]
        };
    }
    *n_components = n;
}

/// Every face's squared doubled area into `area2` (in parallel chunks: each entry depends
/// on its face only).
fn face_areas(mesh: &TriMesh, area2: &mut Vec<f64>) {
    use rayon::prelude::*;
    area2.resize(mesh.n_faces(), 0.0);
    area2.par_iter_mut().enumerate().with_min_len(2048).for_each(|(f, a)| {
        *a = mesh.face_normal_scaled(f).norm_squared();
    });
}

/// Per chord edge of a piece, in piece, cycle and edge order: the piece's fill id, the
/// piece across the edge (`None` where the cut is not closed) and the winding step across
/// it (see [`chord_sign`]; 0 without a piece across).
fn chord_steps(
    mesh: &TriMesh,
    cut: &CutMesh,
    inter: &SelfIntersections,
    nodes: &[Vec3],
) -> Vec<(u32, Option<u32>, i64)> {
    let mut out = Vec::new();
    for (k, piece) in cut.pieces.iter().enumerate() {
        let id = (cut.n_faces + k) as u32;
        for cycle in &piece.cycles {
            for i in 0..cycle.len() {
                let (from, tag) = cycle[i];
                let EdgeTag::Chord { segment } = tag else { continue };
                let to = cycle[(i + 1) % cycle.len()].0;
                let across = cut.piece_with_directed_edge(to, from);
                let delta = across.map_or(0, |_| chord_sign(mesh, inter, nodes, piece.face, segment, from, to));
                out.push((id, across, delta));
            }
        }
    }
    out
}

/// Labels the patches of the cut surface; returns their number (`scratch.patch_of` holds
/// each fill id's patch). Uses what [`prelabel`] computed for this call, where its crossed
/// faces are the faces `cut` split; computes it here otherwise.
pub(crate) fn label_patches(mesh: &TriMesh, cut: &CutMesh, scratch: &mut Scratch) -> usize {
    let n_ids = cut.n_fill_ids();
    let prelabelled = std::mem::take(&mut scratch.prelabelled);
    if !(prelabelled && scratch.area2.len() == mesh.n_faces()) {
        face_areas(mesh, &mut scratch.area2);
    }
    let fresh = prelabelled
        && scratch.crossed.len() == cut.n_faces
        && scratch.component.len() == cut.n_faces
        && scratch.crossed.iter().enumerate().all(|(f, &c)| c == cut.is_cut(f as u32));
    if !fresh {
        scratch.crossed.clear();
        scratch.crossed.extend((0..cut.n_faces as u32).map(|f| cut.is_cut(f)));
        label_uncut(mesh, scratch);
    }
    // Union-find over the components (elements `0..n_components`) and the pieces (then
    // one element each): each piece joined with its neighbours across original edges.
    let n_components = scratch.n_components;
    let component = &scratch.component;
    let element = |id: u32| {
        if (id as usize) < cut.n_faces {
            component[id as usize]
        } else {
            n_components + (id - cut.n_faces as u32)
        }
    };
    let n_elements = n_components as usize + cut.pieces.len();
    let parent = &mut scratch.parent;
    parent.clear();
    parent.extend(0..n_elements as u32);
    for k in 0..cut.pieces.len() {
        let id = (cut.n_faces + k) as u32;
        cut.for_each_neighbour(mesh, id, |nb, wall| {
            if wall.is_none() {
                union(parent, element(id), element(nb));
            }
        });
    }
    let patch_of = &mut scratch.patch_of;
    patch_of.clear();
    patch_of.resize(n_ids, u32::MAX);
    let mut n = 0u32;
    let root_patch = &mut scratch.root_patch;
    root_patch.clear();
    root_patch.resize(n_elements, u32::MAX);
    for id in live_ids(cut) {
        let r = find(parent, element(id)) as usize;
        if root_patch[r] == u32::MAX {
            root_patch[r] = n;
            n += 1;
        }
        patch_of[id as usize] = root_patch[r];
    }
    n as usize
}

/// A ray from a point inside fill id `id`, leaving its face on the outward side, and the face
/// to leave out of the count.
pub(crate) fn probe_ray(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32) -> (AxisRay, u32) {
    let face = if (id as usize) < cut.n_faces { id } else { cut.pieces[id as usize - cut.n_faces].face };
    let [a, b, c] = mesh.triangle(face as usize);
    let n = (b - a).cross(&(c - a));
    let axis = (0..3).max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs())).unwrap_or(0);
    let centroid = (a + b + c) / 3.0;
    let origin = if (id as usize) < cut.n_faces {
        centroid
    } else {
        piece_interior_point(cut, nodes, id as usize - cut.n_faces, a, n, axis).unwrap_or(centroid)
    };
    (AxisRay { origin, axis, positive: n[axis] > 0.0 }, face)
}

/// A point strictly inside piece `k` (holes included), on its face's plane: in the
/// projection along `axis`, the middle of the widest interior interval of the horizontal
/// line through the middle of the widest gap between vertex heights.
fn piece_interior_point(cut: &CutMesh, nodes: &[Vec3], k: usize, a: Vec3, n: Vec3, axis: usize) -> Option<Vec3> {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let piece = &cut.pieces[k];
    let mut ys: Vec<f64> = piece.cycles.iter().flatten().map(|&(node, _)| nodes[node as usize][v]).collect();
    ys.sort_by(f64::total_cmp);
    let (gap, y0) = ys.windows(2).map(|w| (w[1] - w[0], 0.5 * (w[0] + w[1]))).max_by(|p, q| p.0.total_cmp(&q.0))?;
    if gap <= 0.0 || !y0.is_finite() {
        return None;
    }
    let mut xs: Vec<f64> = Vec::new();
    for cycle in &piece.cycles {
        for i in 0..cycle.len() {
            let p = nodes[cycle[i].0 as usize];
            let q = nodes[cycle[(i + 1) % cycle.len()].0 as usize];
            if (p[v] > y0) != (q[v] > y0) {
                xs.push(p[u] + (y0 - p[v]) / (q[v] - p[v]) * (q[u] - p[u]));
            }
        }
    }
    xs.sort_by(f64::total_cmp);
    let (width, x0) =
        xs.chunks_exact(2).map(|w| (w[1] - w[0], 0.5 * (w[0] + w[1]))).max_by(|p, q| p.0.total_cmp(&q.0))?;
    if width <= 0.0 {
        return None;
    }
    let mut x = Vec3::zeros();
    x[u] = x0;
    x[v] = y0;
    x[axis] = a[axis] - (n[u] * (x0 - a[u]) + n[v] * (y0 - a[v])) / n[axis];
    x.iter().all(|c| c.is_finite()).then_some(x)
}

/// What [`classify`] found.
pub(crate) struct Classified {
    pub(crate) patches: Vec<Patch>,
    /// Segment sides whose two pieces lie in one patch or whose winding numbers do not
    /// differ as the exact side test says.
    pub(crate) inconsistent_walls: usize,
    /// Ray queries made (one per connected group of patches, more where an origin lay
    /// exactly on another face).
    pub(crate) rays: usize,
    /// Groups of patches where every probe was refused, or no two probes agreed (their
    /// patches are skipped).
    pub(crate) unresolved: usize,
    /// Groups whose two probes disagreed (unresolved, skipped).
    pub(crate) ray_disagreements: usize,
    /// Per patch, its tangle (a representative patch): groups linked through shared
    /// segments.
    pub(crate) tangle_of: Vec<u32>,
}

/// `w_out(left) − w_out(right)` across the chord `from → to` of face `f` along segment
/// `s`, where `left` is the piece of `f` on the left of that directed edge: `+1` when the
/// left piece lies on the inward side of the other face `g` of the segment, `−1` otherwise.
///
/// The segment runs along `±(n_f × n_g)`, and within `f` the left of `n_f × n_g` is the
/// inward side of `g`, so the sign is that of `(to − from) · (n_f × n_g)`. It is read off
/// exactly at an end of the segment: where an edge `p → q` of `f` (in `f`'s corner order)
/// crosses `g` and the segment leaves `f` there, the left of the chord holds `q`, so the sign
/// is `+` iff `q` lies on `g`'s inward side; where an edge `p → q` of `g` crosses `f` and `g`
/// ends there, the left of the direction within `g` holds `q` and lies on `f`'s outward side
/// iff the sign is `+`. Both sides come from [`orient3d_sos`], the predicate that decided the
/// crossings. At the segment's start the same reading gives the sign of the reversed
/// direction; a loop-vertex end has no edge, so the other end is read. A chord edge between
/// crossing nodes (triple points) takes the sign of its segment, along or against it.
fn chord_sign(mesh: &TriMesh, inter: &SelfIntersections, nodes: &[Vec3], f: u32, s: u32, from: u32, to: u32) -> i64 {
    let seg = &inter.segments[s as usize];
    let g = if seg.faces[0] == f { seg.faces[1] } else { seg.faces[0] };
    let nv = mesh.n_vertices() as u32;
    let faces = mesh.faces();
    let pos = mesh.positions();
    // `q`'s side of face `h`: `Greater` on the inward side.
    let side = |h: u32, q: u32| {
        let hv = faces[h as usize];
        orient3d_sos(
            [pos[hv[0] as usize], pos[hv[1] as usize], pos[hv[2] as usize], pos[q as usize]],
            [hv[0], hv[1], hv[2], q],
        )
    };
    // The second vertex of edge `e` in face `h`'s corner order.
    let second = |h: u32, e: u32| {
        let [a, b] = mesh.topology().edges()[e as usize];
        let hv = faces[h as usize];
        (0..3)
            .map(|k| (hv[k], hv[(k + 1) % 3]))
            .find(|&(x, y)| (x == a && y == b) || (x == b && y == a))
            .map(|(_, y)| y)
    };
    // Sign for the segment directed towards `node`, if `node` is an intersection point.
    let towards = |node: u32| -> Option<bool> {
        if node < nv {
            return None;
        }
        let p = &inter.points[((node - nv) / 2) as usize];
        if (node - nv) % 2 == 0 {
            // Edge node: an edge of f crossing g.
            second(f, p.edge).map(|q| side(g, q) == Ordering::Greater)
        } else {
            // Face node: an edge of g crossing f.
            second(g, p.edge).map(|q| side(f, q) == Ordering::Less)
        }
    };
    // The segment's end nodes on f; a chord edge between crossing nodes (triple points)
    // lies on the segment between them, along it or against it.
    let end = |e: SegmentEnd| match e {
        SegmentEnd::LoopVertex(v) => v,
        SegmentEnd::Point(i) => {
            if inter.points[i as usize].face == f {
                face_node(nv as usize, i)
            } else {
                edge_node(nv as usize, i)
            }
        }
    };
    let (e0, e1) = (end(seg.ends[0]), end(seg.ends[1]));
    let along = if from == e0 || to == e1 {
        true
    } else if from == e1 || to == e0 {
        false
    } else {
        (nodes[to as usize] - nodes[from as usize]).dot(&(nodes[e1 as usize] - nodes[e0 as usize])) > 0.0
    };
    let forward = match towards(e1).or_else(|| towards(e0).map(|b| !b)) {
        Some(true) => 1,
        Some(false) => -1,
        None => return 0,
    };
    if along {
        forward
    } else {
        -forward
    }
}

/// Classifies every patch: the winding difference across every intersection segment comes
/// from [`chord_sign`]; ray queries per connected group of patches (`ray(ray, skip)`
/// returns the signed crossing count), from the group's two best probes (uncut faces'
/// centroids first), fix the group's absolute winding numbers if they agree; then every
/// segment is checked. Volumes and areas are left at 0.
pub(crate) fn classify(
    mesh: &TriMesh,
    cut: &CutMesh,
    inter: &SelfIntersections,
    nodes: &[Vec3],
    scratch: &mut Scratch,
    has_open_holes: bool,
    mut ray: impl FnMut(&AxisRay, u32) -> Option<i64>,
) -> Classified {
    // The labelling, and beside it what needs only the cut: per chord edge of a piece (in
    // piece, cycle and edge order) the piece across it and the winding step, and every
    // piece's area for the probes.
    let (n_patches, (chords, piece_areas)) = rayon::join(
        || label_patches(mesh, cut, scratch),
        || {
            rayon::join(
                || chord_steps(mesh, cut, inter, nodes),
                || {
                    let ids = cut.n_faces as u32..(cut.n_faces + cut.pieces.len()) as u32;
                    ids.map(|id| volume::area(mesh, cut, nodes, id)).collect::<Vec<f64>>()
                },
            )
        },
    );
    let patch_of = &scratch.patch_of;
    let mut patches =
        vec![
            Patch { winding_outside: 0, weight: 0, skipped: false, n_faces: 0, n_pieces: 0, volume: 0.0, area: 0.0 };
            n_patches
        ];
    // Walls `(left patch, right patch, w_left − w_right)`, one per chord edge of a piece, and
    // the patches along each segment.
    let mut walls: Vec<(u32, u32, i64)> = Vec::with_capacity(chords.len());
    let mut segment_patch: Vec<(u32, u32)> = Vec::new();
    for &(id, across, delta) in &chords {
        walls.push(match across {
            // Nothing across the segment: the cut is not closed here.
            None => (patch_of[id as usize], u32::MAX, 0),
            Some(nb) => (patch_of[id as usize], patch_of[nb as usize], delta),
        });
    }
    // Probes per patch: its largest uncut face and its largest piece. An uncut face's
    // centroid lies well inside it; a ray that finds its origin exactly on another face is
    // refused and the next probe is tried. Uncut faces are ranked by their squared doubled
    // area (the same order, without a square root per face), pieces by their area; the two
    // kinds are only compared among themselves.
    let mut best_face: Vec<(f64, u32)> = vec![(-1.0, u32::MAX); n_patches];
    let mut best_piece: Vec<(f64, u32)> = vec![(-1.0, u32::MAX); n_patches];
    for id in live_ids(cut) {
        let p = patch_of[id as usize] as usize;
        let (best, area) = if (id as usize) < cut.n_faces {
            patches[p].n_faces += 1;
            (&mut best_face[p], scratch.area2[id as usize])
        } else {
            patches[p].n_pieces += 1;
            (&mut best_piece[p], piece_areas[id as usize - cut.n_faces])
        };
        if best.1 == u32::MAX || area > best.0 {
            *best = (area, id);
        }
    }
    // Groups of patches linked by walls: relative windings by propagation, then two rays.
    let mut adj: Vec<Vec<(u32, i64)>> = vec![Vec::new(); n_patches];
    for &(a, b, d) in &walls {
        if a != b && b != u32::MAX && d != 0 {
            adj[a as usize].push((b, d));
            adj[b as usize].push((a, -d));
        }
    }
    let mut group_of = vec![u32::MAX; n_patches];
    let mut rays = 0;
    let mut unresolved = 0;
    let mut ray_disagreements = 0;
    let mut group: Vec<u32> = Vec::new();
    let mut candidates: Vec<(bool, f64, u32, u32)> = Vec::new();
    for start in 0..n_patches {
        if group_of[start] != u32::MAX {
            continue;
        }
        group.clear();
        group.push(start as u32);
        group_of[start] = start as u32;
        let mut i = 0;
        while i < group.len() {
            for &(b, _) in &adj[group[i] as usize] {
                if group_of[b as usize] == u32::MAX {
                    group_of[b as usize] = start as u32;
                    group.push(b);
                }
            }
            i += 1;
        }
        candidates.clear();
        for &p in &group {
            for (uncut, (area, id)) in [(true, best_face[p as usize]), (false, best_piece[p as usize])] {
                if id != u32::MAX {
                    candidates.push((uncut, area, id, p));
                }
            }
        }
        candidates.sort_by(|a, b| (b.0, b.1).partial_cmp(&(a.0, a.1)).unwrap_or(Ordering::Equal));
        // Relative winding numbers first (the group's first patch at 0), then the probes:
        // each ray fixes the offset of the whole group. A probe point is computed in floating
        // point, so where another face is coplanar with its own (grid-snapped meshes) the
        // rounding, not the perturbation that decided the crossings, can put it on the wrong
        // side of that face and the count is off by one. A ray whose line meets a face
        // exactly coplanar with the probe's is refused (`ray_winding`); a face nearly
        // coplanar can still mislead a probe. So the first two probes that give a
        // count must agree (a group with a single probe takes its count); where they differ
        // the group is skipped as unresolved: a vote among further probes was measured to
        // pick the wrong count on such meshes (libigl comparison in `reports/gia/`).
        let start_patch = group[0];
        patches[start_patch as usize].winding_outside = 0;
        let mut done: Vec<u32> = vec![start_patch];
        let mut seen: rustc_hash::FxHashSet<u32> = [start_patch].into_iter().collect();
        while let Some(a) = done.pop() {
            let wa = patches[a as usize].winding_outside;
            for &(b, d) in &adj[a as usize] {
                if seen.insert(b) {
                    patches[b as usize].winding_outside = wa - d;
                    done.push(b);
                }
            }
        }
        let mut offsets: Vec<i64> = Vec::new();
        for &(_, _, id, p) in &candidates {
            let (r, skip) = probe_ray(mesh, cut, nodes, id);
            rays += 1;
            let Some(w) = ray(&r, skip) else { continue };
            offsets.push(w - patches[p as usize].winding_outside);
            if offsets.len() == 2 {
                break;
            }
        }
        let offset = match offsets.as_slice() {
            [o] => *o,
            [o, q] if o == q => *o,
            _ => {
                if offsets.len() == 2 {
                    ray_disagreements += 1;
                }
                unresolved += 1;
                for &p in &group {
                    patches[p as usize].skipped = true;
                }
                continue;
            }
        };
        for &p in &group {
            patches[p as usize].winding_outside += offset;
        }
    }
    let mut inconsistent_walls = 0;
    let mut bad_group = vec![false; n_patches];
    for &(a, b, d) in &walls {
        if b == u32::MAX {
            inconsistent_walls += 1;
            bad_group[group_of[a as usize] as usize] = true;
            continue;
        }
        let (wa, wb) = (patches[a as usize].winding_outside, patches[b as usize].winding_outside);
        if a == b || d == 0 || wa - wb != d {
            inconsistent_walls += 1;
            bad_group[group_of[a as usize] as usize] = true;
            bad_group[group_of[b as usize] as usize] = true;
        }
    }
    // One inconsistent wall makes every winding number of its group doubtful (they were
    // propagated through it), and the cells those patches bound are also bounded by the
    // patches across the same segments: the whole tangle (groups linked through shared
    // segments) is skipped, so that no partial sum is reported as a volume.
    // Every piece of a face that a segment crosses lies along that segment; a cut face with
    // no chord at all was kept whole (complex) and its patch cannot be trusted.
    for (s, seg) in inter.segments.iter().enumerate() {
        for &f in &seg.faces {
            for k in cut.face_pieces[f as usize].clone() {
                let piece = &cut.pieces[k as usize];
                let p = patch_of[cut.n_faces + k as usize];
                segment_patch.push((s as u32, p));
                let has_chord = piece.cycles.iter().flatten().any(|c| matches!(c.1, EdgeTag::Chord { .. }));
                if !has_chord {
                    bad_group[group_of[p as usize] as usize] = true;
                }
            }
        }
    }
    // A triple point of faces f, g, h is a crossing node on each of the three faces; where
    // the faces disagree (a crossing found on one face but not on another, in nearly
    // degenerate configurations) the cut is not one surface and its patches are doubtful.
    if !cut.crossings.is_empty() {
        let other = |s: u32, f: u32| {
            let faces = inter.segments[s as usize].faces;
            if faces[0] == f {
                faces[1]
            } else {
                faces[0]
            }
        };
        let mut triples: Vec<[u32; 3]> = cut
            .crossings
            .iter()
            .map(|c| {
                let mut t = [c.face, other(c.segments[0], c.face), other(c.segments[1], c.face)];
                t.sort_unstable();
                t
            })
            .collect();
        triples.sort_unstable();
        let mut i = 0;
        while i < triples.len() {
            let mut j = i;
            while j < triples.len() && triples[j] == triples[i] {
                j += 1;
            }
            if (j - i) % 3 != 0 {
                for &f in &triples[i] {
                    for k in cut.face_pieces[f as usize].clone() {
                        let p = patch_of[cut.n_faces + k as usize];
                        bad_group[group_of[p as usize] as usize] = true;
                    }
                }
            }
            i = j;
        }
    }
    // Tangles: groups linked through shared segments. Every cell's boundary lies within
    // one tangle per connected component (patches meet only along segments or inside a
    // patch), which `accumulate` uses to check that the weighted patches close up.
    let mut tangle: Vec<u32> = (0..n_patches as u32).collect();
    for p in 0..n_patches {
        union(&mut tangle, p as u32, group_of[p]);
    }
    segment_patch.sort_unstable();
    for w in segment_patch.windows(2) {
        if w[0].0 == w[1].0 {
            union(&mut tangle, w[0].1, w[1].1);
        }
    }
    let tangle_of: Vec<u32> = (0..n_patches as u32).map(|p| find(&mut tangle, p)).collect();
    if bad_group.iter().any(|&b| b) {
        let mut bad_tangle = vec![false; n_patches];
        for p in 0..n_patches {
            if bad_group[group_of[p] as usize] {
                bad_tangle[tangle_of[p] as usize] = true;
            }
        }
        for (p, patch) in patches.iter_mut().enumerate() {
            if bad_tangle[tangle_of[p] as usize] {
                patch.skipped = true;
            }
        }
    }
    if has_open_holes {
        // A patch reaching an open hole would bound penetrated space through the hole's
        // virtual fan, which is not in the sum: skipped when its weight is nonzero.
        let topo = mesh.topology();
        for (e, &[g, h]) in topo.edge_faces().iter().enumerate() {
            let _ = e;
            let f = match (g, h) {
                (NO_FACE, f) | (f, NO_FACE) if f != NO_FACE => f,
                _ => continue,
            };
            let ids: Vec<u32> = if cut.is_cut(f) {
                cut.face_pieces[f as usize].clone().map(|k| (cut.n_faces as u32) + k).collect()
            } else {
                vec![f]
            };
            for id in ids {
                let p = &mut patches[patch_of[id as usize] as usize];
                if matches!(p.winding_outside, 1 | -1) {
                    p.skipped = true;
                }
            }
        }
    }
    for p in &mut patches {
        p.weight = if p.skipped {
            0
        } else {
            match p.winding_outside {
                1 => 1,
                -1 => -1,
                _ => 0,
            }
        };
    }
    Classified { patches, inconsistent_walls, rays, unresolved, ray_disagreements, tangle_of }
}

/// Relative mean thickness (of the mesh's bounding-box diagonal) below which a tangle's
/// penetrated cells count as flat (see `accumulate`): about 10⁴ roundings of a coordinate.
pub const FLAT_THICKNESS: f64 = 1e-12;

/// Adds each weighted patch's volume `weight · T_P` and area to `patches`, and their
/// gradients (per cut node) to `node_grad` and `area_node_grad` (an empty buffer is a
/// gradient left out, see [`crate::Gradients`]). Returns the number of
/// tangles skipped because their weighted patches do not close up, and of tangles left out
/// as flat.
///
/// # Flat tangles
/// A tangle whose penetrated cells have a mean thickness `|V_t| / A_t` of at most
/// [`FLAT_THICKNESS`] times the mesh's size (its weighted volume against its weighted
/// patches' area) encloses no volume the coordinates resolve: faces that coincide up to
/// rounding (a flat sheet closed by the fan in its own plane). There the volume is a kink at
/// zero, `V ≈ A |t|`, and its derivative the one-sided `± A n` picked by rounding: so the
/// tangle contributes neither volume nor gradient (not skipped: its answer, 0, is known).
///
/// # Closure check
/// The weighted patches `Σ weight_P · P` are the boundary of the penetrated set, a closed
/// surface within each tangle, so their weighted vector areas `Σ weight_P A_P` (with
/// `A_P = ½ Σ p_k × p_{k+1}` over its cycles) vanish per tangle, up to rounding: the pieces
/// on the two sides of a chord share its nodes. Where they do not (beyond
/// `1e-9 Σ |A_P|`), the classification is wrong somewhere in the tangle (seen on
/// grid-snapped meshes whose faces have zero area: the cut of such a face is not a
/// surface), the sum would depend on the origin and can come out negative, and the
/// tangle's patches are skipped instead (weight 0, counted). Not checked with
/// `check_closed` false: SENC's frozen-weight nodes on moved positions do not meet exactly.
pub(crate) fn accumulate(
    mesh: &TriMesh,
    cut: &CutMesh,
    nodes: &[Vec3],
    scratch: &Scratch,
    tangle_of: &[u32],
    check_closed: bool,
    patches: &mut [Patch],
    node_grad: &mut [Vec3],
    area_node_grad: &mut [Vec3],
) -> (usize, usize) {
    if patches.iter().all(|p| p.weight == 0) {
        return (0, 0);
    }
    // Weighted vector area, total area and weighted volume per tangle; each weighted fill
    // id with its vector area and signed volume, for the sums below.
    let mut closure: Vec<(Vec3, f64, f64)> = vec![(Vec3::zeros(), 0.0, 0.0); patches.len()];
    let mut weighted: Vec<(u32, Vec3, f64)> = Vec::new();
    for id in live_ids(cut) {
        let p = scratch.patch_of[id as usize] as usize;
        if patches[p].weight == 0 {
            continue;
        }
        let w = f64::from(patches[p].weight);
        let a = volume::vector_area(mesh, cut, nodes, id);
        let v = volume::signed_volume(mesh, cut, nodes, id);
        let t = &mut closure[tangle_of[p] as usize];
        t.0 += a * w;
        t.1 += a.norm();
        t.2 += w * v;
        weighted.push((id, a, v));
    }
    let (lo, hi) = mesh
        .positions()
        .iter()
        .fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let size = (hi - lo).norm();
    let mut n_open = 0;
    let mut n_flat = 0;
    // 0: keep, 1: open (skipped), 2: flat (weight 0, not skipped).
    let verdict: Vec<u8> = closure
        .iter()
        .map(|&(v, total, vol)| {
            if total == 0.0 {
                0
            } else if check_closed && (v.norm() > 1e-9 * total || v.norm().is_nan()) {
                n_open += 1;
                1
            } else if vol.abs() <= FLAT_THICKNESS * size * total {
                n_flat += 1;
                2
            } else {
                0
            }
        })
        .collect();
    for (p, patch) in patches.iter_mut().enumerate() {
        match verdict[tangle_of[p] as usize] {
            1 if patch.weight != 0 => (patch.weight, patch.skipped) = (0, true),
            2 => patch.weight = 0,
            _ => {}
        }
    }
    // Weights only drop to 0 above, so these are the weighted ids left, in the same order.
    for &(id, a, v) in &weighted {
        let p = &mut patches[scratch.patch_of[id as usize] as usize];
        if p.weight == 0 {
            continue;
        }
        let w = f64::from(p.weight);
        p.volume += w * v;
        p.area += a.norm();
        if !node_grad.is_empty() {
            volume::add_volume_gradient(mesh, cut, nodes, id, w, node_grad);
        }
        if !area_node_grad.is_empty() {
            volume::add_area_gradient_of(mesh, cut, nodes, id, a, 1.0, area_node_grad);
        }
    }
    (n_open, n_flat)
}
