//! The fast paths against the term-by-term ones they replace: the fused gradient pass of
//! `FrameEnergy::evaluate` against each term's own `eval` (and central finite differences),
//! the parallel Hessian assembly against the serial element-by-element one, and the
//! fixed-size PSD projection's properties.

use nalgebra::{Matrix3, SMatrix, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use senc_energy::hessian::project_spd;
use senc_energy::{assert_gradient, EnergyConfig, EnergyModel};
use senc_geom::{TriMesh, Vec3};
use senc_testmesh::{sheet, sphere};

fn perturb(x: &[Vec3], amp: f64, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    x.iter()
        .map(|p| p + Vec3::new(rng.random_range(-amp..amp), rng.random_range(-amp..amp), rng.random_range(-amp..amp)))
        .collect()
}

/// A sheet over a sphere with every local term on (and a compressed region so that some
/// stretching element Hessians are indefinite).
fn scene() -> (TriMesh, TriMesh, EnergyConfig, Vec<Vec3>, Vec<Vec3>, Vec<Vec3>) {
    let body = sphere(Vec3::zeros(), 0.3, 12, 16);
    let rest = sheet(8, 0.4, 0.301, 0.2, 5);
    let x_t = rest.positions().to_vec();
    let body_next: Vec<Vec3> = body.positions().iter().map(|p| p + Vec3::new(0.002, 0.001, 0.0)).collect();
    let x: Vec<Vec3> = perturb(&x_t, 0.004, 8).iter().map(|p| Vec3::new(0.8 * p.x, p.y, p.z)).collect();
    let mut c = EnergyConfig::default();
    c.self_collision.weight = 0.0;
    c.external_acceleration = [3.0, 0.0, -1.0];
    c.bending_rest = senc_energy::BendingRest::RestMesh;
    (rest, body, c, x_t, x, body_next)
}

#[test]
fn fused_gradient_equals_term_by_term_and_finite_differences() {
    let (rest, body, c, x_t, x, body_next) = scene();
    let model = EnergyModel::new(&rest, &c, Some(&body)).unwrap();
    let prev = perturb(&x_t, 1e-3, 3);
    let frame = model.frame(&x_t, &prev, Some((body.positions(), &body_next))).unwrap();
    let mut g = vec![Vec3::new(7.0, 7.0, 7.0); x.len()]; // overwritten, not added to
    let fused = frame.evaluate(&x, Some(&mut g)).unwrap();
    let value = frame.evaluate(&x, None).unwrap();
    assert_eq!(fused, value, "breakdown with and without gradient must be identical");
    assert!(fused.get("collision").unwrap() > 0.0 && fused.get("friction").unwrap() > 0.0);
    // Term by term, each through its own eval and scatter.
    let mut reference = vec![Vec3::zeros(); x.len()];
    for name in model.term_names() {
        let mut only = c.clone();
        only.material.bending_stiffness = if name == "bending" { c.material.bending_stiffness } else { 0.0 };
        only.inertia = name == "inertia";
        only.external_acceleration = if name == "external" { c.external_acceleration } else { [0.0; 3] };
        only.collision.weight = if name == "collision" { c.collision.weight } else { 0.0 };
        only.friction.mu = if name == "friction" { c.friction.mu } else { 0.0 };
        // Stretching and gravity are always present: their gradients are subtracted below.
        let m = EnergyModel::new(&rest, &only, Some(&body)).unwrap();
        let f = m.frame(&x_t, &prev, Some((body.positions(), &body_next))).unwrap();
        let mut gt = vec![Vec3::zeros(); x.len()];
        let b = f.evaluate(&x, Some(&mut gt)).unwrap();
        assert_eq!(b.get(name), fused.get(name), "{name}");
        if name != "stretching" && name != "gravity" {
            let mut base = only.clone();
            base.material.bending_stiffness = 0.0;
            base.inertia = false;
            base.external_acceleration = [0.0; 3];
            base.collision.weight = 0.0;
            base.friction.mu = 0.0;
            let mb = EnergyModel::new(&rest, &base, Some(&body)).unwrap();
            let fb = mb.frame(&x_t, &prev, Some((body.positions(), &body_next))).unwrap();
            let mut g0 = vec![Vec3::zeros(); x.len()];
            fb.evaluate(&x, Some(&mut g0)).unwrap();
            gt.iter_mut().zip(&g0).for_each(|(a, b)| *a -= b);
        } else if name == "stretching" {
            // Stretching + gravity model: remove gravity (−m g per vertex).
            let gvec = Vec3::from(c.gravity);
            gt.iter_mut().zip(model.masses()).for_each(|(a, m)| *a += gvec * *m);
        } else {
            continue;
        }
        reference.iter_mut().zip(&gt).for_each(|(r, t)| *r += t);
    }
    let gvec = Vec3::from(c.gravity);
    reference.iter_mut().zip(model.masses()).for_each(|(r, m)| *r -= gvec * *m);
    let scale = g.iter().map(|v| v.amax()).fold(0.0, f64::max);
    let err = g.iter().zip(&reference).map(|(a, b)| (a - b).amax()).fold(0.0, f64::max);
    assert!(err <= 1e-9 * scale, "fused gradient differs from the sum of terms: {err:e} (scale {scale:e})");
    let mut e = |y: &[Vec3]| frame.evaluate(y, None).unwrap().total;
    assert_gradient!(e, &x, &g, h = 1e-7, rel = 1e-4);
}

#[test]
fn evaluation_is_deterministic_across_thread_counts() {
    let (rest, body, c, x_t, x, body_next) = scene();
    let model = EnergyModel::new(&rest, &c, Some(&body)).unwrap();
    let frame = model.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut g = vec![Vec3::zeros(); x.len()];
            let b = frame.evaluate(&x, Some(&mut g)).unwrap();
            let mut h = frame.hessian_pattern();
            frame.hessian(&x, &mut h).unwrap();
            let v = vec![Vec3::new(1.0, -2.0, 0.5); x.len()];
            let mut hv = vec![Vec3::zeros(); x.len()];
            h.mul(&v, &mut hv);
            (b, g, hv)
        })
    };
    let one = run(1);
    for t in [2, 3] {
        assert_eq!(one, run(t), "result changed with {t} threads");
    }
}

