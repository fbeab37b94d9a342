//! Fits every `*.obj` of a folder onto the committed body with the default options and
//! prints each garment's summary line (`senc_scene::fit::describe`); writes the fitted
//! assets when given an output folder. A hand check of the fit on garment collections:
//!
//! ```text
//! cargo run -p senc-scene --example fit_dir -- GARMENTS_DIR [OUT_DIR] [--shift X,Y,Z]
//! ```
//!
//! `--shift` moves every garment by (X, Y, Z) m first, to see the alignment at work.

use std::path::PathBuf;

use senc_geom::obj::ObjData;
use senc_geom::Vec3;
use senc_scene::fit::{describe, fit, FitOptions};
use senc_scene::BodyAsset;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut dir = None;
    let mut out = None;
    let mut shift = Vec3::zeros();
    while let Some(a) = args.next() {
        if a == "--shift" {
            let v: Vec<f64> =
                args.next().ok_or("--shift X,Y,Z")?.split(',').map(str::parse).collect::<Result<_, _>>()?;
            shift = Vec3::new(v[0], v[1], v[2]);
        } else if dir.is_none() {
            dir = Some(PathBuf::from(a));
        } else {
            out = Some(PathBuf::from(a));
        }
    }
    let dir = dir.ok_or("usage: fit_dir GARMENTS_DIR [OUT_DIR] [--shift X,Y,Z]")?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let body = BodyAsset::load(root.join("data/body.msgpack"))?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    files.sort();
    for f in files {
        let data = ObjData::read(&f)?;
        let name = f.file_stem().map_or("garment".into(), |s| s.to_string_lossy().into_owned());
        let positions: Vec<Vec3> = data.positions.iter().map(|p| p + shift).collect();
        match fit(&name, &positions, &data.faces, &body, None, &FitOptions::default()) {
            Ok((asset, rep)) => {
                println!("{}", describe(&asset, &rep));
                if let Some(out) = &out {
                    senc_scene::assets::write_msgpack(out.join(format!("{name}.msgpack")), &asset)?;
                }
            }
            Err(e) => println!("{name}: {e}"),
        }
    }
    Ok(())
}
