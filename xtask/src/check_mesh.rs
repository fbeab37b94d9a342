//! `cargo xtask check-mesh`: validate a mesh and print its topology.

use std::path::PathBuf;

use anyhow::{Context, Result};
use senc_geom::remesh::RemeshConfig;
use senc_geom::{close_holes, obj::read_obj, HoleSelection};

/// Arguments of `cargo xtask check-mesh`.
#[derive(clap::Args)]
pub struct Args {
    /// The OBJ file.
    pub mesh: PathBuf,
    /// Close every boundary loop with a centroid fan.
    #[arg(long)]
    pub close_holes: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Reads the mesh and prints its topology and triangle quality.
pub fn run(args: Args) -> Result<()> {
    let (path, close, json) = (args.mesh.as_path(), args.close_holes, args.json);
    let mesh = read_obj(path).with_context(|| format!("reading {}", path.display()))?;
    let topo = mesh.topology();
    let loops: Vec<usize> = topo.boundary_loops().iter().map(|l| l.len()).collect();
    let quality: Vec<f64> = (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            senc_geom::remesh::quality(&a, &b, &c)
        })
        .collect();
    let worst = quality.iter().copied().fold(1.0, f64::min);
    let thin = quality.iter().filter(|&&q| q < RemeshConfig::default().min_quality).count();
    let closed = if close { Some(close_holes(&mesh, &HoleSelection::All)?) } else { None };
    if json {
        let v = serde_json::json!({
            "vertices": mesh.n_vertices(),
            "faces": mesh.n_faces(),
            "edges": topo.edges().len(),
            "boundary_loops": loops,
            "components": topo.n_components(),
            "worst_triangle_quality": worst,
            "thin_triangles": thin,
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
        println!(
            "triangle quality (1 = equilateral): worst {worst:.3}, {thin} below {}{}",
            RemeshConfig::default().min_quality,
            if thin > 0 { " (thin triangles make cloth energies stiff; `cargo xtask fit` removes them)" } else { "" }
        );
        if let Some(c) = closed {
            println!("closed: {} faces, signed volume {:.6e} m³", c.mesh().n_faces(), c.mesh().signed_volume());
        }
    }
    Ok(())
}
