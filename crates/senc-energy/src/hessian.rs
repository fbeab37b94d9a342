//! A symmetric block-sparse matrix (3×3 blocks, CSR over vertices) for the reference
//! solver's Newton systems, with element assembly, a parallel product, and a
//! block-Jacobi preconditioned conjugate gradient solve.

use nalgebra::{Matrix3, SMatrix, SymmetricEigen};
use rayon::prelude::*;

use senc_geom::Vec3;

/// Block-CSR matrix; the sparsity pattern is fixed at construction.
#[derive(Debug, Clone)]
pub struct BlockSparse {
    offsets: Vec<u32>,
    cols: Vec<u32>,
    blocks: Vec<Matrix3<f64>>,
}

impl BlockSparse {
    /// The pattern holding the diagonal and every pair of vertices sharing an element.
    pub fn with_pattern(n_vertices: usize, elements: impl Iterator<Item = Vec<u32>>) -> Self {
        let mut rows: Vec<Vec<u32>> = (0..n_vertices as u32).map(|v| vec![v]).collect();
        for el in elements {
            for &i in &el {
                for &j in &el {
                    rows[i as usize].push(j);
                }
            }
        }
        let mut offsets = Vec::with_capacity(n_vertices + 1);
        let mut cols = Vec::new();
        offsets.push(0);
        for mut r in rows {
            r.sort_unstable();
            r.dedup();
            cols.extend_from_slice(&r);
            offsets.push(cols.len() as u32);
        }
        let blocks = vec![Matrix3::zeros(); cols.len()];
        Self { offsets, cols, blocks }
    }

    /// Sets every block to zero.
    pub fn clear(&mut self) {
        self.blocks.par_iter_mut().for_each(|b| *b = Matrix3::zeros());
    }

    fn index(&self, i: u32, j: u32) -> Option<usize> {
        let (a, b) = (self.offsets[i as usize] as usize, self.offsets[i as usize + 1] as usize);
        self.cols[a..b].binary_search(&j).ok().map(|k| a + k)
    }

    /// Adds `h[k][l]` to block `(el[k], el[l])`. Pairs outside the pattern are ignored.
    pub fn add_element<const K: usize>(&mut self, el: &[u32; K], h: &[[Matrix3<f64>; K]; K]) {
        for k in 0..K {
            for l in 0..K {
                if let Some(idx) = self.index(el[k], el[l]) {
                    self.blocks[idx] += h[k][l];
                }
            }
        }
    }

    /// Number of stored blocks.
    pub fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Block `(i, j)`, if it is in the pattern.
    pub fn block(&self, i: u32, j: u32) -> Option<&Matrix3<f64>> {
        self.index(i, j).map(|k| &self.blocks[k])
    }

    /// Calls `f(i, cols, blocks)` for every block row `i` in parallel, with the row's column
    /// indices (sorted) and its blocks; each row is written by one task only.
    pub fn par_rows_mut(&mut self, f: impl Fn(usize, &[u32], &mut [Matrix3<f64>]) + Sync) {
        let mut rows: Vec<&mut [Matrix3<f64>]> = Vec::with_capacity(self.offsets.len() - 1);
        let mut rest: &mut [Matrix3<f64>] = &mut self.blocks;
        for w in self.offsets.windows(2) {
            let (row, tail) = rest.split_at_mut((w[1] - w[0]) as usize);
            rows.push(row);
            rest = tail;
        }
        let (offsets, cols) = (&self.offsets, &self.cols);
        rows.into_par_iter().enumerate().with_min_len(64).for_each(|(i, row)| {
            f(i, &cols[offsets[i] as usize..offsets[i + 1] as usize], row);
        });
    }

    /// Adds `m` to diagonal block `i`.
    pub fn add_diagonal(&mut self, i: u32, m: &Matrix3<f64>) {
        if let Some(idx) = self.index(i, i) {
            self.blocks[idx] += m;
        }
    }

    /// `y = A x`.
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let (a, b) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
            let mut s = Vec3::zeros();
            for k in a..b {
                s += self.blocks[k] * x[self.cols[k] as usize];
            }
            *yi = s;
        });
    }

    /// Solves `A x = b` by conjugate gradients with a block-Jacobi preconditioner, from
    /// `x = 0`, to relative residual `tol` or `max_iter` iterations. Returns the iteration
    /// count. `A` must be symmetric positive semi-definite.
    pub fn solve_pcg(&self, b: &[Vec3], x: &mut [Vec3], tol: f64, max_iter: usize) -> usize {
        let n = b.len();
        let precond: Vec<Matrix3<f64>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let d = self.index(i as u32, i as u32).map(|k| self.blocks[k]).unwrap_or_else(Matrix3::identity);
                d.try_inverse().unwrap_or_else(Matrix3::identity)
            })
            .collect();
        x.iter_mut().for_each(|v| *v = Vec3::zeros());
        let mut r = b.to_vec();
        let mut z: Vec<Vec3> = r.iter().zip(&precond).map(|(r, p)| p * r).collect();
        let mut p = z.clone();
        let mut ap = vec![Vec3::zeros(); n];
        let mut rz = dot(&r, &z);
        let b_norm = dot(b, b).sqrt();
        if b_norm == 0.0 {
            return 0;
        }
        for it in 0..max_iter {
            self.mul(&p, &mut ap);
            let pap = dot(&p, &ap);
            if pap.is_nan() || pap <= 0.0 {
                return it;
            }
            let alpha = rz / pap;
            x.par_iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
            r.par_iter_mut().zip(&ap).for_each(|(r, ap)| *r -= alpha * ap);
            if dot(&r, &r).sqrt() <= tol * b_norm {
                return it + 1;
            }
            z.par_iter_mut().zip(&r).zip(&precond).for_each(|((z, r), m)| *z = m * r);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            p.par_iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
        }
        max_iter
    }
}

