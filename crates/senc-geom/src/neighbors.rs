//! Spatial neighbour queries on point sets: a uniform hash grid, all pairs closer than a
//! radius, and the nearest target within a radius. Used for self-collision edges, body edges
//! and the repulsive baseline energy.
//!
//! # Behavior
//! - Distances are Euclidean and comparisons strict: a pair at exactly `r` is *not* within
//!   `r`, so `r <= 0` (or NaN) finds nothing.
//! - Points are assumed finite. A point with a NaN coordinate is never reported (every
//!   comparison with NaN is false); infinite coordinates are clamped into the outermost cell
//!   and are likewise never within a finite radius. Nothing here panics on such input.
//! - Comparisons use squared distances, so radii below ~1e-154 m (whose square underflows)
//!   are not supported.
//! - Output is deterministic: it does not depend on the thread count or on hashing order.
//!
//! # Performance
//! The grid has cells of side `r`, so a query visits the 27 cells around its own: linear time
//! in the number of points when the density per cell is bounded (a cloth mesh at a radius of
//! a few edge lengths). A huge `r` relative to the point spread degrades to all pairs,
//! `O(n²)`, which is then also the size of the answer.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::Vec3;

/// Cell coordinates are clamped to ±2⁶² so that neighbouring offsets never overflow `i64`.
const CELL_LIMIT: f64 = 4.611_686_018_427_388e18;

/// A uniform grid of cubic cells of side `cell` over a fixed point set.
///
/// Points are stored sorted by cell (then index), with a hash map (Fx: 27 lookups per query,
/// SipHash's cost showed in profiles) from occupied cell to its slice, so memory is `O(n)` whatever the extent of the points.
#[derive(Debug, Clone)]
pub struct SpatialGrid {
    cell: f64,
    points: Vec<Vec3>,
    /// Point indices grouped by cell, ascending within each cell.
    order: Vec<u32>,
    /// Occupied cell → range in `order`.
    cells: FxHashMap<[i64; 3], (u32, u32)>,
}

impl SpatialGrid {
    /// Bins `points` into cells of side `cell` (metres). A non-positive or non-finite `cell`
    /// puts every point in one cell (every query then scans all points).
    pub fn new(points: &[Vec3], cell: f64) -> Self {
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { f64::INFINITY };
        let mut keyed: Vec<([i64; 3], u32)> =
            points.par_iter().enumerate().map(|(i, p)| (cell_of(p, cell), i as u32)).collect();
        keyed.par_sort_unstable();
        let mut cells = FxHashMap::with_capacity_and_hasher(keyed.len() / 2 + 1, Default::default());
        let mut start = 0usize;
        while start < keyed.len() {
            let key = keyed[start].0;
            let mut end = start + 1;
            while end < keyed.len() && keyed[end].0 == key {
                end += 1;
            }
            cells.insert(key, (start as u32, end as u32));
            start = end;
        }
        let order = keyed.into_iter().map(|(_, i)| i).collect();
        Self { cell, points: points.to_vec(), order, cells }
    }

    /// The cell side, metres (infinite for a single-cell grid).
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// The points the grid was built on.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// Calls `visit(j, squared distance)` for every grid point `j` with `|p_j − q| < r`.
    ///
    /// `r` must not exceed the cell size (points farther than one cell are not visited);
    /// larger `r` is clamped to it. Visit order is unspecified.
    pub fn for_each_within(&self, q: &Vec3, r: f64, mut visit: impl FnMut(u32, f64)) {
        let r = r.min(self.cell);
        if r.is_nan() || r <= 0.0 {
            return;
        }
        let r2 = r * r;
        let c = cell_of(q, self.cell);
        let span: i64 = if self.cell.is_finite() { 1 } else { 0 };
        for dx in -span..=span {
            for dy in -span..=span {
                for dz in -span..=span {
                    let key = [c[0] + dx, c[1] + dy, c[2] + dz];
                    if let Some(&(a, b)) = self.cells.get(&key) {
                        for &j in &self.order[a as usize..b as usize] {
                            let d2 = (self.points[j as usize] - q).norm_squared();
                            if d2 < r2 {
                                visit(j, d2);
                            }
                        }
                    }
                }
            }
        }
    }

