//! Scene-driven assembly: the energy of one frame built from the rest mesh, the material and
//! config, and an optional body, with only the terms the scene needs.

use std::sync::{Arc, Mutex};

use nalgebra::Matrix3;
use rayon::prelude::*;
use serde::Serialize;

use senc_geom::{close_holes, HoleSelection, TriMesh, Vec3};

use crate::config::{BendingRest, EnergyConfig};
use crate::error::EnergyError;
use crate::hessian::BlockSparse;
use crate::rest::RestState;
use crate::scatter::{Gather, Scatter, VERTEX_CHUNK};
use crate::terms::bending::Bending;
use crate::terms::body::{BodyQueries, Collision, Friction};
use crate::terms::gravity::UniformField;
use crate::terms::inertia::Inertia;
use crate::terms::repulsion::Repulsion;
use crate::terms::self_collision::SelfCollision;
use crate::terms::stretching::Stretching;

/// Names of the terms, as they appear in breakdowns and `cargo xtask energy --json`.
pub mod names {
    /// StVK stretching.
    pub const STRETCHING: &str = "stretching";
    /// Discrete-shell bending.
    pub const BENDING: &str = "bending";
    /// Inertia.
    pub const INERTIA: &str = "inertia";
    /// Gravity.
    pub const GRAVITY: &str = "gravity";
    /// External acceleration.
    pub const EXTERNAL: &str = "external";
    /// Body collision.
    pub const COLLISION: &str = "collision";
    /// Friction.
    pub const FRICTION: &str = "friction";
    /// SENC's self-collision volume.
    pub const SELF_COLLISION: &str = "self_collision";
    /// Area of penetrating faces (ablation).
    pub const AREA: &str = "area";
    /// Repulsive baseline.
    pub const REPULSION: &str = "repulsion";
}

/// Energy per term, in joules, in a fixed order, and the total.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Breakdown {
    /// `(term name, J)` for the terms present.
    pub terms: Vec<(&'static str, f64)>,
    /// Sum of the terms, J.
    pub total: f64,
}

impl Breakdown {
    fn push(&mut self, name: &'static str, e: f64) {
        self.terms.push((name, e));
        self.total += e;
    }

    /// The energy of term `name`, if present.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.terms.iter().find(|t| t.0 == name).map(|t| t.1)
    }
}

/// The per-garment part of the energy: rest state, material, config, and the queries that
/// the scene needs (body queries only with a body; GIA only when the self-collision or area
/// weight is positive and the closed garment is a closed surface).
#[derive(Debug)]
pub struct EnergyModel {
    config: EnergyConfig,
    rest: Arc<RestState>,
    mass: Arc<Vec<f64>>,
    stretching: Stretching,
    bending: Option<Bending>,
    body: Option<BodyQueries>,
    self_collision: Option<SelfCollision>,
    repulsion: Option<Repulsion>,
    pattern: Vec<Vec<u32>>,
    /// Vertex → slot map over the element gradient buffer `[3 per face | 4 per hinge]`.
    gather: Gather,
    /// The element gradient buffer, reused across evaluations (a concurrent evaluation that
    /// finds it taken allocates its own).
    scratch: Mutex<Vec<Vec3>>,
    /// Pinned vertices (prescribed positions), one flag per vertex; empty when none is.
    pinned: Vec<bool>,
}

