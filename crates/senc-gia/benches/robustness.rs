//! Robustness run: random jittered and grid-snapped closed meshes (crumpled icospheres and
//! capped tubes, several crumpled through themselves), by default 100,000 of them
//! (`SENC_ROBUSTNESS_CASES` overrides). Counts panics (caught), NaN volumes or gradients,
//! negative volumes, and skipped patches (in all, and on the meshes not snapped to the
//! grid), and prints one JSON line.
//!
//! `cargo bench -p senc-gia --bench robustness`
//!
//! With `SENC_ROBUSTNESS_DUMP=DIR` it also writes the closed mesh of every case with a
//! negative volume or a dropped negative sum, of the first 300 cases whose winding probes
//! disagreed, of the first 300 with flat tangles, of the first 300 that were re-run on
//! jittered positions (`Diagnostics::perturbed_retries`), and of every 500th case to `DIR/case_NNNNNN.obj`, and one JSON line per
//! written case to `DIR/cases.jsonl` (our volume and diagnostics), for comparison with the
//! oracle (`reports/gia/robustness_oracle.py DIR`).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::{close_holes, HoleSelection, Vec3};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode};
use senc_testmesh::{icosphere, tube, Caps};
use std::io::Write;

fn main() {
    let n: usize = std::env::var("SENC_ROBUSTNESS_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let bases = [icosphere(Vec3::zeros(), 1.0, 1).unwrap(), tube(0.5, 1.5, 8, 4, Caps::Fan).unwrap()];
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    let (mut panics, mut nan, mut negative, mut positive, mut with_skips, mut triple) = (0, 0, 0, 0, 0, 0);
    let dump = std::env::var("SENC_ROBUSTNESS_DUMP").ok().map(std::path::PathBuf::from);
    let mut log = dump.as_ref().map(|d| {
        std::fs::create_dir_all(d).unwrap();
        std::fs::File::create(d.join("cases.jsonl")).unwrap()
    });
    let (mut unclosed, mut negative_sums, mut disagreements, mut n_disputed, mut n_retried) = (0, 0, 0, 0, 0);
    let (mut with_flat, mut n_flat_dumped, mut general_skips, mut perturbed) = (0, 0, 0, 0);
    let start = std::time::Instant::now();
    for case in 0..n {
        let base = &bases[case % 2];
        let amp: f64 = rng.random_range(0.0..0.8);
        let snap = rng.random_bool(0.4);
        let pos: Vec<Vec3> = base
            .positions()
            .iter()
            .map(|x| {
                let d =
                    Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                let y = x + d * amp;
                if snap {
                    y.map(|c| (c * 4.0).round() / 4.0)
                } else {
                    y
                }
            })
            .collect();
        let mode = if rng.random_bool(0.5) { GradientMode::Exact } else { GradientMode::FixedBarycentric };
        let run = std::panic::catch_unwind(|| {
            let mesh = base.with_positions(pos).ok()?;
            let closure = close_holes(&mesh, &HoleSelection::All).ok()?;
            let p = GiaWorkspace::new(&closure)
                .penetration(&closure, &GiaOptions { gradient: mode, ..Default::default() })
                .ok()?;
            Some((p, closure))
        });
        if let (Some(dir), Some(log), Ok(Some((p, closure)))) = (&dump, &mut log, &run) {
            let disputed = p.diagnostics.winding_ray_disagreements > 0 && n_disputed < 300;
            n_disputed += usize::from(disputed);
            let flat = p.diagnostics.flat_tangles > 0 && n_flat_dumped < 300;
            n_flat_dumped += usize::from(flat);
            let retried = p.diagnostics.perturbed_retries > 0 && n_retried < 300;
            n_retried += usize::from(retried);
            if p.volume < -1e-12 || case % 500 == 0 || disputed || flat || retried || p.diagnostics.negative_sums > 0 {
                let m = closure.mesh();
                senc_geom::obj::write_obj(dir.join(format!("case_{case:06}.obj")), m.positions(), m.faces()).unwrap();
                let d = serde_json::to_string(&p.diagnostics).unwrap();
                writeln!(log, "{{\"case\":{case},\"volume\":{:e},\"diagnostics\":{d}}}", p.volume).unwrap();
            }
        }
        let run = run.map(|r| r.map(|(p, _)| p));
        match run {
            Err(_) => panics += 1,
            Ok(None) => {}
            Ok(Some(p)) => {
                if !p.volume.is_finite() || p.gradient.iter().any(|g| g.iter().any(|c| !c.is_finite())) {
                    nan += 1;
                }
                if p.volume < -1e-12 {
                    negative += 1;
                }
                if p.volume > 0.0 {
                    positive += 1;
                }
                if p.diagnostics.patches_skipped > 0 {
                    with_skips += 1;
                    general_skips += usize::from(!snap);
                }
                unclosed += usize::from(p.diagnostics.unclosed_tangles > 0);
                negative_sums += p.diagnostics.negative_sums;
                disagreements += usize::from(p.diagnostics.winding_ray_disagreements > 0);
                with_flat += usize::from(p.diagnostics.flat_tangles > 0);
                perturbed += usize::from(p.diagnostics.perturbed_retries > 0 && p.diagnostics.patches_skipped == 0);
                if p.diagnostics.triple_points > 0 {
                    triple += 1;
                }
            }
        }
    }
    println!(
        "{{\"cases\":{n},\"panics\":{panics},\"nan\":{nan},\"negative\":{negative},\"with_volume\":{positive},\"resolved_by_perturbed_retries\":{perturbed},\"with_skipped_patches\":{with_skips},\"skipped_not_snapped\":{general_skips},\"with_triple_points\":{triple},\"with_unclosed_tangles\":{unclosed},\"negative_sums_dropped\":{negative_sums},\"with_ray_disagreements\":{disagreements},\"with_flat_tangles\":{with_flat},\"seconds\":{:.1}}}",
        start.elapsed().as_secs_f64()
    );
}
