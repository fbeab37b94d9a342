//! The one place where f64 geometry becomes f32 tensors and f32 tensors become f64 again.
//!
//! Normalisation happens here too, in f64, just before the cast, so everything the network
//! sees has been rounded to f32 exactly once.

use burn::tensor::{Device, Int, Tensor, TensorData};
use senc_geom::Vec3;

use crate::graph::{EdgeType, GraphInputs, EDGE_FEATURES};
use crate::normalizer::Normalizers;
use crate::ModelError;

/// One edge set on the device.
#[derive(Debug, Clone)]
pub struct EdgeTensors {
    /// Sender node per edge, `[E]`.
    pub senders: Tensor<1, Int>,
    /// Receiver node per edge, `[E]`.
    pub receivers: Tensor<1, Int>,
    /// Normalised features, `[E, EDGE_FEATURES]`.
    pub features: Tensor<2>,
}

/// A graph on the device, normalised, in f32: what [`crate::Network::forward`] consumes.
#[derive(Debug, Clone)]
pub struct GraphTensors {
    /// Number of cloth nodes (the first rows).
    pub n_cloth: usize,
    /// Total node count.
    pub n_nodes: usize,
    /// Normalised node features, `[n_nodes, node features]`.
    pub nodes: Tensor<2>,
    /// Edge sets by [`EdgeType::index`]; `None` where the graph has no edge of that type.
    pub edges: Vec<Option<EdgeTensors>>,
}

impl GraphTensors {
    /// Normalises `graph` with `norm` (f64) and uploads it as f32 to `device`. Edge types
    /// without a normaliser in `norm` (coarse levels the model does not have) are dropped.
    pub fn new(graph: &GraphInputs, norm: &Normalizers, device: &Device) -> Self {
        Self::upload(&HostGraph::new(graph, norm), device)
    }

    /// Uploads a graph already normalised and cast on the host.
    pub fn upload(host: &HostGraph, device: &Device) -> Self {
        let width = host.nodes.len() / host.n_nodes.max(1);
        let nodes = Tensor::from_data(TensorData::new(host.nodes.clone(), [host.n_nodes, width]), device);
        let edges = host
            .edges
            .iter()
            .map(|set| {
                set.as_ref().map(|set| EdgeTensors {
                    senders: index_tensor(&set.senders, device),
                    receivers: index_tensor(&set.receivers, device),
                    features: Tensor::from_data(
                        TensorData::new(set.features.clone(), [set.senders.len(), EDGE_FEATURES]),
                        device,
                    ),
                })
            })
            .collect();
        Self { n_cloth: host.n_cloth, n_nodes: host.n_nodes, nodes, edges }
    }
}

/// One edge set normalised and cast to f32, on the host.
#[derive(Debug, Clone, PartialEq)]
pub struct HostEdges {
    /// Sender node per edge.
    pub senders: Vec<u32>,
    /// Receiver node per edge.
    pub receivers: Vec<u32>,
    /// Normalised features, row-major `[E, EDGE_FEATURES]`.
    pub features: Vec<f32>,
}

/// A graph normalised (in f64) and cast to f32 on the host: what both [`GraphTensors`] (burn)
/// and [`crate::fused::FusedNetwork`] (the CPU inference path) consume, so that the two see
/// the same f32 inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct HostGraph {
    /// Number of cloth nodes (the first rows).
    pub n_cloth: usize,
    /// Total node count.
    pub n_nodes: usize,
    /// Normalised node features, row-major `[n_nodes, node features]`.
    pub nodes: Vec<f32>,
    /// Edge sets by [`EdgeType::index`], one per normaliser in `norm`; `None` where the graph
    /// has no edge of that type.
    pub edges: Vec<Option<HostEdges>>,
}

impl HostGraph {
    /// Normalises `graph` with `norm` in f64 and rounds it to f32 once. Edge types without a
    /// normaliser in `norm` (coarse levels the model does not have) are dropped.
    pub fn new(graph: &GraphInputs, norm: &Normalizers) -> Self {
        let mut nodes = graph.nodes.clone();
        norm.node.normalize(&mut nodes);
        let edges = (0..norm.edges.len())
            .map(|k| {
                let set = graph.edge_set(EdgeType::from_index(k));
                if set.is_empty() {
                    return None;
                }
                let mut feat = set.features.clone();
                norm.edges[k].normalize(&mut feat);
                Some(HostEdges {
                    senders: set.senders.clone(),
                    receivers: set.receivers.clone(),
                    features: to_f32(&feat),
                })
            })
            .collect();
        Self { n_cloth: graph.n_cloth, n_nodes: graph.n_nodes(), nodes: to_f32(&nodes), edges }
    }
}

/// Rounds f64 values to f32.
pub fn to_f32(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

/// A row-major f64 array as an f32 tensor of the given shape.
pub fn f32_tensor<const D: usize>(values: &[f64], shape: [usize; D], device: &Device) -> Tensor<D> {
    Tensor::from_data(TensorData::new(to_f32(values), shape), device)
}

/// Node indices as an integer tensor `[n]`.
pub fn index_tensor(indices: &[u32], device: &Device) -> Tensor<1, Int> {
    let data: Vec<i64> = indices.iter().map(|&i| i64::from(i)).collect();
    Tensor::from_data(TensorData::new(data, [indices.len()]), device)
}

/// Points as an f32 tensor `[n, 3]`.
pub fn vec3_tensor(points: &[Vec3], device: &Device) -> Tensor<2> {
    let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    f32_tensor(&flat, [points.len(), 3], device)
}

/// A `[n, 3]` tensor back to f64 points (reads the tensor back from the device).
pub fn tensor_to_vec3(t: Tensor<2>) -> Result<Vec<Vec3>, ModelError> {
    let [_, cols] = t.dims();
    if cols != 3 {
        return Err(ModelError::NotPoints { columns: cols });
    }
    let v = tensor_to_f64(t);
    Ok(v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}

/// Any float tensor back to a flat row-major f64 vector.
pub fn tensor_to_f64<const D: usize>(t: Tensor<D>) -> Vec<f64> {
    t.into_data().convert::<f32>().iter::<f32>().map(f64::from).collect()
}