impl EnergyModel {
    /// Builds the model of garment `rest` with `config`, and optionally a body mesh (whose
    /// positions are given per frame; only its faces are used here).
    pub fn new(rest: &TriMesh, config: &EnergyConfig, body: Option<&TriMesh>) -> Result<Self, EnergyError> {
        config.validate()?;
        let state = Arc::new(RestState::new(rest));
        let n = rest.n_vertices();
        let mass = Arc::new(state.vertex_area.iter().map(|a| a * config.material.density).collect::<Vec<_>>());
        let face_scatter = Arc::new(Scatter::new(n, &state.faces));
        let stretching = Stretching::new(
            Arc::clone(&state),
            face_scatter,
            config.material.mu,
            config.material.lambda,
            config.material.thickness,
        );
        let bending = (config.material.bending_stiffness > 0.0 && !state.hinges.is_empty()).then(|| {
            let hinges: Vec<[u32; 4]> = state.hinges.iter().map(|h| h.vertices).collect();
            Bending::new(
                Arc::new(state.hinges.clone()),
                Arc::new(Scatter::new(n, &hinges)),
                config.material.bending_stiffness,
                config.bending_rest == BendingRest::RestMesh,
            )
        });
        let sc = &config.self_collision;
        let self_collision = if sc.weight > 0.0 || config.area_weight > 0.0 {
            let n_loops = rest.topology().boundary_loops().len();
            let selection = if sc.open_holes.is_empty() {
                HoleSelection::All
            } else {
                HoleSelection::AllExcept(sc.open_holes.clone())
            };
            let closure = close_holes(rest, &selection)?;
            // Nothing closed on a garment with holes: no enclosed volume, no GIA.
            let closed_surface = !closure.is_identity() || n_loops == 0;
            closed_surface.then(|| SelfCollision::new(closure, sc.gia, sc.weight, config.area_weight))
        } else {
            None
        };
        let repulsion = (config.repulsion.weight > 0.0 && config.repulsion.threshold > 0.0)
            .then(|| Repulsion::new(rest.topology_arc(), config.repulsion.weight, config.repulsion.threshold));
        let mut slot_vertex: Vec<u32> = state.faces.as_flattened().to_vec();
        if bending.is_some() {
            slot_vertex.extend(state.hinges.iter().flat_map(|h| h.vertices));
        }
        let gather = Gather::new(n, &slot_vertex);
        let pattern =
            state.faces.iter().map(|f| f.to_vec()).chain(state.hinges.iter().map(|h| h.vertices.to_vec())).collect();
        Ok(Self {
            config: config.clone(),
            rest: state,
            mass,
            stretching,
            bending,
            body: body.map(BodyQueries::new),
            self_collision,
            repulsion,
            pattern,
            gather,
            scratch: Mutex::new(Vec::new()),
            pinned: Vec::new(),
        })
    }

    /// Pins vertices `pinned`: their positions are prescribed by the caller (e.g. the skinned
    /// garment's waist), so the gradient is zero there and the Newton systems leave them
    /// in place (their rows and columns of the Hessian are replaced by the identity's).
    /// The energy value still counts every term. An empty list unpins all.
    pub fn with_pinned(mut self, pinned: &[usize]) -> Result<Self, EnergyError> {
        let n = self.n_vertices();
        if let Some(&v) = pinned.iter().find(|&&v| v >= n) {
            return Err(EnergyError::PinnedOutOfRange { vertex: v, n });
        }
        self.pinned = if pinned.is_empty() { Vec::new() } else { vec![false; n] };
        pinned.iter().for_each(|&v| self.pinned[v] = true);
        Ok(self)
    }

    /// Replaces the rows and columns of pinned vertices by the identity's.
    fn constrain(&self, h: &mut BlockSparse) {
        if self.pinned.is_empty() {
            return;
        }
        let pinned = &self.pinned;
        h.par_rows_mut(|i, cols, row| {
            for (b, &j) in row.iter_mut().zip(cols) {
                if pinned[i] || pinned[j as usize] {
                    *b = if i == j as usize { Matrix3::identity() } else { Matrix3::zeros() };
                }
            }
        });
    }

    /// The config.
    pub fn config(&self) -> &EnergyConfig {
        &self.config
    }

