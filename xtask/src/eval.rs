//! `cargo xtask eval --checkpoint DIR [--compare DIR ...] [--config C.toml ...] [--garment G]
//! [--refine N,...] [--out reports]`: Table 1 (penetration volume, L_self-col, % frames above thresholds,
//! body penetration, FPS) and the error against run time (reference solver budgets against
//! each network).
//!
//! With several `--config` files, each checkpoint is evaluated with the one whose garment is
//! the garment it was trained on, so one table holds t-shirt and skirt rows. `--garment`
//! swaps in a garment the models never saw (an OBJ is fitted to the body first).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use senc_train::eval::{evaluate, first_scene, one_step_probe, write_reports, Method};
use senc_train::RunConfig;

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

/// A garment asset for `--garment`: a `.msgpack` asset as is, an OBJ fitted to the body of
/// `config`'s scene first (written to the system's temporary directory).
pub fn prepare_garment(garment: &Path, config: &Path) -> Result<PathBuf> {
    match garment.extension().and_then(|e| e.to_str()) {
        Some("msgpack") => Ok(garment.to_path_buf()),
        Some("obj") => {
            let cfg = RunConfig::read(config)?;
            let scene = senc_scene::SceneConfig::read(first_scene(&cfg)?)?;
            let body = senc_scene::BodyAsset::load(&scene.body)?;
            let data = senc_geom::obj::ObjData::read(garment)?;
            let name = garment.file_stem().and_then(|s| s.to_str()).unwrap_or("garment").to_string();
            let (asset, rep) = crate::fit::fit(&name, data.positions, data.faces, &body, None, true, 5e-3)
                .with_context(|| format!("fitting {} to the body", garment.display()))?;
            let out = std::env::temp_dir().join(format!("senc-fitted-{name}.msgpack"));
            senc_scene::assets::write_msgpack(&out, &asset)?;
            eprintln!("fitted {}", crate::fit::describe(&asset, &rep));
            Ok(out)
        }
        _ => {
            bail!("--garment {}: give an OBJ (fitted to the body first) or a fitted .msgpack asset", garment.display())
        }
    }
}

/// Evaluates every checkpoint and writes the reports.
pub fn run(
    checkpoint: &Path,
    compare: &[PathBuf],
    configs: &[PathBuf],
    garment: Option<&Path>,
    refine: &[usize],
    out: &Path,
) -> Result<()> {
    let mut rows = Vec::new();
    let mut curve = Vec::new();
    let refine = if refine.is_empty() { &[0][..] } else { refine };
    let mut curve_done = std::collections::HashSet::new();
    let mut fitted: std::collections::HashMap<PathBuf, PathBuf> = std::collections::HashMap::new();
    let checkpoints = std::iter::once(checkpoint).chain(compare.iter().map(|p| p.as_path()));
    for (ck, &iterations) in checkpoints.flat_map(|c| refine.iter().map(move |r| (c, r))) {
        let config = pick_config(ck, configs)?;
        let mut m = Method::new(ck, config.as_deref())?.with_refine(iterations);
        // A checkpoint's curve once: from its first row (with `--refine 0,2`, the network
        // alone, whose points include the refined answers on the same states).
        m.curve = curve_done.insert(ck.to_path_buf());
        if let Some(g) = garment {
            // Fitted once per config, not once per `--refine` row.
            let asset = match fitted.get(&m.config) {
                Some(a) => a,
                None => fitted.entry(m.config.clone()).or_insert(prepare_garment(g, &m.config)?),
            };
            m = m.with_garment(asset);
        }
        eprintln!("evaluating {} on {}", m.label, m.config.display());
        let (row, c) = evaluate(&m).with_context(|| format!("evaluating {}", ck.display()))?;
        println!(
            "{} {}: V {:.3} cm³, L_self-col {:.3e}, >0.1 {:.1}%, >0.01 {:.1}%, body {:.2}%, from skinned {:.1} cm, {:.1} FPS",
            row.method,
            row.garment,
            row.volume_cm3,
            row.l_selfcol,
            row.pct_above_0_1,
            row.pct_above_0_01,
            row.body_penetration_pct,
            row.departure_cm,
            row.fps
        );
        if m.refine > 0 {
            println!(
                "  network answer rejected (refined from the inertial target) in {:.1}% of frames",
                row.rejected_pct
            );
        }
        rows.push(row);
        // Solver points are per garment; keep them once per garment.
        for p in c {
            if p.series == "solver"
                && curve.iter().any(|q: &senc_train::eval::CurvePoint| q.method == p.method && q.garment == p.garment)
            {
                continue;
            }
            curve.push(p);
        }
    }
    let command = std::env::args().skip(1).collect::<Vec<_>>().join(" ");
    write_reports(out, &rows, &curve, &format!("cargo xtask {command}"))?;
    println!("wrote {}/table1.md (+ .csv, .json) and runtime.md (+ .csv, .svg)", out.display());
    Ok(())
}

/// `cargo xtask probe`: prints the one-step gaps as a Markdown table.
pub fn probe(
    config: &Path,
    checkpoint: Option<&Path>,
    states: usize,
    budgets: &[usize],
    converged: usize,
) -> Result<()> {
    let (rows, reference) = one_step_probe(config, checkpoint, states, budgets, converged)?;
    let names: Vec<&str> = reference.terms.iter().map(|(n, _)| n.as_str()).collect();
    println!("| predictor | gap (J) | {} |", names.join(" | "));
    println!("|---|---:|{}", "---:|".repeat(names.len()));
    for r in rows.iter().chain(std::iter::once(&reference)) {
        let t: Vec<String> = r.terms.iter().map(|(_, v)| format!("{v:.3e}")).collect();
        println!("| {} | {:.3e} | {} |", r.predictor, r.gap, t.join(" | "));
    }
    Ok(())
}
