//! The energy configuration: material, time step, forces, and the weight and switches of
//! each term. Deserialised from TOML or JSON with unknown keys rejected; every field has a
//! documented default, so an empty file is the default configuration (HOOD's material).

use serde::{Deserialize, Serialize};

use senc_gia::GiaOptions;

use crate::error::EnergyError;
use crate::material::Material;

/// Rest angle of the discrete-shell bending term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BendingRest {
    /// θ̄ = 0 everywhere (HOOD's choice: the garment prefers to be flat).
    #[default]
    Flat,
    /// θ̄ = the rest mesh's own dihedral angle on each edge.
    RestMesh,
}

/// Body collision penalty `w Σ max(ε − d, 0)³`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CollisionConfig {
    /// Weight w, J/m³ (default 5e5, the end of HOOD's ramp 5e3 → 5e5).
    pub weight: f64,
    /// Margin ε, m (default 2e-3).
    pub epsilon: f64,
}

impl Default for CollisionConfig {
    fn default() -> Self {
        Self { weight: 5e5, epsilon: 2e-3 }
    }
}

/// Friction against the moving body (HOOD's form).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrictionConfig {
    /// Friction coefficient μ_f (default 0.5; 0 removes the term).
    pub mu: f64,
    /// A cloth vertex is in contact when its signed distance to its nearest body face at
    /// time t is below this, m (default 5e-3).
    pub distance: f64,
    /// Smoothing length η of `sqrt(|Δ_T|² + η²) − η`, m (default 1e-5): keeps the term
    /// differentiable at zero slip.
    pub smoothing: f64,
}

impl Default for FrictionConfig {
    fn default() -> Self {
        Self { mu: 0.5, distance: 5e-3, smoothing: 1e-5 }
    }
}

/// SENC's self-collision (penetration volume from senc-gia).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelfCollisionConfig {
    /// Weight on Σ|6V|, J/m³ (SENC: 30000; 0 removes the term and every GIA call).
    pub weight: f64,
    /// Boundary loops (as numbered by `Topology::boundary_loops`) left open; every other
    /// hole is closed by a centroid fan (the paper leaves collars open).
    pub open_holes: Vec<usize>,
    /// GIA options (gradient definition, region size rule).
    pub gia: GiaOptions,
}

impl Default for SelfCollisionConfig {
    fn default() -> Self {
        Self { weight: 30000.0, open_holes: Vec::new(), gia: GiaOptions::default() }
    }
}

/// The paper's repulsive baseline `−w Σ log(‖xi − xj‖² / τ²)` over non-adjacent pairs
/// closer than τ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RepulsionConfig {
    /// Weight w, J (default 0: off).
    pub weight: f64,
    /// Threshold τ, m (default 0.05).
    pub threshold: f64,
}

impl Default for RepulsionConfig {
    fn default() -> Self {
        Self { weight: 0.0, threshold: 0.05 }
    }
}

/// The energy configuration. Terms with weight 0 are not built at all.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnergyConfig {
    /// The cloth material.
    pub material: Material,
    /// Time step Δt, s (default 1/30).
    pub dt: f64,
    /// Gravity g, m/s² (default (0, −9.81, 0)).
    pub gravity: [f64; 3],
    /// External acceleration a_ext, m/s² (default 0; the `external` term exists only when
    /// it is non-zero).
    pub external_acceleration: [f64; 3],
    /// Bending rest angle.
    pub bending_rest: BendingRest,
    /// Whether the inertia term is present (default true; `cargo xtask energy` without
    /// `--prev` turns it off).
    pub inertia: bool,
    /// Body collision (only built when there is a body).
    pub collision: CollisionConfig,
    /// Friction (only built when there is a body).
    pub friction: FrictionConfig,
    /// SENC's self-collision.
    pub self_collision: SelfCollisionConfig,
    /// Weight on the area of the penetrating faces ("w. area loss" ablation), J/m²
    /// (default 0: off).
    pub area_weight: f64,
    /// The repulsive baseline.
    pub repulsion: RepulsionConfig,
}

impl Default for EnergyConfig {
    fn default() -> Self {
        Self {
            material: Material::default(),
            dt: 1.0 / 30.0,
            gravity: [0.0, -9.81, 0.0],
            external_acceleration: [0.0; 3],
            bending_rest: BendingRest::Flat,
            inertia: true,
            collision: CollisionConfig::default(),
            friction: FrictionConfig::default(),
            self_collision: SelfCollisionConfig::default(),
            area_weight: 0.0,
            repulsion: RepulsionConfig::default(),
        }
    }
}

impl EnergyConfig {
    /// Checks every value is in its domain.
    pub fn validate(&self) -> Result<(), EnergyError> {
        self.material.validate()?;
        let bad = |name, value, why| Err(EnergyError::InvalidParameter { name, value, why });
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return bad("dt", self.dt, "must be finite and > 0 s");
        }
        for v in self.gravity.iter().chain(&self.external_acceleration) {
            if !v.is_finite() {
                return bad("gravity/external_acceleration", *v, "must be finite m/s²");
            }
        }
        let nonneg: [(&'static str, f64); 8] = [
            ("collision.weight", self.collision.weight),
            ("collision.epsilon", self.collision.epsilon),
            ("friction.mu", self.friction.mu),
            ("friction.distance", self.friction.distance),
            ("self_collision.weight", self.self_collision.weight),
            ("area_weight", self.area_weight),
            ("repulsion.weight", self.repulsion.weight),
            ("repulsion.threshold", self.repulsion.threshold),
        ];
        for (name, value) in nonneg {
            if !(value.is_finite() && value >= 0.0) {
                return bad(name, value, "must be finite and >= 0");
            }
        }
        if !(self.friction.smoothing.is_finite() && self.friction.smoothing > 0.0) {
            return bad("friction.smoothing", self.friction.smoothing, "must be finite and > 0 m");
        }
        Ok(())
    }
}
