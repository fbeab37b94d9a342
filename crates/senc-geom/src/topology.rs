//! Mesh connectivity: edges, edge → faces, face → edges, vertex → faces, ordered boundary
//! loops and connected components. Built once per mesh and shared by every frame.

use crate::error::MeshError;
use crate::intersect::SearchSlot;

/// Marker for "no face" in [`Topology::edge_faces`].
pub const NO_FACE: u32 = u32::MAX;

/// Connectivity of a manifold, consistently oriented triangle mesh.
///
/// # Conventions
/// - Edges are stored once as `[a, b]` with `a < b`, sorted lexicographically.
/// - `face_edges[f][k]` is the edge *opposite* vertex `k` of face `f`, i.e. between
///   `faces[f][(k + 1) % 3]` and `faces[f][(k + 2) % 3]`.
/// - Boundary loops follow the winding of their faces (for a boundary face edge traversed
///   `a → b`, the loop goes `a → b`), start at their smallest vertex and are sorted by it.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    n_vertices: usize,
    edges: Vec<[u32; 2]>,
    edge_faces: Vec<[u32; 2]>,
    face_edges: Vec<[u32; 3]>,
    vertex_face_offsets: Vec<u32>,
    vertex_face_indices: Vec<u32>,
    boundary_loops: Vec<Vec<u32>>,
    face_component: Vec<u32>,
    n_components: usize,
    /// The self-intersection search tree, built by the first
    /// [`crate::intersect::SelfIntersector`] made for a mesh with this topology and shared by
    /// every later one (ignored by `==`).
    pub(crate) search: SearchSlot,
}

impl Topology {
    /// Builds the connectivity of `faces` over `n_vertices` vertices.
    ///
    /// Fails with [`MeshError::NonManifoldEdge`] when an edge has more than two faces and
    /// with [`MeshError::InconsistentOrientation`] when two faces traverse an edge the same
    /// way. Indices must already be in range and distinct within each face.
    pub fn new(faces: &[[u32; 3]], n_vertices: usize) -> Result<Self, MeshError> {
        // Half-edges keyed by the undirected edge, sorted so that the result is deterministic:
        // in increasing `(key, face, k)` order. A counting sort on the key's smaller vertex
        // keeps each vertex's half-edges in `(face, k)` order; a stable sort of those few on
        // the larger vertex completes the order.
        let key = |face: &[u32; 3], k: usize| {
            let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
            [a.min(b), a.max(b)]
        };
        let mut start = vec![0u32; n_vertices + 1];
        for face in faces {
            for k in 0..3 {
                start[key(face, k)[0] as usize + 1] += 1;
            }
        }
        for v in 0..n_vertices {
            start[v + 1] += start[v];
        }
        let mut half: Vec<([u32; 2], u32, u8)> = vec![([0; 2], 0, 0); faces.len() * 3];
        let mut next = start.clone();
        for (f, face) in faces.iter().enumerate() {
            for k in 0..3 {
                let e = key(face, k);
                let slot = &mut next[e[0] as usize];
                half[*slot as usize] = (e, f as u32, k as u8);
                *slot += 1;
            }
        }
        for v in 0..n_vertices {
            half[start[v] as usize..start[v + 1] as usize].sort_by_key(|h| h.0[1]);
        }
        let mut edges = Vec::with_capacity(half.len() / 2 + 1);
        let mut edge_faces = Vec::with_capacity(half.len() / 2 + 1);
        let mut face_edges = vec![[0u32; 3]; faces.len()];
        let mut i = 0;
        while i < half.len() {
            let key = half[i].0;
            let mut j = i;
            while j < half.len() && half[j].0 == key {
                j += 1;
            }
            let n = j - i;
            if n > 2 {
                return Err(MeshError::NonManifoldEdge {
                    a: key[0],
                    b: key[1],
                    n_faces: n,
                    faces: half[i..j.min(i + 3)].iter().map(|h| h.1 as usize).collect(),
                });
            }
            let e = edges.len() as u32;
            edges.push(key);
            let mut ef = [NO_FACE; 2];
            for (slot, h) in half[i..j].iter().enumerate() {
                ef[slot] = h.1;
                face_edges[h.1 as usize][h.2 as usize] = e;
            }
            if n == 2 {
                let dir = |h: &([u32; 2], u32, u8)| {
                    let face = faces[h.1 as usize];
                    face[(h.2 as usize + 1) % 3] < face[(h.2 as usize + 2) % 3]
                };
                if dir(&half[i]) == dir(&half[i + 1]) {
                    return Err(MeshError::InconsistentOrientation {
                        a: key[0],
                        b: key[1],
                        face_a: half[i].1 as usize,
                        face_b: half[i + 1].1 as usize,
                    });
                }
            }
            edge_faces.push(ef);
            i = j;
        }

        // vertex -> faces (CSR)
        let mut counts = vec![0u32; n_vertices + 1];
        for face in faces {
            for &v in face {
                counts[v as usize + 1] += 1;
            }
        }
        for v in 0..n_vertices {
            counts[v + 1] += counts[v];
        }
        let mut fill = counts.clone();
        let mut vertex_face_indices = vec![0u32; faces.len() * 3];
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                vertex_face_indices[fill[v as usize] as usize] = f as u32;
                fill[v as usize] += 1;
            }
        }

        let boundary_loops = boundary_loops(faces, &edge_faces, &face_edges);
        let (face_component, n_components) = components(faces.len(), &edge_faces);

        Ok(Self {
            n_vertices,
            edges,
            edge_faces,
            face_edges,
            vertex_face_offsets: counts,
            vertex_face_indices,
            boundary_loops,
            face_component,
            n_components,
            search: SearchSlot::default(),
        })
    }

    /// Number of vertices the topology was built for.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Undirected edges `[a, b]`, `a < b`, sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// The one or two faces of each edge; the second is [`NO_FACE`] on a boundary edge.
    pub fn edge_faces(&self) -> &[[u32; 2]] {
        &self.edge_faces
    }

    /// For each face, the edge opposite each of its vertices.
    pub fn face_edges(&self) -> &[[u32; 3]] {
        &self.face_edges
    }

    /// Faces that use vertex `v`.
    pub fn vertex_faces(&self, v: u32) -> &[u32] {
        let a = self.vertex_face_offsets[v as usize] as usize;
        let b = self.vertex_face_offsets[v as usize + 1] as usize;
        &self.vertex_face_indices[a..b]
    }

    /// Index of edge `(a, b)` (either order), if it exists.
    pub fn find_edge(&self, a: u32, b: u32) -> Option<u32> {
        let key = [a.min(b), a.max(b)];
        self.edges.binary_search(&key).ok().map(|e| e as u32)
    }

    /// Whether edge `e` has only one face.
    pub fn is_boundary_edge(&self, e: u32) -> bool {
        self.edge_faces[e as usize][1] == NO_FACE
    }

    /// Ordered boundary loops (see the type's conventions).
    pub fn boundary_loops(&self) -> &[Vec<u32>] {
        &self.boundary_loops
    }

    /// Connected component of each face (components joined through edges).
    pub fn face_component(&self) -> &[u32] {
        &self.face_component
    }

    /// Number of edge-connected components.
    pub fn n_components(&self) -> usize {
        self.n_components
    }
}

