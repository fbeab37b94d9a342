//! End-to-end trainer tests on `configs/smoke.toml` shrunk further (tiny network, a few
//! iterations): checkpoints, exact resume, phase switch, non-finite handling, evaluation.

use std::path::{Path, PathBuf};

use senc_model::burn::tensor::Device;
use senc_model::Model;
use senc_train::clip::flat_params;
use senc_train::eval::{evaluate, evaluate_solver, first_scene, training_config, write_reports, Method, Series};
use senc_train::{Phase, RunConfig, Trainer};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A copy of the smoke config with fewer iterations, written into `dir`.
fn tiny_config(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("configs/smoke.toml")).unwrap();
    let data = root().join("data");
    let text = text
        .replace("../data", data.to_str().unwrap())
        .replace("warmup_iterations = 10", "warmup_iterations = 3")
        .replace("phase1_iterations = 30", "phase1_iterations = 6")
        .replace("phase2_iterations = 20", "phase2_iterations = 4")
        .replace("checkpoint_every = 10", "checkpoint_every = 2")
        .replace("rollout_growth = 10", "rollout_growth = 2")
        .replace("frames = 20", "frames = 4");
    let p = dir.join("tiny.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// [`tiny_config`] with `keys` (TOML lines) added to its `[train]` table.
fn tiny_config_with(dir: &Path, keys: &str) -> PathBuf {
    let cfg = tiny_config(dir);
    let text = std::fs::read_to_string(&cfg).unwrap().replace("[train]\n", &format!("[train]\n{keys}"));
    std::fs::write(&cfg, text).unwrap();
    cfg
}

/// The flat parameter vector of the checkpoint in `dir`.
fn params(dir: &Path) -> Vec<f64> {
    flat_params(&Model::load(dir, &Device::flex()).unwrap().network)
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("senc-train-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn kill_and_resume_gives_the_same_weights_and_eval_runs() {
    let d = tmp("resume");
    let cfg = tiny_config(&d);
    // Uninterrupted.
    let a = d.join("a");
    let mut t = Trainer::new(&cfg, &a).unwrap();
    let mut losses_a = Vec::new();
    t.run(None, |r| {
        if r.phase != Phase::WarmUp {
            losses_a.push(r.loss)
        }
    })
    .unwrap();
    assert!(t.finished());
    assert_eq!(losses_a.len(), 10, "6 + 4 training iterations");
    assert!(losses_a.iter().all(|l| l.is_finite()), "{losses_a:?}");
    // Killed after 4 iterations (a checkpoint at 4), then resumed.
    let b = d.join("b");
    let mut t = Trainer::new(&cfg, &b).unwrap();
    t.run(Some(4), |_| {}).unwrap();
    assert!(!t.finished());
    drop(t);
    let mut t = Trainer::resume(&b).unwrap();
    assert_eq!(t.progress.iteration, 4);
    t.run(None, |_| {}).unwrap();
    assert!(t.finished());
    let lines = |d: &Path| std::fs::read_to_string(d.join("losses.csv")).unwrap().lines().count();
    assert_eq!(lines(&b), lines(&a), "the resumed CSV has no duplicate rows");
    for phase in ["phase1", "phase2"] {
        let wa = params(&a.join(phase));
        let wb = params(&b.join(phase));
        let diff = wa.iter().zip(&wb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(wa.len() == wb.len() && diff == 0.0, "{phase}: resumed weights differ by up to {diff}");
    }
    // Phase 2 trained from phase 1: the weights moved.
    assert_ne!(params(&a.join("phase1")), params(&a.join("phase2")));
    let csv = std::fs::read_to_string(a.join("losses.csv")).unwrap();
    assert_eq!(csv.lines().count(), 11, "{csv}");
    assert!(csv.contains("self_collision="), "phase 2 logs the self-collision term:\n{csv}");

    // Evaluation of the tiny model writes every report.
    let m = Method::new(&a.join("phase2"), None).unwrap();
    let (rows, curve) = evaluate(&m).unwrap();
    let motions: Vec<&str> = rows.iter().map(|r| r.motion.as_str()).collect();
    assert_eq!(motions, ["boxing_toes", "mocapbank_150"], "one row per test motion of smoke.toml");
    let row = &rows[0];
    assert_eq!(row.frames, 4);
    assert!(row.volume_cm3.is_finite() && row.volume_cm3 >= 0.0);
    assert!(row.fps > 0.0);
    assert!(row.departure_cm.is_finite() && row.departure_cm > 0.0, "{}", row.departure_cm);
    assert_eq!(curve.len(), 5, "3 solver budgets + the network + the network refined by 2 it");
    assert!(curve.iter().all(|p| p.energy_gap.is_finite()));
    assert!(curve[..3].iter().all(|p| p.series == Series::Solver));
    let (net, refined) = (&curve[3], &curve[4]);
    assert_eq!((&net.series, &refined.series), (&Series::Network(m.label.clone()), &Series::Network(m.label.clone())));
    assert_eq!(refined.method, format!("{} + 2 it", m.label));
    // Newton with a line search from the better of the network's answer and the inertial
    // target cannot end above the network's answer.
    assert!(refined.energy_gap <= net.energy_gap + 1e-9, "{} > {}", refined.energy_gap, net.energy_gap);
    // The row is named by the method the checkpoint was trained as (smoke.toml: seed 1).
    assert_eq!(row.method, "SENC, seed 1");
    assert_eq!(row.rise_30_cm, None, "4 frames are fewer than 30");
    // The reference solver's row on the same garment and motions.
    let solver = evaluate_solver(&m).unwrap().remove(0);
    assert_eq!(
        (solver.method.as_str(), solver.frames, solver.garment.as_str()),
        ("reference solver", 4, row.garment.as_str())
    );
    assert!(solver.fps > 0.0 && solver.volume_cm3.is_finite() && solver.departure_cm.is_finite());
    // Cloth stretches by little: the solver's garment keeps its rest area to a few per cent.
    assert!(solver.area_growth_pct.abs() < 5.0, "{}", solver.area_growth_pct);
    assert!(row.area_growth_pct.is_finite());
    assert!(solver.strain_pct >= 0.0 && solver.strain_pct < 10.0, "{}", solver.strain_pct);
    assert!(row.strain_pct.is_finite() && row.strain_pct >= 0.0);
    let out = d.join("reports");
    write_reports(&out, &[row.clone(), solver], &curve, "test").unwrap();
    for f in ["table1.md", "table1.csv", "table1.json", "runtime.md", "runtime.csv", "runtime.svg"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("table1.json")).unwrap()).unwrap();
    for field in ["method", "volume_cm3", "departure_cm", "rise_30_cm", "area_growth_pct", "strain_pct", "fps"] {
        assert!(json[1].get(field).is_some(), "table1.json lacks {field}");
    }
    let csv = std::fs::read_to_string(out.join("table1.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(
        csv.starts_with("method,garment,motion,frames,volume_cm3,") && csv.contains("\nreference solver,"),
        "{csv}"
    );
    let md = std::fs::read_to_string(out.join("table1.md")).unwrap();
    assert!(md.contains("| SENC, seed 1 |") && md.contains("| reference solver |"), "{md}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The next sequence's start is built beside the step that ends the running one when rayon
/// has a second thread: the run is the same, weight for weight, on one thread and on two.
#[test]
fn training_gives_the_same_weights_on_one_thread_and_on_two() {
    let d = tmp("threads");
    let cfg = tiny_config(&d);
    let run = |threads: usize| {
        let out = d.join(format!("t{threads}"));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut losses = Vec::new();
        pool.install(|| {
            let mut t = Trainer::new(&cfg, &out).unwrap();
            t.run(None, |r| losses.push(r.loss)).unwrap();
            assert!(t.finished());
        });
        (params(&out.join("phase2")), losses)
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.1.len(), 3 + 6 + 4, "warm-up and both phases");
    assert!(one.1.iter().skip(3).all(|l| l.is_finite()), "{:?}", one.1);
    assert_eq!(one.0, two.0, "phase-2 weights depend on the thread count");
    let bits = |l: &[f64]| l.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one.1), bits(&two.1), "losses depend on the thread count");
    let _ = std::fs::remove_dir_all(&d);
}

/// `train --seed --set` in library terms: a config extending the smoke config, resolved with
/// overrides and saved as the run's `config.toml` (paths rewritten relative to the run),
/// trains with the overridden values, and its checkpoints give back that config.
#[test]
fn a_resolved_config_with_overrides_trains_and_travels_with_the_checkpoint() {
    let d = tmp("resolved");
    let smoke = root().join("configs/smoke.toml").canonicalize().unwrap();
    let overlay = d.join("overlay.toml");
    let text = format!(
        "extends = {:?}\n[train]\nwarmup_iterations = 2\ncheckpoint_every = 2\nrollout_growth = 2\n",
        smoke.to_str().unwrap()
    );
    std::fs::write(&overlay, text).unwrap();
    let sets = ["train.phase1_iterations=2".to_string(), "train.phase2_iterations=1".to_string()];
    let doc = RunConfig::resolve(&overlay, Some(5), &sets).unwrap();
    let out = d.join("run");
    std::fs::create_dir_all(&out).unwrap();
    let resolved = doc.moved_to(&out.join("config.toml"), senc_train::config::PATH_KEYS);
    let saved_text = resolved.to_toml();
    assert!(!saved_text.contains("extends") && saved_text.contains("[scene]"), "{saved_text}");
    std::fs::write(&resolved.path, &saved_text).unwrap();
    let mut t = Trainer::new(&resolved.path, &out).unwrap();
    let tc = &t.config.train;
    assert_eq!((tc.seed, tc.warmup_iterations, tc.phase1_iterations, tc.phase2_iterations), (5, 2, 2, 1));
    t.run(None, |_| {}).unwrap();
    assert!(t.finished());
    let saved = training_config(&out.join("phase2")).unwrap();
    assert_eq!(saved.train, t.config.train);
    assert_eq!(saved.method_name(), "SENC, seed 5");
    let g = senc_train::Garment::load(&first_scene(&saved).unwrap(), saved.train.body_margin).unwrap();
    assert!(!g.scene.test.is_empty());
    let _ = std::fs::remove_dir_all(&d);
}

/// Training from the network's own rollout states (`pool_share`) with the Newton signal:
/// the pool fills with the states a rollout reached (finite, on the run's garment and a
/// training motion), pooled sequences start from them, and a kill and resume still gives
/// the uninterrupted run's weights exactly (the pool is part of the checkpoint).
#[test]
fn visited_state_pool_and_newton_signal_resume_exactly() {
    let d = tmp("pool");
    let cfg = tiny_config_with(
        &d,
        "pool_share = 1.0\npool_every = 3\npool_frames = 4\npool_stride = 2\npool_size = 3\nnewton_weight = 30.0\n",
    );
    let a = d.join("a");
    let mut t = Trainer::new(&cfg, &a).unwrap();
    let mut losses = Vec::new();
    t.run(None, |r| {
        if r.phase != Phase::WarmUp {
            losses.push(r.loss)
        }
    })
    .unwrap();
    assert!(losses.iter().all(|l| l.is_finite()), "{losses:?}");
    let pool = &t.progress.pool;
    assert_eq!(pool.len(), 3, "pool_size states kept");
    let n = t.garments()[0].rest.n_vertices();
    for s in pool {
        assert!(s.frame > 0, "a pooled state comes after a step, not frame {}", s.frame);
        assert_eq!((s.prev.len(), s.curr.len()), (n, n));
        assert!(s.curr.iter().chain(&s.prev).all(|p| p.iter().all(|c| c.is_finite())));
        assert_ne!(s.prev, s.curr, "a rolled-out state moves");
    }
    let b = d.join("b");
    let mut t = Trainer::new(&cfg, &b).unwrap();
    t.run(Some(5), |_| {}).unwrap();
    drop(t);
    let mut t = Trainer::resume(&b).unwrap();
    t.run(None, |_| {}).unwrap();
    for phase in ["phase1", "phase2"] {
        assert_eq!(params(&a.join(phase)), params(&b.join(phase)), "{phase}: resumed weights differ");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `[train] select_every`: phase 2's network is scored by a rollout on the training motion
/// every 2 iterations; `OUT/phase2` is the best-scoring one (its score recomputed from the
/// saved weights), `selection.csv` has one row per selection, and a killed run resumes to
/// the same choice.
#[test]
fn phase2_keeps_the_network_whose_rollout_strays_least() {
    let d = tmp("select");
    let cfg = tiny_config_with(&d, "select_every = 2\nselect_frames = 5\n");
    let a = d.join("a");
    let mut t = Trainer::new(&cfg, &a).unwrap();
    t.run(None, |_| {}).unwrap();
    assert!(t.finished());
    let csv = std::fs::read_to_string(a.join(senc_train::trainer::SELECTION_FILE)).unwrap();
    let rows: Vec<(u64, f64, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect();
    assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [2, 4], "{csv}");
    assert!(rows.iter().all(|r| r.1.is_finite() && r.1 > 0.0 && r.2.is_finite() && r.2 >= 0.0), "{csv}");
    let (k, best) = t.progress.best.expect("a finite score was seen");
    // The default cap on the volume (100 cm³) is far above what the tiny skirt reaches.
    assert!(rows.iter().all(|r| r.2 < 100.0), "{csv}");
    let min = rows.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    assert!((best - min).abs() < 1e-3, "best {best} is the smallest score {min}");
    assert!(rows.iter().any(|r| r.0 == k));
    assert_eq!(params(&a.join("phase2")), params(&a.join("best")), "phase2/ holds the best network");
    let last = params(&a.join("latest"));
    if k == 4 {
        assert_eq!(last, params(&a.join("phase2")));
    } else {
        assert_ne!(last, params(&a.join("phase2")), "latest/ keeps the last network, not the best");
    }
    // The trainer's model is now the best network: its score is the best one again.
    let again = t.selection_score().unwrap();
    assert!((again.departure_cm - best).abs() < 1e-3);
    let row = rows.iter().find(|r| r.0 == k).unwrap();
    assert!((again.volume_cm3 - row.2).abs() <= 1e-3 * (1.0 + row.2), "{again:?} against {row:?}");
    drop(t);
    // Killed in phase 2 after the first selection, resumed: the same rows and choice.
    let b = d.join("b");
    let mut t = Trainer::new(&cfg, &b).unwrap();
    t.run(Some(6 + 3), |_| {}).unwrap();
    drop(t);
    let mut t = Trainer::resume(&b).unwrap();
    t.run(None, |_| {}).unwrap();
    assert_eq!(std::fs::read_to_string(b.join(senc_train::trainer::SELECTION_FILE)).unwrap(), csv);
    assert_eq!(params(&a.join("phase2")), params(&b.join("phase2")));
    let _ = std::fs::remove_dir_all(&d);
}

/// Where `select_every` does not divide phase 2, the last network is scored too.
#[test]
fn the_last_network_is_scored_when_selection_does_not_divide_phase2() {
    let d = tmp("select-last");
    let cfg = tiny_config_with(&d, "select_every = 3\nselect_frames = 3\n");
    let mut t = Trainer::new(&cfg, &d.join("run")).unwrap();
    t.run(None, |_| {}).unwrap();
    let csv = std::fs::read_to_string(d.join("run").join(senc_train::trainer::SELECTION_FILE)).unwrap();
    let its: Vec<&str> = csv.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect();
    assert_eq!(its, ["3", "4"], "{csv}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A finished run whose saved config asks for more phase-2 iterations continues on
/// `resume` from where it stopped; with the same count it stays finished.
#[test]
fn finished_run_extends_when_its_config_asks_for_more() {
    let d = tmp("extend");
    let cfg = tiny_config(&d);
    let out = d.join("run");
    let mut t = Trainer::new(&cfg, &out).unwrap();
    t.run(None, |_| {}).unwrap();
    assert!(t.finished());
    drop(t);
    let same = Trainer::resume(&out).unwrap();
    assert!(same.finished(), "an unchanged config stays finished");
    drop(same);
    let latest = out.join("latest/config.toml");
    let text = std::fs::read_to_string(&latest).unwrap();
    assert!(text.contains("phase2_iterations = 4"), "{text}");
    std::fs::write(&latest, text.replace("phase2_iterations = 4", "phase2_iterations = 7")).unwrap();
    let before = params(&out.join("phase2"));
    let mut t = Trainer::resume(&out).unwrap();
    assert!(!t.finished());
    let mut phase2_steps = 0;
    t.run(None, |r| {
        if r.phase == Phase::Two {
            phase2_steps += 1
        }
    })
    .unwrap();
    assert!(t.finished());
    assert_eq!(phase2_steps, 3, "iterations 5, 6 and 7 of phase 2");
    assert_eq!(t.progress.iteration, 7);
    let after = params(&out.join("phase2"));
    assert_ne!(before, after, "phase2/ holds the extended weights");
    let _ = std::fs::remove_dir_all(&d);
}

/// Phase 2 restarted from a copy of `OUT/phase1` (how the ablations that share SENC's
/// phase 1 are trained) gives the same phase-2 weights as the uninterrupted run: phase 2's
/// fresh Adam state is what `phase1/` holds.
#[test]
fn phase2_from_a_copy_of_phase1_equals_the_uninterrupted_run() {
    let d = tmp("phase1copy");
    let cfg = tiny_config(&d);
    let a = d.join("a");
    let mut t = Trainer::new(&cfg, &a).unwrap();
    t.run(None, |_| {}).unwrap();
    drop(t);
    let b = d.join("b");
    std::fs::create_dir_all(b.join("latest")).unwrap();
    for f in std::fs::read_dir(a.join("phase1")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, b.join("latest").join(f.file_name().unwrap())).unwrap();
    }
    let mut t = Trainer::resume(&b).unwrap();
    assert_eq!((t.progress.phase, t.progress.iteration), (Phase::Two, 0));
    t.run(None, |_| {}).unwrap();
    assert!(t.finished());
    let (wa, wb) = (params(&a.join("phase2")), params(&b.join("phase2")));
    let diff = wa.iter().zip(&wb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(wa.len() == wb.len() && diff == 0.0, "phase 2 from phase1/ differs by up to {diff}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_config_is_an_error_naming_the_key() {
    let d = tmp("bad");
    let p = d.join("bad.toml");
    std::fs::write(&p, "[train]\nlearning_rat = 1.0\n").unwrap();
    let e = Trainer::new(&p, &d.join("out")).err().expect("must fail");
    assert!(e.to_string().contains("learning_rat"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The reference solver's simulation of the t-shirt on the test motion (whose clip starts
/// facing away from the rest pose) keeps the garment whole and on the body for the first
/// frames: edges stretch by less than 50 % and no vertex strays more than 10 cm from its
/// skinned position (free fall alone would be 20 cm). Before the clips were aligned to the
/// rest heading, the lead-in spun the body through the garment and the solver's garment
/// exploded within 7 frames.
#[test]
fn reference_solver_rollout_keeps_the_tshirt_whole() {
    use senc_train::garment::Garment;
    use senc_train::rollout::solver_rollout;
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/tshirt.toml")).unwrap();
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    let motion = &g.scene.test[0];
    let energy = cfg.energy_for(Phase::One, scene_material(&g).unwrap(), [0.0; 3]);
    let frames = 6;
    let r = solver_rollout(&g, motion, frames, &energy, 4).unwrap();
    assert_eq!(r.cloth.len(), frames + 1);
    let rest = g.rest.positions();
    let x = r.cloth.last().unwrap();
    let strain = g
        .rest
        .faces()
        .iter()
        .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
        .map(|(i, j)| (x[i as usize] - x[j as usize]).norm() / (rest[i as usize] - rest[j as usize]).norm())
        .fold(0.0f64, f64::max);
    assert!(strain < 1.5, "max edge stretch {strain}");
    let skinned = g.skinned_at(motion, frames).unwrap();
    let dev = x.iter().zip(&skinned).map(|(a, b)| (a - b).norm()).fold(0.0f64, f64::max);
    assert!(dev < 0.1, "max distance from the skinned garment {dev} m");
}

/// `[scene] pin = ["waist"]` (smoke.toml's coarse skirt): in the reference solver's
/// rollout and in a network rollout the waist vertices are exactly the skinned garment's
/// at every frame, and the solver's skirt hangs from them instead of falling off (free
/// fall alone would take it 35 cm down in 8 frames).
#[test]
fn pinned_waist_follows_the_body_and_holds_the_skirt() {
    use senc_train::garment::Garment;
    use senc_train::rollout::{rollout, solver_rollout};
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/smoke.toml")).unwrap();
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    assert!(!g.pinned.is_empty(), "smoke.toml pins the waist");
    let motion = &g.scene.test[0];
    let material = scene_material(&g).unwrap();
    let frames = 8;
    let energy = cfg.energy_for(Phase::One, material, [0.0; 3]);
    let solver = solver_rollout(&g, motion, frames, &energy, 6).unwrap();
    let model = Model::new(cfg.model.network.clone(), cfg.model.graph, 3, &Device::flex());
    let net = rollout(&model, &g, motion, frames, senc_geom::Vec3::zeros(), &material).unwrap();
    for f in 0..=frames {
        let skinned = g.skinned_at(motion, f).unwrap();
        for r in [&solver, &net] {
            for &i in &g.pinned {
                assert_eq!(r.cloth[f][i], skinned[i], "frame {f}: pinned vertex {i} is off the body");
            }
        }
    }
    let skinned = g.skinned_at(motion, frames).unwrap();
    let x = solver.cloth.last().unwrap();
    let mean_drop = x.iter().zip(&skinned).map(|(a, b)| b.y - a.y).sum::<f64>() / x.len() as f64;
    assert!(mean_drop < 0.1, "the pinned skirt fell {mean_drop} m on average");
}

/// `Garment::relax_start` on skinned t-shirt states whose cloth is inside the body (linear
/// blend skinning artefacts): afterwards fewer vertices are inside the proxy body, the
/// static energy of the frame is far lower, and every vertex keeps its velocity `x[t] − x[t−1]`.
/// `network_rollout` with Newton refinement (`simulate --refine`, `eval --refine`), on the
/// smoke scene with an untrained network: no refinement is the plain rollout bit for bit;
/// with it, every frame is recorded, no refined frame has a higher phase-2 energy than the
/// network's answer or the inertial target, the solver starts from the target exactly where
/// the network's answer is worse, and the rollout stays finite.
#[test]
fn refined_rollout_never_raises_the_energy() {
    use senc_train::garment::Garment;
    use senc_train::rollout::{network_rollout, rollout, Refine};
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/smoke.toml")).unwrap();
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    let motion = &g.scene.test[0];
    let material = scene_material(&g).unwrap();
    let model = Model::new(cfg.model.network.clone(), cfg.model.graph, 7, &Device::flex());
    let frames = 6;
    let ext = senc_geom::Vec3::zeros();
    let plain = rollout(&model, &g, motion, frames, ext, &material).unwrap();
    let none = network_rollout(&model, &g, motion, frames, ext, &material, None).unwrap();
    assert_eq!(plain.cloth, none.cloth);
    assert!(none.refined.is_empty());
    let energy = cfg.energy_for(Phase::Two, material, [0.0; 3]);
    assert!(energy.self_collision.weight > 0.0, "smoke.toml's phase 2 has self-collision");
    let zero =
        network_rollout(&model, &g, motion, frames, ext, &material, Some(Refine { energy: &energy, iterations: 0 }))
            .unwrap();
    assert_eq!(plain.cloth, zero.cloth);
    let r =
        network_rollout(&model, &g, motion, frames, ext, &material, Some(Refine { energy: &energy, iterations: 2 }))
            .unwrap();
    assert_eq!(r.refined.len(), frames);
    assert!(r.cloth.iter().flatten().all(|p| p.iter().all(|c| c.is_finite())));
    let mut moved = 0;
    for (f, s) in r.refined.iter().enumerate() {
        assert!(s.refined.is_finite() && s.inertial.is_finite(), "frame {f}: {s:?}");
        assert!(s.refined <= s.inertial.min(s.network) + 1e-12 * s.inertial.abs().max(1.0), "frame {f}: {s:?}");
        assert_eq!(s.rejected, s.network.is_nan() || s.network > s.inertial, "frame {f}: {s:?}");
        moved += usize::from(r.cloth[f + 1] != plain.cloth[f + 1]);
    }
    assert!(moved > 0, "the refinement changed no frame");
}

#[test]
fn relaxed_start_leaves_the_body_and_keeps_velocities() {
    use senc_train::garment::Garment;
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/tshirt.toml")).unwrap();
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    let em = g.energy_model(cfg.energy_for(Phase::One, scene_material(&g).unwrap(), [0.0; 3]), g.scene.dt()).unwrap();
    let motion = &g.scene.train[0];
    let f = 20;
    let body = g.body_at(motion, f).unwrap();
    let q = senc_scene::BodyQuery::new(&body, g.body_faces()).unwrap();
    let (mut prev, mut curr) = (g.skinned_at(motion, f - 1).unwrap(), g.skinned_at(motion, f).unwrap());
    let static_energy =
        |x: &[senc_geom::Vec3]| em.frame(x, x, Some((&body, &body))).unwrap().evaluate(x, None).unwrap().total;
    let (inside0, e0) = (q.inside(&curr).len(), static_energy(&curr));
    let v0: Vec<_> = curr.iter().zip(&prev).map(|(c, p)| c - p).collect();
    g.relax_start(&em, &mut prev, &mut curr, &body, 4).unwrap();
    let (inside1, e1) = (q.inside(&curr).len(), static_energy(&curr));
    assert!(inside0 > 50, "frame {f} was expected to penetrate: {inside0}");
    // 352 -> 294 inside and 1035 J -> 67 J: the cubic penalty leaves many vertices a
    // millimetre inside, where it costs almost nothing, so the energy falls far more than
    // the count.
    eprintln!("inside {inside0} -> {inside1}, energy {e0} J -> {e1} J");
    assert!(inside1 * 10 <= inside0 * 9, "inside {inside0} -> {inside1}");
    assert!(e1 * 10.0 < e0, "energy {e0} -> {e1}");
    for (i, ((c, p), v)) in curr.iter().zip(&prev).zip(&v0).enumerate() {
        assert!((c - p - v).norm() < 1e-12, "vertex {i}: velocity changed");
    }
}

/// After the long first step the state keeps its velocity for 1/fps steps:
/// `rescale_velocity` turns a 0.1 s displacement into the 1/30 s one of the same velocity.
#[test]
fn rescaled_velocity_is_the_same_velocity() {
    use senc_geom::Vec3;
    let curr = vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0)];
    let mut prev = vec![Vec3::new(1.0, 2.3, 3.0), Vec3::new(-1.6, 0.5, 0.3)];
    let v_before: Vec<Vec3> = curr.iter().zip(&prev).map(|(c, p)| (c - p) / 0.1).collect();
    senc_train::garment::rescale_velocity(&mut prev, &curr, (1.0 / 30.0) / 0.1);
    for ((c, p), v) in curr.iter().zip(&prev).zip(&v_before) {
        assert!(((c - p) * 30.0 - v).norm() < 1e-12);
    }
}

/// Every config in configs/ parses, resolves its `extends`, validates and names scene files
/// that exist, so configs cannot silently rot as keys change; each ablation extends its
/// garment's config and trains the method its name says.
#[test]
fn every_committed_config_parses() {
    let mut files = Vec::new();
    for e in std::fs::read_dir(root().join("configs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            files.push(p);
        }
    }
    assert!(files.iter().any(|p| p.ends_with("tshirt.toml")), "configs/ has no tshirt.toml");
    for p in &files {
        let cfg = RunConfig::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let scenes = cfg.scene_files();
        assert!(!scenes.is_empty(), "{}: no [scene] and no [train] scenes", p.display());
        for s in scenes {
            assert!(s.is_file(), "{}: scene file {} is missing", p.display(), s.display());
            senc_scene::SceneConfig::read(&s).unwrap_or_else(|e| panic!("{}: {e}", s.display()));
        }
    }
    let method = |name: &str| RunConfig::read(root().join("configs").join(name)).unwrap().method_name();
    for garment in ["tshirt", "skirt"] {
        for (suffix, name) in [
            ("", "SENC"),
            ("-baseline", "baseline"),
            ("-no-selfcol-edges", "w/o self-col edges"),
            ("-mesh-edges", "w. mesh edges"),
            ("-area", "w. area loss"),
            ("-repulsive", "repulsive"),
            ("-eval-quick", "SENC"),
        ] {
            let file = format!("{garment}{suffix}.toml");
            assert_eq!(method(&file), name, "{file}");
            if !suffix.is_empty() {
                let text = std::fs::read_to_string(root().join("configs").join(&file)).unwrap();
                assert!(text.contains(&format!("extends = \"{garment}.toml\"")), "{file} copies instead of extending");
                // An overlay changes what it names and inherits the rest, [train] included.
                let (a, b) = (RunConfig::read(root().join("configs").join(&file)).unwrap(), method_cfg(garment));
                assert_eq!(a.train, b.train, "{file}: [train] differs from {garment}.toml");
            }
        }
    }
    assert_eq!(method("all.toml"), "SENC, 5 garments");
    for garment in ["longsleeve", "pants", "dress"] {
        assert_eq!(method(&format!("{garment}.toml")), "SENC");
        assert_eq!(method(&format!("{garment}-eval-quick.toml")), "SENC");
    }
}

/// The stress cases run an untrained network (the smoke config, elastic features on) on
/// every case without an error; each reports finite numbers or says why it stopped, the
/// stiff case costs more energy than the default and the inside start starts deeper.
#[test]
fn stress_cases_report_every_case() {
    use senc_train::garment::Garment;
    use senc_train::stress::{stress, towards_body, StressCase};
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/smoke.toml")).unwrap();
    assert!(cfg.model.graph.elastic_features);
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    let motion = &g.scene.test[0];
    let material = scene_material(&g).unwrap();
    let energy = cfg.energy_for(Phase::Two, material, [0.0; 3]);
    let model = Model::new(cfg.model.network.clone(), cfg.model.graph, 3, &Device::flex());
    let rows = stress(&model, &g, motion, 4, &energy, &material).unwrap();
    assert_eq!(rows.iter().map(|r| r.case).collect::<Vec<_>>(), StressCase::ALL.to_vec());
    for r in &rows {
        assert_eq!(r.finite, r.error.is_none(), "{r:?}");
        if r.finite {
            assert_eq!(r.frames, 4, "{r:?}");
            assert!(r.energy_mean_j.is_finite() && r.departure_cm.is_finite() && r.max_speed_cm >= 0.0, "{r:?}");
        }
    }
    let (default, stiff) = (&rows[0], &rows[1]);
    assert!(stiff.energy_max_j > default.energy_max_j, "{default:?} {stiff:?}");
    // The inside start is deeper in the body than the skinned garment.
    let body = g.scene.body_at(motion, 0).unwrap();
    let q = senc_scene::BodyQuery::new(&body, &g.scene.body.faces).unwrap();
    let x0 = g.skinned_at(motion, 0).unwrap();
    let moved = towards_body(&x0, &q, 0.02);
    let depth = |x: &[senc_geom::Vec3]| x.iter().map(|p| q.closest(p).signed_distance).sum::<f64>() / x.len() as f64;
    assert!(depth(&moved) < depth(&x0) - 0.015, "{} vs {}", depth(&moved), depth(&x0));
}

fn method_cfg(garment: &str) -> RunConfig {
    RunConfig::read(root().join("configs").join(format!("{garment}.toml"))).unwrap()
}

/// The networks committed in `checkpoints/` still load with the current code and give the
/// rollout they gave when they were committed: mean cloth displacement from the start after
/// three frames of the first test motion, to 1 mm (the values recorded when they were
/// committed). Each checkpoint's `config.toml` is the resolved training config, with paths
/// relative to the checkpoint; all are self-contained but `all`, whose scenes are the five
/// garment configs. A change to the checkpoint format, the features, the graph or the
/// network that silently changes what a trained checkpoint computes fails here; retrain the
/// checkpoints (`checkpoints/README.md`) and update the values then.
#[test]
fn committed_checkpoints_load_and_give_their_recorded_rollout() {
    use senc_train::garment::Garment;
    use senc_train::rollout::rollout;
    use senc_train::trainer::scene_material;
    let expected: &[(&str, [f64; 3])] = &[
        ("all", [0.005345, 0.000153, -0.005475]),
        ("dress", [0.000577, -0.003887, -0.005155]),
        ("longsleeve", [-0.000187, -0.005266, -0.008899]),
        ("pants", [-0.002745, 0.003385, -0.005107]),
        ("skirt", [0.003477, -0.002045, -0.003576]),
        ("skirt-baseline", [0.003718, -0.003528, -0.003592]),
        ("tshirt", [-0.000426, -0.000809, -0.012205]),
        ("tshirt-baseline", [0.00203, 0.00028, -0.01208]),
        ("tshirt-baseline-seed1", [0.000053, -0.001502, -0.012982]),
        ("tshirt-seed1", [0.001559, -0.003296, -0.01953]),
    ];
    let mut found: Vec<String> = std::fs::read_dir(root().join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
        .collect();
    found.sort();
    assert_eq!(found, expected.iter().map(|(n, _)| n.to_string()).collect::<Vec<_>>());
    // Every checkpoint is checked before failing, so one run lists all the new values.
    let mut moved = Vec::new();
    for (name, want) in expected {
        let dir = root().join("checkpoints").join(name);
        let cfg = training_config(&dir).unwrap_or_else(|e| panic!("{name}: {e}"));
        let scenes: Vec<_> = cfg.scene_files().iter().map(|p| p.canonicalize().unwrap()).collect();
        // The many-garment network trains on the scenes of `configs/all.toml`; every other
        // checkpoint is self-contained.
        let (own, garments) = match *name {
            "all" => (RunConfig::read(root().join("configs/all.toml")).unwrap().scene_files(), ", 5 garments"),
            _ => (vec![dir.join("config.toml")], ""),
        };
        assert_eq!(scenes, own.iter().map(|p| p.canonicalize().unwrap()).collect::<Vec<_>>(), "{name}");
        let method = if name.contains("baseline") { "baseline" } else { "SENC" };
        let seed = if name.ends_with("seed1") { ", seed 1" } else { "" };
        assert_eq!(cfg.method_name(), format!("{method}{garments}{seed}"), "{name}");
        let g = Garment::load(&first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
        let model = Model::load(&dir, &Device::flex()).unwrap();
        let material = scene_material(&g).unwrap();
        let r = rollout(&model, &g, &g.scene.test[0], 3, senc_geom::Vec3::zeros(), &material).unwrap();
        let (x0, x3) = (&r.cloth[0], &r.cloth[3]);
        assert!(x3.iter().all(|v| v.iter().all(|c| c.is_finite())), "{name}: non-finite rollout");
        let mean = x0.iter().zip(x3).map(|(a, b)| b - a).sum::<senc_geom::Vec3>() / x0.len() as f64;
        if (mean - senc_geom::Vec3::from(*want)).norm() >= 1e-3 {
            moved.push(format!("{name}: mean displacement after 3 frames {mean:?}, recorded {want:?}"));
        }
    }
    assert!(moved.is_empty(), "{}", moved.join("\n"));
}

/// A `[scene.material]` table becomes one energy material: HOOD's defaults where it gives
/// nothing, its own numbers where it does, Young's modulus and Poisson's ratio converted.
#[test]
fn material_tables_fill_hoods_defaults_and_convert_young_and_poisson() {
    use senc_energy::Material;
    use senc_scene::config::MaterialConfig;
    use senc_train::trainer::material_from_config;
    assert_eq!(material_from_config(&MaterialConfig::default()).unwrap(), Material::default());
    let ep = material_from_config(&MaterialConfig { young: Some(1000.0), poisson: Some(0.25), ..Default::default() })
        .unwrap();
    assert!((ep.mu - 400.0).abs() < 1e-9 && (ep.lambda - 400.0).abs() < 1e-9);
    assert_eq!(ep.density, Material::default().density);
    let given = MaterialConfig { density: Some(0.3), bending: Some(1e-4), thickness: Some(1e-3), ..Default::default() };
    let m = material_from_config(&given).unwrap();
    assert_eq!((m.density, m.bending_stiffness, m.thickness, m.mu), (0.3, 1e-4, 1e-3, Material::default().mu));
    let mixed = MaterialConfig { young: Some(1000.0), lame_mu: Some(3.0), ..Default::default() };
    assert!(material_from_config(&mixed).is_err());
}

/// The resting-case check on the smoke skirt and a held pose: an untrained network against
/// the solver reports its one-step error from 6 of each rollout's frame pairs (frames 2 to
/// 7 of 8), finite, with the mean offset no larger than the mean distance; a rollout
/// compared with itself is at distance zero.
#[test]
fn against_solver_reports_one_step_errors_on_both_rollouts() {
    use senc_train::garment::Garment;
    use senc_train::resting::{against_solver, compare};
    use senc_train::trainer::scene_material;
    let cfg = senc_train::RunConfig::read(root().join("configs/smoke.toml")).unwrap();
    let g = Garment::load(&senc_train::eval::first_scene(&cfg).unwrap(), cfg.train.body_margin).unwrap();
    let motion = g.scene.resolve_motion(root().join("data/motions/cmu_01_01_held.msgpack").to_str().unwrap()).unwrap();
    let material = scene_material(&g).unwrap();
    let energy = cfg.energy_for(Phase::Two, material, [0.0; 3]);
    let model = Model::new(cfg.model.network.clone(), cfg.model.graph, 5, &Device::flex());
    let (c, network, reference) = against_solver(&model, &g, &motion, 8, &material, &energy, 5).unwrap();
    assert_eq!(c.frames, 8);
    for e in [c.on_solver_states, c.on_network_states] {
        assert_eq!(e.steps, 6, "{c:?}");
        assert!(e.distance_cm.is_finite() && e.distance_cm > 0.0, "{c:?}");
        assert!(e.rise_cm.abs() <= e.distance_cm + 1e-12, "{c:?}");
    }
    let same = compare(&reference, &reference);
    assert_eq!(same.final_distance_cm, 0.0);
    assert!(compare(&network, &reference).max_distance_cm > 0.0);
}

/// A garment a model never saw hangs as its kind does in training: a skirt run in the
/// t-shirt's scene has its waist pinned (the t-shirt scene pins nothing) and every loop
/// closed; a t-shirt run in the skirt's scene pins nothing and leaves its neck open.
#[test]
fn unseen_garments_pin_their_waist_and_leave_the_neck_open() {
    let data = root().join("data/garments");
    let skirt_asset = senc_scene::GarmentAsset::load(data.join("skirt.msgpack")).unwrap();
    let waist: Vec<usize> = {
        let mut v: Vec<usize> = skirt_asset
            .loops
            .iter()
            .find(|l| l.name == "waist")
            .unwrap()
            .vertices
            .iter()
            .map(|&i| i as usize)
            .collect();
        v.sort_unstable();
        v
    };
    let g = senc_train::Garment::load_unseen(&root().join("configs/tshirt.toml"), &data.join("skirt.msgpack"), 0.05)
        .unwrap();
    assert_eq!(g.pinned, waist);
    assert!(g.open_holes.is_empty());
    let g = senc_train::Garment::load_unseen(&root().join("configs/skirt.toml"), &data.join("tshirt.msgpack"), 0.05)
        .unwrap();
    assert!(g.pinned.is_empty());
    assert_eq!(g.open_holes.len(), 1, "only the neck stays open");
}
