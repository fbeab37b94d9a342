//! [`Model`]: the network together with everything needed to use it (its config, the graph
//! config and the normalisers), the object a checkpoint restores.

use burn::module::Module;
use burn::tensor::{Device, Tensor};
use senc_geom::Vec3;

use crate::convert::{f32_tensor, tensor_to_vec3, GraphTensors};
use crate::fused::FusedNetwork;
use crate::graph::{GraphConfig, GraphInputs};
use crate::network::{ModelConfig, Network};
use crate::normalizer::Normalizers;
use crate::ModelError;

/// The trained object: network, sizes, graph construction and normalisers.
///
/// Training uses a model on an autodiff device (`Device::flex().autodiff()`), inference a
/// [`Model::valid`] copy (otherwise every forward records an autodiff graph).
#[derive(Debug, Clone)]
pub struct Model {
    /// The burn module (hand it to the optimiser).
    pub network: Network,
    /// Network sizes.
    pub config: ModelConfig,
    /// How graphs are built for this model.
    pub graph: GraphConfig,
    /// Input and output normalisers.
    pub normalizers: Normalizers,
    /// The device the network lives on.
    pub device: Device,
}

/// Draws a network's initial weights from burn's generator, seeded first when `seed` is
/// given. burn's generator is global and burn initialises parameters lazily (at first
/// use), so the draws are forced here, inside one process-wide lock: otherwise a model
/// initialised or loaded on another thread (a load draws initial weights too, then
/// overwrites them) shifts the numbers this seed gives (seen as flaky resume tests).
pub(crate) fn init_network(config: &ModelConfig, node_features: usize, seed: Option<u64>, device: &Device) -> Network {
    static INIT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = INIT.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(seed) = seed {
        device.seed(seed);
    }
    let network = config.init(node_features, device);
    network.visit(&mut ForceInit);
    network
}

/// Touches every parameter so that its lazy initialisation runs now.
struct ForceInit;

impl burn::module::ModuleVisitor for ForceInit {
    fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<burn::tensor::Tensor<D>>) {
        let _ = param.val();
    }
}

impl Model {
    /// A freshly initialised model. `seed` seeds the device's generator before the weights
    /// are drawn. burn's generator is global, so seeding and drawing hold a process-wide
    /// lock: two models initialised at once on different threads (parallel tests, several
    /// trainers in one process) each get exactly the weights of their seed.
    /// `graph.coarse_levels` is overwritten by `config.coarse_levels`.
    pub fn new(config: ModelConfig, mut graph: GraphConfig, seed: u64, device: &Device) -> Self {
        graph.coarse_levels = config.coarse_levels.min(crate::graph::MAX_COARSE_LEVELS);
        let network = init_network(&config, graph.node_features(), Some(seed), device);
        let normalizers = Normalizers::new(graph.coarse_levels, graph.node_features());
        Self { network, config, graph, normalizers, device: device.clone() }
    }

    /// The same model without autodiff, for inference.
    pub fn valid(&self) -> Self {
        Self { network: self.network.valid(), device: self.device.clone().inner(), ..self.clone() }
    }

    /// Builds the graph of a frame with this model's [`GraphConfig`].
    pub fn build_graph(&self, frame: &crate::FrameState<'_>) -> Result<GraphInputs, ModelError> {
        GraphInputs::build(frame, &self.graph)
    }

    /// Uploads a graph (normalising it) to this model's device.
    pub fn tensors(&self, graph: &GraphInputs) -> GraphTensors {
        GraphTensors::new(graph, &self.normalizers, &self.device)
    }

    /// The predicted response acceleration per cloth vertex, m/s²: the cloth's own
    /// acceleration beyond gravity and the external force (stretching, bending, contact), so
    /// that `x[t+1] = 2 x[t] − x[t−1] + Δt² (g + a_ext + forward(..))`. An acceleration, as in
    /// HOOD, rather than a displacement: the same output is right for the long first step
    /// and for ordinary frames (a displacement normalised on 1/30 s frames is 9× too small
    /// to hold cloth up over a 0.1 s step).
    ///
    /// # Shapes
    /// `[n_cloth, 3]`, f32, on this model's device (tracked when the device is autodiff).
    pub fn forward(&self, graph: &GraphInputs) -> Tensor<2> {
        self.forward_tensors(&self.tensors(graph))
    }

    /// [`Model::forward`] on an already uploaded graph. `[n_cloth, 3]`.
    pub fn forward_tensors(&self, g: &GraphTensors) -> Tensor<2> {
        let out = self.network.forward(g); // [n_cloth, 3], normalised
        let mean = f32_tensor(&self.normalizers.output.mean(), [1, 3], &self.device);
        let std = f32_tensor(&self.normalizers.output.std(), [1, 3], &self.device);
        out * std + mean
    }

