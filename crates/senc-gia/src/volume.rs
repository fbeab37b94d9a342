//! Signed volumes and areas of cut-mesh pieces, and the chain rule from piece nodes back to
//! mesh vertices (exact or with SENC's fixed barycentric weights).

use senc_geom::cut::CutMesh;
use senc_geom::intersect::SelfIntersections;
use senc_geom::{TriMesh, Vec3};

use crate::GradientMode;

/// Positions of every node of a cut mesh (vertices, then two nodes per intersection point).
///
/// In [`GradientMode::Exact`] both nodes of a point sit at the exact crossing
/// `X = a + t (b - a)`; with [`GradientMode::FixedBarycentric`] the edge node is
/// `(1 - t) a + t b` and the face node `Σ bary_k p_k` with `t` and `bary` as recorded (equal
/// to `X` up to rounding at the configuration they were computed in).
///
/// Crossing nodes (triple points, [`CutMesh::crossings`]) follow: exactly, the crossing of
/// the lines through their two chord edges within the face; with fixed weights, the
/// recorded barycentric combination of the face's corners.
///
/// [`crate::GiaWorkspace::penetration`] places the nodes exactly in both modes (the volume
/// is a function of the geometry, the mode only decides the chain rule): the fixed-weight
/// positions equal `X` only up to rounding, and not at all where the recorded barycentric
/// coordinates are meaningless (a face of zero area), where the pieces would no longer meet
/// and the sum over them would not be a closed surface's volume. The fixed-weight positions
/// serve [`crate::GiaWorkspace::analyse`]: on crossings found at other positions they give
/// SENC's frozen-weight volume, whose derivative the fixed-weight gradient is.
pub fn node_positions(
    mesh: &TriMesh,
    inter: &SelfIntersections,
    cut: &CutMesh,
    mode: GradientMode,
    out: &mut Vec<Vec3>,
) {
    out.clear();
    out.extend_from_slice(mesh.positions());
    let pos = mesh.positions();
    let edges = mesh.topology().edges();
    for p in &inter.points {
        let [a, b] = edges[p.edge as usize];
        let e = pos[a as usize] * (1.0 - p.t) + pos[b as usize] * p.t;
        let f = match mode {
            GradientMode::Exact => e,
            GradientMode::FixedBarycentric => {
                let fv = mesh.faces()[p.face as usize];
                (0..3).map(|k| pos[fv[k] as usize] * p.bary[k]).sum()
            }
        };
        out.push(e);
        out.push(f);
    }
    for c in &cut.crossings {
        let x = match mode {
            GradientMode::Exact => {
                let m = mesh.face_normal_scaled(c.face as usize);
                let [a, b, cc, d] = [c.first[0], c.first[1], c.second[0], c.second[1]].map(|n| out[n as usize]);
                let den = (b - a).cross(&(d - cc)).dot(&m);
                let s = if den != 0.0 && den.is_finite() { (cc - a).cross(&(d - cc)).dot(&m) / den } else { 0.5 };
                a + (b - a) * s
            }
            GradientMode::FixedBarycentric => {
                let fv = mesh.faces()[c.face as usize];
                (0..3).map(|k| pos[fv[k] as usize] * c.bary[k]).sum()
            }
        };
        out.push(x);
    }
}

