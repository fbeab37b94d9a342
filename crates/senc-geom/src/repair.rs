//! Repair of triangle soups made elsewhere (garments exported by other tools) into valid
//! [`TriMesh`]es, saying what was changed, and refusing what cannot be repaired.
//!
//! Repaired: duplicate vertices (welded within a tolerance relative to the bounding-box
//! diagonal), faces that collapse under the weld or have zero area (dropped), repeated faces
//! (dropped), faces whose winding disagrees with their neighbours on an orientable
//! component (flipped, the fewer of the two choices per component), tiny stray components
//! (dropped: area under a fraction of the largest component's) and unused vertices
//! (dropped). Refused: a non-finite coordinate or an out-of-range index, an edge shared by
//! more than two faces after welding, a non-orientable component (a Möbius strip), an
//! empty mesh. A component is a set of faces connected through shared edges.

use std::collections::HashMap;

use crate::error::MeshError;
use crate::mesh::{TriMesh, ZERO_AREA_REL};
use crate::Vec3;

/// Settings of [`repair`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepairConfig {
    /// Vertices closer than this fraction of the bounding-box diagonal are welded. Default
    /// 1e-6 (about 2 µm on a 2 m garment): exporters split vertices along seams and UV
    /// borders at exactly the same position.
    pub weld_tolerance: f64,
    /// Components with less than this fraction of the largest component's area are dropped
    /// as strays (stray buttons, labels, loose triangles). Default 0.02.
    pub stray_fraction: f64,
}

impl Default for RepairConfig {
    fn default() -> Self {
        Self { weld_tolerance: 1e-6, stray_fraction: 0.02 }
    }
}

/// What [`repair`] changed.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RepairReport {
    /// Vertices merged into another one.
    pub welded: usize,
    /// Faces dropped because they collapsed (repeated vertex after welding) or had zero area.
    pub degenerate_faces: usize,
    /// Faces dropped because another face has the same three vertices.
    pub duplicate_faces: usize,
    /// Faces whose winding was reversed to agree with their neighbours.
    pub flipped: usize,
    /// Stray components dropped, and their faces.
    pub dropped_components: usize,
    /// Faces of the dropped components.
    pub dropped_faces: usize,
    /// Vertices no kept face uses (dropped).
    pub unused_vertices: usize,
}

impl RepairReport {
    /// True when nothing was changed but unused vertices.
    pub fn is_clean(&self) -> bool {
        self.welded + self.degenerate_faces + self.duplicate_faces + self.flipped + self.dropped_components == 0
    }
}

impl std::fmt::Display for RepairReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "welded {} duplicate vertices, dropped {} degenerate and {} repeated faces, flipped {} faces to agree with their neighbours, dropped {} stray components ({} faces) and {} unused vertices",
            self.welded,
            self.degenerate_faces,
            self.duplicate_faces,
            self.flipped,
            self.dropped_components,
            self.dropped_faces,
            self.unused_vertices
        )
    }
}

/// Why a soup could not be repaired.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RepairError {
    /// No faces (or none left).
    #[error("the mesh has no faces{0}")]
    Empty(&'static str),
    /// A face uses a vertex that does not exist.
    #[error("face {face} uses vertex {index}, but there are {n_vertices} vertices")]
    IndexOutOfRange {
        /// The face.
        face: usize,
        /// The index.
        index: u32,
        /// Vertices in the mesh.
        n_vertices: usize,
    },
    /// A face uses a vertex with a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate {position:?}; fix or remove it in the modelling tool")]
    NonFinite {
        /// The vertex.
        vertex: usize,
        /// Its coordinates.
        position: [f64; 3],
    },
    /// More than two faces share an edge after welding.
    #[error(
        "edge ({a}, {b}) is shared by {faces} faces after welding (input vertex numbers); the surface branches there, which a garment cannot: separate the sheets in the modelling tool"
    )]
    NonManifoldEdge {
        /// One end (input numbering).
        a: u32,
        /// The other end.
        b: u32,
        /// Faces on it.
        faces: usize,
    },
    /// A component cannot be oriented consistently.
    #[error(
        "the component containing face {face} is not orientable (a Möbius strip): no choice of face windings agrees across every edge"
    )]
    NonOrientable {
        /// A face of the component (input numbering).
        face: usize,
    },
    /// The repaired mesh was still refused by [`TriMesh::new`].
    #[error("the repaired mesh is still invalid: {0}")]
    Mesh(#[from] MeshError),
}

