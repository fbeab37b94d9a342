//! senc-gia: Global Intersection Analysis and the differentiable penetration volume
//! (SENC's self-collision energy, paper section 3.2).
//!
//! Given a garment closed by fans ([`senc_geom::Closure`]), [`GiaWorkspace::penetration`]
//! finds where the surface passes through itself (exact predicates, `senc_geom::intersect`),
//! cuts the faces along the intersection segments (`senc_geom::cut`), links the segments
//! into contours ([`paths`]), flood-fills both sides of each contour in lockstep and keeps the
//! side that finishes first, and sums `|Σ signed tetrahedra|` over each group of contours
//! that bound one pocket (twin contours of two crossing sheets, or one contour of a fold).
//! The gradient reaches every original garment vertex, through the cut nodes (exactly, or
//! with SENC's fixed barycentric weights) and through the fan centroids.
//!
//! # Example
//! ```
//! use senc_geom::{close_holes, HoleSelection, TriMesh, Vec3};
//! use senc_gia::{GiaOptions, GiaWorkspace};
//!
//! // Two unit cubes overlapping by half along x: overlap volume 0.5 m³.
//! fn cube(o: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
//!     let p: Vec<Vec3> = (0..8).map(|i| o + Vec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64)).collect();
//!     let f = vec![[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
//!                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]];
//!     (p, f)
//! }
//! let (mut p, mut f) = cube(Vec3::zeros());
//! let (p2, f2) = cube(Vec3::new(0.5, 0.25, 0.25));
//! f.extend(f2.iter().map(|t| t.map(|i| i + 8)));
//! p.extend(p2);
//! let mesh = TriMesh::new(p, f).unwrap();
//! let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
//! let mut ws = GiaWorkspace::new(&closure);
//! let pen = ws.penetration(&closure, &GiaOptions::default()).unwrap();
//! assert!((pen.volume - 0.5 * 0.75 * 0.75).abs() < 1e-9);
//! ```

pub mod paths;
pub mod volume;

use senc_geom::cut::CutMesh;
use senc_geom::intersect::{SelfIntersections, SelfIntersector};
use senc_geom::{Closure, Vec3};

pub use paths::{Contour, PathKind};

/// How the gradient treats intersection points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GradientMode {
    /// The true derivative: an intersection point's edge parameter and barycentric
    /// coordinates depend on the vertices too.
    #[default]
    Exact,
    /// SENC's version: barycentric weights of intersection points held fixed (measured 6 to
    /// 9 % below the true derivative on overlapping cubes).
    FixedBarycentric,
}

/// How the flood fill decides which side of a contour is the smaller (penetrating) one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeRule {
    /// Both sides grow one face (or piece) per step; the side that runs out first is the
    /// smaller one (Baraff, Witkin and Kass 2003; SENC).
    #[default]
    Faces,
    /// The side with less area grows next; the side that runs out first is smaller. Robust
    /// to uneven tessellation, slightly more work per step.
    Area,
}

/// Options of one penetration query.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GiaOptions {
    /// Gradient definition.
    pub gradient: GradientMode,
    /// Region size rule.
    pub size_rule: SizeRule,
}

/// One penetrating pocket: the filled sides of a group of contours that bound it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Region {
    /// Indices into [`Penetration::paths`] of the contours that bound it.
    pub paths: Vec<usize>,
    /// Original faces of the closed mesh it covers, wholly or in part (sorted).
    pub faces: Vec<u32>,
    /// Number of cut pieces (sub-faces) in it.
    pub n_sub_faces: usize,
    /// Its volume, m³ (`|Σ signed tetrahedra|`).
    pub volume: f64,
    /// Its area, m².
    pub area: f64,
}

/// One contour and what became of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PathInfo {
    /// Its kind.
    pub kind: PathKind,
    /// Number of segment preimages it is made of.
    pub n_steps: usize,
    /// The region it bounds, if its fill succeeded.
    pub region: Option<usize>,
}

