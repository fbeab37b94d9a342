//! SENC's self-collision energy and the area ablation, both from one senc-gia query.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use senc_geom::{Closure, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace};

use crate::error::EnergyError;

/// Self-collision through Global Intersection Analysis on the hole-closed garment.
///
/// - Volume (SENC): `E = w_V · Σ_regions |6 V_r|` (J) with `V_r` the volume (m³) enclosed by
///   penetrating region r and `w_V` in J/m³ (SENC: 30000). Gradient `6 w_V ∂V/∂x` from
///   senc-gia, chained through the closure's centroid vertices.
/// - Area ablation ("w. area loss"): `E = w_A · A_pen` (J) with `A_pen` the area of the
///   penetrating faces (m²), `w_A` in J/m².
///
/// Domain: every finite `x`; errors from senc-gia are returned, never hidden. Each
/// evaluation costs exactly one GIA query, counted by [`SelfCollision::gia_calls`].
#[derive(Debug)]
pub struct SelfCollision {
    state: Mutex<(Closure, GiaWorkspace)>,
    options: GiaOptions,
    volume_weight: f64,
    area_weight: f64,
    calls: AtomicU64,
}

/// One self-collision evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SelfCollisionValue {
    /// `w_V |6V|`, J.
    pub volume_energy: f64,
    /// `w_A A_pen`, J.
    pub area_energy: f64,
}

impl SelfCollision {
    /// The term on `closure` (the garment with its chosen holes closed).
    pub fn new(closure: Closure, options: GiaOptions, volume_weight: f64, area_weight: f64) -> Self {
        let ws = GiaWorkspace::new(&closure);
        Self { state: Mutex::new((closure, ws)), options, volume_weight, area_weight, calls: AtomicU64::new(0) }
    }

    /// GIA queries made so far.
    pub fn gia_calls(&self) -> u64 {
        self.calls.load(Ordering::Relaxed)
    }

    /// Whether the volume and area parts are present.
    pub fn parts(&self) -> (bool, bool) {
        (self.volume_weight > 0.0, self.area_weight > 0.0)
    }

    /// Energies (J), adding the gradient into `grad` when given.
    pub fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> Result<SelfCollisionValue, EnergyError> {
        let mut guard = self.state.lock().unwrap_or_else(|p| p.into_inner());
        let (closure, ws) = &mut *guard;
        closure.update(x)?;
        self.calls.fetch_add(1, Ordering::Relaxed);
        let pen = ws.penetration(closure, &self.options)?;
        if let Some(g) = grad {
            for (i, gi) in g.iter_mut().enumerate() {
                if let Some(v) = pen.gradient.get(i) {
                    *gi += v * (6.0 * self.volume_weight);
                }
                if self.area_weight > 0.0 {
                    if let Some(a) = pen.area_gradient.get(i) {
                        *gi += a * self.area_weight;
                    }
                }
            }
        }
        Ok(SelfCollisionValue {
            volume_energy: 6.0 * self.volume_weight * pen.volume.abs(),
            area_energy: self.area_weight * pen.area,
        })
    }
}
