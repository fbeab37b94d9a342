//! Triangle-pair tests: float plane filters with rigorous bounds, the exact edge-versus-face
//! test from [`orient3d_sos`], and assembling pair results into points and segments.

use super::*;

/// Float plane of a face for the conservative side filter: a point `v` is certainly on the
/// side `sign(n · (v − p))` when `(n · (v − p))² > tol2 · |v − p|²`. The tolerance bounds
/// the rounding of the cross and dot products (a few ulp of `|q−p| |r−p| |v−p|`; we use
/// 1e-13, far above it), so the filter never contradicts the exact predicate.
#[derive(Debug, Clone, Copy)]
pub(super) struct FacePlane {
    pub(super) p: Vec3,
    pub(super) n: Vec3,
    pub(super) tol2: f64,
}

impl FacePlane {
    pub(super) const ZERO: FacePlane =
        FacePlane { p: Vec3::new(0.0, 0.0, 0.0), n: Vec3::new(0.0, 0.0, 0.0), tol2: 0.0 };

    #[inline]
    pub(super) fn of_triangle(p: Vec3, q: Vec3, r: Vec3) -> Self {
        let (a, b) = (q - p, r - p);
        // (1e-13 |a| |b|)², without the square roots.
        FacePlane { p, n: a.cross(&b), tol2: 1e-26 * a.norm_squared() * b.norm_squared() }
    }
}

/// A crossing found by one face pair: (edge as sorted vertex pair, face).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Crossing {
    pub(super) edge: [u32; 2],
    pub(super) face: u32,
}

#[derive(Debug, PartialEq)]
pub(super) struct PairResult {
    pub(super) faces: [u32; 2],
    pub(super) loop_vertex: Option<u32>,
    pub(super) crossings: [Option<Crossing>; 2],
    pub(super) inconsistent: bool,
}

/// `[f(a[0]), f(a[1]), f(a[2])]`: the array's `map`, always inlined (the library's is a
/// call in the pair tests' hot paths).
#[inline(always)]
pub(super) fn map3<T: Copy, U>(a: [T; 3], f: impl Fn(T) -> U) -> [U; 3] {
    [f(a[0]), f(a[1]), f(a[2])]
}

/// Side of `v` relative to the plane when the float evaluation is certain: `Some(true)` on
/// the positive side, `Some(false)` on the negative side, `None` when too close to tell.
#[inline]
pub(super) fn certain_side(plane: &FacePlane, v: Vec3) -> Option<bool> {
    let d = v - plane.p;
    let s = plane.n.dot(&d);
    if s * s > plane.tol2 * d.norm_squared() && s.is_finite() {
        Some(s > 0.0)
    } else {
        None
    }
}

/// Points and segments from the per-pair results, sorted (independent of their order).
pub(super) fn assemble(mesh: &TriMesh, results: Vec<PairResult>, n_candidate_pairs: usize) -> SelfIntersections {
    let topo = mesh.topology();
    let mut keys: Vec<(u32, u32)> = Vec::with_capacity(results.len() * 2);
    for r in &results {
        for c in r.crossings.iter().flatten() {
            let e = topo.find_edge(c.edge[0], c.edge[1]).expect("crossing edge belongs to the mesh");
            keys.push((e, c.face));
        }
    }
    keys.sort_unstable();
    keys.dedup();
    // The points on one side, the segments (which need only the points' indices) on the
    // other.
    let (points, (segments, n_inconsistent)) = rayon::join(
        || keys.iter().map(|&(e, f)| crossing_point(mesh, e, f)).collect::<Vec<IntersectionPoint>>(),
        || {
            let point_index = |c: &Crossing| -> u32 {
                let e = topo.find_edge(c.edge[0], c.edge[1]).expect("edge exists");
                keys.binary_search(&(e, c.face)).expect("point was collected") as u32
            };
            let mut segments = Vec::with_capacity(results.len());
            let mut n_inconsistent = 0;
            for r in &results {
                if r.inconsistent {
                    n_inconsistent += 1;
                    continue;
                }
                let ends = match (r.loop_vertex, r.crossings) {
                    (Some(s), [Some(c), None]) => [SegmentEnd::LoopVertex(s), SegmentEnd::Point(point_index(&c))],
                    (None, [Some(c0), Some(c1)]) => {
                        let (a, b) = (point_index(&c0), point_index(&c1));
                        [SegmentEnd::Point(a.min(b)), SegmentEnd::Point(a.max(b))]
                    }
                    _ => continue,
                };
                segments.push(Segment { faces: r.faces, ends });
            }
            segments.sort_unstable_by_key(|s| (s.faces, s.ends));
            (segments, n_inconsistent)
        },
    );
    SelfIntersections { points, segments, n_candidate_pairs, n_inconsistent_pairs: n_inconsistent }
}

