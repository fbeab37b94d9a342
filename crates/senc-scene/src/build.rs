//! Mesh building steps used by `cargo xtask data` and `cargo xtask fit`: face-subset
//! extraction, linear quad subdivision, skinning-weight transfer from the body and the
//! geometric push-out that moves a garment out of the body.

use std::collections::HashMap;

use rayon::prelude::*;
use senc_geom::Vec3;

use crate::skeleton::SkinWeights;
use senc_geom::BodyQuery;

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

/// Settings of [`push_out`].
#[derive(Debug, Clone, Copy)]
pub struct PushOut {
    /// Clearance every vertex gets from the body surface, m.
    pub margin: f64,
    /// Push / smooth rounds.
    pub rounds: usize,
    /// Laplacian smoothing weight of pushed vertices per round (0..1).
    pub smoothing: f64,
}

impl Default for PushOut {
    /// 5 mm clearance (above the 2 mm collision threshold ε of the body term, so the
    /// first frame starts without body-collision energy), 30 rounds, smoothing 0.5.
    fn default() -> Self {
        Self { margin: 5e-3, rounds: 30, smoothing: 0.5 }
    }
}

/// Moves every garment vertex that is inside the body or closer than `margin` to its
/// surface out along the surface normal (from the closest point), then smooths the moved
/// region so the garment does not crease; repeats, and ends with a pure push so that on
/// return no vertex is inside. Returns the number of vertices moved in the first round.
pub fn push_out(positions: &mut [Vec3], faces: &[[u32; 3]], body: &BodyQuery, cfg: PushOut) -> usize {
    let n = positions.len();
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); n];
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            if !nbrs[a as usize].contains(&b) {
                nbrs[a as usize].push(b);
            }
            if !nbrs[b as usize].contains(&a) {
                nbrs[b as usize].push(a);
            }
        }
    }
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
    let mut first = 0;
    for round in 0..cfg.rounds {
        let moved = push(positions);
        let count = moved.iter().filter(|&&m| m).count();
        if round == 0 {
            first = count;
        }
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
    first
}
