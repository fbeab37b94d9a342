//! The burn network: encoders, message-passing blocks with one message MLP per edge type,
//! and the decoder. f32 throughout; it only ever sees [`GraphTensors`].
//!
//! Every MLP whose input is a concatenation `[a, b, c]` instead holds one weight block per
//! part and sums `a·W_a + b·W_b + c·W_c + bias`, which equals the first layer applied to the
//! concatenation. For an edge MLP the node parts are multiplied on the node rows and then
//! gathered, `(h·W_r)[r] + (h·W_s)[s]`, which is cheaper than gathering first because there
//! are several times more edges than nodes, and it avoids `cat` (slow on the flex backend).

use burn::config::Config;
use burn::module::Module;
use burn::nn::{LayerNorm, LayerNormConfig, Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::module::linear;
use burn::tensor::{Device, IndexingUpdateOp, Tensor};

use crate::convert::GraphTensors;
use crate::graph::{EDGE_FEATURES, MAX_COARSE_LEVELS, N_EDGE_TYPES};

/// Sizes of the network. Saved with every checkpoint.
#[derive(Config, Debug, PartialEq)]
pub struct ModelConfig {
    /// Width of every latent vector (HOOD: 128).
    #[config(default = 128)]
    pub latent: usize,
    /// Number of message-passing blocks (HOOD: 15).
    #[config(default = 15)]
    pub blocks: usize,
    /// Hidden layers per MLP (HOOD: 2): an MLP is `in → L`, then `hidden_layers − 1` times
    /// `L → L`, then `L → out`, with ReLU between.
    #[config(default = 2)]
    pub hidden_layers: usize,
    /// LayerNorm on the output of every MLP except the decoder's (HOOD: yes).
    #[config(default = true)]
    pub layer_norm: bool,
    /// Coarse levels of HOOD's hierarchy (0: none, at most `MAX_COARSE_LEVELS`). With `k > 0`
    /// the blocks cycle through the levels `0, 1, …, k, k−1, …, 1, 0, 1, …` and the last
    /// block is on level 0 ([`ModelConfig::block_levels`]).
    #[config(default = 0)]
    pub coarse_levels: usize,
}

impl ModelConfig {
    /// HOOD's size: latent 128, 15 blocks, 2 hidden layers, LayerNorm.
    pub fn hood() -> Self {
        Self::new()
    }

    /// A size that runs at interactive rates on 2 CPU cores: latent 32, 4 blocks, 1 hidden
    /// layer, LayerNorm.
    pub fn small_cpu() -> Self {
        Self::new().with_latent(32).with_blocks(4).with_hidden_layers(1)
    }

    /// The level each block passes messages on: level 0 uses the mesh, body and
    /// self-collision edges, level `ℓ > 0` the coarse edges of level `ℓ` only.
    pub fn block_levels(&self) -> Vec<usize> {
        let k = self.coarse_levels.min(MAX_COARSE_LEVELS);
        let mut levels: Vec<usize> = (0..self.blocks)
            .map(|b| {
                if k == 0 {
                    0
                } else {
                    let p = b % (2 * k);
                    if p <= k {
                        p
                    } else {
                        2 * k - p
                    }
                }
            })
            .collect();
        if let Some(last) = levels.last_mut() {
            *last = 0;
        }
        levels
    }

    /// Builds a freshly initialised network for graphs of `node_features` node columns
    /// ([`crate::GraphConfig::node_features`]) on `device` (burn's default initialisers;
    /// seed the device first with `device.seed(..)` for reproducible weights).
    pub fn init(&self, node_features: usize, device: &Device) -> Network {
        let l = self.latent.max(1);
        let n_types = N_EDGE_TYPES + self.coarse_levels.min(MAX_COARSE_LEVELS);
        Network {
            node_encoder: Mlp::new(&[node_features], l, l, self, self.layer_norm, device),
            edge_encoders: (0..n_types)
                .map(|_| Mlp::new(&[EDGE_FEATURES], l, l, self, self.layer_norm, device))
                .collect(),
            blocks: self
                .block_levels()
                .into_iter()
                .map(|level| {
                    let n_edge_mlps = if level == 0 { N_EDGE_TYPES } else { 1 };
                    Block {
                        level,
                        // [e, h_receiver, h_sender]
                        edges: (0..n_edge_mlps)
                            .map(|_| Mlp::new(&[l, l, l], l, l, self, self.layer_norm, device))
                            .collect(),
                        // [h, Σe' per edge type of this level]
                        node: Mlp::new(&vec![l; 1 + n_edge_mlps], l, l, self, self.layer_norm, device),
                    }
                })
                .collect(),
            decoder: Mlp::new(&[l], l, 3, self, false, device),
        }
    }
}

/// A multilayer perceptron whose first layer takes its input in parts (see the module docs).
#[derive(Module, Debug)]
pub struct Mlp {
    /// One weight block per input part; only the first carries the bias.
    pub(crate) first: Vec<Linear>,
    /// The remaining layers.
    pub(crate) layers: Vec<Linear>,
    pub(crate) norm: Option<LayerNorm>,
}

impl Mlp {
    fn new(parts: &[usize], hidden: usize, out: usize, c: &ModelConfig, norm: bool, device: &Device) -> Self {
        let first = parts
            .iter()
            .enumerate()
            .map(|(k, &p)| LinearConfig::new(p, hidden).with_bias(k == 0).init(device))
            .collect();
        let n_hidden = c.hidden_layers.max(1);
        let mut layers: Vec<Linear> = (1..n_hidden).map(|_| LinearConfig::new(hidden, hidden).init(device)).collect();
        layers.push(LinearConfig::new(hidden, out).init(device));
        let norm = norm.then(|| LayerNormConfig::new(out).with_epsilon(LAYER_NORM_EPSILON).init(device));
        Self { first, layers, norm }
    }

    /// The first layer's contribution of input part `k`: `x·W_k` (`+ b` for `k = 0`).
    /// `[n, d_k] → [n, hidden]`.
    fn part(&self, k: usize, x: Tensor<2>) -> Tensor<2> {
        self.first[k].forward(x)
    }

    /// Everything after the first layer's pre-activation: ReLU, the other layers, LayerNorm.
    /// `[n, hidden] → [n, out]`.
    ///
    /// Training on the CPU (flex autodiff) uses [`crate::layer_norm`], one autodiff node with
    /// a hand-written backward; other autodiff backends run the last layer and the norm as
    /// [`linear_layer_norm`] (cheaper to differentiate than burn's decomposition); inference
    /// uses burn's fused LayerNorm kernel.
    fn finish(&self, pre: Tensor<2>) -> Tensor<2> {
        let mut x = pre;
        let (last, inner) = self.layers.split_last().expect("an MLP has at least one layer");
        for layer in inner {
            x = layer.forward(relu(x));
        }
        match &self.norm {
            Some(norm) if crate::layer_norm::supported(&x) => {
                let pre = last.forward(relu(x));
                crate::layer_norm::layer_norm(&pre, norm).unwrap_or_else(|| norm.forward(pre))
            }
            Some(norm) if x.is_autodiff() => linear_layer_norm(relu(x), last, norm),
            Some(norm) => norm.forward(last.forward(relu(x))),
            None => last.forward(relu(x)),
        }
    }

    /// The whole MLP on a single-part input. `[n, d_0] → [n, out]`.
    fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        self.finish(self.part(0, x))
    }
}

