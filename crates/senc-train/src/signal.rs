//! The training signal: what the surrogate loss `Σ x ⊙ s` is given as `s`, the outside
//! gradient at the predicted next frame `x`: the energy gradient `g = ∂E/∂x` (HOOD, SENC),
//! plus, with `[train] newton_weight = β > 0`, `β (M / Δt²) d` with `d ≈ H⁻¹ g` the Newton
//! step from the prediction (`H` the solver's PSD-projected Hessian, a few block-Jacobi PCG
//! iterations; `M` the lumped masses, `Δt` the step). With `β = 0` no Hessian is built.
//!
//! # Why the Newton signal
//! Near the minimiser `x*` of the incremental potential, `g(x) ≈ H (x − x*)`. The plain
//! signal weighs an error along each eigenvector of `H` by its eigenvalue: a stretching
//! mode of stiffness `k` costs `k`, a rigid drift costs only the inertia's `m / Δt²` per
//! vertex (the elastic terms do not resist translation), so a drift that compounds over a
//! rollout is almost invisible next to the stiff local errors.
//!
//! With `d = H⁻¹ g ≈ x − x*` the error `δ = x − x*` of the prediction,
//! `s = (H + β M / Δt²) δ`: the gradient of `½ δᵀ H δ + ½ β δᵀ (M / Δt²) δ`, the energy's
//! own second-order error plus `β` times the error measured in the inertia's metric. In
//! the eigenbasis of `H` relative to `M / Δt²` (eigenvalue `λ`, with `λ = 1` for a rigid
//! translation) a mode's error is weighed `λ + β` instead of `λ`: the drift gains the
//! factor `1 + β` on the stiff modes' `λ + β ≈ λ`. `β = 0` is the plain gradient; `β → ∞`
//! measures every mode as a displacement (`s ∝ (M / Δt²) d`), which neglects the stiff
//! modes entirely (large stretching and collision errors cost as little as small drifts).
//! The metric `M / Δt²` keeps `s` in newtons, the plain gradient's units. The fixed point
//! is unchanged: `s = 0` exactly where `g = 0` (`H` positive definite on the free vertices;
//! pinned rows are the identity's and their gradient is zero).
//! Self-collision enters through `g` and through the curvature model the solver's Hessian
//! gives it (see `senc_energy::terms::self_collision`); repulsion through `g` only.

use senc_energy::FrameEnergy;
use senc_geom::Vec3;

/// Replaces the energy gradient `grad` at `x` by `grad + β (M / Δt²) H⁻¹ grad` (at most
/// `cg_iterations` block-Jacobi PCG iterations to relative residual `cg_tolerance`).
/// `masses` are the lumped vertex masses, `dt` the step, `beta` the Newton term's weight.
/// Returns the PCG iterations used, or the error of the self-collision query the Hessian
/// needs.
pub fn newton_signal(
    fe: &FrameEnergy<'_>,
    x: &[Vec3],
    masses: &[f64],
    dt: f64,
    beta: f64,
    grad: &mut [Vec3],
    cg_iterations: usize,
    cg_tolerance: f64,
) -> Result<usize, senc_energy::EnergyError> {
    let mut h = fe.hessian_pattern();
    fe.hessian(x, &mut h)?;
    let mut d = vec![Vec3::zeros(); grad.len()];
    let used = h.solve_pcg(grad, &mut d, cg_tolerance, cg_iterations);
    for ((g, d), m) in grad.iter_mut().zip(&d).zip(masses) {
        *g += d * (beta * *m / (dt * dt));
    }
    Ok(used)
}

#[cfg(test)]
mod tests {
    use super::*;
    use senc_energy::{EnergyConfig, EnergyModel};

    /// A flat sheet at rest (no self-collision: its fan closure would lie in its plane): the elastic terms vanish and do not resist translation, so a
    /// prediction displaced rigidly by `δ` from free flight has `g = M δ / Δt²` and
    /// `H⁻¹ g = δ` exactly; the signal is `(1 + β) M δ / Δt²`. At free flight itself
    /// (zero gravity) the signal is zero.
    #[test]
    fn a_rigid_drift_weighs_one_plus_beta_times_and_the_minimiser_stays() {
        let rest = senc_testmesh::sheet(6, 0.5, 1.0, 0.0, 3);
        let mut config = EnergyConfig { gravity: [0.0; 3], dt: 1.0 / 30.0, ..Default::default() };
        config.self_collision.weight = 0.0;
        let em = EnergyModel::new(&rest, &config, None).unwrap();
        let x0 = rest.positions().to_vec();
        let fe = em.frame(&x0, &x0, None).unwrap();
        let delta = Vec3::new(0.003, -0.01, 0.002);
        let x: Vec<Vec3> = x0.iter().map(|p| p + delta).collect();
        let scale = em.masses().iter().cloned().fold(0.0, f64::max) * delta.norm() / (config.dt * config.dt);
        for beta in [0.0, 1.0, 30.0] {
            let mut s = vec![Vec3::zeros(); x.len()];
            fe.evaluate(&x, Some(&mut s)).unwrap();
            newton_signal(&fe, &x, em.masses(), config.dt, beta, &mut s, 200, 1e-12).unwrap();
            for (i, (s, m)) in s.iter().zip(em.masses()).enumerate() {
                let want = delta * ((1.0 + beta) * m / (config.dt * config.dt));
                assert!((s - want).norm() <= 1e-6 * want.norm(), "β = {beta}, vertex {i}: {s:?}, want {want:?}");
            }
            let mut s0 = vec![Vec3::zeros(); x.len()];
            fe.evaluate(&x0, Some(&mut s0)).unwrap();
            newton_signal(&fe, &x0, em.masses(), config.dt, beta, &mut s0, 200, 1e-12).unwrap();
            let worst = s0.iter().map(|v| v.norm()).fold(0.0, f64::max);
            assert!(worst <= 1e-9 * scale, "β = {beta}: the minimiser's signal is {worst:e}, not zero");
        }
    }
}