/// A repaired mesh.
#[derive(Debug, Clone)]
pub struct Repaired {
    /// The mesh.
    pub mesh: TriMesh,
    /// For every output vertex, the input vertex it came from (the first of a welded group).
    pub source: Vec<u32>,
    /// For every output face, the input face it came from.
    pub face_source: Vec<u32>,
    /// What was changed.
    pub report: RepairReport,
}

/// The soup after welding, cleaning and orienting: faces in input numbering of their
/// representative vertices, with their input face index and component.
struct Oriented {
    faces: Vec<[u32; 3]>,
    face_source: Vec<u32>,
    component: Vec<usize>,
    areas: Vec<f64>,
    report: RepairReport,
}

fn diagonal(points: impl Iterator<Item = Vec3>) -> f64 {
    let (mut lo, mut hi) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
    for p in points {
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    (hi - lo).norm()
}

/// For each vertex its representative: the first vertex (in index order) within `tol`.
fn weld(positions: &[Vec3], used: &[bool], tol: f64) -> Vec<u32> {
    let mut rep: Vec<u32> = (0..positions.len() as u32).collect();
    if tol.is_nan() || tol <= 0.0 {
        return rep;
    }
    let cell = |p: &Vec3| -> [i64; 3] { [p.x, p.y, p.z].map(|c| (c / tol).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (v, p) in positions.iter().enumerate() {
        if !used[v] {
            continue;
        }
        let c = cell(p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        if let Some(&w) = list.iter().find(|&&w| (positions[w as usize] - p).norm() <= tol) {
                            found = Some(w);
                            break 'search;
                        }
                    }
                }
            }
        }
        match found {
            Some(w) => rep[v] = w,
            None => grid.entry(c).or_default().push(v as u32),
        }
    }
    rep
}

