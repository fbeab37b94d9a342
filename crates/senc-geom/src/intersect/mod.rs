//! Self-intersection of a triangle mesh: a BVH broad phase over triangle boxes (our own
//! flat tree with leaves of a few faces, self traversal, refit when only positions change)
//! and an exact narrow phase of edge-versus-face crossings decided by
//! [`crate::predicates::orient3d_sos`], behind conservative float filters.
//!
//! # Performance
//! Each face pair whose boxes overlap is filtered where the traversal finds it, with no pair
//! list: faces sharing an edge, or one vertex whose ring is embedded (see
//! [`embedded_rings`]), are dropped by comparing vertex ids; the rest take the sides of each
//! face's vertices against the other face's float plane (exact predicate only when the float
//! value is within its rounding bound) and reuse them for the edge tests. Before that, a
//! node whose faces form a topological disk with all normals in a cone narrower than a
//! hemisphere and whose boundary projects to a simple curve is skipped whole: such a patch
//! cannot cross itself (see [`Traversal::patch_is_embedded`]).
//!
//! # Behavior
//! - Triangles sharing an edge are skipped (in the perturbed general position they meet only
//!   along that edge).
//! - Triangles sharing one vertex `s` can only cross through an edge opposite `s`; such a
//!   crossing gives one point and a segment ending at the **loop vertex** `s`.
//! - Other pairs give zero or two crossings, the two ends of one segment.
//! - Each crossing is an [`IntersectionPoint`] `(edge, face)`, reported once although both
//!   faces of the edge find it; it is the shared end of their two segments.
//! - Output is sorted (points by `(edge, face)`, segments by face pair) and so does not
//!   depend on the thread count or on whether the BVH was refit or rebuilt.

use std::cmp::Ordering;
use std::sync::atomic::{AtomicU8, Ordering as AtomicOrdering};
use std::sync::{Arc, OnceLock};

use rayon::prelude::*;
use wide::{f32x4, i32x4, CmpEq, CmpLe};

use crate::mesh::TriMesh;
use crate::predicates::{orient3d_sos, orient3d_value};
use crate::topology::{Topology, NO_FACE};
use crate::Vec3;

/// A crossing of mesh edge `edge` through the interior of face `face`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntersectionPoint {
    /// Edge index (see [`crate::Topology::edges`]).
    pub edge: u32,
    /// Face index.
    pub face: u32,
    /// Parameter along the edge from `edges[edge][0]` (t = 0) to `edges[edge][1]` (t = 1).
    pub t: f64,
    /// Barycentric coordinates in `face`, weights of `faces[face][0..3]`.
    pub bary: [f64; 3],
}

/// One end of an intersection segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SegmentEnd {
    /// An intersection point (index into [`SelfIntersections::points`]).
    Point(u32),
    /// A loop vertex: the vertex shared by the two faces.
    LoopVertex(u32),
}

/// The intersection of two faces: a segment lying on both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// The two faces, smaller index first.
    pub faces: [u32; 2],
    /// Its two ends. A loop vertex, if any, comes first.
    pub ends: [SegmentEnd; 2],
}

/// All crossings of a mesh with itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SelfIntersections {
    /// Crossing points, sorted by `(edge, face)`.
    pub points: Vec<IntersectionPoint>,
    /// Face-pair segments, sorted by `faces`.
    pub segments: Vec<Segment>,
    /// Candidate pairs the broad phase passed to the narrow phase.
    pub n_candidate_pairs: usize,
    /// Pairs whose crossing count was not 0 or 2 (0 expected: exact predicates make this
    /// impossible; counted rather than asserted).
    pub n_inconsistent_pairs: usize,
}

impl SelfIntersections {
    /// Sorted, deduplicated intersecting face pairs.
    pub fn face_pairs(&self) -> Vec<[u32; 2]> {
        let mut v: Vec<[u32; 2]> = self.segments.iter().map(|s| s.faces).collect();
        v.dedup();
        v
    }

    /// 3D position of point `i` on `mesh` (from its edge parameter).
    pub fn point_position(&self, mesh: &TriMesh, i: usize) -> Vec3 {
        let p = &self.points[i];
        let [a, b] = mesh.topology().edges()[p.edge as usize];
        let (a, b) = (mesh.positions()[a as usize], mesh.positions()[b as usize]);
        a + (b - a) * p.t
    }
}

mod bvh;
mod pair;
mod patches;
mod ray;
mod rings;
#[cfg(test)]
mod tests;
mod traversal;

pub(crate) use bvh::SearchSlot;
pub use bvh::SelfIntersector;
pub use pair::{barycentric, edge_parameter};
pub use ray::{ray_winding_brute, AxisRay};
pub use rings::embedded_rings;

use bvh::*;
use pair::*;
use patches::*;
use rings::*;
use traversal::*;

/// One-shot self-intersection (builds a BVH; use [`SelfIntersector`] across frames).
pub fn self_intersections(mesh: &TriMesh) -> SelfIntersections {
    SelfIntersector::new(mesh).find(mesh)
}
