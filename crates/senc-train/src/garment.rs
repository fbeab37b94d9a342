//! One training or test garment: the loaded scene, its proxy body (the body vertices near
//! the garment, so that graphs and collision queries skip the far side of the body) and the
//! frames of its motions.

use std::sync::Arc;

use senc_geom::{HoleSelection, TriMesh, Vec3};
use senc_model::{BodyState, FrameState, Material};
use senc_scene::{skin, Motion, Scene, SkinWeights};

use crate::error::TrainError;

/// A scene prepared for simulation.
#[derive(Debug, Clone)]
pub struct Garment {
    /// The loaded scene.
    pub scene: Arc<Scene>,
    /// The garment rest mesh.
    pub rest: TriMesh,
    /// Boundary loops left open for the self-collision energy (loop indices).
    pub open_holes: Vec<usize>,
    /// Proxy body: rest positions of the kept body vertices.
    proxy_rest: Vec<Vec3>,
    /// Proxy body: skinning weights of the kept vertices.
    proxy_weights: SkinWeights,
    /// Proxy body mesh (kept vertices, faces whose three vertices are kept).
    pub proxy_mesh: TriMesh,
    /// Pinned garment vertices (`[scene] pin`), sorted: they follow the skinned garment.
    pub pinned: Vec<usize>,
}

impl Garment {
    /// Loads the scene file `path` and builds the proxy body with `margin` metres.
    pub fn load(path: &std::path::Path, margin: f64) -> Result<Self, TrainError> {
        let scene = Scene::load(path)?;
        Self::new(Arc::new(scene), margin)
    }

    /// Loads the scene file `path` with its garment replaced by `asset`, a garment asset
    /// fitted to the same body (`cargo xtask fit`), so that a model can be run on a garment
    /// it never saw (the paper's Table 3). Every boundary loop of the asset is closed for
    /// the self-collision volume except the one named `neck` (the scene's own `close_holes`
    /// name the scene's garment, not this one). A loop named `waist` (skirts and trousers,
    /// whose top opening `fit` finds below the neck) is pinned, as the skirt and pants
    /// scenes pin theirs, whatever the scene pins: nothing else holds such a garment up. The
    /// motions, material and forces are the scene's.
    pub fn load_unseen(path: &std::path::Path, asset: &std::path::Path, margin: f64) -> Result<Self, TrainError> {
        let mut config = senc_scene::SceneConfig::read(path)?;
        let fitted = senc_scene::GarmentAsset::load(asset)?;
        config.garment = asset.to_path_buf();
        let loops = fitted.loop_names();
        config.pin = loops.iter().filter(|n| *n == "waist").cloned().collect();
        config.close_holes = loops.into_iter().filter(|n| n != "neck").collect();
        let scene = Scene::from_config(config)?;
        Self::new(Arc::new(scene), margin)
    }

    /// Prepares a loaded scene.
    pub fn new(scene: Arc<Scene>, margin: f64) -> Result<Self, TrainError> {
        let rest = scene.garment_mesh.clone();
        let n_loops = rest.topology().boundary_loops().len();
        let open_holes = match scene.hole_selection()? {
            HoleSelection::All => Vec::new(),
            HoleSelection::None => (0..n_loops).collect(),
            HoleSelection::AllExcept(v) => v,
            HoleSelection::Only(close) => (0..n_loops).filter(|i| !close.contains(i)).collect(),
        };
        let body = &scene.body;
        let m2 = margin * margin;
        let cloth = rest.positions();
        let keep: Vec<bool> =
            body.positions.iter().map(|b| cloth.iter().any(|c| (c - b).norm_squared() < m2)).collect();
        let mut map = vec![u32::MAX; keep.len()];
        let mut proxy_rest = Vec::new();
        let mut lists = Vec::new();
        for (i, &k) in keep.iter().enumerate() {
            if k {
                map[i] = proxy_rest.len() as u32;
                proxy_rest.push(body.positions[i]);
                lists.push(body.weights.of(i).map(|(b, w)| (b as u16, w as f32)).collect::<Vec<_>>());
            }
        }
        let faces: Vec<[u32; 3]> = body
            .faces
            .iter()
            .filter(|f| f.iter().all(|&v| keep[v as usize]))
            .map(|f| [map[f[0] as usize], map[f[1] as usize], map[f[2] as usize]])
            .collect();
        // Drop vertices no kept face uses, so the proxy mesh has no isolated vertices.
        let mut used = vec![false; proxy_rest.len()];
        faces.iter().flatten().for_each(|&v| used[v as usize] = true);
        let mut remap = vec![u32::MAX; proxy_rest.len()];
        let mut pr = Vec::new();
        let mut pl = Vec::new();
        for i in 0..proxy_rest.len() {
            if used[i] {
                remap[i] = pr.len() as u32;
                pr.push(proxy_rest[i]);
                pl.push(lists[i].clone());
            }
        }
        let faces: Vec<[u32; 3]> =
            faces.iter().map(|f| [remap[f[0] as usize], remap[f[1] as usize], remap[f[2] as usize]]).collect();
        if faces.is_empty() {
            return Err(TrainError::Invalid(format!(
                "no body face lies within body_margin = {margin} m of garment {}; raise [train] body_margin",
                scene.garment.name
            )));
        }
        let proxy_weights = SkinWeights::from_lists(&pl)?;
        let proxy_mesh = TriMesh::new(pr.clone(), faces)?;
        let pinned = scene.pinned_vertices()?;
        Ok(Self { scene, rest, open_holes, proxy_rest: pr, proxy_weights, proxy_mesh, pinned })
    }

