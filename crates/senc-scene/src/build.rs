//! Mesh building steps used by `cargo xtask data` and `cargo xtask fit`: face-subset
//! extraction, linear quad subdivision, skinning-weight transfer from the body and the
//! geometric push-out that moves a garment out of the body.

use std::collections::HashMap;

use rayon::prelude::*;
use senc_geom::{vertex_normals, BodyQuery, Vec3};

use crate::skeleton::SkinWeights;

/// Per-vertex weight lists, the editable form of [`SkinWeights`].
pub type WeightLists = Vec<Vec<(u16, f32)>>;

/// Keeps the polygons for which `keep` is true and the vertices they use, renumbered in
/// first-use order. Returns the new positions, polygons and, per new vertex, its old index.
pub fn extract(
    positions: &[Vec3],
    polys: &[Vec<u32>],
    keep: impl Fn(usize) -> bool,
) -> (Vec<Vec3>, Vec<Vec<u32>>, Vec<u32>) {
    let mut map: HashMap<u32, u32> = HashMap::new();
    let mut old = Vec::new();
    let mut out = Vec::new();
    for (f, poly) in polys.iter().enumerate() {
        if !keep(f) {
            continue;
        }
        out.push(
            poly.iter()
                .map(|&v| {
                    *map.entry(v).or_insert_with(|| {
                        old.push(v);
                        (old.len() - 1) as u32
                    })
                })
                .collect(),
        );
    }
    (old.iter().map(|&v| positions[v as usize]).collect(), out, old)
}

/// One step of linear subdivision of a quad mesh: every quad becomes four, with new
/// vertices at edge midpoints and face centres. Weight lists are averaged the same way
/// (so the garment keeps its skinning). Returns positions, quads and weights.
pub fn subdivide_quads(
    positions: &[Vec3],
    quads: &[[u32; 4]],
    weights: &WeightLists,
) -> (Vec<Vec3>, Vec<[u32; 4]>, WeightLists) {
    let mut pos = positions.to_vec();
    let mut w = weights.clone();
    let mut edge_mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut out = Vec::with_capacity(quads.len() * 4);
    let avg = |ids: &[u32], w: &WeightLists| -> Vec<(u16, f32)> {
        let mut acc: Vec<(u16, f32)> = Vec::new();
        for &i in ids {
            for &(b, x) in &w[i as usize] {
                match acc.iter_mut().find(|(c, _)| *c == b) {
                    Some(e) => e.1 += x / ids.len() as f32,
                    None => acc.push((b, x / ids.len() as f32)),
                }
            }
        }
        acc
    };
    for q in quads {
        let mut mids = [0u32; 4];
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            let key = (a.min(b), a.max(b));
            mids[k] = *edge_mid.entry(key).or_insert_with(|| {
                pos.push((pos[a as usize] + pos[b as usize]) * 0.5);
                let nw = avg(&[a, b], &w);
                w.push(nw);
                (pos.len() - 1) as u32
            });
        }
        let c = q.iter().fold(Vec3::zeros(), |s, &i| s + pos[i as usize]) * 0.25;
        pos.push(c);
        let nw = avg(q, &w);
        w.push(nw);
        let ci = (pos.len() - 1) as u32;
        for k in 0..4 {
            out.push([q[k], mids[k], ci, mids[(k + 3) % 4]]);
        }
    }
    (pos, out, w)
}

/// Splits polygons into triangles (fans), keeping their winding.
pub fn triangulate(polys: &[Vec<u32>]) -> Vec<[u32; 3]> {
    polys.iter().flat_map(|p| (1..p.len() - 1).map(move |k| [p[0], p[k], p[k + 1]])).collect()
}

