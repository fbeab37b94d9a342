//! `cargo xtask train --config C.toml [--out DIR] [--resume] [--stop-after N]`: both
//! training phases with a progress bar, tracing logs and a CSV of losses.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use senc_train::Trainer;

/// Trains (or resumes) and prints where the checkpoints are.
pub fn run(config: &Path, out: &Path, resume: bool, stop_after: Option<u64>) -> Result<()> {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
    let mut trainer = if resume {
        Trainer::resume(out).with_context(|| format!("resuming from {}", out.display()))?
    } else {
        Trainer::new(config, out).with_context(|| format!("starting {}", config.display()))?
    };
    let t = &trainer.config.train;
    let total = t.warmup_iterations + t.phase1_iterations + t.phase2_iterations;
    let p = &trainer.progress;
    let done = p.warmup_done + if p.phase == 2 { t.phase1_iterations } else { 0 } + p.iteration;
    let bar = ProgressBar::new(total).with_position(done);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {per_sec} eta {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    trainer.run(stop_after, |r| {
        bar.inc(1);
        let phase = if r.phase == 0 { "warm-up".to_string() } else { format!("phase {}", r.phase) };
        let terms: Vec<String> = r.terms.iter().map(|(n, v)| format!("{n} {v:.3e}")).collect();
        bar.set_message(format!(
            "{phase} it {}/{} loss {:.4e} [{}] |g| {:.2e} skipped {}",
            r.iteration,
            r.phase_iterations,
            r.loss,
            terms.join(", "),
            r.grad_norm,
            r.skipped_total
        ));
    })?;
    bar.finish();
    let p = &trainer.progress;
    println!(
        "{} in {:.1} s; skipped steps: phase 1 {}, phase 2 {}; checkpoints in {} (phase1/, phase2/, latest/), losses in {}",
        if p.finished { "training finished" } else { "training stopped" },
        start.elapsed().as_secs_f64(),
        p.skipped[0],
        p.skipped[1],
        out.display(),
        out.join(senc_train::trainer::CSV_FILE).display()
    );
    Ok(())
}