pub(super) fn sos(mesh: &TriMesh, idx: [u32; 4]) -> Ordering {
    orient3d_sos(idx.map(|i| mesh.positions()[i as usize]), idx)
}

/// Whether edge `{a, b}` crosses the interior of face `face` (no shared vertices).
#[cfg(test)]
pub(super) fn edge_crosses_face(mesh: &TriMesh, edge: [u32; 2], face: [u32; 3]) -> bool {
    let [a, b] = edge;
    let [p, q, r] = face;
    let sa = sos(mesh, [p, q, r, a]);
    let sb = sos(mesh, [p, q, r, b]);
    if sa == sb {
        return false;
    }
    let s1 = sos(mesh, [a, b, p, q]);
    let s2 = sos(mesh, [a, b, q, r]);
    s1 == s2 && s2 == sos(mesh, [a, b, r, p])
}

/// Sign of `orient3d(t[0], t[1], t[2], v)` (as [`orient3d_sos`]), where `plane` is face
/// `t`'s float plane: from the plane when [`certain_side`] is sure (`n · (v − p) > 0`
/// means `v` above, where `orient3d` is negative), from the exact predicate otherwise.
#[inline]
pub(super) fn plane_side(mesh: &TriMesh, plane: &FacePlane, t: [u32; 3], v: u32) -> Ordering {
    match certain_side(plane, mesh.positions()[v as usize]) {
        Some(true) => Ordering::Less,
        Some(false) => Ordering::Greater,
        None => sos(mesh, [t[0], t[1], t[2], v]),
    }
}

/// Whether two faces sharing no vertex are certainly apart: along the in-plane normal
/// `a = n × e` of some edge `e = q − p` of either face (pointing away from that face's third
/// vertex), every vertex `w` of the other face has `a · (w − p) > 1e-12 |a| (|w − p| + |e|)`.
/// The face itself reaches at most about `3 ε |a| |e|` along `a` (exactly 0 at `p`, and `a`
/// is perpendicular to `e` up to rounding), and the rounding of each dot product is a few
/// `ε |a| |w − p|`, so the faces are a positive distance apart and no perturbation can make
/// them cross. Used for nearly coplanar pairs, where the plane sides are undecided.
pub(super) fn separated_by_edge_normal(
    pos: &[Vec3],
    fv: [u32; 3],
    gv: [u32; 3],
    pf: &FacePlane,
    pg: &FacePlane,
) -> bool {
    for (t, o, pl) in [(fv, gv, pf), (gv, fv, pg)] {
        let tp = map3(t, |v| pos[v as usize]);
        let op = map3(o, |v| pos[v as usize]);
        'edges: for k in 0..3 {
            let (p, q, r) = (tp[k], tp[(k + 1) % 3], tp[(k + 2) % 3]);
            let e = q - p;
            let mut a = pl.n.cross(&e);
            let an = a.norm_squared();
            let dr = r - p;
            let sr = a.dot(&dr);
            // The third vertex must be clearly on the inner side (non-degenerate face).
            let inner_clear = sr * sr > 1e-24 * an * dr.norm_squared();
            if !inner_clear {
                continue;
            }
            if sr > 0.0 {
                a = -a;
            }
            let en = e.norm_squared();
            for w in op {
                let d = w - p;
                let s = a.dot(&d);
                if !(s > 0.0 && s * s > 4e-24 * an * d.norm_squared().max(en)) {
                    continue 'edges;
                }
            }
            return true;
        }
    }
    false
}

