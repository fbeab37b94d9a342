//! The message-passing graph of one frame and its raw (unnormalised, f64) features: cloth and
//! body nodes; mesh, body and self-collision edges. Pure f64 geometry, no burn.
//!
//! # Nodes
//! Cloth vertices come first (`0..n_cloth`), body vertices after them
//! (`n_cloth..n_cloth + n_body`). Node features, [`NODE_FEATURES`] = 15 columns, and
//! [`ELASTIC_FEATURES`] more with [`GraphConfig::elastic_features`]:
//!
//! | columns | meaning | unit |
//! |---|---|---|
//! | 0..3 | velocity per frame: cloth `x[t] − x[t−1]`, body `b[t+1] − b[t]`; with [`GraphConfig::comoving`] both minus the body's mean velocity `u` (below) | m / frame |
//! | 3, 4 | vertex type one-hot: free cloth `[1, 0]`; body and pinned cloth `[0, 1]` | – |
//! | 5..8 | unit area-weighted vertex normal (cloth at `t`, body at `t+1`) | – |
//! | 8 | `ln μ` (Lamé μ, HOOD's units); 0 for body | – |
//! | 9 | `λ` (Lamé λ, HOOD's units, sampled uniformly so not logged); 0 for body | – |
//! | 10 | `ln k_b` (bending stiffness); 0 for body | – |
//! | 11 | `ln m_i`, `m_i = Σ_{f∋i} ρ A_f / 3` (rest areas, ρ in kg/m²); 0 for body | ln kg |
//! | 12..15 | gravity + external acceleration `g + a_ext`, the same on every node | m/s² |
//! | 15..18 | only with [`GraphConfig::elastic_features`]: elastic acceleration `−∇(E_stretch + E_bend)(x[t]) / m_i` (the internal force of the cloth per unit mass: whether a vertex is held up by its neighbours); 0 for body | m/s² |
//!
//! # Edges
//! Every edge is directed `sender → receiver` and carries [`EDGE_FEATURES`] = 8 columns; every
//! undirected pair appears in both directions.
//! - **Mesh** (cloth–cloth, every edge of the garment): `x_s − x_r`, `|x_s − x_r|` at `t`,
//!   then the same at rest.
//! - **Body** (each cloth vertex and its nearest body vertex closer than
//!   [`GraphConfig::body_radius`] at `t`): `p_s − p_r`, `|p_s − p_r|` with body positions at
//!   `t`, then the same with body positions at `t+1` (cloth stays at `x[t]`).
//! - **Self-collision** (cloth pairs closer than [`GraphConfig::self_radius`] at `t`, by
//!   default excluding pairs joined by a mesh edge): `x_s − x_r`, `|x_s − x_r|` at `t`, then
//!   the same at rest (a pair far apart at rest but close now is a contact).
//!
//! - **Coarse level k** (optional, [`GraphConfig::coarse_levels`]): cloth pairs of HOOD's
//!   hierarchy ([`coarsen`]), same features as mesh edges.
//!
//! All features are differences of positions, so translating the scene leaves them unchanged;
//! renumbering the vertices permutes nodes and edges alike.
//!
//! # The body's frame
//! With [`GraphConfig::comoving`] the features are also unchanged by a uniform motion of the
//! whole scene (a Galilean boost), like the physics they stand for: the inertia, elastic and
//! contact energies of `x[t+1]` depend on velocities only through differences, and the
//! acceleration the network predicts is the same in every frame moving at constant velocity.
//! The reference is the body's mean velocity over the coming step, `u = mean_j (b[t+1] −
//! b[t])` (zero without a body). It is subtracted from every velocity column, and the body
//! edges' `t+1` half compares the cloth with `b[t+1] − u`, where the body will be relative to
//! a frame that moves with it. A boost by `w` per frame shifts `u` by `w`, so every feature is
//! invariant. A garment carried along by a walking body then looks to the network as it
//! does on a body walking in place.

use std::time::Instant;

use senc_geom::neighbors::{nearest_within, radius_pairs};
use senc_geom::{vertex_normals, TriMesh, Vec3};
use serde::{Deserialize, Serialize};

use crate::ModelError;

