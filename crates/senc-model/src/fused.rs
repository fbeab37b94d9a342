//! The fused CPU inference path: [`FusedNetwork`] computes exactly the function of
//! [`Network::forward`] (on a plain, non-autodiff device) in f32 on the host, without burn.
//!
//! Why: burn runs the network one whole-tensor operation at a time, so every `[E, L]`
//! intermediate (gathered node terms, pre-activations, ReLU, LayerNorm statistics, the
//! residual) makes a round trip through memory; with ~10⁵ edges and a small latent that
//! traffic, not arithmetic, is the run time. Here each edge MLP runs on chunks of
//! [`CHUNK_ROWS`] edges that stay in cache from the gather to the residual add, the matrix
//! products go to the `gemm` crate (single-threaded per chunk, AVX-512 kernels where the CPU
//! has them) and rayon spreads the chunks over the cores. The sum of messages per receiver
//! reads the edges through a receiver-sorted index (CSR), so no two threads write one row.
//!
//! Deterministic: every row is computed by the same operations whatever the thread count
//! (chunk boundaries are fixed, sums run in edge order), so a rollout repeats bit for bit.
//! Equal to burn's forward to f32 rounding (test `fused_matches_burn_forward`).
//!
//! Used by [`crate::Stepper`] for rollouts on the CPU; training keeps burn (autodiff).

use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::Tensor;
use rayon::prelude::*;
use senc_geom::gather::Gather;
use senc_geom::Vec3;

use crate::convert::HostGraph;
use crate::graph::{GraphConfig, GraphInputs, EDGE_FEATURES};
use crate::model::Model;
use crate::network::{Mlp, Network, LAYER_NORM_EPSILON};
use crate::normalizer::Normalizers;
use crate::ModelError;

/// Rows (edges or nodes) per task: large enough for efficient matrix products, small enough
/// that a chunk's intermediates (`CHUNK_ROWS × latent` f32, 128 KiB at latent 128) stay in
/// the core's cache.
pub const CHUNK_ROWS: usize = 256;

/// A network's weights copied out of burn, ready for host inference, with the normalisers
/// and graph settings of its [`Model`].
#[derive(Debug, Clone)]
pub struct FusedNetwork {
    node_encoder: HostMlp,
    edge_encoders: Vec<HostMlp>,
    blocks: Vec<HostBlock>,
    decoder: HostMlp,
    latent: usize,
    /// How graphs are built for this model.
    pub graph: GraphConfig,
    /// Input and output normalisers.
    pub normalizers: Normalizers,
}

#[derive(Debug, Clone)]
struct HostBlock {
    /// Edge-type indices of this block, paired with `edges` (see [`crate::network::Block`]).
    types: Vec<usize>,
    edges: Vec<HostMlp>,
    node: HostMlp,
}

/// `y = x·W (+ b)` with `W` row-major `[d_in, d_out]` (burn's `Linear` layout).
#[derive(Debug, Clone)]
struct Dense {
    w: Vec<f32>,
    b: Option<Vec<f32>>,
    d_in: usize,
    d_out: usize,
}

#[derive(Debug, Clone)]
struct HostNorm {
    gamma: Vec<f32>,
    beta: Option<Vec<f32>>,
}

#[derive(Debug, Clone)]
struct HostMlp {
    /// First layer, one block per input part (only the first has a bias).
    first: Vec<Dense>,
    /// Remaining layers, ReLU before each.
    layers: Vec<Dense>,
    norm: Option<HostNorm>,
}

fn host_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().convert::<f32>().iter::<f32>().collect()
}

impl Dense {
    fn new(l: &Linear) -> Self {
        let w = l.weight.val();
        let [d_in, d_out] = w.dims();
        Self { w: host_vec(w), b: l.bias.as_ref().map(|b| host_vec(b.val())), d_in, d_out }
    }

