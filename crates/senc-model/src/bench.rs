//! Timing of graph building, the network (inference and forward + backward) and its main
//! operations. Run by `cargo xtask bench model` (on the real t-shirt graph); the graphs can be
//! exported for `tools/bench_torch.py`.
//!
//! Times are wall-clock medians over `reps` runs after one warm-up run. The machine may be
//! shared: report the load average next to the numbers and compare ratios from one run.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use burn::module::Module;
use burn::nn::{LayerNormConfig, LinearConfig};
use burn::tensor::{Device, IndexingUpdateOp, Int, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::Vec3;

use crate::convert::{index_tensor, tensor_to_f64};
use crate::graph::{EdgeType, GraphConfig, GraphInputs};
use crate::model::Model;
use crate::network::ModelConfig;
use crate::surrogate::surrogate_backward;
use crate::synthetic::SyntheticScene;

/// Median wall-clock seconds of `f` over `reps` runs after one warm-up.
pub fn time_median(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// The t-shirt-sized scene: 78 × 78 = 6084 cloth vertices at 1.5 cm spacing and a sphere
/// body of about 6890 vertices (SMPL's count).
pub fn tshirt_scene() -> SyntheticScene {
    SyntheticScene::new(78, 0.015, 6890, 2024)
}

/// Times graph building for an `n × n` garment (1.5 cm spacing) with an SMPL-sized body.
/// Returns `(cloth vertices, edges per type, seconds)`.
pub fn bench_graph(n: usize, reps: usize) -> (usize, [usize; 3], f64, crate::graph::BuildTimings) {
    let scene = SyntheticScene::new(n, 0.015, 6890, 7);
    let config = GraphConfig::default();
    let (g, _) = GraphInputs::build_timed(&scene.frame(), &config).expect("synthetic scene is valid");
    let counts = EdgeType::ALL.map(|t| g.edge_set(t).len());
    let mut stages = crate::graph::BuildTimings::default();
    let secs = time_median(reps, || {
        let (_, t) = GraphInputs::build_timed(&scene.frame(), &config).expect("valid");
        stages = t;
    });
    (g.n_cloth, counts, secs, stages)
}

/// Builds the graph of `frame` once and times building it again (median of `reps`).
/// Returns the graph, the per-stage times of the median run and its total seconds.
pub fn bench_build(
    frame: &crate::graph::FrameState<'_>,
    config: &GraphConfig,
    reps: usize,
) -> Result<(GraphInputs, crate::graph::BuildTimings, f64), crate::ModelError> {
    let (graph, _) = GraphInputs::build_timed(frame, config)?;
    let mut runs: Vec<(f64, crate::graph::BuildTimings)> = Vec::new();
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        let (_, st) = GraphInputs::build_timed(frame, config)?;
        runs.push((t0.elapsed().as_secs_f64(), st));
    }
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (secs, stages) = runs[runs.len() / 2];
    Ok((graph, stages, secs))
}

/// One row of the network benchmark.
#[derive(Debug, Clone)]
pub struct NetTiming {
    /// Label of the configuration.
    pub label: String,
    /// Parameter count.
    pub params: usize,
    /// Upload (normalise + f64 → f32) seconds.
    pub upload: f64,
    /// Inference seconds (valid model, output read back).
    pub forward: f64,
    /// Inference seconds of the fused host path ([`crate::FusedNetwork`]: normalise, cast,
    /// network, de-normalise; the same work as `upload + forward`).
    pub fused: f64,
    /// Forward + surrogate backward seconds (autodiff model).
    pub forward_backward: f64,
}

/// Times `config` on `graph` on `device` (`Device::flex()` or a GPU device from
/// [`crate::device_named`]): inference on the plain device, inference on the fused host path
/// (CPU only; NaN on another device) and, with `backward`, forward + backward on the
/// device's autodiff version (NaN otherwise). Each timed run ends with the device synchronised
/// (results read back, or `Device::sync` after the backward pass), so asynchronous GPU
/// work is counted.
pub fn bench_network(
    label: &str,
    config: &ModelConfig,
    graph: &GraphInputs,
    reps: usize,
    backward: bool,
    device: &Device,
) -> NetTiming {
    let device = device.clone().inner();
    let cpu = device == Device::flex();
    let mut model = Model::new(config.clone(), GraphConfig::default(), 1, &device.clone().autodiff());
    model.normalizers.update_inputs(graph);
    let valid = model.valid();
    let params = valid.network.num_params();
    let tensors = valid.tensors(graph);
    let upload = time_median(reps, || {
        let _ = valid.tensors(graph);
        let _ = device.sync();
    });
    let forward = time_median(reps, || {
        let out = valid.forward_tensors(&tensors);
        let _ = tensor_to_f64(out);
    });
    let fused = if cpu {
        let engine = crate::FusedNetwork::new(&valid);
        time_median(reps, || {
            let _ = engine.accelerations(graph);
        })
    } else {
        f64::NAN
    };
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let g: Vec<Vec3> = (0..graph.n_cloth).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
    let ad_tensors = model.tensors(graph);
    let forward_backward = if backward {
        time_median(reps, || {
            let x = model.forward_tensors(&ad_tensors);
            let _grads = surrogate_backward(x, &g).expect("shapes match");
            let _ = device.sync();
        })
    } else {
        f64::NAN
    };
    NetTiming { label: label.to_string(), params, upload, forward, fused, forward_backward }
}

/// Times the network's main operations at the sizes of one message-passing step on `graph`'s
/// mesh edges with latent `l`: `(name, inference seconds, forward + backward seconds)`.
pub fn bench_ops(graph: &GraphInputs, l: usize, reps: usize) -> Vec<(String, f64, f64)> {
    let set = graph.edge_set(EdgeType::Mesh);
    let (n, e) = (graph.n_nodes(), set.len());
    let mut out: Vec<(String, f64, f64)> = Vec::new();
    for autodiff in [false, true] {
        let device = if autodiff { Device::flex().autodiff() } else { Device::flex() };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut rand_t = |rows: usize, cols: usize| {
            let v: Vec<f32> = (0..rows * cols).map(|_| rng.random_range(-1.0..1.0)).collect();
            let t = Tensor::<2>::from_data(TensorData::new(v, [rows, cols]), &device);
            if autodiff {
                t.require_grad()
            } else {
                t
            }
        };
        let h = rand_t(n, l);
        let ev = rand_t(e, l);
        let w = rand_t(l, l);
        let idx: Tensor<1, Int> = index_tensor(&set.receivers, &device);
        let ln = LayerNormConfig::new(l).init(&device);
        let lin = LinearConfig::new(l, l).init(&device);
        let finish = |t: Tensor<2>| {
            if autodiff {
                let _ = t.sum().backward();
            } else {
                let _ = t.into_data();
            }
        };
        let rows: Vec<(String, f64)> = vec![
            (format!("matmul [{e},{l}]x[{l},{l}]"), time_median(reps, || finish(ev.clone().matmul(w.clone())))),
            (format!("matmul [{n},{l}]x[{l},{l}]"), time_median(reps, || finish(h.clone().matmul(w.clone())))),
            (format!("gather [{n},{l}] -> [{e},{l}]"), time_median(reps, || finish(h.clone().select(0, idx.clone())))),
            (
                format!("scatter-add [{e},{l}] -> [{n},{l}]"),
                time_median(reps, || {
                    let z = Tensor::<2>::zeros([n, l], &device);
                    finish(z.select_assign(0, idx.clone(), ev.clone(), IndexingUpdateOp::Add))
                }),
            ),
            (format!("layernorm (burn) [{e},{l}]"), time_median(reps, || finish(ln.forward(ev.clone())))),
            (
                format!("linear + layernorm (burn) [{e},{l}]"),
                time_median(reps, || finish(ln.forward(lin.forward(ev.clone())))),
            ),
            (
                format!("layernorm (senc, hand-written backward) [{e},{l}]"),
                time_median(reps, || finish(senc_layer_norm(ev.clone(), &ln))),
            ),
            (
                format!("linear + layernorm (senc, folded mean) [{e},{l}]"),
                time_median(reps, || finish(crate::network::linear_layer_norm(ev.clone(), &lin, &ln))),
            ),
            (
                format!("linear + layernorm (senc, hand-written backward) [{e},{l}]"),
                time_median(reps, || finish(senc_layer_norm(lin.forward(ev.clone()), &ln))),
            ),
            (format!("relu [{e},{l}]"), time_median(reps, || finish(burn::tensor::activation::relu(ev.clone())))),
            (format!("add [{e},{l}]"), time_median(reps, || finish(ev.clone() + ev.clone()))),
        ];
        for (k, (name, t)) in rows.into_iter().enumerate() {
            if autodiff {
                out[k] = (name, out[k].1, t);
            } else {
                out.push((name, t, f64::NAN));
            }
        }
    }
    out
}

/// The training path's LayerNorm: the hand-written node where it applies (flex autodiff),
/// burn's own otherwise.
fn senc_layer_norm(x: Tensor<2>, ln: &burn::nn::LayerNorm) -> Tensor<2> {
    crate::layer_norm::layer_norm(&x, ln).unwrap_or_else(|| ln.forward(x))
}

/// Writes `graph`'s sizes and indices for `tools/bench_torch.py`: `<stem>.json` with the
/// counts and `<stem>.<type>.{senders,receivers}.u32` as little-endian u32 arrays.
pub fn export_graph(graph: &GraphInputs, stem: &Path) -> std::io::Result<()> {
    let mut json = format!(
        "{{\"n_cloth\": {}, \"n_body\": {}, \"node_features\": {}, \"edge_features\": {}, \"edges\": {{",
        graph.n_cloth,
        graph.n_body,
        graph.nodes.len() / graph.n_nodes().max(1),
        crate::graph::EDGE_FEATURES
    );
    for (k, t) in EdgeType::ALL.iter().enumerate() {
        let set = graph.edge_set(*t);
        json += &format!("{}\"{}\": {}", if k > 0 { ", " } else { "" }, t.name(), set.len());
        for (part, v) in [("senders", &set.senders), ("receivers", &set.receivers)] {
            let path = stem.with_extension(format!("{}.{part}.u32", t.name()));
            let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
            for x in v.iter() {
                f.write_all(&x.to_le_bytes())?;
            }
        }
    }
    json += "}}\n";
    std::fs::write(stem.with_extension("json"), json)
}