/// Whether the signs of `orient3d(a, b, p, q)`, `(a, b, q, r)` and `(a, b, r, p)` agree,
/// that is, whether edge `{a, b}`, whose ends lie on opposite sides of face `(p, q, r)`,
/// crosses its interior. Each sign is first taken from the float value
/// `orient3d(a, b, x, y) = −(b − a) · ((x − a) × (y − a))` when it exceeds 1e-13 times the
/// product of the three difference lengths (the rounding is below 50 ε of that product), and
/// from [`orient3d_sos`] otherwise: the same decision as [`edge_crosses_face`].
#[inline]
pub(super) fn edge_orients_agree(mesh: &TriMesh, edge: [u32; 2], face: [u32; 3]) -> bool {
    let pos = mesh.positions();
    let [a, b] = edge;
    let pa = pos[a as usize];
    let d = pos[b as usize] - pa;
    let dn = d.norm_squared();
    let w = map3(face, |v| pos[v as usize] - pa);
    let orient = |i: usize, j: usize| -> Ordering {
        let v = d.dot(&w[i].cross(&w[j]));
        let bound2 = 1e-26 * dn * w[i].norm_squared() * w[j].norm_squared();
        if v * v > bound2 && v.is_finite() {
            if v < 0.0 {
                Ordering::Greater
            } else {
                Ordering::Less
            }
        } else {
            sos(mesh, [a, b, face[i], face[j]])
        }
    };
    let s1 = orient(0, 1);
    s1 == orient(1, 2) && s1 == orient(2, 0)
}

/// [`test_pair`] for faces `f < g` with their float planes: the same result, with the signs
/// of each face's vertices against the other face's plane taken once, from the planes where
/// certain, and reused for the edges.
pub(super) fn test_pair_planes(mesh: &TriMesh, f: u32, g: u32, pf: &FacePlane, pg: &FacePlane) -> Option<PairResult> {
    let fv = mesh.faces()[f as usize];
    let gv = mesh.faces()[g as usize];
    let mut shared = None;
    let mut n_shared = 0;
    for &v in &fv {
        if gv.contains(&v) {
            shared = Some(v);
            n_shared += 1;
        }
    }
    match (n_shared, shared) {
        (0, _) => {
            let pos = mesh.positions();
            // Certainly all on one side of the other's plane: apart (`g`'s vertices first,
            // `f`'s only where that did not settle it).
            let one_side = |c: [Option<bool>; 3]| matches!(c, [Some(a), Some(b), Some(c)] if a == b && b == c);
            let cg = map3(gv, |v| certain_side(pf, pos[v as usize]));
            if one_side(cg) {
                return None;
            }
            let cf = map3(fv, |v| certain_side(pg, pos[v as usize]));
            if one_side(cf) {
                return None;
            }
            // Nearly coplanar: try to separate the faces within the plane before any exact
            // predicate.
            if (cg.contains(&None) || cf.contains(&None)) && separated_by_edge_normal(pos, fv, gv, pf, pg) {
                return None;
            }
            let resolve = |c: Option<bool>, t: [u32; 3], v: u32| match c {
                Some(true) => Ordering::Less,
                Some(false) => Ordering::Greater,
                None => sos(mesh, [t[0], t[1], t[2], v]),
            };
            let sg = map3([0, 1, 2], |k| resolve(cg[k], fv, gv[k]));
            if sg[0] == sg[1] && sg[1] == sg[2] {
                return None;
            }
            let sf = map3([0, 1, 2], |k| resolve(cf[k], gv, fv[k]));
            if sf[0] == sf[1] && sf[1] == sf[2] {
                return None;
            }
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, signs) in [(fv, gv, g, sf), (gv, fv, f, sg)] {
                for k in 0..3 {
                    if signs[(k + 1) % 3] == signs[(k + 2) % 3] {
                        continue;
                    }
                    let e = sorted(tri[(k + 1) % 3], tri[(k + 2) % 3]);
                    if edge_orients_agree(mesh, e, other) {
                        if n < 2 {
                            found[n] = Some(Crossing { edge: e, face: other_id });
                        }
                        n += 1;
                    }
                }
            }
            match n {
                0 => None,
                _ => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: n != 2 }),
            }
        }
        (1, Some(s)) => {
            let opposite = |t: [u32; 3]| {
                let k = t.iter().position(|&v| v == s).unwrap_or(0);
                sorted(t[(k + 1) % 3], t[(k + 2) % 3])
            };
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, plane) in [(fv, gv, g, pg), (gv, fv, f, pf)] {
                let e = opposite(tri);
                if plane_side(mesh, plane, other, e[0]) == plane_side(mesh, plane, other, e[1]) {
                    continue;
                }
                if edge_orients_agree(mesh, e, other) {
                    if n < 2 {
                        found[n] = Some(Crossing { edge: e, face: other_id });
                    }
                    n += 1;
                }
            }
            match n {
                0 => None,
                _ => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: n != 1 }),
            }
        }
        _ => None,
    }
}

