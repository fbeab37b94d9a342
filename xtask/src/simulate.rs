//! `cargo xtask simulate --checkpoint DIR --motion NAME|CLIP.bvh [--wind X,Y,Z] [--frames N]
//! [--garment G] [--previews K] --out DIR`: rolls a trained model out on a motion and writes
//! one OBJ per frame (garment and proxy body), one animated `sequence.glb` (garment and full
//! body), and K preview PNGs (front, side and back views) spread over the sequence.
//! `--solver N --config FILE` (no checkpoint) simulates with the reference solver instead
//! (at most N Newton iterations per frame on the config's phase-2 energy); `--refine N`
//! refines each network frame with at most N such iterations started from its answer.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use senc_geom::obj::write_obj;
use senc_geom::Vec3;
use senc_scene::raster::{render, Layer, BODY, GARMENT_INSIDE, GARMENT_OUTSIDE};
use senc_train::eval::{Method, Predictor, Scenario};
use senc_train::rollout::{network_rollout, solver_rollout, Refine};

use crate::glb::{write_animated_glb, AnimatedMesh};

/// Arguments of `cargo xtask simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Checkpoint directory (not needed with --solver and --config).
    #[arg(long, required_unless_present = "solver")]
    pub checkpoint: Option<PathBuf>,
    /// Simulate with the reference solver instead of a network: at most N Newton
    /// iterations per frame on the config's phase-2 energy.
    #[arg(long)]
    pub solver: Option<usize>,
    /// Refine each network frame with at most N Newton iterations of the reference
    /// solver on the config's phase-2 energy, started from the network's answer.
    #[arg(long, conflicts_with = "solver")]
    pub refine: Option<usize>,
    /// Motion: a scene motion's name (e.g. boxing_toes) or a clip file (`.bvh`, retargeted
    /// to the body's rig by joint name; `.msgpack`).
    #[arg(long)]
    pub motion: String,
    /// Config (default: the checkpoint's own).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// External acceleration X,Y,Z in m/s² (wind).
    #[arg(long, allow_hyphen_values = true)]
    pub wind: Option<String>,
    /// Frames to simulate.
    #[arg(long, default_value_t = 90)]
    pub frames: usize,
    /// A garment the model never saw: an OBJ in metres (fitted to the body first; in a file
    /// of several garments `X.obj#NAME` or `#largest` picks one) or a fitted .msgpack asset.
    #[arg(long)]
    pub garment: Option<PathBuf>,
    /// Preview PNGs (front, side, back) spread evenly over the sequence.
    #[arg(long, default_value_t = 4)]
    pub previews: usize,
    /// Output directory (OBJ sequence, sequence.glb, preview PNGs).
    #[arg(long)]
    pub out: PathBuf,
}

/// Parses `--wind X,Y,Z`.
fn parse_wind(w: &str) -> Result<Vec3> {
    let v: Vec<f64> = w
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--wind {w}: expected three numbers X,Y,Z in m/s²"))?;
    if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
        bail!("--wind {w}: expected three finite numbers X,Y,Z in m/s²");
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// Simulates and writes the sequence.
pub fn run(a: &Args) -> Result<()> {
    let mut m = match (a.checkpoint.as_deref(), a.solver, a.config.as_deref()) {
        (Some(c), _, _) => Method::new(c, a.config.as_deref())?,
        (None, Some(_), Some(cfg)) => Method::solver(cfg),
        _ => bail!("give --checkpoint DIR, or --solver N with --config FILE"),
    };
    if let Some(g) = a.garment.as_deref() {
        let assets = crate::eval::prepare_garments(g, &m.config)?;
        let [asset] = assets.as_slice() else {
            bail!("--garment {}: {} garments; pick one with X.obj#NAME or #largest", g.display(), assets.len())
        };
        m = m.with_garment(asset);
    }
    let Scenario { garment: g, material, mut energy, .. } = m.scenario()?;
    let motion = &g.scene.resolve_motion(&a.motion)?;
    let wind = a.wind.as_deref().map(parse_wind).transpose()?.unwrap_or_else(Vec3::zeros);
    let ext = Vec3::from(g.scene.config.external_force.acceleration) + wind;
    energy.external_acceleration = ext.into();
    let r = match (&m.predictor, a.solver) {
        (Predictor::Solver, Some(iterations)) => solver_rollout(&g, motion, a.frames, &energy, iterations)?,
        _ => {
            let model = m.load_model()?;
            let refine = a.refine.map(|iterations| Refine { energy: &energy, iterations });
            network_rollout(&model, &g, motion, a.frames, ext, &material, refine)?
        }
    };
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    for (f, (x, b)) in r.cloth.iter().zip(&r.body).enumerate() {
        write_obj(a.out.join(format!("cloth_{f:04}.obj")), x, g.rest.faces())?;
        write_obj(a.out.join(format!("body_{f:04}.obj")), b, g.body_faces())?;
    }
    // The full body for the animation and the pictures (the rollout used the proxy).
    let bodies: Vec<Vec<Vec3>> = (0..r.cloth.len()).map(|f| g.scene.body_at(motion, f)).collect::<Result<_, _>>()?;
    let glb = a.out.join("sequence.glb");
    write_animated_glb(
        &glb,
        &[
            AnimatedMesh { name: "garment", faces: g.rest.faces(), frames: &r.cloth, color: [0.85, 0.2, 0.2] },
            AnimatedMesh { name: "body", faces: &g.scene.body.faces, frames: &bodies, color: [0.6, 0.6, 0.62] },
        ],
        g.scene.config.fps,
    )?;
    let n = r.cloth.len();
    let k = a.previews.min(n);
    let mut pngs = Vec::new();
    for i in 0..k {
        let f = if k <= 1 { n - 1 } else { i * (n - 1) / (k - 1) };
        let img = render(
            &[
                Layer { positions: &bodies[f], faces: &g.scene.body.faces, outside: BODY, inside: BODY },
                Layer {
                    positions: &r.cloth[f],
                    faces: g.rest.faces(),
                    outside: GARMENT_OUTSIDE,
                    inside: GARMENT_INSIDE,
                },
            ],
            &[0.0, 90.0, 180.0],
            320,
        );
        let p = a.out.join(format!("preview_{f:04}.png"));
        img.write_png(&p)?;
        pngs.push(p);
    }
    println!(
        "wrote {n} frames to {} (cloth_NNNN.obj, body_NNNN.obj: proxy body), {} (garment and full body, {} fps) and {} preview PNGs; {:.1} FPS",
        a.out.display(),
        glb.display(),
        g.scene.config.fps,
        pngs.len(),
        r.steps as f64 / r.infer_seconds.max(1e-12)
    );
    if !r.refined.is_empty() {
        let rejected = r.refined.iter().filter(|f| f.rejected).count();
        let mean = |e: fn(&senc_train::rollout::RefinedFrame) -> f64| {
            r.refined.iter().map(e).sum::<f64>() / r.refined.len() as f64
        };
        println!(
            "refinement: mean energy {:.3e} J (network {:.3e}, inertial target {:.3e}); network answer rejected in {rejected} of {} frames",
            mean(|f| f.refined),
            mean(|f| f.network),
            mean(|f| f.inertial),
            r.refined.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wind_parses_three_finite_numbers_only() {
        assert_eq!(parse_wind("1, -2,3.5").unwrap(), Vec3::new(1.0, -2.0, 3.5));
        assert!(parse_wind("1,2").is_err());
        assert!(parse_wind("1,2,x").is_err());
        assert!(parse_wind("1,2,NaN").is_err());
    }
}
