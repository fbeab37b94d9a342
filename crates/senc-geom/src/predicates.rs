//! Exact orientation with symbolic perturbation (Simulation of Simplicity).
//!
//! [`orient3d_sos`] returns the sign of the orientation of four *indexed* points as if every
//! coordinate `p_v[j]` were perturbed by `ε^(2^k(v, j))` for an infinitesimal `ε > 0`, where
//! `k` orders the entries by (vertex index, coordinate). The determinant is then a
//! polynomial in `ε` whose lowest-order nonzero coefficient gives the sign; each coefficient
//! is a minor of the homogeneous 4×4 matrix, evaluated exactly (Shewchuk's `orient3d` and
//! `orient2d` from the `robust` crate, or a coordinate comparison). All predicates of one
//! mesh are therefore evaluated on one consistent, perturbed point set in general position:
//! no exact zero survives, so every edge-face crossing is decided once and paths stay
//! connected on grid-made meshes.
//!
//! Four distinct vertex indices are required (a repeated index makes the determinant vanish
//! identically; callers handle shared vertices combinatorially).

use std::cmp::Ordering;
use std::sync::LazyLock;

use crate::Vec3;

/// Sign of `det[[a,1],[b,1],[c,1],[d,1]]` (= `robust::orient3d(a, b, c, d)`), exact and never
/// zero for four distinct indices. Positive when `d` lies below the plane through `a, b, c`
/// seen with `a, b, c` counterclockwise.
pub fn orient3d_sos(p: [Vec3; 4], idx: [u32; 4]) -> Ordering {
    if let Some(o) = orient3d_filtered(p) {
        return o;
    }
    let det = robust::orient3d(coord3(p[0]), coord3(p[1]), coord3(p[2]), coord3(p[3]));
    if det > 0.0 {
        return Ordering::Greater;
    }
    if det < 0.0 {
        return Ordering::Less;
    }
    perturbed_sign(p, idx)
}

/// The sign of `orient3d` from a plain float evaluation when it is certain: the rounding
/// error of `(a−d) · ((b−d) × (c−d))` is below `c ε |a−d| |b−d| |c−d|` with `c` about 10;
/// a margin of 1e-13 (≈ 450 ε) keeps the filter conservative. Cheaper than the adaptive
/// predicate's own filter (no permanent, no square root).
#[inline]
fn orient3d_filtered(p: [Vec3; 4]) -> Option<Ordering> {
    let (a, b, c) = (p[0] - p[3], p[1] - p[3], p[2] - p[3]);
    let det = a.dot(&b.cross(&c));
    let bound2 = 1e-26 * a.norm_squared() * b.norm_squared() * c.norm_squared();
    if det * det > bound2 && det.is_finite() {
        Some(if det > 0.0 { Ordering::Greater } else { Ordering::Less })
    } else {
        None
    }
}