/// Skinning weights for arbitrary points from the `k` nearest body vertices, blended with
/// inverse-distance weights `1 / (d + 1 mm)` (brute force, parallel).
pub fn transfer_weights(points: &[Vec3], body: &[Vec3], body_weights: &SkinWeights, k: usize) -> WeightLists {
    points
        .par_iter()
        .map(|p| {
            let mut best: Vec<(f64, usize)> = Vec::with_capacity(k + 1);
            for (i, b) in body.iter().enumerate() {
                let d = (b - p).norm_squared();
                if best.len() < k || d < best[best.len() - 1].0 {
                    let at = best.partition_point(|x| x.0 < d);
                    best.insert(at, (d, i));
                    best.truncate(k);
                }
            }
            let mut acc: Vec<(u16, f32)> = Vec::new();
            for (d, i) in best {
                let s = 1.0 / (d.sqrt() + 1e-3);
                for (b, w) in body_weights.of(i) {
                    let x = (s * w) as f32;
                    match acc.iter_mut().find(|(c, _)| *c as usize == b) {
                        Some(e) => e.1 += x,
                        None => acc.push((b as u16, x)),
                    }
                }
            }
            acc
        })
        .collect()
}

/// The number of points of a garment's faces inside the body, sampled at each face's
/// centroid and its edges' quarter points: a garment whose vertices all lie outside the body
/// can still cut through it with its faces (a long face across the top of a shoulder).
pub fn face_points_inside(positions: &[Vec3], faces: &[[u32; 3]], body: &BodyQuery) -> usize {
    faces
        .par_iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| positions[i as usize]);
            let edges = [(a, b), (b, c), (c, a)];
            let points = edges.iter().flat_map(|&(p, q)| [0.25, 0.5, 0.75].map(|t| p * (1.0 - t) + q * t));
            std::iter::once((a + b + c) / 3.0).chain(points).filter(|p| body.closest(p).inside).count()
        })
        .sum()
}

/// Settings of [`push_out`].
#[derive(Debug, Clone, Copy)]
pub struct PushOut {
    /// Clearance every vertex gets from the body surface, m.
    pub margin: f64,
    /// Push / smooth rounds.
    pub rounds: usize,
    /// Laplacian smoothing weight of pushed vertices per round (0..1).
    pub smoothing: f64,
    /// Rings of outside vertices that a vertex pushed along its normal drags along.
    pub drag_rings: usize,
    /// Share of a ring's displacement that the next ring out takes (0..1).
    pub drag: f64,
}

impl Default for PushOut {
    /// 5 mm clearance (above the 2 mm collision threshold ε of the body term, so the
    /// first frame starts without body-collision energy), 30 rounds, smoothing 0.5; vertices
    /// pushed along their normals drag 8 rings, each taking 0.8 of the last.
    fn default() -> Self {
        Self { margin: 5e-3, rounds: 30, smoothing: 0.5, drag_rings: 8, drag: 0.8 }
    }
}

/// The least cosine between a vertex's normal and the way out to the closest surface point
/// at which [`push_out`] takes that short way (60°).
const NEAREST_AGREES: f64 = 0.5;

/// How far `p` must move along the unit direction `dir` to lie `margin` outside the body,
/// by sphere tracing; `None` where the line does not get there within 0.5 m (a normal that
/// runs along the inside of the body).
fn exit_distance(body: &BodyQuery, p: &Vec3, dir: &Vec3, margin: f64) -> Option<f64> {
    const REACH: f64 = 0.5;
    const MIN_STEP: f64 = 2e-4;
    let mut t = 0.0;
    for _ in 0..256 {
        let c = body.closest(&(p + dir * t));
        if c.signed_distance >= margin {
            return Some(t);
        }
        t += (margin - c.signed_distance).max(MIN_STEP);
        if t > REACH {
            return None;
        }
    }
    None
}

/// A garment's faces with each vertex's neighbours and the faces around it.
#[derive(Clone, Copy)]
struct Star<'a> {
    faces: &'a [[u32; 3]],
    nbrs: &'a [Vec<u32>],
    stars: &'a [Vec<u32>],
}

