//! `cargo xtask eval --checkpoint DIR [--compare DIR ...] [--config C.toml ...] [--garment G ...]
//! [--refine N,...] [--out reports]`: Table 1 (penetration volume, L_self-col, % frames above
//! thresholds, body penetration, distance from and rise above the skinned garment, FPS), with
//! the reference solver as a row per garment, and the error against run time (reference
//! solver budgets against each network). `cargo xtask probe`: the one-step probe.
//!
//! With several `--config` files, each checkpoint is evaluated with the one whose garment is
//! the garment it was trained on, so one table holds t-shirt and skirt rows. `--garment`
//! swaps in garments the models never saw (the paper's Table 3), one row each: an OBJ is
//! fitted to the body first (`X.obj#NAME`, `#largest` and `#each` select components as
//! `fit` does).

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use senc_scene::fit::{describe, fit_obj, FitOptions, Select};
use senc_train::eval::{
    evaluate, evaluate_solver, first_scene, one_step_probe, write_reports, CurvePoint, MarkdownTable, Method, Row,
    Series, RISE_FRAME,
};
use senc_train::RunConfig;

/// Arguments of `cargo xtask eval`.
#[derive(clap::Args)]
pub struct Args {
    /// Checkpoint directory (e.g. runs/tshirt/phase2).
    #[arg(long)]
    pub checkpoint: PathBuf,
    /// More checkpoints, one row each.
    #[arg(long, num_args = 1..)]
    pub compare: Vec<PathBuf>,
    /// Config whose scene, energy and [eval] settings to use (default: each checkpoint's own).
    /// Several: each checkpoint uses the one with its training garment (t-shirt and skirt
    /// rows in one table).
    #[arg(long, num_args = 1..)]
    pub config: Vec<PathBuf>,
    /// Garments the models never saw, one row each: OBJs in metres (fitted to the body
    /// first, as `cargo xtask fit` does, with its `X.obj#WHICH` forms) or fitted .msgpack
    /// assets. Every loop but `neck` is closed, and a loop named `waist` is pinned.
    #[arg(long, num_args = 1..)]
    pub garment: Vec<PathBuf>,
    /// Leave out the reference solver's rows. They depend only on the garment, motion and
    /// config, not on the networks, and on garments of t-shirt size they cost minutes per
    /// motion; leave them out when another report already has them.
    #[arg(long)]
    pub no_solver: bool,
    /// Also roll each checkpoint out with every frame refined by N Newton iterations of
    /// the reference solver (phase-2 energy), one row per value: `--refine 0,2` gives the
    /// network alone and refined by 2. Default 0.
    #[arg(long, value_delimiter = ',')]
    pub refine: Vec<usize>,
    /// Output directory for table1.md/.csv/.json and runtime.md/.csv/.svg.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
}

/// Arguments of `cargo xtask probe`.
#[derive(clap::Args)]
pub struct ProbeArgs {
    /// Run config (its first scene and training motions).
    #[arg(long)]
    pub config: PathBuf,
    /// Checkpoint whose network is probed (none: only the classical predictors).
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// States sampled from the training motions.
    #[arg(long, default_value_t = 8)]
    pub states: usize,
    /// Solver iteration budgets to compare.
    #[arg(long, value_delimiter = ',', default_value = "1,4")]
    pub budgets: Vec<usize>,
    /// Iterations of the converged reference.
    #[arg(long, default_value_t = 50)]
    pub converged: usize,
}

/// The garment asset a config's first scene uses (canonical path, for matching).
fn scene_garment(config: &Path) -> Result<PathBuf> {
    let cfg = RunConfig::read(config)?;
    let scene = senc_scene::SceneConfig::read(first_scene(&cfg)?)?;
    Ok(scene.garment.canonicalize().unwrap_or(scene.garment))
}

/// The config to evaluate `checkpoint` with: the only one given, or the one whose garment
/// matches the checkpoint's training garment.
fn pick_config(checkpoint: &Path, configs: &[PathBuf]) -> Result<Option<PathBuf>> {
    match configs {
        [] => Ok(None),
        [one] => Ok(Some(one.clone())),
        many => {
            let own = Method::new(checkpoint, None)?;
            let g = scene_garment(&own.config)?;
            for c in many {
                if scene_garment(c)? == g {
                    return Ok(Some(c.clone()));
                }
            }
            bail!(
                "{} was trained on {}, and none of the --config files uses that garment",
                checkpoint.display(),
                g.display()
            )
        }
    }
}