/// Number of node feature columns (see the module docs).
pub const NODE_FEATURES: usize = 15;
/// Node feature columns added by [`GraphConfig::elastic_features`].
pub const ELASTIC_FEATURES: usize = 3;
/// Number of edge feature columns, the same for every edge type.
pub const EDGE_FEATURES: usize = 8;
/// Number of edge types of every graph (mesh, body, self); coarse levels add one each.
pub const N_EDGE_TYPES: usize = 3;
/// Most coarse levels a graph may have.
pub const MAX_COARSE_LEVELS: usize = 8;

/// The edge types, each with its own encoder and message MLPs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum EdgeType {
    /// Garment mesh edges.
    Mesh,
    /// Cloth vertex ↔ nearest body vertex.
    Body,
    /// Cloth ↔ cloth proximity (SENC's self-collision edges).
    SelfCollision,
    /// Edges of coarse level `k ≥ 1` of the garment (HOOD's hierarchy, see [`coarsen`]).
    Coarse(u8),
}

impl EdgeType {
    /// The three edge types of every graph, in storage order; coarse levels follow them.
    pub const ALL: [EdgeType; N_EDGE_TYPES] = [EdgeType::Mesh, EdgeType::Body, EdgeType::SelfCollision];

    /// Index into per-type arrays: mesh 0, body 1, self 2, coarse level `k` at `2 + k`.
    pub fn index(self) -> usize {
        match self {
            EdgeType::Mesh => 0,
            EdgeType::Body => 1,
            EdgeType::SelfCollision => 2,
            EdgeType::Coarse(k) => 2 + k as usize,
        }
    }

    /// The edge type stored at `index` (the inverse of [`EdgeType::index`]).
    pub fn from_index(index: usize) -> Self {
        match index {
            0 => EdgeType::Mesh,
            1 => EdgeType::Body,
            2 => EdgeType::SelfCollision,
            k => EdgeType::Coarse((k - 2).min(u8::MAX as usize) as u8),
        }
    }

    /// Short name, used for normaliser and timing labels.
    pub fn name(self) -> String {
        match self {
            EdgeType::Mesh => "mesh".into(),
            EdgeType::Body => "body".into(),
            EdgeType::SelfCollision => "self".into(),
            EdgeType::Coarse(k) => format!("coarse{k}"),
        }
    }
}

/// Which self-collision edges to build (the paper's ablations). Written in snake case
/// (`[model] self_edges = "exclude_mesh"`); checkpoints that spell the variants in Pascal
/// case read too.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SelfEdges {
    /// No self-collision edges (HOOD, the baseline, "w/o self-col edge").
    #[serde(alias = "None")]
    None,
    /// Cloth pairs within the radius, pairs joined by a mesh edge excluded (SENC, default).
    #[default]
    #[serde(alias = "ExcludeMesh")]
    ExcludeMesh,
    /// Cloth pairs within the radius, mesh-edge pairs kept (ablation "w. mesh edge").
    #[serde(alias = "KeepMesh")]
    KeepMesh,
}

/// How the graph is built. Saved with every checkpoint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GraphConfig {
    /// Self-collision edge radius, metres (SENC: 0.02).
    pub self_radius: f64,
    /// Body edge radius, metres (HOOD: 0.03).
    pub body_radius: f64,
    /// Self-collision edge mode.
    pub self_edges: SelfEdges,
    /// Number of coarse levels (0: none; at most [`MAX_COARSE_LEVELS`]). [`crate::Model`]
    /// sets it from its [`crate::ModelConfig`].
    #[serde(default)]
    pub coarse_levels: usize,
    /// Whether the nodes carry the cloth's elastic acceleration (module docs, columns
    /// 15..18). Absent from older checkpoints, which read as false.
    #[serde(default)]
    pub elastic_features: bool,
    /// Whether velocities are measured in the body's frame (module docs, "The body's frame").
    /// Absent from older checkpoints, which read as false (world velocities).
    #[serde(default)]
    pub comoving: bool,
}

impl GraphConfig {
    /// Node feature columns of graphs built with this config.
    pub fn node_features(&self) -> usize {
        NODE_FEATURES + if self.elastic_features { ELASTIC_FEATURES } else { 0 }
    }
}

impl Default for GraphConfig {
    fn default() -> Self {
        Self {
            self_radius: 0.02,
            body_radius: 0.03,
            self_edges: SelfEdges::ExcludeMesh,
            coarse_levels: 0,
            elastic_features: false,
            comoving: false,
        }
    }
}