/// The ε of every LayerNorm (burn's default), added to the variance.
pub const LAYER_NORM_EPSILON: f64 = 1e-5;

/// `LayerNorm(x·W + b)` written so that its autodiff graph is cheap: the mean subtraction is
/// folded into the layer, `c = x·(W − W·1/L·1ᵀ) + (b − mean b)` (each row of `c` then has mean
/// zero exactly, up to rounding), so no `[n, L]` broadcast subtraction and no division is
/// recorded: `y = c · (mean(c²) + ε)^(−1/2) · γ + β`.
///
/// Equal to burn's `norm.forward(layer.forward(x))` to f32 rounding, in values and gradients
/// (tested). `x`: `[n, d_in]`, weight `[d_in, L]` → `[n, L]`.
pub fn linear_layer_norm(x: Tensor<2>, layer: &Linear, norm: &LayerNorm) -> Tensor<2> {
    let w = layer.weight.val(); // [d_in, L]
    let w_centred = w.clone() - w.mean_dim(1); // [d_in, L], rows of mean 0
    let b_centred = layer.bias.as_ref().map(|b| {
        let b = b.val(); // [L]
        b.clone() - b.mean()
    });
    let c = linear(x, w_centred, b_centred); // [n, L], rows of mean 0
    let inv_std = (c.clone().square().mean_dim(1) + LAYER_NORM_EPSILON).sqrt().recip(); // [n, 1]
    let y = c * inv_std * norm.gamma.val().unsqueeze::<2>(); // [n, L]
    match &norm.beta {
        Some(beta) => y + beta.val().unsqueeze::<2>(),
        None => y,
    }
}