    /// Number of garment vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest.n_vertices()
    }

    /// Lumped vertex masses, kg.
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// The rest state.
    pub fn rest(&self) -> &RestState {
        &self.rest
    }

    /// GIA queries made so far (0 when no self-collision term was built).
    pub fn gia_calls(&self) -> u64 {
        self.self_collision.as_ref().map_or(0, |s| s.gia_calls())
    }

    /// Body nearest-face query batches made so far (0 without a body).
    pub fn body_queries(&self) -> u64 {
        self.body.as_ref().map_or(0, |b| b.query_count())
    }

    /// The gradient of the elastic energy alone (stretching and bending) at `x`, J/m per
    /// vertex: minus the cloth's internal forces. Pinned vertices are not special here.
    pub fn elastic_gradient(&self, x: &[Vec3]) -> Result<Vec<Vec3>, EnergyError> {
        if x.len() != self.n_vertices() {
            return Err(EnergyError::VertexCount { what: "positions", expected: self.n_vertices(), got: x.len() });
        }
        let mut grad = vec![Vec3::zeros(); x.len()];
        self.stretching.eval(x, Some(&mut grad));
        if let Some(b) = &self.bending {
            b.eval(x, Some(&mut grad));
        }
        Ok(grad)
    }

    /// Whether a body was given.
    pub fn has_body(&self) -> bool {
        self.body.is_some()
    }

    /// Names of the terms a frame of this model has (in breakdown order).
    pub fn term_names(&self) -> Vec<&'static str> {
        let mut t = vec![names::STRETCHING];
        if self.bending.is_some() {
            t.push(names::BENDING);
        }
        if self.config.inertia {
            t.push(names::INERTIA);
        }
        t.push(names::GRAVITY);
        if self.config.external_acceleration.iter().any(|&a| a != 0.0) {
            t.push(names::EXTERNAL);
        }
        if self.body.is_some() {
            if self.config.collision.weight > 0.0 {
                t.push(names::COLLISION);
            }
            if self.config.friction.mu > 0.0 {
                t.push(names::FRICTION);
            }
        }
        if let Some(sc) = &self.self_collision {
            let (v, a) = sc.parts();
            if v {
                t.push(names::SELF_COLLISION);
            }
            if a {
                t.push(names::AREA);
            }
        }
        if self.repulsion.is_some() {
            t.push(names::REPULSION);
        }
        t
    }

    /// Prepares the energy of the frame predicting `x[t+1]` from `x_cur = x[t]` and
    /// `x_prev = x[t−1]`, with the body at t and t+1 (required exactly when the model has a
    /// body). Runs the body's nearest-face queries once.
    pub fn frame<'m>(
        &'m self,
        x_cur: &[Vec3],
        x_prev: &[Vec3],
        body: Option<(&[Vec3], &[Vec3])>,
    ) -> Result<FrameEnergy<'m>, EnergyError> {
        check_positions("x[t]", x_cur, self.n_vertices())?;
        check_positions("x[t-1]", x_prev, self.n_vertices())?;
        let inertia = self.config.inertia.then(|| Inertia::new(Arc::clone(&self.mass), x_cur, x_prev, self.config.dt));
        let gravity = UniformField::new(Arc::clone(&self.mass), Vec3::from(self.config.gravity));
        let ext = Vec3::from(self.config.external_acceleration);
        let external = (ext != Vec3::zeros()).then(|| UniformField::new(Arc::clone(&self.mass), ext));
        let (collision, friction) = match (&self.body, body) {
            (None, None) => (None, None),
            (Some(_), None) => {
                return Err(EnergyError::Body("the model has a body but the frame gives no body positions".into()))
            }
            (None, Some(_)) => {
                return Err(EnergyError::Body(
                    "the frame gives body positions but the model was built without a body".into(),
                ))
            }
            (Some(q), Some((b_t, b_next))) => {
                let c = self.config.collision;
                let f = self.config.friction;
                let need = c.weight > 0.0 || f.mu > 0.0;
                let contacts = if need { q.contacts(x_cur, b_t, b_next)? } else { Vec::new() };
                let g = Vec3::from(self.config.gravity).norm();
                (
                    (c.weight > 0.0).then(|| Collision::new(&contacts, c.weight, c.epsilon)),
                    (f.mu > 0.0).then(|| Friction::new(&contacts, x_cur, &self.mass, f.mu, g, f.distance, f.smoothing)),
                )
            }
        };
        Ok(FrameEnergy { model: self, inertia, gravity, external, collision, friction })
    }
}

