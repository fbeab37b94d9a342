//! LayerNorm with a hand-written backward pass for training on the CPU.
//!
//! burn's autodiff differentiates LayerNorm through its decomposition (mean, subtract,
//! square, mean, sqrt, divide, scale, shift): about ten `[n, L]` temporaries and one
//! recorded node each, so on the flex backend its backward took 21× its forward
//! (`reports/bench/model-small.md`). This module registers LayerNorm as one autodiff node
//! on `Autodiff<Flex>` whose backward is a single pass over the rows:
//!
//! with `x̂ = (x − μ)·r`, `r = (σ² + ε)^(−1/2)` per row and `u = ∂L/∂y ⊙ γ`,
//! - `∂L/∂x = r · (u − mean(u) − x̂ · mean(u ⊙ x̂))` (row-wise means over the L features),
//! - `∂L/∂γ = Σ_rows ∂L/∂y ⊙ x̂`, `∂L/∂β = Σ_rows ∂L/∂y`.
//!
//! The forward keeps `x̂` and `r` as the node's state (one `[n, L]` and one `[n]` buffer).
//! On any other backend, or with gradient checkpointing, [`layer_norm`] returns `None` and
//! the caller uses burn's own differentiable LayerNorm.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::flex::FlexTensor;
use burn::backend::tensor::FloatTensor;
use burn::backend::{Autodiff, Flex, TensorMetadata};
use burn::nn::LayerNorm;
use burn::tensor::{Tensor, TensorData};
use rayon::prelude::*;

use crate::fused::{row_sum, simd, CHUNK_ROWS, LANES};
use crate::network::LAYER_NORM_EPSILON;

type Ad = Autodiff<Flex, NoCheckpointing>;

/// `norm(x)` over the last axis as one autodiff node with a hand-written backward.
///
/// Returns `None` (and consumes nothing the caller still needs: `x` is cloned) when `x` or
/// the norm's parameters are not tracked `f32` tensors of the flex autodiff backend without
/// checkpointing; the caller then falls back to burn's decomposition. `x`: `[n, L]` → `[n, L]`.
pub fn layer_norm(x: &Tensor<2>, norm: &LayerNorm) -> Option<Tensor<2>> {
    if !supported(x) {
        return None;
    }
    let xp = x.clone().try_into_primitive::<Ad>().ok()?;
    let gamma = norm.gamma.val().try_into_primitive::<Ad>().ok()?;
    let beta = match &norm.beta {
        Some(b) => Some(b.val().try_into_primitive::<Ad>().ok()?),
        None => None,
    };
    let out = match beta {
        Some(beta) => forward_op::<3>([xp, gamma, beta])?,
        None => forward_op::<2>([xp, gamma])?,
    };
    Some(Tensor::from_primitive::<Ad>(out))
}

/// Whether `x` lives on the backend this module differentiates (flex autodiff, no
/// checkpointing, `f32`). Cheap: tensors are reference-counted.
pub fn supported(x: &Tensor<2>) -> bool {
    x.dtype() == burn::tensor::DType::F32 && x.clone().try_into_primitive::<Ad>().is_ok()
}

/// The autodiff node. `N` = 3 with β, 2 without; parents are `[x, γ, β]`.
#[derive(Debug)]
struct LayerNormBackward<const N: usize>;

/// What the backward pass needs: `x̂` `[n·L]`, `r` `[n]`, `γ` `[L]`.
#[derive(Debug, Clone)]
struct LayerNormState {
    x_hat: Arc<Vec<f32>>,
    inv_std: Arc<Vec<f32>>,
    gamma: Arc<Vec<f32>>,
}