/// One message-passing block.
#[derive(Module, Debug)]
pub struct Block {
    /// The hierarchy level it works on (0: mesh, body and self edges).
    pub(crate) level: usize,
    pub(crate) edges: Vec<Mlp>,
    pub(crate) node: Mlp,
}

impl Block {
    /// The edge-type indices this block passes messages on, in the order of its edge MLPs:
    /// mesh, body and self on level 0, the level's coarse edges on level `ℓ > 0`.
    pub(crate) fn edge_types(&self) -> Vec<usize> {
        if self.level == 0 {
            (0..N_EDGE_TYPES).collect()
        } else {
            vec![2 + self.level]
        }
    }
}

/// The whole network. Build it with [`ModelConfig::init`].
#[derive(Module, Debug)]
pub struct Network {
    pub(crate) node_encoder: Mlp,
    pub(crate) edge_encoders: Vec<Mlp>,
    pub(crate) blocks: Vec<Block>,
    pub(crate) decoder: Mlp,
}

impl Network {
    /// The same network with the decoder's last layer (weights and bias) set to zero, so
    /// that it predicts the output normaliser's mean for every vertex: a smooth free-flight
    /// step instead of independent per-vertex noise, whose stretching energy is orders of
    /// magnitude above any physical step. The last layer still receives gradients, so
    /// training moves off zero on its first step.
    pub fn with_zero_output(mut self) -> Self {
        if let Some(last) = self.decoder.layers.last_mut() {
            last.weight = last.weight.clone().map(|w| w.zeros_like().require_grad());
            last.bias = last.bias.take().map(|b| b.map(|t| t.zeros_like().require_grad()));
        }
        self
    }

