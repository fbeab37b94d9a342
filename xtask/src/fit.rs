//! `cargo xtask fit --garment X.obj[#WHICH]`: fit a garment made elsewhere onto the senc
//! body (`senc_scene::fit`). `#NAME` fits the OBJ group or object of that name, `#largest`
//! its largest component, `#each` every component as its own garment; without `#` the whole
//! file is one garment.

use std::path::{Path, PathBuf};

use anyhow::Result;
use senc_geom::Vec3;
use senc_scene::build::WeightLists;
use senc_scene::fit::{fit_obj, FitOptions, FitReport, Select};
use senc_scene::{BodyAsset, GarmentAsset};

pub use senc_scene::fit::describe;

/// Fits one garment (for `eval --garment`, `simulate --garment`).
pub fn fit(
    name: &str,
    positions: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    body: &BodyAsset,
    weights: Option<WeightLists>,
    align: bool,
    margin: f64,
) -> Result<(GarmentAsset, FitReport)> {
    let opts = FitOptions { align, margin, ..FitOptions::default() };
    Ok(senc_scene::fit::fit(name, &positions, &faces, body, weights, &opts)?)
}

/// `cargo xtask fit`.
pub fn run(garment: &Path, body: &Path, out: Option<PathBuf>, scale: f64, no_align: bool, margin: f64) -> Result<()> {
    let body_asset = BodyAsset::load(body)?;
    let (file, select) = Select::from_arg(garment);
    let opts = FitOptions { align: !no_align, margin, ..FitOptions::default() };
    let fitted = fit_obj(&file, &select, scale, &body_asset, &opts)?;
    let out = out.unwrap_or_else(|| file.with_extension("msgpack"));
    let several = fitted.len() > 1;
    for (asset, rep) in &fitted {
        let path = if several { out.with_file_name(format!("{}.msgpack", asset.name)) } else { out.clone() };
        senc_scene::assets::write_msgpack(&path, asset)?;
        let obj = path.with_extension("fitted.obj");
        senc_geom::obj::write_obj(&obj, &asset.positions, &asset.faces)?;
        println!("{}", describe(asset, rep));
        println!("wrote {} and {}", path.display(), obj.display());
    }
    Ok(())
}
