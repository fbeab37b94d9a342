//! Global gradient-norm clipping (HOOD clips the norm of all parameters' gradients taken
//! together; burn's built-in clipping works per tensor).

use senc_model::burn::module::{Module, ModuleVisitor, Param};
use senc_model::burn::optim::GradientsParams;
use senc_model::burn::tensor::Tensor;

struct NormSq<'a> {
    grads: &'a GradientsParams,
    sum: f64,
}

impl ModuleVisitor for NormSq<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            let s = senc_model::convert::tensor_to_f64(g.powi_scalar(2).sum());
            self.sum += s.first().copied().unwrap_or(f64::NAN);
        }
    }
}

struct Scale<'a> {
    grads: &'a mut GradientsParams,
    factor: f32,
}

impl ModuleVisitor for Scale<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.remove::<D>(param.id) {
            self.grads.register::<D>(param.id, g.mul_scalar(self.factor));
        }
    }
}

/// The global L2 norm `sqrt(Σ_params ‖∂L/∂θ‖²)` of `grads` over the parameters of `module`
/// (NaN when any gradient is not finite).
pub fn global_norm<M: Module>(module: &M, grads: &GradientsParams) -> f64 {
    let mut v = NormSq { grads, sum: 0.0 };
    module.visit(&mut v);
    v.sum.sqrt()
}

/// Scales every gradient by `max_norm / norm` when the global norm exceeds `max_norm`;
/// returns the norm before clipping.
pub fn clip_global_norm<M: Module>(module: &M, grads: &mut GradientsParams, max_norm: f64) -> f64 {
    let norm = global_norm(module, grads);
    if norm.is_finite() && norm > max_norm {
        let mut s = Scale { grads, factor: (max_norm / norm) as f32 };
        module.visit(&mut s);
    }
    norm
}

struct ParamNormSq {
    sum: f64,
}

impl ModuleVisitor for ParamNormSq {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let s = senc_model::convert::tensor_to_f64(param.val().powi_scalar(2).sum());
        self.sum += s.first().copied().unwrap_or(f64::NAN);
    }
}

/// The L2 norm of all parameters of `module` (NaN when any weight is not finite).
pub fn param_norm<M: Module>(module: &M) -> f64 {
    let mut v = ParamNormSq { sum: 0.0 };
    module.visit(&mut v);
    v.sum.sqrt()
}

struct Flatten {
    values: Vec<f64>,
}

impl ModuleVisitor for Flatten {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        self.values.extend(senc_model::convert::tensor_to_f64(param.val()));
    }
}

/// Every float parameter of `module`, flattened in visiting order (for comparing weights).
pub fn flat_params<M: Module>(module: &M) -> Vec<f64> {
    let mut v = Flatten { values: Vec::new() };
    module.visit(&mut v);
    v.values
}
