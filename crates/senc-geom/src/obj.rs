//! Wavefront OBJ reading and writing.
//!
//! Reading is our own small parser rather than `tobj`: tobj re-indexes the vertices of each
//! `o`/`g` group separately, which splits vertices shared between groups and tears a garment
//! made of several groups apart; we need the file's own global vertex numbering (skinning
//! weights refer to it). Only `v`, `f`, `g` and `o` lines are read; `vt`, `vn` and the rest
//! are ignored; polygons are kept as read and also fan-triangulated; negative (relative)
//! indices are supported. Malformed lines (a `v` with fewer than three numbers, a
//! non-finite coordinate, a face index out of range) are a [`MeshError::Parse`] naming the
//! line, never a panic.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::MeshError;
use crate::mesh::TriMesh;
use crate::Vec3;

/// The raw content of an OBJ file: positions, triangles and the named face groups.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjData {
    /// All `v` positions, in file order.
    pub positions: Vec<Vec3>,
    /// Triangles (polygons fan-split), 0-based.
    pub faces: Vec<[u32; 3]>,
    /// Face groups in file order: name and the range of `faces` they cover.
    pub groups: Vec<(String, std::ops::Range<usize>)>,
    /// The file's polygons as read (before triangulation), 0-based.
    pub polygons: Vec<Vec<u32>>,
    /// Face groups over `polygons`: name and the range of `polygons` they cover.
    pub polygon_groups: Vec<(String, std::ops::Range<usize>)>,
}

impl ObjData {
    /// Parses OBJ text. `path` only names the source in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, MeshError> {
        let err =
            |line: usize, msg: &str| MeshError::Parse { path: path.to_owned(), message: format!("line {line}: {msg}") };
        let mut data = ObjData::default();
        let mut group_start = 0usize;
        let mut poly_start = 0usize;
        let mut group_name: Option<String> = None;
        let mut poly: Vec<u32> = Vec::with_capacity(8);
        for (ln, line) in text.lines().enumerate() {
            let ln = ln + 1;
            let mut it = line.split_whitespace();
            match it.next() {
                Some("v") => {
                    let mut c = [0.0f64; 3];
                    for x in &mut c {
                        *x = it
                            .next()
                            .ok_or_else(|| err(ln, "vertex with fewer than 3 coordinates"))?
                            .parse()
                            .map_err(|_| err(ln, "vertex coordinate is not a number"))?;
                        if !x.is_finite() {
                            return Err(err(ln, "vertex coordinate is not finite"));
                        }
                    }
                    data.positions.push(Vec3::new(c[0], c[1], c[2]));
                }
                Some("f") => {
                    poly.clear();
                    for tok in it {
                        let first = tok.split('/').next().unwrap_or("");
                        let idx: i64 = first.parse().map_err(|_| err(ln, "face index is not an integer"))?;
                        let n = data.positions.len() as i64;
                        let zero_based = if idx > 0 {
                            idx - 1
                        } else if idx < 0 {
                            n + idx
                        } else {
                            -1
                        };
                        if zero_based < 0 || zero_based > u32::MAX as i64 {
                            return Err(err(ln, &format!("face index {idx} is out of range")));
                        }
                        poly.push(zero_based as u32);
                    }
                    if poly.len() < 3 {
                        return Err(err(ln, "face with fewer than 3 vertices"));
                    }
                    for k in 1..poly.len() - 1 {
                        data.faces.push([poly[0], poly[k], poly[k + 1]]);
                    }
                    data.polygons.push(poly.clone());
                }
                Some("g") | Some("o") => {
                    if let Some(name) = group_name.take() {
                        data.groups.push((name.clone(), group_start..data.faces.len()));
                        data.polygon_groups.push((name, poly_start..data.polygons.len()));
                    }
                    group_start = data.faces.len();
                    poly_start = data.polygons.len();
                    group_name = Some(it.collect::<Vec<_>>().join(" "));
                }
                _ => {}
            }
        }
        if let Some(name) = group_name {
            data.groups.push((name.clone(), group_start..data.faces.len()));
            data.polygon_groups.push((name, poly_start..data.polygons.len()));
        }
        Ok(data)
    }

    /// Names of the `o`/`g` groups, in file order, each once.
    pub fn group_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for (n, _) in &self.groups {
            if !names.contains(&n.as_str()) {
                names.push(n);
            }
        }
        names
    }

    /// The triangles of every group called `name` (a name may appear more than once);
    /// `None` when no group has that name.
    pub fn group_faces(&self, name: &str) -> Option<Vec<[u32; 3]>> {
        let ranges: Vec<_> = self.groups.iter().filter(|(n, _)| n == name).map(|(_, r)| r.clone()).collect();
        (!ranges.is_empty()).then(|| ranges.into_iter().flat_map(|r| self.faces[r].iter().copied()).collect())
    }

    /// Reads and parses a file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, MeshError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| MeshError::Io { path: path.to_owned(), message: e.to_string() })?;
        Self::parse(&text, path)
    }
}

