//! Winding numbers by exact ray crossing counts: an axis-aligned ray from a point to beyond
//! the mesh, each face it crosses counted `+1` when the ray leaves through the face's outward
//! side and `−1` when it enters, every sign from [`orient3d_sos`].
//!
//! The ray's origin and far end take the two indices after the mesh's vertices in the
//! symbolic perturbation, so a ray through an edge or a vertex is decided like any other
//! degenerate configuration: consistently for all faces, as if the origin were moved by an
//! infinitesimal amount. On a closed, consistently oriented surface the count is then the
//! winding number of the surface around the (perturbed) origin, whatever the direction.

use super::*;

/// An axis-aligned ray: from `origin` along `+axis` (`positive`) or `−axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisRay {
    /// Start point (any finite point; it need not be a vertex).
    pub origin: Vec3,
    /// Coordinate axis, 0, 1 or 2.
    pub axis: usize,
    /// Direction along the axis.
    pub positive: bool,
}

impl AxisRay {
    /// The far end of the ray: same coordinates as the origin except along the axis, where it
    /// lies beyond `lo..hi` (the extent of the mesh along that axis).
    fn far_end(&self, lo: f64, hi: f64) -> Vec3 {
        let mut far = self.origin;
        let margin = (hi - lo).abs() + 1.0;
        far[self.axis] = if self.positive {
            greater(hi, self.origin[self.axis]) + margin
        } else {
            lesser(lo, self.origin[self.axis]) - margin
        };
        far
    }

    /// Whether a closed box can contain a point of the ray.
    #[inline]
    fn may_hit(&self, b: &Aabb3) -> bool {
        let (a1, a2) = ((self.axis + 1) % 3, (self.axis + 2) % 3);
        let o = self.origin;
        let along = if self.positive { b.hi[self.axis] >= o[self.axis] } else { b.lo[self.axis] <= o[self.axis] };
        along && b.lo[a1] <= o[a1] && o[a1] <= b.hi[a1] && b.lo[a2] <= o[a2] && o[a2] <= b.hi[a2]
    }
}

/// `Some(+1)` if the segment `origin → far` crosses face `f` from its inward to its outward
/// side, `Some(−1)` the other way, `Some(0)` if it misses (exact, with symbolic
/// perturbation); `None` when the line passes through the face and the origin lies exactly
/// in the face's plane, so that only the perturbation decides on which side of the face the
/// origin is.
fn face_crossing(mesh: &TriMesh, ray: &AxisRay, far: Vec3, f: usize) -> Option<i64> {
    triangle_crossing(mesh.triangle(f), mesh.faces()[f], mesh.n_vertices() as u32, ray, far)
}

/// [`face_crossing`] for any indexed triangle; the origin and far end take indices
/// `n_vertices` and `n_vertices + 1`.
fn triangle_crossing(p: [Vec3; 3], idx: [u32; 3], n_vertices: u32, ray: &AxisRay, far: Vec3) -> Option<i64> {
    let [ia, ib, ic] = idx;
    let [pa, pb, pc] = p;
    let (io, ifar) = (n_vertices, n_vertices + 1);
    let q = ray.origin;
    if !line_meets_triangle(p, idx, n_vertices, ray, far) {
        return Some(0);
    }
    if orient3d_value(pa, pb, pc, q) == 0.0 {
        return None;
    }
    let so = orient3d_sos([pa, pb, pc, q], [ia, ib, ic, io]);
    let sf = orient3d_sos([pa, pb, pc, far], [ia, ib, ic, ifar]);
    if so == sf {
        return Some(0);
    }
    // `Greater`: the origin lies on the inward side (below the counterclockwise face).
    Some(if so == Ordering::Greater { 1 } else { -1 })
}

/// Whether face `f` lies exactly in the plane of face `skip` and the ray's line passes
/// through it. The origin is a rounded point of `skip`'s plane, so the side of `f` it lies
/// on is rounding, not the perturbation that decided the crossings: such a ray is refused.
fn meets_coplanar(mesh: &TriMesh, ray: &AxisRay, far: Vec3, skip: u32, f: usize) -> bool {
    if skip == u32::MAX || skip as usize == f {
        return false;
    }
    let [a, b, c] = mesh.triangle(skip as usize);
    let [pa, pb, pc] = mesh.triangle(f);
    if ![pa, pb, pc].iter().all(|&p| orient3d_value(a, b, c, p) == 0.0) {
        return false;
    }
    line_meets_triangle([pa, pb, pc], mesh.faces()[f], mesh.n_vertices() as u32, ray, far)
}

/// Whether the line through the ray's origin and far end passes through the triangle
/// (exact, with symbolic perturbation; the origin and far end take indices `n_vertices`
/// and `n_vertices + 1`).
fn line_meets_triangle(p: [Vec3; 3], idx: [u32; 3], n_vertices: u32, ray: &AxisRay, far: Vec3) -> bool {
    let ([pa, pb, pc], [ia, ib, ic]) = (p, idx);
    let (io, ifar) = (n_vertices, n_vertices + 1);
    let q = ray.origin;
    let e1 = orient3d_sos([q, far, pa, pb], [io, ifar, ia, ib]);
    e1 == orient3d_sos([q, far, pb, pc], [io, ifar, ib, ic]) && e1 == orient3d_sos([q, far, pc, pa], [io, ifar, ic, ia])
}

