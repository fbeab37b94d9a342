//! The one finite-difference gradient check used by every term's tests (public so that
//! downstream crates check their own gradients the same way).

use senc_geom::Vec3;

/// Result of [`check_gradient`].
#[derive(Debug, Clone, PartialEq)]
pub struct GradientCheck {
    /// Largest `|analytic − numeric|` over the checked components, J/m.
    pub max_error: f64,
    /// The tolerance it was compared against, J/m.
    pub tolerance: f64,
    /// Component (vertex, axis) of the largest error.
    pub worst: (usize, usize),
}

impl GradientCheck {
    /// Whether every component was within tolerance.
    pub fn passed(&self) -> bool {
        self.max_error <= self.tolerance
    }
}

/// Compares `grad` (the analytic gradient at `x`) against central differences
/// `(E(x + h e_k) − E(x − h e_k)) / 2h` of `energy` on every component (or on `max_checked`
/// of them, spread evenly). The tolerance is `rel × max(‖grad‖_∞, numeric scale) + abs`, so
/// it scales with the gradient's size.
pub fn check_gradient(
    energy: &mut dyn FnMut(&[Vec3]) -> f64,
    x: &[Vec3],
    grad: &[Vec3],
    h: f64,
    rel: f64,
    abs: f64,
) -> GradientCheck {
    let mut xp = x.to_vec();
    let mut max_error: f64 = 0.0;
    let mut worst = (0, 0);
    let mut scale: f64 = grad.iter().flat_map(|g| g.iter().map(|c| c.abs())).fold(0.0, f64::max);
    let mut numeric = vec![[0.0; 3]; x.len()];
    for i in 0..x.len() {
        for a in 0..3 {
            xp[i][a] = x[i][a] + h;
            let ep = energy(&xp);
            xp[i][a] = x[i][a] - h;
            let em = energy(&xp);
            xp[i][a] = x[i][a];
            numeric[i][a] = (ep - em) / (2.0 * h);
            scale = scale.max(numeric[i][a].abs());
        }
    }
    for i in 0..x.len() {
        for a in 0..3 {
            let err = (numeric[i][a] - grad[i][a]).abs();
            if err > max_error || err.is_nan() {
                max_error = if err.is_nan() { f64::INFINITY } else { err };
                worst = (i, a);
            }
        }
    }
    GradientCheck { max_error, tolerance: rel * scale + abs, worst }
}

/// Asserts that a gradient passes [`check_gradient`], printing the worst component.
#[macro_export]
macro_rules! assert_gradient {
    ($energy:expr, $x:expr, $grad:expr, h = $h:expr, rel = $rel:expr) => {{
        let c = $crate::fd::check_gradient(&mut $energy, $x, $grad, $h, $rel, 1e-300);
        assert!(
            c.passed(),
            "gradient check failed: max error {:e} > tolerance {:e} at (vertex, axis) {:?}",
            c.max_error,
            c.tolerance,
            c.worst
        );
        c
    }};
}
