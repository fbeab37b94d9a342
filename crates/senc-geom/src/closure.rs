//! Hole closure (SENC Algorithm 1, steps 2-7): each chosen boundary loop gets a centroid
//! vertex, the mean of the loop, and a fan of triangles oriented like the faces beside it,
//! so that the garment becomes a closed surface whose penetrations enclose volumes.

use crate::error::MeshError;
use crate::mesh::TriMesh;
use crate::Vec3;

/// Which boundary loops to close. Loops are numbered as in
/// [`crate::Topology::boundary_loops`].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum HoleSelection {
    /// Close every hole.
    #[default]
    All,
    /// Close none (the closure is the mesh itself).
    None,
    /// Close every hole except these (e.g. a collar left open).
    AllExcept(Vec<usize>),
    /// Close only these.
    Only(Vec<usize>),
}

/// A vertex added by closure: the mean of one boundary loop.
#[derive(Debug, Clone, PartialEq)]
pub struct CentroidVertex {
    /// Its index in the closed mesh.
    pub vertex: u32,
    /// The boundary loop it closes.
    pub hole: usize,
    /// The original vertices it is the mean of (each with weight `1 / len`).
    pub loop_vertices: Vec<u32>,
}

/// A garment closed by fans, and how its new vertices depend on the original ones.
///
/// # Invariants
/// - vertices `0..n_original` of the closed mesh are the original vertices, in order;
/// - faces `0..n_original_faces` are the original faces, in order; fan faces follow;
/// - each centroid is the unweighted mean of its loop's original vertices.
#[derive(Debug, Clone)]
pub struct Closure {
    mesh: TriMesh,
    n_original: usize,
    n_original_faces: usize,
    centroids: Vec<CentroidVertex>,
    open_holes: Vec<usize>,
}

/// Closes the chosen holes of `mesh`. With nothing to close, the closure is `mesh` itself
/// and costs one clone.
pub fn close_holes(mesh: &TriMesh, selection: &HoleSelection) -> Result<Closure, MeshError> {
    let loops = mesh.topology().boundary_loops();
    let n_loops = loops.len();
    let check = |ids: &Vec<usize>| {
        ids.iter()
            .try_for_each(|&i| if i < n_loops { Ok(()) } else { Err(MeshError::NoSuchHole { index: i, n_loops }) })
    };
    let chosen: Vec<usize> = match selection {
        HoleSelection::All => (0..n_loops).collect(),
        HoleSelection::None => Vec::new(),
        HoleSelection::AllExcept(ids) => {
            check(ids)?;
            (0..n_loops).filter(|i| !ids.contains(i)).collect()
        }
        HoleSelection::Only(ids) => {
            check(ids)?;
            let mut v = ids.clone();
            v.sort_unstable();
            v.dedup();
            v
        }
    };
    let open_holes = (0..n_loops).filter(|i| !chosen.contains(i)).collect();
    let n_original = mesh.n_vertices();
    let n_original_faces = mesh.n_faces();
    if chosen.is_empty() {
        return Ok(Closure { mesh: mesh.clone(), n_original, n_original_faces, centroids: Vec::new(), open_holes });
    }
    let mut positions = mesh.positions().to_vec();
    let mut faces = mesh.faces().to_vec();
    let mut centroids = Vec::with_capacity(chosen.len());
    for &hole in &chosen {
        let lp = &loops[hole];
        let c = positions.len() as u32;
        positions.push(loop_mean(mesh.positions(), lp));
        for i in 0..lp.len() {
            let a = lp[i];
            let b = lp[(i + 1) % lp.len()];
            // The boundary face traverses a -> b; the fan face must traverse b -> a.
            faces.push([b, a, c]);
        }
        centroids.push(CentroidVertex { vertex: c, hole, loop_vertices: lp.clone() });
    }
    let mesh = TriMesh::new(positions, faces)?;
    Ok(Closure { mesh, n_original, n_original_faces, centroids, open_holes })
}

fn loop_mean(positions: &[Vec3], lp: &[u32]) -> Vec3 {
    lp.iter().map(|&v| positions[v as usize]).sum::<Vec3>() / lp.len() as f64
}

impl Closure {
    /// The closed mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// Number of original vertices.
    pub fn n_original(&self) -> usize {
        self.n_original
    }

    /// Number of original faces; faces at or past this index are fan faces.
    pub fn n_original_faces(&self) -> usize {
        self.n_original_faces
    }

    /// Whether face `f` of the closed mesh was added by closure.
    pub fn is_fan_face(&self, f: usize) -> bool {
        f >= self.n_original_faces
    }

    /// The added vertices and what they depend on.
    pub fn centroids(&self) -> &[CentroidVertex] {
        &self.centroids
    }

    /// Holes left open.
    pub fn open_holes(&self) -> &[usize] {
        &self.open_holes
    }

    /// For each face of the closed mesh, 0 for an original face and `k + 1` for a face of
    /// the fan of centroid `k` (see `intersect::SelfIntersector::with_groups`).
    pub fn fan_groups(&self) -> Vec<u32> {
        let mut g = vec![0u32; self.n_original_faces];
        for (k, c) in self.centroids.iter().enumerate() {
            g.extend(std::iter::repeat_n(k as u32 + 1, c.loop_vertices.len()));
        }
        g
    }

    /// Whether nothing was closed.
    pub fn is_identity(&self) -> bool {
        self.centroids.is_empty()
    }

    /// Moves the closed mesh to new original positions (centroids recomputed).
    pub fn update(&mut self, original: &[Vec3]) -> Result<(), MeshError> {
        if original.len() != self.n_original {
            return Err(MeshError::PositionCount { expected: self.n_original, got: original.len() });
        }
        let mut positions = Vec::with_capacity(self.mesh.n_vertices());
        positions.extend_from_slice(original);
        positions.extend(self.centroids.iter().map(|c| loop_mean(original, &c.loop_vertices)));
        self.mesh.set_positions(positions)
    }

    /// Chains a gradient on the closed mesh's vertices back to the original vertices: each
    /// centroid's gradient is shared equally by its loop.
    pub fn pull_back(&self, closed_gradient: &[Vec3]) -> Vec<Vec3> {
        let mut g = closed_gradient[..self.n_original.min(closed_gradient.len())].to_vec();
        g.resize(self.n_original, Vec3::zeros());
        for c in &self.centroids {
            if let Some(gc) = closed_gradient.get(c.vertex as usize) {
                let share = gc / c.loop_vertices.len() as f64;
                for &v in &c.loop_vertices {
                    g[v as usize] += share;
                }
            }
        }
        g
    }
}
