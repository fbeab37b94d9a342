//! senc-model integration tests: graph construction, equivariance and invariance of the
//! network, checkpoints, and the surrogate loss. Small sizes only (seconds).

use std::collections::HashSet;

use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::{Device, Gradients, Int, Tensor, TensorData};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::{TriMesh, Vec3};
use senc_model::convert::{tensor_to_f64, vec3_tensor};
use senc_model::synthetic::SyntheticScene;
use senc_model::{
    surrogate_backward, tensor_to_vec3, EdgeType, FrameState, GraphConfig, GraphInputs, Model, ModelConfig, ModelError,
    SelfEdges,
};

fn small_config() -> ModelConfig {
    ModelConfig::new().with_latent(16).with_blocks(2).with_hidden_layers(2)
}

fn scene() -> SyntheticScene {
    SyntheticScene::new(10, 0.01, 200, 11)
}

/// A model whose normalisers have seen the scene's graph (so the test runs in the
/// normalised regime the trained model sees).
fn warmed_model(scene: &SyntheticScene, device: &Device, seed: u64) -> Model {
    let mut model = Model::new(small_config(), GraphConfig::default(), seed, device);
    let graph = model.build_graph(&scene.frame()).unwrap();
    model.normalizers.update_inputs(&graph);
    model.normalizers.output.update(&[0.001, -0.01, 0.0, -0.002, -0.012, 0.001]);
    model
}

fn max_abs_diff(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).amax()).fold(0.0, f64::max)
}

fn max_abs(a: &[Vec3]) -> f64 {
    a.iter().map(|p| p.amax()).fold(0.0, f64::max)
}

#[test]
fn synthetic_scene_has_every_edge_type() {
    let s = scene();
    let g = GraphInputs::build(&s.frame(), &GraphConfig::default()).unwrap();
    for t in EdgeType::ALL {
        assert!(!g.edge_set(t).is_empty(), "no {} edges", t.name());
    }
    assert_eq!(g.edge_set(EdgeType::Mesh).len(), 2 * s.rest.topology().edges().len());
    assert_eq!(g.n_body, s.body_curr.len());
}

#[test]
fn self_collision_edges_exclude_mesh_edges_and_come_in_both_directions() {
    let s = scene();
    let topo = s.rest.topology();
    let r = 0.02;
    // Brute-force reference: all pairs closer than r, minus mesh edges.
    let mut expected = HashSet::new();
    let mut expected_with_mesh = HashSet::new();
    for i in 0..s.curr.len() {
        for j in 0..s.curr.len() {
            if i != j && (s.curr[i] - s.curr[j]).norm() < r {
                expected_with_mesh.insert((j as u32, i as u32));
                if topo.find_edge(i as u32, j as u32).is_none() {
                    expected.insert((j as u32, i as u32));
                }
            }
        }
    }
    assert!(expected_with_mesh.len() > expected.len(), "the scene must have mesh edges shorter than r");
    for (mode, want) in [(SelfEdges::ExcludeMesh, &expected), (SelfEdges::KeepMesh, &expected_with_mesh)] {
        let config = GraphConfig { self_edges: mode, ..GraphConfig::default() };
        let g = GraphInputs::build(&s.frame(), &config).unwrap();
        let set = g.edge_set(EdgeType::SelfCollision);
        let got: HashSet<(u32, u32)> = set.senders.iter().copied().zip(set.receivers.iter().copied()).collect();
        assert_eq!(got.len(), set.len(), "{mode:?}: duplicate edges");
        assert_eq!(&got, want, "{mode:?}");
        for &(a, b) in &got {
            assert!(got.contains(&(b, a)), "{mode:?}: ({a}, {b}) has no reverse");
            assert!((a as usize) < g.n_cloth && (b as usize) < g.n_cloth);
            if mode == SelfEdges::ExcludeMesh {
                assert!(topo.find_edge(a, b).is_none(), "mesh edge ({a}, {b}) became a self-collision edge");
            }
        }
    }
    let none = GraphConfig { self_edges: SelfEdges::None, ..GraphConfig::default() };
    assert!(GraphInputs::build(&s.frame(), &none).unwrap().edge_set(EdgeType::SelfCollision).is_empty());
}

