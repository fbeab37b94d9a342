//! `cargo xtask against-solver`: a network rolled out alone against the reference solver on
//! the same motion, frame by frame (distance, rise, first step, stillness at the end). On a
//! motion whose body holds still (`configs/rest-skirt.toml`'s `cmu_01_01_held`) it is the
//! resting-case check: the garment must sag a little and hang still, as the solver's does.

use crate::network::NetworkArgs;
use anyhow::Result;
use senc_train::eval::Scenario;
use senc_train::resting::against_solver;

/// Arguments of `cargo xtask against-solver`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub network: NetworkArgs,
    /// Motion: a scene motion's name or a clip file (`.bvh`, `.msgpack`).
    #[arg(long)]
    pub motion: String,
    /// Frames to simulate.
    #[arg(long, default_value_t = 90)]
    pub frames: usize,
    /// Newton iterations per frame of the reference solver (phase-2 energy).
    #[arg(long, default_value_t = 30)]
    pub solver: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs both rollouts and prints the comparison.
pub fn run(a: &Args) -> Result<()> {
    let m = a.network.method()?;
    let Scenario { garment: g, material, energy, .. } = m.scenario()?;
    let motion = &g.scene.resolve_motion(&a.motion)?;
    let model = m.load_model()?;
    let (c, _, _) = against_solver(&model, &g, motion, a.frames, &material, &energy, a.solver)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
        return Ok(());
    }
    println!(
        "network against the reference solver ({} iterations per frame), {} frames of {}:",
        a.solver, c.frames, a.motion
    );
    println!("  distance at the last frame   {:8.2} cm (largest {:.2} cm)", c.final_distance_cm, c.max_distance_cm);
    println!("  rise above the solver's      {:8.2} cm", c.final_rise_cm);
    println!(
        "  first-step rise              {:8.2} cm (solver {:.2} cm)",
        c.first_step_rise_cm, c.solver_first_step_rise_cm
    );
    println!(
        "  speed over the last frames   {:8.3} cm/frame (solver {:.3} cm/frame)",
        c.final_speed_cm, c.solver_final_speed_cm
    );
    for (what, e) in [("solver's", c.on_solver_states), ("network's", c.on_network_states)] {
        println!(
            "  one step from the {what:9} states: {:6.3} cm from the solver's step, {:+7.3} cm above it ({} steps)",
            e.distance_cm, e.rise_cm, e.steps
        );
    }
    Ok(())
}
