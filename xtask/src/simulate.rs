//! `cargo xtask simulate --checkpoint DIR --motion NAME [--wind X,Y,Z] [--frames N] --out DIR`:
//! rolls a trained model out on a motion and writes one OBJ per frame (garment and body).

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use senc_geom::obj::write_obj;
use senc_geom::Vec3;
use senc_model::burn::tensor::Device;
use senc_model::Model;
use senc_train::eval::Method;
use senc_train::rollout::rollout;
use senc_train::trainer::scene_material;
use senc_train::{Garment, RunConfig};

/// Simulates and writes `OUT/cloth_NNNN.obj` and `OUT/body_NNNN.obj`.
pub fn run(
    checkpoint: &Path,
    config: Option<&Path>,
    motion: &str,
    wind: Option<&str>,
    frames: usize,
    out: &Path,
) -> Result<()> {
    let m = Method::new(checkpoint, config)?;
    let cfg = RunConfig::read(&m.config)?;
    let g = Garment::load(&senc_train::eval::first_scene(&cfg)?, cfg.train.body_margin)?;
    let (motion, _) = g.scene.motion(motion).ok_or_else(|| {
        let names: Vec<&str> = g.scene.train.iter().chain(&g.scene.test).map(|m| m.name.as_str()).collect();
        anyhow!("no motion named {motion}; this scene has {}", names.join(", "))
    })?;
    let wind = match wind {
        None => Vec3::zeros(),
        Some(w) => {
            let v: Vec<f64> = w
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("--wind {w}: expected three numbers X,Y,Z in m/s²"))?;
            if v.len() != 3 {
                bail!("--wind {w}: expected three numbers X,Y,Z in m/s²");
            }
            Vec3::new(v[0], v[1], v[2])
        }
    };
    let model = Model::load(&m.checkpoint, &Device::flex())?;
    let material = scene_material(&g)?;
    let ext = Vec3::from(g.scene.config.external_force.acceleration) + wind;
    let r = rollout(&model, &g, motion, frames, ext, &material)?;
    std::fs::create_dir_all(out)?;
    for (f, (x, b)) in r.cloth.iter().zip(&r.body).enumerate() {
        write_obj(out.join(format!("cloth_{f:04}.obj")), x, g.rest.faces())?;
        write_obj(out.join(format!("body_{f:04}.obj")), b, g.body_faces())?;
    }
    println!(
        "wrote {} frames to {} (cloth_NNNN.obj, body_NNNN.obj: proxy body); {:.1} FPS",
        r.cloth.len(),
        out.display(),
        r.steps as f64 / r.infer_seconds.max(1e-12)
    );
    Ok(())
}
