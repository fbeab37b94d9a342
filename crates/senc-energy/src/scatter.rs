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

/// Vertex → slot map over a flat buffer of per-slot gradients.
#[derive(Debug, Clone)]
pub struct Gather {
    offsets: Vec<u32>,
    slots: Vec<u32>,
}

impl Gather {
    /// Builds the map from the vertex of every slot, in buffer order (`slot_vertex[s]` is the
    /// vertex that slot `s` belongs to).
    pub fn new(n_vertices: usize, slot_vertex: &[u32]) -> Self {
        let mut offsets = vec![0u32; n_vertices + 1];
        for &v in slot_vertex {
            offsets[v as usize + 1] += 1;
        }
        for v in 0..n_vertices {
            offsets[v + 1] += offsets[v];
        }
        let mut fill = offsets.clone();
        let mut slots = vec![0u32; slot_vertex.len()];
        for (s, &v) in slot_vertex.iter().enumerate() {
            slots[fill[v as usize] as usize] = s as u32;
            fill[v as usize] += 1;
        }
        Self { offsets, slots }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Number of slots.
    pub fn n_slots(&self) -> usize {
        self.slots.len()
    }

    /// The slots of vertex `v`, in increasing order.
    #[inline]
    pub fn slots(&self, v: usize) -> &[u32] {
        &self.slots[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// `Σ_{s ∈ slots(v)} buf[s]`, in slot order.
    #[inline]
    pub fn sum(&self, v: usize, buf: &[Vec3]) -> Vec3 {
        let mut sum = Vec3::zeros();
        for &s in self.slots(v) {
            sum += buf[s as usize];
        }
        sum
    }
}

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