    /// The known part of the next positions, `2 x[t] − x[t−1] + Δt² (g + a_ext)`: free flight
    /// under gravity and the external force. The network predicts only the rest, the
    /// response of the cloth (stretching, bending, contact), so a force it never saw in
    /// training (a new wind direction) still moves the garment exactly, and the output
    /// normaliser's statistics describe that response, not the sequence's random force.
    pub fn free_flight(frame: &crate::FrameState<'_>) -> Vec<Vec3> {
        let f = frame.accel * (frame.dt * frame.dt);
        frame.curr.iter().zip(frame.prev).map(|(c, p)| c * 2.0 - p + f).collect()
    }

    /// The predicted next cloth positions `x[t+1] = free flight + r` (see
    /// [`Model::free_flight`]) as a tensor (tracked when the device is autodiff).
    /// `[n_cloth, 3]`.
    pub fn predict_positions(&self, graph: &GraphInputs, frame: &crate::FrameState<'_>) -> Tensor<2> {
        let base: Vec<f64> = Self::free_flight(frame).iter().flat_map(|b| [b.x, b.y, b.z]).collect();
        let base = f32_tensor(&base, [frame.curr.len(), 3], &self.device);
        base + self.forward(graph) * (frame.dt * frame.dt) as f32
    }

    /// One training prediction: the tracked response displacement `r = Δt² a` `[n_cloth, 3]`
    /// (`a` from [`Model::forward`]) and the next positions in f64,
    /// `x[t+1] = 2 x[t] − x[t−1] + Δt² (g + a_ext) + r` (the f32 `r` read back once).
    ///
    /// Feed `∂E/∂x[t+1]` at those positions to [`crate::surrogate_backward`] together with the
    /// tensor: `x[t+1]` and `a` differ by a constant, so they have the same parameter gradient.
    pub fn predict(
        &self,
        graph: &GraphInputs,
        frame: &crate::FrameState<'_>,
    ) -> Result<(Tensor<2>, Vec<Vec3>), ModelError> {
        let accel = self.forward(graph) * (frame.dt * frame.dt) as f32;
        let a = tensor_to_vec3(accel.clone().detach())?;
        if a.len() != frame.curr.len() {
            return Err(ModelError::LengthMismatch { what: "cloth x[t]", got: frame.curr.len(), expected: a.len() });
        }
        let next = Self::free_flight(frame).into_iter().zip(a).map(|(b, a)| b + a).collect();
        Ok((accel, next))
    }

    /// Inference in f64: next cloth positions for one frame (graph built, network run on a
    /// [`Model::valid`] copy of itself if the device is autodiff, result read back).
    pub fn step(&self, frame: &crate::FrameState<'_>) -> Result<Vec<Vec3>, ModelError> {
        let graph = self.build_graph(frame)?;
        let accel = if self.device.is_autodiff() { self.valid().forward(&graph) } else { self.forward(&graph) };
        Ok(Self::integrate(frame, tensor_to_vec3(accel)?))
    }

    /// The next positions from the predicted response accelerations `a` (m/s²):
    /// `x[t+1] = free flight + Δt² a` (see [`Model::free_flight`]).
    pub(crate) fn integrate(frame: &crate::FrameState<'_>, accel: Vec<Vec3>) -> Vec<Vec3> {
        let dt2 = frame.dt * frame.dt;
        Self::free_flight(frame).into_iter().zip(accel).map(|(b, a)| b + a * dt2).collect()
    }
}

/// How a model runs inference in rollouts: the fused host path ([`FusedNetwork`]) when the
/// model lives on the CPU (flex) device, burn's tensors otherwise (a GPU device). Build it
/// once per rollout with [`Model::stepper`]: it copies the weights.
#[derive(Debug, Clone)]
pub enum Stepper {
    /// The fused CPU path.
    Fused(Box<FusedNetwork>),
    /// burn on the model's (non-autodiff) device.
    Burn(Box<Model>),
}

impl Model {
    /// The inference engine for this model's device (see [`Stepper`]).
    pub fn stepper(&self) -> Stepper {
        if self.device.clone().inner() == Device::flex() {
            Stepper::Fused(Box::new(FusedNetwork::new(self)))
        } else {
            Stepper::Burn(Box::new(self.valid()))
        }
    }
}

impl Stepper {
    /// The next cloth positions of one frame (see [`Model::step`]).
    pub fn step(&self, frame: &crate::FrameState<'_>) -> Result<Vec<Vec3>, ModelError> {
        match self {
            Self::Fused(f) => f.step(frame),
            Self::Burn(m) => m.step(frame),
        }
    }
}
