//! senc-gia: Global Intersection Analysis and the differentiable penetration volume
//! (SENC's self-collision energy, paper section 3.2).
//!
//! Given a garment closed by fans ([`senc_geom::Closure`]), [`GiaWorkspace::penetration`]
//! finds where the surface passes through itself (exact predicates, `senc_geom::intersect`),
//! cuts the faces along every intersection segment at once (`senc_geom::cut`) and measures
//! the volume of space that the surface covers twice or more, or inside out (winding number
//! `w ≥ 2` or `w ≤ −1`). By default ([`VolumeRule::Winding`], module [`winding`]) each patch
//! of the cut surface is classified by exact ray queries and the volume is a weighted sum
//! of the tetrahedra the patches span with the origin: exact on any tangle, with no flood
//! fill and no tie rule. SENC's rule ([`VolumeRule::SmallerSide`]: flood-fill both sides of
//! each contour and keep the one that finishes first) stays available for ablation.
//! The gradient reaches every original garment vertex, through the cut nodes (exactly, or
//! with SENC's fixed barycentric weights) and through the fan centroids.
//!
//! Nothing is guessed: a tangle the analysis cannot classify consistently is skipped and
//! counted ([`Diagnostics`]). That happens only on exactly degenerate input (coincident
//! vertices, faces of zero area, coplanar faces crossing), and then the query is re-run on
//! positions jittered far below any length cloth resolves ([`PERTURBATIONS`]), which
//! changes the volume only at rounding level ([`GiaWorkspace::penetration`]).
//!
//! # Holes left open
//! The winding number is an integer only for a closed surface. A hole that the closure
//! leaves open (not fanned, e.g. a collar) is closed *virtually* for this measurement:
//! [`GiaWorkspace::penetration`] fans every open loop to its centroid (the fan
//! [`senc_geom::close_holes`] would add), finds the crossings of that virtually closed
//! surface, the fans' included, and measures it exactly as a closed one. So:
//!
//! - **The volume is the penetration volume of the surface with every open hole closed by a
//!   fan to the loop's mean**: the space that surface covers twice or more, or inside out.
//!   It is the number a closure of that hole gives, and the number of libigl's arrangement
//!   with every hole fanned (`penetration_oracle.py --close-holes`); nothing is skipped for
//!   reaching a hole.
//! - A part of the garment that passes through an open hole's fan bounds penetrated space
//!   with the fan and is counted like any other crossing; [`Diagnostics::virtual_fan_pairs`]
//!   counts the crossing pairs that involve a virtual fan, so a caller can tell whether the
//!   fan shaped the answer.
//! - The fan's centroid is not a vertex of the result: its gradient is shared equally by the
//!   loop's vertices (the centroid is their mean), as for a hole the closure fans.
//!
//! Why a fan: without a closing surface "inside" has no meaning (the generalized winding
//! number of an open surface is not an integer), any closing surface gives a definition, and
//! the fan is the one the paper uses for the holes it closes. Leaving a hole open therefore
//! changes what the rest of senc sees (the garment's own faces and vertices), not this
//! volume. [`GiaWorkspace::analyse`], which is handed crossings that hold no fan, keeps the
//! fans only in its rays and skips a patch of nonzero weight that reaches an open hole
//! (counted in [`Diagnostics::patches_skipped`]).
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

mod flood;
pub mod paths;
pub mod volume;
pub mod winding;

use senc_geom::cut::CutMesh;
use senc_geom::intersect::{ray_winding_brute, SelfIntersections, SelfIntersector};
use senc_geom::{close_holes, Closure, HoleSelection, Vec3};

pub use paths::{Contour, PathKind};
pub use winding::Patch;

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

/// Which points of space count as penetrated, and how they are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VolumeRule {
    /// Winding number `≥ 2` or `≤ −1`, by classifying the patches of the cut surface with
    /// exact ray queries (module [`winding`]): exact on any tangle of a closed surface.
    #[default]
    Winding,
    /// SENC's rule: per group of contours, the smaller side found by lockstep flood fills
    /// (see [`SizeRule`]); skips contours where it has no answer.
    SmallerSide,
}