    /// `out[r, d_out] (+)= x[r, d_in]·W + b`, accumulating into `out` when `accumulate`.
    fn apply(&self, x: &[f32], out: &mut [f32], accumulate: bool) {
        let rows = out.len() / self.d_out;
        debug_assert_eq!(x.len(), rows * self.d_in);
        let read_out = match &self.b {
            Some(b) => {
                for row in out.chunks_exact_mut(self.d_out) {
                    if accumulate {
                        row.iter_mut().zip(b).for_each(|(o, b)| *o += b);
                    } else {
                        row.copy_from_slice(b);
                    }
                }
                true
            }
            None => accumulate,
        };
        kernel::matmul(rows, self.d_out, self.d_in, x, &self.w, out, read_out);
    }
}

impl HostMlp {
    fn new(m: &Mlp) -> Self {
        Self {
            first: m.first.iter().map(Dense::new).collect(),
            layers: m.layers.iter().map(Dense::new).collect(),
            norm: m
                .norm
                .as_ref()
                .map(|n| HostNorm { gamma: host_vec(n.gamma.val()), beta: n.beta.as_ref().map(|b| host_vec(b.val())) }),
        }
    }

    fn hidden(&self) -> usize {
        self.first[0].d_out
    }

    fn out(&self) -> usize {
        self.layers.last().map_or(0, |l| l.d_out)
    }

    /// Everything after the first layer's pre-activation (ReLU, the other layers, the
    /// LayerNorm): `pre [r, hidden]` (overwritten) → `out [r, out]`. `tmp` is scratch.
    fn finish(&self, pre: &mut Vec<f32>, tmp: &mut Vec<f32>, out: &mut [f32]) {
        let rows = out.len() / self.out().max(1);
        let Some((last, inner)) = self.layers.split_last() else { return };
        for layer in inner {
            relu(pre);
            tmp.resize(rows * layer.d_out, 0.0);
            layer.apply(pre, tmp, false);
            std::mem::swap(pre, tmp);
        }
        relu(pre);
        last.apply(&pre[..rows * last.d_in], out, false);
        if let Some(norm) = &self.norm {
            layer_norm(out, norm);
        }
    }

    /// The whole MLP on a single-part input, row chunks in parallel: `x [r, d_0] → out [r, out]`,
    /// or `out += MLP(x)` with `residual`.
    fn forward(&self, x: &[f32], out: &mut [f32], residual: bool) {
        let (d_in, d_out, hidden) = (self.first[0].d_in, self.out(), self.hidden());
        out.par_chunks_mut(CHUNK_ROWS * d_out).enumerate().for_each_init(
            || (Vec::new(), Vec::new(), Vec::new()),
            |(pre, tmp, res), (c, o)| {
                let rows = o.len() / d_out;
                let r0 = c * CHUNK_ROWS;
                pre.resize(rows * hidden, 0.0);
                self.first[0].apply(&x[r0 * d_in..(r0 + rows) * d_in], pre, false);
                if residual {
                    res.resize(o.len(), 0.0);
                    self.finish(pre, tmp, res);
                    add_assign(o, res);
                } else {
                    self.finish(pre, tmp, o);
                }
            },
        );
    }
}

/// Runs `f` compiled for the best instruction set this CPU has (AVX-512, AVX2, …; chosen at
/// run time by `pulp`), so that the element-wise loops below vectorise on any x86-64 build.
#[inline(always)]
pub(crate) fn simd<R>(f: impl FnOnce() -> R) -> R {
    pulp::Arch::new().dispatch(f)
}

/// In-place ReLU. A compare-and-select, not `f32::max` (whose NaN rule blocks
/// vectorisation); NaN stays NaN.
fn relu(x: &mut [f32]) {
    simd(|| {
        x.iter_mut().for_each(|v| {
            if *v < 0.0 {
                *v = 0.0;
            }
        })
    });
}

/// `x += y`, element-wise.
fn add_assign(x: &mut [f32], y: &[f32]) {
    simd(|| x.iter_mut().zip(y).for_each(|(x, y)| *x += y));
}

/// Lanes of the partial sums in [`row_sum`]: one AVX-512 register of f32, so the reduction
/// vectorises (a single running sum cannot be reordered by the compiler).
pub(crate) const LANES: usize = 16;

