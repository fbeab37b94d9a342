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
use burn::tensor::{Device, IndexingUpdateOp, Tensor};

use crate::convert::GraphTensors;
use crate::graph::{EDGE_FEATURES, MAX_COARSE_LEVELS, NODE_FEATURES, N_EDGE_TYPES};

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

    /// Builds a freshly initialised network on `device` (burn's default initialisers; seed
    /// the device first with `device.seed(..)` for reproducible weights).
    pub fn init(&self, device: &Device) -> Network {
        let l = self.latent.max(1);
        let n_types = N_EDGE_TYPES + self.coarse_levels.min(MAX_COARSE_LEVELS);
        Network {
            node_encoder: Mlp::new(&[NODE_FEATURES], l, l, self, self.layer_norm, device),
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
    first: Vec<Linear>,
    /// The remaining layers.
    layers: Vec<Linear>,
    norm: Option<LayerNorm>,
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
        let norm = norm.then(|| LayerNormConfig::new(out).init(device));
        Self { first, layers, norm }
    }

    /// The first layer's contribution of input part `k`: `x·W_k` (`+ b` for `k = 0`).
    /// `[n, d_k] → [n, hidden]`.
    fn part(&self, k: usize, x: Tensor<2>) -> Tensor<2> {
        self.first[k].forward(x)
    }

    /// Everything after the first layer's pre-activation: ReLU, the other layers, LayerNorm.
    /// `[n, hidden] → [n, out]`.
    fn finish(&self, pre: Tensor<2>) -> Tensor<2> {
        let mut x = pre;
        for layer in &self.layers {
            x = layer.forward(relu(x));
        }
        match &self.norm {
            Some(norm) => norm.forward(x),
            None => x,
        }
    }

    /// The whole MLP on a single-part input. `[n, d_0] → [n, out]`.
    fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        self.finish(self.part(0, x))
    }
}

/// One message-passing block.
#[derive(Module, Debug)]
pub struct Block {
    /// The hierarchy level it works on (0: mesh, body and self edges).
    level: usize,
    edges: Vec<Mlp>,
    node: Mlp,
}

/// The whole network. Build it with [`ModelConfig::init`].
#[derive(Module, Debug)]
pub struct Network {
    node_encoder: Mlp,
    edge_encoders: Vec<Mlp>,
    blocks: Vec<Block>,
    decoder: Mlp,
}

impl Network {
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
            let types: Vec<usize> = if block.level == 0 { (0..N_EDGE_TYPES).collect() } else { vec![2 + block.level] };
            for (k, (&t, mlp)) in types.iter().zip(&block.edges).enumerate() {
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