/// The normal-led push of [`push_out`]. Each vertex that is inside the body, or one of whose
/// edges or faces runs through it, takes the deepest such point of its star. Where the
/// closest surface point of that point lies within 60° of the vertex's outward normal
/// (faces oriented outwards, as [`crate::fit::orient_outward`] leaves them) and less than
/// `margin` away, the vertex moves the short way, to `margin` beyond that surface point.
/// Otherwise it moves along its own normal, to `margin` beyond where that line leaves the
/// body (found by sphere tracing: inside, the distance to the surface is a step that cannot
/// overshoot it), and drags the outside vertices around it along, fading by
/// [`PushOut::drag`] per ring over [`PushOut::drag_rings`] rings, so the moved region does
/// not tear away from its neighbourhood. Repeated (at most `cfg.rounds` times) until no
/// vertex, edge or face is inside.
fn push_along_normals(positions: &mut [Vec3], mesh: &Star<'_>, body: &BodyQuery, cfg: &PushOut) {
    let Star { faces, nbrs, stars } = *mesh;
    for _ in 0..cfg.rounds {
        let normals = vertex_normals(positions, faces);
        // The deepest point of each vertex's star that is inside the body: the vertex itself,
        // a quarter point of one of its edges or the centroid of one of its faces (a face can
        // cross the body between outside vertices, at a corner such as the top of a shoulder).
        let pos: &[Vec3] = positions;
        let need: Vec<Option<(Vec3, bool)>> = (0..pos.len())
            .into_par_iter()
            .map(|i| {
                let p = pos[i];
                let mut deepest: Option<(Vec3, f64, Vec3)> = None;
                let mut consider = |q: Vec3| {
                    let c = body.closest(&q);
                    if c.inside && deepest.is_none_or(|(_, d, _)| c.signed_distance < d) {
                        deepest = Some((q, c.signed_distance, c.point));
                    }
                };
                consider(p);
                for &j in &nbrs[i] {
                    let q = pos[j as usize];
                    for t in [0.25, 0.5, 0.75] {
                        consider(p * (1.0 - t) + q * t);
                    }
                }
                for &f in &stars[i] {
                    consider(faces[f as usize].iter().fold(Vec3::zeros(), |s, &v| s + pos[v as usize]) / 3.0);
                }
                let (q, depth, at) = deepest?;
                let out = (at - q).try_normalize(1e-300).unwrap_or_else(Vec3::zeros);
                let nearest = at - q + out * cfg.margin;
                let nrm = normals[i];
                if -depth < cfg.margin && nrm.dot(&out) >= NEAREST_AGREES {
                    // The closest surface point lies ahead of the normal: the short way is
                    // the right one, and nothing else need follow.
                    return Some((nearest, false));
                }
                if nrm == Vec3::zeros() {
                    // All faces around the vertex degenerate: no normal to follow.
                    return Some((nearest, false));
                }
                Some(match exit_distance(body, &q, &nrm, cfg.margin) {
                    Some(t) => (nrm * t, true),
                    // No way out along the normal: to the closest surface point instead.
                    None => (nearest, false),
                })
            })
            .collect();
        if need.iter().all(Option::is_none) {
            return;
        }
        // Spread the displacements ring by ring over the vertices not pushed themselves:
        // each takes `drag` times the mean of its displaced neighbours from the ring before.
        let mut disp: Vec<Vec3> = need.iter().map(|d| d.map_or_else(Vec3::zeros, |(d, _)| d)).collect();
        let mut reached: Vec<bool> = need.iter().map(Option::is_some).collect();
        // Only the pushes along a normal drag their neighbourhood: a vertex moved the short
        // way to the closest surface point moves about as far as the closest-point push would.
        let mut drags: Vec<bool> = need.iter().map(|d| d.is_some_and(|(_, n)| n)).collect();
        for _ in 0..cfg.drag_rings {
            let next: Vec<Option<Vec3>> = (0..positions.len())
                .into_par_iter()
                .map(|i| {
                    if reached[i] {
                        return None;
                    }
                    let (sum, count) = nbrs[i]
                        .iter()
                        .filter(|&&j| drags[j as usize])
                        .fold((Vec3::zeros(), 0usize), |(s, k), &j| (s + disp[j as usize], k + 1));
                    (count > 0).then(|| sum * (cfg.drag / count as f64))
                })
                .collect();
            let mut grew = false;
            for (i, d) in next.into_iter().enumerate() {
                if let Some(d) = d {
                    disp[i] = d;
                    reached[i] = true;
                    drags[i] = true;
                    grew = true;
                }
            }
            if !grew {
                break;
            }
        }
        for (p, d) in positions.iter_mut().zip(&disp) {
            *p += d;
        }
    }
}