    /// The grid point nearest to `q` with distance `< r`, ties to the smaller index, as
    /// `(index, distance)`.
    pub fn nearest(&self, q: &Vec3, r: f64) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        self.for_each_within(q, r, |j, d2| match best {
            Some((bj, bd2)) if bd2 < d2 || (bd2 == d2 && bj < j) => {}
            _ => best = Some((j, d2)),
        });
        best.map(|(j, d2)| (j, d2.sqrt()))
    }
}

fn cell_of(p: &Vec3, cell: f64) -> [i64; 3] {
    if !cell.is_finite() {
        return [0; 3];
    }
    // `as` saturates and maps NaN to 0; the clamp keeps ±1 offsets in range.
    p.map(|x| (x / cell).floor().clamp(-CELL_LIMIT, CELL_LIMIT) as i64).into()
}

/// Every pair `[i, j]`, `i < j`, with `|p_i − p_j| < r`, sorted lexicographically.
///
/// # Example
/// ```
/// use senc_geom::{neighbors::radius_pairs, Vec3};
/// let p = [Vec3::zeros(), Vec3::new(0.5, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0)];
/// assert_eq!(radius_pairs(&p, 1.0), vec![[0, 1]]);
/// ```
pub fn radius_pairs(points: &[Vec3], r: f64) -> Vec<[u32; 2]> {
    if r.is_nan() || r <= 0.0 || points.len() < 2 {
        return Vec::new();
    }
    let grid = SpatialGrid::new(points, r);
    let per_point: Vec<Vec<[u32; 2]>> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let i = i as u32;
            let mut found = Vec::new();
            grid.for_each_within(p, r, |j, _| {
                if j > i {
                    found.push([i, j]);
                }
            });
            found.sort_unstable();
            found
        })
        .collect();
    per_point.concat()
}