/// Projects a symmetric 9×9 triangle Hessian that is invariant under translation (every
/// block row sums to zero, as for any energy of the edge vectors only) onto the positive
/// semi-definite cone, with a 6×6 eigen decomposition instead of 9×9.
///
/// Such a matrix maps the translations `1 ⊗ v` to zero, so its eigenvectors are those
/// three (eigenvalue 0, kept by the projection) and six in the orthogonal complement,
/// spanned by `Q = [u1 ⊗ I, u2 ⊗ I]` with `u1 = (1, −1, 0)/√2`, `u2 = (1, 1, −2)/√6`. Hence
/// `P(H) = Q P(QᵀHQ) Qᵀ`: the same result as [`project_spd`] up to rounding, at about a
/// third of the cost. Returns unchanged when `QᵀHQ` is already PSD.
pub fn project_spd_translation_invariant(h: &mut [[Matrix3<f64>; 3]; 3]) {
    let u = [
        [std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2, 0.0],
        [1.0 / 6f64.sqrt(), 1.0 / 6f64.sqrt(), -2.0 / 6f64.sqrt()],
    ];
    let mut m = SMatrix::<f64, 6, 6>::zeros();
    for p in 0..2 {
        for q in 0..2 {
            let mut b = Matrix3::zeros();
            for k in 0..3 {
                for l in 0..3 {
                    let w = u[p][k] * u[q][l];
                    if w != 0.0 {
                        b += h[k][l] * w;
                    }
                }
            }
            m.fixed_view_mut::<3, 3>(3 * p, 3 * q).copy_from(&b);
        }
    }
    // Symmetrise the rounding of the reduction.
    let m = 0.5 * (m + m.transpose());
    let eig = SymmetricEigen::new(m);
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return;
    }
    let v = &eig.eigenvectors;
    let mut scaled = *v;
    for (j, l) in eig.eigenvalues.iter().enumerate() {
        scaled.column_mut(j).scale_mut(l.max(0.0));
    }
    let m = scaled * v.transpose();
    let b = [
        [m.fixed_view::<3, 3>(0, 0).into_owned(), m.fixed_view::<3, 3>(0, 3).into_owned()],
        [m.fixed_view::<3, 3>(3, 0).into_owned(), m.fixed_view::<3, 3>(3, 3).into_owned()],
    ];
    for k in 0..3 {
        for l in 0..3 {
            let mut s = Matrix3::zeros();
            for p in 0..2 {
                for q in 0..2 {
                    let w = u[p][k] * u[q][l];
                    if w != 0.0 {
                        s += b[p][q] * w;
                    }
                }
            }
            h[k][l] = s;
        }
    }
}

/// Projects a symmetric 9×9 matrix given as 3×3 blocks (a triangle's element Hessian) onto
/// the positive semi-definite cone: negative eigenvalues are clamped to zero. Fixed-size
/// (stack) eigen decomposition; the input is returned unchanged when it is already PSD.
pub fn project_spd(h: &mut [[Matrix3<f64>; 3]; 3]) {
    let mut m = SMatrix::<f64, 9, 9>::zeros();
    for k in 0..3 {
        for l in 0..3 {
            m.fixed_view_mut::<3, 3>(3 * k, 3 * l).copy_from(&h[k][l]);
        }
    }
    let eig = SymmetricEigen::new(m);
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return;
    }
    let v = &eig.eigenvectors;
    let mut scaled = *v;
    for (j, l) in eig.eigenvalues.iter().enumerate() {
        let l = l.max(0.0);
        scaled.column_mut(j).scale_mut(l);
    }
    let m = scaled * v.transpose();
    for k in 0..3 {
        for l in 0..3 {
            h[k][l] = m.fixed_view::<3, 3>(3 * k, 3 * l).into_owned();
        }
    }
}

/// Σ aᵢ·bᵢ, in parallel over fixed chunks whose partial sums are added in order, so the
/// result does not depend on how rayon splits the work (a plain parallel `sum` does, and
/// made solves differ in the last bits from run to run, enough to change a short solve).
pub(crate) fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    const CHUNK: usize = 1024;
    let partial: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(a, b)| a.iter().zip(b).map(|(a, b)| a.dot(b)).sum())
        .collect();
    partial.iter().sum()
}
