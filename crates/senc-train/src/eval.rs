//! Evaluation: the paper's Table-1 metrics on the test motions, and the error against run
//! time of the reference solver and the network.
//!
//! Per test frame (frames 1.. of each rollout): the penetration volume V (m³) of the
//! garment after closing the scene's holes (senc-gia), `L_self-col = 100 · |6V|`, and the
//! share of cloth vertices inside the full body. Speed is graph building plus network
//! only. The error-against-run-time states are frames of the network's own rollout: from
//! each, the reference solver (senc-energy, Newton/PCG, the run's phase-2 energy and the
//! scene's material) runs with several iteration budgets; the "converged" answer uses
//! `[eval] converged_iterations`. Gap = E(answer) − E(converged), J. The same solver started
//! from the network's answer instead (`[eval] refine_budgets`) gives the network's own
//! curve, "network + N it", on the same states.
//!
//! A method with [`Method::refine`] > 0 is rolled out with each frame refined that way
//! (`rollout::network_rollout`), so its Table-1 row measures the hybrid simulator.

use std::path::{Path, PathBuf};
use std::time::Instant;

use senc_energy::{solve, SolverOptions};
use senc_geom::{close_holes, Closure, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace};
use senc_model::burn::tensor::Device;
use senc_model::{BodyState, FrameState, Model};
use senc_scene::BodyQuery;
use serde::Serialize;

use crate::config::RunConfig;
use crate::error::TrainError;
use crate::garment::Garment;
use crate::rollout::{network_rollout, refine_start, Refine, Rollout};
use crate::trainer::{model_material, scene_material, CONFIG_FILE};

/// A checkpoint to evaluate, with the row label and the config whose scene it runs on.
#[derive(Debug, Clone)]
pub struct Method {
    /// Row label.
    pub label: String,
    /// Checkpoint directory.
    pub checkpoint: PathBuf,
    /// Config file (scene, energy, eval settings).
    pub config: PathBuf,
    /// A garment asset that replaces the scene's garment (an unseen garment, fitted to the
    /// body first); `None` runs the scene's own garment.
    pub garment: Option<PathBuf>,
    /// Newton iterations (phase-2 energy) refining each network frame; 0 = the network alone.
    pub refine: usize,
    /// Compute the error-against-run-time points (default true; `xtask eval` turns it off
    /// for a checkpoint's second and later rows, whose curve would repeat the first's).
    pub curve: bool,
}

impl Method {
    /// A method for `checkpoint`; the config defaults to the one the checkpoint was trained
    /// with, the label to the checkpoint's run directory name.
    pub fn new(checkpoint: &Path, config: Option<&Path>) -> Result<Self, TrainError> {
        let config = match config {
            Some(c) => c.to_path_buf(),
            None => {
                let s = checkpoint.join("source.txt");
                let text = std::fs::read_to_string(&s).map_err(|e| TrainError::Checkpoint {
                    path: checkpoint.to_path_buf(),
                    message: format!("no source.txt ({e}); give --config"),
                })?;
                PathBuf::from(text.trim())
            }
        };
        if !checkpoint.join(CONFIG_FILE).exists() && !checkpoint.join(senc_model::checkpoint::META_FILE).exists() {
            return Err(TrainError::Checkpoint { path: checkpoint.to_path_buf(), message: "not a checkpoint".into() });
        }
        let abs = checkpoint.canonicalize().unwrap_or_else(|_| checkpoint.to_path_buf());
        let run = abs.parent().and_then(|p| p.file_name()).map(|n| n.to_string_lossy().to_string());
        let phase = abs.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let label = match run {
            Some(r) => format!("{r}/{phase}"),
            None => phase,
        };
        Ok(Self { label, checkpoint: checkpoint.to_path_buf(), config, garment: None, refine: 0, curve: true })
    }

    /// The reference solver on the config `config`'s scene (no checkpoint; used by
    /// `xtask simulate --solver`).
    pub fn solver(config: &Path) -> Self {
        Self {
            label: "solver".into(),
            checkpoint: PathBuf::new(),
            config: config.to_path_buf(),
            garment: None,
            refine: 0,
            curve: true,
        }
    }