/// The garment assets of one `--garment` argument: a `.msgpack` asset as is, or an OBJ
/// (`X.obj#WHICH` as in `fit`) fitted to the body of `config`'s scene first (written to the
/// system's temporary directory); `#each` gives one asset per component.
pub fn prepare_garments(garment: &Path, config: &Path) -> Result<Vec<PathBuf>> {
    let (file, select) = Select::from_arg(garment);
    match file.extension().and_then(|e| e.to_str()) {
        Some("msgpack") => Ok(vec![file]),
        Some("obj") => {
            let cfg = RunConfig::read(config)?;
            let scene = senc_scene::SceneConfig::read(first_scene(&cfg)?)?;
            let body = senc_scene::BodyAsset::load(&scene.body)?;
            let fitted = fit_obj(&file, &select, 1.0, &body, &FitOptions::default())
                .with_context(|| format!("fitting {} to the body", garment.display()))?;
            // Named by the file too, so that two files with the same stem do not collide.
            let tag = {
                use std::hash::{Hash, Hasher};
                let mut h = std::collections::hash_map::DefaultHasher::new();
                file.canonicalize().unwrap_or_else(|_| file.clone()).hash(&mut h);
                h.finish()
            };
            fitted
                .iter()
                .map(|(asset, rep)| {
                    let out = std::env::temp_dir().join(format!("senc-fitted-{}-{tag:016x}.msgpack", asset.name));
                    senc_scene::assets::write_msgpack(&out, asset)?;
                    eprintln!("fitted {}", describe(asset, rep));
                    Ok(out)
                })
                .collect()
        }
        _ => {
            bail!("--garment {}: give an OBJ (fitted to the body first) or a fitted .msgpack asset", garment.display())
        }
    }
}

fn print_row(row: &Row) {
    let rise = row.rise_30_cm.map_or("–".to_string(), |r| format!("{r:.1} cm"));
    println!(
        "{} {} {}: V {:.3} cm³, L_self-col {:.3e}, >0.1 {:.1}%, >0.01 {:.1}%, body {:.2}%, from skinned {:.1} cm, \
         rise after {RISE_FRAME} frames {rise}, area growth {:.1}%, strain {:.1}%, {:.1} FPS",
        row.method,
        row.garment,
        row.motion,
        row.volume_cm3,
        row.l_selfcol,
        row.pct_above_0_1,
        row.pct_above_0_01,
        row.body_penetration_pct,
        row.departure_cm,
        row.area_growth_pct,
        row.strain_pct,
        row.fps
    );
}

