//! Penetration volume + gradient on a ≥ 10k-face garment-like mesh (sleeve pressed into a
//! torso, holes closed by fans), with a reused workspace (BVH refit) as in training.

use criterion::{criterion_group, criterion_main, Criterion};
use senc_geom::shapes::garment_benchmark;
use senc_geom::{close_holes, HoleSelection};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode};

fn bench(c: &mut Criterion) {
    let closure = close_holes(&garment_benchmark().unwrap(), &HoleSelection::All).unwrap();
    for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
        let opts = GiaOptions { gradient: mode, ..Default::default() };
        let mut ws = GiaWorkspace::new(&closure);
        c.bench_function(&format!("volume_and_gradient/{mode:?}"), |b| {
            b.iter(|| ws.penetration(&closure, &opts).unwrap())
        });
    }
}

criterion_group! { name = benches; config = Criterion::default().sample_size(20); targets = bench }
criterion_main!(benches);