    /// The same method with each network frame refined by at most `iterations` Newton
    /// iterations of the reference solver; the label gains " + N it".
    pub fn with_refine(mut self, iterations: usize) -> Self {
        if iterations > 0 {
            self.label = format!("{} + {iterations} it", self.label);
        }
        self.refine = iterations;
        self
    }

    /// The same method run on another garment asset (see [`Garment::load_unseen`]).
    pub fn with_garment(mut self, asset: &Path) -> Self {
        self.garment = Some(asset.to_path_buf());
        self
    }

    /// The garment this method runs on: the config's first scene, or that scene with
    /// [`Method::garment`] in place of its garment.
    pub fn load_garment(&self, cfg: &RunConfig) -> Result<Garment, TrainError> {
        let scene = first_scene(cfg)?;
        match &self.garment {
            None => Garment::load(&scene, cfg.train.body_margin),
            Some(asset) => Garment::load_unseen(&scene, asset, cfg.train.body_margin),
        }
    }
}

/// Table-1 metrics of one method on one garment.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Method label.
    pub method: String,
    /// Garment name.
    pub garment: String,
    /// Test frames evaluated.
    pub frames: usize,
    /// Mean penetration volume, cm³.
    pub volume_cm3: f64,
    /// Mean `L_self-col = 100 · |6V|` (V in m³).
    pub l_selfcol: f64,
    /// Percentage of frames with `L_self-col > 0.1`.
    pub pct_above_0_1: f64,
    /// Percentage of frames with `L_self-col > 0.01`.
    pub pct_above_0_01: f64,
    /// Mean share of cloth vertices inside the body, %.
    pub body_penetration_pct: f64,
    /// Mean distance of the cloth vertices from the linearly skinned garment, cm, over the
    /// test frames: how far the simulated garment has left the body-following one. A few cm
    /// is cloth dynamics (a skirt swings); tens of cm mean the rollout has drifted off the
    /// body, and its volumes describe no plausible garment.
    pub departure_cm: f64,
    /// Frames per second (graph + network, and the refinement for a refined method).
    pub fps: f64,
    /// Share of frames whose refinement started from the inertial target because the
    /// network's answer had the higher energy, %; 0 without refinement.
    pub rejected_pct: f64,
}

/// One point of the error-against-run-time comparison (averaged over the test states).
#[derive(Debug, Clone, Serialize)]
pub struct CurvePoint {
    /// "solver N it" or the method label.
    pub method: String,
    /// Garment name.
    pub garment: String,
    /// Milliseconds per frame.
    pub ms_per_frame: f64,
    /// Mean energy gap to the converged reference, J.
    pub energy_gap: f64,
    /// The curve this point belongs to: "solver", or the network's label (its refined points
    /// share it).
    pub series: String,
    /// Mean penetration volume of the answers, cm³.
    pub volume_cm3: f64,
}

/// Penetration volumes of garment states.
pub struct VolumeMeter {
    closure: Closure,
    ws: GiaWorkspace,
    options: GiaOptions,
}

impl VolumeMeter {
    /// For the garment's closure (the scene's holes closed).
    pub fn new(g: &Garment) -> Result<Self, TrainError> {
        let closure = close_holes(&g.rest, &g.scene.hole_selection()?)?;
        let ws = GiaWorkspace::new(&closure);
        Ok(Self { closure, ws, options: GiaOptions::default() })
    }

    /// Penetration volume of `x`, m³.
    pub fn volume(&mut self, x: &[Vec3]) -> Result<f64, TrainError> {
        self.closure.update(x)?;
        Ok(self.ws.penetration(&self.closure, &self.options)?.volume)
    }
}

/// Mean Euclidean distance between corresponding points, in the points' unit (0 for none).
fn mean_distance(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len().min(b.len()).max(1) as f64
}

