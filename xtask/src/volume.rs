//! `cargo xtask volume`: the penetration volume of any mesh, with diagnostics and timing.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use senc_geom::{close_holes, obj::read_obj, HoleSelection};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, SizeRule};

/// Options of the command.
pub struct VolumeArgs<'a> {
    pub mesh: &'a Path,
    pub close_holes: bool,
    pub leave_open: &'a [usize],
    pub json: bool,
    pub fixed_barycentric: bool,
    pub area_rule: bool,
}

pub fn run(args: &VolumeArgs) -> Result<()> {
    let mesh = read_obj(args.mesh).with_context(|| format!("reading {}", args.mesh.display()))?;
    let selection = if args.close_holes {
        if args.leave_open.is_empty() {
            HoleSelection::All
        } else {
            HoleSelection::AllExcept(args.leave_open.to_vec())
        }
    } else {
        HoleSelection::None
    };
    let closure = close_holes(&mesh, &selection).context("closing holes")?;
    let options = GiaOptions {
        gradient: if args.fixed_barycentric { GradientMode::FixedBarycentric } else { GradientMode::Exact },
        size_rule: if args.area_rule { SizeRule::Area } else { SizeRule::Faces },
    };
    let start = Instant::now();
    let mut ws = GiaWorkspace::new(&closure);
    let pen = ws.penetration(&closure, &options)?;
    let time_ms = start.elapsed().as_secs_f64() * 1e3;
    if args.json {
        let v = serde_json::json!({
            "volume_m3": pen.volume,
            "volume_cm3": pen.volume * 1e6,
            "area_m2": pen.area,
            "regions": pen.regions.len(),
            "paths": pen.paths.len(),
            "region_volumes_m3": pen.regions.iter().map(|r| r.volume).collect::<Vec<_>>(),
            "path_kinds": pen.paths.iter().map(|p| p.kind).collect::<Vec<_>>(),
            "holes_closed": closure.centroids().len(),
            "holes_open": closure.open_holes(),
            "diagnostics": pen.diagnostics,
            "time_ms": time_ms,
        });
        println!("{v}");
    } else {
        println!(
            "{}: {} vertices, {} faces ({} holes closed, {} left open)",
            args.mesh.display(),
            mesh.n_vertices(),
            mesh.n_faces(),
            closure.centroids().len(),
            closure.open_holes().len()
        );
        println!("penetration volume: {:.6e} m³ = {:.4} cm³", pen.volume, pen.volume * 1e6);
        println!("regions: {}, paths: {}, penetrating area {:.4e} m²", pen.regions.len(), pen.paths.len(), pen.area);
        for (i, r) in pen.regions.iter().enumerate() {
            println!(
                "  region {i}: {:.6e} m³ over {} faces ({} sub-faces), paths {:?}",
                r.volume,
                r.faces.len(),
                r.n_sub_faces,
                r.paths
            );
        }
        println!("diagnostics: {:?}", pen.diagnostics);
        println!("time: {time_ms:.2} ms (BVH build + detection + GIA + gradient)");
    }
    Ok(())
}
