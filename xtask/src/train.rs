//! `cargo xtask train --config C.toml [--seed N] [--seeds K] [--set key=value ...] [--out DIR]
//! [--resume] [--stop-after N]`: both training phases with a progress bar, tracing logs and a
//! CSV of losses.
//!
//! With `--seeds K`, K runs of seeds N, N+1, … train side by side in `OUT/seed-S/`, the
//! threads split between them, and `OUT/phase2` becomes the selected network of the run
//! with the best selection score (`[train] select_every`; `OUT/seeds.csv`). The seed moves a
//! network's rollouts far more than most recipe changes do, and the selection score, a
//! rollout on the training motions, ranks networks much as the test motions do.
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
    /// Train this many seeds side by side (from `--seed`, else the config's), each in
    /// OUT/seed-S, and keep the network with the best selection score as OUT/phase2 (needs
    /// `[train] select_every`). With `--resume`, every OUT/seed-S goes on.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub seeds: u64,
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
    let out =
        args.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(args.config.file_stem().unwrap_or_default()));
    let (out, resume, stop_after) = (out.as_path(), args.resume, args.stop_after);
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
    if args.seeds > 1 || (resume && out.join(SEEDS_FILE).exists()) {
        return seeds::run(&args, out);
    }
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

/// The table of a `--seeds` run: one row per seed, its selected iteration and score.
pub const SEEDS_FILE: &str = "seeds.csv";

mod seeds {
    use std::path::{Path, PathBuf};
    use std::time::Instant;

    use anyhow::{bail, Context, Result};
    use senc_train::{RunConfig, Trainer};

    use super::{fresh_trainer, Args, SEEDS_FILE};

    /// How one seed's training ended: its best selection (iteration, score in cm) and
    /// whether both phases are done.
    struct Ended {
        best: Option<(u64, f64)>,
        finished: bool,
    }

    /// The runs of a `--seeds` training: `(seed, OUT/seed-S)`, from the arguments, or from
    /// `OUT/seeds.csv` when resuming.
    fn runs(args: &Args, out: &Path) -> Result<Vec<(u64, PathBuf)>> {
        let seeds: Vec<u64> = if args.resume {
            let path = out.join(SEEDS_FILE);
            let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
            text.lines()
                .skip(1)
                .map(|l| {
                    l.split(',')
                        .next()
                        .and_then(|s| s.parse().ok())
                        .with_context(|| format!("bad row `{l}` in {}", path.display()))
                })
                .collect::<Result<_>>()?
        } else {
            let config = RunConfig::from_document(&RunConfig::resolve(&args.config, args.seed, &args.overrides)?)?;
            if config.train.select_every == 0 {
                bail!("--seeds chooses among the seeds by their selection score: set [train] select_every > 0");
            }
            (config.train.seed..config.train.seed + args.seeds).collect()
        };
        Ok(seeds.into_iter().map(|s| (s, out.join(format!("seed-{s}")))).collect())
    }

    /// Writes `OUT/seeds.csv`: each seed's best iteration and score so far, and which one
    /// `OUT/phase2` holds (`chosen`).
    fn write_table(out: &Path, rows: &[(u64, Option<(u64, f64)>)], chosen: Option<u64>) -> Result<()> {
        let mut text = String::from("seed,iteration,score_cm,chosen\n");
        for &(seed, best) in rows {
            let (it, score) = best.map_or((String::new(), String::new()), |(i, s)| (i.to_string(), format!("{s:.4}")));
            text.push_str(&format!("{seed},{it},{score},{}\n", u8::from(chosen == Some(seed))));
        }
        let path = out.join(SEEDS_FILE);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    }

