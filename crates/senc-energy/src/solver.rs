//! The reference solver: Newton's method with a backtracking line search on the incremental
//! potential of one frame.
//!
//! Each iteration assembles the block-sparse, positive semi-definite Hessian approximation of
//! [`FrameEnergy::hessian`] (exact StVK projected per element, Gauss–Newton bending, inertia
//! `m/Δt² I`, collision, friction, and a curvature model of the self-collision term that
//! keeps its force from asking for metre-long steps where compressed cloth is held by
//! inertia alone), solves `H p = −g` by block-Jacobi preconditioned
//! conjugate gradients (no factorisation: the inertia term makes `H` well conditioned at
//! cloth time steps, so CG converges in tens of iterations, and no sparse-solver dependency
//! is needed), and backtracks on the true energy with an Armijo condition. When `p` is not a
//! descent direction (a term without Hessian dominates) it falls back to steepest descent.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use senc_geom::Vec3;

use crate::error::EnergyError;
use crate::model::{Breakdown, FrameEnergy};

/// Solver options.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolverOptions {
    /// Newton iteration budget (default 30).
    pub max_iterations: usize,
    /// Stop when the largest per-vertex gradient is below this, N (default 1e-9).
    pub gradient_tolerance: f64,
    /// Stop when the largest vertex step is below this, m (default 1e-9).
    pub step_tolerance: f64,
    /// CG relative residual (default 1e-4).
    pub cg_tolerance: f64,
    /// CG iteration cap per Newton step (default 200).
    pub cg_max_iterations: usize,
    /// Line-search halvings before giving up (default 40).
    pub max_backtracks: usize,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            gradient_tolerance: 1e-9,
            step_tolerance: 1e-9,
            cg_tolerance: 1e-4,
            cg_max_iterations: 200,
            max_backtracks: 40,
        }
    }
}

/// Why the solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The gradient is below tolerance.
    GradientTolerance,
    /// The accepted step is below tolerance.
    StepTolerance,
    /// The iteration budget is spent.
    IterationBudget,
    /// No step along the search direction decreases the energy (at the limit of floating
    /// point, or a non-smooth term): the last accepted iterate is returned.
    LineSearchFailed,
    /// The initial guess has a non-finite energy or gradient; nothing was done.
    NonFiniteStart,
}

/// What a solve did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolveReport {
    /// Newton iterations taken (accepted steps).
    pub iterations: usize,
    /// Energy at the initial guess, J.
    pub initial_energy: f64,
    /// Energy at the result, J (never above `initial_energy`).
    pub energy: f64,
    /// Largest per-vertex gradient norm at the result, N.
    pub gradient_norm: f64,
    /// Total CG iterations.
    pub cg_iterations: usize,
    /// Why it stopped.
    pub stop: StopReason,
    /// Breakdown at the result.
    pub breakdown: Breakdown,
    /// Wall time, s.
    pub seconds: f64,
}

fn max_norm(v: &[Vec3]) -> f64 {
    v.par_iter().map(|g| g.norm()).reduce(|| 0.0, f64::max)
}

/// Minimises `energy` from `x0`; returns the positions and a report. The result is always
/// finite (the last accepted iterate); errors only come from term evaluation (e.g. GIA).
pub fn solve(
    energy: &FrameEnergy<'_>,
    x0: &[Vec3],
    options: &SolverOptions,
) -> Result<(Vec<Vec3>, SolveReport), EnergyError> {
    let start = Instant::now();
    let n = x0.len();
    let mut x = x0.to_vec();
    let mut g = vec![Vec3::zeros(); n];
    let mut b = energy.evaluate(&x, Some(&mut g))?;
    let initial_energy = b.total;
    let report = |x: Vec<Vec3>, b: Breakdown, g: &[Vec3], iterations, cg_iterations, stop| {
        let r = SolveReport {
            iterations,
            initial_energy,
            energy: b.total,
            gradient_norm: max_norm(g),
            cg_iterations,
            stop,
            breakdown: b,
            seconds: start.elapsed().as_secs_f64(),
        };
        Ok((x, r))
    };
    if !b.total.is_finite() || g.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
        return report(x, b, &g, 0, 0, StopReason::NonFiniteStart);
    }
    let mut h = energy.hessian_pattern();
    let mut p = vec![Vec3::zeros(); n];
    let mut x_try = vec![Vec3::zeros(); n];
    let mut g_try = vec![Vec3::zeros(); n];
    let mut cg_total = 0;
    for it in 0..options.max_iterations {
        if max_norm(&g) <= options.gradient_tolerance {
            return report(x, b, &g, it, cg_total, StopReason::GradientTolerance);
        }
        energy.hessian(&x, &mut h)?;
        let rhs: Vec<Vec3> = g.iter().map(|v| -v).collect();
        cg_total += h.solve_pcg(&rhs, &mut p, options.cg_tolerance, options.cg_max_iterations);
        let mut slope = crate::hessian::dot(&p, &g);
        if slope.is_nan() || slope >= 0.0 || p.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
            // Not a descent direction: steepest descent, scaled by the Hessian diagonal.
            p.iter_mut().zip(&rhs).for_each(|(p, r)| *p = *r);
            let scale = 1.0 / h_diag_max(&h, n).max(1e-300);
            p.iter_mut().for_each(|v| *v *= scale);
            slope = crate::hessian::dot(&p, &g);
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..=options.max_backtracks {
            x_try.par_iter_mut().zip(&x).zip(&p).for_each(|((t, x), p)| *t = x + alpha * p);
            if let Ok(bt) = energy.evaluate(&x_try, Some(&mut g_try)) {
                if bt.total.is_finite() && bt.total <= b.total + 1e-4 * alpha * slope {
                    accepted = Some(bt);
                    break;
                }
            }
            alpha *= 0.5;
        }
        let Some(bt) = accepted else {
            return report(x, b, &g, it, cg_total, StopReason::LineSearchFailed);
        };
        let step = alpha * max_norm(&p);
        std::mem::swap(&mut x, &mut x_try);
        std::mem::swap(&mut g, &mut g_try);
        b = bt;
        if step <= options.step_tolerance {
            return report(x, b, &g, it + 1, cg_total, StopReason::StepTolerance);
        }
    }
    let iters = options.max_iterations;
    report(x, b, &g, iters, cg_total, StopReason::IterationBudget)
}

fn h_diag_max(h: &crate::hessian::BlockSparse, n: usize) -> f64 {
    let e = vec![Vec3::new(1.0, 1.0, 1.0); n];
    let mut y = vec![Vec3::zeros(); n];
    h.mul(&e, &mut y);
    max_norm(&y)
}