/// The first scene file of a config (its own `[scene]`, else the first of `[train] scenes`).
pub fn first_scene(cfg: &RunConfig) -> Result<PathBuf, TrainError> {
    cfg.scene_files().into_iter().next().ok_or_else(|| TrainError::Config {
        path: cfg.path.clone(),
        message: "no [scene] table and no [train] scenes".into(),
    })
}

/// Evaluates one method: Table-1 row per garment and the network's curve points.
pub fn evaluate(method: &Method) -> Result<(Row, Vec<CurvePoint>), TrainError> {
    let cfg = RunConfig::read(&method.config)?;
    let g = method.load_garment(&cfg)?;
    let model = Model::load(&method.checkpoint, &Device::flex())?;
    let material = scene_material(&g)?;
    let ext = Vec3::from(g.scene.config.external_force.acceleration);
    let mut meter = VolumeMeter::new(&g)?;
    let (mut vols, mut body_pct, mut departure) = (Vec::new(), Vec::new(), Vec::new());
    let (mut secs, mut steps, mut rejected) = (0.0, 0, 0);
    let mut rollouts: Vec<(usize, Rollout)> = Vec::new();
    if g.scene.test.is_empty() {
        return Err(TrainError::Invalid(format!(
            "{}: no test motions in [scene.motions] test",
            method.config.display()
        )));
    }
    for (mi, motion) in g.scene.test.iter().enumerate() {
        let energy = cfg.energy_for(2, material, ext.into());
        let refine = Some(Refine { energy: &energy, iterations: method.refine });
        let r = network_rollout(&model, &g, motion, cfg.eval.frames, ext, &material, refine)?;
        secs += r.infer_seconds;
        steps += r.steps;
        rejected += r.refined.iter().filter(|f| f.rejected).count();
        for (f, x) in r.cloth.iter().enumerate().skip(1) {
            vols.push(meter.volume(x)?);
            let body = g.scene.body_at(motion, f)?;
            let q = BodyQuery::new(&body, &g.scene.body.faces)?;
            body_pct.push(100.0 * q.inside(x).len() as f64 / x.len() as f64);
            let skinned = g.skinned_at(motion, f)?;
            departure.push(mean_distance(x, &skinned));
        }
        rollouts.push((mi, r));
    }
    let n = vols.len().max(1) as f64;
    let ls: Vec<f64> = vols.iter().map(|v| 100.0 * 6.0 * v).collect();
    let row = Row {
        method: method.label.clone(),
        garment: g.name().to_string(),
        frames: vols.len(),
        volume_cm3: vols.iter().sum::<f64>() / n * 1e6,
        l_selfcol: ls.iter().sum::<f64>() / n,
        pct_above_0_1: 100.0 * ls.iter().filter(|&&l| l > 0.1).count() as f64 / n,
        pct_above_0_01: 100.0 * ls.iter().filter(|&&l| l > 0.01).count() as f64 / n,
        body_penetration_pct: body_pct.iter().sum::<f64>() / n,
        departure_cm: departure.iter().sum::<f64>() / n * 100.0,
        fps: if secs > 0.0 { steps as f64 / secs } else { f64::NAN },
        rejected_pct: 100.0 * rejected as f64 / steps.max(1) as f64,
    };
    let curve =
        if method.curve { error_vs_runtime(method, &cfg, &g, &model, &rollouts, &mut meter)? } else { Vec::new() };
    Ok((row, curve))
}

