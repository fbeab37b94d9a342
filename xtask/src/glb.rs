//! One animated binary glTF (`.glb`) for a simulated sequence.
//!
//! Each mesh (garment, body) is one glTF mesh whose base positions are its first frame and
//! whose morph targets are the displacements of every later frame from it; one animation
//! steps the morph weights so that at time `k / fps` only target `k` is on (linear
//! interpolation in between, which blends neighbouring frames). Viewers that play glTF
//! animations (Blender, three.js, gltf-viewer) show the sequence without any plug-in.
//!
//! Written with serde_json rather than the `gltf` crate: gltf-json switches on serde_json's
//! `raw_value` feature, which changes burn-core's build and costs a full burn rebuild
//! (about 26 CPU-minutes here) for ten JSON objects and a three-field container. Positions
//! are written as f32 (the f64 → f32 conversion happens here, at the file boundary). The
//! test reads the file back by the glTF 2.0 rules and compares every frame.

use std::path::Path;

use anyhow::{bail, Context, Result};
use senc_geom::Vec3;
use serde_json::{json, Value};

/// One animated mesh: fixed faces, positions per frame.
pub struct AnimatedMesh<'a> {
    /// Node and mesh name.
    pub name: &'a str,
    /// Triangles (indices into each frame's positions).
    pub faces: &'a [[u32; 3]],
    /// Positions per frame, m; every frame has the same length.
    pub frames: &'a [Vec<Vec3>],
    /// Base colour, linear RGB.
    pub color: [f32; 3],
}

/// glTF constants (glTF 2.0 specification, section 5).
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const TRIANGLES: u32 = 4;

/// Accumulates the binary chunk with its buffer views and accessors.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Appends `bytes` (4-byte aligned) as a buffer view and an accessor over it; returns
    /// the accessor index.
    fn accessor(&mut self, bytes: &[u8], target: Option<u32>, mut acc: Value) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut view = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        acc["bufferView"] = json!(self.views.len());
        self.views.push(view);
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A VEC3 float accessor with min/max (required for positions and morph targets).
    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let mut lo = [f32::MAX; 3];
        let mut hi = [f32::MIN; 3];
        for p in v {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let acc = json!({ "componentType": FLOAT, "count": v.len(), "type": "VEC3", "min": lo, "max": hi });
        self.accessor(&bytes, Some(ARRAY_BUFFER), acc)
    }

    /// A SCALAR float accessor (animation times with min/max, or weights).
    fn scalars(&mut self, v: &[f32], bounds: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut acc = json!({ "componentType": FLOAT, "count": v.len(), "type": "SCALAR" });
        if bounds {
            acc["min"] = json!([v.iter().copied().fold(f32::MAX, f32::min)]);
            acc["max"] = json!([v.iter().copied().fold(f32::MIN, f32::max)]);
        }
        self.accessor(&bytes, None, acc)
    }
}

