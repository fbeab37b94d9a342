//! The validated triangle mesh: f64 positions, u32 faces, and its topology.

use std::sync::Arc;

use crate::error::MeshError;
use crate::topology::Topology;
use crate::Vec3;

/// Relative threshold under which a face counts as zero-area at construction:
/// `|e1 × e2| <= ZERO_AREA_REL * max(|e|²)` (twice the area against the longest edge squared).
/// 1e-14 only catches collinear or coincident vertices up to rounding, never thin but real
/// triangles.
pub const ZERO_AREA_REL: f64 = 1e-14;

/// Unit area-weighted vertex normals of `positions` under `faces` (each face adds
/// `(p1 - p0) × (p2 - p0)` to its three vertices); zero for a vertex whose faces are all
/// degenerate.
pub fn vertex_normals(positions: &[Vec3], faces: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::zeros(); positions.len()];
    for f in faces {
        let [a, b, c] = f.map(|i| i as usize);
        let w = (positions[b] - positions[a]).cross(&(positions[c] - positions[a]));
        n[a] += w;
        n[b] += w;
        n[c] += w;
    }
    for v in &mut n {
        let len = v.norm();
        *v = if len > 0.0 && len.is_finite() { *v / len } else { Vec3::zeros() };
    }
    n
}

/// A manifold, consistently oriented triangle mesh.
///
/// # Invariants
/// - every coordinate is finite;
/// - every face has three distinct, in-range indices;
/// - at construction every face has non-zero area (later position updates through
///   [`TriMesh::set_positions`] only re-check finiteness: a simulated garment may pass
///   through a degenerate configuration, and downstream code must cope with it);
/// - every edge has one or two faces, traversed in opposite directions.
///
/// The topology is shared (`Arc`) between copies that only differ in positions.
#[derive(Debug, Clone)]
pub struct TriMesh {
    positions: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    topology: Arc<Topology>,
}

impl TriMesh {
    /// Validates and builds a mesh. Errors name the first offending element.
    pub fn new(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        if faces.is_empty() {
            return Err(MeshError::Empty);
        }
        check_finite(&positions)?;
        let n = positions.len();
        for (f, face) in faces.iter().enumerate() {
            for &i in face {
                if i as usize >= n {
                    return Err(MeshError::IndexOutOfRange { face: f, index: i, n_vertices: n });
                }
            }
            if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
                return Err(MeshError::RepeatedIndex { face: f, indices: *face });
            }
            let [a, b, c] = face.map(|i| positions[i as usize]);
            let (e0, e1, e2) = (b - a, c - a, c - b);
            let longest = e0.norm_squared().max(e1.norm_squared()).max(e2.norm_squared());
            if e0.cross(&e1).norm() <= ZERO_AREA_REL * longest {
                return Err(MeshError::ZeroAreaFace { face: f, indices: *face });
            }
        }
        let topology = Arc::new(Topology::new(&faces, n)?);
        Ok(Self { positions, faces, topology })
    }

    /// A mesh with the same faces and topology and new positions (no re-validation of
    /// areas; finiteness and count are checked).
    pub fn with_positions(&self, positions: Vec<Vec3>) -> Result<Self, MeshError> {
        let mut m = self.clone();
        m.set_positions(positions)?;
        Ok(m)
    }

    /// Replaces the positions, keeping faces and topology.
    pub fn set_positions(&mut self, positions: Vec<Vec3>) -> Result<(), MeshError> {
        if positions.len() != self.positions.len() {
            return Err(MeshError::PositionCount { expected: self.positions.len(), got: positions.len() });
        }
        check_finite(&positions)?;
        self.positions = positions;
        Ok(())
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Faces, counter-clockwise around their normal.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }

    /// Connectivity.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Shared handle to the connectivity.
    pub fn topology_arc(&self) -> Arc<Topology> {
        Arc::clone(&self.topology)
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// The three corner positions of face `f`.
    #[inline]
    pub fn triangle(&self, f: usize) -> [Vec3; 3] {
        self.faces[f].map(|i| self.positions[i as usize])
    }

    /// Unnormalised normal `(p1 - p0) × (p2 - p0)` of face `f` (twice its area in length).
    #[inline]
    pub fn face_normal_scaled(&self, f: usize) -> Vec3 {
        let [a, b, c] = self.triangle(f);
        (b - a).cross(&(c - a))
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        self.area_at(&self.positions)
    }

    /// Total area of the faces with their vertices placed at `positions` (one per vertex,
    /// e.g. a simulated state of the mesh).
    pub fn area_at(&self, positions: &[Vec3]) -> f64 {
        debug_assert_eq!(positions.len(), self.positions.len());
        self.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| positions[i as usize]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum()
    }

    /// Signed volume `Σ p0 · (p1 × p2) / 6` (the enclosed volume for a closed, outward
    /// oriented mesh).
    pub fn signed_volume(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| self.positions[i as usize]);
                a.dot(&b.cross(&c))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Length of the axis-aligned bounding box diagonal (0 for a single point).
    pub fn bounding_diagonal(&self) -> f64 {
        let mut lo = Vec3::repeat(f64::INFINITY);
        let mut hi = Vec3::repeat(f64::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (hi - lo).norm()
    }
}

fn check_finite(positions: &[Vec3]) -> Result<(), MeshError> {
    for (i, p) in positions.iter().enumerate() {
        if !p.iter().all(|x| x.is_finite()) {
            return Err(MeshError::NonFiniteVertex { vertex: i, value: [p.x, p.y, p.z] });
        }
    }
    Ok(())
}
