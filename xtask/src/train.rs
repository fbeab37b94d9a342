//! `cargo xtask train --config C.toml [--seed N] [--set key=value ...] [--out DIR] [--resume]
//! [--stop-after N]`: both training phases with a progress bar, tracing logs and a CSV of
//! losses.
//!
//! The config is resolved first (its `extends` chain merged, `--seed` and each `--set`
//! applied, every key checked) and written to `OUT/config.toml`, with its paths rewritten
//! relative to `OUT`; the run trains from that file, so each checkpoint holds the exact
//! config it was trained with.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use senc_train::config::PATH_KEYS;
use senc_train::{Phase, RunConfig, Trainer};

/// Arguments of `cargo xtask train`.
#[derive(clap::Args)]
pub struct Args {
    /// Config (TOML with [scene] and optional [train], [model], [energy], [eval]; it may
    /// `extends = "other.toml"`).
    #[arg(long, default_value = "configs/tshirt.toml")]
    pub config: PathBuf,
    /// Seed of every random choice (replaces `[train] seed`).
    #[arg(long, conflicts_with = "resume")]
    pub seed: Option<u64>,
    /// Override one config value: a dotted key and a TOML value, e.g.
    /// `--set train.phase2_iterations=100` or `--set 'model.self_edges="none"'`. Repeatable;
    /// applied in order after `--seed`. Paths are relative to the config file.
    #[arg(long = "set", value_name = "KEY=VALUE", conflicts_with = "resume")]
    pub overrides: Vec<String>,
    /// Output directory (checkpoints phase1/, phase2/, latest/, losses.csv and the resolved
    /// config.toml). Default: runs/ and the config's name.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue from OUT/latest exactly where it stopped (with the config saved there).
    #[arg(long)]
    pub resume: bool,
    /// Stop after this many training iterations (both phases counted); resume later.
    #[arg(long)]
    pub stop_after: Option<u64>,
}

/// A new run of `config` in `out`: the config resolved (`seed`, then each override) and
/// written to `OUT/config.toml` with its paths rewritten relative to `OUT`, the trainer
/// started from that file.
pub fn fresh_trainer(config: &Path, seed: Option<u64>, overrides: &[String], out: &Path) -> Result<Trainer> {
    let doc = RunConfig::resolve(config, seed, overrides)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let resolved = doc.moved_to(&out.join(senc_train::trainer::CONFIG_FILE), PATH_KEYS);
    std::fs::write(&resolved.path, resolved.to_toml())
        .with_context(|| format!("writing {}", resolved.path.display()))?;
    Trainer::new(&resolved.path, out).with_context(|| format!("starting {}", config.display()))
}

/// Trains (or resumes) and prints where the checkpoints are.
pub fn run(args: Args) -> Result<()> {
    let out = args.out.unwrap_or_else(|| PathBuf::from("runs").join(args.config.file_stem().unwrap_or_default()));
    let (out, resume, stop_after) = (out.as_path(), args.resume, args.stop_after);
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
    let mut trainer = if resume {
        Trainer::resume(out).with_context(|| format!("resuming from {}", out.display()))?
    } else {
        fresh_trainer(&args.config, args.seed, &args.overrides, out)?
    };
    let t = &trainer.config.train;
    let total = t.warmup_iterations + t.phase1_iterations + t.phase2_iterations;
    let p = &trainer.progress;
    let done = p.warmup_done + if p.phase == Phase::Two { t.phase1_iterations } else { 0 } + p.iteration;
    let bar = ProgressBar::new(total).with_position(done);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {per_sec} eta {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    trainer.run(stop_after, |r| {
        bar.inc(1);
        let phase = r.phase;
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