/// How the flood fill of [`VolumeRule::SmallerSide`] decides which side of a contour is the smaller (penetrating) one.
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

/// Which gradients a query computes: the caller asks for what it uses, so a volume meter
/// pays for no gradient and an energy without the area term for no area gradient. Not
/// read from configs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Gradients {
    /// None: [`Penetration::gradient`] and [`Penetration::area_gradient`] are left empty.
    None,
    /// The volume's: [`Penetration::area_gradient`] is left empty.
    Volume,
    /// The volume's and the area's.
    #[default]
    VolumeAndArea,
}

/// Options of one penetration query.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GiaOptions {
    /// Gradient definition.
    pub gradient: GradientMode,
    /// Which rule measures the volume.
    pub rule: VolumeRule,
    /// Region size rule of [`VolumeRule::SmallerSide`] (unused by the winding rule).
    pub size_rule: SizeRule,
    /// Which gradients to compute (all by default; set by the caller, never by a config).
    #[serde(skip)]
    pub gradients: Gradients,
}

/// One penetrating pocket of [`VolumeRule::SmallerSide`]: the filled sides of a group of contours that bound it.
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
    /// The region it bounds, if its fill succeeded ([`VolumeRule::SmallerSide`] only).
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
    /// Patches of the cut surface ([`VolumeRule::Winding`]).
    pub patches: usize,
    /// Patches skipped as inconsistent: an intersection segment with the patch on both
    /// sides (the surface was not cut there: a complex face or a dangling chord), or
    /// winding numbers across a segment that differ by other than one ([`winding`]).
    pub patches_skipped: usize,
    /// Segment sides where that check failed.
    pub inconsistent_walls: usize,
    /// Ray queries made (two per group of patches linked by intersection segments, which
    /// must agree; one where a group has a single probe; more where a probe's origin lay
    /// exactly on another face).
    pub winding_rays: usize,
    /// Groups of patches whose every probe origin lay exactly on another face, or whose
    /// probes gave no two agreeing winding numbers: their patches are skipped.
    pub unresolved_groups: usize,
    /// Groups of patches whose two probes disagreed (a probe point rounded onto the wrong
    /// side of a face coplanar with its own: grid-snapped meshes): unresolved, their
    /// patches skipped (also counted in `unresolved_groups`).
    pub winding_ray_disagreements: usize,
    /// Tangles (patches linked through intersection segments) whose weighted patches do not
    /// close up (their weighted vector area is not zero, see `winding`'s closure check): a
    /// classification error, seen only where faces of zero area are cut. Their patches are
    /// skipped (counted in `patches_skipped`).
    pub unclosed_tangles: usize,
    /// 1 when the weighted patches summed to a negative volume (a volume is never
    /// negative, so some classification was wrong that no local check caught; seen only on
    /// grid-snapped random meshes with faces of zero area): every weighted patch is then
    /// skipped and the volume is 0. Otherwise 0.
    pub negative_sums: usize,
    /// Tangles whose penetrated cells are flat (mean thickness at most
    /// [`winding::FLAT_THICKNESS`] of the mesh's size: faces coinciding up to rounding, e.g.
    /// a flat sheet and the fan in its plane): they contribute no volume and no gradient.
    pub flat_tangles: usize,
    /// Contours whose two fills met (the contour does not separate the surface): skipped
    /// ([`VolumeRule::SmallerSide`]).
    pub fills_met: usize,
    /// Contours whose two sides finished in the same step: skipped
    /// ([`VolumeRule::SmallerSide`]).
    pub fills_tied: usize,
    /// Face pairs with a crossing count other than 0 or 2 (should be 0).
    pub inconsistent_pairs: usize,
    /// Faces whose chords could not be ordered or traced: kept whole, their segments not
    /// walls.
    pub complex_faces: usize,
    /// Crossings of chords inside a face (triple points), each a node of the cut.
    pub triple_points: usize,
    /// Chords ending inside a face (paths to an open boundary).
    pub dangling_chords: usize,
    /// Points whose exact derivative fell back to fixed weights (edge nearly parallel to
    /// the face); counted only when the volume's gradient is computed.
    pub gradient_fallbacks: usize,
    /// Regions dropped because a contour of their group failed ([`VolumeRule::SmallerSide`]).
    pub groups_skipped: usize,
    /// Re-runs on jittered positions ([`GiaWorkspace::penetration`], [`PERTURBATIONS`]):
    /// the number of re-runs made. 0 when the first run skipped nothing; with
    /// `patches_skipped == 0` after re-runs, the last one made skipped nothing and its
    /// result is reported; with `patches_skipped > 0`, none did (at most
    /// [`PERTURBED_RETRIES`]) and the unperturbed run is reported.
    pub perturbed_retries: usize,
    /// Crossing face pairs that involve a virtual fan (a hole the closure leaves open, see
    /// the crate docs, "Holes left open"): the surface passes through the hole's fan, or a
    /// fan over a tangled hole crosses itself. These crossings are measured like any other;
    /// this counts them so that a caller can tell whether the open hole's closure shaped the
    /// answer. Included in `intersecting_pairs`.
    pub virtual_fan_pairs: usize,
}

