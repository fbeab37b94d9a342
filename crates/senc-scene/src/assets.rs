//! Body and garment assets: the compact MessagePack files committed under `data/`.
//!
//! A body asset holds the rest mesh (m, Y up, facing +z), its skeleton and skinning weights.
//! A garment asset holds the rest mesh fitted to that body, its skinning weights and named
//! boundary loops (`hem`, `neck`, `left_sleeve`, `waist`, ...), stored as vertex lists and
//! matched to [`senc_geom::Topology::boundary_loops`] indices at load time.

use std::path::Path;

use senc_geom::{HoleSelection, TriMesh, Vec3};
use serde::{de::DeserializeOwned, Deserialize, Serialize};

use crate::error::SceneError;
use crate::skeleton::{Skeleton, SkinWeights};

/// Reads a MessagePack file.
pub fn read_msgpack<T: DeserializeOwned>(path: impl AsRef<Path>) -> Result<T, SceneError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    rmp_serde::from_slice(&bytes).map_err(|e| SceneError::Asset { path: path.to_owned(), message: e.to_string() })
}

/// Writes a MessagePack file (named fields, so files stay readable by other tools).
pub fn write_msgpack<T: Serialize>(path: impl AsRef<Path>, value: &T) -> Result<(), SceneError> {
    let path = path.as_ref();
    let bytes = rmp_serde::to_vec_named(value)
        .map_err(|e| SceneError::Asset { path: path.to_owned(), message: e.to_string() })?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
    }
    std::fs::write(path, bytes).map_err(|e| SceneError::io(path, e))
}

/// The body: rest mesh, skeleton and skinning weights.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BodyAsset {
    /// Rest positions, m.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles (normals point out of the body).
    pub faces: Vec<[u32; 3]>,
    /// The skeleton the weights refer to.
    pub skeleton: Skeleton,
    /// Per-vertex skinning weights.
    pub weights: SkinWeights,
}

impl BodyAsset {
    /// Loads and validates a body asset.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let b: Self = read_msgpack(path)?;
        b.validate()?;
        Ok(b)
    }

    /// Checks mesh, skeleton and weights against one another.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.skeleton.validate()?;
        self.weights.validate(self.positions.len(), self.skeleton.len())?;
        Ok(())
    }

    /// The rest mesh, validated by senc-geom.
    pub fn mesh(&self) -> Result<TriMesh, SceneError> {
        Ok(TriMesh::new(self.positions.clone(), self.faces.clone())?)
    }
}

/// A named boundary loop of a garment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NamedLoop {
    /// Name (`hem`, `neck`, `left_sleeve`, `right_sleeve`, `waist`, `left_leg`, ...).
    pub name: String,
    /// The loop's vertices (any order, any start).
    pub vertices: Vec<u32>,
}

/// A garment: rest mesh fitted to the body, skinning weights on the body's skeleton, named
/// boundary loops.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GarmentAsset {
    /// Name (`tshirt`, `skirt`, ...).
    pub name: String,
    /// Rest positions, m (fitted: no vertex inside the body).
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles (normals point away from the body).
    pub faces: Vec<[u32; 3]>,
    /// Skinning weights on the body skeleton.
    pub weights: SkinWeights,
    /// Named boundary loops.
    pub loops: Vec<NamedLoop>,
}

impl GarmentAsset {
    /// Loads a garment asset and checks it against its mesh.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let g: Self = read_msgpack(path)?;
        g.mesh()?;
        g.loop_indices()?;
        Ok(g)
    }

    /// The rest mesh, validated by senc-geom.
    pub fn mesh(&self) -> Result<TriMesh, SceneError> {
        Ok(TriMesh::new(self.positions.clone(), self.faces.clone())?)
    }

    /// For each named loop, its index among the mesh's `Topology::boundary_loops`.
    pub fn loop_indices(&self) -> Result<Vec<(String, usize)>, SceneError> {
        let mesh = self.mesh()?;
        let loops = mesh.topology().boundary_loops();
        let sorted: Vec<Vec<u32>> = loops
            .iter()
            .map(|l| {
                let mut v = l.clone();
                v.sort_unstable();
                v
            })
            .collect();
        self.loops
            .iter()
            .map(|nl| {
                let mut v = nl.vertices.clone();
                v.sort_unstable();
                sorted
                    .iter()
                    .position(|l| *l == v)
                    .map(|i| (nl.name.clone(), i))
                    .ok_or_else(|| SceneError::LoopMismatch { garment: self.name.clone(), name: nl.name.clone() })
            })
            .collect()
    }

    /// The vertices of the named loops, sorted and without repeats (pinned vertices).
    pub fn loop_vertices(&self, names: &[String]) -> Result<Vec<usize>, SceneError> {
        let mut out = Vec::new();
        for n in names {
            let l = self.loops.iter().find(|l| &l.name == n).ok_or_else(|| SceneError::NoSuchLoop {
                garment: self.name.clone(),
                name: n.clone(),
                available: self.loop_names(),
            })?;
            out.extend(l.vertices.iter().map(|&v| v as usize));
        }
        out.sort_unstable();
        out.dedup();
        Ok(out)
    }

    /// Names of the loops.
    pub fn loop_names(&self) -> Vec<String> {
        self.loops.iter().map(|l| l.name.clone()).collect()
    }

    /// The hole selection closing exactly the named loops.
    pub fn hole_selection(&self, close: &[String]) -> Result<HoleSelection, SceneError> {
        let idx = self.loop_indices()?;
        let ids = close
            .iter()
            .map(|n| {
                idx.iter().find(|(m, _)| m == n).map(|(_, i)| *i).ok_or_else(|| SceneError::NoSuchLoop {
                    garment: self.name.clone(),
                    name: n.clone(),
                    available: self.loop_names(),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(if ids.is_empty() { HoleSelection::None } else { HoleSelection::Only(ids) })
    }
}
