//! SENC's rule, kept for ablation and comparison: each closed contour is flood-filled on both
//! sides in lockstep and the side that runs out first is the penetrating one (Baraff, Witkin
//! and Kass 2003); contours that share intersection points are grouped, and each group's
//! filled pieces give one region of volume `|Σ signed tetrahedra|`.
//!
//! The rule has no answer where a region is bounded by several contours that are not
//! twins, where contours share regions, or where both sides are equal: such contours are
//! skipped and counted ([`Diagnostics::fills_met`], [`Diagnostics::fills_tied`],
//! [`Diagnostics::groups_skipped`]). Where it does answer, it agrees with the winding rule.

use senc_geom::cut::CutMesh;
use senc_geom::intersect::SelfIntersections;
use senc_geom::{TriMesh, Vec3};

use crate::paths::{Contour, PathKind};
use crate::{volume, Diagnostics, Penetration, Region, SizeRule};

/// Flood-fill marks, reused between calls.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    mark: Vec<u8>,
    touched: Vec<u32>,
}

const UNSEEN: u8 = 0;
const LEFT: u8 = 1;
const RIGHT: u8 = 2;

/// Fills every closed contour, groups them and adds each group's region to `out`, its volume
/// gradient (per cut node) to `node_grad` and its area gradient to `area_node_grad` (an
/// empty buffer is a gradient left out, see [`crate::Gradients`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn regions(
    scratch: &mut Scratch,
    mesh: &TriMesh,
    cut: &CutMesh,
    inter: &SelfIntersections,
    contours: &[Contour],
    nodes: &[Vec3],
    rule: SizeRule,
    out: &mut Penetration,
    node_grad: &mut [Vec3],
    area_node_grad: &mut [Vec3],
) {
    let mut sides: Vec<Option<Vec<u32>>> = Vec::with_capacity(contours.len());
    for c in contours {
        if c.kind == PathKind::OpenBoundary {
            sides.push(None);
            continue;
        }
        sides.push(fill(scratch, mesh, cut, inter, c, nodes, rule, &mut out.diagnostics));
    }
    // Group contours that share intersection points (twins bound one pocket).
    for group in group_contours(contours, inter.points.len()) {
        if group.iter().any(|&c| sides[c].is_none()) {
            if group.iter().any(|&c| contours[c].kind != PathKind::OpenBoundary) {
                out.diagnostics.groups_skipped += 1;
            }
            continue;
        }
        let mut ids: Vec<u32> = group.iter().flat_map(|&c| sides[c].clone().unwrap_or_default()).collect();
        ids.sort_unstable();
        ids.dedup();
        let signed: f64 = ids.iter().map(|&id| volume::signed_volume(mesh, cut, nodes, id)).sum();
        let area: f64 = ids.iter().map(|&id| volume::area(mesh, cut, nodes, id)).sum();
        let sign = if signed >= 0.0 { 1.0 } else { -1.0 };
        for &id in &ids {
            if !node_grad.is_empty() {
                volume::add_volume_gradient(mesh, cut, nodes, id, sign, node_grad);
            }
            if !area_node_grad.is_empty() {
                volume::add_area_gradient(mesh, cut, nodes, id, 1.0, area_node_grad);
            }
        }
        let mut faces: Vec<u32> = ids.iter().map(|&id| cut.face_of(id)).collect();
        faces.sort_unstable();
        faces.dedup();
        let region = out.regions.len();
        for &c in &group {
            out.paths[c].region = Some(region);
        }
        out.regions.push(Region {
            paths: group.clone(),
            faces,
            n_sub_faces: ids.iter().filter(|&&id| id as usize >= cut.n_faces).count(),
            volume: signed.abs(),
            area,
        });
        out.volume += signed.abs();
        out.area += area;
    }
}

