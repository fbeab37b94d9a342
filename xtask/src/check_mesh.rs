//! `cargo xtask check-mesh`: validate a mesh and print its topology.

use std::path::Path;

use anyhow::{Context, Result};
use senc_geom::{close_holes, obj::read_obj, HoleSelection};

pub fn run(path: &Path, close: bool, json: bool) -> Result<()> {
    let mesh = read_obj(path).with_context(|| format!("reading {}", path.display()))?;
    let topo = mesh.topology();
    let loops: Vec<usize> = topo.boundary_loops().iter().map(|l| l.len()).collect();
    let closed = if close { Some(close_holes(&mesh, &HoleSelection::All)?) } else { None };
    if json {
        let v = serde_json::json!({
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "edges": topo.edges().len(),
            "boundary_loops": loops,
            "components": topo.n_components(),
            "closed_faces": closed.as_ref().map(|c| c.mesh().n_faces()),
            "closed_signed_volume_m3": closed.as_ref().map(|c| c.mesh().signed_volume()),
        });
        println!("{v}");
    } else {
        println!(
            "{}: {} vertices, {} faces, {} edges, {} components",
            path.display(),
            mesh.n_vertices(),
            mesh.n_faces(),
            topo.edges().len(),
            topo.n_components()
        );
        println!("boundary loops (vertex counts): {loops:?}");
        if let Some(c) = closed {
            println!("closed: {} faces, signed volume {:.6e} m³", c.mesh().n_faces(), c.mesh().signed_volume());
        }
    }
    Ok(())
}
