//! `cargo xtask fit --garment X.obj[#WHICH]`: fit a garment made elsewhere onto the senc
//! body (`senc_scene::fit`). `#NAME` fits the OBJ group or object of that name, `#largest`
//! its largest component, `#each` every component as its own garment; without `#` the whole
//! file is one garment.

use std::path::PathBuf;

use anyhow::Result;
use senc_scene::fit::{fit_obj, FitOptions, Select};
use senc_scene::BodyAsset;

pub use senc_scene::fit::describe;

/// Arguments of `cargo xtask fit`.
#[derive(clap::Args)]
pub struct Args {
    /// The garment OBJ.
    #[arg(long)]
    pub garment: PathBuf,
    /// Body asset.
    #[arg(long, default_value = "data/body.msgpack")]
    pub body: PathBuf,
    /// Output asset (default: next to the OBJ, .msgpack).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Factor to metres (0.01 for centimetres).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Skip the rigid alignment (the garment is already placed on the body).
    #[arg(long)]
    pub no_align: bool,
    /// Clearance from the body, m.
    #[arg(long, default_value_t = 5e-3)]
    pub margin: f64,
}

/// Fits the garment and writes the asset(s).
pub fn run(args: &Args) -> Result<()> {
    let Args { garment, body, out, scale, no_align, margin } = args;
    let (out, scale, no_align, margin) = (out.clone(), *scale, *no_align, *margin);
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
