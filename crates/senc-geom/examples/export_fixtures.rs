//! Writes every named fixture of `senc_testmesh::FIXTURES` as OBJ, plus `manifest.json`
//! (name, description, sizes, coordinate checksum), into a directory, for the offline
//! libigl scripts under `tools/` that compute the committed reference answers.
//!
//! `cargo run -p senc-geom --example export_fixtures -- OUT_DIR [NAME ...]`

use std::path::PathBuf;

use senc_geom::obj::write_obj;
use senc_testmesh::FIXTURES;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let Some(dir) = args.next().map(PathBuf::from) else {
        eprintln!("usage: export_fixtures OUT_DIR [NAME ...]");
        std::process::exit(2);
    };
    let only: Vec<String> = args.collect();
    std::fs::create_dir_all(&dir)?;
    let mut manifest = Vec::new();
    for f in FIXTURES.iter().filter(|f| only.is_empty() || only.iter().any(|n| n == f.name)) {
        let m = f.build()?;
        let path = dir.join(format!("{}.obj", f.name));
        write_obj(&path, m.positions(), m.faces())?;
        let checksum: f64 = m.positions().iter().map(|p| p.x + 2.0 * p.y + 3.0 * p.z).sum();
        manifest.push(serde_json::json!({
            "name": f.name,
            "description": f.description,
            "close_holes": f.close_holes,
            "n_vertices": m.n_vertices(),
            "n_faces": m.n_faces(),
            "boundary_loops": m.topology().boundary_loops().len(),
            "components": m.topology().n_components(),
            "signed_volume_m3": m.signed_volume(),
            "coordinate_checksum": checksum,
            "obj": path.file_name().map(|s| s.to_string_lossy().into_owned()),
        }));
        eprintln!("{}: {} faces -> {}", f.name, m.n_faces(), path.display());
    }
    std::fs::write(dir.join("manifest.json"), serde_json::to_string_pretty(&manifest)?)?;
    Ok(())
}
