//! Rest-state quantities computed once per garment: per-face rest shape matrices and areas,
//! lumped vertex masses, and the bending hinges.

use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;

use senc_geom::topology::NO_FACE;
use senc_geom::{TriMesh, Vec3};

use crate::terms::bending::dihedral_angle;

/// One interior edge and its two faces: vertices `[a, b, c, d]` with the edge `a → b` as
/// face 0 `(a, b, c)` traverses it, `c` opposite on face 0 and `d` opposite on face 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hinge {
    /// `[a, b, c, d]`.
    pub vertices: [u32; 4],
    /// `k_b l_e² / (4 (A_0 + A_1))` with rest edge length and rest face areas, J per unit
    /// material k_b (multiply by k_b).
    pub geometric_weight: f64,
    /// Rest dihedral angle of the mesh, rad.
    pub rest_angle: f64,
}

/// Rest state of a garment.
#[derive(Debug, Clone)]
pub struct RestState {
    /// Faces.
    pub faces: Vec<[u32; 3]>,
    /// `Dm⁻¹` per face, with `Dm = [X0 − X2, X1 − X2]` expressed in an orthonormal basis of
    /// the rest triangle's plane (first axis along `X0 − X2`).
    pub dm_inv: Vec<Matrix2<f64>>,
    /// Rest area per face, m².
    pub face_area: Vec<f64>,
    /// Interior edges.
    pub hinges: Vec<Hinge>,
    /// Lumped mass per vertex per unit areal density: `Σ_{f∋i} A_f / 3`, m².
    pub vertex_area: Vec<f64>,
}

impl RestState {
    /// Rest quantities of `rest`. Never fails: the mesh guarantees non-zero rest areas.
    pub fn new(rest: &TriMesh) -> Self {
        let faces = rest.faces().to_vec();
        let x = rest.positions();
        let (dm_inv, face_area): (Vec<_>, Vec<_>) = faces
            .par_iter()
            .map(|f| {
                let [p0, p1, p2] = f.map(|i| x[i as usize]);
                let (e0, e1) = (p0 - p2, p1 - p2);
                let u = e0 / e0.norm();
                let n = e0.cross(&e1);
                let v = n.normalize().cross(&u);
                let dm = Matrix2::from_columns(&[
                    Vector2::new(u.dot(&e0), v.dot(&e0)),
                    Vector2::new(u.dot(&e1), v.dot(&e1)),
                ]);
                let inv = dm.try_inverse().unwrap_or_else(Matrix2::zeros);
                (inv, 0.5 * n.norm())
            })
            .unzip();
        let mut vertex_area = vec![0.0; x.len()];
        for (f, face) in faces.iter().enumerate() {
            for &i in face {
                vertex_area[i as usize] += face_area[f] / 3.0;
            }
        }
        let topo = rest.topology();
        let hinges = topo
            .edges()
            .iter()
            .zip(topo.edge_faces())
            .filter(|(_, ef)| ef[1] != NO_FACE)
            .map(|(e, ef)| {
                let f0 = faces[ef[0] as usize];
                let f1 = faces[ef[1] as usize];
                // Orient the edge as face 0 traverses it: f0 = (a, b, c) up to rotation.
                let k = (0..3)
                    .find(|&k| {
                        let (u, w) = (f0[k], f0[(k + 1) % 3]);
                        [u.min(w), u.max(w)] == *e
                    })
                    .unwrap_or(0);
                let (a, b, c) = (f0[k], f0[(k + 1) % 3], f0[(k + 2) % 3]);
                let d = f1.iter().copied().find(|&v| v != a && v != b).unwrap_or(a);
                let l2 = (x[b as usize] - x[a as usize]).norm_squared();
                let area = face_area[ef[0] as usize] + face_area[ef[1] as usize];
                let vertices = [a, b, c, d];
                let rest_angle = dihedral_angle(&vertices.map(|i| x[i as usize]));
                Hinge { vertices, geometric_weight: l2 / (4.0 * area), rest_angle }
            })
            .collect();
        Self { faces, dm_inv, face_area, hinges, vertex_area }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertex_area.len()
    }
}

/// Gathers positions `[Vec3; K]` of an element.
#[inline]
pub(crate) fn corners<const K: usize>(x: &[Vec3], el: &[u32; K]) -> [Vec3; K] {
    el.map(|i| x[i as usize])
}
