//! `cargo xtask volume`: the penetration volume of any mesh, with diagnostics and timing.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use senc_geom::{close_holes, obj::read_obj, HoleSelection};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, Gradients, SizeRule, VolumeRule};

/// Arguments of `cargo xtask volume`.
#[derive(clap::Args)]
pub struct Args {
    /// The OBJ file.
    pub mesh: PathBuf,
    /// Close boundary loops with centroid fans first.
    #[arg(long)]
    pub close_holes: bool,
    /// Boundary loops to leave open (indices as printed by check-mesh), with --close-holes.
    #[arg(long, num_args = 1..)]
    pub leave_open: Vec<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Gradient with SENC's fixed barycentric weights instead of the exact one.
    #[arg(long)]
    pub fixed_barycentric: bool,
    /// SENC's smaller-side flood fill instead of winding numbers (ablation).
    #[arg(long)]
    pub smaller_side: bool,
    /// With --smaller-side: decide the penetrating side by area instead of face count.
    #[arg(long)]
    pub area_rule: bool,
    /// Warm calls on the same workspace after the first (their median is `time_ms`).
    #[arg(long, default_value_t = 0)]
    pub repeat: usize,
}

/// Measures the volume and prints it.
pub fn run(args: &Args) -> Result<()> {
    let mesh = read_obj(&args.mesh).with_context(|| format!("reading {}", args.mesh.display()))?;
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
        rule: if args.smaller_side { VolumeRule::SmallerSide } else { VolumeRule::Winding },
        size_rule: if args.area_rule { SizeRule::Area } else { SizeRule::Faces },
        // The volume's gradient, as the self-collision energy asks for it.
        gradients: Gradients::Volume,
    };
    let start = Instant::now();
    let mut ws = GiaWorkspace::new(&closure);
    let pen = ws.penetration(&closure, &options)?;
    let first_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut warm: Vec<f64> = Vec::with_capacity(args.repeat);
    for _ in 0..args.repeat {
        let t = Instant::now();
        let again = ws.penetration(&closure, &options)?;
        warm.push(t.elapsed().as_secs_f64() * 1e3);
        anyhow::ensure!(again.volume == pen.volume, "a warm call gave {} instead of {}", again.volume, pen.volume);
    }
    warm.sort_by(f64::total_cmp);
    let time_ms = if warm.is_empty() { first_ms } else { warm[warm.len() / 2] };
    let weighted: Vec<_> = pen.patches.iter().filter(|p| p.weight != 0).collect();
    if args.json {
        let v = serde_json::json!({
            "volume_m3": pen.volume,
            "volume_cm3": pen.volume * 1e6,
            "area_m2": pen.area,
            "rule": options.rule,
            "patches": pen.patches.len(),
            "weighted_patches": weighted,
            "regions": pen.regions.len(),
            "paths": pen.paths.len(),
            "region_volumes_m3": pen.regions.iter().map(|r| r.volume).collect::<Vec<_>>(),
            "path_kinds": pen.paths.iter().map(|p| p.kind).collect::<Vec<_>>(),
            "holes_closed": closure.centroids().len(),
            "holes_open": closure.open_holes(),
            "faces": closure.mesh().n_faces(),
            "diagnostics": pen.diagnostics,
            "first_ms": first_ms,
            "time_ms": time_ms,
            "warm_calls": warm.len(),
            "warm_min_ms": warm.first(),
            "warm_max_ms": warm.last(),
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
        println!("penetration volume: {:.6e} m³ = {:.4} cm³ ({:?} rule)", pen.volume, pen.volume * 1e6, options.rule);
        println!("patches: {}, paths: {}, penetrating area {:.4e} m²", pen.patches.len(), pen.paths.len(), pen.area);
        for (i, p) in pen.patches.iter().enumerate().filter(|(_, p)| p.weight != 0 || p.skipped) {
            println!(
                "  patch {i}: winding {} outside, weight {}, {:.6e} m³, {} faces + {} pieces{}",
                p.winding_outside,
                p.weight,
                p.volume,
                p.n_faces,
                p.n_pieces,
                if p.skipped { " (skipped)" } else { "" }
            );
        }
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
        println!(
            "time: first call {first_ms:.2} ms (BVH build + detection + GIA + gradient); median of {} warm calls {time_ms:.3} ms",
            warm.len()
        );
    }
    Ok(())
}
