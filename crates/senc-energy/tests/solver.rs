//! The reference solver on stiff and extreme scenes (small meshes, CI-fast): 200 frames
//! each, never a NaN or infinite position, energy never above the initial guess's, and
//! every stop has a reason.

use senc_energy::{solve, EnergyConfig, EnergyModel, SolverOptions, StopReason};
use senc_geom::{TriMesh, Vec3};
use senc_testmesh::{sheet, sphere};

struct Scene {
    garment: TriMesh,
    body: TriMesh,
    /// Body translation per frame, m.
    body_step: Vec3,
    config: EnergyConfig,
}

fn base_config() -> EnergyConfig {
    let mut c = EnergyConfig::default();
    c.self_collision.weight = 0.0;
    c
}

/// Runs `frames` frames; returns (frames whose energy strictly decreased, stop reasons).
fn run(scene: &Scene, frames: usize) -> (usize, Vec<StopReason>) {
    let model = EnergyModel::new(&scene.garment, &scene.config, Some(&scene.body)).unwrap();
    let mut prev = scene.garment.positions().to_vec();
    let mut cur = prev.clone();
    let mut body_t = scene.body.positions().to_vec();
    let options =
        SolverOptions { max_iterations: 15, gradient_tolerance: 1e-7, step_tolerance: 1e-7, ..Default::default() };
    let mut iterations = 0;
    let mut decreased = 0;
    let mut reasons = Vec::new();
    for frame in 0..frames {
        let body_next: Vec<Vec3> = body_t.iter().map(|p| p + scene.body_step).collect();
        let e = model.frame(&cur, &prev, Some((&body_t, &body_next))).unwrap();
        let guess = e.inertial_target().unwrap().to_vec();
        let (next, report) = solve(&e, &guess, &options).unwrap();
        assert!(next.iter().all(|p| p.iter().all(|c| c.is_finite())), "frame {frame}: non-finite position");
        assert!(report.energy.is_finite() && report.gradient_norm.is_finite(), "frame {frame}: {report:?}");
        assert!(report.energy <= report.initial_energy, "frame {frame}: energy rose {report:?}");
        assert_ne!(report.stop, StopReason::NonFiniteStart, "frame {frame}");
        if report.energy < report.initial_energy {
            decreased += 1;
        }
        iterations += report.iterations;
        reasons.push(report.stop);
        prev = cur;
        cur = next;
        body_t = body_next;
    }
    eprintln!("{} Newton iterations in {frames} frames", iterations);
    (decreased, reasons)
}

fn drape(config: EnergyConfig, body_step: Vec3, height: f64) -> Scene {
    Scene { garment: sheet(5, 0.8, height, 0.2, 1), body: sphere(Vec3::zeros(), 0.3, 8, 12), body_step, config }
}

fn assert_ok(name: &str, (decreased, reasons): (usize, Vec<StopReason>)) {
    let failed = reasons.iter().filter(|r| **r == StopReason::LineSearchFailed).count();
    eprintln!("{name}: {decreased}/200 frames decreased, {failed} line-search stops, last {:?}", reasons.last());
    assert!(decreased >= 150, "{name}: only {decreased} frames made progress");
}

#[test]
fn stiff_material() {
    let mut c = base_config();
    c.material.mu *= 100.0;
    c.material.bending_stiffness *= 100.0;
    assert_ok("stiff", run(&drape(c, Vec3::zeros(), 0.35), 200));
}

#[test]
fn fast_body() {
    // 10× a brisk 0.5 m/s: the sphere rises through the sheet at 5 m/s (17 cm per frame).
    assert_ok("fast body", run(&drape(base_config(), Vec3::new(0.0, 5.0 / 30.0, 0.0), 0.35), 200));
}

#[test]
fn strong_external_acceleration() {
    let mut c = base_config();
    c.external_acceleration = [50.0, 0.0, 0.0];
    assert_ok("50 m/s²", run(&drape(c, Vec3::zeros(), 0.35), 200));
}

#[test]
fn garment_started_inside_body() {
    assert_ok("inside", run(&drape(base_config(), Vec3::zeros(), 0.0), 200));
}

#[test]
fn iteration_budget_is_honoured_and_more_iterations_do_not_hurt() {
    let scene = drape(base_config(), Vec3::zeros(), 0.31);
    let model = EnergyModel::new(&scene.garment, &scene.config, Some(&scene.body)).unwrap();
    let x = scene.garment.positions();
    let b = scene.body.positions();
    let e = model.frame(x, x, Some((b, b))).unwrap();
    let mut last = f64::INFINITY;
    for budget in [1, 2, 4, 8] {
        let (_, r) = solve(&e, x, &SolverOptions { max_iterations: budget, ..Default::default() }).unwrap();
        assert!(r.iterations <= budget);
        assert!(r.energy <= last + 1e-12 * last.abs());
        last = r.energy;
    }
}

