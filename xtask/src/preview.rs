//! `cargo xtask preview --config C --frame N --out F.png`: draw the body and the skinned
//! garment at frame N of a scene motion (front, side and back views).

use std::path::PathBuf;

use anyhow::{Context, Result};
use senc_scene::raster::{render, Layer, BODY, GARMENT_INSIDE, GARMENT_OUTSIDE};
use senc_scene::{Scene, Split};

/// Arguments of `cargo xtask preview`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene config (TOML with a [scene] table).
    #[arg(long)]
    pub config: PathBuf,
    /// Frame index (frame 0 is the rest pose, where the garment is fitted).
    #[arg(long, default_value_t = 0)]
    pub frame: usize,
    /// Motion name (default: the first training motion).
    #[arg(long)]
    pub motion: Option<String>,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
    /// Width of one view, pixels.
    #[arg(long, default_value_t = 320)]
    pub size: u32,
}

/// `cargo xtask preview`.
pub fn run(args: Args) -> Result<()> {
    let (frame, out, size) = (args.frame, args.out.as_path(), args.size);
    let scene = Scene::load(&args.config)?;
    let (m, split) = match args.motion.as_deref() {
        Some(name) => scene.motion(name).with_context(|| {
            let names: Vec<&str> = scene.train.iter().chain(&scene.test).map(|m| m.name.as_str()).collect();
            format!("the scene has no motion {name}; it has {names:?}")
        })?,
        None => (&scene.train[0], Split::Train),
    };
    let body = scene.body_at(m, frame)?;
    let garment = scene.garment_skinned_at(m, frame)?;
    let img = render(
        &[
            Layer { positions: &body, faces: &scene.body.faces, outside: BODY, inside: BODY },
            Layer {
                positions: &garment,
                faces: &scene.garment.faces,
                outside: GARMENT_OUTSIDE,
                inside: GARMENT_INSIDE,
            },
        ],
        &[0.0, 90.0, 180.0],
        size,
    );
    img.write_png(out)?;
    let q = senc_scene::BodyQuery::new(&body, &scene.body.faces)?;
    let inside = q.inside(&garment).len();
    println!(
        "{}: motion {} ({:?}), frame {frame}/{}, garment vertices inside the body (skinned, no dynamics): {inside}",
        out.display(),
        m.name,
        split,
        m.n_frames()
    );
    Ok(())
}
