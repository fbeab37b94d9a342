//! `cargo xtask <command>`: every command senc users run.
//!
//! - `check-mesh MESH.obj [--close-holes] [--json]`: validate a mesh and print its topology
//!   (vertices, faces, boundary loops, components, closure).
//!
//! Later issues add `volume`, `energy`, `data`, `fit`, `preview`, `train`, `eval`,
//! `simulate` and `bench`. `cargo xtask` with no arguments lists what exists.

use std::path::PathBuf;

use anyhow::Result;
use clap::{CommandFactory, Parser, Subcommand};

mod check_mesh;

#[derive(Parser)]
#[command(name = "cargo xtask", about = "senc: self-collision-aware neural cloth simulation", version)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
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
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result: Result<()> = match cli.command {
        None => {
            let _ = Cli::command().print_help();
            println!();
            return std::process::ExitCode::SUCCESS;
        }
        Some(Command::CheckMesh { mesh, close_holes, json }) => check_mesh::run(&mesh, close_holes, json),
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