/// `Σ f(x_i)` over a row with [`LANES`] partial sums.
#[inline(always)]
pub(crate) fn row_sum(row: &[f32], f: impl Fn(f32) -> f32) -> f32 {
    let mut acc = [0.0f32; LANES];
    let chunks = row.chunks_exact(LANES);
    let tail: f32 = chunks.remainder().iter().map(|&v| f(v)).sum();
    for c in chunks {
        for (a, &v) in acc.iter_mut().zip(c) {
            *a += f(v);
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// Row-wise LayerNorm, `y = (x − mean) / sqrt(var + ε) · γ + β` (population variance).
/// Widths 16, 32, 64 and 128 get a loop with the width known at compile time (unrolled and
/// vectorised); others the generic loop.
fn layer_norm(x: &mut [f32], norm: &HostNorm) {
    let width = norm.gamma.len();
    let zeros;
    let beta = match &norm.beta {
        Some(b) => b.as_slice(),
        None => {
            zeros = vec![0.0f32; width];
            zeros.as_slice()
        }
    };
    simd(|| match width {
        16 => layer_norm_fixed::<16>(x, &norm.gamma, beta),
        32 => layer_norm_fixed::<32>(x, &norm.gamma, beta),
        64 => layer_norm_fixed::<64>(x, &norm.gamma, beta),
        128 => layer_norm_fixed::<128>(x, &norm.gamma, beta),
        _ => {
            for row in x.chunks_exact_mut(width) {
                layer_norm_row(row, &norm.gamma, beta);
            }
        }
    });
}

#[inline(always)]
fn layer_norm_fixed<const W: usize>(x: &mut [f32], gamma: &[f32], beta: &[f32]) {
    let (Ok(gamma), Ok(beta)) = (<&[f32; W]>::try_from(gamma), <&[f32; W]>::try_from(beta)) else { return };
    for row in x.chunks_exact_mut(W) {
        if let Ok(row) = <&mut [f32; W]>::try_from(row) {
            layer_norm_row(row, gamma, beta);
        }
    }
}

#[inline(always)]
fn layer_norm_row(row: &mut [f32], gamma: &[f32], beta: &[f32]) {
    let width = row.len() as f32;
    let mean = row_sum(row, |v| v) / width;
    let var = row_sum(row, |v| (v - mean) * (v - mean)) / width;
    let inv = 1.0 / (var + LAYER_NORM_EPSILON as f32).sqrt();
    for ((v, g), b) in row.iter_mut().zip(gamma).zip(beta) {
        *v = (*v - mean) * inv * g + b;
    }
}

/// `out[n] = Σ_{i received by n} e[i]` for every node, with `by_receiver` grouping the edges
/// by receiving node (`Gather::new(n_nodes, receivers)`); rows in parallel (no write
/// conflicts; sums in edge order, so the result does not depend on the thread count).
fn sum_by_receiver(by_receiver: &Gather, e: &[f32], width: usize, out: &mut [f32]) {
    out.par_chunks_mut(CHUNK_ROWS * width).enumerate().for_each(|(c, o)| {
        o.fill(0.0);
        simd(|| {
            for (j, row) in o.chunks_exact_mut(width).enumerate() {
                for &i in by_receiver.slots(c * CHUNK_ROWS + j) {
                    let src = &e[i as usize * width..(i as usize + 1) * width];
                    row.iter_mut().zip(src).for_each(|(o, s)| *o += s);
                }
            }
        })
    });
}

impl FusedNetwork {
    /// Copies the weights of `model`'s network (any device; they are read back once) and
    /// keeps its normalisers and graph settings.
    pub fn new(model: &Model) -> Self {
        Self::from_network(&model.network.valid(), model.config.latent.max(1), model.graph, model.normalizers.clone())
    }

    fn from_network(net: &Network, latent: usize, graph: GraphConfig, normalizers: Normalizers) -> Self {
        Self {
            node_encoder: HostMlp::new(&net.node_encoder),
            edge_encoders: net.edge_encoders.iter().map(HostMlp::new).collect(),
            blocks: net
                .blocks
                .iter()
                .map(|b| HostBlock {
                    types: b.edge_types(),
                    edges: b.edges.iter().map(HostMlp::new).collect(),
                    node: HostMlp::new(&b.node),
                })
                .collect(),
            decoder: HostMlp::new(&net.decoder),
            latent,
            graph,
            normalizers,
        }
    }

    /// The network on a host graph: normalised output per cloth vertex, row-major
    /// `[n_cloth, 3]` (what [`Network::forward`] returns).
    pub fn forward_normalized(&self, g: &HostGraph) -> Vec<f32> {
        let l = self.latent;
        let n = g.n_nodes;
        debug_assert_eq!(g.nodes.len() % n.max(1), 0);
        let mut h = vec![0.0f32; n * l];
        self.node_encoder.forward(&g.nodes, &mut h, false);
        let mut e: Vec<Option<Vec<f32>>> = g
            .edges
            .iter()
            .zip(&self.edge_encoders)
            .map(|(set, enc)| {
                set.as_ref().map(|s| {
                    debug_assert_eq!(s.features.len(), s.senders.len() * EDGE_FEATURES);
                    let mut out = vec![0.0f32; s.senders.len() * l];
                    enc.forward(&s.features, &mut out, false);
                    out
                })
            })
            .collect();
        let by_receiver: Vec<Option<Gather>> =
            g.edges.iter().map(|set| set.as_ref().map(|s| Gather::new(n, &s.receivers))).collect();
        // Node-sized buffers, allocated once and reused by every block (fresh allocations of
        // this size cost page faults on every block).
        let mut node_pre = Vec::new();
        let (mut from_r, mut from_s) = (Vec::new(), Vec::new());
        let mut agg = vec![0.0f32; n * l];
        for block in &self.blocks {
            let hidden = block.node.hidden();
            node_pre.resize(n * hidden, 0.0);
            par_dense(&block.node.first[0], &h, &mut node_pre, false);
            for (k, (&t, mlp)) in block.types.iter().zip(&block.edges).enumerate() {
                let (Some(Some(set)), Some(Some(e_t)), Some(Some(csr))) =
                    (g.edges.get(t), e.get_mut(t), by_receiver.get(t))
                else {
                    continue;
                };
                let eh = mlp.hidden();
                from_r.resize(n * eh, 0.0);
                from_s.resize(n * eh, 0.0);
                par_dense(&mlp.first[1], &h, &mut from_r, false);
                par_dense(&mlp.first[2], &h, &mut from_s, false);
                let (from_r, from_s) = (&from_r, &from_s);
                e_t.par_chunks_mut(CHUNK_ROWS * l).enumerate().for_each_init(
                    || (Vec::new(), Vec::new(), Vec::new()),
                    |(pre, tmp, res), (c, e_chunk)| {
                        let rows = e_chunk.len() / l;
                        let r0 = c * CHUNK_ROWS;
                        pre.resize(rows * eh, 0.0);
                        mlp.first[0].apply(e_chunk, pre, false);
                        simd(|| {
                            for (j, p) in pre.chunks_exact_mut(eh).enumerate() {
                                let (r, s) = (set.receivers[r0 + j] as usize, set.senders[r0 + j] as usize);
                                let (ar, as_) = (&from_r[r * eh..(r + 1) * eh], &from_s[s * eh..(s + 1) * eh]);
                                for ((p, a), b) in p.iter_mut().zip(ar).zip(as_) {
                                    *p += a + b;
                                }
                            }
                        });
                        res.resize(e_chunk.len(), 0.0);
                        mlp.finish(pre, tmp, res);
                        add_assign(e_chunk, res);
                    },
                );
                sum_by_receiver(csr, e_t, l, &mut agg);
                par_dense(&block.node.first[1 + k], &agg, &mut node_pre, true);
            }
            h.par_chunks_mut(CHUNK_ROWS * l).zip(node_pre.par_chunks_mut(CHUNK_ROWS * hidden)).for_each_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(pre, tmp, res), (h_chunk, pre_chunk)| {
                    pre.clear();
                    pre.extend_from_slice(pre_chunk);
                    res.resize(h_chunk.len(), 0.0);
                    block.node.finish(pre, tmp, res);
                    add_assign(h_chunk, res);
                },
            );
        }
        let mut out = vec![0.0f32; g.n_cloth * self.decoder.out()];
        self.decoder.forward(&h[..g.n_cloth * l], &mut out, false);
        out
    }

    /// The response acceleration per cloth vertex, m/s² (what [`Model::forward`] returns, in
    /// f64): the network's output de-normalised.
    pub fn accelerations(&self, graph: &GraphInputs) -> Vec<Vec3> {
        let out = self.forward_normalized(&HostGraph::new(graph, &self.normalizers));
        let (mean, std) = (self.normalizers.output.mean(), self.normalizers.output.std());
        // Same rounding as the burn path: f32 output · f32 std + f32 mean.
        let (mean, std): ([f32; 3], [f32; 3]) =
            (std::array::from_fn(|k| mean[k] as f32), std::array::from_fn(|k| std[k] as f32));
        out.chunks_exact(3)
            .map(|a| {
                let v: [f32; 3] = std::array::from_fn(|k| a[k] * std[k] + mean[k]);
                Vec3::new(v[0].into(), v[1].into(), v[2].into())
            })
            .collect()
    }

    /// Inference: the next cloth positions of one frame, `x[t+1] = 2 x[t] − x[t−1] + Δt² (g +
    /// a_ext + a)` (as [`Model::step`]).
    pub fn step(&self, frame: &crate::FrameState<'_>) -> Result<Vec<Vec3>, ModelError> {
        let graph = GraphInputs::build(frame, &self.graph)?;
        Ok(Model::integrate(frame, self.accelerations(&graph)))
    }
}

/// `out = x·W (+ b)` (or `out +=` with `accumulate`) over row chunks in parallel.
fn par_dense(layer: &Dense, x: &[f32], out: &mut [f32], accumulate: bool) {
    let (d_in, d_out) = (layer.d_in, layer.d_out);
    out.par_chunks_mut(CHUNK_ROWS * d_out).enumerate().for_each(|(c, o)| {
        let r0 = c * CHUNK_ROWS;
        let rows = o.len() / d_out;
        layer.apply(&x[r0 * d_in..(r0 + rows) * d_in], o, accumulate);
    });
}

/// The one call into the `gemm` crate, the only `unsafe` in the workspace.
#[allow(unsafe_code)]
mod kernel {
    /// `c[m, n] = (c if read_c) + a[m, k]·b[k, n]`, all row-major, single-threaded (the
    /// callers parallelise over row chunks).
    ///
    /// # Panics
    /// If a slice is shorter than its matrix (a bug in this module, never user input).
    pub(super) fn matmul(m: usize, n: usize, k: usize, a: &[f32], b: &[f32], c: &mut [f32], read_c: bool) {
        assert!(a.len() >= m * k && b.len() >= k * n && c.len() >= m * n, "matmul: slice shorter than its matrix");
        if m == 0 || n == 0 {
            return;
        }
        // SAFETY: the asserts above guarantee that every element the three row-major
        // matrices address (row stride = column count, column stride 1) lies inside its
        // slice; `c` is a unique borrow, so it aliases neither `a` nor `b`; no threads are
        // spawned (Parallelism::None), so the borrows outlive the call.
        unsafe {
            gemm::gemm(
                m,
                n,
                k,
                c.as_mut_ptr(),
                1,
                n as isize,
                read_c,
                a.as_ptr(),
                1,
                k as isize,
                b.as_ptr(),
                1,
                n as isize,
                1.0f32,
                1.0f32,
                false,
                false,
                false,
                gemm::Parallelism::None,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Device, Distribution};

    use super::*;
    use crate::convert::{tensor_to_f64, GraphTensors};
    use crate::network::ModelConfig;
    use crate::synthetic::SyntheticScene;

    /// A model with random (not burn's initial) weights everywhere, including LayerNorm γ, β
    /// and the decoder, and normalisers fitted to the graph.
    fn random_model(config: ModelConfig, graph: &GraphInputs) -> Model {
        let device = Device::flex();
        let mut model = Model::new(config, GraphConfig::default(), 5, &device);
        model.network = model.network.map(&mut Perturb);
        model.normalizers.update_inputs(graph);
        model
    }

    struct Perturb;
    impl burn::module::ModuleMapper for Perturb {
        fn map_float<const D: usize>(
            &mut self,
            param: burn::module::Param<Tensor<D>>,
        ) -> burn::module::Param<Tensor<D>> {
            param.map(|t| {
                let noise = Tensor::random(t.shape(), Distribution::Uniform(-0.3, 0.3), &t.device());
                t + noise
            })
        }
    }

    fn check(config: ModelConfig, scene: &SyntheticScene, with_body: bool) {
        let mut frame = scene.frame();
        if !with_body {
            frame.body = None;
        }
        let gc = GraphConfig { coarse_levels: config.coarse_levels, ..Default::default() };
        let graph = GraphInputs::build(&frame, &gc).unwrap();
        // Every edge type (and each coarse level) is exercised, the body's only with a body.
        for (t, set) in graph.edges.iter().enumerate() {
            assert_eq!(set.is_empty(), t == 1 && !with_body, "edge type {t}: {} edges", set.len());
        }
        let model = random_model(config, &graph);
        let burn_out =
            tensor_to_f64(model.network.forward(&GraphTensors::new(&graph, &model.normalizers, &model.device)));
        let fused = FusedNetwork::new(&model);
        let ours: Vec<f64> =
            fused.forward_normalized(&HostGraph::new(&graph, &model.normalizers)).into_iter().map(f64::from).collect();
        assert_eq!(ours.len(), burn_out.len());
        let scale = burn_out.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = ours.iter().zip(&burn_out).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(scale > 1e-2, "output all zero");
        assert!(diff <= 2e-4 * scale, "fused differs from burn by {diff} at scale {scale}");
        // De-normalised accelerations agree with the model's.
        let acc = fused.accelerations(&graph);
        let model_acc = crate::convert::tensor_to_vec3(model.forward(&graph)).unwrap();
        let d = acc.iter().zip(&model_acc).fold(0.0f64, |m, (a, b)| m.max((a - b).norm()));
        let s = model_acc.iter().fold(0.0f64, |m, a| m.max(a.norm()));
        assert!(d <= 2e-4 * s.max(1e-3), "accelerations differ by {d} at scale {s}");
    }

    #[test]
    fn fused_matches_burn_forward() {
        let scene = SyntheticScene::new(14, 0.015, 300, 3);
        // Small size with a body, two hidden layers, no body, no LayerNorm, coarse levels.
        check(ModelConfig::small_cpu(), &scene, true);
        check(ModelConfig::small_cpu().with_hidden_layers(2).with_latent(20), &scene, true);
        check(ModelConfig::small_cpu(), &scene, false);
        check(ModelConfig::small_cpu().with_layer_norm(false).with_blocks(2), &scene, true);
        check(ModelConfig::small_cpu().with_coarse_levels(2).with_blocks(5), &scene, true);
    }

    #[test]
    fn fused_step_is_deterministic_across_thread_counts() {
        let scene = SyntheticScene::new(14, 0.015, 300, 4);
        let frame = scene.frame();
        let graph = GraphInputs::build(&frame, &GraphConfig::default()).unwrap();
        let fused = FusedNetwork::new(&random_model(ModelConfig::small_cpu(), &graph));
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| fused.step(&frame).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert!(a.iter().all(|p| p.iter().all(|v| v.is_finite())));
        assert_eq!(a, b, "results depend on the thread count");
    }
}
