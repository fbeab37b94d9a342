//! Writes a committed garment frame (`tests/fixtures/garment_frames/`) as an OBJ, holes
//! open, for the oracle and the libigl timings:
//! `cargo run --release -p senc-gia --example export_garment_frame -- tshirt 20 /tmp/tshirt_0020.obj`.

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, garment, frame, out] = args.as_slice() else {
        eprintln!("usage: export_garment_frame GARMENT FRAME OUT.obj");
        std::process::exit(2);
    };
    let frame: u32 = frame.parse().expect("a frame number");
    let (pos, faces) = senc_testmesh::garment_frame_parts(garment, frame).expect("a committed garment frame");
    senc_geom::obj::write_obj(out, &pos, &faces).expect("write");
}