fn error_vs_runtime(
    method: &Method,
    cfg: &RunConfig,
    g: &Garment,
    model: &Model,
    rollouts: &[(usize, Rollout)],
    meter: &mut VolumeMeter,
) -> Result<Vec<CurvePoint>, TrainError> {
    let material = scene_material(g)?;
    let ext = g.scene.config.external_force.acceleration;
    let dt = g.scene.dt();
    let em = g.energy_model(cfg.energy_for(2, material, ext), dt)?;
    let (_, r) = &rollouts[0];
    // States from frame 2 on: frame 1's stored predecessor is the start, whose difference
    // to frame 1 spans the long first step, not a 1/fps velocity.
    if r.steps < 3 {
        return Err(TrainError::Invalid("the error-against-run-time curve needs [eval] frames >= 3".into()));
    }
    let k = cfg.eval.curve_states.max(1).min(r.steps - 2);
    let states: Vec<usize> = (0..k).map(|i| 2 + i * (r.steps - 2) / k).collect();
    let budgets = &cfg.eval.solver_budgets;
    // The network's points: alone (or refined as the method's rollout was), then refined
    // by each of `[eval] refine_budgets` more.
    let mut refine = vec![method.refine];
    refine.extend(cfg.eval.refine_budgets.iter().filter(|&&k| k > method.refine));
    let mut acc = vec![(0.0, 0.0, 0.0); budgets.len() + refine.len()];
    let accel = Vec3::from(g.scene.config.external_force.gravity) + Vec3::from(ext);
    let mat = model_material(&material);
    let stepper = model.stepper();
    for &s in &states {
        let (prev, curr) = (&r.cloth[s - 1], &r.cloth[s]);
        let (bt, bn) = (&r.body[s], &r.body[s + 1]);
        let fe = em.frame(curr, prev, Some((bt, bn)))?;
        let mut x0: Vec<Vec3> = fe.inertial_target().map(|t| t.to_vec()).unwrap_or_else(|| curr.clone());
        g.pin_from(&mut x0, &r.cloth[s + 1]);
        let conv = SolverOptions { max_iterations: cfg.eval.converged_iterations, ..Default::default() };
        let (_, rep) = solve(&fe, &x0, &conv)?;
        let e_star = rep.energy;
        for (i, &b) in budgets.iter().enumerate() {
            let (x, rep) = solve(&fe, &x0, &SolverOptions { max_iterations: b, ..Default::default() })?;
            acc[i].0 += rep.seconds * 1e3;
            acc[i].1 += rep.energy - e_star;
            acc[i].2 += meter.volume(&x)? * 1e6;
        }
        let t0 = Instant::now();
        let frame = FrameState {
            rest: &g.rest,
            prev,
            curr,
            material: mat,
            accel,
            dt,
            body: Some(BodyState { faces: g.body_faces(), curr: bt, next: bn }),
            pinned: &g.pinned,
        };
        let mut x = stepper.step(&frame)?;
        g.pin_from(&mut x, &r.cloth[s + 1]);
        let net_ms = t0.elapsed().as_secs_f64() * 1e3;
        // Refined as in `network_rollout`: from the better of the network's answer and the
        // inertial target (the comparison is timed with the refinement).
        let t1 = Instant::now();
        let (e_net, _, rejected) = refine_start(&fe, &x, &x0)?;
        let pick_ms = t1.elapsed().as_secs_f64() * 1e3;
        for (j, &k) in refine.iter().enumerate() {
            let (answer, e, ms) = if k == 0 {
                (x.clone(), e_net, net_ms)
            } else {
                let start = if rejected { &x0 } else { &x };
                let (answer, rep) = solve(&fe, start, &SolverOptions { max_iterations: k, ..Default::default() })?;
                (answer, rep.energy, net_ms + pick_ms + rep.seconds * 1e3)
            };
            let a = &mut acc[budgets.len() + j];
            a.0 += ms;
            a.1 += e - e_star;
            a.2 += meter.volume(&answer)? * 1e6;
        }
    }
    let n = states.len() as f64;
    let base = method.label.strip_suffix(&format!(" + {} it", method.refine)).unwrap_or(&method.label);
    let names =
        budgets.iter().map(|b| (format!("solver {b} it"), "solver".to_string())).chain(refine.iter().map(|&k| {
            let name = if k == 0 { base.to_string() } else { format!("{base} + {k} it") };
            (name, base.to_string())
        }));
    let out = names
        .zip(&acc)
        .map(|((method, series), a)| CurvePoint {
            method,
            garment: g.name().to_string(),
            ms_per_frame: a.0 / n,
            energy_gap: a.1 / n,
            series,
            volume_cm3: a.2 / n,
        })
        .collect();
    Ok(out)
}