/// Largest displacements of the perturbed re-runs of [`GiaWorkspace::penetration`],
/// relative to the bounding box's diagonal, tried in this order: far below what simulated
/// cloth resolves, and at most [`winding::FLAT_THICKNESS`], so that cells made by jittering
/// faces that coincide are still flat.
pub const PERTURBATIONS: [f64; 2] = [1e-13, 1e-12];

/// Perturbed re-runs of [`GiaWorkspace::penetration`] per size in [`PERTURBATIONS`].
pub const RETRIES_PER_PERTURBATION: usize = 6;

/// Perturbed re-runs in all before the skipped patches of the unperturbed run are reported.
pub const PERTURBED_RETRIES: usize = PERTURBATIONS.len() * RETRIES_PER_PERTURBATION;

/// A seeded displacement in `[−1, 1)³` for vertex `v` of perturbed run `attempt`
/// (SplitMix64 of both; the same call gives the same jitter on every machine).
fn jitter(v: usize, attempt: usize) -> Vec3 {
    let mut state = (v as u64) ^ ((attempt as u64) << 40);
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    Vec3::new(next(), next(), next())
}

/// Result of a penetration query.
#[derive(Debug, Clone, Default)]
pub struct Penetration {
    /// Total penetration volume, m³.
    pub volume: f64,
    /// Gradient of `volume` with respect to every original (unclosed) vertex, m² (empty
    /// when [`GiaOptions::gradients`] leaves it out).
    pub gradient: Vec<Vec3>,
    /// Area of the surface bounding the penetrated space (the paper's "w. area loss"
    /// ablation): the patches of nonzero weight, or the filled regions, m².
    pub area: f64,
    /// Gradient of `area` with respect to every original vertex, m (empty unless
    /// [`GiaOptions::gradients`] is [`Gradients::VolumeAndArea`]).
    pub area_gradient: Vec<Vec3>,
    /// The patches of the cut surface ([`VolumeRule::Winding`]).
    pub patches: Vec<Patch>,
    /// The pockets ([`VolumeRule::SmallerSide`]).
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
    /// The virtual fan over a hole left open could not be placed (its centroid is not
    /// finite: coordinates near the largest f64). Scale the mesh to metres.
    #[error("the virtual fan over a hole left open could not be placed: {0}")]
    VirtualClosure(senc_geom::MeshError),
}

/// Reusable state between queries on one closed mesh whose positions change: the BVH (refit,
/// not rebuilt) and the labelling, fill and gradient buffers.
#[derive(Debug)]
pub struct GiaWorkspace {
    n_faces: usize,
    /// The closure's mesh with every hole it leaves open fanned to its centroid (the
    /// *virtual* closure, see the crate docs); `None` when nothing is left open.
    virtual_closure: Option<Closure>,
    /// Self-intersection of the analysed mesh: the virtual closure's where there is one.
    intersector: SelfIntersector,
    /// Boundary loops of the closure's mesh (holes left open), for the rays' virtual fans of
    /// [`Self::analyse`], which sees only the crossings it is given.
    open_loops: Vec<Vec<u32>>,
    flood: flood::Scratch,
    winding: winding::Scratch,
    nodes: Vec<Vec3>,
    /// Gradient buffers reused between calls: per cut-mesh node (volume, area) and per
    /// closed-mesh vertex.
    node_grad: Vec<Vec3>,
    area_node_grad: Vec<Vec3>,
    closed_grad: Vec<Vec3>,
}