fn check_positions(what: &'static str, x: &[Vec3], n: usize) -> Result<(), EnergyError> {
    if x.len() != n {
        return Err(EnergyError::VertexCount { what, expected: n, got: x.len() });
    }
    if let Some(v) = x.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(EnergyError::NonFinite { what, vertex: v, value: x[v].into() });
    }
    Ok(())
}

/// The incremental potential `E(x[t+1])` of one frame.
#[derive(Debug)]
pub struct FrameEnergy<'m> {
    model: &'m EnergyModel,
    inertia: Option<Inertia>,
    gravity: UniformField,
    external: Option<UniformField>,
    collision: Option<Collision>,
    friction: Option<Friction>,
}

impl FrameEnergy<'_> {
    /// The model.
    pub fn model(&self) -> &EnergyModel {
        self.model
    }

    /// The inertial target `2x[t] − x[t−1]` (a good initial guess), if inertia is on.
    pub fn inertial_target(&self) -> Option<&[Vec3]> {
        self.inertia.as_ref().map(|i| i.target())
    }

    /// Energy breakdown of `x = x[t+1]`; when `grad` is given it is overwritten with
    /// `∂E/∂x` (N).
    ///
    /// With a gradient, stretching and bending write per-element corner gradients into one
    /// buffer (parallel over fixed chunks of elements), and a single pass over vertices
    /// gathers them (fixed order) together with inertia, gravity, external force and
    /// collision; friction, self-collision and repulsion are added after. Every energy is
    /// summed in a fixed chunk order, so the result does not depend on thread scheduling.
    ///
    /// The gradient is zero at pinned vertices ([`EnergyModel::with_pinned`]).
    pub fn evaluate(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> Result<Breakdown, EnergyError> {
        match grad {
            Some(g) if !self.model.pinned.is_empty() => {
                let b = self.evaluate_free(x, Some(&mut *g))?;
                g.iter_mut().zip(&self.model.pinned).filter(|(_, &p)| p).for_each(|(g, _)| *g = Vec3::zeros());
                Ok(b)
            }
            g => self.evaluate_free(x, g),
        }
    }

    fn evaluate_free(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> Result<Breakdown, EnergyError> {
        let m = self.model;
        check_positions("x[t+1]", x, m.n_vertices())?;
        let Some(grad) = grad else {
            return self.evaluate_value(x);
        };
        if grad.len() != x.len() {
            return Err(EnergyError::VertexCount { what: "gradient buffer", expected: x.len(), got: grad.len() });
        }
        let mut local = Vec::new();
        let mut guard = m.scratch.try_lock().ok();
        let buf: &mut Vec<Vec3> = match guard.as_deref_mut() {
            Some(b) => b,
            None => &mut local,
        };
        buf.resize(m.gather.n_slots(), Vec3::zeros());
        let (face_buf, hinge_buf) = buf.split_at_mut(3 * m.stretching.n_faces());
        let (e_stretch, e_bend) = rayon::join(
            || m.stretching.element_gradients(x, face_buf),
            || m.bending.as_ref().map(|t| t.element_gradients(x, hinge_buf)),
        );
        let buf: &[Vec3] = buf;
        // Per-vertex terms, in breakdown order: inertia, gravity, external, collision.
        let (inertia, external, collision) = (self.inertia.as_ref(), self.external.as_ref(), self.collision.as_ref());
        let partials: Vec<[f64; 4]> = grad
            .par_chunks_mut(VERTEX_CHUNK)
            .zip(x.par_chunks(VERTEX_CHUNK))
            .enumerate()
            .map(|(c, (gs, xs))| {
                let mut e = [0.0; 4];
                for (j, (g, xi)) in gs.iter_mut().zip(xs).enumerate() {
                    let i = c * VERTEX_CHUNK + j;
                    let mut gi = m.gather.sum(i, buf);
                    if let Some(t) = inertia {
                        let (ev, gv) = t.vertex(i, xi);
                        e[0] += ev;
                        gi += gv;
                    }
                    let (ev, gv) = self.gravity.vertex(i, xi);
                    e[1] += ev;
                    gi += gv;
                    if let Some(t) = external {
                        let (ev, gv) = t.vertex(i, xi);
                        e[2] += ev;
                        gi += gv;
                    }
                    if let Some(t) = collision {
                        let (ev, gv) = t.vertex(i, xi);
                        e[3] += ev;
                        gi += gv;
                    }
                    *g = gi;
                }
                e
            })
            .collect();
        let mut sums = [0.0; 4];
        for p in &partials {
            for (s, v) in sums.iter_mut().zip(p) {
                *s += v;
            }
        }
        drop(guard);
        let mut b = Breakdown::default();
        b.push(names::STRETCHING, e_stretch);
        if let Some(e) = e_bend {
            b.push(names::BENDING, e);
        }
        if inertia.is_some() {
            b.push(names::INERTIA, sums[0]);
        }
        b.push(names::GRAVITY, sums[1]);
        if external.is_some() {
            b.push(names::EXTERNAL, sums[2]);
        }
        if collision.is_some() {
            b.push(names::COLLISION, sums[3]);
        }
        if let Some(t) = &self.friction {
            b.push(names::FRICTION, t.eval(x, Some(&mut *grad)));
        }
        self.add_nonlocal(x, Some(grad), &mut b)?;
        Ok(b)
    }

    /// The energy breakdown without a gradient, term by term.
    fn evaluate_value(&self, x: &[Vec3]) -> Result<Breakdown, EnergyError> {
        let m = self.model;
        let mut b = Breakdown::default();
        b.push(names::STRETCHING, m.stretching.eval(x, None));
        if let Some(t) = &m.bending {
            b.push(names::BENDING, t.eval(x, None));
        }
        if let Some(t) = &self.inertia {
            b.push(names::INERTIA, t.eval(x, None));
        }
        b.push(names::GRAVITY, self.gravity.eval(x, None));
        if let Some(t) = &self.external {
            b.push(names::EXTERNAL, t.eval(x, None));
        }
        if let Some(t) = &self.collision {
            b.push(names::COLLISION, t.eval(x, None));
        }
        if let Some(t) = &self.friction {
            b.push(names::FRICTION, t.eval(x, None));
        }
        self.add_nonlocal(x, None, &mut b)?;
        Ok(b)
    }

    /// Self-collision, area and repulsion: added to the breakdown and `grad`.
    fn add_nonlocal(&self, x: &[Vec3], mut grad: Option<&mut [Vec3]>, b: &mut Breakdown) -> Result<(), EnergyError> {
        let m = self.model;
        if let Some(t) = &m.self_collision {
            let v = t.eval(x, grad.as_deref_mut())?;
            let (vol, area) = t.parts();
            if vol {
                b.push(names::SELF_COLLISION, v.volume_energy);
            }
            if area {
                b.push(names::AREA, v.area_energy);
            }
        }
        if let Some(t) = &m.repulsion {
            b.push(names::REPULSION, t.eval(x, grad));
        }
        Ok(())
    }

    /// A new, empty Hessian with this model's sparsity pattern.
    pub fn hessian_pattern(&self) -> BlockSparse {
        BlockSparse::with_pattern(self.model.n_vertices(), self.model.pattern.iter().cloned())
    }

    /// Fills `h` with the positive semi-definite approximation of `∂²E/∂x²` the reference
    /// solver uses: projected StVK, Gauss–Newton bending, inertia, collision, friction, and
    /// the self-collision term's curvature model (see [`SelfCollision`]; it reuses that
    /// term's last GIA query when it was made at `x`, else makes one, whose error is
    /// returned). Repulsion contributes its gradient only.
    ///
    /// Element Hessians are computed in parallel (stretching: exact, projected per face with a
    /// fixed-size eigen decomposition; bending: its rank-one Gauss–Newton factors), then
    /// each block row is summed by one task from the vertex's element corners in a fixed
    /// order, so the result does not depend on thread scheduling. `h` must come from
    /// [`FrameEnergy::hessian_pattern`]; blocks outside its pattern are ignored.
    pub fn hessian(&self, x: &[Vec3], h: &mut BlockSparse) -> Result<(), EnergyError> {
        let m = self.model;
        let faces = &m.rest.faces;
        let nf = faces.len();
        let mut hf = vec![[[Matrix3::zeros(); 3]; 3]; nf];
        let mut wb = vec![[Vec3::zeros(); 4]; m.bending.as_ref().map_or(0, |b| b.n_hinges())];
        rayon::join(
            || m.stretching.hessians_into(x, &mut hf),
            || {
                if let Some(b) = &m.bending {
                    b.gauss_newton_factors(x, &mut wb);
                }
            },
        );
        let hinges = m.bending.as_ref().map_or(&[][..], |b| b.hinges());
        let (inertia, collision) = (self.inertia.as_ref(), self.collision.as_ref());
        h.par_rows_mut(|i, cols, row| {
            row.iter_mut().for_each(|b| *b = Matrix3::zeros());
            let find = |j: u32| cols.binary_search(&j).ok();
            for &s in m.gather.slots(i) {
                let s = s as usize;
                if s < 3 * nf {
                    let (f, k) = (s / 3, s % 3);
                    for (l, &j) in faces[f].iter().enumerate() {
                        if let Some(b) = find(j) {
                            row[b] += hf[f][k][l];
                        }
                    }
                } else {
                    let (e, k) = ((s - 3 * nf) / 4, (s - 3 * nf) % 4);
                    let w = &wb[e];
                    for (l, &j) in hinges[e].vertices.iter().enumerate() {
                        if let Some(b) = find(j) {
                            row[b] += w[k] * w[l].transpose();
                        }
                    }
                }
            }
            if let Some(b) = find(i as u32) {
                if let Some(t) = inertia {
                    row[b] += Matrix3::identity() * t.stiffness(i);
                }
                if let Some(c) = collision {
                    row[b] += c.hessian(i, &x[i]);
                }
            }
        });
        if let Some(fr) = &self.friction {
            for (i, m) in fr.hessians(x) {
                h.add_diagonal(i, &m);
            }
        }
        if let Some(sc) = &m.self_collision {
            sc.add_curvature(x, h)?;
        }
        self.model.constrain(h);
        Ok(())
    }

    /// The same matrix as [`FrameEnergy::hessian`], assembled serially element by element
    /// (the reference the parallel assembly is tested against).
    pub fn hessian_serial(&self, x: &[Vec3], h: &mut BlockSparse) -> Result<(), EnergyError> {
        h.clear();
        for (f, hf) in self.model.rest.faces.iter().zip(self.model.stretching.hessians(x)) {
            h.add_element(f, &hf);
        }
        if let Some(bend) = &self.model.bending {
            for (hinge, hh) in bend.hinges().iter().zip(bend.hessians(x)) {
                h.add_element(&hinge.vertices, &hh);
            }
        }
        for i in 0..x.len() {
            let mut d = Matrix3::zeros();
            if let Some(t) = &self.inertia {
                d += Matrix3::identity() * t.stiffness(i);
            }
            if let Some(c) = &self.collision {
                d += c.hessian(i, &x[i]);
            }
            h.add_diagonal(i as u32, &d);
        }
        if let Some(fr) = &self.friction {
            for (i, m) in fr.hessians(x) {
                h.add_diagonal(i, &m);
            }
        }
        if let Some(sc) = &self.model.self_collision {
            sc.add_curvature(x, h)?;
        }
        self.model.constrain(h);
        Ok(())
    }
}