fn forward_op<const N: usize>(inputs: [FloatTensor<Ad>; N]) -> Option<FloatTensor<Ad>>
where
    LayerNormBackward<N>: Backward<Flex, N, State = LayerNormState>,
{
    let nodes = inputs.each_ref().map(|t| t.node());
    let mut prims = inputs.into_iter().map(|t| t.into_primitive());
    let x = prims.next()?;
    let gamma = prims.next()?;
    let beta = prims.next();
    let shape = x.shape().clone();
    let width = *shape.last()?;
    let (x, gamma) = (contiguous(x)?, contiguous(gamma)?);
    let beta = match beta {
        Some(b) => Some(contiguous(b)?),
        None => None,
    };
    let (xs, gs) = (x.as_slice::<f32>()?, gamma.as_slice::<f32>()?);
    let bs = match &beta {
        Some(b) => Some(b.as_slice::<f32>()?),
        None => None,
    };
    if width == 0 || gs.len() != width || bs.is_some_and(|b| b.len() != width) {
        return None;
    }
    let mut y = vec![0.0f32; xs.len()];
    match LayerNormBackward::<N>.prepare::<NoCheckpointing>(nodes).compute_bound().stateful() {
        OpsKind::Tracked(prep) => {
            let mut x_hat = vec![0.0f32; xs.len()];
            let mut inv_std = vec![0.0f32; xs.len() / width];
            normalise(xs, gs, bs, width, &mut y, Some((&mut x_hat, &mut inv_std)));
            let state =
                LayerNormState { x_hat: Arc::new(x_hat), inv_std: Arc::new(inv_std), gamma: Arc::new(gs.to_vec()) };
            Some(prep.finish(state, flex(y, shape.to_vec())))
        }
        OpsKind::UnTracked(prep) => {
            normalise(xs, gs, bs, width, &mut y, None);
            Some(prep.finish(flex(y, shape.to_vec())))
        }
    }
}

impl<const N: usize> Backward<Flex, N> for LayerNormBackward<N> {
    type State = LayerNormState;

    fn backward(self, ops: Ops<Self::State, N>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let grad = grads.consume::<Flex>(&ops.node);
        let st = ops.state;
        let width = st.gamma.len();
        let shape = grad.shape().to_vec();
        // The incoming gradient is an f32 tensor of this node's shape (burn's invariant).
        let Some(grad) = contiguous(grad) else { return };
        let Some(dy) = grad.as_slice::<f32>() else { return };
        let (dx, dgamma, dbeta) = backward_rows(dy, &st, width);
        let mut outs = [Some((dx, shape)), Some((dgamma, vec![width])), Some((dbeta, vec![width]))];
        for (parent, out) in ops.parents.iter().zip(outs.iter_mut()) {
            if let (Some(node), Some((values, shape))) = (parent, out.take()) {
                grads.register::<Flex>(node.id, flex(values, shape));
            }
        }
    }
}

/// `t` itself when its `f32` values are one contiguous slice, else a contiguous copy;
/// `None` for other element types.
fn contiguous(t: FlexTensor) -> Option<FlexTensor> {
    if t.dtype() != burn::tensor::DType::F32 {
        None
    } else if t.as_slice::<f32>().is_some() {
        Some(t)
    } else {
        Some(t.to_contiguous())
    }
}

fn flex(values: Vec<f32>, shape: Vec<usize>) -> FlexTensor {
    FlexTensor::from_data(TensorData::new(values, shape))
}

