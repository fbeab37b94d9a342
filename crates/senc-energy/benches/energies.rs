//! Criterion benchmark: every term with its gradient on a seeded ≥ 10k-face garment (a
//! jittered 72×72-quad sheet, 10,368 faces) draped over a sphere, plus the total.

use criterion::{criterion_group, criterion_main, Criterion};

use senc_energy::{EnergyConfig, EnergyModel};
use senc_geom::Vec3;
use senc_testmesh::{bench_scene, BenchScene};

fn energies(c: &mut Criterion) {
    let BenchScene { rest, body, body_next, x } = bench_scene();
    assert!(rest.n_faces() >= 10_000);
    let x_t = rest.positions().to_vec();
    let mut config = EnergyConfig::default();
    // GIA is benchmarked in senc-gia; the repulsive baseline is on so that it is measured.
    config.self_collision.weight = 0.0;
    config.external_acceleration = [1.0, 0.0, 0.0];
    config.repulsion.weight = 1e-4;
    config.repulsion.threshold = 0.02;
    let model = EnergyModel::new(&rest, &config, Some(&body)).unwrap();
    let frame = model.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    let mut g = vec![Vec3::zeros(); x.len()];
    let mut group = c.benchmark_group(format!("energy_{}_faces", rest.n_faces()));
    group.bench_function("all_terms_with_gradient", |b| b.iter(|| frame.evaluate(&x, Some(&mut g)).unwrap().total));
    let mut no_rep = config.clone();
    no_rep.repulsion.weight = 0.0;
    let model2 = EnergyModel::new(&rest, &no_rep, Some(&body)).unwrap();
    let frame2 = model2.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    group.bench_function("hood_terms_with_gradient", |b| b.iter(|| frame2.evaluate(&x, Some(&mut g)).unwrap().total));
    group.bench_function("frame_setup_body_queries", |b| {
        b.iter(|| {
            model2.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap().inertial_target().map(|t| t.len())
        })
    });
    let mut h = frame2.hessian_pattern();
    group.bench_function("hessian_assembly", |b| b.iter(|| frame2.hessian(&x, &mut h).unwrap()));
    group.finish();
    let mut per = c.benchmark_group(format!("term_{}_faces", rest.n_faces()));
    let only = |f: &dyn Fn(&mut EnergyConfig)| {
        let mut c = no_rep.clone();
        f(&mut c);
        c
    };
    let cases: Vec<(&str, EnergyConfig)> = vec![
        (
            "stretching_gravity",
            only(&|c| {
                c.material.bending_stiffness = 0.0;
                c.inertia = false;
                c.external_acceleration = [0.0; 3];
            }),
        ),
        ("repulsion", config.clone()),
        (
            "stretching_bending_gravity",
            only(&|c| {
                c.inertia = false;
                c.external_acceleration = [0.0; 3];
            }),
        ),
        (
            "stretching_inertia_gravity",
            only(&|c| {
                c.material.bending_stiffness = 0.0;
                c.external_acceleration = [0.0; 3];
            }),
        ),
    ];
    for (name, cfg) in cases {
        let m = EnergyModel::new(&rest, &cfg, None).unwrap();
        let f = m.frame(&x_t, &x_t, None).unwrap();
        per.bench_function(name, |b| b.iter(|| f.evaluate(&x, Some(&mut g)).unwrap().total));
    }
    per.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(3));
    targets = energies
}
criterion_main!(benches);
