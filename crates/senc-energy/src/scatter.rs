//! Deterministic parallel accumulation of per-element gradients into per-vertex gradients:
//! a CSR map from each vertex to the slots (element corners) of a flat per-element buffer
//! that touch it, so each vertex sums its own slots in a fixed order (no scatter races, no
//! per-thread buffers to merge).

use rayon::prelude::*;

use senc_geom::Vec3;

/// Elements per parallel task in the element passes (fixed, so that energy sums are
/// reduced in the same order on every run and thread count).
pub(crate) const ELEMENT_CHUNK: usize = 512;
/// Vertices per parallel task in the vertex passes.
pub(crate) const VERTEX_CHUNK: usize = 1024;

/// Sums per-chunk partial energies in chunk order (deterministic).
pub(crate) fn ordered_sum(partials: Vec<f64>) -> f64 {
    partials.iter().sum()
}

pub use senc_geom::gather::Gather;

/// Vertex → element-corner map for elements of `K` vertices.
#[derive(Debug, Clone)]
pub struct Scatter<const K: usize> {
    gather: Gather,
}

impl<const K: usize> Scatter<K> {
    /// Builds the map for `elements` over `n_vertices` vertices.
    pub fn new(n_vertices: usize, elements: &[[u32; K]]) -> Self {
        Self { gather: Gather::new(n_vertices, elements.as_flattened()) }
    }

    /// Adds `scale × per_element[e][k]` to `grad[v]` for every corner `k` of element `e`
    /// at vertex `v`; parallel over vertices, summation order fixed.
    pub fn add_to(&self, per_element: &[[Vec3; K]], scale: f64, grad: &mut [Vec3]) {
        self.add_flat(per_element.as_flattened(), scale, grad);
    }

    /// As [`Scatter::add_to`] with the per-element gradients flattened (`K` per element).
    pub fn add_flat(&self, per_slot: &[Vec3], scale: f64, grad: &mut [Vec3]) {
        grad.par_iter_mut().enumerate().with_min_len(256).for_each(|(v, g)| {
            *g += self.gather.sum(v, per_slot) * scale;
        });
    }
}