/// Moves the garment out of the body. Returns the number of vertices the first round of the
/// closest-point push moved (those inside the body or closer than `margin` to it on entry).
///
/// First by the closest surface points: every vertex closer than `margin` (inside or not)
/// moves to `margin` from its closest surface point, along the surface normal there, and the
/// moved region is smoothed so the garment does not crease; repeated, ending with a pure
/// push so that no vertex is inside ([`push_nearest`]). Where that leaves faces through the
/// body ([`face_points_inside`]), the closest point was the wrong way somewhere: a garment
/// fitted too low on a shoulder has vertices nearer the side of the arm than its top, and
/// pushed sideways they leave faces spanning the shoulder, every vertex outside. Then the
/// push is also made led by the garment's normals ([`push_along_normals`], then the closest
/// points for the clearance, then the normals again, since the smoothing can pull an edge
/// back across a corner), and of the two results the one with fewer vertices inside, then
/// fewer face points inside, is kept (the first on a tie). The normals are the wrong way in
/// a fold of the body (the crotch, an armpit) where the closest point is right, so neither
/// push serves every garment.
pub fn push_out(positions: &mut [Vec3], faces: &[[u32; 3]], body: &BodyQuery, cfg: PushOut) -> usize {
    let n = positions.len();
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut stars: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            if !nbrs[a as usize].contains(&b) {
                nbrs[a as usize].push(b);
            }
            if !nbrs[b as usize].contains(&a) {
                nbrs[b as usize].push(a);
            }
            stars[a as usize].push(fi as u32);
        }
    }
    let start = positions.to_vec();
    let first = push_nearest(positions, &nbrs, body, &cfg);
    let through = face_points_inside(positions, faces, body);
    if through > 0 {
        let mesh = Star { faces, nbrs: &nbrs, stars: &stars };
        let mut led = start;
        push_along_normals(&mut led, &mesh, body, &cfg);
        push_nearest(&mut led, &nbrs, body, &cfg);
        push_along_normals(&mut led, &mesh, body, &cfg);
        let score = |p: &[Vec3]| (body.inside(p).len(), face_points_inside(p, faces, body));
        if score(&led) < (body.inside(positions).len(), through) {
            positions.copy_from_slice(&led);
        }
    }
    first
}

/// The closest-point push of [`push_out`]: `cfg.rounds` rounds of pushing every vertex closer
/// than `margin` out to `margin` from its closest surface point and smoothing the moved region
/// and its neighbours, then up to five rounds of pure pushes. Returns the number of vertices
/// the first round moved.
fn push_nearest(positions: &mut [Vec3], nbrs: &[Vec<u32>], body: &BodyQuery, cfg: &PushOut) -> usize {
    let n = positions.len();
    let push = |positions: &mut [Vec3]| -> Vec<bool> {
        let moved: Vec<Option<Vec3>> = positions
            .par_iter()
            .map(|p| {
                let c = body.closest(p);
                if c.signed_distance >= 0.99 * cfg.margin {
                    return None;
                }
                let d = p - c.point;
                let dir = if d.norm() < 1e-12 {
                    return None;
                } else if c.inside {
                    -d / d.norm()
                } else {
                    d / d.norm()
                };
                Some(c.point + dir * cfg.margin)
            })
            .collect();
        moved
            .into_iter()
            .zip(positions.iter_mut())
            .map(|(m, p)| {
                if let Some(q) = m {
                    *p = q;
                    true
                } else {
                    false
                }
            })
            .collect()
    };
    let mut first = None;
    for _ in 0..cfg.rounds {
        let moved = push(positions);
        let count = moved.iter().filter(|&&m| m).count();
        first.get_or_insert(count);
        if count == 0 {
            break;
        }
        // Smooth the moved vertices and their neighbours towards their neighbours' mean.
        let mut region = moved.clone();
        for (i, m) in moved.iter().enumerate() {
            if *m {
                for &j in &nbrs[i] {
                    region[j as usize] = true;
                }
            }
        }
        let snapshot = positions.to_vec();
        for i in 0..n {
            if region[i] && !nbrs[i].is_empty() {
                let mean = nbrs[i].iter().fold(Vec3::zeros(), |s, &j| s + snapshot[j as usize]) / nbrs[i].len() as f64;
                positions[i] = snapshot[i] * (1.0 - cfg.smoothing) + mean * cfg.smoothing;
            }
        }
    }
    for _ in 0..5 {
        if !push(positions).iter().any(|&m| m) {
            break;
        }
    }
    first.unwrap_or(0)
}
