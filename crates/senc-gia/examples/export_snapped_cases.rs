//! Writes the grid-snapped crumpled meshes of `tests/fixtures/snapped_cases.json`: for seeds
//! from 0 on, `crumple_snapped` of the icosphere (even seeds) or the capped tube (odd seeds)
//! by 0.6 m on a 0.25 m grid, keeping those whose unperturbed run skips patches, until
//! `N` (default 12, the fixture's count) are found. Writes `DIR/snapped_SEED.obj` (the
//! closed mesh) and prints one JSON line per mesh with senc's volume and diagnostics, for
//! `tools/snapped_answers.py DIR`.
//!
//! `cargo run --release -p senc-gia --example export_snapped_cases -- DIR [N]`
use senc_geom::{close_holes, HoleSelection, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace};
use senc_testmesh::{crumple_snapped, icosphere, tube, Caps};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = std::path::PathBuf::from(args.get(1).ok_or("usage: export_snapped_cases DIR [N]")?);
    let n: usize = args.get(2).map_or(Ok(12), |s| s.parse())?;
    std::fs::create_dir_all(&dir)?;
    let bases = [icosphere(Vec3::zeros(), 1.0, 1)?, tube(0.5, 1.5, 8, 4, Caps::Fan)?];
    let mut found = 0;
    for seed in 0u64.. {
        if found == n {
            break;
        }
        let mesh = crumple_snapped(&bases[(seed % 2) as usize], 0.6, 0.25, seed)?;
        let closure = close_holes(&mesh, &HoleSelection::All)?;
        let p = GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default())?;
        if p.diagnostics.perturbed_retries == 0 {
            continue;
        }
        found += 1;
        let m = closure.mesh();
        senc_geom::obj::write_obj(dir.join(format!("snapped_{seed}.obj")), m.positions(), m.faces())?;
        println!(
            "{{\"seed\":{seed},\"volume\":{:e},\"diagnostics\":{}}}",
            p.volume,
            serde_json::to_string(&p.diagnostics)?
        );
    }
    Ok(())
}