/// What was skipped or looked odd, instead of a silent guess or a panic.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct Diagnostics {
    /// Face pairs the broad phase passed on.
    pub candidate_pairs: usize,
    /// Intersecting face pairs.
    pub intersecting_pairs: usize,
    /// Paths ending at an open boundary (not filled).
    pub open_paths: usize,
    /// Contours whose two fills met (the contour does not separate the surface): skipped.
    pub fills_met: usize,
    /// Contours whose two sides finished in the same step: skipped.
    pub fills_tied: usize,
    /// Face pairs with a crossing count other than 0 or 2 (should be 0).
    pub inconsistent_pairs: usize,
    /// Faces whose chords crossed (triple points): kept whole, their segments not walls.
    pub complex_faces: usize,
    /// Chords ending inside a face (paths to an open boundary).
    pub dangling_chords: usize,
    /// Points whose exact derivative fell back to fixed weights (edge nearly parallel to
    /// the face).
    pub gradient_fallbacks: usize,
    /// Regions dropped because a contour of their group failed.
    pub groups_skipped: usize,
}

/// Result of a penetration query.
#[derive(Debug, Clone, Default)]
pub struct Penetration {
    /// Total penetration volume, m³ (sum over regions).
    pub volume: f64,
    /// Gradient of `volume` with respect to every original (unclosed) vertex, m².
    pub gradient: Vec<Vec3>,
    /// Area of the penetrating faces (the paper's "w. area loss" ablation), m².
    pub area: f64,
    /// Gradient of `area` with respect to every original vertex, m.
    pub area_gradient: Vec<Vec3>,
    /// The pockets.
    pub regions: Vec<Region>,
    /// The contours.
    pub paths: Vec<PathInfo>,
    /// What was skipped.
    pub diagnostics: Diagnostics,
}

/// Why a query failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GiaError {
    /// The closure does not fit the workspace.
    #[error("the closure has {got} faces but this workspace was made for {expected}; make a new GiaWorkspace for a different mesh")]
    WrongMesh {
        /// Faces the workspace was built for.
        expected: usize,
        /// Faces given.
        got: usize,
    },
}

/// Reusable state between queries on one closed mesh whose positions change: the BVH (refit,
/// not rebuilt) and the flood-fill buffers.
#[derive(Debug)]
pub struct GiaWorkspace {
    n_faces: usize,
    intersector: SelfIntersector,
    mark: Vec<u8>,
    touched: Vec<u32>,
    nodes: Vec<Vec3>,
    /// Gradient buffers reused between calls: per cut-mesh node (volume, area) and per
    /// closed-mesh vertex.
    node_grad: Vec<Vec3>,
    area_node_grad: Vec<Vec3>,
    closed_grad: Vec<Vec3>,
}

const UNSEEN: u8 = 0;
const LEFT: u8 = 1;
const RIGHT: u8 = 2;

impl GiaWorkspace {
    /// A workspace for meshes with `closure`'s topology.
    pub fn new(closure: &Closure) -> Self {
        let mesh = closure.mesh();
        Self {
            n_faces: mesh.n_faces(),
            intersector: SelfIntersector::new(mesh).with_groups(closure.fan_groups()),
            mark: Vec::new(),
            touched: Vec::new(),
            nodes: Vec::new(),
            node_grad: Vec::new(),
            area_node_grad: Vec::new(),
            closed_grad: Vec::new(),
        }
    }

    /// Penetration volume, area and gradients of the closed mesh at its current positions.
    pub fn penetration(&mut self, closure: &Closure, options: &GiaOptions) -> Result<Penetration, GiaError> {
        let mesh = closure.mesh();
        if mesh.n_faces() != self.n_faces {
            return Err(GiaError::WrongMesh { expected: self.n_faces, got: mesh.n_faces() });
        }
        let inter = self.intersector.find(mesh);
        Ok(self.analyse(closure, &inter, options))
    }