/// Evaluates every checkpoint, adds the reference solver's row per garment (unless
/// `--no-solver`), and writes the reports.
pub fn run(args: Args) -> Result<()> {
    let mut rows = Vec::new();
    let mut curve: Vec<CurvePoint> = Vec::new();
    let refine = if args.refine.is_empty() { vec![0] } else { args.refine.clone() };
    let mut curve_done = HashSet::new();
    let mut fitted: HashMap<(PathBuf, PathBuf), Vec<PathBuf>> = HashMap::new();
    // The solver's row once per (config, garment), after the networks on it.
    let mut solver_for: Vec<Method> = Vec::new();
    let checkpoints = std::iter::once(&args.checkpoint).chain(&args.compare);
    for (ck, &iterations) in checkpoints.flat_map(|c| refine.iter().map(move |r| (c, r))) {
        let config = pick_config(ck, &args.config)?;
        let base = Method::new(ck, config.as_deref())?.with_refine(iterations);
        // The scene's own garment, or every `--garment` asset, each fitted once per config.
        let mut assets: Vec<Option<PathBuf>> = Vec::new();
        for g in &args.garment {
            let key = (g.clone(), base.config.clone());
            if !fitted.contains_key(&key) {
                fitted.insert(key.clone(), prepare_garments(g, &base.config)?);
            }
            assets.extend(fitted[&key].iter().cloned().map(Some));
        }
        if assets.is_empty() {
            assets.push(None);
        }
        for asset in assets {
            let mut m = base.clone();
            if let Some(a) = &asset {
                m = m.with_garment(a);
            }
            // A checkpoint's curve once per garment: from its first row (with `--refine 0,2`,
            // the network alone, whose points include the refined answers on the same states).
            m.curve = curve_done.insert((ck.to_path_buf(), asset));
            eprintln!("evaluating {} on {}", m.label, m.config.display());
            let (method_rows, c) = evaluate(&m).with_context(|| format!("evaluating {}", ck.display()))?;
            for row in &method_rows {
                print_row(row);
                if m.refine() > 0 {
                    println!(
                        "  network answer rejected (refined from the inertial target) in {:.1}% of frames",
                        row.rejected_pct
                    );
                }
            }
            if !args.no_solver && !solver_for.iter().any(|s| s.config == m.config && s.garment == m.garment) {
                solver_for.push(m.clone());
            }
            rows.extend(method_rows);
            // Solver points are per garment; keep them once per garment.
            for p in c {
                if p.series == Series::Solver && curve.iter().any(|q| q.method == p.method && q.garment == p.garment) {
                    continue;
                }
                curve.push(p);
            }
        }
    }
    for m in &solver_for {
        eprintln!("evaluating the reference solver on {}", m.config.display());
        let solver_rows =
            evaluate_solver(m).with_context(|| format!("the reference solver on {}", m.config.display()))?;
        solver_rows.iter().for_each(print_row);
        rows.extend(solver_rows);
    }
    let command = std::env::args().skip(1).collect::<Vec<_>>().join(" ");
    write_reports(&args.out, &rows, &curve, &format!("cargo xtask {command}"))?;
    println!("wrote {}/table1.md (+ .csv, .json) and runtime.md (+ .csv, .svg)", args.out.display());
    Ok(())
}

/// `cargo xtask probe`: prints the one-step gaps as a Markdown table.
pub fn probe(args: ProbeArgs) -> Result<()> {
    let (rows, reference) =
        one_step_probe(&args.config, args.checkpoint.as_deref(), args.states, &args.budgets, args.converged)?;
    let mut headers = vec!["predictor".to_string(), "gap (J)".to_string()];
    headers.extend(reference.terms.iter().map(|(n, _)| n.clone()));
    let mut t = MarkdownTable::new(&headers, 1);
    for r in rows.iter().chain(std::iter::once(&reference)) {
        let mut cells = vec![r.predictor.clone(), format!("{:.3e}", r.gap)];
        cells.extend(r.terms.iter().map(|(_, v)| format!("{v:.3e}")));
        t.push(cells);
    }
    print!("{}", t.render());
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;

    use super::*;

    fn root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// Two copies of the CI skirt in one OBJ, one moved 1 m aside: `#each` fits both, a
    /// name picks its group, an unknown extension is refused with the forms to use.
    #[test]
    fn garment_arguments_fit_each_named_or_every_component() {
        let skirt = senc_scene::GarmentAsset::load(root().join("data/garments/skirt_coarse.msgpack")).unwrap();
        let mut text = String::new();
        for shift in [0.0, 1.0] {
            for p in &skirt.positions {
                let _ = writeln!(text, "v {} {} {}", p.x + shift, p.y, p.z);
            }
        }
        let n = skirt.positions.len() as u32;
        for (k, name) in ["first", "second"].iter().enumerate() {
            let _ = writeln!(text, "o {name}");
            for f in &skirt.faces {
                let o = 1 + k as u32 * n;
                let _ = writeln!(text, "f {} {} {}", f[0] + o, f[1] + o, f[2] + o);
            }
        }
        let dir = std::env::temp_dir().join(format!("senc-eval-garments-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("two.obj");
        std::fs::write(&obj, text).unwrap();
        let config = root().join("configs/smoke.toml");
        let each = prepare_garments(&PathBuf::from(format!("{}#each", obj.display())), &config).unwrap();
        assert_eq!(each.len(), 2);
        assert_ne!(each[0], each[1], "each garment has its own asset file");
        let named = prepare_garments(&PathBuf::from(format!("{}#second", obj.display())), &config).unwrap();
        assert_eq!(named.len(), 1);
        let fitted = senc_scene::GarmentAsset::load(&named[0]).unwrap();
        assert_eq!(fitted.faces.len(), skirt.faces.len());
        let err = prepare_garments(&dir.join("two.txt"), &config).unwrap_err().to_string();
        assert!(err.contains("give an OBJ"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