#[test]
fn body_edges_link_each_close_cloth_vertex_to_its_nearest_body_vertex() {
    let s = scene();
    let g = GraphInputs::build(&s.frame(), &GraphConfig::default()).unwrap();
    let set = g.edge_set(EdgeType::Body);
    let pairs: HashSet<(u32, u32)> = set.senders.iter().copied().zip(set.receivers.iter().copied()).collect();
    for (i, x) in s.curr.iter().enumerate() {
        let (j, d) = s
            .body_curr
            .iter()
            .enumerate()
            .map(|(j, b)| (j, (x - b).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let body_node = (g.n_cloth + j) as u32;
        let linked = pairs.contains(&(i as u32, body_node)) && pairs.contains(&(body_node, i as u32));
        assert_eq!(linked, d < 0.03, "cloth vertex {i}, nearest body vertex {j} at {d} m");
    }
    assert_eq!(set.len(), 2 * s.curr.iter().filter(|x| s.body_curr.iter().any(|b| (*x - b).norm() < 0.03)).count());
}

#[test]
fn body_less_scene_has_no_body_edges() {
    let s = SyntheticScene::new(10, 0.01, 0, 11);
    let g = GraphInputs::build(&s.frame(), &GraphConfig::default()).unwrap();
    assert_eq!(g.n_body, 0);
    assert!(g.edge_set(EdgeType::Body).is_empty());
    assert_eq!(g.nodes.len(), g.n_cloth * senc_model::graph::NODE_FEATURES);
    // And the model runs on it.
    let model = Model::new(small_config(), GraphConfig::default(), 3, &Device::flex());
    assert_eq!(model.step(&s.frame()).unwrap().len(), s.curr.len());
}

#[test]
fn bad_input_is_a_typed_error() {
    let s = scene();
    let short = &s.prev[..5];
    let mut frame = s.frame();
    frame.prev = short;
    assert!(matches!(
        GraphInputs::build(&frame, &GraphConfig::default()),
        Err(ModelError::LengthMismatch { what: "cloth x[t-1]", got: 5, .. })
    ));
    let mut nan = s.curr.clone();
    nan[7].y = f64::NAN;
    let mut frame = s.frame();
    frame.curr = &nan;
    assert!(matches!(GraphInputs::build(&frame, &GraphConfig::default()), Err(ModelError::NotFinite { index: 7, .. })));
    let mut frame = s.frame();
    frame.material.mu = -1.0;
    assert!(matches!(GraphInputs::build(&frame, &GraphConfig::default()), Err(ModelError::BadMaterial { .. })));
}

/// Renumbering the cloth vertices permutes the predicted accelerations the same way.
#[test]
fn permutation_equivariance() {
    let s = scene();
    let device = Device::flex();
    let model = warmed_model(&s, &device, 5);
    let base = tensor_to_vec3(model.forward(&model.build_graph(&s.frame()).unwrap())).unwrap();

    let n = s.curr.len();
    let mut perm: Vec<usize> = (0..n).collect(); // new index -> old index
    perm.shuffle(&mut ChaCha8Rng::seed_from_u64(99));
    let mut old_to_new = vec![0u32; n];
    for (new, &old) in perm.iter().enumerate() {
        old_to_new[old] = new as u32;
    }
    let rest_pos: Vec<Vec3> = perm.iter().map(|&o| s.rest.positions()[o]).collect();
    let faces: Vec<[u32; 3]> = s.rest.faces().iter().map(|f| f.map(|v| old_to_new[v as usize])).collect();
    let rest = TriMesh::new(rest_pos, faces).unwrap();
    let prev: Vec<Vec3> = perm.iter().map(|&o| s.prev[o]).collect();
    let curr: Vec<Vec3> = perm.iter().map(|&o| s.curr[o]).collect();
    let frame = FrameState { rest: &rest, prev: &prev, curr: &curr, ..s.frame() };
    let permuted = tensor_to_vec3(model.forward(&model.build_graph(&frame).unwrap())).unwrap();

    let expected: Vec<Vec3> = perm.iter().map(|&o| base[o]).collect();
    let diff = max_abs_diff(&permuted, &expected);
    assert!(max_abs(&base) > 1e-4, "degenerate output");
    assert!(diff <= 1e-5 * max_abs(&base), "permuted output differs by {diff}");
}

/// The scene's frame with other cloth states (`t−1`, `t`) and body states (`t`, `t+1`).
fn frame_with<'a>(
    s: &'a SyntheticScene,
    prev: &'a [Vec3],
    curr: &'a [Vec3],
    body_curr: &'a [Vec3],
    body_next: &'a [Vec3],
) -> FrameState<'a> {
    let mut frame = s.frame();
    frame.prev = prev;
    frame.curr = curr;
    let body = frame.body.as_mut().unwrap();
    body.curr = body_curr;
    body.next = body_next;
    frame
}