/// The signed crossing count of `ray` with every face of `mesh` except `skip` (pass
/// `u32::MAX` to count all), by testing every face. Reference for
/// [`SelfIntersector::ray_winding`]. `None` when the origin lies exactly on a face the ray
/// passes through (the count would then depend on the perturbation alone, not on which side
/// of that face the origin's own surface is), or when the ray's line passes through a face
/// exactly coplanar with `skip` (the origin, a rounded point of `skip`, lies on a side of
/// that face by rounding): choose another origin. Virtual fans over
/// `open_loops` count as faces (see [`SelfIntersector::ray_winding`]).
pub fn ray_winding_brute(mesh: &TriMesh, ray: &AxisRay, skip: u32, open_loops: &[Vec<u32>]) -> Option<i64> {
    let ax = ray.axis;
    let (lo, hi) =
        mesh.positions().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[ax]), h.max(p[ax])));
    let far = ray.far_end(lo, hi);
    let faces: Option<i64> = (0..mesh.n_faces())
        .filter(|&f| f as u32 != skip)
        .map(|f| if meets_coplanar(mesh, ray, far, skip, f) { None } else { face_crossing(mesh, ray, far, f) })
        .sum();
    Some(faces? + fan_crossings(mesh, ray, far, open_loops)?)
}

/// Crossings of the virtual fans that close `open_loops` (each loop fanned to the mean of
/// its vertices, oriented like [`crate::close_holes`]'s fans: `[b, a, centroid]` for a
/// boundary edge `a → b`). Fan centroid `k` takes index `n_vertices + 2 + k`.
fn fan_crossings(mesh: &TriMesh, ray: &AxisRay, far: Vec3, open_loops: &[Vec<u32>]) -> Option<i64> {
    let pos = mesh.positions();
    let nv = mesh.n_vertices() as u32;
    let mut count = 0;
    for (k, lp) in open_loops.iter().enumerate() {
        if lp.is_empty() {
            continue;
        }
        let c = lp.iter().map(|&v| pos[v as usize]).sum::<Vec3>() / lp.len() as f64;
        let ic = nv + 2 + k as u32;
        for i in 0..lp.len() {
            let (a, b) = (lp[i], lp[(i + 1) % lp.len()]);
            count += triangle_crossing([pos[b as usize], pos[a as usize], c], [b, a, ic], nv, ray, far)?;
        }
    }
    Some(count)
}

/// The box of face `f` of `mesh` (as the refit computes it).
#[inline]
fn face_box(mesh: &TriMesh, f: u32) -> Aabb3 {
    let [a, b, c] = mesh.triangle(f as usize);
    Aabb3::of_triangle(a, b, c)
}

impl SelfIntersector {
    /// The signed crossing count of `ray` with every face of `mesh` except `skip`, through
    /// this intersector's BVH: the same number as [`ray_winding_brute`]. The boxes are those
    /// of the last [`SelfIntersector::find`], so `mesh` must have the positions of that call
    /// (otherwise, or for a mesh with other faces, every face is tested).
    ///
    /// On a closed, consistently oriented mesh, with `skip` the face that `origin` lies on
    /// and the ray leaving that face on its outward side, this is the winding number just
    /// outside the face there. `None` as for [`ray_winding_brute`]. The ray also counts the
    /// virtual fans over `open_loops` (holes left open; pass `&[]` when there are none), so
    /// that the count is the winding number of the surface closed by those fans.
    pub fn ray_winding(&self, mesh: &TriMesh, ray: &AxisRay, skip: u32, open_loops: &[Vec<u32>]) -> Option<i64> {
        if self.nodes.is_empty() || !self.fits(mesh) || self.lanes.len() != self.tree.order.len().div_ceil(LEAF_SIZE) {
            return ray_winding_brute(mesh, ray, skip, open_loops);
        }
        let root = self.nodes[0].bbox;
        let far = ray.far_end(root.lo[ray.axis], root.hi[ray.axis]);
        let mut count = 0;
        let mut stack: Vec<u32> = vec![0];
        while let Some(i) = stack.pop() {
            let nd = self.nodes[i as usize];
            if !ray.may_hit(&nd.bbox) {
                continue;
            }
            if nd.leaf {
                for slot in nd.a as usize..nd.b as usize {
                    let f = self.tree.order[slot];
                    if f != skip && ray.may_hit(&face_box(mesh, f)) {
                        if meets_coplanar(mesh, ray, far, skip, f as usize) {
                            return None;
                        }
                        count += face_crossing(mesh, ray, far, f as usize)?;
                    }
                }
            } else {
                stack.push(nd.a);
                stack.push(nd.b);
            }
        }
        Some(count + fan_crossings(mesh, ray, far, open_loops)?)
    }
}