fn boundary_loops(faces: &[[u32; 3]], edge_faces: &[[u32; 2]], face_edges: &[[u32; 3]]) -> Vec<Vec<u32>> {
    // Directed boundary half-edges a -> b in face winding order, sorted by a.
    let mut directed: Vec<[u32; 2]> = Vec::new();
    for (e, ef) in edge_faces.iter().enumerate() {
        if ef[1] != NO_FACE {
            continue;
        }
        let f = ef[0] as usize;
        let k = face_edges[f].iter().position(|&x| x as usize == e).unwrap_or(0);
        let face = faces[f];
        directed.push([face[(k + 1) % 3], face[(k + 2) % 3]]);
    }
    directed.sort_unstable();
    let mut used = vec![false; directed.len()];
    let mut loops = Vec::new();
    for start in 0..directed.len() {
        if used[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut cur = start;
        loop {
            used[cur] = true;
            lp.push(directed[cur][0]);
            let next_v = directed[cur][1];
            // First unused half-edge leaving next_v (several only at a pinched vertex).
            let lo = directed.partition_point(|h| h[0] < next_v);
            let mut next = None;
            let mut k = lo;
            while k < directed.len() && directed[k][0] == next_v {
                if !used[k] {
                    next = Some(k);
                    break;
                }
                k += 1;
            }
            match next {
                Some(n) => cur = n,
                None => break,
            }
        }
        // Start each loop at its smallest vertex.
        if let Some(pos) = lp.iter().enumerate().min_by_key(|(_, &v)| v).map(|(i, _)| i) {
            lp.rotate_left(pos);
        }
        loops.push(lp);
    }
    loops.sort_by_key(|l| l[0]);
    loops
}

fn components(n_faces: usize, edge_faces: &[[u32; 2]]) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..n_faces as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for ef in edge_faces {
        if ef[1] != NO_FACE {
            let a = find(&mut parent, ef[0]);
            let b = find(&mut parent, ef[1]);
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut label = vec![u32::MAX; n_faces];
    let mut comp = vec![0u32; n_faces];
    let mut n = 0u32;
    for f in 0..n_faces {
        let r = find(&mut parent, f as u32) as usize;
        if label[r] == u32::MAX {
            label[r] = n;
            n += 1;
        }
        comp[f] = label[r];
    }
    (comp, n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The edge tables equal those of the half-edges sorted by comparison, on a grid whose
    /// vertex ids are shuffled.
    #[test]
    fn edge_tables_match_a_comparison_sort() {
        let (nx, ny) = (12u32, 9u32);
        let n = ((nx + 1) * (ny + 1)) as usize;
        let mut perm: Vec<u32> = (0..n as u32).collect();
        let mut seed = 12345u64;
        for i in (1..n).rev() {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            perm.swap(i, (seed >> 33) as usize % (i + 1));
        }
        let id = |i: u32, j: u32| perm[(j * (nx + 1) + i) as usize];
        let mut faces = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                faces.extend([[a, b, c], [a, c, d]]);
            }
        }
        let t = Topology::new(&faces, n).unwrap();
        let mut half: Vec<([u32; 2], u32, u8)> = Vec::new();
        for (f, face) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                half.push(([a.min(b), a.max(b)], f as u32, k as u8));
            }
        }
        half.sort_unstable();
        let (mut edges, mut edge_faces, mut face_edges) = (Vec::new(), Vec::new(), vec![[0u32; 3]; faces.len()]);
        for h in &half {
            if edges.last() != Some(&h.0) {
                edges.push(h.0);
                edge_faces.push([h.1, NO_FACE]);
            } else {
                edge_faces.last_mut().unwrap()[1] = h.1;
            }
            face_edges[h.1 as usize][h.2 as usize] = edges.len() as u32 - 1;
        }
        assert_eq!(t.edges(), edges.as_slice());
        assert_eq!(t.edge_faces(), edge_faces.as_slice());
        assert_eq!(t.face_edges(), face_edges.as_slice());
    }
}