/// Moves the gradient of every crossing node onto the nodes it is made of (exact mode: the
/// four chord-edge ends, through `X = A + s (B − A)` with
/// `s = ((C − A) × (D − C)) · m / ((B − A) × (D − C)) · m` and the face normal `m` held
/// fixed, since `s` does not change to first order when the normal turns) or onto the face's
/// corners (fixed weights). Crossing gradients are zero afterwards.
fn unfold_crossings(
    mesh: &TriMesh,
    cut: &CutMesh,
    mode: GradientMode,
    nodes: &[Vec3],
    node_grad: &mut [Vec3],
    vertex_grad: &mut [Vec3],
) {
    for (k, c) in cut.crossings.iter().enumerate() {
        let id = cut.crossing_node(k) as usize;
        let g = std::mem::replace(&mut node_grad[id], Vec3::zeros());
        if g == Vec3::zeros() {
            continue;
        }
        match mode {
            GradientMode::FixedBarycentric => {
                let fv = mesh.faces()[c.face as usize];
                for j in 0..3 {
                    vertex_grad[fv[j] as usize] += g * c.bary[j];
                }
            }
            GradientMode::Exact => {
                let m = mesh.face_normal_scaled(c.face as usize);
                let ids = [c.first[0], c.first[1], c.second[0], c.second[1]].map(|n| n as usize);
                let [a, b, cc, d] = ids.map(|n| nodes[n]);
                let den = (b - a).cross(&(d - cc)).dot(&m);
                if den == 0.0 || !den.is_finite() {
                    node_grad[ids[0]] += g * 0.5;
                    node_grad[ids[1]] += g * 0.5;
                    continue;
                }
                let num = (cc - a).cross(&(d - cc)).dot(&m);
                let s = num / den;
                let dc = d - cc;
                // ∂num and ∂den with respect to A, B, C, D.
                let dn = [-dc.cross(&m), Vec3::zeros(), dc.cross(&m) - m.cross(&(cc - a)), m.cross(&(cc - a))];
                let dd = [-dc.cross(&m), dc.cross(&m), -m.cross(&(b - a)), m.cross(&(b - a))];
                let gb = g.dot(&(b - a));
                for j in 0..4 {
                    let ds = (dn[j] - dd[j] * s) / den;
                    node_grad[ids[j]] += ds * gb;
                }
                node_grad[ids[0]] += g * (1.0 - s);
                node_grad[ids[1]] += g * s;
            }
        }
    }
}

/// `Σ p0 · (p1 × p2) / 6` over the fan of every cycle of fill id `id` (6 × signed volume of
/// the cone from the origin, divided by 6).
pub fn signed_volume(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32) -> f64 {
    let mut v = 0.0;
    for_each_fan_triangle(mesh, cut, id, |a, b, c| {
        v += nodes[a as usize].dot(&nodes[b as usize].cross(&nodes[c as usize]))
    });
    v / 6.0
}

/// Adds `scale · ∂(signed volume of id)/∂node` into `grad`.
pub fn add_volume_gradient(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32, scale: f64, grad: &mut [Vec3]) {
    let s = scale / 6.0;
    for_each_fan_triangle(mesh, cut, id, |a, b, c| {
        let (pa, pb, pc) = (nodes[a as usize], nodes[b as usize], nodes[c as usize]);
        grad[a as usize] += pb.cross(&pc) * s;
        grad[b as usize] += pc.cross(&pa) * s;
        grad[c as usize] += pa.cross(&pb) * s;
    });
}

/// Vector area `½ Σ p_k × p_{k+1}` of fill id `id` (holes subtract).
pub(crate) fn vector_area(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32) -> Vec3 {
    let mut a = Vec3::zeros();
    for_each_cycle(mesh, cut, id, |cycle| {
        for k in 0..cycle.len() {
            a += nodes[cycle[k] as usize].cross(&nodes[cycle[(k + 1) % cycle.len()] as usize]);
        }
    });
    a * 0.5
}

/// Area of fill id `id`.
pub fn area(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32) -> f64 {
    vector_area(mesh, cut, nodes, id).norm()
}

/// Adds `scale · ∂(area of id)/∂node` into `grad`: `½ (p_{k+1} − p_{k−1}) × n̂` per corner.
pub fn add_area_gradient(mesh: &TriMesh, cut: &CutMesh, nodes: &[Vec3], id: u32, scale: f64, grad: &mut [Vec3]) {
    add_area_gradient_of(mesh, cut, nodes, id, vector_area(mesh, cut, nodes, id), scale, grad);
}

/// [`add_area_gradient`] for a fill id whose [`vector_area`] `va` is known.
pub(crate) fn add_area_gradient_of(
    mesh: &TriMesh,
    cut: &CutMesh,
    nodes: &[Vec3],
    id: u32,
    va: Vec3,
    scale: f64,
    grad: &mut [Vec3],
) {
    let norm = va.norm();
    if norm == 0.0 || !norm.is_finite() {
        return;
    }
    let n = va / norm;
    for_each_cycle(mesh, cut, id, |cycle| {
        let m = cycle.len();
        for k in 0..m {
            let next = nodes[cycle[(k + 1) % m] as usize];
            let prev = nodes[cycle[(k + m - 1) % m] as usize];
            grad[cycle[k] as usize] += (next - prev).cross(&n) * (0.5 * scale);
        }
    });
}