/// Writes `table1.md`, `table1.csv`, `table1.json`, `runtime.md`, `runtime.csv` and
/// `runtime.svg` into `out`. `command` is recorded in the Markdown files.
pub fn write_reports(out: &Path, rows: &[Row], curve: &[CurvePoint], command: &str) -> Result<(), TrainError> {
    std::fs::create_dir_all(out).map_err(|e| TrainError::io(out, e))?;
    let w = |name: &str, text: String| -> Result<(), TrainError> {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| TrainError::io(&p, e))
    };
    let mut md = format!(
        "# Table 1: self-collision on the test motions\n\nProduced by `{command}`.\n\n\
         | method | garment | frames | V (cm³) | L_self-col (×10⁻³) | % > 0.1 | % > 0.01 | body pen. (%) | from skinned (cm) | FPS |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    let mut csv = String::from(
        "method,garment,frames,volume_cm3,l_selfcol,pct_above_0_1,pct_above_0_01,body_penetration_pct,departure_cm,fps,\
         rejected_pct\n",
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {} | {:.3} | {:.3} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} |\n",
            r.method,
            r.garment,
            r.frames,
            r.volume_cm3,
            r.l_selfcol * 1e3,
            r.pct_above_0_1,
            r.pct_above_0_01,
            r.body_penetration_pct,
            r.departure_cm,
            r.fps
        );
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{}\n",
            r.method,
            r.garment,
            r.frames,
            r.volume_cm3,
            r.l_selfcol,
            r.pct_above_0_1,
            r.pct_above_0_01,
            r.body_penetration_pct,
            r.departure_cm,
            r.fps,
            r.rejected_pct
        );
    }
    w("table1.md", md)?;
    w("table1.csv", csv)?;
    w("table1.json", serde_json::to_string_pretty(rows).map_err(|e| TrainError::io(out.join("table1.json"), e))?)?;
    let mut md = format!(
        "# Error against run time\n\nProduced by `{command}`. Energy gap = E(answer) − E(reference solver, converged), J, \
         averaged over test states of the network's rollout. \
         \"network + N it\": N Newton iterations of the same solver started from the network's answer.\n\n\
         | method | garment | ms/frame | energy gap (J) | V (cm³) |\n|---|---|---:|---:|---:|\n"
    );
    let mut csv = String::from("method,series,garment,ms_per_frame,energy_gap,volume_cm3\n");
    for p in curve {
        md += &format!(
            "| {} | {} | {:.2} | {:.4e} | {:.3} |\n",
            p.method, p.garment, p.ms_per_frame, p.energy_gap, p.volume_cm3
        );
        csv +=
            &format!("{},{},{},{},{},{}\n", p.method, p.series, p.garment, p.ms_per_frame, p.energy_gap, p.volume_cm3);
    }
    md += "\n![error against run time](runtime.svg)\n";
    w("runtime.md", md)?;
    w("runtime.csv", csv)?;
    w("runtime.svg", svg_plot(curve))
}