/// Translating cloth and body together leaves the accelerations unchanged.
#[test]
fn translation_invariance() {
    let s = scene();
    let device = Device::flex();
    let model = warmed_model(&s, &device, 6);
    let base = tensor_to_vec3(model.forward(&model.build_graph(&s.frame()).unwrap())).unwrap();
    let shift = Vec3::new(0.37, -1.25, 2.5);
    let mv = |v: &[Vec3]| v.iter().map(|p| p + shift).collect::<Vec<_>>();
    let (prev, curr, bc, bn) = (mv(&s.prev), mv(&s.curr), mv(&s.body_curr), mv(&s.body_next));
    let frame = frame_with(&s, &prev, &curr, &bc, &bn);
    let moved = tensor_to_vec3(model.forward(&model.build_graph(&frame).unwrap())).unwrap();
    let diff = max_abs_diff(&moved, &base);
    assert!(diff <= 1e-5 * max_abs(&base), "translated output differs by {diff}");
}

/// A uniform motion of the whole scene by `w` per frame (cloth at `t−1`, `t` and body at `t`,
/// `t+1` each moved on by one more `w`) leaves every feature, so the accelerations, unchanged
/// in the body's frame (`comoving`), and changes the world-frame velocities.
#[test]
fn comoving_features_are_galilean_invariant() {
    let s = scene();
    let w = Vec3::new(0.04, -0.01, 0.03);
    let boost = |v: &[Vec3], k: f64| v.iter().map(|p| p + w * k).collect::<Vec<_>>();
    let (prev, curr, bc, bn) =
        (boost(&s.prev, 0.0), boost(&s.curr, 1.0), boost(&s.body_curr, 1.0), boost(&s.body_next, 2.0));
    let frame = frame_with(&s, &prev, &curr, &bc, &bn);
    // Largest difference relative to the feature's size (the elastic columns are large
    // sums of forces, exact only to rounding).
    let rel = |x: &f64, y: &f64| (x - y).abs() / x.abs().max(1.0);
    let worst = |a: &GraphInputs, b: &GraphInputs| {
        let mut d = a.nodes.iter().zip(&b.nodes).map(|(x, y)| rel(x, y)).fold(0.0, f64::max);
        for (ea, eb) in a.edges.iter().zip(&b.edges) {
            assert_eq!(ea.senders, eb.senders);
            d = ea.features.iter().zip(&eb.features).map(|(x, y)| rel(x, y)).fold(d, f64::max);
        }
        d
    };
    let comoving = GraphConfig { comoving: true, elastic_features: true, ..GraphConfig::default() };
    let (a, b) = (GraphInputs::build(&s.frame(), &comoving).unwrap(), GraphInputs::build(&frame, &comoving).unwrap());
    assert!(a.n_body > 0 && !a.edges[EdgeType::Body.index()].senders.is_empty(), "no body edges");
    assert!(worst(&a, &b) < 1e-9, "boosted features differ by {}", worst(&a, &b));
    // The body nodes' velocities average to zero in their own frame.
    let f = comoving.node_features();
    for k in 0..3 {
        let mean: f64 = (a.n_cloth..a.n_cloth + a.n_body).map(|i| a.nodes[i * f + k]).sum::<f64>() / a.n_body as f64;
        assert!(mean.abs() < 1e-12, "body mean velocity, column {k}: {mean}");
    }
    let world = GraphConfig { elastic_features: true, ..GraphConfig::default() };
    let (a, b) = (GraphInputs::build(&s.frame(), &world).unwrap(), GraphInputs::build(&frame, &world).unwrap());
    assert!(worst(&a, &b) > 0.5 * w.norm(), "world-frame velocities should see the boost");
}

