//! Penetration volume + gradient with a reused workspace (BVH refit) as in training: the
//! ≥ 10k-face garment-like benchmark mesh (sleeve pressed into a torso, holes closed by fans)
//! and simulated garment frames (a t-shirt: 12,772 closed faces, 285 crossing pairs, 46
//! triple points; a dress: 15,618 closed faces, 623 crossing pairs), by winding numbers
//! (default) and by SENC's smaller-side rule, in both gradient modes; and the t-shirt frame
//! with its neck left open (closed virtually inside the workspace). First calls come in two
//! kinds: a fresh workspace on a topology seen before (`first_call`: the search tree built
//! for that topology is shared) and on a topology never seen (`first_call_new_topology`:
//! the tree is built in the call).

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use senc_geom::{close_holes, HoleSelection, TriMesh};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, VolumeRule};
use senc_testmesh::garment_benchmark;

fn tshirt_frame() -> TriMesh {
    senc_testmesh::garment_frame("tshirt", 20).unwrap()
}

fn bench(c: &mut Criterion) {
    let dress = senc_testmesh::garment_frame("dress", 90).unwrap();
    for (mesh_name, mesh) in
        [("garment_benchmark", garment_benchmark().unwrap()), ("tshirt_0020", tshirt_frame()), ("dress_0090", dress)]
    {
        let closure = close_holes(&mesh, &HoleSelection::All).unwrap();
        for rule in [VolumeRule::Winding, VolumeRule::SmallerSide] {
            for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
                let opts = GiaOptions { gradient: mode, rule, ..Default::default() };
                let mut ws = GiaWorkspace::new(&closure);
                c.bench_function(&format!("{mesh_name}/{rule:?}/{mode:?}"), |b| {
                    b.iter(|| ws.penetration(&closure, &opts).unwrap())
                });
            }
        }
        // The first call on a fresh workspace for a topology seen before (the search tree is
        // shared; the boxes are refit).
        c.bench_function(&format!("{mesh_name}/first_call"), |b| {
            b.iter(|| GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap())
        });
        // The first call on a topology never seen (tree build, ring and patch analysis); the
        // mesh and its closure are made outside the timing.
        c.bench_function(&format!("{mesh_name}/first_call_new_topology"), |b| {
            b.iter_batched(
                || {
                    let fresh = TriMesh::new(mesh.positions().to_vec(), mesh.faces().to_vec()).unwrap();
                    close_holes(&fresh, &HoleSelection::All).unwrap()
                },
                |closure| GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap(),
                BatchSize::SmallInput,
            )
        });
    }
    // The t-shirt with its neck (the highest boundary loop) left open: closed virtually.
    let mesh = tshirt_frame();
    let loops = mesh.topology().boundary_loops();
    let mean_y = |l: &Vec<u32>| l.iter().map(|&v| mesh.positions()[v as usize].y).sum::<f64>() / l.len() as f64;
    let neck = (0..loops.len()).max_by(|&a, &b| mean_y(&loops[a]).total_cmp(&mean_y(&loops[b]))).unwrap();
    let closure = close_holes(&mesh, &HoleSelection::AllExcept(vec![neck])).unwrap();
    let mut ws = GiaWorkspace::new(&closure);
    c.bench_function("tshirt_0020_neck_open/Winding/Exact", |b| {
        b.iter(|| ws.penetration(&closure, &GiaOptions::default()).unwrap())
    });
    c.bench_function("tshirt_0020_neck_open/first_call", |b| {
        b.iter(|| GiaWorkspace::new(&closure).penetration(&closure, &GiaOptions::default()).unwrap())
    });
}

criterion_group! { name = benches; config = Criterion::default().sample_size(20); targets = bench }
criterion_main!(benches);