    /// The analysis of a given intersection set (exposed for tests and tools).
    pub fn analyse(&mut self, closure: &Closure, inter: &SelfIntersections, options: &GiaOptions) -> Penetration {
        let mesh = closure.mesh();
        let nv = mesh.n_vertices();
        let mut out = Penetration::default();
        out.diagnostics.candidate_pairs = inter.n_candidate_pairs;
        out.diagnostics.inconsistent_pairs = inter.n_inconsistent_pairs;
        out.diagnostics.intersecting_pairs = inter.segments.len();
        if inter.segments.is_empty() {
            out.gradient = vec![Vec3::zeros(); closure.n_original()];
            out.area_gradient = vec![Vec3::zeros(); closure.n_original()];
            return out;
        }
        let cut = CutMesh::new(mesh, inter);
        out.diagnostics.complex_faces = cut.n_complex_faces;
        out.diagnostics.dangling_chords = cut.n_dangling_chords;
        let contours = paths::contours(nv, inter);
        volume::node_positions(mesh, inter, options.gradient, &mut self.nodes);
        let nodes = std::mem::take(&mut self.nodes);

        // Fill each closed contour; remember the smaller side.
        let mut sides: Vec<Option<Vec<u32>>> = Vec::with_capacity(contours.len());
        for c in &contours {
            out.paths.push(PathInfo { kind: c.kind, n_steps: c.steps.len(), region: None });
            if c.kind == PathKind::OpenBoundary {
                out.diagnostics.open_paths += 1;
                sides.push(None);
                continue;
            }
            let side = self.fill(mesh, &cut, inter, c, &nodes, options.size_rule, &mut out.diagnostics);
            sides.push(side);
        }

        // Group contours that share intersection points (twins bound one pocket).
        let groups = group_contours(&contours, inter.points.len());
        let mut node_grad = std::mem::take(&mut self.node_grad);
        let mut area_node_grad = std::mem::take(&mut self.area_node_grad);
        for g in [&mut node_grad, &mut area_node_grad] {
            g.clear();
            g.resize(nodes.len(), Vec3::zeros());
        }
        for group in groups {
            if group.iter().any(|&c| sides[c].is_none()) {
                if group.iter().any(|&c| contours[c].kind != PathKind::OpenBoundary) {
                    out.diagnostics.groups_skipped += 1;
                }
                continue;
            }
            let mut ids: Vec<u32> = group.iter().flat_map(|&c| sides[c].clone().unwrap_or_default()).collect();
            ids.sort_unstable();
            ids.dedup();
            let signed: f64 = ids.iter().map(|&id| volume::signed_volume(mesh, &cut, &nodes, id)).sum();
            let area: f64 = ids.iter().map(|&id| volume::area(mesh, &cut, &nodes, id)).sum();
            let sign = if signed >= 0.0 { 1.0 } else { -1.0 };
            for &id in &ids {
                volume::add_volume_gradient(mesh, &cut, &nodes, id, sign, &mut node_grad);
                volume::add_area_gradient(mesh, &cut, &nodes, id, 1.0, &mut area_node_grad);
            }
            let mut faces: Vec<u32> = ids
                .iter()
                .map(|&id| if (id as usize) < cut.n_faces { id } else { cut.pieces[id as usize - cut.n_faces].face })
                .collect();
            faces.sort_unstable();
            faces.dedup();
            let region = out.regions.len();
            for &c in &group {
                out.paths[c].region = Some(region);
            }
            out.regions.push(Region {
                paths: group.clone(),
                faces,
                n_sub_faces: ids.iter().filter(|&&id| id as usize >= cut.n_faces).count(),
                volume: signed.abs(),
                area,
            });
            out.volume += signed.abs();
            out.area += area;
        }
        let mut closed_grad = std::mem::take(&mut self.closed_grad);
        closed_grad.clear();
        closed_grad.resize(nv, Vec3::zeros());
        out.diagnostics.gradient_fallbacks =
            volume::chain_to_vertices(mesh, inter, options.gradient, &node_grad, &mut closed_grad);
        out.gradient = closure.pull_back(&closed_grad);
        closed_grad.iter_mut().for_each(|g| *g = Vec3::zeros());
        volume::chain_to_vertices(mesh, inter, options.gradient, &area_node_grad, &mut closed_grad);
        out.area_gradient = closure.pull_back(&closed_grad);
        self.nodes = nodes;
        self.node_grad = node_grad;
        self.area_node_grad = area_node_grad;
        self.closed_grad = closed_grad;
        out
    }