impl GiaWorkspace {
    /// A workspace for meshes with `closure`'s topology.
    pub fn new(closure: &Closure) -> Self {
        let mesh = closure.mesh();
        let open_loops = mesh.topology().boundary_loops().to_vec();
        // Closing every loop of a valid mesh cannot fail; should it, the rays' virtual fans
        // of `analyse` remain (patches reaching the hole skipped).
        let virtual_closure = if open_loops.is_empty() { None } else { close_holes(mesh, &HoleSelection::All).ok() };
        let intersector = SelfIntersector::new(virtual_closure.as_ref().map_or(mesh, Closure::mesh));
        Self {
            n_faces: mesh.n_faces(),
            virtual_closure,
            // Fans are tested against each other too: a fan over a tangled hole can cross
            // itself, and the winding numbers change across those crossings as across any.
            intersector,
            open_loops,
            flood: flood::Scratch::default(),
            winding: winding::Scratch::default(),
            nodes: Vec::new(),
            node_grad: Vec::new(),
            area_node_grad: Vec::new(),
            closed_grad: Vec::new(),
        }
    }

    /// Penetration volume, area and gradients of the closed mesh at its current positions.
    ///
    /// With the winding rule, a run that skips patches (exactly degenerate input: faces of
    /// zero area, coincident vertices, coplanar faces meeting along a crossing) is repeated
    /// on the positions moved by a seeded jitter of at most [`PERTURBATIONS`] times the
    /// bounding box's diagonal ([`RETRIES_PER_PERTURBATION`] times per size, the smaller
    /// first, with a new jitter each time), and the first run that skips nothing is returned
    /// ([`Diagnostics::perturbed_retries`] says which). The penetration volume changes by at
    /// most the area times that displacement when the surface moves (the winding number
    /// changes only where the surface passes), so the answer is that of the given mesh to
    /// rounding, and its gradient is a one-sided derivative there. Meshes in general
    /// position, such as simulated garment frames, skip nothing and never pay for this.
    pub fn penetration(&mut self, closure: &Closure, options: &GiaOptions) -> Result<Penetration, GiaError> {
        // On one of rayon's threads from the start: the parallel steps inside (refit,
        // traversal, cut, labelling) then start there directly, not each by handing work
        // from this thread to the pool and waiting for it.
        rayon::scope(|_| {
            let out = self.penetration_here(closure, options)?;
            if out.diagnostics.patches_skipped == 0 || options.rule != VolumeRule::Winding {
                return Ok(out);
            }
            let original = &closure.mesh().positions()[..closure.n_original()];
            let diagonal = closure.mesh().bounding_diagonal();
            let mut out = out;
            let mut moved = closure.clone();
            for attempt in 1..=PERTURBED_RETRIES {
                let step = PERTURBATIONS[(attempt - 1) / RETRIES_PER_PERTURBATION] * diagonal;
                let jittered: Vec<Vec3> =
                    original.iter().enumerate().map(|(v, p)| p + jitter(v, attempt) * step).collect();
                // Fails only where jittered coordinates overflow: no re-run is possible.
                if moved.update(&jittered).is_err() {
                    break;
                }
                out.diagnostics.perturbed_retries = attempt;
                let mut retry = self.penetration_here(&moved, options)?;
                if retry.diagnostics.patches_skipped == 0 {
                    retry.diagnostics.perturbed_retries = attempt;
                    return Ok(retry);
                }
            }
            Ok(out)
        })
    }

