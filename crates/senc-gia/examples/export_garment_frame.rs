//! Writes a committed garment frame (`tests/fixtures/garment_frames/`) as an OBJ, holes
//! open, for the oracle and the libigl timings:
//! `cargo run --release -p senc-gia --example export_garment_frame -- tshirt 20 /tmp/tshirt_0020.obj`.

use senc_geom::Vec3;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, garment, frame, out] = args.as_slice() else {
        eprintln!("usage: export_garment_frame GARMENT FRAME OUT.obj");
        std::process::exit(2);
    };
    let frame: u32 = frame.parse().expect("a frame number");
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/garment_frames");
    let faces: Vec<[u32; 3]> =
        rmp_serde::from_slice(&std::fs::read(format!("{dir}/{garment}_faces.msgpack")).expect("faces file"))
            .expect("faces");
    let pos: Vec<[f64; 3]> =
        rmp_serde::from_slice(&std::fs::read(format!("{dir}/{garment}_{frame:04}.msgpack")).expect("frame file"))
            .expect("positions");
    let pos: Vec<Vec3> = pos.into_iter().map(Vec3::from).collect();
    senc_geom::obj::write_obj(out, &pos, &faces).expect("write");
}