    /// Runs the network on one graph and returns the normalised output for the cloth nodes.
    ///
    /// # Shapes
    /// - `g.nodes`: `[N, NODE_FEATURES]` (normalised), `N = n_cloth + n_body`
    /// - `g.edges[t].features`: `[E_t, EDGE_FEATURES]`, senders / receivers `[E_t]`; the
    ///   graph must have been uploaded with this model's normalisers (one per edge type)
    /// - latent node state `h`: `[N, L]`; latent edge state `e_t`: `[E_t, L]`
    /// - output: `[n_cloth, 3]`, normalised (de-normalise with the output normaliser)
    ///
    /// Per block and edge type of its level present: `e_t ← e_t + MLP_t([e_t, h_r, h_s])`;
    /// then `h ← h + MLP_node([h, Σ_r e_mesh, Σ_r e_body, Σ_r e_self])` (level 0) or
    /// `h ← h + MLP_node([h, Σ_r e_coarse_ℓ])` (level ℓ), with sums over the edges received by
    /// each node. An edge type with no edges in this graph contributes nothing. Coarse nodes
    /// are a subset of the cloth nodes, so every level shares the one node state `h`.
    pub fn forward(&self, g: &GraphTensors) -> Tensor<2> {
        let n_nodes = g.n_nodes;
        let mut h = self.node_encoder.forward(g.nodes.clone()); // [N, L]
        let mut e: Vec<Option<Tensor<2>>> = g
            .edges
            .iter()
            .zip(&self.edge_encoders)
            .map(|(set, enc)| set.as_ref().map(|s| enc.forward(s.features.clone()))) // [E_t, L]
            .collect();
        for block in &self.blocks {
            let mut node_pre = block.node.part(0, h.clone()); // [N, L]
            for (k, (&t, mlp)) in block.edge_types().iter().zip(&block.edges).enumerate() {
                let (Some(Some(set)), Some(Some(e_t))) = (g.edges.get(t), e.get_mut(t).map(Option::take)) else {
                    continue;
                };
                let from_r = mlp.part(1, h.clone()).select(0, set.receivers.clone()); // [E_t, L]
                let from_s = mlp.part(2, h.clone()).select(0, set.senders.clone()); // [E_t, L]
                let pre = mlp.part(0, e_t.clone()) + from_r + from_s;
                let e_new = e_t + mlp.finish(pre); // [E_t, L]
                let width = e_new.dims()[1];
                let agg = Tensor::<2>::zeros([n_nodes, width], &e_new.device()).select_assign(
                    0,
                    set.receivers.clone(),
                    e_new.clone(),
                    IndexingUpdateOp::Add,
                ); // [N, L]
                node_pre = node_pre + block.node.part(1 + k, agg);
                e[t] = Some(e_new);
            }
            h = h + block.node.finish(node_pre); // [N, L]
        }
        self.decoder.forward(h.narrow(0, 0, g.n_cloth)) // [n_cloth, 3]
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::TensorData;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::convert::tensor_to_f64;

    fn random(rng: &mut ChaCha8Rng, shape: [usize; 2], scale: f32, device: &Device) -> Tensor<2> {
        let v: Vec<f32> = (0..shape[0] * shape[1]).map(|_| scale * rng.random_range(-1.0f32..1.0)).collect();
        Tensor::from_data(TensorData::new(v, shape), device)
    }

    fn assert_close(what: &str, a: Tensor<2>, b: Tensor<2>) {
        let (a, b) = (tensor_to_f64(a), tensor_to_f64(b));
        assert_eq!(a.len(), b.len());
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(scale > 1e-3, "{what}: all zero");
        assert!(diff <= 2e-5 * scale, "{what}: difference {diff} at scale {scale}");
    }

    /// The hand-written linear + LayerNorm equals burn's `Linear` then `LayerNorm` in values
    /// and in the gradients of the input, the weight, the bias, γ and β.
    #[test]
    fn linear_layer_norm_matches_burn_in_values_and_gradients() {
        let device = Device::flex().autodiff();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (n, d_in, l) = (37, 12, 16);
        device.seed(4);
        let layer = LinearConfig::new(d_in, l).init(&device);
        let mut norm = LayerNormConfig::new(l).with_epsilon(LAYER_NORM_EPSILON).init(&device);
        // Non-trivial γ and β (burn starts them at 1 and 0).
        norm.gamma = burn::module::Param::from_tensor(random(&mut rng, [1, l], 1.5, &device).reshape([l]) + 1.0);
        norm.beta = Some(burn::module::Param::from_tensor(random(&mut rng, [1, l], 0.5, &device).reshape([l])));
        // Rows with an offset, so that the mean subtraction matters.
        let x = (random(&mut rng, [n, d_in], 2.0, &device) + 3.0).require_grad();
        let g = random(&mut rng, [n, l], 1.0, &device);

        let ours = linear_layer_norm(x.clone(), &layer, &norm);
        let theirs = norm.forward(layer.forward(x.clone()));
        assert_close("values", ours.clone(), theirs.clone());
        // The inference path (burn's fused kernel on a plain device) agrees too.
        let plain = norm.valid().forward(layer.valid().forward(x.clone().inner()));
        assert_close("inference", ours.clone().inner(), plain);

        let grads_ours = (ours * g.clone()).sum().backward();
        let grads_theirs = (theirs * g).sum().backward();
        let pairs: [(&str, Tensor<2>, Tensor<2>); 5] = [
            ("dx", x.grad(&grads_ours).unwrap(), x.grad(&grads_theirs).unwrap()),
            ("dW", layer.weight.val().grad(&grads_ours).unwrap(), layer.weight.val().grad(&grads_theirs).unwrap()),
            (
                "db",
                layer.bias.as_ref().unwrap().val().grad(&grads_ours).unwrap().unsqueeze(),
                layer.bias.as_ref().unwrap().val().grad(&grads_theirs).unwrap().unsqueeze(),
            ),
            (
                "dgamma",
                norm.gamma.val().grad(&grads_ours).unwrap().unsqueeze(),
                norm.gamma.val().grad(&grads_theirs).unwrap().unsqueeze(),
            ),
            (
                "dbeta",
                norm.beta.as_ref().unwrap().val().grad(&grads_ours).unwrap().unsqueeze(),
                norm.beta.as_ref().unwrap().val().grad(&grads_theirs).unwrap().unsqueeze(),
            ),
        ];
        for (what, a, b) in pairs {
            assert_close(what, a, b);
        }
    }
}

#[cfg(test)]
mod layer_norm_tests {
    use burn::nn::LayerNormConfig;
    use burn::tensor::TensorData;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::convert::tensor_to_f64;
    use crate::layer_norm::{layer_norm, supported};

