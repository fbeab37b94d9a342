//! Deterministic parallel accumulation of per-element gradients into per-vertex gradients:
//! a CSR map from each vertex to the (element, corner) slots that touch it.

use rayon::prelude::*;

use senc_geom::Vec3;

/// Vertex → element-corner map for elements of `K` vertices.
#[derive(Debug, Clone)]
pub struct Scatter<const K: usize> {
    offsets: Vec<u32>,
    /// `element * K + corner`.
    slots: Vec<u32>,
}

impl<const K: usize> Scatter<K> {
    /// Builds the map for `elements` over `n_vertices` vertices.
    pub fn new(n_vertices: usize, elements: &[[u32; K]]) -> Self {
        let mut offsets = vec![0u32; n_vertices + 1];
        for el in elements {
            for &v in el {
                offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..n_vertices {
            offsets[v + 1] += offsets[v];
        }
        let mut fill = offsets.clone();
        let mut slots = vec![0u32; elements.len() * K];
        for (e, el) in elements.iter().enumerate() {
            for (k, &v) in el.iter().enumerate() {
                slots[fill[v as usize] as usize] = (e * K + k) as u32;
                fill[v as usize] += 1;
            }
        }
        Self { offsets, slots }
    }

    /// Adds `scale × per_element[e][k]` to `grad[v]` for every corner `k` of element `e`
    /// at vertex `v`; parallel over vertices, summation order fixed.
    pub fn add_to(&self, per_element: &[[Vec3; K]], scale: f64, grad: &mut [Vec3]) {
        grad.par_iter_mut().enumerate().for_each(|(v, g)| {
            let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
            let mut sum = Vec3::zeros();
            for &s in &self.slots[a..b] {
                let s = s as usize;
                sum += per_element[s / K][s % K];
            }
            *g += sum * scale;
        });
    }
}
