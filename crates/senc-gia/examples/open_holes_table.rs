//! The committed garment frames with each hole left open in turn (closed virtually inside
//! the workspace), against every hole fanned: one CSV row per frame and hole.
//! `cargo run --release -p senc-gia --example open_holes_table`.

use senc_geom::{close_holes, HoleSelection, TriMesh};
use senc_gia::{GiaOptions, GiaWorkspace};

fn frame(garment: &str, frame: u32) -> TriMesh {
    senc_testmesh::garment_frame(garment, frame).unwrap()
}

fn main() {
    let mut out = csv::Writer::from_writer(std::io::stdout());
    out.write_record([
        "frame",
        "open hole",
        "hole mean height (m)",
        "hole vertices",
        "volume (m³)",
        "all fanned (m³)",
        "virtual-fan pairs",
        "patches",
        "patches skipped",
    ])
    .unwrap();
    for (garment, f) in [
        ("tshirt", 20),
        ("tshirt", 60),
        ("tshirt", 90),
        ("skirt", 20),
        ("skirt", 50),
        ("skirt", 90),
        ("pants", 90),
        ("dress", 90),
    ] {
        let mesh = frame(garment, f);
        let all = close_holes(&mesh, &HoleSelection::All).unwrap();
        let closed = GiaWorkspace::new(&all).penetration(&all, &GiaOptions::default()).unwrap();
        for (k, lp) in mesh.topology().boundary_loops().iter().enumerate() {
            let y = lp.iter().map(|&v| mesh.positions()[v as usize].y).sum::<f64>() / lp.len() as f64;
            let c = close_holes(&mesh, &HoleSelection::AllExcept(vec![k])).unwrap();
            let p = GiaWorkspace::new(&c).penetration(&c, &GiaOptions::default()).unwrap();
            let d = &p.diagnostics;
            out.write_record([
                format!("{garment} {f}"),
                k.to_string(),
                format!("{y:.3}"),
                lp.len().to_string(),
                format!("{:.9e}", p.volume),
                format!("{:.9e}", closed.volume),
                d.virtual_fan_pairs.to_string(),
                d.patches.to_string(),
                d.patches_skipped.to_string(),
            ])
            .unwrap();
        }
    }
    out.flush().unwrap();
}
