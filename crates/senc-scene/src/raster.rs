//! A small software rasteriser for preview pictures: orthographic views about the vertical
//! axis, a z-buffer, flat shading; the garment's outside is white and its inside pink (as in
//! the paper's figures), the body grey. Pictures are written as PNG.

use std::path::Path;

use senc_geom::Vec3;

use crate::error::SceneError;

/// An RGB image, row-major, 8 bits per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `3 · width · height` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// Writes the image as PNG.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), SceneError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| SceneError::io(path, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| SceneError::io(path, e))?;
        w.write_image_data(&self.rgb).map_err(|e| SceneError::io(path, e))
    }

    /// The colour at pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y * self.width + x) as usize;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// One mesh to draw and its colours.
#[derive(Debug, Clone, Copy)]
pub struct Layer<'a> {
    /// Positions, m.
    pub positions: &'a [Vec3],
    /// Counter-clockwise triangles.
    pub faces: &'a [[u32; 3]],
    /// Colour of faces whose outward normal faces the viewer.
    pub outside: [f64; 3],
    /// Colour of faces seen from behind.
    pub inside: [f64; 3],
}

/// Garment outside colour (white).
pub const GARMENT_OUTSIDE: [f64; 3] = [0.97, 0.97, 0.97];
/// Garment inside colour (pink).
pub const GARMENT_INSIDE: [f64; 3] = [0.98, 0.55, 0.70];
/// Body colour (grey).
pub const BODY: [f64; 3] = [0.55, 0.55, 0.58];
const BACKGROUND: [u8; 3] = [40, 44, 52];

/// Renders the layers seen from each yaw angle (degrees about +y; 0 looks at the front,
/// i.e. from +z), side by side, each view `view_size` pixels wide and `1.5 · view_size` high.
/// All views share one scale, chosen so that the bounding box of every layer fits.
pub fn render(layers: &[Layer<'_>], yaws_deg: &[f64], view_size: u32) -> Image {
    let vw = view_size.max(16);
    let vh = vw * 3 / 2;
    let width = vw * yaws_deg.len().max(1) as u32;
    let mut img = Image { width, height: vh, rgb: BACKGROUND.repeat((width * vh) as usize) };
    let all = layers.iter().flat_map(|l| l.positions.iter());
    let (mut lo, mut hi) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
    for p in all {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    if !lo.x.is_finite() {
        return img;
    }
    let centre = (lo + hi) * 0.5;
    let radius_xz = ((hi.x - lo.x).powi(2) + (hi.z - lo.z).powi(2)).sqrt() * 0.5;
    let scale = (0.92 * vw as f64 / (2.0 * radius_xz)).min(0.92 * vh as f64 / (hi.y - lo.y).max(1e-9));
    let light = Vec3::new(0.35, 0.55, 1.0).normalize();
    for (k, &yaw) in yaws_deg.iter().enumerate() {
        let (s, c) = yaw.to_radians().sin_cos();
        // Rotate the scene by −yaw so the camera, at angle yaw around the body, looks down −z.
        let view = |p: &Vec3| -> Vec3 {
            let q = p - centre;
            Vec3::new(c * q.x - s * q.z, q.y, s * q.x + c * q.z)
        };
        let x0 = (k as u32 * vw) as f64;
        let mut zbuf = vec![f64::NEG_INFINITY; (vw * vh) as usize];
        for layer in layers {
            let pts: Vec<Vec3> = layer.positions.iter().map(view).collect();
            for f in layer.faces {
                let [a, b, cc] = f.map(|i| pts[i as usize]);
                let n = (b - a).cross(&(cc - a));
                let len = n.norm();
                if len < 1e-18 {
                    continue;
                }
                let n = n / len;
                let (col, nn) = if n.z >= 0.0 { (layer.outside, n) } else { (layer.inside, -n) };
                let shade = 0.30 + 0.70 * nn.dot(&light).max(0.0);
                let rgb = col.map(|x| (x * shade * 255.0).clamp(0.0, 255.0) as u8);
                let sp = [a, b, cc].map(|p| (vw as f64 * 0.5 + p.x * scale, vh as f64 * 0.5 - p.y * scale, p.z));
                fill_triangle(&mut img, &mut zbuf, x0 as u32, vw, vh, sp, rgb);
            }
        }
    }
    img
}

fn fill_triangle(img: &mut Image, zbuf: &mut [f64], x0: u32, vw: u32, vh: u32, p: [(f64, f64, f64); 3], rgb: [u8; 3]) {
    let minx = p.iter().map(|q| q.0).fold(f64::INFINITY, f64::min).floor().max(0.0) as i64;
    let maxx = p.iter().map(|q| q.0).fold(f64::NEG_INFINITY, f64::max).ceil().min(vw as f64 - 1.0) as i64;
    let miny = p.iter().map(|q| q.1).fold(f64::INFINITY, f64::min).floor().max(0.0) as i64;
    let maxy = p.iter().map(|q| q.1).fold(f64::NEG_INFINITY, f64::max).ceil().min(vh as f64 - 1.0) as i64;
    let edge =
        |a: (f64, f64, f64), b: (f64, f64, f64), x: f64, y: f64| (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0);
    let area = edge(p[0], p[1], p[2].0, p[2].1);
    if area.abs() < 1e-12 {
        return;
    }
    for y in miny..=maxy {
        for x in minx..=maxx {
            let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
            let w0 = edge(p[1], p[2], fx, fy) / area;
            let w1 = edge(p[2], p[0], fx, fy) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let z = w0 * p[0].2 + w1 * p[1].2 + w2 * p[2].2;
            let zi = (y as u32 * vw + x as u32) as usize;
            if z > zbuf[zi] {
                zbuf[zi] = z;
                let i = 3 * (y as usize * img.width as usize + x0 as usize + x as usize);
                img.rgb[i..i + 3].copy_from_slice(&rgb);
            }
        }
    }
}