/// The garment material (senc-energy's: Lamé parameters, thickness, bending stiffness,
/// density; HOOD's defaults).
pub use senc_energy::Material;

/// The body (obstacle) of one frame: its triangles and its vertices now and next frame.
#[derive(Debug, Clone, Copy)]
pub struct BodyState<'a> {
    /// Body triangles (indices into `curr` / `next`), used for normals only.
    pub faces: &'a [[u32; 3]],
    /// Body vertices at `t`, metres.
    pub curr: &'a [Vec3],
    /// Body vertices at `t+1`, metres (known: the body motion is prescribed).
    pub next: &'a [Vec3],
}

/// Everything the network sees about one frame, in f64.
#[derive(Debug, Clone, Copy)]
pub struct FrameState<'a> {
    /// The garment at rest (positions and faces; the faces define the mesh edges).
    pub rest: &'a TriMesh,
    /// Cloth vertices at `t−1`, metres.
    pub prev: &'a [Vec3],
    /// Cloth vertices at `t`, metres.
    pub curr: &'a [Vec3],
    /// The garment material.
    pub material: Material,
    /// Gravity plus the sequence's external acceleration `g + a_ext`, m/s².
    pub accel: Vec3,
    /// Time step `Δt` from `t` to `t+1`, s. The known forcing step `Δt² (g + a_ext)` is added
    /// to the network's output (see [`crate::Model::predict`]).
    pub dt: f64,
    /// The body, if the scene has one.
    pub body: Option<BodyState<'a>>,
    /// Pinned cloth vertices (prescribed positions, e.g. a skirt's waist), sorted; they are
    /// typed as kinematic nodes (type one-hot `[0, 1]`, like the body). Empty: none.
    pub pinned: &'a [usize],
}

/// One edge set: directed edges and their raw features.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EdgeSet {
    /// Sender node of each edge.
    pub senders: Vec<u32>,
    /// Receiver node of each edge.
    pub receivers: Vec<u32>,
    /// Row-major `[n_edges, EDGE_FEATURES]` raw features.
    pub features: Vec<f64>,
}

impl EdgeSet {
    /// Number of directed edges.
    pub fn len(&self) -> usize {
        self.senders.len()
    }

    /// Whether there are no edges.
    pub fn is_empty(&self) -> bool {
        self.senders.is_empty()
    }

    fn push(&mut self, s: u32, r: u32, feat: [f64; EDGE_FEATURES]) {
        self.senders.push(s);
        self.receivers.push(r);
        self.features.extend_from_slice(&feat);
    }
}

/// Wall-clock time of each graph-building stage, seconds (for benchmarks).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BuildTimings {
    /// Node features (normals, masses).
    pub nodes: f64,
    /// Mesh edges.
    pub mesh: f64,
    /// Body edges (nearest-neighbour search included).
    pub body: f64,
    /// Self-collision edges (radius search included).
    pub self_collision: f64,
}

/// The graph of one frame with raw f64 features: the input of [`crate::Model::forward`].
#[derive(Debug, Clone, PartialEq)]
pub struct GraphInputs {
    /// Number of cloth nodes (the first nodes).
    pub n_cloth: usize,
    /// Number of body nodes (after the cloth nodes).
    pub n_body: usize,
    /// Row-major `[n_cloth + n_body, NODE_FEATURES]` raw node features.
    pub nodes: Vec<f64>,
    /// Edge sets indexed by [`EdgeType::index`]: mesh, body, self, then one per coarse level.
    pub edges: Vec<EdgeSet>,
}

impl GraphInputs {
    /// Builds the graph of one frame. Checks lengths and finiteness; never panics on bad input.
    pub fn build(frame: &FrameState<'_>, config: &GraphConfig) -> Result<Self, ModelError> {
        Self::build_timed(frame, config).map(|(g, _)| g)
    }