/// Reads an OBJ file as one validated mesh (all groups, unreferenced vertices kept).
pub fn read_obj(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let data = ObjData::read(path)?;
    TriMesh::new(data.positions, data.faces)
}

/// OBJ text of a mesh (`v` and `f` lines, 1-based, 17 significant digits so that positions
/// survive the round trip exactly).
pub fn obj_string(positions: &[Vec3], faces: &[[u32; 3]]) -> String {
    let mut s = String::with_capacity(positions.len() * 60 + faces.len() * 24);
    for p in positions {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for f in faces {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// Writes a mesh as OBJ.
pub fn write_obj(path: impl AsRef<Path>, positions: &[Vec3], faces: &[[u32; 3]]) -> Result<(), MeshError> {
    let path = path.as_ref();
    std::fs::write(path, obj_string(positions, faces))
        .map_err(|e| MeshError::Io { path: path.to_owned(), message: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ObjData, MeshError> {
        ObjData::parse(text, Path::new("t.obj"))
    }

    #[test]
    fn short_or_non_finite_vertex_lines_are_errors_naming_the_line() {
        let short = parse("v 0 0 0\nv 1 0\n").unwrap_err().to_string();
        assert!(short.contains("line 2") && short.contains("fewer than 3"), "{short}");
        let nan = parse("v 0 0 0\nv 1 NaN 0\n").unwrap_err().to_string();
        assert!(nan.contains("line 2") && nan.contains("not finite"), "{nan}");
        let inf = parse("v inf 0 0\n").unwrap_err().to_string();
        assert!(inf.contains("line 1"), "{inf}");
        let bad_index = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n").unwrap_err().to_string();
        assert!(bad_index.contains("line 4") && bad_index.contains("out of range"), "{bad_index}");
        let zero = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err().to_string();
        assert!(zero.contains("out of range"), "{zero}");
    }

    #[test]
    fn polygons_and_groups_keep_the_file_numbering() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\ng a\nf 1/1 2/2 3/3 4/4\no b\nf -4 5 3\ng a\nf 1 2 5\n";
        let d = parse(text).unwrap();
        assert_eq!(d.polygons, vec![vec![0, 1, 2, 3], vec![1, 4, 2], vec![0, 1, 4]]);
        assert_eq!(d.faces, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2], [0, 1, 4]]);
        assert_eq!(d.polygon_groups, vec![("a".into(), 0..1), ("b".into(), 1..2), ("a".into(), 2..3)]);
        assert_eq!(d.group_names(), vec!["a", "b"]);
        assert_eq!(d.group_faces("a").unwrap(), vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]]);
        assert!(d.group_faces("c").is_none());
    }

    #[test]
    fn written_meshes_read_back_exactly() {
        let positions = vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0 / 3.0, 0.0, 0.0), Vec3::new(0.0, 1e-17, 1.0)];
        let d = parse(&obj_string(&positions, &[[0, 1, 2]])).unwrap();
        assert_eq!(d.positions, positions);
        assert_eq!(d.faces, vec![[0, 1, 2]]);
    }
}