fn f32x3(p: &Vec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Writes the meshes as one animated GLB at `fps` frames per second.
pub fn write_animated_glb(path: &Path, meshes: &[AnimatedMesh<'_>], fps: f64) -> Result<()> {
    let mut b = Builder::default();
    let (mut nodes, mut json_meshes, mut materials) = (Vec::new(), Vec::new(), Vec::new());
    let (mut channels, mut samplers) = (Vec::new(), Vec::new());
    for m in meshes {
        let Some(first) = m.frames.first() else { bail!("mesh {}: no frames to write", m.name) };
        if let Some((k, f)) = m.frames.iter().enumerate().find(|(_, f)| f.len() != first.len()) {
            bail!("mesh {}: frame {k} has {} vertices, frame 0 has {}", m.name, f.len(), first.len());
        }
        if m.frames.iter().flatten().any(|p| !p.iter().all(|c| c.is_finite())) {
            bail!("mesh {}: non-finite positions; nothing written", m.name);
        }
        if let Some(f) = m.faces.iter().find(|f| f.iter().any(|&v| v as usize >= first.len())) {
            bail!("mesh {}: face {f:?} indexes past its {} vertices", m.name, first.len());
        }
        let base: Vec<[f32; 3]> = first.iter().map(f32x3).collect();
        let positions = b.vec3(&base);
        let idx: Vec<u8> = m.faces.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        let indices = b.accessor(
            &idx,
            Some(ELEMENT_ARRAY_BUFFER),
            json!({ "componentType": UNSIGNED_INT, "count": m.faces.len() * 3, "type": "SCALAR" }),
        );
        let n_targets = m.frames.len() - 1;
        let targets: Vec<Value> = m.frames[1..]
            .iter()
            .map(|f| {
                let d: Vec<[f32; 3]> = f
                    .iter()
                    .zip(&base)
                    .map(|(p, q)| {
                        let p = f32x3(p);
                        [p[0] - q[0], p[1] - q[1], p[2] - q[2]]
                    })
                    .collect();
                json!({ "POSITION": b.vec3(&d) })
            })
            .collect();
        let [r, g, bl] = m.color;
        materials.push(json!({
            "name": m.name,
            "doubleSided": true,
            "pbrMetallicRoughness": { "baseColorFactor": [r, g, bl, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9 }
        }));
        let mut prim = json!({
            "attributes": { "POSITION": positions },
            "indices": indices,
            "material": materials.len() - 1,
            "mode": TRIANGLES
        });
        let mut mesh = json!({ "name": m.name });
        if n_targets > 0 {
            prim["targets"] = Value::Array(targets);
            mesh["weights"] = json!(vec![0.0; n_targets]);
        }
        mesh["primitives"] = json!([prim]);
        json_meshes.push(mesh);
        nodes.push(json!({ "name": m.name, "mesh": json_meshes.len() - 1 }));
        if n_targets > 0 {
            // Frame k at time k / fps: all weights 0 at frame 0, only target k on at frame k.
            let times: Vec<f32> = (0..m.frames.len()).map(|k| (k as f64 / fps) as f32).collect();
            let mut w = vec![0.0f32; m.frames.len() * n_targets];
            for k in 1..m.frames.len() {
                w[k * n_targets + (k - 1)] = 1.0;
            }
            let input = b.scalars(&times, true);
            let output = b.scalars(&w, false);
            samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
            channels.push(
                json!({ "sampler": samplers.len() - 1, "target": { "node": nodes.len() - 1, "path": "weights" } }),
            );
        }
    }
    while b.bin.len() % 4 != 0 {
        b.bin.push(0);
    }
    let mut root = json!({
        "asset": { "version": "2.0", "generator": "senc (cargo xtask simulate)" },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": json_meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{ "byteLength": b.bin.len() }],
    });
    if !channels.is_empty() {
        root["animations"] = json!([{ "name": "simulation", "samplers": samplers, "channels": channels }]);
    }
    let mut text = serde_json::to_vec(&root).context("serialising the glTF JSON")?;
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let length = 12 + 8 + text.len() + 8 + b.bin.len();
    let length =
        u32::try_from(length).context("the sequence is larger than a GLB can hold (4 GiB); simulate fewer frames")?;
    let mut out = Vec::with_capacity(length as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&length.to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(b.bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b.bin);
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads a GLB by the specification: (JSON, binary chunk).
    fn read_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
        assert_eq!(&bytes[0..4], b"glTF");
        assert_eq!(u32_at(4), 2);
        assert_eq!(u32_at(8), bytes.len());
        let jl = u32_at(12);
        assert_eq!(&bytes[16..20], b"JSON");
        assert_eq!(jl % 4, 0);
        let json: Value = serde_json::from_slice(&bytes[20..20 + jl]).unwrap();
        let bo = 20 + jl;
        let bl = u32_at(bo);
        assert_eq!(&bytes[bo + 4..bo + 8], b"BIN\0");
        assert_eq!(bo + 8 + bl, bytes.len());
        (json, bytes[bo + 8..].to_vec())
    }

    /// The f32 values behind accessor `a`.
    fn floats(json: &Value, bin: &[u8], a: usize) -> Vec<f32> {
        let acc = &json["accessors"][a];
        assert_eq!(acc["componentType"], FLOAT);
        let view = &json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let (o, l) = (view["byteOffset"].as_u64().unwrap() as usize, view["byteLength"].as_u64().unwrap() as usize);
        assert_eq!(o % 4, 0);
        let per = if acc["type"] == "VEC3" { 3 } else { 1 };
        assert_eq!(l, acc["count"].as_u64().unwrap() as usize * per * 4);
        bin[o..o + l].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
    }

    /// A written sequence reads back as the same frames (base + target k = frame k), with
    /// an animation that turns target k on at time k / fps, and min/max that bound the data.
    #[test]
    fn round_trips_frames_through_morph_targets() {
        let faces = [[0u32, 1, 2], [0, 2, 3]];
        let frames: Vec<Vec<Vec3>> = (0..4)
            .map(|k| {
                let s = k as f64 * 0.1;
                vec![
                    Vec3::new(0.0, s, 0.0),
                    Vec3::new(1.0, 0.0, s),
                    Vec3::new(1.0, 1.0 + s, 0.0),
                    Vec3::new(0.0, 1.0, -s),
                ]
            })
            .collect();
        let path = std::env::temp_dir().join(format!("senc-glb-test-{}.glb", std::process::id()));
        write_animated_glb(
            &path,
            &[AnimatedMesh { name: "cloth", faces: &faces, frames: &frames, color: [1.0; 3] }],
            30.0,
        )
        .unwrap();
        let (json, bin) = read_glb(&std::fs::read(&path).unwrap());
        std::fs::remove_file(&path).ok();
        let prim = &json["meshes"][0]["primitives"][0];
        let pa = prim["attributes"]["POSITION"].as_u64().unwrap() as usize;
        let base = floats(&json, &bin, pa);
        let lo = json["accessors"][pa]["min"].as_array().unwrap();
        for (i, x) in base.iter().enumerate() {
            assert!(*x >= lo[i % 3].as_f64().unwrap() as f32);
        }
        let ia = &json["accessors"][prim["indices"].as_u64().unwrap() as usize];
        assert_eq!(ia["componentType"], UNSIGNED_INT);
        assert_eq!(ia["count"], 6);
        let targets = prim["targets"].as_array().unwrap();
        assert_eq!(targets.len(), 3);
        for (k, t) in targets.iter().enumerate() {
            let d = floats(&json, &bin, t["POSITION"].as_u64().unwrap() as usize);
            for v in 0..4 {
                for c in 0..3 {
                    let want = frames[k + 1][v][c] as f32;
                    assert!((base[3 * v + c] + d[3 * v + c] - want).abs() < 1e-6, "frame {} vertex {v}", k + 1);
                }
            }
        }
        let anim = &json["animations"][0];
        assert_eq!(anim["channels"][0]["target"]["path"], "weights");
        let s = &anim["samplers"][0];
        let times = floats(&json, &bin, s["input"].as_u64().unwrap() as usize);
        assert_eq!(times.len(), 4);
        assert!((times[3] - 0.1).abs() < 1e-6);
        let w = floats(&json, &bin, s["output"].as_u64().unwrap() as usize);
        assert_eq!(w.len(), 4 * 3);
        assert_eq!(&w[0..3], &[0.0, 0.0, 0.0]);
        assert_eq!(&w[6..9], &[0.0, 1.0, 0.0]);
    }

    #[test]
    fn refuses_non_finite_and_ragged_frames() {
        let faces = [[0u32, 1, 2]];
        let good = vec![Vec3::zeros(), Vec3::x(), Vec3::y()];
        let nan = vec![Vec3::zeros(), Vec3::x(), Vec3::new(f64::NAN, 0.0, 0.0)];
        let path = std::env::temp_dir().join(format!("senc-glb-bad-{}.glb", std::process::id()));
        let e = write_animated_glb(
            &path,
            &[AnimatedMesh { name: "c", faces: &faces, frames: &[good.clone(), nan], color: [1.0; 3] }],
            30.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("non-finite"), "{e}");
        let e = write_animated_glb(
            &path,
            &[AnimatedMesh { name: "c", faces: &faces, frames: &[good.clone(), good[..2].to_vec()], color: [1.0; 3] }],
            30.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("frame 1"), "{e}");
    }
}