/// Lockstep flood fill of both sides of contour `c`; returns the fill ids of the side
/// that finished first, or `None` (with a diagnostic) when the fills meet or tie.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fill(
    scratch: &mut Scratch,
    mesh: &TriMesh,
    cut: &CutMesh,
    inter: &SelfIntersections,
    c: &Contour,
    nodes: &[Vec3],
    rule: SizeRule,
    diag: &mut Diagnostics,
) -> Option<Vec<u32>> {
    let n_ids = cut.n_fill_ids();
    if scratch.mark.len() < n_ids {
        scratch.mark.resize(n_ids, UNSEEN);
    }
    for &t in &scratch.touched {
        scratch.mark[t as usize] = UNSEEN;
    }
    scratch.touched.clear();
    // Walls of this contour: (segment, side) preimages.
    let mut walls: Vec<(u32, u8)> = c.steps.iter().map(|s| (s.segment, s.side)).collect();
    walls.sort_unstable();
    let is_wall = |segment: u32, face: u32| -> bool {
        let seg = &inter.segments[segment as usize];
        let side = if seg.faces[0] == face { 0 } else { 1 };
        walls.binary_search(&(segment, side)).is_ok()
    };
    let mut queues: [std::collections::VecDeque<u32>; 2] = Default::default();
    let mut met = false;
    for s in &c.steps {
        for (dir, label) in [((s.from, s.to), LEFT), ((s.to, s.from), RIGHT)] {
            if let Some(id) = cut.piece_with_directed_edge(dir.0, dir.1) {
                let m = &mut scratch.mark[id as usize];
                if *m == UNSEEN {
                    *m = label;
                    scratch.touched.push(id);
                    queues[(label - 1) as usize].push_back(id);
                } else if *m != label {
                    met = true;
                }
            }
        }
    }
    if queues[0].is_empty() || queues[1].is_empty() {
        met = true;
    }
    let mut size = [0.0f64; 2];
    let mut members: [Vec<u32>; 2] = Default::default();
    let face_of = |id: u32| if (id as usize) < cut.n_faces { id } else { cut.pieces[id as usize - cut.n_faces].face };
    while !met {
        let done = [queues[0].is_empty(), queues[1].is_empty()];
        if done[0] || done[1] {
            if done[0] && done[1] {
                diag.fills_tied += 1;
                return None;
            }
            let k = if done[0] { 0 } else { 1 };
            return Some(std::mem::take(&mut members[k]));
        }
        // Which side grows now.
        let order: &[usize] = match rule {
            SizeRule::Faces => &[0, 1],
            SizeRule::Area => {
                if size[0] <= size[1] {
                    &[0]
                } else {
                    &[1]
                }
            }
        };
        for &k in order {
            let Some(id) = queues[k].pop_front() else { continue };
            members[k].push(id);
            size[k] += match rule {
                SizeRule::Faces => 1.0,
                SizeRule::Area => volume::area(mesh, cut, nodes, id),
            };
            let label = if k == 0 { LEFT } else { RIGHT };
            let mark = &mut scratch.mark;
            let touched = &mut scratch.touched;
            let queue = &mut queues[k];
            cut.for_each_neighbour(mesh, id, |nb, wall| {
                if let Some(seg) = wall {
                    if is_wall(seg, face_of(id)) {
                        return;
                    }
                }
                let m = &mut mark[nb as usize];
                if *m == UNSEEN {
                    *m = label;
                    touched.push(nb);
                    queue.push_back(nb);
                } else if *m != label {
                    met = true;
                }
            });
            if met {
                break;
            }
        }
    }
    diag.fills_met += 1;
    None
}

/// Groups contours that share an intersection point (union-find).
fn group_contours(contours: &[Contour], n_points: usize) -> Vec<Vec<usize>> {
    let mut owner = vec![usize::MAX; n_points];
    let mut parent: Vec<usize> = (0..contours.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for (c, contour) in contours.iter().enumerate() {
        for &pt in &contour.points {
            let o = owner[pt as usize];
            if o == usize::MAX {
                owner[pt as usize] = c;
            } else {
                let (a, b) = (find(&mut parent, o), find(&mut parent, c));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut index = vec![usize::MAX; contours.len()];
    for c in 0..contours.len() {
        let r = find(&mut parent, c);
        if index[r] == usize::MAX {
            index[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[index[r]].push(c);
    }
    groups
}