/// A log-log scatter plot (ms per frame against energy gap) as SVG text: solver budgets as
/// a line per garment, networks as labelled dots.
pub fn svg_plot(curve: &[CurvePoint]) -> String {
    let (w, h, m) = (640.0, 420.0, 60.0);
    let pts: Vec<(f64, f64)> =
        curve.iter().map(|p| (p.ms_per_frame.max(1e-3).log10(), p.energy_gap.abs().max(1e-9).log10())).collect();
    let (x0, x1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let (x0, x1) = (x0.floor(), x1.ceil().max(x0.floor() + 1.0));
    let (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let sx = |x: f64| m + (x - x0) / (x1 - x0) * (w - 2.0 * m);
    let sy = |y: f64| h - m - (y - y0) / (y1 - y0) * (h - 2.0 * m);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <line x1=\"{m}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>\n<line x1=\"{m}\" y1=\"{m}\" x2=\"{m}\" y2=\"{}\" stroke=\"black\"/>\n\
         <text x=\"{}\" y=\"{}\" text-anchor=\"middle\">milliseconds per frame (log)</text>\n\
         <text x=\"14\" y=\"{}\" transform=\"rotate(-90 14 {})\" text-anchor=\"middle\">|energy gap| J (log)</text>\n",
        h - m, w - m, h - m, h - m, w / 2.0, h - 15.0, h / 2.0, h / 2.0
    );
    for e in x0 as i32..=x1 as i32 {
        s += &format!("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">1e{e}</text>\n", sx(e as f64), h - m + 15.0);
    }
    for e in y0 as i32..=y1 as i32 {
        s += &format!("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{e}</text>\n", m - 5.0, sy(e as f64) + 4.0);
    }
    // One line per (series, garment): the solver's budgets, and each network with its
    // refined points.
    let mut series: Vec<(&str, &str)> = Vec::new();
    for p in curve {
        if !series.contains(&(p.series.as_str(), p.garment.as_str())) {
            series.push((p.series.as_str(), p.garment.as_str()));
        }
    }
    for (name, gname) in &series {
        let line: Vec<String> = (0..curve.len())
            .filter(|&i| curve[i].series == *name && curve[i].garment == *gname)
            .map(|i| format!("{:.1},{:.1}", sx(pts[i].0), sy(pts[i].1)))
            .collect();
        if line.len() > 1 {
            let color = if *name == "solver" { "steelblue" } else { "crimson" };
            s += &format!(
                "<polyline points=\"{}\" fill=\"none\" stroke=\"{color}\" stroke-width=\"{}\"/>\n",
                line.join(" "),
                if *name == "solver" { 2 } else { 1 }
            );
        }
    }
    for (i, p) in curve.iter().enumerate() {
        let net = p.series != "solver";
        let color = if net { "crimson" } else { "steelblue" };
        s += &format!("<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"{color}\"/>\n", sx(pts[i].0), sy(pts[i].1));
        // A network's refined points are labelled by their iterations only.
        let label = match p.method.strip_prefix(p.series.as_str()) {
            Some(rest) if net && !rest.is_empty() => rest.trim_start().to_string(),
            _ if net => format!("{} ({})", p.method, p.garment),
            _ => p.method.clone(),
        };
        s += &format!(
            "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"{color}\">{}</text>\n",
            sx(pts[i].0) + 6.0,
            sy(pts[i].1) - 6.0,
            label.replace('&', "&amp;").replace('<', "&lt;")
        );
    }
    s + "</svg>\n"
}

/// One predictor's mean energy above the converged reference over the probe states.
#[derive(Debug, Clone, Serialize)]
pub struct ProbeRow {
    /// "free flight", "skinned", "solver N it" or "network".
    pub predictor: String,
    /// Mean `E(x) − E(x*)`, J.
    pub gap: f64,
    /// Mean energy per term, J.
    pub terms: Vec<(String, f64)>,
}

/// One-step probe on the training distribution: from `states` skinned states `(x[t−1],
/// x[t])` of the config's training motions (relaxed as training starts are when `[train]
/// relax_start_iterations` > 0; the scene's material, gravity, no random
/// force), the energy of the next frame predicted by free flight `2x[t] − x[t−1] + Δt² g`,
/// by the skinned garment, by the network of `checkpoint` (if given) and by the reference
/// solver at `budgets`, each as a gap above the converged solve (`converged` iterations).
///
/// A network that has learned anything beats free flight here; the converged solver's
/// terms say which energies a good step still pays. Phase-1 energy (no self-collision).
pub fn one_step_probe(
    config: &Path,
    checkpoint: Option<&Path>,
    states: usize,
    budgets: &[usize],
    converged: usize,
) -> Result<(Vec<ProbeRow>, ProbeRow), TrainError> {
    let cfg = RunConfig::read(config)?;
    let g = Garment::load(&first_scene(&cfg)?, cfg.train.body_margin)?;
    let model = checkpoint.map(|c| Model::load(c, &Device::flex())).transpose()?.map(|m| m.stepper());
    let material = scene_material(&g)?;
    let ext = g.scene.config.external_force.acceleration;
    let dt = g.scene.dt();
    let em = g.energy_model(cfg.energy_for(1, material, ext), dt)?;
    let accel = Vec3::from(g.scene.config.external_force.gravity) + Vec3::from(ext);
    let mat = model_material(&material);
    let mut names: Vec<String> = vec!["free flight".into(), "skinned".into()];
    names.extend(budgets.iter().map(|b| format!("solver {b} it")));
    if model.is_some() {
        names.push("network".into());
    }
    let mut rows: Vec<ProbeRow> =
        names.into_iter().map(|predictor| ProbeRow { predictor, gap: 0.0, terms: Vec::new() }).collect();
    let mut reference =
        ProbeRow { predictor: format!("solver {converged} it (reference)"), gap: 0.0, terms: Vec::new() };
    let add = |row: &mut ProbeRow, b: &senc_energy::Breakdown, e_star: f64| {
        row.gap += b.total - e_star;
        for (k, (name, v)) in b.terms.iter().enumerate() {
            match row.terms.get_mut(k) {
                Some(t) => t.1 += v,
                None => row.terms.push((name.to_string(), *v)),
            }
        }
    };
    let motions: Vec<_> = g.scene.train.iter().filter(|m| m.n_frames() >= 4).collect();
    if motions.is_empty() {
        return Err(TrainError::Invalid(format!("garment {}: no training motion has 4 frames", g.name())));
    }
    let k = states.max(1);
    for i in 0..k {
        let motion = motions[i % motions.len()];
        let f = 1 + (i / motions.len() * 7919 + 13 * i) % (motion.n_frames() - 2);
        let (mut prev, mut curr, skinned) =
            (g.skinned_at(motion, f - 1)?, g.skinned_at(motion, f)?, g.skinned_at(motion, f + 1)?);
        let (bt, bn) = (g.body_at(motion, f)?, g.body_at(motion, f + 1)?);
        if cfg.train.relax_start_iterations > 0 {
            g.relax_start(&em, &mut prev, &mut curr, &bt, cfg.train.relax_start_iterations)?;
        }
        let fe = em.frame(&curr, &prev, Some((&bt, &bn)))?;
        let mut flight: Vec<Vec3> = curr.iter().zip(&prev).map(|(c, p)| c * 2.0 - p + accel * dt * dt).collect();
        g.pin_from(&mut flight, &skinned);
        let (x_star, _) = solve(&fe, &flight, &SolverOptions { max_iterations: converged, ..Default::default() })?;
        let b_star = fe.evaluate(&x_star, None)?;
        add(&mut reference, &b_star, 0.0);
        let mut answers = vec![flight.clone(), skinned];
        for &b in budgets {
            answers.push(solve(&fe, &flight, &SolverOptions { max_iterations: b, ..Default::default() })?.0);
        }
        if let Some(m) = &model {
            let frame = FrameState {
                rest: &g.rest,
                prev: &prev,
                curr: &curr,
                material: mat,
                accel,
                dt,
                body: Some(BodyState { faces: g.body_faces(), curr: &bt, next: &bn }),
                pinned: &g.pinned,
            };
            let mut x = m.step(&frame)?;
            g.pin_from(&mut x, &answers[1]);
            answers.push(x);
        }
        for (row, x) in rows.iter_mut().zip(&answers) {
            add(row, &fe.evaluate(x, None)?, b_star.total);
        }
    }
    let n = k as f64;
    for r in rows.iter_mut().chain(std::iter::once(&mut reference)) {
        r.gap /= n;
        r.terms.iter_mut().for_each(|t| t.1 /= n);
    }
    Ok((rows, reference))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_distance_averages_point_offsets() {
        let a = [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)];
        let b = [Vec3::new(0.0, 3.0, 4.0), Vec3::new(1.0, 0.0, 1.0)];
        assert!((mean_distance(&a, &b) - 3.0).abs() < 1e-12);
        assert_eq!(mean_distance(&[], &[]), 0.0);
    }
}
