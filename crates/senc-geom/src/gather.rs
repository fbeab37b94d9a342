//! Grouping the slots of a flat buffer by the item (vertex, node) each slot belongs to: a
//! CSR index built by one counting pass, so that each item can sum its own slots in a fixed
//! order, in parallel over items, with no write conflicts and a result independent of the
//! thread count. Used for per-element gradients (senc-energy) and for message sums per
//! receiving node (senc-model's fused network).

use crate::Vec3;

/// Item → slot map over a flat buffer (items are called vertices below).
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_grouped_by_vertex_in_buffer_order() {
        let g = Gather::new(4, &[2, 0, 2, 3, 0, 2]);
        assert_eq!((g.n_vertices(), g.n_slots()), (4, 6));
        assert_eq!(g.slots(0), &[1, 4]);
        assert!(g.slots(1).is_empty());
        assert_eq!(g.slots(2), &[0, 2, 5]);
        assert_eq!(g.slots(3), &[3]);
        let buf: Vec<Vec3> = (0..6).map(|s| Vec3::new(s as f64, 0.0, 1.0)).collect();
        assert_eq!(g.sum(2, &buf), Vec3::new(7.0, 0.0, 3.0));
    }
}
