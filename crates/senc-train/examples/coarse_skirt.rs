//! Writes `data/garments/skirt_coarse.msgpack`: a coarse procedural skirt (an open tube of
//! `RINGS × AROUND` vertices) traced on the committed skirt's surface, with skinning weights
//! from the body, for the smoke config and the tests.
//!
//! Run: `cargo run -p senc-train --example coarse_skirt` (from the workspace root).

use senc_geom::Vec3;
use senc_scene::build::transfer_weights;
use senc_scene::{BodyAsset, GarmentAsset, NamedLoop, SkinWeights};

const RINGS: usize = 6;
const AROUND: usize = 16;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let skirt = GarmentAsset::load("data/garments/skirt.msgpack")?;
    let body = BodyAsset::load("data/body.msgpack")?;
    let ys: Vec<f64> = skirt.positions.iter().map(|p| p.y).collect();
    let (y_min, y_max) = ys.iter().fold((f64::MAX, f64::MIN), |(a, b), &y| (a.min(y), b.max(y)));
    let band = (y_max - y_min) / (RINGS as f64 - 1.0) * 0.5;
    let mut positions = Vec::new();
    for r in 0..RINGS {
        let y = y_max - (y_max - y_min) * r as f64 / (RINGS as f64 - 1.0);
        let near: Vec<&Vec3> = skirt.positions.iter().filter(|p| (p.y - y).abs() <= band).collect();
        let c = near.iter().fold(Vec3::zeros(), |a, p| a + **p) / near.len() as f64;
        for k in 0..AROUND {
            let th = std::f64::consts::TAU * k as f64 / AROUND as f64;
            let dir = Vec3::new(th.cos(), 0.0, th.sin());
            // Largest radial distance among skirt vertices within 15° of this direction,
            // 4% out so the chords stay outside the body.
            let rad = near
                .iter()
                .map(|p| Vec3::new(p.x - c.x, 0.0, p.z - c.z))
                .filter(|d| d.norm() > 1e-9 && d.normalize().dot(&dir) > 15f64.to_radians().cos())
                .map(|d| d.norm())
                .fold(0.0, f64::max);
            positions.push(Vec3::new(c.x, y, c.z) + dir * rad * 1.04);
        }
    }
    let mut faces = Vec::new();
    let id = |r: usize, k: usize| (r * AROUND + k % AROUND) as u32;
    for r in 0..RINGS - 1 {
        for k in 0..AROUND {
            // Normals outwards (away from the body) with y down the rings and θ towards +z.
            faces.push([id(r, k), id(r, k + 1), id(r + 1, k)]);
            faces.push([id(r, k + 1), id(r + 1, k + 1), id(r + 1, k)]);
        }
    }
    let lists = transfer_weights(&positions, &body.positions, &body.weights, 4);
    let weights = SkinWeights::from_lists(&lists)?;
    let loops = vec![
        NamedLoop { name: "waist".into(), vertices: (0..AROUND as u32).collect() },
        NamedLoop { name: "hem".into(), vertices: ((RINGS - 1) * AROUND..RINGS * AROUND).map(|v| v as u32).collect() },
    ];
    let g = GarmentAsset { name: "skirt_coarse".into(), positions, faces, weights, loops };
    g.mesh()?;
    g.loop_indices()?;
    senc_scene::assets::write_msgpack("data/garments/skirt_coarse.msgpack", &g)?;
    println!("wrote data/garments/skirt_coarse.msgpack: {} vertices, {} faces", g.positions.len(), g.faces.len());
    Ok(())
}
