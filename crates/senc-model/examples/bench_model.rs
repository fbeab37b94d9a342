//! `cargo run -p senc-model --example bench_model -- [--reps N] [--quick] [--export STEM]`:
//! times graph building (5k and 20k cloth vertices), the network at HOOD size and at the small
//! CPU size on the t-shirt-sized scene (inference and forward + backward), and the main
//! operations of one message-passing step. `--export STEM` also writes the t-shirt graph for
//! `python tools/bench_torch.py --graph STEM`. Runs in the dev profile (opt-level 2), which
//! shares the workspace's one build.

use std::path::PathBuf;

use senc_model::bench::{bench_graph, bench_network, bench_ops, export_graph, tshirt_scene};
use senc_model::{EdgeType, GraphConfig, GraphInputs, ModelConfig};

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut reps = 3;
    let mut quick = false;
    let mut export: Option<PathBuf> = None;
    let mut k = 0;
    while k < args.len() {
        match args[k].as_str() {
            "--reps" => {
                k += 1;
                reps = args.get(k).and_then(|s| s.parse().ok()).unwrap_or(reps);
            }
            "--quick" => quick = true,
            "--export" => {
                k += 1;
                export = args.get(k).map(PathBuf::from);
            }
            other => {
                eprintln!("error: unknown argument {other}; expected --reps N, --quick, --export STEM");
                std::process::exit(2);
            }
        }
        k += 1;
    }
    println!("threads: rayon {}; load average at start: {}", rayon::current_num_threads(), load());

    println!("\n## graph building (1.5 cm spacing, SMPL-sized sphere body, median of {reps})");
    for n in [71, 142] {
        let (nc, counts, secs, st) = bench_graph(n, reps);
        println!(
            "cloth {nc:6} | edges mesh {:6} body {:6} self {:6} | {:7.2} ms (nodes {:.2}, mesh {:.2}, body {:.2}, self {:.2})",
            counts[0],
            counts[1],
            counts[2],
            secs * 1e3,
            st.nodes * 1e3,
            st.mesh * 1e3,
            st.body * 1e3,
            st.self_collision * 1e3
        );
    }

    let scene = tshirt_scene();
    let (graph, bt) = GraphInputs::build_timed(&scene.frame(), &GraphConfig::default()).expect("valid scene");
    let build = bt.nodes + bt.mesh + bt.body + bt.self_collision;
    println!(
        "\n## t-shirt-sized graph: {} cloth + {} body nodes; edges mesh {} body {} self {}; build {:.1} ms",
        graph.n_cloth,
        graph.n_body,
        graph.edge_set(EdgeType::Mesh).len(),
        graph.edge_set(EdgeType::Body).len(),
        graph.edge_set(EdgeType::SelfCollision).len(),
        build * 1e3
    );
    if let Some(stem) = &export {
        export_graph(&graph, stem).expect("export the graph");
        println!("exported to {}.json", stem.display());
    }

    let mut configs = vec![("small-cpu (32, 4 blocks, 1 hidden)", ModelConfig::small_cpu())];
    configs.push(("hood, 1 block (128, 2 hidden)", ModelConfig::hood().with_blocks(1)));
    if !quick {
        configs.push(("hood (128, 15 blocks, 2 hidden)", ModelConfig::hood()));
    }
    println!("\n## network (median of {reps}); load {}", load());
    for (label, config) in &configs {
        let t = bench_network(label, config, &graph, reps);
        println!(
            "{:36} params {:8} | upload {:7.1} ms | forward {:8.1} ms | forward+backward {:8.1} ms | fps incl. graph {:.1}",
            t.label,
            t.params,
            t.upload * 1e3,
            t.forward * 1e3,
            t.forward_backward * 1e3,
            1.0 / (build + t.upload + t.forward)
        );
    }

    println!("\n## operations of one step on the mesh edges, latent 128 (median of {reps}); load {}", load());
    for (name, fwd, fb) in bench_ops(&graph, 128, reps) {
        println!("{name:40} | forward {:8.2} ms | forward+backward {:8.2} ms", fwd * 1e3, fb * 1e3);
    }
    println!("\nload average at end: {}", load());
}