    fn penetration_here(&mut self, closure: &Closure, options: &GiaOptions) -> Result<Penetration, GiaError> {
        let mesh = closure.mesh();
        if mesh.n_faces() != self.n_faces {
            return Err(GiaError::WrongMesh { expected: self.n_faces, got: mesh.n_faces() });
        }
        if let Some(mut virt) = self.virtual_closure.take() {
            let moved = virt.update(mesh.positions());
            let out = moved.map(|()| {
                let inter = self.intersector.find(virt.mesh());
                let mut out = self.analyse_with(&virt, &inter, options, true, &[]);
                out.diagnostics.virtual_fan_pairs =
                    inter.segments.iter().filter(|s| s.faces.iter().any(|&f| f as usize >= self.n_faces)).count();
                for g in [&mut out.gradient, &mut out.area_gradient] {
                    if !g.is_empty() {
                        *g = closure.pull_back(g);
                    }
                }
                out
            });
            self.virtual_closure = Some(virt);
            return out.map_err(GiaError::VirtualClosure);
        }
        let inter = self.intersector.find(mesh);
        Ok(self.analyse_with(closure, &inter, options, true, &[]))
    }

    /// The analysis of a given intersection set of `closure.mesh()` (exposed for tests and
    /// tools). The winding rule's ray queries test every face here (the BVH's boxes may
    /// belong to other positions), so this is slower than [`Self::penetration`]. With holes
    /// left open, `inter` holds no crossing of their virtual fans: the rays still count the
    /// fans, but a patch of nonzero weight that reaches an open hole is skipped (counted in
    /// [`Diagnostics::patches_skipped`]); [`Self::penetration`] measures the virtual closure
    /// instead and skips nothing there. In [`GradientMode::FixedBarycentric`] the
    /// intersection nodes sit at the recorded weights of `inter` (SENC's frozen-weight
    /// volume, for checking that mode's gradient); [`Self::penetration`] places them exactly.
    pub fn analyse(&mut self, closure: &Closure, inter: &SelfIntersections, options: &GiaOptions) -> Penetration {
        let loops = std::mem::take(&mut self.open_loops);
        let out = self.analyse_with(closure, inter, options, false, &loops);
        self.open_loops = loops;
        out
    }

