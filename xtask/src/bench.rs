//! `cargo xtask bench model [--config C.toml] [--quick] [--reps N] [--export DIR] [--torch]`:
//! times the senc-model network on the real t-shirt graph. `cargo xtask bench train
//! [--config C.toml] [--iterations N] [--phase 1|2] [--rounds R]` times training iterations.
//!
//! The graph is the one training builds: the config's garment (default the t-shirt) skinned
//! onto the body at frames `f − 1` and `f` of its first training motion, the proxy body at
//! `f` and `f + 1`, the config's `[model]` graph settings. Timed: graph building, upload,
//! inference (`valid()` model, output read back), inference on the fused CPU path
//! (`FusedNetwork`, what rollouts use; normalisation and cast included) and forward +
//! surrogate backward at the
//! config's `[model]` size, at HOOD's size with one block and at HOOD's full size (latent 128,
//! 15 blocks, 2 hidden layers; one rep with `--quick`). Without `--quick` also graph building
//! on synthetic 5k and 20k-vertex garments and the main operations of one block.
//!
//! `--export DIR` writes the graph for `tools/bench_torch.py --graph DIR/graph`; `--torch`
//! exports (to a temporary directory unless `--export`) and runs that script right after, so
//! the ratios burn / PyTorch come from one run on one machine. Times are medians after one warm-up.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Subcommand;
use senc_geom::Vec3;
use senc_model::bench::{bench_build, bench_graph, bench_network, bench_ops, export_graph, NetTiming};
use senc_model::{EdgeType, ModelConfig};
use senc_train::eval::first_scene;
use senc_train::trainer::scene_material;
use senc_train::{Garment, RunConfig};

/// Arguments of `cargo xtask bench`.
#[derive(clap::Args)]
pub struct Args {
    /// What to time.
    #[command(subcommand)]
    pub target: Target,
}

/// What `cargo xtask bench` times.
#[derive(Subcommand)]
pub enum Target {
    /// The network: graph building, inference and forward + backward (burn, optionally PyTorch).
    Model(ModelArgs),
    /// Training throughput: iterations per second, cores busy and CPU time per iteration.
    Train(TrainArgs),
}

/// Arguments of `cargo xtask bench train`.
#[derive(clap::Args)]
pub struct TrainArgs {
    /// Config to train (its warm-up runs untimed first).
    #[arg(long, default_value = "configs/skirt.toml")]
    pub config: PathBuf,
    /// Timed training iterations per round.
    #[arg(long, default_value_t = 60)]
    pub iterations: u64,
    /// Phase to time (1 or 2: phase 2 adds self-collision, area and repulsion).
    #[arg(long, default_value_t = 2)]
    pub phase: u8,
    /// Rounds, each a fresh run; the table gives their median.
    #[arg(long, default_value_t = 1)]
    pub rounds: usize,
}

/// Arguments of `cargo xtask bench model`.
#[derive(clap::Args)]
pub struct ModelArgs {
    /// Config whose scene and `[model]` table to use.
    #[arg(long, default_value = "configs/tshirt.toml")]
    pub config: PathBuf,
    /// Frame of the first training motion to build the graph at.
    #[arg(long, default_value_t = 40)]
    pub frame: usize,
    /// Timed runs per measurement (median; one warm-up run first).
    #[arg(long, default_value_t = 3)]
    pub reps: usize,
    /// Full HOOD size with one rep only; skip the synthetic scaling and operation profile.
    #[arg(long)]
    pub quick: bool,
    /// Write the graph to DIR/graph.* for tools/bench_torch.py.
    #[arg(long)]
    pub export: Option<PathBuf>,
    /// Run tools/bench_torch.py (python3, torch) on the same graph and print the ratios.
    #[arg(long)]
    pub torch: bool,
    /// Sizes to time, any of `config`, `hood1` (HOOD with one block), `hood` (for
    /// profiling one size; `--torch` needs all three).
    #[arg(long, value_delimiter = ',', default_value = "config,hood1,hood")]
    pub sizes: Vec<String>,
    /// Skip the forward + backward timing (inference only).
    #[arg(long)]
    pub no_backward: bool,
    /// Device to time the network on: cpu (default) or vulkan (build with `--features
    /// gpu`). Graph building always runs on the CPU.
    #[arg(long, default_value = "cpu")]
    pub device: String,
}

/// Runs one benchmark target.
pub fn run(args: Args) -> Result<()> {
    match args.target {
        Target::Model(m) => {
            if m.torch && (m.sizes.len() != 3 || m.no_backward) {
                bail!("--torch compares all three sizes with backward; drop --sizes and --no-backward");
            }
            let device = senc_model::device_named(&m.device)?;
            model(&m, &device)
        }
        Target::Train(t) => train(&t),
    }
}

/// Process CPU time (user + system, every thread), seconds, from `/proc/self/stat` (in
/// USER_HZ = 100 ticks per second, the Linux ABI's fixed unit). NaN where that file is
/// missing.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // The fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after the name.
    match (f.get(11).and_then(|v| v.parse::<f64>().ok()), f.get(12).and_then(|v| v.parse::<f64>().ok())) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// Training throughput: a fresh trainer per round in a temporary directory, its warm-up
