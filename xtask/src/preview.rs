//! `cargo xtask preview --config C --frame N --out F.png`: draw the body and the skinned
//! garment at frame N of a scene motion (front, side and back views).

use std::path::Path;

use anyhow::{Context, Result};
use senc_scene::raster::{render, Layer, BODY, GARMENT_INSIDE, GARMENT_OUTSIDE};
use senc_scene::{Scene, Split};

/// `cargo xtask preview`.
pub fn run(config: &Path, frame: usize, motion: Option<&str>, out: &Path, size: u32) -> Result<()> {
    let scene = Scene::load(config)?;
    let (m, split) = match motion {
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
