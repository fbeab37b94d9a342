//! `cargo xtask stress`: a network rolled out alone on the stiff and extreme cases (μ and
//! k_b ×100, the motion 3× faster, 50 m/s² wind, a start 2 cm towards the body), each
//! case's energy, distance from the skinned garment and speed, and whether it stayed finite.

use crate::network::NetworkArgs;
use anyhow::Result;
use senc_train::eval::{MarkdownTable, Scenario};
use senc_train::stress::stress;

/// Arguments of `cargo xtask stress`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub network: NetworkArgs,
    /// Motion: a scene motion's name or a clip file (`.bvh`, `.msgpack`); default the
    /// config's first test motion.
    #[arg(long)]
    pub motion: Option<String>,
    /// Frames to simulate per case.
    #[arg(long, default_value_t = 60)]
    pub frames: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs every case and prints the table.
pub fn run(a: &Args) -> Result<()> {
    let m = a.network.method()?;
    let Scenario { garment: g, material, energy, .. } = m.scenario()?;
    let motion = match &a.motion {
        Some(name) => g.scene.resolve_motion(name)?,
        None => g
            .scene
            .test
            .first()
            .cloned()
            .ok_or_else(|| anyhow::anyhow!("{}: no test motion; pass --motion", m.config.display()))?,
    };
    let model = m.load_model()?;
    let rows = stress(&model, &g, &motion, a.frames, &energy, &material)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!("{} on {} ({} frames per case), network alone:\n", g.name(), motion.name, a.frames);
    let mut t = MarkdownTable::new(
        &["case", "what", "finite", "frames", "mean E (J)", "max E (J)", "from skinned (cm)", "max speed (cm/frame)"],
        3,
    );
    for r in &rows {
        t.push(vec![
            format!("{:?}", r.case),
            r.case.description().to_string(),
            (if r.finite { "yes" } else { "no" }).to_string(),
            r.frames.to_string(),
            format!("{:.3e}", r.energy_mean_j),
            format!("{:.3e}", r.energy_max_j),
            format!("{:.1}", r.departure_cm),
            format!("{:.2}", r.max_speed_cm),
        ]);
    }
    print!("{}", t.render());
    for r in rows.iter().filter(|r| !r.finite) {
        println!("\n{:?}: {}", r.case, r.error.as_deref().unwrap_or(""));
    }
    Ok(())
}