#[test]
fn save_then_load_gives_the_same_output_bit_for_bit() {
    let s = scene();
    let device = Device::flex();
    let model = warmed_model(&s, &device, 8);
    let graph = model.build_graph(&s.frame()).unwrap();
    let before = tensor_to_f64(model.forward(&graph));
    let dir = std::env::temp_dir().join(format!("senc-model-ckpt-{}", std::process::id()));
    model.save(&dir).unwrap();
    // Loading into a fresh, differently seeded model must overwrite everything.
    let loaded = Model::load(&dir, &device).unwrap();
    assert_eq!(loaded.config, model.config);
    assert_eq!(loaded.graph, model.graph);
    assert_eq!(loaded.normalizers, model.normalizers);
    let after = tensor_to_f64(loaded.forward(&graph));
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(before.len(), after.len());
    for (a, b) in before.iter().zip(&after) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    // A missing checkpoint is a typed error naming the file.
    let missing = Model::load(&dir, &device).unwrap_err();
    assert!(matches!(missing, ModelError::Checkpoint { .. }), "{missing}");
}

/// Collects the gradient norm of every float parameter.
struct GradNorms<'a> {
    grads: &'a Gradients,
    norms: Vec<(Vec<usize>, Option<f64>)>,
}

impl ModuleVisitor for GradNorms<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let t = param.val();
        let dims = t.dims().to_vec();
        let norm = t.grad(self.grads).map(|g| tensor_to_f64(g).iter().map(|v| v * v).sum::<f64>().sqrt());
        self.norms.push((dims, norm));
    }
}

#[test]
fn surrogate_gradient_reaches_every_parameter() {
    let s = scene();
    let device = Device::flex().autodiff();
    let plain = warmed_model(&s, &device, 9);
    // With HOOD's hierarchy: two coarse levels, blocks on levels 0, 1, 2, 0.
    let mut coarse =
        Model::new(small_config().with_blocks(4).with_coarse_levels(2), GraphConfig::default(), 9, &device);
    assert_eq!(coarse.config.block_levels(), vec![0, 1, 2, 0]);
    let graph = coarse.build_graph(&s.frame()).unwrap();
    coarse.normalizers.update_inputs(&graph);
    for model in [plain, coarse] {
        check_every_parameter_gets_a_gradient(&s, &model);
    }
}