/// For each query, the nearest target with distance `< r` as `(target index, distance)`,
/// ties to the smaller target index; `None` when no target is that close.
///
/// # Example
/// ```
/// use senc_geom::{neighbors::nearest_within, Vec3};
/// let targets = [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)];
/// let hits = nearest_within(&[Vec3::new(0.9, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0)], &targets, 0.5);
/// assert_eq!(hits[0].map(|h| h.0), Some(1));
/// assert_eq!(hits[1], None);
/// ```
pub fn nearest_within(queries: &[Vec3], targets: &[Vec3], r: f64) -> Vec<Option<(u32, f64)>> {
    if r.is_nan() || r <= 0.0 || targets.is_empty() {
        return vec![None; queries.len()];
    }
    let grid = SpatialGrid::new(targets, r);
    queries.par_iter().map(|q| grid.nearest(q, r)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_points(seed: u64, n: usize, extent: f64) -> Vec<Vec3> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| Vec3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>()) * extent).collect()
    }

    fn brute_pairs(p: &[Vec3], r: f64) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                if (p[i] - p[j]).norm() < r {
                    out.push([i as u32, j as u32]);
                }
            }
        }
        out
    }

    fn brute_nearest(q: &[Vec3], t: &[Vec3], r: f64) -> Vec<Option<(u32, f64)>> {
        q.iter()
            .map(|q| {
                let mut best: Option<(u32, f64)> = None;
                for (j, t) in t.iter().enumerate() {
                    let d = (t - q).norm();
                    if d < r && best.is_none_or(|(_, bd)| d < bd) {
                        best = Some((j as u32, d));
                    }
                }
                best
            })
            .collect()
    }

    #[test]
    fn radius_pairs_match_brute_force() {
        for (seed, n, r) in [(1, 500, 0.05), (2, 300, 0.2), (3, 50, 2.0), (4, 1000, 0.01), (5, 2, 0.5)] {
            let p = random_points(seed, n, 1.0);
            let got = radius_pairs(&p, r);
            assert_eq!(got, brute_pairs(&p, r), "seed {seed}, n {n}, r {r}");
            assert!(seed == 5 || !got.is_empty() || r < 0.02, "test should find pairs");
        }
        // A lattice around the origin whose points sit exactly on cell faces (spacing r/2,
        // negative coordinates too): every pair of neighbouring cells must be visited once.
        let r = 0.1;
        let p: Vec<Vec3> = (0..7 * 7 * 7)
            .map(|k| Vec3::new((k % 7) as f64, (k / 7 % 7) as f64, (k / 49) as f64) * (r / 2.0) - Vec3::repeat(0.15))
            .collect();
        let got = radius_pairs(&p, r);
        assert_eq!(got, brute_pairs(&p, r));
        assert!(got.len() > 7 * 7 * 7, "{} pairs", got.len());
    }

    #[test]
    fn radius_pairs_edge_cases() {
        let p = random_points(7, 20, 1.0);
        assert!(radius_pairs(&p, 0.0).is_empty());
        assert!(radius_pairs(&p, -1.0).is_empty());
        assert!(radius_pairs(&p, f64::NAN).is_empty());
        assert!(radius_pairs(&[], 1.0).is_empty());
        assert!(radius_pairs(&p[..1], 1.0).is_empty());
        // Infinite radius: every pair.
        assert_eq!(radius_pairs(&p, f64::INFINITY).len(), 20 * 19 / 2);
        // Duplicates are at distance 0 < r.
        let d = vec![Vec3::new(0.3, 0.3, 0.3); 4];
        assert_eq!(radius_pairs(&d, 1e-9), brute_pairs(&d, 1e-9));
        assert_eq!(radius_pairs(&d, 1e-9).len(), 6);
        // Exactly at r is excluded.
        let q = [Vec3::zeros(), Vec3::new(0.25, 0.0, 0.0)];
        assert!(radius_pairs(&q, 0.25).is_empty());
        // Negative coordinates and points on cell boundaries.
        let mut g: Vec<Vec3> = (0..5).map(|i| Vec3::new(-0.1 * i as f64, 0.0, 0.0)).collect();
        g.push(Vec3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(radius_pairs(&g, 0.1 + 1e-12), vec![[0, 1], [1, 2], [2, 3], [3, 4]]);
    }

    #[test]
    fn nearest_within_matches_brute_force() {
        for (seed, nq, nt, r) in [(11, 300, 400, 0.05), (12, 100, 30, 0.3), (13, 50, 1000, 0.02)] {
            let q = random_points(seed, nq, 1.0);
            let t = random_points(seed + 100, nt, 1.0);
            let got = nearest_within(&q, &t, r);
            let want = brute_nearest(&q, &t, r);
            assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g.map(|x| x.0), w.map(|x| x.0));
                if let (Some(g), Some(w)) = (g, w) {
                    assert!((g.1 - w.1).abs() <= 1e-12);
                }
            }
            assert!(got.iter().any(|g| g.is_some()));
        }
    }

    #[test]
    fn nearest_within_edge_cases_and_ties() {
        let t = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)];
        // Equidistant targets 0, 1 and the duplicate 2: ties go to the smallest index.
        assert_eq!(nearest_within(&[Vec3::zeros()], &t, 1.5), vec![Some((0, 1.0))]);
        let t2 = vec![t[1], t[0], t[2]];
        assert_eq!(nearest_within(&[Vec3::zeros()], &t2, 1.5), vec![Some((0, 1.0))]);
        assert_eq!(nearest_within(&[Vec3::zeros()], &t, 0.0), vec![None]);
        assert_eq!(nearest_within(&[Vec3::zeros()], &[], 1.0), vec![None]);
        assert!(nearest_within(&[], &t, 1.0).is_empty());
        assert_eq!(nearest_within(&[Vec3::new(f64::NAN, 0.0, 0.0)], &t, 10.0), vec![None]);
        assert_eq!(nearest_within(&[Vec3::zeros()], &t, f64::INFINITY), vec![Some((0, 1.0))]);
    }

    #[test]
    fn tiny_radius_far_coordinates_do_not_overflow() {
        let p = vec![Vec3::new(1e300, 0.0, 0.0), Vec3::new(1e300, 0.0, 0.0), Vec3::new(-1e300, 1.0, 0.0)];
        assert_eq!(radius_pairs(&p, 1e-3), vec![[0, 1]]);
        assert_eq!(nearest_within(&p[2..], &p, 1e-3), vec![Some((2, 0.0))]);
    }
}