    /// Trains every seed's run on its share of the threads, then copies the best-scoring
    /// run's `phase2/` to `OUT/phase2`.
    pub fn run(args: &Args, out: &Path) -> Result<()> {
        let runs = runs(args, out)?;
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        write_table(out, &runs.iter().map(|&(s, _)| (s, None)).collect::<Vec<_>>(), None)?;
        let threads = (rayon::current_num_threads() / runs.len()).max(1);
        let start = Instant::now();
        let results: Vec<Result<Ended>> = std::thread::scope(|scope| {
            let handles: Vec<_> = runs
                .iter()
                .map(|(seed, dir)| {
                    scope.spawn(move || -> Result<Ended> {
                        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
                        pool.install(|| {
                            let mut trainer = if args.resume {
                                Trainer::resume(dir).with_context(|| format!("resuming from {}", dir.display()))?
                            } else {
                                fresh_trainer(&args.config, Some(*seed), &args.overrides, dir)?
                            };
                            let mut last = Instant::now();
                            trainer.run(args.stop_after, |r| {
                                if last.elapsed().as_secs() >= 60 {
                                    last = Instant::now();
                                    eprintln!(
                                        "seed {seed}: {} iteration {}/{}, loss {:.4e}",
                                        r.phase, r.iteration, r.phase_iterations, r.loss
                                    );
                                }
                            })?;
                            Ok(Ended { best: trainer.progress.best, finished: trainer.finished() })
                        })
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a training thread panicked"))))
                .collect()
        });
        let results = results.into_iter().collect::<Result<Vec<_>>>()?;
        let rows: Vec<(u64, Option<(u64, f64)>)> = runs.iter().zip(&results).map(|((s, _), r)| (*s, r.best)).collect();
        if !results.iter().all(|r| r.finished) {
            write_table(out, &rows, None)?;
            println!(
                "training stopped after {:.1} s; resume with --resume --out {}",
                start.elapsed().as_secs_f64(),
                out.display()
            );
            return Ok(());
        }
        let best = rows
            .iter()
            .zip(&runs)
            .filter_map(|(&(seed, b), (_, dir))| b.map(|(_, score)| (seed, score, dir)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((seed, score, dir)) = best else {
            write_table(out, &rows, None)?;
            bail!("no seed's network was admissible for selection (see OUT/seed-S/selection.csv)");
        };
        // Copied under a temporary name and renamed, so OUT/phase2 is never half written.
        let (target, tmp) = (out.join("phase2"), out.join(".phase2.tmp"));
        for d in [&tmp, &target] {
            if d.exists() {
                std::fs::remove_dir_all(d).with_context(|| format!("removing {}", d.display()))?;
            }
        }
        std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        let from = dir.join("phase2");
        for entry in std::fs::read_dir(&from).with_context(|| format!("reading {}", from.display()))? {
            let entry = entry?;
            std::fs::copy(entry.path(), tmp.join(entry.file_name()))
                .with_context(|| format!("copying {}", entry.path().display()))?;
        }
        std::fs::rename(&tmp, &target)
            .with_context(|| format!("renaming {} to {}", tmp.display(), target.display()))?;
        write_table(out, &rows, Some(seed))?;
        println!(
            "training finished in {:.1} s; seed {seed} scored best ({score:.2} cm): {} is a copy of {} (scores in {})",
            start.elapsed().as_secs_f64(),
            target.display(),
            from.display(),
            out.join(SEEDS_FILE).display()
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(out: &Path, overrides: &[&str], resume: bool, stop_after: Option<u64>) -> Args {
        Args {
            config: Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/smoke.toml"),
            seed: None,
            overrides: overrides.iter().map(|s| s.to_string()).collect(),
            out: Some(out.to_path_buf()),
            resume,
            stop_after,
            seeds: if resume { 1 } else { 2 },
        }
    }

    /// Two seeds stopped part-way and resumed: `OUT/phase2` is then the phase-2 network of
    /// the seed with the lower selection score, as `seeds.csv` says.
    #[test]
    fn seeds_train_side_by_side_and_the_best_scoring_one_is_kept() {
        let out = std::env::temp_dir().join(format!("senc-seeds-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let e = run(args(&out, &[], false, None)).unwrap_err().to_string();
        assert!(e.contains("select_every"), "{e}");
        let set = ["train.select_every=10", "train.select_frames=3"];
        run(args(&out, &set, false, Some(35))).unwrap();
        assert!(!out.join("phase2").exists(), "nothing is chosen before every seed is done");
        run(args(&out, &[], true, None)).unwrap();
        let table = std::fs::read_to_string(out.join(SEEDS_FILE)).unwrap();
        let rows: Vec<(u64, f64, bool)> = table
            .lines()
            .skip(1)
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                (c[0].parse().unwrap(), c[2].parse().unwrap(), c[3] == "1")
            })
            .collect();
        assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [1, 2], "{table}");
        let chosen = rows.iter().find(|r| r.2).expect("one seed chosen");
        assert!(rows.iter().all(|r| r.1 >= chosen.1), "{table}");
        let weights = |dir: PathBuf| std::fs::read(dir.join("weights.bpk")).unwrap();
        assert_eq!(weights(out.join("phase2")), weights(out.join(format!("seed-{}/phase2", chosen.0))));
        let _ = std::fs::remove_dir_all(&out);
    }
}