fn check_every_parameter_gets_a_gradient(s: &SyntheticScene, model: &Model) {
    let graph = model.build_graph(&s.frame()).unwrap();
    let (x, _) = model.predict(&graph, &s.frame()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let g: Vec<Vec3> = (0..s.curr.len()).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
    let grads = surrogate_backward(x, &g).unwrap();
    let mut visitor = GradNorms { grads: &grads, norms: Vec::new() };
    model.network.visit(&mut visitor);
    assert_eq!(visitor.norms.len(), model.network.num_params_tensors());
    for (k, (dims, norm)) in visitor.norms.iter().enumerate() {
        let norm = norm.unwrap_or_else(|| panic!("parameter {k} {dims:?} has no gradient"));
        assert!(norm > 0.0 && norm.is_finite(), "parameter {k} {dims:?} gradient norm {norm}");
    }
}

trait CountTensors {
    fn num_params_tensors(&self) -> usize;
}

impl<M: Module> CountTensors for M {
    fn num_params_tensors(&self) -> usize {
        struct Count(usize);
        impl ModuleVisitor for Count {
            fn visit_float<const D: usize>(&mut self, _: &Param<Tensor<D>>) {
                self.0 += 1;
            }
        }
        let mut c = Count(0);
        self.visit(&mut c);
        c.0
    }
}

/// `E(x) = ½ Σ_i w_i |x_i − c_i|² + ½ Σ_(a,b) |x_a − x_b|²` written in burn, and its gradient
/// `∂E/∂x_i = w_i (x_i − c_i) + Σ_(a,b) ±(x_a − x_b)` written in f64.
fn quadratic_energy(x: Tensor<2>, w: &[f64], c: &[Vec3], edges: &[[u32; 2]]) -> Tensor<1> {
    let device = x.device();
    let n = c.len();
    let w_t = senc_model::convert::f32_tensor(w, [n, 1], &device);
    let c_t = vec3_tensor(c, &device);
    let d = x.clone() - c_t;
    let anchor = (d.clone() * d * w_t).sum().mul_scalar(0.5);
    let idx = |k: usize| {
        let v: Vec<i64> = edges.iter().map(|e| i64::from(e[k])).collect();
        Tensor::<1, Int>::from_data(TensorData::new(v, [edges.len()]), &device)
    };
    let e = x.clone().select(0, idx(0)) - x.select(0, idx(1));
    anchor + (e.clone() * e).sum().mul_scalar(0.5)
}

fn quadratic_gradient(x: &[Vec3], w: &[f64], c: &[Vec3], edges: &[[u32; 2]]) -> Vec<Vec3> {
    let mut g: Vec<Vec3> = x.iter().zip(w).zip(c).map(|((x, w), c)| (x - c) * *w).collect();
    for &[a, b] in edges {
        let d = x[a as usize] - x[b as usize];
        g[a as usize] += d;
        g[b as usize] -= d;
    }
    g
}

#[test]
fn surrogate_gives_burns_own_gradient_for_a_quadratic_energy() {
    let s = scene();
    let device = Device::flex().autodiff();
    let model = warmed_model(&s, &device, 10);
    let graph = model.build_graph(&s.frame()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let n = s.curr.len();
    let w: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
    let c: Vec<Vec3> = s.curr.iter().map(|p| p + Vec3::new(0.0, -0.01, 0.003)).collect();
    let edges = s.rest.topology().edges().to_vec();

    // Burn's own gradient of E(x(θ)).
    let x = model.predict_positions(&graph, &s.frame());
    let x_values = tensor_to_vec3(x.clone().detach()).unwrap();
    let direct = quadratic_energy(x, &w, &c, &edges).backward();
    // The surrogate with g = ∂E/∂x computed outside burn.
    let g = quadratic_gradient(&x_values, &w, &c, &edges);
    let x = model.predict_positions(&graph, &s.frame());
    let surrogate = surrogate_backward(x, &g).unwrap();

    let mut a = GradNorms { grads: &direct, norms: Vec::new() };
    model.network.visit(&mut a);
    struct Grads<'a>(&'a Gradients, &'a Gradients, f64, f64);
    impl ModuleVisitor for Grads<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            let t = param.val();
            let a = tensor_to_f64(t.grad(self.0).unwrap());
            let b = tensor_to_f64(t.grad(self.1).unwrap());
            for (x, y) in a.iter().zip(&b) {
                self.2 = self.2.max((x - y).abs());
                self.3 = self.3.max(x.abs());
            }
        }
    }
    let mut cmp = Grads(&direct, &surrogate, 0.0, 0.0);
    model.network.visit(&mut cmp);
    assert!(cmp.3 > 0.0);
    // f32 arithmetic: g is rounded to f32 once, burn's own g is computed in f32.
    assert!(cmp.2 <= 1e-4 * cmp.3, "max difference {} against max gradient {}", cmp.2, cmp.3);

    // On a leaf, the gradient of Σ x ⊙ g is exactly g (as f32).
    let leaf = vec3_tensor(&x_values, &device).require_grad();
    let grads = surrogate_backward(leaf.clone(), &g).unwrap();
    let got = tensor_to_f64(leaf.grad(&grads).unwrap());
    let want: Vec<f64> = g.iter().flat_map(|v| [v.x, v.y, v.z]).map(|v| f64::from(v as f32)).collect();
    assert_eq!(got, want);
}

#[test]
fn surrogate_rejects_a_gradient_of_the_wrong_length() {
    let device = Device::flex().autodiff();
    let x = vec3_tensor(&[Vec3::zeros(); 4], &device).require_grad();
    assert!(matches!(
        surrogate_backward(x, &[Vec3::zeros(); 3]),
        Err(ModelError::GradientShape { got: 3, expected: 4 })
    ));
}

#[test]
fn normalizer_matches_direct_statistics() {
    let mut stats = senc_model::RunningStats::new(2);
    assert_eq!(stats.mean(), vec![0.0, 0.0]);
    assert_eq!(stats.std(), vec![1.0, 1.0]);
    stats.update(&[1.0, 5.0, 3.0, 5.0, f64::NAN, 1.0]);
    stats.update(&[5.0, 5.0]);
    assert_eq!(stats.count(), 3);
    assert!((stats.mean()[0] - 3.0).abs() < 1e-12);
    assert!((stats.std()[0] - (8.0f64 / 3.0).sqrt()).abs() < 1e-12);
    assert_eq!(stats.std()[1], senc_model::normalizer::STD_EPSILON);
    let mut rows = vec![3.0, 5.0];
    stats.normalize(&mut rows);
    assert_eq!(rows, vec![0.0, 0.0]);
}