    /// [`GraphInputs::build`], also returning how long each stage took.
    pub fn build_timed(frame: &FrameState<'_>, config: &GraphConfig) -> Result<(Self, BuildTimings), ModelError> {
        validate(frame)?;
        let mut timings = BuildTimings::default();
        let n_cloth = frame.rest.n_vertices();
        let n_body = frame.body.map_or(0, |b| b.curr.len());

        let t0 = Instant::now();
        let u = if config.comoving { body_velocity(frame) } else { Vec3::zeros() };
        let nodes = node_features(frame, config.elastic_features, u)?;
        timings.nodes = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let rest = frame.rest.positions();
        let x = frame.curr;
        let mut mesh = EdgeSet::default();
        for &[a, b] in frame.rest.topology().edges() {
            mesh.push(a, b, pair_features(x[a as usize] - x[b as usize], rest[a as usize] - rest[b as usize]));
            mesh.push(b, a, pair_features(x[b as usize] - x[a as usize], rest[b as usize] - rest[a as usize]));
        }
        timings.mesh = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let mut body_edges = EdgeSet::default();
        if let Some(body) = frame.body {
            let hits = nearest_within(x, body.curr, config.body_radius);
            for (i, hit) in hits.into_iter().enumerate() {
                if let Some((j, _)) = hit {
                    let (c, b) = (i as u32, (n_cloth + j as usize) as u32);
                    let ju = j as usize;
                    // cloth → body: sender cloth, receiver body.
                    let next = body.next[ju] - u;
                    body_edges.push(c, b, pair_features(x[i] - body.curr[ju], x[i] - next));
                    body_edges.push(b, c, pair_features(body.curr[ju] - x[i], next - x[i]));
                }
            }
        }
        timings.body = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let mut self_edges = EdgeSet::default();
        if config.self_edges != SelfEdges::None {
            let topo = frame.rest.topology();
            for [a, b] in radius_pairs(x, config.self_radius) {
                if config.self_edges == SelfEdges::ExcludeMesh && topo.find_edge(a, b).is_some() {
                    continue;
                }
                let (au, bu) = (a as usize, b as usize);
                self_edges.push(a, b, pair_features(x[au] - x[bu], rest[au] - rest[bu]));
                self_edges.push(b, a, pair_features(x[bu] - x[au], rest[bu] - rest[au]));
            }
        }
        timings.self_collision = t0.elapsed().as_secs_f64();

        let mut edges = vec![mesh, body_edges, self_edges];
        let levels = config.coarse_levels.min(MAX_COARSE_LEVELS);
        if levels > 0 {
            let t0 = Instant::now();
            for pairs in coarsen(n_cloth, frame.rest.topology().edges(), levels) {
                let mut set = EdgeSet::default();
                for [a, b] in pairs {
                    let (au, bu) = (a as usize, b as usize);
                    set.push(a, b, pair_features(x[au] - x[bu], rest[au] - rest[bu]));
                    set.push(b, a, pair_features(x[bu] - x[au], rest[bu] - rest[au]));
                }
                edges.push(set);
            }
            timings.mesh += t0.elapsed().as_secs_f64();
        }
        Ok((Self { n_cloth, n_body, nodes, edges }, timings))
    }

    /// Total node count.
    pub fn n_nodes(&self) -> usize {
        self.n_cloth + self.n_body
    }

    /// The edge set of one type (empty for a coarse level the graph does not have).
    pub fn edge_set(&self, t: EdgeType) -> &EdgeSet {
        static EMPTY: EdgeSet = EdgeSet { senders: Vec::new(), receivers: Vec::new(), features: Vec::new() };
        self.edges.get(t.index()).unwrap_or(&EMPTY)
    }

    /// Number of coarse levels in this graph.
    pub fn coarse_levels(&self) -> usize {
        self.edges.len().saturating_sub(N_EDGE_TYPES)
    }
}