    /// Lockstep flood fill of both sides of contour `c`; returns the fill ids of the side
    /// that finished first, or `None` (with a diagnostic) when the fills meet or tie.
    #[allow(clippy::too_many_arguments)]
    fn fill(
        &mut self,
        mesh: &senc_geom::TriMesh,
        cut: &CutMesh,
        inter: &SelfIntersections,
        c: &Contour,
        nodes: &[Vec3],
        rule: SizeRule,
        diag: &mut Diagnostics,
    ) -> Option<Vec<u32>> {
        let n_ids = cut.n_fill_ids();
        if self.mark.len() < n_ids {
            self.mark.resize(n_ids, UNSEEN);
        }
        for &t in &self.touched {
            self.mark[t as usize] = UNSEEN;
        }
        self.touched.clear();
        // Walls of this contour: (segment, side) preimages.
        let mut walls: Vec<(u32, u8)> = c.steps.iter().map(|s| (s.segment, s.side)).collect();
        walls.sort_unstable();
        let is_wall = |segment: u32, face: u32| -> bool {
            let seg = &inter.segments[segment as usize];
            let side = if seg.faces[0] == face { 0 } else { 1 };
            walls.binary_search(&(segment, side)).is_ok()
        };
        let mut queues: [std::collections::VecDeque<u32>; 2] = Default::default();
        let mut met = false;
        for s in &c.steps {
            for (dir, label) in [((s.from, s.to), LEFT), ((s.to, s.from), RIGHT)] {
                if let Some(id) = cut.piece_with_directed_edge(dir.0, dir.1) {
                    let m = &mut self.mark[id as usize];
                    if *m == UNSEEN {
                        *m = label;
                        self.touched.push(id);
                        queues[(label - 1) as usize].push_back(id);
                    } else if *m != label {
                        met = true;
                    }
                }
            }
        }
        if queues[0].is_empty() || queues[1].is_empty() {
            met = true;
        }
        let mut size = [0.0f64; 2];
        let mut members: [Vec<u32>; 2] = Default::default();
        let face_of =
            |id: u32| if (id as usize) < cut.n_faces { id } else { cut.pieces[id as usize - cut.n_faces].face };
        while !met {
            let done = [queues[0].is_empty(), queues[1].is_empty()];
            if done[0] || done[1] {
                if done[0] && done[1] {
                    diag.fills_tied += 1;
                    return None;
                }
                let k = if done[0] { 0 } else { 1 };
                return Some(std::mem::take(&mut members[k]));
            }
            // Which side grows now.
            let order: &[usize] = match rule {
                SizeRule::Faces => &[0, 1],
                SizeRule::Area => {
                    if size[0] <= size[1] {
                        &[0]
                    } else {
                        &[1]
                    }
                }
            };
            for &k in order {
                let Some(id) = queues[k].pop_front() else { continue };
                members[k].push(id);
                size[k] += match rule {
                    SizeRule::Faces => 1.0,
                    SizeRule::Area => volume::area(mesh, cut, nodes, id),
                };
                let label = if k == 0 { LEFT } else { RIGHT };
                let mark = &mut self.mark;
                let touched = &mut self.touched;
                let queue = &mut queues[k];
                cut.for_each_neighbour(mesh, id, |nb, wall| {
                    if let Some(seg) = wall {
                        if is_wall(seg, face_of(id)) {
                            return;
                        }
                    }
                    let m = &mut mark[nb as usize];
                    if *m == UNSEEN {
                        *m = label;
                        touched.push(nb);
                        queue.push_back(nb);
                    } else if *m != label {
                        met = true;
                    }
                });
                if met {
                    break;
                }
            }
        }
        diag.fills_met += 1;
        None
    }
}

/// Groups contours that share an intersection point (union-find).
fn group_contours(contours: &[Contour], n_points: usize) -> Vec<Vec<usize>> {
    let mut owner = vec![usize::MAX; n_points];
    let mut parent: Vec<usize> = (0..contours.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for (c, contour) in contours.iter().enumerate() {
        for &pt in &contour.points {
            let o = owner[pt as usize];
            if o == usize::MAX {
                owner[pt as usize] = c;
            } else {
                let (a, b) = (find(&mut parent, o), find(&mut parent, c));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut index = vec![usize::MAX; contours.len()];
    for c in 0..contours.len() {
        let r = find(&mut parent, c);
        if index[r] == usize::MAX {
            index[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[index[r]].push(c);
    }
    groups
}