/// The (approximate) value of `robust::orient3d`, exposed for computing crossing parameters.
pub fn orient3d_value(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f64 {
    robust::orient3d(coord3(a), coord3(b), coord3(c), coord3(d))
}

fn coord3(p: Vec3) -> robust::Coord3D<f64> {
    robust::Coord3D { x: p.x, y: p.y, z: p.z }
}

/// Every partial matching of 4 rows × 3 coordinate columns of size 1 to 3, in increasing
/// order of `Σ 2^(3·rank + col)`, which is the order of increasing power of `ε`.
static TERMS: LazyLock<Vec<Vec<(u8, u8)>>> = LazyLock::new(|| {
    let mut terms = Vec::new();
    for mask in 1u32..(1 << 12) {
        let entries: Vec<(u8, u8)> =
            (0..12).filter(|b| mask & (1 << b) != 0).map(|b| ((b / 3) as u8, (b % 3) as u8)).collect();
        if entries.len() > 3 {
            continue;
        }
        let rows_distinct = entries.iter().enumerate().all(|(i, a)| entries[i + 1..].iter().all(|b| b.0 != a.0));
        let cols_distinct = entries.iter().enumerate().all(|(i, a)| entries[i + 1..].iter().all(|b| b.1 != a.1));
        if rows_distinct && cols_distinct {
            terms.push(entries);
        }
    }
    terms
});

fn perturbed_sign(p: [Vec3; 4], idx: [u32; 4]) -> Ordering {
    // rank[r] = argument position of the r-th smallest index.
    let mut rank = [0usize, 1, 2, 3];
    rank.sort_by_key(|&i| idx[i]);
    for term in TERMS.iter() {
        let s = term_sign(&p, &rank, term);
        if s != 0 {
            return if s > 0 { Ordering::Greater } else { Ordering::Less };
        }
    }
    // Unreachable for distinct indices: size-3 terms are ±1.
    Ordering::Greater
}

/// Sign of the coefficient of one perturbation term: the determinant of the homogeneous
/// matrix (rows in argument order, columns x, y, z, 1) with row `rank[r]` replaced by the unit
/// row `e_c` for each `(r, c)` in the term.
fn term_sign(p: &[Vec3; 4], rank: &[usize; 4], term: &[(u8, u8)]) -> i32 {
    // Rows and columns replaced, in term order; the rest ascending. No allocation: this
    // runs for every exact zero on grid-made meshes.
    let k = term.len();
    let mut row_perm = [0usize; 4];
    let mut col_perm = [0usize; 4];
    let (mut used_rows, mut used_cols) = ([false; 4], [false; 4]);
    for (i, &(r, c)) in term.iter().enumerate() {
        row_perm[i] = rank[r as usize];
        col_perm[i] = c as usize;
        used_rows[row_perm[i]] = true;
        used_cols[col_perm[i]] = true;
    }
    let (mut nr, mut nc) = (k, k);
    for x in 0..4 {
        if !used_rows[x] {
            row_perm[nr] = x;
            nr += 1;
        }
        if !used_cols[x] {
            col_perm[nc] = x;
            nc += 1;
        }
    }
    // det(M') = sgn(row order) · sgn(col order) · det(minor), the unit block moved first.
    let sign = parity(&row_perm) * parity(&col_perm);
    let rest_rows = &row_perm[k..];
    let rest_cols = &col_perm[k..];
    let minor = match rest_rows.len() {
        // Columns left: two coordinates and the ones column: an exact orient2d.
        3 => {
            let (u, v) = (rest_cols[0], rest_cols[1]);
            let q = |r: usize| robust::Coord { x: p[r][u], y: p[r][v] };
            sgn(robust::orient2d(q(rest_rows[0]), q(rest_rows[1]), q(rest_rows[2])))
        }
        // One coordinate and the ones column: det[[a,1],[b,1]] = a - b, exact by comparison.
        2 => {
            let u = rest_cols[0];
            match p[rest_rows[0]][u].partial_cmp(&p[rest_rows[1]][u]) {
                Some(Ordering::Greater) => 1,
                Some(Ordering::Less) => -1,
                _ => 0,
            }
        }
        // Only the ones column.
        _ => 1,
    };
    sign * minor
}

fn sgn(x: f64) -> i32 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

fn parity(perm: &[usize]) -> i32 {
    let mut inversions = 0;
    for i in 0..perm.len() {
        for j in i + 1..perm.len() {
            if perm[i] > perm[j] {
                inversions += 1;
            }
        }
    }
    if inversions % 2 == 0 {
        1
    } else {
        -1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn det4(p: [Vec3; 4]) -> f64 {
        nalgebra::Matrix3::from_columns(&[p[0] - p[3], p[1] - p[3], p[2] - p[3]]).transpose().determinant()
    }

    #[test]
    fn agrees_with_float_determinant_on_generic_points() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..1000 {
            let p: [Vec3; 4] = std::array::from_fn(|_| Vec3::new(rng.random(), rng.random(), rng.random()));
            let d = det4(p);
            if d.abs() > 1e-9 {
                let expect = if d > 0.0 { Ordering::Greater } else { Ordering::Less };
                assert_eq!(orient3d_sos(p, [0, 1, 2, 3]), expect);
            }
        }
    }

    #[test]
    fn degenerate_sign_is_antisymmetric_under_swaps() {
        // Coplanar and even coincident points: the perturbed sign must flip with each swap
        // of two arguments, as a real determinant does.
        let grid = |x: f64, y: f64| Vec3::new(x, y, 0.0);
        let cases = [
            [grid(0., 0.), grid(1., 0.), grid(0., 1.), grid(1., 1.)],
            [grid(0., 0.), grid(1., 0.), grid(2., 0.), grid(3., 0.)],
            [grid(0., 0.), grid(0., 0.), grid(0., 0.), grid(1., 1.)],
            [Vec3::zeros(); 4],
        ];
        let idx = [7u32, 3, 11, 5];
        for p in cases {
            let s = orient3d_sos(p, idx);
            for (i, j) in [(0, 1), (0, 2), (1, 3), (2, 3)] {
                let mut q = p;
                let mut k = idx;
                q.swap(i, j);
                k.swap(i, j);
                assert_eq!(orient3d_sos(q, k), s.reverse(), "swap {i}{j} of {p:?}");
            }
        }
    }

    #[test]
    fn perturbation_matches_a_small_real_perturbation() {
        // Four coplanar points. In SoS order the smallest index's coordinates move by
        // (ε, ε², ε⁴); the first two coefficients vanish here, so the ε⁴ term decides. With
        // ε = 1e-2 the float determinant of the really moved points shows the same sign.
        let p = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(0., 1., 0.), Vec3::new(1., 1., 0.)];
        for perm in [[0u32, 1, 2, 3], [2, 0, 3, 1], [3, 2, 1, 0]] {
            let first = perm.iter().position(|&i| i == 0).unwrap();
            let mut q = p;
            let eps = 1e-2;
            q[first] += Vec3::new(eps, eps * eps, eps.powi(4));
            let d = det4(q);
            assert!(d.abs() > 1e-12, "the ε⁴ term should be visible: {d}");
            let expect = if d > 0.0 { Ordering::Greater } else { Ordering::Less };
            assert_eq!(orient3d_sos(p, perm), expect, "indices {perm:?}");
        }
    }
}