/// HOOD's hierarchy: `levels` coarse edge sets of a mesh with `n` vertices and undirected
/// `edges` (`[a, b]`, `a < b`), each as sorted undirected pairs `[a, b]`, `a < b`.
///
/// Level `k` keeps every other vertex of level `k − 1`: a breadth-first search over level
/// `k − 1`'s edges from the smallest vertex of each connected component keeps the vertices
/// at even depth. Two kept vertices are joined at level `k` when they were adjacent or had a
/// common neighbour at level `k − 1`. Level 0 is the mesh itself (all vertices). The result
/// depends only on the topology, not on positions.
pub fn coarsen(n: usize, edges: &[[u32; 2]], levels: usize) -> Vec<Vec<[u32; 2]>> {
    let mut active = vec![true; n];
    let mut current: Vec<[u32; 2]> = edges.to_vec();
    let mut out = Vec::with_capacity(levels);
    for _ in 0..levels {
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &[a, b] in &current {
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
        let mut depth = vec![u32::MAX; n];
        let mut queue = std::collections::VecDeque::new();
        for s in 0..n {
            if !active[s] || depth[s] != u32::MAX {
                continue;
            }
            depth[s] = 0;
            queue.push_back(s);
            while let Some(v) = queue.pop_front() {
                for &w in &adj[v] {
                    if depth[w as usize] == u32::MAX {
                        depth[w as usize] = depth[v] + 1;
                        queue.push_back(w as usize);
                    }
                }
            }
        }
        let kept: Vec<bool> = (0..n).map(|v| active[v] && depth[v] % 2 == 0).collect();
        let mut next = Vec::new();
        for w in 0..n {
            if !active[w] {
                continue;
            }
            let mut around: Vec<u32> = adj[w].iter().copied().filter(|&u| kept[u as usize]).collect();
            if kept[w] {
                around.push(w as u32);
            }
            for i in 0..around.len() {
                for j in i + 1..around.len() {
                    let (a, b) = (around[i].min(around[j]), around[i].max(around[j]));
                    if a != b {
                        next.push([a, b]);
                    }
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        out.push(next.clone());
        active = kept;
        current = next;
    }
    out
}

/// `[d, |d|, d_alt, |d_alt|]`.
fn pair_features(d: Vec3, d_alt: Vec3) -> [f64; EDGE_FEATURES] {
    [d.x, d.y, d.z, d.norm(), d_alt.x, d_alt.y, d_alt.z, d_alt.norm()]
}

fn check_finite(what: &'static str, v: &[Vec3]) -> Result<(), ModelError> {
    match v.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(index) => Err(ModelError::NotFinite { what, index }),
        None => Ok(()),
    }
}

fn validate(frame: &FrameState<'_>) -> Result<(), ModelError> {
    let n = frame.rest.n_vertices();
    for (what, v) in [("cloth x[t-1]", frame.prev), ("cloth x[t]", frame.curr)] {
        if v.len() != n {
            return Err(ModelError::LengthMismatch { what, got: v.len(), expected: n });
        }
        check_finite(what, v)?;
    }
    if !frame.accel.iter().all(|c| c.is_finite()) {
        return Err(ModelError::NotFinite { what: "gravity + external acceleration", index: 0 });
    }
    if !(frame.dt.is_finite() && frame.dt > 0.0) {
        return Err(ModelError::BadMaterial { what: "time step dt", value: frame.dt });
    }
    let m = frame.material;
    for (what, value) in [
        ("mu", m.mu),
        ("lambda", m.lambda),
        ("thickness", m.thickness),
        ("bending", m.bending_stiffness),
        ("density", m.density),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(ModelError::BadMaterial { what, value });
        }
    }
    if let Some(body) = frame.body {
        let nb = body.curr.len();
        if body.next.len() != nb {
            return Err(ModelError::LengthMismatch { what: "body b[t+1]", got: body.next.len(), expected: nb });
        }
        check_finite("body b[t]", body.curr)?;
        check_finite("body b[t+1]", body.next)?;
        for (face, f) in body.faces.iter().enumerate() {
            if let Some(&vertex) = f.iter().find(|&&v| v as usize >= nb) {
                return Err(ModelError::BadBodyFace { face, vertex, n_vertices: nb });
            }
        }
    }
    Ok(())
}

/// The cloth's elastic acceleration `−∇(E_stretch + E_bend)(x[t]) / m_i` per vertex, from
/// senc-energy's model of the garment (its own lumped masses). The model is cached per
/// thread, since a rollout or a training run builds graphs of the same few garments and
/// materials over and over: keyed by the rest mesh's contents (sizes and a hash of its
/// positions and faces) and the material's bits, at most [`ELASTIC_CACHE`] entries.
fn elastic_accelerations(frame: &FrameState<'_>) -> Result<Vec<Vec3>, ModelError> {
    use std::cell::RefCell;
    use std::hash::{Hash, Hasher};
    use std::sync::Arc;
    type Key = (usize, usize, u64, [u64; 5]);
    thread_local! {
        static CACHE: RefCell<Vec<(Key, Arc<senc_energy::EnergyModel>)>> = const { RefCell::new(Vec::new()) };
    }
    let m = frame.material;
    let rest = frame.rest;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    rest.positions().iter().flat_map(|p| p.iter()).for_each(|c| c.to_bits().hash(&mut h));
    rest.faces().hash(&mut h);
    let key: Key = (
        rest.n_vertices(),
        rest.n_faces(),
        h.finish(),
        [m.mu, m.lambda, m.thickness, m.bending_stiffness, m.density].map(f64::to_bits),
    );
    let model = CACHE.with(|c| {
        let mut c = c.borrow_mut();
        if let Some(pos) = c.iter().position(|(k, _)| *k == key) {
            let entry = c.remove(pos);
            let model = Arc::clone(&entry.1);
            c.push(entry);
            return Ok::<_, ModelError>(model);
        }
        let mut config = senc_energy::EnergyConfig { material: m, ..Default::default() };
        config.self_collision.weight = 0.0;
        let model = Arc::new(senc_energy::EnergyModel::new(rest, &config, None)?);
        if c.len() >= ELASTIC_CACHE {
            c.remove(0);
        }
        c.push((key, Arc::clone(&model)));
        Ok(model)
    })?;
    let grad = model.elastic_gradient(frame.curr)?;
    Ok(grad.iter().zip(model.masses()).map(|(g, &mi)| if mi > 0.0 { -g / mi } else { Vec3::zeros() }).collect())
}

/// Most elastic models [`elastic_accelerations`] keeps per thread.
const ELASTIC_CACHE: usize = 8;

/// Lumped vertex masses `m_i = Σ_{f∋i} ρ A_f / 3`, kg, from the rest mesh.
pub fn vertex_masses(rest: &TriMesh, density: f64) -> Vec<f64> {
    let mut m = vec![0.0; rest.n_vertices()];
    for f in 0..rest.n_faces() {
        let area = 0.5 * rest.face_normal_scaled(f).norm();
        for &v in &rest.faces()[f] {
            m[v as usize] += density * area / 3.0;
        }
    }
    m
}

/// The body's mean velocity over the coming step, `mean_j (b[t+1] − b[t])`, m per frame
/// (zero without a body): the reference of [`GraphConfig::comoving`].
fn body_velocity(frame: &FrameState<'_>) -> Vec3 {
    match frame.body {
        Some(b) if !b.curr.is_empty() => {
            b.next.iter().zip(b.curr).fold(Vec3::zeros(), |s, (n, c)| s + (n - c)) / b.curr.len() as f64
        }
        _ => Vec3::zeros(),
    }
}

fn node_features(frame: &FrameState<'_>, elastic: bool, u: Vec3) -> Result<Vec<f64>, ModelError> {
    let n_cloth = frame.rest.n_vertices();
    let n_body = frame.body.map_or(0, |b| b.curr.len());
    let mut out = Vec::with_capacity((n_cloth + n_body) * (NODE_FEATURES + ELASTIC_FEATURES));
    let normals = vertex_normals(frame.curr, frame.rest.faces());
    let masses = vertex_masses(frame.rest, frame.material.density);
    let m = frame.material;
    let g = frame.accel;
    let elastic_acc = if elastic { elastic_accelerations(frame)? } else { Vec::new() };
    for i in 0..n_cloth {
        let kinematic = frame.pinned.binary_search(&i).is_ok();
        let v = frame.curr[i] - frame.prev[i] - u;
        let n = normals[i];
        // An isolated vertex has no mass; clamp so that the log stays finite.
        let log_m = masses[i].max(1e-12).ln();
        out.extend_from_slice(&[
            v.x,
            v.y,
            v.z,
            if kinematic { 0.0 } else { 1.0 },
            if kinematic { 1.0 } else { 0.0 },
            n.x,
            n.y,
            n.z,
            m.mu.ln(),
            m.lambda,
            m.bending_stiffness.ln(),
            log_m,
            g.x,
            g.y,
            g.z,
        ]);
        if let Some(e) = elastic_acc.get(i) {
            out.extend_from_slice(&[e.x, e.y, e.z]);
        }
    }
    if let Some(body) = frame.body {
        let normals = vertex_normals(body.next, body.faces);
        for j in 0..n_body {
            let v = body.next[j] - body.curr[j] - u;
            let n = normals[j];
            out.extend_from_slice(&[v.x, v.y, v.z, 0.0, 1.0, n.x, n.y, n.z, 0.0, 0.0, 0.0, 0.0, g.x, g.y, g.z]);
            if elastic {
                out.extend_from_slice(&[0.0; ELASTIC_FEATURES]);
            }
        }
    }
    Ok(out)
}