#[test]
fn valid_model_matches_the_training_model() {
    let s = scene();
    let device = Device::flex().autodiff();
    let model = warmed_model(&s, &device, 13);
    let graph = model.build_graph(&s.frame()).unwrap();
    let train = tensor_to_f64(model.forward(&graph));
    let valid = model.valid();
    assert!(!valid.device.is_autodiff());
    let infer = tensor_to_f64(valid.forward(&graph));
    // Same weights; the autodiff path may pick different f32 kernels, so a few ulps apart.
    let scale = train.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = train.iter().zip(&infer).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(scale > 0.0 && diff <= 1e-5 * scale, "difference {diff} at scale {scale}");
}

/// Mesh-hop distances from `src` over undirected `edges`.
fn hops(n: usize, edges: &[[u32; 2]], src: usize) -> Vec<usize> {
    let mut adj = vec![Vec::new(); n];
    for &[a, b] in edges {
        adj[a as usize].push(b as usize);
        adj[b as usize].push(a as usize);
    }
    let mut d = vec![usize::MAX; n];
    d[src] = 0;
    let mut q = std::collections::VecDeque::from([src]);
    while let Some(v) = q.pop_front() {
        for &w in &adj[v] {
            if d[w] == usize::MAX {
                d[w] = d[v] + 1;
                q.push_back(w);
            }
        }
    }
    d
}

#[test]
fn coarse_levels_keep_about_half_the_vertices_and_stay_local() {
    let s = SyntheticScene::new(12, 0.01, 0, 1);
    let n = s.curr.len();
    let mesh = s.rest.topology().edges();
    let levels = senc_model::graph::coarsen(n, mesh, 2);
    let mut previous = n;
    for (k, pairs) in levels.iter().enumerate() {
        let verts: HashSet<u32> = pairs.iter().flatten().copied().collect();
        assert!(
            verts.len() * 10 >= previous * 3 && verts.len() * 10 <= previous * 7,
            "level {}: {} of {previous}",
            k + 1,
            verts.len()
        );
        previous = verts.len();
        for &[a, b] in pairs {
            assert!(a < b);
            let d = hops(n, mesh, a as usize)[b as usize];
            assert!(d >= 1 && d <= 2 << k, "level {} edge ({a}, {b}) spans {d} mesh hops", k + 1);
        }
    }
    // The graph carries them as two more edge types, in both directions.
    let config = GraphConfig { coarse_levels: 2, ..GraphConfig::default() };
    let g = GraphInputs::build(&s.frame(), &config).unwrap();
    assert_eq!(g.coarse_levels(), 2);
    assert_eq!(g.edge_set(EdgeType::Coarse(1)).len(), 2 * levels[0].len());
    assert_eq!(g.edge_set(EdgeType::Coarse(2)).len(), 2 * levels[1].len());
}

#[test]
fn zero_output_network_takes_the_mean_step_and_still_learns() {
    let s = scene();
    let device = Device::flex().autodiff();
    let mut model = warmed_model(&s, &device, 5);
    model.network = model.network.with_zero_output();
    let frame = s.frame();
    let graph = model.build_graph(&frame).unwrap();
    let (x, next) = model.predict(&graph, &frame).unwrap();
    // Every vertex gets free flight under gravity plus the output normaliser's mean
    // acceleration (m/s²) over the step.
    let mean = model.normalizers.output.mean();
    let dt2 = frame.dt * frame.dt;
    let forcing = frame.accel * dt2;
    assert!(forcing.norm() > 1e-3);
    for ((n, c), p) in next.iter().zip(frame.curr).zip(frame.prev) {
        let a = (n - (c * 2.0 - p) - forcing) / dt2;
        for k in 0..3 {
            assert!((a[k] - mean[k]).abs() < 1e-6 / dt2, "{a:?} vs {mean:?}");
        }
    }
    // The zeroed layer is still a tracked parameter: its gradient is non-zero.
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let g: Vec<Vec3> = (0..s.curr.len()).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
    let grads = surrogate_backward(x, &g).unwrap();
    let mut visitor = GradNorms { grads: &grads, norms: Vec::new() };
    model.network.visit(&mut visitor);
    let last: Vec<f64> = visitor.norms.iter().rev().take(2).map(|(_, n)| n.unwrap_or(0.0)).collect();
    assert!(last.iter().all(|&n| n > 0.0 && n.is_finite()), "decoder output layer gradients {last:?}");
}