/// `y = x̂ γ + β` row by row, rows in parallel; also writes `x̂` and `r` when asked.
fn normalise(
    x: &[f32],
    gamma: &[f32],
    beta: Option<&[f32]>,
    width: usize,
    y: &mut [f32],
    keep: Option<(&mut [f32], &mut [f32])>,
) {
    let chunk = CHUNK_ROWS * width;
    let row = |xr: &[f32], yr: &mut [f32]| -> f32 {
        let n = width as f32;
        let mean = row_sum(xr, |v| v) / n;
        let var = row_sum(xr, |v| (v - mean) * (v - mean)) / n;
        let r = 1.0 / (var + LAYER_NORM_EPSILON as f32).sqrt();
        for (o, &v) in yr.iter_mut().zip(xr) {
            *o = (v - mean) * r;
        }
        r
    };
    let affine = |yr: &mut [f32]| match beta {
        Some(b) => yr.iter_mut().zip(gamma).zip(b).for_each(|((o, g), b)| *o = *o * g + b),
        None => yr.iter_mut().zip(gamma).for_each(|(o, g)| *o *= g),
    };
    match keep {
        Some((x_hat, inv_std)) => {
            (
                y.par_chunks_mut(chunk),
                x.par_chunks(chunk),
                x_hat.par_chunks_mut(chunk),
                inv_std.par_chunks_mut(CHUNK_ROWS),
            )
                .into_par_iter()
                .for_each(|(yc, xc, hc, rc)| {
                    simd(|| {
                        for (((yr, xr), hr), r) in yc
                            .chunks_exact_mut(width)
                            .zip(xc.chunks_exact(width))
                            .zip(hc.chunks_exact_mut(width))
                            .zip(rc)
                        {
                            *r = row(xr, hr);
                            yr.copy_from_slice(hr);
                            affine(yr);
                        }
                    })
                });
        }
        None => {
            (y.par_chunks_mut(chunk), x.par_chunks(chunk)).into_par_iter().for_each(|(yc, xc)| {
                simd(|| {
                    for (yr, xr) in yc.chunks_exact_mut(width).zip(xc.chunks_exact(width)) {
                        row(xr, yr);
                        affine(yr);
                    }
                })
            });
        }
    }
}

/// `(∂L/∂x, ∂L/∂γ, ∂L/∂β)` from `∂L/∂y`; rows in parallel, the parameter sums reduced over
/// chunks in a fixed order (the result does not depend on the thread count).
fn backward_rows(dy: &[f32], st: &LayerNormState, width: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let chunk = CHUNK_ROWS * width;
    let gamma = st.gamma.as_slice();
    let mut dx = vec![0.0f32; dy.len()];
    let partial: Vec<(Vec<f32>, Vec<f32>)> =
        (dx.par_chunks_mut(chunk), dy.par_chunks(chunk), st.x_hat.par_chunks(chunk), st.inv_std.par_chunks(CHUNK_ROWS))
            .into_par_iter()
            .map(|(dxc, dyc, hc, rc)| {
                let mut dg = vec![0.0f32; width];
                let mut db = vec![0.0f32; width];
                simd(|| {
                    for (((dxr, dyr), hr), &r) in
                        dxc.chunks_exact_mut(width).zip(dyc.chunks_exact(width)).zip(hc.chunks_exact(width)).zip(rc)
                    {
                        for ((u, &d), &g) in dxr.iter_mut().zip(dyr).zip(gamma) {
                            *u = d * g;
                        }
                        for (((gs, bs), &d), &h) in dg.iter_mut().zip(db.iter_mut()).zip(dyr).zip(hr) {
                            *gs += d * h;
                            *bs += d;
                        }
                        let n = width as f32;
                        let m1 = row_sum(dxr, |u| u) / n;
                        let m2 = row_dot(dxr, hr) / n;
                        for (u, &h) in dxr.iter_mut().zip(hr) {
                            *u = r * (*u - m1 - h * m2);
                        }
                    }
                });
                (dg, db)
            })
            .collect();
    let mut dgamma = vec![0.0f32; width];
    let mut dbeta = vec![0.0f32; width];
    for (dg, db) in &partial {
        dgamma.iter_mut().zip(dg).for_each(|(a, b)| *a += b);
        dbeta.iter_mut().zip(db).for_each(|(a, b)| *a += b);
    }
    (dx, dgamma, dbeta)
}

/// `Σ a_j b_j` with [`LANES`] partial sums (vectorisable, like `fused::row_sum`).
#[inline(always)]
fn row_dot(a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [0.0f32; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in ca.zip(cb) {
        for ((l, p), q) in lanes.iter_mut().zip(x).zip(y) {
            *l += p * q;
        }
    }
    lanes.iter().sum::<f32>() + tail
}