    fn random(rng: &mut ChaCha8Rng, shape: [usize; 2], scale: f32, offset: f32, device: &Device) -> Tensor<2> {
        let v: Vec<f32> = (0..shape[0] * shape[1]).map(|_| offset + scale * rng.random_range(-1.0f32..1.0)).collect();
        Tensor::from_data(TensorData::new(v, shape), device)
    }

    fn max_abs_diff(a: Tensor<2>, b: Tensor<2>) -> (f64, f64) {
        let (a, b) = (tensor_to_f64(a), tensor_to_f64(b));
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        (a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())), scale)
    }

    fn norm_with(rng: &mut ChaCha8Rng, l: usize, beta: bool, device: &Device) -> LayerNorm {
        let mut norm = LayerNormConfig::new(l).with_epsilon(LAYER_NORM_EPSILON).with_bias(beta).init(device);
        norm.gamma = burn::module::Param::from_tensor(random(rng, [1, l], 0.5, 1.0, device).reshape([l]));
        if beta {
            norm.beta = Some(burn::module::Param::from_tensor(random(rng, [1, l], 0.5, 0.0, device).reshape([l])));
        }
        norm
    }

    /// The hand-written LayerNorm node equals burn's own LayerNorm (differentiated through its
    /// decomposition) in values and in the gradients of x, γ and β: widths with and without a
    /// SIMD remainder, row counts over several parallel chunks, with and without β, rows with
    /// large offsets and one constant row (zero variance).
    #[test]
    fn hand_written_layer_norm_matches_burn() {
        let device = Device::flex().autodiff();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (n, l, beta) in [(5usize, 3usize, true), (700, 128, true), (300, 37, false), (257, 16, true)] {
            let norm = norm_with(&mut rng, l, beta, &device);
            let mut x = random(&mut rng, [n, l], 2.0, 3.0, &device);
            x = x.slice_assign([0..1, 0..l], Tensor::<2>::ones([1, l], &device) * 4.0); // constant row
            let x = x.require_grad();
            let w = random(&mut rng, [n, l], 1.0, 0.0, &device);
            assert!(supported(&x));
            let ours = layer_norm(&x, &norm).expect("flex autodiff takes the hand-written path");
            let theirs = norm.forward(x.clone());
            let (d, _) = max_abs_diff(ours.clone(), theirs.clone());
            assert!(d < 2e-5, "values differ by {d} (n={n}, L={l})");

            let g_ours = (ours * w.clone()).sum().backward();
            let g_theirs = (theirs * w).sum().backward();
            let mut pairs = vec![
                ("dx", x.grad(&g_ours).unwrap(), x.grad(&g_theirs).unwrap()),
                (
                    "dgamma",
                    norm.gamma.val().grad(&g_ours).unwrap().unsqueeze(),
                    norm.gamma.val().grad(&g_theirs).unwrap().unsqueeze(),
                ),
            ];
            if let Some(b) = &norm.beta {
                pairs.push((
                    "dbeta",
                    b.val().grad(&g_ours).unwrap().unsqueeze(),
                    b.val().grad(&g_theirs).unwrap().unsqueeze(),
                ));
            }
            for (what, a, b) in pairs {
                assert!(tensor_to_f64(a.clone()).iter().all(|v| v.is_finite()), "{what} not finite");
                let (d, scale) = max_abs_diff(a, b);
                assert!(scale > 1e-3, "{what}: all zero");
                assert!(d <= 1e-4 * scale, "{what} differs by {d} at scale {scale} (n={n}, L={l})");
            }
        }
    }

    /// Inference tensors are not taken: burn's fused kernel serves them.
    #[test]
    fn hand_written_layer_norm_only_under_flex_autodiff() {
        let plain = Device::flex();
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let norm = norm_with(&mut rng, 8, true, &plain);
        let x = random(&mut rng, [4, 8], 1.0, 0.0, &plain);
        assert!(!supported(&x));
        assert!(layer_norm(&x, &norm).is_none());
    }
}