/// untimed, then `iterations` training iterations of the chosen phase at the steady rollout
/// length (`[train] rollout_max`), timed by wall clock and process CPU time.
fn train(a: &TrainArgs) -> Result<()> {
    if a.iterations == 0 || a.rounds == 0 {
        bail!("give at least one iteration and one round");
    }
    let phase = match a.phase {
        1 => senc_train::Phase::One,
        2 => senc_train::Phase::Two,
        p => bail!("--phase {p}: give 1 or 2"),
    };
    let tmp = std::env::temp_dir().join(format!("senc-bench-train-{}", std::process::id()));
    let mut rounds = Vec::with_capacity(a.rounds);
    for round in 0..a.rounds {
        let out = tmp.join(format!("round{round}"));
        let mut trainer = crate::train::fresh_trainer(&a.config, None, &[], &out)?;
        trainer.config.train.checkpoint_every = u64::MAX;
        while trainer.progress.warmup_done < trainer.config.train.warmup_iterations {
            trainer.step()?;
        }
        let t = &trainer.config.train;
        trainer.progress.phase = phase;
        trainer.progress.iteration = t.rollout_growth.saturating_mul(t.rollout_max as u64);
        match phase {
            senc_train::Phase::One => trainer.config.train.phase1_iterations = u64::MAX,
            _ => trainer.config.train.phase2_iterations = u64::MAX,
        }
        let (w0, c0) = (std::time::Instant::now(), cpu_seconds());
        trainer.run(Some(a.iterations), |_| {})?;
        let (wall, cpu) = (w0.elapsed().as_secs_f64(), cpu_seconds() - c0);
        eprintln!("round {}: {wall:.1} s wall, {cpu:.1} s CPU", round + 1);
        rounds.push((wall, cpu));
        let _ = std::fs::remove_dir_all(&out);
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let wall = median(rounds.iter().map(|x| x.0).collect());
    let cpu = median(rounds.iter().map(|x| x.1).collect());
    println!(
        "Training throughput, {} phase {}, {} iterations per round, {} round(s), load {}\n",
        a.config.display(),
        a.phase,
        a.iterations,
        a.rounds,
        load()
    );
    println!("| iterations/s | cores busy | CPU ms per iteration |");
    println!("|---:|---:|---:|");
    println!("| {:.2} | {:.2} | {:.0} |", a.iterations as f64 / wall, cpu / wall, 1e3 * cpu / a.iterations as f64);
    Ok(())
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// The three sizes timed: the config's own, HOOD with one block, full HOOD.
fn sizes(own: &ModelConfig) -> Vec<(String, ModelConfig)> {
    vec![
        (format!("config ({}, {} blocks, {} hidden)", own.latent, own.blocks, own.hidden_layers), own.clone()),
        ("hood, 1 block (128, 2 hidden)".into(), ModelConfig::hood().with_blocks(1)),
        ("hood (128, 15 blocks, 2 hidden)".into(), ModelConfig::hood()),
    ]
}

fn model(o: &ModelArgs, device: &senc_model::burn::tensor::Device) -> Result<()> {
    let (config, frame, reps, quick, torch) = (o.config.as_path(), o.frame, o.reps, o.quick, o.torch);
    for s in &o.sizes {
        if !["config", "hood1", "hood"].contains(&s.as_str()) {
            bail!("unknown size {s}; expected config, hood1 or hood");
        }
    }
    let cfg = RunConfig::read(config)?;
    let g = Garment::load(&first_scene(&cfg)?, cfg.train.body_margin)?;
    let Some(motion) = g.scene.train.first() else { bail!("{} has no training motion", config.display()) };
    if motion.n_frames() < 3 {
        bail!("the first training motion of {} has fewer than 3 frames", config.display());
    }
    let f = frame.clamp(1, motion.n_frames() - 2);
    let prev = g.skinned_at(motion, f - 1)?;
    let curr = g.skinned_at(motion, f)?;
    let body_t = g.body_at(motion, f)?;
    let body_n = g.body_at(motion, f + 1)?;
    let gravity = Vec3::from(g.scene.config.external_force.gravity);
    let state = g.frame_state([&prev, &curr], [&body_t, &body_n], scene_material(&g)?, gravity, g.scene.dt());
    let graph_config = cfg.model.graph;
    println!("threads: rayon {}; load average at start: {}", rayon_threads(), load());
    let (graph, st, build) = bench_build(&state, &graph_config, reps)?;
    println!(
        "\n## graph: {} ({}), frame {f} of motion 0: {} cloth + {} body nodes; edges mesh {} body {} self {}",
        g.name(),
        config.display(),
        graph.n_cloth,
        graph.n_body,
        graph.edge_set(EdgeType::Mesh).len(),
        graph.edge_set(EdgeType::Body).len(),
        graph.edge_set(EdgeType::SelfCollision).len(),
    );
    println!(
        "build {:.1} ms (median of {reps}; nodes {:.1}, mesh {:.1}, body {:.1}, self {:.1})",
        build * 1e3,
        st.nodes * 1e3,
        st.mesh * 1e3,
        st.body * 1e3,
        st.self_collision * 1e3
    );

    let export_dir = match (o.export.as_deref(), torch) {
        (Some(d), _) => Some(d.to_path_buf()),
        (None, true) => Some(std::env::temp_dir().join("senc-bench-graph")),
        (None, false) => None,
    };
    if let Some(dir) = &export_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        export_graph(&graph, &dir.join("graph")).with_context(|| format!("writing the graph to {}", dir.display()))?;
        println!("exported to {}/graph.json", dir.display());
    }

    let own = cfg.model.network.clone();
    println!(
        "\n## network, burn on {} (median of {reps}; full HOOD {} rep(s)); load {}",
        o.device,
        if quick { 1 } else { reps },
        load()
    );
    let mut rows: Vec<NetTiming> = Vec::new();
    for (k, (label, c)) in sizes(&own).into_iter().enumerate() {
        if !o.sizes.iter().any(|s| s == ["config", "hood1", "hood"][k]) {
            continue;
        }
        let r = if quick && k == 2 { 1 } else { reps };
        let t = bench_network(&label, &c, &graph, r, !o.no_backward, device);
        println!(
            "{:34} params {:7} | upload {:6.1} ms | forward {:8.1} ms | fused {:8.1} ms | forward+backward {:8.1} ms | fps incl. graph: burn {:.1}, fused {:.1}",
            t.label,
            t.params,
            t.upload * 1e3,
            t.forward * 1e3,
            t.fused * 1e3,
            t.forward_backward * 1e3,
            1.0 / (build + t.upload + t.forward),
            1.0 / (build + t.fused)
        );
        rows.push(t);
    }

    if torch {
        let dir = export_dir.as_ref().expect("set when torch");
        torch_compare(dir, &own, reps, quick, &rows)?;
    }

    if !quick {
        println!("\n## graph building, synthetic folded garments (1.5 cm spacing, SMPL-sized sphere body)");
        for n in [71, 142] {
            let (nc, counts, secs, _) = bench_graph(n, reps);
            println!(
                "cloth {nc:6} | edges mesh {:6} body {:6} self {:6} | {:7.1} ms",
                counts[0],
                counts[1],
                counts[2],
                secs * 1e3
            );
        }
        println!("\n## operations of one block on the mesh edges, latent 128 (median of {reps}); load {}", load());
        for (name, fwd, fb) in bench_ops(&graph, 128, reps) {
            println!("{name:40} | forward {:8.2} ms | forward+backward {:8.2} ms", fwd * 1e3, fb * 1e3);
        }
    }
    println!("\nload average at end: {}", load());
    Ok(())
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// Runs `tools/bench_torch.py` on the exported graph and prints burn / PyTorch per size.
fn torch_compare(dir: &Path, own: &ModelConfig, reps: usize, quick: bool, rows: &[NetTiming]) -> Result<()> {
    let json = dir.join("torch.json");
    let mut cmd = Command::new("python3");
    cmd.arg("tools/bench_torch.py")
        .arg("--graph")
        .arg(dir.join("graph"))
        .args(["--reps", &reps.to_string()])
        .args(["--small", &format!("{},{},{}", own.latent, own.blocks, own.hidden_layers)])
        .arg("--json")
        .arg(&json);
    if quick {
        cmd.arg("--quick");
    }
    println!("\n## PyTorch on the same graph: {cmd:?}");
    // Our heap keeps its peak (crate::alloc); give it back so that PyTorch runs with the
    // whole machine's memory, as it would alone (holding it made PyTorch ~25 % slower).
    crate::alloc::release_free_memory();
    let status = cmd.status().context("running python3 tools/bench_torch.py (is torch installed?)")?;
    if !status.success() {
        bail!("tools/bench_torch.py failed ({status})");
    }
    let text = std::fs::read_to_string(&json).with_context(|| format!("reading {}", json.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("parsing {}", json.display()))?;
    let Some(torch_rows) = v["rows"].as_array() else { bail!("{} has no rows", json.display()) };
    println!(
        "\n## burn / PyTorch (same graph, same run; targets at HOOD size: forward <= 0.7, forward+backward <= 1.0)"
    );
    for (burn, t) in rows.iter().zip(torch_rows) {
        let (tf, tb) = (t["forward"].as_f64().unwrap_or(f64::NAN), t["forward_backward"].as_f64().unwrap_or(f64::NAN));
        println!(
            "{:34} | forward {:7.1} / {:7.1} ms = {:.2} | fused forward {:7.1} / {:7.1} ms = {:.2} | forward+backward {:8.1} / {:8.1} ms = {:.2}",
            burn.label,
            burn.forward * 1e3,
            tf * 1e3,
            burn.forward / tf,
            burn.fused * 1e3,
            tf * 1e3,
            burn.fused / tf,
            burn.forward_backward * 1e3,
            tb * 1e3,
            burn.forward_backward / tb
        );
    }
    Ok(())
}