/// The same solve gives bit-identical positions whatever the thread count: the solver's
/// reductions (line-search slope, CG dot products) add fixed chunks in order. A plain
/// parallel `sum` made short solves differ run to run, enough to flip a test threshold.
#[test]
fn solve_is_bit_identical_across_thread_counts() {
    let scene = drape(base_config(), Vec3::new(0.0, 0.01, 0.0), 0.32);
    let garment = sheet(60, 0.8, 0.32, 0.2, 1);
    assert!(garment.n_vertices() > 3000);
    let model = EnergyModel::new(&garment, &scene.config, Some(&scene.body)).unwrap();
    let x = garment.positions().to_vec();
    let body: Vec<Vec3> = scene.body.positions().to_vec();
    let body_next: Vec<Vec3> = body.iter().map(|p| p + scene.body_step).collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let e = model.frame(&x, &x, Some((&body, &body_next))).unwrap();
            let guess = e.inertial_target().unwrap().to_vec();
            solve(&e, &guess, &SolverOptions { max_iterations: 4, ..Default::default() }).unwrap().0
        })
    };
    let one = run(1);
    for threads in [2, 3] {
        assert!(one == run(threads), "{threads} threads gave other positions than 1");
    }
}

/// A sheet pinned along one row hangs from it: the pinned vertices keep their prescribed
/// positions exactly through Newton solves, their gradient is zero, and the free vertices
/// fall under gravity.
#[test]
fn pinned_vertices_stay_where_they_are_put() {
    let garment = sheet(8, 0.4, 0.3, 0.0, 1);
    let x0 = garment.positions().to_vec();
    let top = x0.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    let pinned: Vec<usize> = (0..x0.len()).filter(|&i| (x0[i].z - top).abs() < 1e-12).collect();
    assert!(pinned.len() >= 8, "{} pinned", pinned.len());
    let model = EnergyModel::new(&garment, &base_config(), None).unwrap().with_pinned(&pinned).unwrap();
    let (mut prev, mut cur) = (x0.clone(), x0.clone());
    for _ in 0..10 {
        let e = model.frame(&cur, &prev, None).unwrap();
        let guess = e.inertial_target().unwrap().to_vec();
        let mut g = vec![Vec3::zeros(); guess.len()];
        e.evaluate(&guess, Some(&mut g)).unwrap();
        assert!(pinned.iter().all(|&i| g[i] == Vec3::zeros()));
        assert!(g.iter().any(|v| v.norm() > 0.0));
        let (next, _) = solve(&e, &guess, &SolverOptions { max_iterations: 5, ..Default::default() }).unwrap();
        for &i in &pinned {
            assert_eq!(next[i], guess[i], "pinned vertex {i} moved");
        }
        prev = std::mem::replace(&mut cur, next);
    }
    let free = (0..x0.len()).find(|i| !pinned.contains(i)).unwrap();
    assert!(cur[free].y < x0[free].y - 1e-3, "free vertex did not fall: {:?} -> {:?}", x0[free], cur[free]);
    let err = EnergyModel::new(&garment, &base_config(), None).unwrap().with_pinned(&[x0.len()]).unwrap_err();
    assert!(err.to_string().contains("does not exist"), "{err}");
}

/// A closed tube folded through itself at an elbow, simulated as cloth with SENC's
/// self-collision and nothing else pushing: the volume term's force opens the tangle, and
/// the curvature model the solver gives that term keeps each frame's step near the
/// tangle's depth, so no vertex is flung away and no edge tears. (Seen only through its
/// force, the same term moves vertices 0.3-0.7 m per frame here and stretches edges 8-14
/// times.)
#[test]
fn self_collision_opens_a_tangle_without_tearing() {
    let tube = senc_testmesh::fixture("elbow_fold").unwrap();
    let config = EnergyConfig { gravity: [0.0; 3], ..Default::default() };
    let model = EnergyModel::new(&tube, &config, None).unwrap();
    let x0 = tube.positions().to_vec();
    let edges: Vec<(usize, usize, f64)> = tube
        .faces()
        .iter()
        .flat_map(|f| (0..3).map(move |k| (f[k] as usize, f[(k + 1) % 3] as usize)))
        .map(|(a, b)| (a, b, (x0[a] - x0[b]).norm()))
        .collect();
    let self_energy = |x: &[Vec3]| {
        let e = model.frame(x, x, None).unwrap();
        e.evaluate(x, None).unwrap().get("self_collision").unwrap()
    };
    let first = self_energy(&x0);
    assert!(first > 1.0, "the fixture is not tangled: {first} J");
    let (mut prev, mut cur) = (x0.clone(), x0.clone());
    for frame in 0..4 {
        let e = model.frame(&cur, &prev, None).unwrap();
        let guess = e.inertial_target().unwrap().to_vec();
        let (next, r) = solve(&e, &guess, &SolverOptions { max_iterations: 8, ..Default::default() }).unwrap();
        let step = next.iter().zip(&cur).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        let stretch = edges.iter().map(|&(a, b, l)| (next[a] - next[b]).norm() / l).fold(0.0, f64::max);
        eprintln!("frame {frame}: largest step {step:.4} m, largest stretch {stretch:.3}, {r:?}");
        assert!(step < 0.15, "frame {frame}: a vertex moved {step} m");
        assert!(stretch < 2.0, "frame {frame}: an edge stretched {stretch} times");
        prev = std::mem::replace(&mut cur, next);
    }
    let last = self_energy(&cur);
    eprintln!("self-collision energy {first} J -> {last} J");
    assert!(last < 0.5 * first, "the tangle did not open: {first} J -> {last} J");
}