pub(super) fn sorted(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// The reference pair test, all from [`orient3d_sos`] (kept for tests of the faster path).
#[cfg(test)]
pub(super) fn test_pair(mesh: &TriMesh, f: u32, g: u32) -> Option<PairResult> {
    let fv = mesh.faces()[f as usize];
    let gv = mesh.faces()[g as usize];
    let mut shared = [0u32; 3];
    let mut n_shared = 0;
    for &v in &fv {
        if gv.contains(&v) {
            shared[n_shared] = v;
            n_shared += 1;
        }
    }
    match n_shared {
        0 => {
            // Early out: all of one triangle strictly on one side of the other's plane.
            let side = |t: [u32; 3], v: u32| sos(mesh, [t[0], t[1], t[2], v]);
            let sg = gv.map(|v| side(fv, v));
            if sg[0] == sg[1] && sg[1] == sg[2] {
                return None;
            }
            let sf = fv.map(|v| side(gv, v));
            if sf[0] == sf[1] && sf[1] == sf[2] {
                return None;
            }
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id, signs) in [(fv, gv, g, sf), (gv, fv, f, sg)] {
                for k in 0..3 {
                    let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
                    // An edge can only cross if its ends are on opposite sides.
                    if signs[(k + 1) % 3] == signs[(k + 2) % 3] {
                        continue;
                    }
                    if edge_crosses_face(mesh, sorted(a, b), other) {
                        if n < 2 {
                            found[n] = Some(Crossing { edge: sorted(a, b), face: other_id });
                        }
                        n += 1;
                    }
                }
            }
            match n {
                0 => None,
                2 => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: false }),
                _ => Some(PairResult { faces: [f, g], loop_vertex: None, crossings: found, inconsistent: true }),
            }
        }
        1 => {
            let s = shared[0];
            let opposite = |t: [u32; 3]| {
                let k = t.iter().position(|&v| v == s).unwrap_or(0);
                sorted(t[(k + 1) % 3], t[(k + 2) % 3])
            };
            let mut found: [Option<Crossing>; 2] = [None, None];
            let mut n = 0;
            for (tri, other, other_id) in [(fv, gv, g), (gv, fv, f)] {
                let e = opposite(tri);
                if edge_crosses_face(mesh, e, other) {
                    if n < 2 {
                        found[n] = Some(Crossing { edge: e, face: other_id });
                    }
                    n += 1;
                }
            }
            match n {
                0 => None,
                1 => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: false }),
                _ => Some(PairResult { faces: [f, g], loop_vertex: Some(s), crossings: found, inconsistent: true }),
            }
        }
        _ => None,
    }
}

/// Float position data of crossing `(e, f)`: edge parameter and face barycentrics, clamped
/// to their valid ranges (the exact predicates decided that the crossing exists).
pub(super) fn crossing_point(mesh: &TriMesh, e: u32, f: u32) -> IntersectionPoint {
    let [ia, ib] = mesh.topology().edges()[e as usize];
    let pos = mesh.positions();
    let (a, b) = (pos[ia as usize], pos[ib as usize]);
    let [p, q, r] = mesh.triangle(f as usize);
    let t = edge_parameter(a, b, p, q, r);
    let x = a + (b - a) * t;
    IntersectionPoint { edge: e, face: f, t, bary: barycentric(x, p, q, r) }
}

/// Parameter of the crossing of segment `a → b` with the plane of `(p, q, r)`, in `[0, 1]`.
pub fn edge_parameter(a: Vec3, b: Vec3, p: Vec3, q: Vec3, r: Vec3) -> f64 {
    let oa = orient3d_value(p, q, r, a);
    let ob = orient3d_value(p, q, r, b);
    let denom = oa - ob;
    if denom == 0.0 || !denom.is_finite() {
        return 0.5;
    }
    (oa / denom).clamp(0.0, 1.0)
}

/// Barycentric coordinates of `x` (projected on the plane) in `(p, q, r)`, clamped to be
/// non-negative and renormalised; the centroid for a degenerate triangle.
pub fn barycentric(x: Vec3, p: Vec3, q: Vec3, r: Vec3) -> [f64; 3] {
    let n = (q - p).cross(&(r - p));
    let nn = n.norm_squared();
    if nn == 0.0 || !nn.is_finite() {
        return [1.0 / 3.0; 3];
    }
    let b0 = ((q - x).cross(&(r - x))).dot(&n) / nn;
    let b1 = ((r - x).cross(&(p - x))).dot(&n) / nn;
    let b = [b0.max(0.0), b1.max(0.0), (1.0 - b0 - b1).max(0.0)];
    let s = b[0] + b[1] + b[2];
    if s > 0.0 {
        b.map(|v| v / s)
    } else {
        [1.0 / 3.0; 3]
    }
}