fn for_each_cycle(mesh: &TriMesh, cut: &CutMesh, id: u32, mut f: impl FnMut(&[u32])) {
    if (id as usize) < cut.n_faces {
        f(&mesh.faces()[id as usize]);
        return;
    }
    let piece = &cut.pieces[id as usize - cut.n_faces];
    let mut buf: smallvec::SmallVec<[u32; 16]> = smallvec::SmallVec::new();
    for cycle in &piece.cycles {
        buf.clear();
        buf.extend(cycle.iter().map(|c| c.0));
        f(&buf);
    }
}

fn for_each_fan_triangle(mesh: &TriMesh, cut: &CutMesh, id: u32, mut f: impl FnMut(u32, u32, u32)) {
    if (id as usize) < cut.n_faces {
        let [a, b, c] = mesh.faces()[id as usize];
        f(a, b, c);
        return;
    }
    let piece = &cut.pieces[id as usize - cut.n_faces];
    for cycle in &piece.cycles {
        for k in 1..cycle.len().saturating_sub(1) {
            f(cycle[0].0, cycle[k].0, cycle[k + 1].0);
        }
    }
}

/// Chains node gradients back to the mesh vertices. Returns the number of points whose
/// exact derivative was replaced by the fixed-weight one because the edge was nearly
/// parallel to the face (the exact derivative grows without bound there).
///
/// Crossing nodes are unfolded first (`node_grad` is modified).
pub fn chain_to_vertices(
    mesh: &TriMesh,
    inter: &SelfIntersections,
    cut: &CutMesh,
    mode: GradientMode,
    nodes: &[Vec3],
    node_grad: &mut [Vec3],
    vertex_grad: &mut [Vec3],
) -> usize {
    let nv = mesh.n_vertices();
    vertex_grad[..nv].iter_mut().for_each(|g| *g = Vec3::zeros());
    unfold_crossings(mesh, cut, mode, nodes, node_grad, vertex_grad);
    for (v, g) in vertex_grad[..nv].iter_mut().zip(&node_grad[..nv]) {
        *v += *g;
    }
    let pos = mesh.positions();
    let edges = mesh.topology().edges();
    let mut n_fallback = 0;
    for (i, p) in inter.points.iter().enumerate() {
        let ge = node_grad[nv + 2 * i];
        let gf = node_grad[nv + 2 * i + 1];
        let [ia, ib] = edges[p.edge as usize];
        let fv = mesh.faces()[p.face as usize];
        let fixed = |vertex_grad: &mut [Vec3]| {
            vertex_grad[ia as usize] += ge * (1.0 - p.t);
            vertex_grad[ib as usize] += ge * p.t;
            for k in 0..3 {
                vertex_grad[fv[k] as usize] += gf * p.bary[k];
            }
        };
        if mode == GradientMode::FixedBarycentric {
            fixed(vertex_grad);
            continue;
        }
        // Exact: both nodes sit at X(a, b, p, q, r) = a + t d, t = N·(p − a) / N·d.
        let g = ge + gf;
        let (a, b) = (pos[ia as usize], pos[ib as usize]);
        let [pp, q, r] = fv.map(|v| pos[v as usize]);
        let d = b - a;
        let n = (q - pp).cross(&(r - pp));
        let nd = n.dot(&d);
        if nd.abs() <= 1e-9 * n.norm() * d.norm() || !nd.is_finite() {
            n_fallback += 1;
            fixed(vertex_grad);
            continue;
        }
        let t = n.dot(&(pp - a)) / nd;
        let x = a + d * t;
        let s = g.dot(&d) / nd;
        let h = g - n * s;
        vertex_grad[ia as usize] += h * (1.0 - t);
        vertex_grad[ib as usize] += h * t;
        let w = (pp - x) * s;
        vertex_grad[fv[0] as usize] += (q - r).cross(&w) + n * s;
        vertex_grad[fv[1] as usize] += (r - pp).cross(&w);
        vertex_grad[fv[2] as usize] += (pp - q).cross(&w);
    }
    n_fallback
}
