//! The surrogate loss: how a gradient computed outside burn (the f64 energies of
//! senc-energy) trains the network.
//!
//! For predicted positions `x(θ)` and a constant `g = ∂E/∂x` evaluated at the prediction,
//! `L(θ) = Σ_ik x_ik(θ) g_ik` has `∂L/∂θ = Σ_ik g_ik ∂x_ik/∂θ = ∂E/∂θ` (chain rule), so one
//! backward pass of `L` gives the energy's parameter gradient.

use burn::tensor::{Gradients, Tensor};
use senc_geom::Vec3;

use crate::convert::vec3_tensor;
use crate::ModelError;

/// `Σ x ⊙ g` as a one-element tensor; `x` is `[n, 3]` (tracked), `g` has `n` rows (held
/// constant: it carries no autodiff graph).
pub fn surrogate_loss(x: Tensor<2>, g: &[Vec3]) -> Result<Tensor<1>, ModelError> {
    let [n, _] = x.dims();
    if g.len() != n {
        return Err(ModelError::GradientShape { got: g.len(), expected: n });
    }
    let g = vec3_tensor(g, &x.device()).detach(); // [n, 3], constant
    Ok((x * g).sum())
}

/// Backpropagates the surrogate loss: the gradients of every tracked parameter that `x`
/// depends on, ready for `GradientsParams::from_grads` and an optimiser step.
pub fn surrogate_backward(x: Tensor<2>, g: &[Vec3]) -> Result<Gradients, ModelError> {
    Ok(surrogate_loss(x, g)?.backward())
}