    /// Garment name.
    pub fn name(&self) -> &str {
        &self.scene.garment.name
    }

    /// Proxy body vertices at `frame` of `motion`, m.
    pub fn body_at(&self, motion: &Motion, frame: usize) -> Result<Vec<Vec3>, TrainError> {
        let tr = self.scene.body.skeleton.bone_transforms(&motion.pose(frame)?)?;
        Ok(skin(&self.proxy_rest, &self.proxy_weights, &tr))
    }

    /// The energy of this garment's frames: `energy` with the step `dt` (s), the scene's
    /// gravity and the garment's open holes, against the proxy body.
    pub fn energy_model(
        &self,
        mut energy: senc_energy::EnergyConfig,
        dt: f64,
    ) -> Result<senc_energy::EnergyModel, TrainError> {
        energy.dt = dt;
        energy.gravity = self.scene.config.external_force.gravity;
        energy.self_collision.open_holes = self.open_holes.clone();
        Ok(senc_energy::EnergyModel::new(&self.rest, &energy, Some(&self.proxy_mesh))?.with_pinned(&self.pinned)?)
    }

    /// Makes a skinned state usable as a simulation start. Linear blend skinning pushes
    /// loose garments into the body where limbs meet the torso (100-380 of the t-shirt's
    /// vertices on every frame of the training clips), and a start with cloth centimetres
    /// deep in the body carries up to millions of joules of collision energy whose removal
    /// in one step flings the cloth off at metres per second (and teaches a network to do
    /// so). Pushing vertices out geometrically distorts the garment (1 kJ of stretching on
    /// the t-shirt), so the start is relaxed physically instead: `iterations` Newton
    /// iterations of `em`'s energy at zero velocity against the static body at `body_t`
    /// (the garment settles out of the body and its skinning strain relaxes), and `prev`
    /// moves by the same offsets as `curr`, so the skinned velocity is kept. `em` should be a
    /// phase-1 energy of this garment ([`Garment::energy_model`]); pinned vertices stay.
    pub fn relax_start(
        &self,
        em: &senc_energy::EnergyModel,
        prev: &mut [Vec3],
        curr: &mut [Vec3],
        body_t: &[Vec3],
        iterations: usize,
    ) -> Result<(), TrainError> {
        let fe = em.frame(curr, curr, Some((body_t, body_t)))?;
        let options = senc_energy::SolverOptions { max_iterations: iterations, ..Default::default() };
        let (x, _) = senc_energy::solve(&fe, curr, &options)?;
        for ((p, c), x) in prev.iter_mut().zip(curr.iter_mut()).zip(x) {
            *p += x - *c;
            *c = x;
        }
        Ok(())
    }

    /// Copies the pinned vertices' positions from `prescribed` into `x`.
    pub fn pin_from(&self, x: &mut [Vec3], prescribed: &[Vec3]) {
        for &i in &self.pinned {
            x[i] = prescribed[i];
        }
    }

    /// Moves the pinned vertices of `x` to the skinned garment at `frame` of `motion` (no
    /// skinning at all when nothing is pinned).
    pub fn pin_at(&self, x: &mut [Vec3], motion: &Motion, frame: usize) -> Result<(), TrainError> {
        if !self.pinned.is_empty() {
            self.pin_from(x, &self.skinned_at(motion, frame)?);
        }
        Ok(())
    }

    /// The garment skinned (no dynamics) to `frame` of `motion`, m.
    pub fn skinned_at(&self, motion: &Motion, frame: usize) -> Result<Vec<Vec3>, TrainError> {
        Ok(self.scene.garment_skinned_at(motion, frame)?)
    }

    /// Mean over frames `1..` of a rollout `cloth` of `motion` (frame 0 the start) of the mean
    /// vertex distance from the skinned garment, m: Table 1's and the stress cases' "from
    /// skinned", and the selection score.
    pub fn departure(&self, motion: &Motion, cloth: &[Vec<Vec3>]) -> Result<f64, TrainError> {
        let d = (1..cloth.len())
            .map(|f| Ok(crate::metrics::mean_distance(&cloth[f], &self.skinned_at(motion, f)?)))
            .collect::<Result<Vec<f64>, TrainError>>()?;
        Ok(crate::metrics::mean(&d))
    }

    /// The proxy body's faces.
    pub fn body_faces(&self) -> &[[u32; 3]] {
        self.proxy_mesh.faces()
    }

    /// The network's view of one step of this garment: the cloth at t−1 and t, the proxy
    /// body at t and t+1, the material, gravity plus external acceleration (m/s²) and the
    /// step's length (s).
    pub fn frame_state<'a>(
        &'a self,
        [prev, curr]: [&'a [Vec3]; 2],
        [body_t, body_next]: [&'a [Vec3]; 2],
        material: Material,
        accel: Vec3,
        dt: f64,
    ) -> FrameState<'a> {
        FrameState {
            rest: &self.rest,
            prev,
            curr,
            material,
            accel,
            dt,
            body: Some(BodyState { faces: self.body_faces(), curr: body_t, next: body_next }),
            pinned: &self.pinned,
        }
    }
}

/// Moves `prev` so that `curr − prev` becomes `k (curr − prev)`: after a step of length
/// `Δt₁`, the state for steps of length `Δt` keeps the same velocity with `k = Δt / Δt₁`.
pub fn rescale_velocity(prev: &mut [Vec3], curr: &[Vec3], k: f64) {
    for (p, c) in prev.iter_mut().zip(curr) {
        *p = c - (c - *p) * k;
    }
}