#[test]
fn parallel_hessian_equals_serial_assembly() {
    let (rest, body, c, x_t, x, body_next) = scene();
    let model = EnergyModel::new(&rest, &c, Some(&body)).unwrap();
    let frame = model.frame(&x_t, &x_t, Some((body.positions(), &body_next))).unwrap();
    let mut hp = frame.hessian_pattern();
    let mut hs = frame.hessian_pattern();
    frame.hessian(&x, &mut hp).unwrap();
    frame.hessian_serial(&x, &mut hs).unwrap();
    let n = x.len() as u32;
    let mut scale: f64 = 0.0;
    let mut err: f64 = 0.0;
    let mut blocks = 0;
    for i in 0..n {
        for j in 0..n {
            if let (Some(a), Some(b)) = (hp.block(i, j), hs.block(i, j)) {
                scale = scale.max(b.amax());
                err = err.max((a - b).amax());
                blocks += 1;
            }
        }
    }
    assert_eq!(blocks, hp.n_blocks());
    assert!(scale > 0.0);
    assert!(err <= 1e-12 * scale, "parallel assembly differs: {err:e} (scale {scale:e})");
}

#[test]
fn fixed_size_projection_is_psd_and_keeps_psd_input() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for trial in 0..50 {
        let a = SMatrix::<f64, 9, 9>::from_fn(|_, _| rng.random_range(-1.0..1.0));
        // Odd trials: PSD input (AᵀA), left unchanged; even: indefinite, projected.
        let m = if trial % 2 == 1 { a.transpose() * a } else { a + a.transpose() };
        let mut h = [[Matrix3::zeros(); 3]; 3];
        for k in 0..3 {
            for l in 0..3 {
                h[k][l] = m.fixed_view::<3, 3>(3 * k, 3 * l).into_owned();
            }
        }
        let before = h;
        project_spd(&mut h);
        let mut p = SMatrix::<f64, 9, 9>::zeros();
        for k in 0..3 {
            for l in 0..3 {
                p.fixed_view_mut::<3, 3>(3 * k, 3 * l).copy_from(&h[k][l]);
            }
        }
        let eig_in = SymmetricEigen::new(m).eigenvalues;
        let eig_out = SymmetricEigen::new(p).eigenvalues;
        let tol = 1e-12 * m.amax();
        assert!(eig_out.iter().all(|&l| l >= -tol), "projection left a negative eigenvalue");
        assert!((p - p.transpose()).amax() <= tol, "projection is not symmetric");
        if eig_in.iter().all(|&l| l >= 0.0) {
            assert_eq!(h, before, "a PSD matrix must be left unchanged");
        } else {
            // The positive part of the spectrum is kept: trace(P) = Σ max(λ, 0).
            let kept: f64 = eig_in.iter().map(|l| l.max(0.0)).sum();
            assert!((p.trace() - kept).abs() <= 1e-10 * kept.max(1.0));
        }
    }
}

#[test]
fn reduced_projection_equals_full_projection_on_translation_invariant_matrices() {
    use senc_energy::hessian::project_spd_translation_invariant;
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut projected = 0;
    for trial in 0..50 {
        // H = Bᵀ A B with B the edge-vector map (x0 − x2, x1 − x2): translation invariant.
        let a = SMatrix::<f64, 6, 6>::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let a = if trial % 5 == 0 { a.transpose() * a } else { a + a.transpose() };
        let mut b = SMatrix::<f64, 6, 9>::zeros();
        for r in 0..3 {
            b[(r, r)] = 1.0;
            b[(r, 6 + r)] = -1.0;
            b[(3 + r, 3 + r)] = 1.0;
            b[(3 + r, 6 + r)] = -1.0;
        }
        let m = b.transpose() * a * b;
        let mut full = [[Matrix3::zeros(); 3]; 3];
        for k in 0..3 {
            for l in 0..3 {
                full[k][l] = m.fixed_view::<3, 3>(3 * k, 3 * l).into_owned();
            }
        }
        let mut reduced = full;
        project_spd(&mut full);
        project_spd_translation_invariant(&mut reduced);
        let tol = 1e-12 * m.amax();
        for k in 0..3 {
            for l in 0..3 {
                let err = (full[k][l] - reduced[k][l]).amax();
                assert!(err <= tol, "trial {trial}: block ({k}, {l}) differs by {err:e}");
            }
        }
        projected += usize::from(SymmetricEigen::new(a).eigenvalues.iter().any(|&l| l < 0.0));
    }
    assert!(projected >= 30, "most trials must need a projection ({projected})");
}
