//! Process CPU time per evaluation of the benchmark's HOOD terms, split by pass, so that the
//! cost can be compared on a loaded machine (CPU time barely depends on other processes,
//! wall time does). Run: `cargo run --release -p senc-energy --example energy_profile`.

use std::time::Instant;

use senc_energy::{EnergyConfig, EnergyModel};
use senc_geom::Vec3;
use senc_testmesh::{bench_scene, BenchScene};

/// Process CPU time (user + system, all threads) in seconds, from `/proc/self/stat`.
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = s.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 =
        f.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0) + f.get(12).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}

fn measure(name: &str, n: usize, mut f: impl FnMut()) {
    f();
    let (c0, w0) = (cpu_seconds(), Instant::now());
    for _ in 0..n {
        f();
    }
    let (cpu, wall) = (cpu_seconds() - c0, w0.elapsed().as_secs_f64());
    println!("{name:32} cpu {:8.3} ms/iter   wall {:8.3} ms/iter", 1e3 * cpu / n as f64, 1e3 * wall / n as f64);
}

fn main() {
    let BenchScene { rest, body, body_next, x } = bench_scene();
    let x_t = rest.positions().to_vec();
    let mut config = EnergyConfig::default();
    config.self_collision.weight = 0.0;
    config.external_acceleration = [1.0, 0.0, 0.0];
    let n: usize = std::env::var("N").ok().and_then(|v| v.parse().ok()).unwrap_or(300);
    let model = EnergyModel::new(&rest, &config, Some(&body)).unwrap();
    let frame = model.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    let mut g = vec![Vec3::zeros(); x.len()];
    measure("hood_terms_with_gradient", n, || {
        frame.evaluate(&x, Some(&mut g)).unwrap();
    });
    let mut c = config.clone();
    c.material.bending_stiffness = 0.0;
    c.inertia = false;
    c.external_acceleration = [0.0; 3];
    let m = EnergyModel::new(&rest, &c, None).unwrap();
    let f = m.frame(&x_t, &x_t, None).unwrap();
    measure("stretching_gravity", n, || {
        f.evaluate(&x, Some(&mut g)).unwrap();
    });
    c.material.bending_stiffness = config.material.bending_stiffness;
    let m = EnergyModel::new(&rest, &c, None).unwrap();
    let f = m.frame(&x_t, &x_t, None).unwrap();
    measure("stretching_bending_gravity", n, || {
        f.evaluate(&x, Some(&mut g)).unwrap();
    });
    {
        use senc_energy::rest::RestState;
        use senc_energy::scatter::Scatter;
        use senc_energy::terms::bending::Bending;
        use senc_energy::terms::stretching::Stretching;
        use std::sync::Arc;
        let state = Arc::new(RestState::new(&rest));
        let nv = rest.n_vertices();
        let st = Stretching::new(Arc::clone(&state), Arc::new(Scatter::new(nv, &state.faces)), 2e4, 4e4, 5e-4);
        let hv: Vec<[u32; 4]> = state.hinges.iter().map(|h| h.vertices).collect();
        let sc = Scatter::new(nv, &hv);
        let be = Bending::new(Arc::new(state.hinges.clone()), Arc::new(sc.clone()), 4e-5, false);
        let mut fb = vec![Vec3::zeros(); 3 * st.n_faces()];
        let mut hb = vec![Vec3::zeros(); 4 * be.n_hinges()];
        measure("stretching_element_pass", n, || {
            st.element_gradients(&x, &mut fb);
        });
        measure("bending_element_pass", n, || {
            be.element_gradients(&x, &mut hb);
        });
        measure("bending_energy_only", n, || {
            be.eval(&x, None);
        });
        measure("bending_gather", n, || sc.add_flat(&hb, 1.0, &mut g));
    }
    let mut h = frame.hessian_pattern();
    measure("hessian_assembly", n / 30 + 1, || frame.hessian(&x, &mut h).unwrap());
    let mut rc = config.clone();
    rc.repulsion.weight = 1e-4;
    rc.repulsion.threshold = 0.02;
    let m = EnergyModel::new(&rest, &rc, None).unwrap();
    let f = m.frame(&x_t, &x_t, None).unwrap();
    measure("all_with_repulsion", n / 10 + 1, || {
        f.evaluate(&x, Some(&mut g)).unwrap();
    });
    let mb = EnergyModel::new(&rest, &rc, Some(&body)).unwrap();
    let fb = mb.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    measure("all_with_repulsion_and_body", n / 10 + 1, || {
        fb.evaluate(&x, Some(&mut g)).unwrap();
    });
    let rep = senc_energy::terms::repulsion::Repulsion::new(rest.topology_arc(), 1e-4, 0.02);
    println!("repulsion: {} non-adjacent pairs", rep.pairs(&x).len());
    measure("repulsion_eval_with_gradient", n / 10 + 1, || {
        rep.eval(&x, Some(&mut g));
    });
    measure("radius_pairs_only (senc-geom)", n / 10 + 1, || {
        senc_geom::neighbors::radius_pairs(&x, 0.02);
    });
}