    fn analyse_with(
        &mut self,
        closure: &Closure,
        inter: &SelfIntersections,
        options: &GiaOptions,
        bvh_current: bool,
        loops: &[Vec<u32>],
    ) -> Penetration {
        let mesh = closure.mesh();
        let nv = mesh.n_vertices();
        let mut out = Penetration::default();
        out.diagnostics.candidate_pairs = inter.n_candidate_pairs;
        out.diagnostics.inconsistent_pairs = inter.n_inconsistent_pairs;
        out.diagnostics.intersecting_pairs = inter.segments.len();
        let (volume_grad, area_grad) = match options.gradients {
            Gradients::None => (false, false),
            Gradients::Volume => (true, false),
            Gradients::VolumeAndArea => (true, true),
        };
        if inter.segments.is_empty() && options.rule == VolumeRule::SmallerSide {
            let zeros = |on: bool| if on { vec![Vec3::zeros(); closure.n_original()] } else { Vec::new() };
            (out.gradient, out.area_gradient) = (zeros(volume_grad), zeros(area_grad));
            return out;
        }
        // The cut, and beside it what needs only the crossings: the contours and the winding
        // rule's labelling of the faces the cut leaves whole.
        let winding_scratch = &mut self.winding;
        let winding_rule = options.rule == VolumeRule::Winding;
        let (cut, contours) = rayon::join(
            || CutMesh::new(mesh, inter),
            || {
                if winding_rule {
                    winding::prelabel(mesh, inter, winding_scratch);
                }
                paths::contours(nv, inter)
            },
        );
        out.diagnostics.complex_faces = cut.n_complex_faces;
        out.diagnostics.triple_points = cut.crossings.len();
        out.diagnostics.dangling_chords = cut.n_dangling_chords;
        for c in &contours {
            out.paths.push(PathInfo { kind: c.kind, n_steps: c.steps.len(), region: None });
            if c.kind == PathKind::OpenBoundary {
                out.diagnostics.open_paths += 1;
            }
        }
        // The volume is measured with exact nodes; `analyse` keeps SENC's frozen weights in
        // fixed-weight mode (see `volume::node_positions`).
        let placement = if bvh_current { GradientMode::Exact } else { options.gradient };
        volume::node_positions(mesh, inter, &cut, placement, &mut self.nodes);
        let nodes = std::mem::take(&mut self.nodes);
        let mut node_grad = std::mem::take(&mut self.node_grad);
        let mut area_node_grad = std::mem::take(&mut self.area_node_grad);
        // A gradient left out keeps an empty buffer, which the sums below skip.
        for (g, on) in [(&mut node_grad, volume_grad), (&mut area_node_grad, area_grad)] {
            g.clear();
            if on {
                g.resize(nodes.len(), Vec3::zeros());
            }
        }
        match options.rule {
            VolumeRule::Winding => {
                let intersector = &self.intersector;
                let has_open = !loops.is_empty();
                let classified =
                    winding::classify(mesh, &cut, inter, &nodes, &mut self.winding, has_open, |ray, skip| {
                        if bvh_current {
                            intersector.ray_winding(mesh, ray, skip, loops)
                        } else {
                            ray_winding_brute(mesh, ray, skip, loops)
                        }
                    });
                out.diagnostics.inconsistent_walls = classified.inconsistent_walls;
                out.diagnostics.winding_rays = classified.rays;
                out.diagnostics.unresolved_groups = classified.unresolved;
                out.diagnostics.winding_ray_disagreements = classified.ray_disagreements;
                out.patches = classified.patches;
                out.diagnostics.patches = out.patches.len();
                (out.diagnostics.unclosed_tangles, out.diagnostics.flat_tangles) = winding::accumulate(
                    mesh,
                    &cut,
                    &nodes,
                    &self.winding,
                    &classified.tangle_of,
                    placement == GradientMode::Exact,
                    &mut out.patches,
                    &mut node_grad,
                    &mut area_node_grad,
                );
                // A volume is never negative; a negative sum of closed tangles means a
                // classification error that no local check caught (seen only on grid-snapped
                // meshes with faces of zero area): nothing is reported rather than a guess.
                let total: f64 = out.patches.iter().map(|p| p.volume).sum();
                let scale: f64 = out.patches.iter().map(|p| p.volume.abs()).sum();
                if total < -1e-9 * scale {
                    out.diagnostics.negative_sums = 1;
                    for p in out.patches.iter_mut().filter(|p| p.weight != 0) {
                        (p.weight, p.skipped, p.volume, p.area) = (0, true, 0.0, 0.0);
                    }
                    node_grad.iter_mut().chain(area_node_grad.iter_mut()).for_each(|g| *g = Vec3::zeros());
                }
                out.diagnostics.patches_skipped = out.patches.iter().filter(|p| p.skipped).count();
                out.volume = out.patches.iter().map(|p| p.volume).sum();
                out.area = out.patches.iter().map(|p| p.area).sum();
            }
            VolumeRule::SmallerSide => flood::regions(
                &mut self.flood,
                mesh,
                &cut,
                inter,
                &contours,
                &nodes,
                options.size_rule,
                &mut out,
                &mut node_grad,
                &mut area_node_grad,
            ),
        }
        let mut closed_grad = std::mem::take(&mut self.closed_grad);
        closed_grad.clear();
        if volume_grad || area_grad {
            closed_grad.resize(nv, Vec3::zeros());
        }
        if volume_grad {
            out.diagnostics.gradient_fallbacks = volume::chain_to_vertices(
                mesh,
                inter,
                &cut,
                options.gradient,
                &nodes,
                &mut node_grad,
                &mut closed_grad,
            );
            out.gradient = closure.pull_back(&closed_grad);
        }
        if area_grad {
            volume::chain_to_vertices(
                mesh,
                inter,
                &cut,
                options.gradient,
                &nodes,
                &mut area_node_grad,
                &mut closed_grad,
            );
            out.area_gradient = closure.pull_back(&closed_grad);
        }
        self.nodes = nodes;
        self.node_grad = node_grad;
        self.area_node_grad = area_node_grad;
        self.closed_grad = closed_grad;
        out
    }
}
