//! Closest-point and inside queries against a triangle surface (parry's BVH, with
//! pseudo-normals for the inside test), the one wrapper of parry in senc: the scene uses
//! [`BodyQuery`] to fit and push garments out of the body, the energy [`NearestFaces`] (no
//! pseudo-normals to build, once per frame) to find each cloth vertex's nearest body face.
//!
//! A point is *inside* when it lies behind the angle-weighted pseudo-normal at its closest
//! point on the surface (Bærentzen–Aanæs), which is exact for closed, consistently oriented
//! meshes and a good local test near an open one away from its holes.

use parry3d_f64::math::Vector as PVec;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::{TriMesh as PTriMesh, TriMeshFlags};

use crate::error::MeshError;
use crate::Vec3;

/// A surface prepared for nearest-point queries only (no inside test): cheaper to build
/// than a [`BodyQuery`], for surfaces that move every frame.
pub struct NearestFaces {
    mesh: PTriMesh,
}

/// A surface (usually a body) prepared for closest-point and inside queries.
pub struct BodyQuery {
    nearest: NearestFaces,
}

/// The answer of [`BodyQuery::closest`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The closest point on the surface, m.
    pub point: Vec3,
    /// The face the closest point lies on.
    pub face: u32,
    /// Whether the query point is inside the surface.
    pub inside: bool,
    /// Signed distance, m: negative inside.
    pub signed_distance: f64,
}

fn pv(v: &Vec3) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

impl NearestFaces {
    /// Builds the BVH (O(n log n)). Fails on non-finite positions, out-of-range indices and
    /// meshes parry's builder refuses.
    pub fn new(positions: &[Vec3], faces: &[[u32; 3]]) -> Result<Self, MeshError> {
        Self::with_flags(positions, faces, TriMeshFlags::empty())
    }

    fn with_flags(positions: &[Vec3], faces: &[[u32; 3]], flags: TriMeshFlags) -> Result<Self, MeshError> {
        if faces.is_empty() {
            return Err(MeshError::Empty);
        }
        if let Some(v) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(MeshError::NonFiniteVertex { vertex: v, value: positions[v].into() });
        }
        for (f, face) in faces.iter().enumerate() {
            if let Some(&index) = face.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(MeshError::IndexOutOfRange { face: f, index, n_vertices: positions.len() });
            }
        }
        let verts: Vec<PVec> = positions.iter().map(pv).collect();
        let mesh = PTriMesh::with_flags(verts, faces.to_vec(), flags)
            .map_err(|e| MeshError::QueryStructure(format!("{e:?}")))?;
        Ok(Self { mesh })
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.mesh.indices().len()
    }

    /// The closest surface point to `p` and the face it lies on.
    pub fn nearest(&self, p: &Vec3) -> (Vec3, u32) {
        let (point, _, face) = self.project(p);
        (point, face)
    }

    fn project(&self, p: &Vec3) -> (Vec3, bool, u32) {
        let (proj, (face, _)) = self.mesh.project_local_point_and_get_location(pv(p), false);
        let face = face.min(self.n_faces().saturating_sub(1) as u32);
        (Vec3::new(proj.point.x, proj.point.y, proj.point.z), proj.is_inside, face)
    }
}

impl BodyQuery {
    /// Builds the BVH and the pseudo-normals (O(n log n)). Fails as [`NearestFaces::new`]
    /// does.
    pub fn new(positions: &[Vec3], faces: &[[u32; 3]]) -> Result<Self, MeshError> {
        Ok(Self { nearest: NearestFaces::with_flags(positions, faces, TriMeshFlags::ORIENTED)? })
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.nearest.n_faces()
    }

    /// Closest surface point, its face, the inside flag and the signed distance of `p`.
    pub fn closest(&self, p: &Vec3) -> Closest {
        let (point, inside, face) = self.nearest.project(p);
        let d = (p - point).norm();
        Closest { point, face, inside, signed_distance: if inside { -d } else { d } }
    }

    /// Indices of the points that are inside the surface.
    pub fn inside(&self, points: &[Vec3]) -> Vec<usize> {
        use rayon::prelude::*;
        points.par_iter().enumerate().filter(|(_, p)| self.closest(p).inside).map(|(i, _)| i).collect()
    }

    /// The smallest signed distance over `points`, m (negative: some point is inside).
    pub fn min_signed_distance(&self, points: &[Vec3]) -> f64 {
        use rayon::prelude::*;
        points.par_iter().map(|p| self.closest(p).signed_distance).reduce(|| f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::icosphere;

    #[test]
    fn closest_points_lie_on_the_sphere_with_the_right_side() {
        let s = icosphere(Vec3::zeros(), 1.0, 3).unwrap();
        let q = BodyQuery::new(s.positions(), s.faces()).unwrap();
        for (p, inside) in [(Vec3::new(0.0, 0.2, 0.1), true), (Vec3::new(1.5, -0.3, 0.2), false)] {
            let c = q.closest(&p);
            assert_eq!(c.inside, inside, "{p:?}");
            assert!((c.point.norm() - 1.0).abs() < 0.02, "{:?}", c.point);
            assert_eq!(c.signed_distance < 0.0, inside);
            let [a, b, d] = s.faces()[c.face as usize].map(|i| s.positions()[i as usize]);
            let n = (b - a).cross(&(d - a));
            assert!((c.point - a).dot(&n).abs() < 1e-9 * n.norm(), "the point lies on its face's plane");
        }
    }

    #[test]
    fn nearest_faces_find_the_same_points_and_faces_as_the_oriented_query() {
        let s = icosphere(Vec3::zeros(), 1.0, 3).unwrap();
        let (q, n) =
            (BodyQuery::new(s.positions(), s.faces()).unwrap(), NearestFaces::new(s.positions(), s.faces()).unwrap());
        for p in [Vec3::new(0.0, 0.2, 0.1), Vec3::new(1.5, -0.3, 0.2), Vec3::new(-0.4, 0.9, -0.7)] {
            let c = q.closest(&p);
            assert_eq!(n.nearest(&p), (c.point, c.face), "{p:?}");
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let p = vec![Vec3::zeros(), Vec3::x(), Vec3::y()];
        assert_eq!(BodyQuery::new(&p, &[]).err(), Some(MeshError::Empty));
        assert_eq!(NearestFaces::new(&p, &[]).err(), Some(MeshError::Empty));
        assert!(matches!(BodyQuery::new(&p, &[[0, 1, 7]]), Err(MeshError::IndexOutOfRange { index: 7, .. })));
        let nan = vec![Vec3::zeros(), Vec3::new(f64::NAN, 0.0, 0.0), Vec3::y()];
        assert!(matches!(BodyQuery::new(&nan, &[[0, 1, 2]]), Err(MeshError::NonFiniteVertex { vertex: 1, .. })));
    }
}
