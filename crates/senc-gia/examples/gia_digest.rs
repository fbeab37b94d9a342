//! Every output of the penetration query on the committed garment frames and the garment
//! benchmark, printed in full (`{:?}`: shortest round-trip floats, so two builds print the
//! same text exactly when their results are equal bit for bit), for comparing two builds of
//! the library: `cargo run --release -p senc-gia --example gia_digest > a.txt`, then the
//! same with the other build and `cmp a.txt b.txt` (also with `RAYON_NUM_THREADS=1`).
//!
//! Cases: the t-shirt and skirt frames with holes fanned and left open, each a fresh
//! workspace's first call, a second (warm) call, and a workspace made on frame 20 called on
//! the frame (a tree built at other positions, refit); both volume rules and both gradient
//! modes on frame 20; the garment benchmark.

use senc_geom::{close_holes, Closure, HoleSelection, TriMesh};
use senc_gia::{GiaOptions, GiaWorkspace, GradientMode, VolumeRule};
use senc_testmesh::{garment_benchmark, garment_frame};

fn frame(garment: &str, frame: u32) -> TriMesh {
    garment_frame(garment, frame).unwrap()
}

fn print(name: &str, closure: &Closure, ws: &mut GiaWorkspace, opts: &GiaOptions) {
    let p = ws.penetration(closure, opts).unwrap();
    println!("{name}: volume {:e} area {:e}\n{p:?}", p.volume, p.area);
}

fn main() {
    let default = GiaOptions::default();
    for (garment, frames) in [("tshirt", [20, 60, 90]), ("skirt", [20, 50, 90])] {
        for (holes, selection) in [("fanned", HoleSelection::All), ("open", HoleSelection::None)] {
            let base = close_holes(&frame(garment, 20), &selection).unwrap();
            let mut reused = GiaWorkspace::new(&base);
            for f in frames {
                let closure = close_holes(&frame(garment, f), &selection).unwrap();
                let mut ws = GiaWorkspace::new(&closure);
                print(&format!("{garment} {f} {holes} first"), &closure, &mut ws, &default);
                print(&format!("{garment} {f} {holes} warm"), &closure, &mut ws, &default);
                print(&format!("{garment} {f} {holes} tree of frame 20"), &closure, &mut reused, &default);
            }
            for rule in [VolumeRule::Winding, VolumeRule::SmallerSide] {
                for mode in [GradientMode::Exact, GradientMode::FixedBarycentric] {
                    let opts = GiaOptions { gradient: mode, rule, ..Default::default() };
                    print(&format!("{garment} 20 {holes} {rule:?} {mode:?}"), &base, &mut reused, &opts);
                }
            }
        }
    }
    let closure = close_holes(&garment_benchmark().unwrap(), &HoleSelection::All).unwrap();
    let mut ws = GiaWorkspace::new(&closure);
    print("garment_benchmark first", &closure, &mut ws, &default);
    print("garment_benchmark warm", &closure, &mut ws, &default);
}
