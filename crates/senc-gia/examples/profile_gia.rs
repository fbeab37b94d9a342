//! Where the time of one penetration query goes, phase by phase, on the garment benchmark
//! mesh: `cargo run --release -p senc-gia --example profile_gia` (`SENC_PROFILE_FRAME=tshirt_0020`
//! for a committed garment frame instead, all holes fanned).
//!
//! `profile_gia detect N` (or `analyse N`, `total N`, `volume N`: a warm call without the
//! area's gradient, as the self-collision energy makes it, `first N`: a fresh workspace's first
//! query on the topology seen before, `build N`: a fresh mesh and its intersector, whose
//! search tree is built, `mesh N`: a fresh mesh and closure of the same faces, `new N`: that
//! and a fresh workspace's first query on it, whose search tree is built) runs only that
//! phase N times and
//! prints nothing else, for CPU-time measurements with `perf stat -e task-clock` on a busy
//! machine.

use std::time::Instant;

use senc_geom::cut::CutMesh;
use senc_geom::intersect::SelfIntersector;
use senc_geom::{close_holes, HoleSelection};
use senc_gia::{GiaOptions, GiaWorkspace, Gradients};
use senc_testmesh::garment_benchmark;

fn main() {
    let mesh = match std::env::var("SENC_PROFILE_FRAME") {
        Ok(name) => {
            let (garment, frame) = name.split_once('_').expect("GARMENT_NNNN");
            senc_testmesh::garment_frame(garment, frame.parse().expect("a frame number")).unwrap()
        }
        Err(_) => garment_benchmark().unwrap(),
    };
    let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
    let mesh = closure.mesh();
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 3 {
        let n: usize = args[2].parse().expect("a repeat count");
        let mut ix = SelfIntersector::new(mesh).with_groups(closure.fan_groups());
        let inter = ix.find(mesh);
        let mut ws = GiaWorkspace::new(&closure);
        let mut times = Vec::with_capacity(n);
        for _ in 0..n {
            let t = Instant::now();
            match args[1].as_str() {
                "detect" => drop(std::hint::black_box(ix.find(mesh))),
                "build" => {
                    let fresh = senc_geom::TriMesh::new(mesh.positions().to_vec(), mesh.faces().to_vec()).unwrap();
                    let _ = fresh.topology().edge_faces();
                    drop(std::hint::black_box(SelfIntersector::new(&fresh)));
                }
                "mesh" | "new" => {
                    let fresh = senc_geom::TriMesh::new(mesh.positions().to_vec(), mesh.faces().to_vec()).unwrap();
                    let c = close_holes(&fresh, &HoleSelection::None).unwrap();
                    if args[1] == "new" {
                        drop(std::hint::black_box(
                            GiaWorkspace::new(&c).penetration(&c, &GiaOptions::default()).unwrap(),
                        ));
                    } else {
                        drop(std::hint::black_box(c));
                    }
                }
                "analyse" => drop(std::hint::black_box(ws.analyse(&closure, &inter, &GiaOptions::default()))),
                "first" => drop(std::hint::black_box(
                    GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap(),
                )),
                "volume" => {
                    let opts = GiaOptions { gradients: Gradients::Volume, ..Default::default() };
                    drop(std::hint::black_box(ws.penetration(&closure, &opts).unwrap()))
                }
                _ => drop(std::hint::black_box(ws.penetration(&closure, &GiaOptions::default()).unwrap())),
            }
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        if n > 0 {
            println!("{} x{n}: min {:.3} ms, median {:.3} ms", args[1], times[0], times[n / 2]);
        }
        return;
    }
    let reps = 20;
    // The first call's parts: the intersector's build (BVH, rings, disk patches) on a mesh
    // whose topology no intersector has seen, and a fresh workspace's whole first query, on
    // such a topology and on the topology seen before (whose search tree is shared).
    let fresh = |n: usize| -> Vec<senc_geom::Closure> {
        (0..n)
            .map(|_| {
                let m = senc_geom::TriMesh::new(mesh.positions().to_vec(), mesh.faces().to_vec()).unwrap();
                close_holes(&m, &HoleSelection::None).unwrap()
            })
            .collect()
    };
    let meshes = fresh(reps);
    let t = Instant::now();
    for c in &meshes {
        std::hint::black_box(SelfIntersector::new(c.mesh()));
    }
    let build = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let meshes = fresh(reps);
    let t = Instant::now();
    for c in &meshes {
        std::hint::black_box(GiaWorkspace::new(c).penetration(c, &GiaOptions::default()).unwrap());
    }
    let first_new = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap());
    }
    let first = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    println!(
        "first call {first_new:.2} ms on a new topology (of which SelfIntersector::new {build:.2} ms), {first:.2} ms on a topology seen before"
    );
    let mut ix = SelfIntersector::new(mesh).with_groups(closure.fan_groups());
    let inter = ix.find(mesh);
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(ix.find(mesh));
    }
    let detect = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(CutMesh::new(mesh, &inter));
    }
    let cut = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let mut ws = GiaWorkspace::new(&closure);
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(ws.analyse(&closure, &inter, &GiaOptions::default()));
    }
    let analyse = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let t = Instant::now();
    let mut pen = None;
    for _ in 0..reps {
        pen = Some(ws.penetration(&closure, &GiaOptions::default()).unwrap());
    }
    let total = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let pen = pen.unwrap();
    println!(
        "faces {} candidate pairs {} intersecting {} | detect {detect:.2} ms, cut {cut:.2} ms, analyse (cut+paths+fill+volume+gradient) {analyse:.2} ms, total {total:.2} ms | {} patches, {} rays | volume {:.10e} m³",
        mesh.n_faces(),
        inter.n_candidate_pairs,
        inter.segments.len(),
        pen.diagnostics.patches,
        pen.diagnostics.winding_rays,
        pen.volume
    );
}