/// Pinned cloth vertices are typed as kinematic nodes (`[0, 1]`, like the body); the
/// others stay free cloth (`[1, 0]`).
#[test]
fn pinned_cloth_vertices_are_kinematic_nodes() {
    let s = scene();
    let pinned = [0usize, 3];
    let frame = FrameState { pinned: &pinned, ..s.frame() };
    let g = GraphInputs::build(&frame, &GraphConfig::default()).unwrap();
    let f = senc_model::graph::NODE_FEATURES;
    for i in 0..s.curr.len() {
        let ty = [g.nodes[i * f + 3], g.nodes[i * f + 4]];
        let want = if pinned.contains(&i) { [0.0, 1.0] } else { [1.0, 0.0] };
        assert_eq!(ty, want, "vertex {i}");
    }
}

/// With `elastic_features` every node row has three more columns: the cloth's elastic
/// acceleration `−∇(E_stretch + E_bend)/m` at `x[t]` (zero on body nodes). It is zero for
/// the flat rest state, points back towards the rest length for a sheet stretched along x,
/// sums to zero over the garment (internal forces), and the model runs on it.
#[test]
fn elastic_features_are_the_internal_forces_per_unit_mass() {
    use senc_model::graph::{ELASTIC_FEATURES, NODE_FEATURES};
    let mut s = SyntheticScene::new(6, 0.02, 40, 5);
    let config = GraphConfig { elastic_features: true, ..GraphConfig::default() };
    let width = NODE_FEATURES + ELASTIC_FEATURES;
    assert_eq!(config.node_features(), width);
    let col = |g: &GraphInputs, i: usize| {
        let r = &g.nodes[i * width + NODE_FEATURES..(i + 1) * width];
        senc_geom::Vec3::new(r[0], r[1], r[2])
    };
    // At rest: no internal force.
    s.curr = s.rest.positions().to_vec();
    s.prev = s.curr.clone();
    let g = GraphInputs::build(&s.frame(), &config).unwrap();
    assert_eq!(g.nodes.len(), (g.n_cloth + g.n_body) * width);
    assert!((0..g.n_cloth).all(|i| col(&g, i).norm() < 1e-9));
    // Stretched 10 % along x: the two x-edges of the sheet are pulled inwards.
    s.curr = s.rest.positions().iter().map(|p| senc_geom::Vec3::new(1.1 * p.x, p.y, p.z)).collect();
    let g = GraphInputs::build(&s.frame(), &config).unwrap();
    let xs: Vec<f64> = s.curr.iter().map(|p| p.x).collect();
    let (lo, hi) = (xs.iter().copied().fold(f64::MAX, f64::min), xs.iter().copied().fold(f64::MIN, f64::max));
    for i in 0..g.n_cloth {
        let a = col(&g, i);
        if (xs[i] - hi).abs() < 1e-12 {
            assert!(a.x < 0.0, "right edge vertex {i}: {a:?}");
        }
        if (xs[i] - lo).abs() < 1e-12 {
            assert!(a.x > 0.0, "left edge vertex {i}: {a:?}");
        }
    }
    let masses = senc_model::graph::vertex_masses(&s.rest, s.material.density);
    let net: senc_geom::Vec3 = (0..g.n_cloth).map(|i| col(&g, i) * masses[i]).sum();
    let scale: f64 = (0..g.n_cloth).map(|i| (col(&g, i) * masses[i]).norm()).sum();
    assert!(net.norm() < 1e-9 * scale, "net internal force {net:?} of {scale}");
    assert!((g.n_cloth..g.n_cloth + g.n_body).all(|i| col(&g, i) == senc_geom::Vec3::zeros()));
    let model = Model::new(small_config(), config, 3, &Device::flex());
    assert_eq!(model.graph.node_features(), width);
    assert_eq!(model.step(&s.frame()).unwrap().len(), s.curr.len());
}
