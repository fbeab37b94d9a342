//! `cargo xtask eval --checkpoint DIR [--compare DIR ...] [--config C.toml] [--out reports]`:
//! Table 1 (penetration volume, L_self-col, % frames above thresholds, body penetration,
//! FPS) and the error against run time (reference solver budgets against each network).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use senc_train::eval::{evaluate, write_reports, Method};

/// Evaluates every checkpoint and writes the reports.
pub fn run(checkpoint: &Path, compare: &[PathBuf], config: Option<&Path>, out: &Path) -> Result<()> {
    let mut rows = Vec::new();
    let mut curve = Vec::new();
    for ck in std::iter::once(checkpoint).chain(compare.iter().map(|p| p.as_path())) {
        let m = Method::new(ck, config)?;
        eprintln!("evaluating {} on {}", m.label, m.config.display());
        let (row, c) = evaluate(&m).with_context(|| format!("evaluating {}", ck.display()))?;
        println!(
            "{} {}: V {:.3} cm³, L_self-col {:.3e}, >0.1 {:.1}%, >0.01 {:.1}%, body {:.2}%, {:.1} FPS",
            row.method,
            row.garment,
            row.volume_cm3,
            row.l_selfcol,
            row.pct_above_0_1,
            row.pct_above_0_01,
            row.body_penetration_pct,
            row.fps
        );
        rows.push(row);
        // Solver points are per garment; keep them once per garment.
        for p in c {
            if p.method.starts_with("solver ")
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