fn orient(positions: &[Vec3], faces: &[[u32; 3]], cfg: &RepairConfig) -> Result<Oriented, RepairError> {
    if faces.is_empty() {
        return Err(RepairError::Empty(""));
    }
    let n = positions.len();
    let mut used = vec![false; n];
    for (f, face) in faces.iter().enumerate() {
        for &i in face {
            if i as usize >= n {
                return Err(RepairError::IndexOutOfRange { face: f, index: i, n_vertices: n });
            }
            used[i as usize] = true;
        }
    }
    if let Some(v) = (0..n).find(|&v| used[v] && !positions[v].iter().all(|c| c.is_finite())) {
        let p = positions[v];
        return Err(RepairError::NonFinite { vertex: v, position: [p.x, p.y, p.z] });
    }
    let diag = diagonal((0..n).filter(|&v| used[v]).map(|v| positions[v]));
    let rep = weld(positions, &used, cfg.weld_tolerance * diag);
    let mut report =
        RepairReport { welded: (0..n).filter(|&v| used[v] && rep[v] != v as u32).count(), ..RepairReport::default() };
    // Collapsed, zero-area and repeated faces.
    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(faces.len());
    let mut face_source = Vec::with_capacity(faces.len());
    let mut seen: HashMap<[u32; 3], ()> = HashMap::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let t = face.map(|i| rep[i as usize]);
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let longest = (b - a).norm_squared().max((c - b).norm_squared()).max((a - c).norm_squared());
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(&(c - a)).norm() <= ZERO_AREA_REL * longest {
            report.degenerate_faces += 1;
            continue;
        }
        let mut key = t;
        key.sort_unstable();
        if seen.insert(key, ()).is_some() {
            report.duplicate_faces += 1;
            continue;
        }
        kept.push(t);
        face_source.push(f as u32);
    }
    if kept.is_empty() {
        return Err(RepairError::Empty(" left after dropping degenerate faces"));
    }
    // Edges: sorted pair -> faces on it.
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::with_capacity(kept.len() * 2);
    for (f, t) in kept.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(f as u32);
        }
    }
    if let Some(((a, b), fs)) = edges.iter().filter(|(_, fs)| fs.len() > 2).min_by_key(|(e, _)| **e) {
        return Err(RepairError::NonManifoldEdge { a: *a, b: *b, faces: fs.len() });
    }
    // Breadth-first over each component; `flip[f]` says whether f must be reversed to agree
    // with the component's seed face.
    let has_edge = |t: &[u32; 3], a: u32, b: u32| (0..3).any(|k| t[k] == a && t[(k + 1) % 3] == b);
    let mut component = vec![usize::MAX; kept.len()];
    let mut flip = vec![false; kept.len()];
    let mut areas = Vec::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    for seed in 0..kept.len() {
        if component[seed] != usize::MAX {
            continue;
        }
        let id = members.len();
        component[seed] = id;
        let mut queue = vec![seed];
        let mut list = Vec::new();
        while let Some(f) = queue.pop() {
            list.push(f);
            let t = kept[f];
            for k in 0..3 {
                // The edge as f traverses it once f is oriented.
                let (mut a, mut b) = (t[k], t[(k + 1) % 3]);
                if flip[f] {
                    std::mem::swap(&mut a, &mut b);
                }
                for &g in &edges[&(a.min(b), a.max(b))] {
                    let g = g as usize;
                    if g == f {
                        continue;
                    }
                    // g must traverse (b, a); it traverses (a, b) as stored when it needs a flip.
                    let needs = has_edge(&kept[g], a, b);
                    if component[g] == usize::MAX {
                        component[g] = id;
                        flip[g] = needs;
                        queue.push(g);
                    } else if flip[g] != needs {
                        return Err(RepairError::NonOrientable { face: face_source[seed] as usize });
                    }
                }
            }
        }
        let area: f64 = list
            .iter()
            .map(|&f| {
                let [a, b, c] = kept[f].map(|i| positions[i as usize]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum();
        areas.push(area);
        members.push(list);
    }
    // Per component, the fewer flips of the two consistent choices.
    for list in &members {
        let flipped = list.iter().filter(|&&f| flip[f]).count();
        let invert = 2 * flipped > list.len();
        for &f in list {
            if flip[f] != invert {
                kept[f].swap(1, 2);
                report.flipped += 1;
            }
        }
    }
    Ok(Oriented { faces: kept, face_source, component, areas, report })
}

/// The faces of `keep`'s components as a compact, validated mesh.
fn build(
    positions: &[Vec3],
    o: &Oriented,
    keep: impl Fn(usize) -> bool,
    mut report: RepairReport,
) -> Result<Repaired, RepairError> {
    // Output vertices in input order, so that a clean mesh comes back unchanged.
    let mut source: Vec<u32> = o
        .faces
        .iter()
        .enumerate()
        .filter(|(f, _)| keep(o.component[*f]))
        .flat_map(|(_, t)| t.iter().copied())
        .collect();
    source.sort_unstable();
    source.dedup();
    let index: HashMap<u32, u32> = source.iter().enumerate().map(|(k, &v)| (v, k as u32)).collect();
    let mut faces = Vec::new();
    let mut face_source = Vec::new();
    for (f, t) in o.faces.iter().enumerate() {
        if keep(o.component[f]) {
            faces.push(t.map(|v| index[&v]));
            face_source.push(o.face_source[f]);
        }
    }
    let used = o.faces.iter().flatten().collect::<std::collections::HashSet<_>>().len();
    report.unused_vertices = positions.len() - report.welded - used;
    let mesh = TriMesh::new(source.iter().map(|&v| positions[v as usize]).collect(), faces)?;
    Ok(Repaired { mesh, source, face_source, report })
}

/// Repairs a soup into one mesh (see the module doc): every component but the strays.
pub fn repair(positions: &[Vec3], faces: &[[u32; 3]], cfg: &RepairConfig) -> Result<Repaired, RepairError> {
    let o = orient(positions, faces, cfg)?;
    let largest = o.areas.iter().cloned().fold(0.0, f64::max);
    let stray = |c: usize| o.areas[c] < cfg.stray_fraction * largest;
    let mut report = o.report.clone();
    report.dropped_components = (0..o.areas.len()).filter(|&c| stray(c)).count();
    report.dropped_faces = o.component.iter().filter(|&&c| stray(c)).count();
    build(positions, &o, |c| !stray(c), report)
}

/// Repairs a soup into one mesh per component, largest area first; strays are dropped and
/// counted in the first part's report.
pub fn repair_parts(positions: &[Vec3], faces: &[[u32; 3]], cfg: &RepairConfig) -> Result<Vec<Repaired>, RepairError> {
    let o = orient(positions, faces, cfg)?;
    let largest = o.areas.iter().cloned().fold(0.0, f64::max);
    let mut order: Vec<usize> = (0..o.areas.len()).filter(|&c| o.areas[c] >= cfg.stray_fraction * largest).collect();
    order.sort_by(|&a, &b| o.areas[b].total_cmp(&o.areas[a]));
    let mut report = o.report.clone();
    report.dropped_components = o.areas.len() - order.len();
    report.dropped_faces = o.component.iter().filter(|&&c| !order.contains(&c)).count();
    order
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let r = if k == 0 { report.clone() } else { RepairReport::default() };
            build(positions, &o, |d| d == c, r)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::grid_sheet;

    fn sheet() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let m = grid_sheet(1.0, 1.0, 6, 6).unwrap();
        (m.positions().to_vec(), m.faces().to_vec())
    }

    #[test]
    fn a_clean_mesh_comes_back_unchanged() {
        let (p, f) = sheet();
        let r = repair(&p, &f, &RepairConfig::default()).unwrap();
        assert!(r.report.is_clean(), "{}", r.report);
        assert_eq!(r.mesh.faces(), &f[..]);
        assert_eq!(r.mesh.positions(), &p[..]);
    }

    #[test]
    fn inconsistent_windings_are_flipped_to_agree() {
        let (p, mut f) = sheet();
        for k in [3, 10, 11, 40] {
            f[k].swap(0, 1);
        }
        assert!(TriMesh::new(p.clone(), f.clone()).is_err());
        let r = repair(&p, &f, &RepairConfig::default()).unwrap();
        assert_eq!(r.report.flipped, 4);
        // Every face again turns the way the untouched ones do (the sheet's +z).
        for f in 0..r.mesh.n_faces() {
            assert!(r.mesh.face_normal_scaled(f).z > 0.0, "face {f}");
        }
    }

    #[test]
    fn split_vertices_are_welded_and_repeated_faces_dropped() {
        // Split the sheet along a seam: the faces right of x = 0.5 get their own copies of
        // the seam vertices, as exporters do at UV borders.
        let (mut p, mut f) = sheet();
        let n = p.len() as u32;
        let seam: Vec<u32> = (0..n).filter(|&v| (p[v as usize].x - 0.5).abs() < 1e-9).collect();
        let copies: Vec<u32> = seam
            .iter()
            .map(|&v| {
                p.push(p[v as usize] + Vec3::new(1e-9, 0.0, 0.0));
                (p.len() - 1) as u32
            })
            .collect();
        for t in f.iter_mut() {
            let c = t.iter().map(|&v| p[v as usize]).fold(Vec3::zeros(), |s, q| s + q) / 3.0;
            if c.x > 0.5 {
                for v in t.iter_mut() {
                    if let Some(k) = seam.iter().position(|s| s == v) {
                        *v = copies[k];
                    }
                }
            }
        }
        f.push(f[0]);
        let r = repair(&p, &f, &RepairConfig::default()).unwrap();
        assert_eq!(r.report.welded, seam.len());
        assert_eq!(r.report.duplicate_faces, 1);
        assert_eq!(r.mesh.n_vertices(), n as usize);
        assert_eq!(r.mesh.topology().boundary_loops().len(), 1, "welded into one sheet");
    }

    #[test]
    fn stray_components_are_dropped_and_parts_split() {
        let (mut p, mut f) = sheet();
        let base = p.len() as u32;
        // A tiny triangle far away, and a second sheet half the size.
        p.extend([Vec3::new(5.0, 0.0, 0.0), Vec3::new(5.01, 0.0, 0.0), Vec3::new(5.0, 0.01, 0.0)]);
        f.push([base, base + 1, base + 2]);
        let half = grid_sheet(0.5, 1.0, 3, 6).unwrap();
        let off = p.len() as u32;
        p.extend(half.positions().iter().map(|q| q + Vec3::new(3.0, 0.0, 0.0)));
        f.extend(half.faces().iter().map(|t| t.map(|v| v + off)));
        let r = repair(&p, &f, &RepairConfig::default()).unwrap();
        assert_eq!((r.report.dropped_components, r.report.dropped_faces), (1, 1));
        assert_eq!(r.mesh.n_faces(), f.len() - 1);
        let parts = repair_parts(&p, &f, &RepairConfig::default()).unwrap();
        assert_eq!(parts.len(), 2);
        assert!((parts[0].mesh.area() - 1.0).abs() < 1e-9 && (parts[1].mesh.area() - 0.5).abs() < 1e-9);
        assert!(parts[1].source.iter().all(|&v| v >= off));
    }

    #[test]
    fn what_cannot_be_repaired_is_refused_by_name() {
        let (mut p, f) = sheet();
        // A third face on an edge.
        let mut fan = f.clone();
        let e = fan[0];
        p.push(Vec3::new(0.1, 0.1, 1.0));
        fan.push([e[0], e[2], (p.len() - 1) as u32]); // (0, 8): the sheet's first diagonal
        assert!(matches!(
            repair(&p, &fan, &RepairConfig::default()),
            Err(RepairError::NonManifoldEdge { faces: 3, .. })
        ));
        // NaN in a used vertex; out-of-range index; nothing at all.
        let mut bad = p.clone();
        bad[f[5][1] as usize].y = f64::NAN;
        assert!(matches!(repair(&bad, &f, &RepairConfig::default()), Err(RepairError::NonFinite { .. })));
        let mut oob = f.clone();
        oob[2][2] = 9999;
        assert!(matches!(
            repair(&p, &oob, &RepairConfig::default()),
            Err(RepairError::IndexOutOfRange { face: 2, index: 9999, .. })
        ));
        assert!(matches!(repair(&p, &[], &RepairConfig::default()), Err(RepairError::Empty(_))));
    }

    #[test]
    fn a_moebius_strip_is_refused() {
        // A strip of 8 quads whose ends are joined with a half twist.
        let n = 8;
        let mut p = Vec::new();
        for k in 0..n {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            let (c, s) = (t.cos(), t.sin());
            let w = 0.2 * (0.5 * t).cos();
            let h = 0.2 * (0.5 * t).sin();
            p.push(Vec3::new(c * (1.0 + w), s * (1.0 + w), h));
            p.push(Vec3::new(c * (1.0 - w), s * (1.0 - w), -h));
        }
        let mut f = Vec::new();
        for k in 0..n {
            let (a, b) = (2 * k as u32, 2 * k as u32 + 1);
            let (c, d) = if k + 1 < n { (a + 2, b + 2) } else { (1, 0) };
            f.push([a, b, d]);
            f.push([a, d, c]);
        }
        let e = repair(&p, &f, &RepairConfig::default()).unwrap_err();
        assert!(matches!(e, RepairError::NonOrientable { .. }), "{e}");
        assert!(e.to_string().contains("not orientable"));
    }
}
