//! Self-intersection detection on ≥ 10k-face meshes, with and without crossings, one-shot
//! (BVH build) and with a reused, refit BVH.

use criterion::{criterion_group, criterion_main, Criterion};
use senc_geom::intersect::{self_intersections, SelfIntersector};
use senc_geom::{close_holes, HoleSelection, Vec3};
use senc_testmesh::{garment_benchmark, icosphere};

fn bench(c: &mut Criterion) {
    let garment = close_holes(&garment_benchmark().unwrap(), &HoleSelection::All).unwrap();
    let sphere = icosphere(Vec3::zeros(), 0.3, 5).unwrap(); // 20,480 faces, no crossing
    for (name, mesh) in [("garment_13k_crossing", garment.mesh()), ("icosphere_20k_clean", &sphere)] {
        c.bench_function(&format!("detect_build/{name}"), |b| b.iter(|| self_intersections(mesh)));
        let mut ix = SelfIntersector::new(mesh);
        c.bench_function(&format!("detect_refit/{name}"), |b| b.iter(|| ix.find(mesh)));
    }
}

criterion_group! { name = benches; config = Criterion::default().sample_size(20); targets = bench }
criterion_main!(benches);
