//! Skeletons, poses and linear blend skinning.
//!
//! A [`Skeleton`] is a list of bones, parents before children, each with a rest head and tail
//! in metres. A [`Pose`] gives every bone a world rotation *relative to its rest orientation*
//! and the root a translation; the bone's rigid transform is
//! `T_j(v) = W_j (v − h_j) + p_j` with `h_j` the rest head, `p_root = h_root + t_root` and
//! `p_j = T_parent(j)(h_j)` for the other bones (forward kinematics). Skinning is
//! `v' = Σ_j w_vj T_j(v)` with weights summing to one.

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use senc_geom::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// One bone: a name, a parent (earlier in the list) and rest head/tail positions (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Bone {
    /// Name (the `cmu_mb` rig uses CMU mocap joint names).
    pub name: String,
    /// Index of the parent bone, `None` for the root.
    pub parent: Option<usize>,
    /// Rest position of the bone's head (its pivot), m.
    pub head: Vec3,
    /// Rest position of the bone's tail, m.
    pub tail: Vec3,
}

/// A skeleton: bones ordered so that every parent precedes its children.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skeleton {
    /// The bones.
    pub bones: Vec<Bone>,
}

/// A pose: per bone, the world rotation relative to rest; plus the root translation (m).
#[derive(Debug, Clone, PartialEq)]
pub struct Pose {
    /// `W_j`, one per bone.
    pub rotations: Vec<UnitQuaternion<f64>>,
    /// Root translation from its rest head, m.
    pub root_translation: Vec3,
}

impl Pose {
    /// The rest pose of a skeleton with `n_bones` bones.
    pub fn identity(n_bones: usize) -> Self {
        Self { rotations: vec![UnitQuaternion::identity(); n_bones], root_translation: Vec3::zeros() }
    }
}

impl Skeleton {
    /// Checks that parents precede children and names are unique.
    pub fn validate(&self) -> Result<(), SceneError> {
        for (j, b) in self.bones.iter().enumerate() {
            if let Some(p) = b.parent {
                if p >= j {
                    return Err(SceneError::Invalid(format!(
                        "bone {} ({j}) has parent {p}, which does not precede it; order bones parents first",
                        b.name
                    )));
                }
            }
            if self.bones[..j].iter().any(|o| o.name == b.name) {
                return Err(SceneError::Invalid(format!("bone name {} appears twice", b.name)));
            }
        }
        Ok(())
    }

    /// Index of the bone called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    /// Number of bones.
    pub fn len(&self) -> usize {
        self.bones.len()
    }

    /// True when there are no bones.
    pub fn is_empty(&self) -> bool {
        self.bones.is_empty()
    }

    /// The rigid transform of every bone in `pose` (forward kinematics, see the module doc).
    pub fn bone_transforms(&self, pose: &Pose) -> Result<Vec<Isometry3<f64>>, SceneError> {
        if pose.rotations.len() != self.bones.len() {
            return Err(SceneError::BoneCount {
                motion: "pose".into(),
                expected: self.bones.len(),
                got: pose.rotations.len(),
            });
        }
        let mut out: Vec<Isometry3<f64>> = Vec::with_capacity(self.bones.len());
        for (j, b) in self.bones.iter().enumerate() {
            let p = match b.parent {
                None => b.head + pose.root_translation,
                Some(pj) => out[pj].transform_point(&b.head.into()).coords,
            };
            let w = pose.rotations[j];
            // T(v) = W (v - h) + p  =>  translation p - W h.
            let t = p - w * b.head;
            out.push(Isometry3::from_parts(Translation3::from(t), w));
        }
        Ok(out)
    }
}

/// Sparse skinning weights: for each vertex, (bone, weight) pairs summing to one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkinWeights {
    /// `offsets[v]..offsets[v + 1]` indexes `bones` and `weights` for vertex `v`.
    pub offsets: Vec<u32>,
    /// Bone indices.
    pub bones: Vec<u16>,
    /// Weights (dimensionless, per vertex summing to 1).
    pub weights: Vec<f32>,
}

impl SkinWeights {
    /// Builds weights from per-vertex lists, dropping zero weights and renormalising each
    /// vertex to sum 1. A vertex with no positive weight is an error.
    pub fn from_lists(lists: &[Vec<(u16, f32)>]) -> Result<Self, SceneError> {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        let mut bones = Vec::new();
        let mut weights = Vec::new();
        offsets.push(0u32);
        for (v, l) in lists.iter().enumerate() {
            let sum: f32 = l.iter().filter(|(_, w)| *w > 0.0).map(|(_, w)| *w).sum();
            if !(sum > 0.0) || !sum.is_finite() {
                return Err(SceneError::Weights(format!("vertex {v} has no positive weight")));
            }
            for &(b, w) in l.iter().filter(|(_, w)| *w > 0.0) {
                bones.push(b);
                weights.push(w / sum);
            }
            offsets.push(bones.len() as u32);
        }
        Ok(Self { offsets, bones, weights })
    }

    /// Number of vertices covered.
    pub fn n_vertices(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The (bone, weight) pairs of vertex `v`.
    pub fn of(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.offsets[v] as usize..self.offsets[v + 1] as usize;
        self.bones[r.clone()].iter().zip(&self.weights[r]).map(|(&b, &w)| (b as usize, w as f64))
    }

    /// Checks the layout against `n_vertices` vertices and `n_bones` bones.
    pub fn validate(&self, n_vertices: usize, n_bones: usize) -> Result<(), SceneError> {
        if self.n_vertices() != n_vertices {
            return Err(SceneError::Weights(format!(
                "weights cover {} vertices but the mesh has {n_vertices}",
                self.n_vertices()
            )));
        }
        if self.bones.len() != self.weights.len()
            || self.offsets.last().map(|&o| o as usize) != Some(self.bones.len())
            || self.offsets.windows(2).any(|w| w[0] > w[1])
        {
            return Err(SceneError::Weights("offsets, bones and weights are inconsistent".into()));
        }
        if let Some(&b) = self.bones.iter().find(|&&b| b as usize >= n_bones) {
            return Err(SceneError::Weights(format!("bone {b} does not exist (skeleton has {n_bones})")));
        }
        for v in 0..n_vertices {
            let s: f64 = self.of(v).map(|(_, w)| w).sum();
            if (s - 1.0).abs() > 1e-4 {
                return Err(SceneError::Weights(format!("weights of vertex {v} sum to {s}, not 1")));
            }
        }
        Ok(())
    }
}

/// Linear blend skinning: `v' = Σ_j w_vj T_j(v)` for every rest position.
pub fn skin(rest: &[Vec3], weights: &SkinWeights, transforms: &[Isometry3<f64>]) -> Vec<Vec3> {
    rest.iter()
        .enumerate()
        .map(|(v, p)| {
            // Weights are stored as f32; dividing by their f64 sum keeps the blend an exact
            // partition of unity, so identity transforms reproduce the rest pose.
            let mut acc = Vec3::zeros();
            let mut sum = 0.0;
            for (b, w) in weights.of(v) {
                acc += w * transforms[b].transform_point(&(*p).into()).coords;
                sum += w;
            }
            acc / sum
        })
        .collect()
}
