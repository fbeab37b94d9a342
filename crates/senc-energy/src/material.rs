//! Cloth materials: Lamé parameters, bending stiffness, areal density and thickness, with
//! conversion from Young's modulus and Poisson's ratio and HOOD's random sampling ranges.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::EnergyError;

/// A thin-shell cloth material.
///
/// Defaults (HOOD's): μ = 23600 Pa, λ = 44400 Pa, thickness 4.7e-4 m,
/// k_b = 3.9626e-5 (J, the bending stiffness multiplying θ²), ρ = 0.20022 kg/m².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Material {
    /// Lamé's second parameter (shear modulus) μ, Pa.
    pub mu: f64,
    /// Lamé's first parameter λ, Pa.
    pub lambda: f64,
    /// Shell thickness h, m (the stretching energy density is integrated over A·h).
    pub thickness: f64,
    /// Bending stiffness k_b, J.
    pub bending_stiffness: f64,
    /// Areal density ρ, kg/m².
    pub density: f64,
}

impl Default for Material {
    fn default() -> Self {
        Self { mu: 23600.0, lambda: 44400.0, thickness: 4.7e-4, bending_stiffness: 3.9626e-5, density: 0.20022 }
    }
}

/// HOOD's sampling ranges of the material for training.
pub mod hood_ranges {
    /// μ, log-uniform, Pa.
    pub const MU: [f64; 2] = [15909.0, 63636.0];
    /// λ, uniform, Pa.
    pub const LAMBDA: [f64; 2] = [3535.41, 93333.74];
    /// k_b, log-uniform, J.
    pub const BENDING: [f64; 2] = [6.37e-8, 1.314e-3];
    /// ρ, uniform, kg/m².
    pub const DENSITY: [f64; 2] = [0.0434, 0.7];
}

impl Material {
    /// From Young's modulus `young` (Pa) and Poisson's ratio `poisson` (−1 < ν < ½), with the
    /// 3D relations μ = E / (2(1+ν)), λ = Eν / ((1+ν)(1−2ν)); other fields default.
    pub fn from_young_poisson(young: f64, poisson: f64) -> Result<Self, EnergyError> {
        if !(young.is_finite() && young > 0.0) {
            return Err(EnergyError::InvalidParameter {
                name: "young",
                value: young,
                why: "must be finite and > 0 Pa",
            });
        }
        if !(poisson > -1.0 && poisson < 0.5) {
            return Err(EnergyError::InvalidParameter {
                name: "poisson",
                value: poisson,
                why: "must lie in (-1, 0.5)",
            });
        }
        Ok(Self {
            mu: young / (2.0 * (1.0 + poisson)),
            lambda: young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)),
            ..Self::default()
        })
    }

    /// A material drawn from HOOD's ranges (μ and k_b log-uniform, λ and ρ uniform);
    /// thickness stays at its default. Seed the generator for reproducibility.
    pub fn sample_hood(rng: &mut impl Rng) -> Self {
        let log_uniform = |rng: &mut dyn rand::RngCore, [a, b]: [f64; 2]| {
            let u: f64 = rng.random();
            (a.ln() + u * (b.ln() - a.ln())).exp()
        };
        let uniform = |rng: &mut dyn rand::RngCore, [a, b]: [f64; 2]| a + rng.random::<f64>() * (b - a);
        Self {
            mu: log_uniform(rng, hood_ranges::MU),
            lambda: uniform(rng, hood_ranges::LAMBDA),
            bending_stiffness: log_uniform(rng, hood_ranges::BENDING),
            density: uniform(rng, hood_ranges::DENSITY),
            ..Self::default()
        }
    }

    /// Checks every field is finite; μ, h, ρ > 0; λ, k_b ≥ 0.
    pub fn validate(&self) -> Result<(), EnergyError> {
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            ("material.mu", self.mu, self.mu > 0.0, "must be finite and > 0 Pa"),
            ("material.lambda", self.lambda, self.lambda >= 0.0, "must be finite and >= 0 Pa"),
            ("material.thickness", self.thickness, self.thickness > 0.0, "must be finite and > 0 m"),
            (
                "material.bending_stiffness",
                self.bending_stiffness,
                self.bending_stiffness >= 0.0,
                "must be finite and >= 0",
            ),
            ("material.density", self.density, self.density > 0.0, "must be finite and > 0 kg/m²"),
        ];
        for (name, value, ok, why) in checks {
            if !(ok && value.is_finite()) {
                return Err(EnergyError::InvalidParameter { name, value, why });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn young_poisson_round_trip() {
        let m = Material::from_young_poisson(1000.0, 0.25).unwrap();
        assert!((m.mu - 400.0).abs() < 1e-9);
        assert!((m.lambda - 400.0).abs() < 1e-9);
        assert!(Material::from_young_poisson(1000.0, 0.5).is_err());
        assert!(Material::from_young_poisson(-1.0, 0.3).is_err());
    }

    #[test]
    fn hood_samples_stay_in_range_and_are_seeded() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let a: Vec<Material> = (0..200).map(|_| Material::sample_hood(&mut rng)).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        assert_eq!(a[0], Material::sample_hood(&mut rng));
        for m in &a {
            assert!(m.mu >= hood_ranges::MU[0] && m.mu <= hood_ranges::MU[1]);
            assert!(m.lambda >= hood_ranges::LAMBDA[0] && m.lambda <= hood_ranges::LAMBDA[1]);
            assert!(m.bending_stiffness >= hood_ranges::BENDING[0] && m.bending_stiffness <= hood_ranges::BENDING[1]);
            assert!(m.density >= hood_ranges::DENSITY[0] && m.density <= hood_ranges::DENSITY[1]);
            m.validate().unwrap();
        }
        // log-uniform: the median of μ is near the geometric mean.
        let below = a.iter().filter(|m| m.mu < (hood_ranges::MU[0] * hood_ranges::MU[1]).sqrt()).count();
        assert!((60..140).contains(&below), "{below}");
    }
}
