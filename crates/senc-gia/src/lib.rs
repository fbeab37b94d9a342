//! senc-gia: Global Intersection Analysis and the differentiable penetration volume
//! (SENC's self-collision energy).
//!
//! UNDER CONSTRUCTION (issue 3): the public API below is fixed so that other crates can
//! build against it; `GiaWorkspace::penetration` returns `GiaError::Unfinished` until the
//! implementation lands.

use senc_geom::{Closure, Vec3};

/// How the gradient treats intersection points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GradientMode {
    /// The true derivative: an intersection point's edge parameter and barycentric
    /// coordinates depend on the vertices too.
    #[default]
    Exact,
    /// SENC's version: barycentric weights of intersection points held fixed.
    FixedBarycentric,
}

/// How the flood fill decides which side of a path is the smaller (penetrating) one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeRule {
    /// The side with fewer faces (the side whose lockstep fill finishes first).
    #[default]
    Faces,
    /// The side with the smaller area.
    Area,
}

/// Options of one penetration query.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct GiaOptions {
    /// Gradient definition.
    pub gradient: GradientMode,
    /// Region size rule.
    pub size_rule: SizeRule,
}

/// Result of a penetration query.
#[derive(Debug, Clone, Default)]
pub struct Penetration {
    /// Total penetration volume, m³ (sum over regions of |Σ signed tetrahedra|).
    pub volume: f64,
    /// Gradient of `volume` with respect to every original (unclosed) vertex, m².
    pub gradient: Vec<Vec3>,
    /// Area of the penetrating faces (the paper's "w. area loss" ablation), m².
    pub area: f64,
    /// Gradient of `area` with respect to every original vertex, m.
    pub area_gradient: Vec<Vec3>,
}

/// Why a query failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GiaError {
    /// Not built yet.
    #[error("senc-gia is not finished yet")]
    Unfinished,
}

/// Reusable state between queries on one closed mesh whose positions change.
#[derive(Debug, Default)]
pub struct GiaWorkspace {}

impl GiaWorkspace {
    /// A workspace for meshes with `closure`'s topology.
    pub fn new(_closure: &Closure) -> Self {
        Self {}
    }

    /// Penetration volume, area and gradients of the closed mesh at its current positions.
    pub fn penetration(&mut self, _closure: &Closure, _options: &GiaOptions) -> Result<Penetration, GiaError> {
        Err(GiaError::Unfinished)
    }
}
