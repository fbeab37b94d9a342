//! Tests of the self-intersection pipeline against brute force and the reference predicates.

use super::*;
use crate::shapes;
use rand::{Rng, SeedableRng};

/// Every face pair with overlapping boxes through the reference test: no BVH, no ring or
/// plane filters.
fn brute_force(mesh: &TriMesh) -> SelfIntersections {
    let n = mesh.n_faces();
    let boxes: Vec<Aabb3> = (0..n)
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            Aabb3::of_triangle(a, b, c)
        })
        .collect();
    let mut results = Vec::new();
    for f in 0..n {
        for g in f + 1..n {
            if boxes[f].overlaps(&boxes[g]) {
                results.extend(test_pair(mesh, f as u32, g as u32));
            }
        }
    }
    assemble(mesh, results, 0)
}

#[test]
fn bvh_and_filters_find_every_crossing_of_the_brute_force() {
    let mut meshes: Vec<(String, TriMesh)> = Vec::new();
    for name in
        ["boxes_overlap_grid", "boxes_touch_grid", "bent_tube_jitter", "folded_sheet_grid", "icospheres_overlap_grid"]
    {
        let m = shapes::fixture(name).unwrap();
        let closed = crate::close_holes(&m, &crate::HoleSelection::All).unwrap().mesh().clone();
        meshes.push((name.to_string(), m));
        meshes.push((format!("{name} closed"), closed));
    }
    // Crumpled, grid-snapped spheres: many exact degeneracies and self-crossings.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for k in 0..4 {
        let s = shapes::icosphere(Vec3::zeros(), 1.0, 2).unwrap();
        let p: Vec<Vec3> = s
            .positions()
            .iter()
            .map(|p| {
                let q = p + Vec3::new(
                    rng.random_range(-0.4..0.4),
                    rng.random_range(-0.4..0.4),
                    rng.random_range(-0.4..0.4),
                );
                if k % 2 == 0 {
                    (q * 4.0).map(f64::round) / 4.0
                } else {
                    q
                }
            })
            .collect();
        meshes.push((format!("crumpled {k}"), s.with_positions(p).unwrap()));
    }
    let mut total_segments = 0;
    let mut compared = 0;
    for (name, m) in &meshes {
        if m.n_faces() > 12_000 {
            continue;
        }
        compared += 1;
        let fast = self_intersections(m);
        let slow = brute_force(m);
        assert_eq!(fast.points, slow.points, "{name}");
        assert_eq!(fast.segments, slow.segments, "{name}");
        assert_eq!(fast.n_inconsistent_pairs, slow.n_inconsistent_pairs, "{name}");
        total_segments += fast.segments.len();
    }
    assert!(compared >= 14, "{compared} meshes compared");
    assert!(total_segments > 500, "the meshes should cross themselves: {total_segments}");
}

#[test]
fn f32_rounding_is_outward() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
    for _ in 0..10_000 {
        let x: f64 = rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-40..38));
        assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x, "{x}");
        assert!(f32_up(x) as f64 - f32_down(x) as f64 <= 2.0 * (x.abs() * 1.2e-7 + 1.5e-45), "{x}");
    }
    for x in [0.0, -0.0, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY] {
        assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x, "{x}");
    }
}

#[test]
fn plane_pair_test_matches_the_reference() {
    // Random pairs sharing no or one vertex, half snapped to a coarse grid (exact
    // coplanarities, vertices on faces, collinear edges).
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut hits = 0;
    for case in 0..20_000 {
        let snap = case % 2 == 0;
        let p: Vec<Vec3> = (0..6)
            .map(|_| {
                let v =
                    Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                if snap {
                    (v * 2.0).map(f64::round) / 2.0
                } else {
                    v
                }
            })
            .collect();
        let shared = case % 3 == 0;
        let f1 = [0u32, 1, 2];
        let f2 = if shared { [0u32, 4, 5] } else { [3u32, 4, 5] };
        let Ok(m) = TriMesh::new(p, vec![f1, f2]) else { continue };
        let planes: Vec<FacePlane> = (0..2)
            .map(|f| {
                let [a, b, c] = m.triangle(f);
                FacePlane::of_triangle(a, b, c)
            })
            .collect();
        let want = test_pair(&m, 0, 1);
        hits += want.is_some() as usize;
        assert_eq!(test_pair_planes(&m, 0, 1, &planes[0], &planes[1]), want, "case {case}");
    }
    assert!(hits > 1000, "{hits}");
}

#[test]
fn closed_ring_winding_test_agrees_with_angle_sums() {
    // On smooth and crumpled closed meshes, the winding count accepts a closed ring
    // exactly when the wedge angles (each in (1e-9, π − 1e-9)) add up to one turn.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut accepted = 0;
    let mut rejected = 0;
    for amp in [0.0, 0.05, 0.3, 0.8] {
        let s = shapes::icosphere(Vec3::zeros(), 1.0, 3).unwrap();
        let p: Vec<Vec3> = s
            .positions()
            .iter()
            .map(|p| {
                p + Vec3::new(rng.random_range(-amp..=amp), rng.random_range(-amp..=amp), rng.random_range(-amp..=amp))
            })
            .collect();
        let m = s.with_positions(p).unwrap();
        let rings = embedded_rings(&m);
        for (v, &r) in rings.iter().enumerate() {
            let v = v as u32;
            let ring = m.topology().vertex_faces(v);
            let n: Vec3 = ring.iter().map(|&f| m.face_normal_scaled(f as usize)).sum::<Vec3>().normalize();
            let helper = if n.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
            let u = n.cross(&helper).normalize();
            let w = n.cross(&u);
            let ps = m.positions()[v as usize];
            let mut total = 0.0;
            let mut ok = true;
            for &f in ring {
                let fv = m.faces()[f as usize];
                let k = fv.iter().position(|&x| x == v).unwrap();
                let (da, db) =
                    (m.positions()[fv[(k + 1) % 3] as usize] - ps, m.positions()[fv[(k + 2) % 3] as usize] - ps);
                let (xa, ya, xb, yb) = (da.dot(&u), da.dot(&w), db.dot(&u), db.dot(&w));
                let angle = (xa * yb - ya * xb).atan2(xa * xb + ya * yb);
                ok &= angle > 1e-9 && angle < std::f64::consts::PI - 1e-9;
                total += angle;
            }
            let want = ok && (total - std::f64::consts::TAU).abs() < 1e-6;
            assert_eq!(r, want, "vertex {v}, amplitude {amp}, total {total}");
            if r {
                accepted += 1
            } else {
                rejected += 1
            }
        }
    }
    assert!(accepted > 100 && rejected > 100, "{accepted} {rejected}");
}

/// Internal nodes whose self-traversal [`Traversal::patch_is_embedded`] skips, for the
/// positions `ix` was last refit to.
fn skipped_nodes(ix: &SelfIntersector, mesh: &TriMesh) -> Vec<u32> {
    let ctx = ix.traversal(mesh);
    let mut segs = Vec::new();
    (0..ix.nodes.len() as u32).filter(|&n| !ix.nodes[n as usize].leaf && ctx.patch_is_embedded(n, &mut segs)).collect()
}

/// A flat strip wound 1.25 times around the z axis, climbing 0.02 per turn, tilted
/// about its centre line from +0.3 rad at the start to −0.3 rad at the end: every
/// normal is within 0.3 rad of z (a narrow cone) and the strip is one disk, but its last
/// quarter turn crosses its first (the tilts differ by more than the climb allows).
fn crossing_spiral_strip(n_around: usize, n_across: usize) -> TriMesh {
    let turns = 1.25;
    let (w, climb, tilt) = (0.3, 0.02, 0.3);
    let mut pos = Vec::new();
    for i in 0..=n_around {
        let u = i as f64 / n_around as f64;
        let th = u * turns * std::f64::consts::TAU;
        let a = tilt * (1.0 - 2.0 * u);
        for j in 0..=n_across {
            let s = w * (j as f64 / n_across as f64 - 0.5);
            let r = 1.0 + s * a.cos();
            pos.push(Vec3::new(r * th.cos(), r * th.sin(), climb * u * turns + s * a.sin()));
        }
    }
    let id = |i: usize, j: usize| (i * (n_across + 1) + j) as u32;
    let mut faces = Vec::new();
    for i in 0..n_around {
        for j in 0..n_across {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(pos, faces).unwrap()
}

#[test]
fn embedded_patches_are_skipped_and_overlapping_ones_are_not() {
    // A gently curved height-field sheet: no crossings, and whole subtrees skipped.
    let sheet = shapes::grid_sheet(1.0, 1.0, 40, 40).unwrap();
    let p: Vec<Vec3> =
        sheet.positions().iter().map(|p| Vec3::new(p.x, p.y, 0.1 * (3.0 * p.x).sin() * (2.0 * p.y).cos())).collect();
    let sheet = sheet.with_positions(p).unwrap();
    let mut ix = SelfIntersector::new(&sheet);
    let found = ix.find(&sheet);
    assert!(found.segments.is_empty() && found.n_candidate_pairs == 0, "{found:?}");
    let skipped = skipped_nodes(&ix, &sheet);
    assert!(skipped.contains(&0), "the root patch of a height field should be skipped: {skipped:?}");

    // The spiral strip: narrow normal cone, one disk, but it crosses itself, so the
    // root must not be skipped (its projected boundary overlaps itself) while smaller
    // patches are.
    let strip = crossing_spiral_strip(240, 6);
    let mut ix = SelfIntersector::new(&strip);
    let found = ix.find(&strip);
    assert!(ix.tree.patch_ranges[0][0] < ix.tree.patch_ranges[0][1], "the strip is one disk");
    assert!(ix.node_normals[0].direction().is_some(), "the strip's normals lie in a narrow cone");
    let skipped = skipped_nodes(&ix, &strip);
    assert!(!skipped.contains(&0) && skipped.len() > 5, "{skipped:?}");
    assert!(found.segments.len() > 20, "{} segments", found.segments.len());
    let slow = brute_force(&strip);
    assert_eq!(found.points, slow.points);
    assert_eq!(found.segments, slow.segments);

    // Folded through itself (wide normal cone): nothing that crosses is skipped.
    let folded = shapes::folded_sheet(1.0, 24).unwrap();
    let found = self_intersections(&folded);
    assert_eq!(found.segments, brute_force(&folded).segments);
}

/// [`brute_force`] without the pairs of faces that share a nonzero group.
fn brute_force_grouped(mesh: &TriMesh, groups: &[u32]) -> SelfIntersections {
    let n = mesh.n_faces();
    let mut results = Vec::new();
    for f in 0..n {
        let [a, b, c] = mesh.triangle(f);
        let bf = Aabb3::of_triangle(a, b, c);
        for g in f + 1..n {
            let [a, b, c] = mesh.triangle(g);
            if (groups[f] == 0 || groups[f] != groups[g]) && bf.overlaps(&Aabb3::of_triangle(a, b, c)) {
                results.extend(test_pair(mesh, f as u32, g as u32));
            }
        }
    }
    assemble(mesh, results, 0)
}

#[test]
fn nodes_of_one_fan_are_skipped_but_fans_still_meet_other_faces() {
    // An open tube closed by two fans, each pierced by a small box: the fans' own pairs
    // are skipped whole (nodes of one group), the fans' crossings with the boxes are not.
    let tube = shapes::tube(0.5, 1.0, 48, 12, shapes::Caps::Open).unwrap();
    let top = shapes::grid_box(Vec3::new(-0.2, -0.1, 0.8), Vec3::new(0.1, 0.2, 1.2), 3).unwrap();
    let bottom = shapes::grid_box(Vec3::new(0.05, -0.25, -0.15), Vec3::new(0.3, 0.0, 0.1), 3).unwrap();
    let m = shapes::merge(&shapes::merge(&tube, &top).unwrap(), &bottom).unwrap();
    let closure = crate::close_holes(&m, &crate::HoleSelection::All).unwrap();
    let (closed, groups) = (closure.mesh(), closure.fan_groups());
    let mut ix = SelfIntersector::new(closed).with_groups(groups.clone());
    let found = ix.find(closed);
    let grouped_nodes = ix.node_groups.iter().filter(|&&g| g != 0).count();
    assert!(grouped_nodes >= 4, "{grouped_nodes} nodes lie in one fan");
    let slow = brute_force_grouped(closed, &groups);
    assert_eq!(found.points, slow.points);
    assert_eq!(found.segments, slow.segments);
    let fan_hits =
        |group: u32| found.segments.iter().filter(|s| s.faces.iter().any(|&f| groups[f as usize] == group)).count();
    assert!(fan_hits(1) >= 4 && fan_hits(2) >= 4, "{} {}", fan_hits(1), fan_hits(2));
}

#[test]
fn parallel_tree_build_gives_the_sequential_tree() {
    let m = shapes::garment_benchmark().unwrap();
    assert!(m.n_faces() >= 4 * PAR_BUILD_MIN, "{} faces: too few to build in parallel", m.n_faces());
    let centroids: Vec<Vec3> = (0..m.n_faces()).map(|f| m.triangle(f).iter().sum::<Vec3>() / 3.0).collect();
    let nbrs = face_neighbours(&m);
    let keys = centroid_keys(&centroids);
    let (seq_nodes, seq_order) = build_tree([&keys[0], &keys[1], &keys[2]], &nbrs, 0);
    let (par_nodes, par_order) = build_tree([&keys[0], &keys[1], &keys[2]], &nbrs, PAR_BUILD_DEPTH);
    assert_eq!(seq_order, par_order);
    let shape = |n: &[TreeNode]| n.iter().map(|nd| (nd.a, nd.b, nd.leaf)).collect::<Vec<_>>();
    assert_eq!(shape(&seq_nodes), shape(&par_nodes));
}

/// Sort key of face `f` along `axis`: its centroid coordinate's key, then its index.
fn axis_key(centroids: &[Vec3], axis: usize, f: u32) -> (u64, u32) {
    (coordinate_key(centroids[f as usize][axis]), f)
}

/// Per axis, the keys of the centroids' coordinates (the input of [`build_tree`]).
fn centroid_keys(centroids: &[Vec3]) -> [Vec<u64>; 3] {
    std::array::from_fn(|axis| centroids.iter().map(|c| coordinate_key(c[axis])).collect())
}

/// The tree of [`build_tree`], built the plain way: each node's faces sorted along every
/// axis by [`axis_key`], the first half grown across edges from the smallest face (the
/// queued face smallest along the axis first), then every face of the node counted for
/// the stray swaps.
fn reference_tree(centroids: &[Vec3], nbrs: &[[u32; 3]]) -> (Vec<(u32, u32, bool)>, Vec<u32>) {
    fn node(
        centroids: &[Vec3],
        nbrs: &[[u32; 3]],
        nodes: &mut Vec<(u32, u32, bool)>,
        order: &mut [u32],
        lo: usize,
        hi: usize,
    ) -> u32 {
        let id = nodes.len();
        nodes.push((lo as u32, hi as u32, true));
        if hi - lo <= LEAF_SIZE {
            return id as u32;
        }
        let sorted = |ax: usize| {
            let mut faces = order[lo..hi].to_vec();
            faces.sort_by_key(|&f| axis_key(centroids, ax, f));
            faces
        };
        let lists = [sorted(0), sorted(1), sorted(2)];
        let ext = |ax: usize| centroids[*lists[ax].last().unwrap() as usize][ax] - centroids[lists[ax][0] as usize][ax];
        let axis = if ext(0) >= ext(1) && ext(0) >= ext(2) {
            0
        } else if ext(1) >= ext(2) {
            1
        } else {
            2
        };
        let sorted = &lists[axis];
        let mid = lo + ((hi - lo).div_ceil(LEAF_SIZE) / 2) * LEAF_SIZE;
        // Side per face of the node: 0 first half, 1 second half.
        let mut side: std::collections::HashMap<u32, u32> = sorted.iter().map(|&f| (f, 1)).collect();
        let mut queue = std::collections::BTreeSet::new();
        let mut queued = std::collections::HashSet::new();
        let mut taken = 0;
        while taken < mid - lo {
            let f = match queue.pop_first() {
                Some((_, f)) => f,
                None => *sorted.iter().find(|&&f| side[&f] == 1).unwrap(),
            };
            side.insert(f, 0);
            taken += 1;
            for g in nbrs[f as usize] {
                if side.get(&g) == Some(&1) && queued.insert(g) {
                    queue.insert((axis_key(centroids, axis, g), g));
                }
            }
        }
        let (left, right): (Vec<u32>, Vec<u32>) = sorted.iter().partition(|&&f| side[&f] == 0);
        order[lo..mid].copy_from_slice(&left);
        order[mid..hi].copy_from_slice(&right);
        for _ in 0..2 {
            let (mut strays, mut notches) = ([vec![], vec![]], [vec![], vec![]]);
            for slot in lo..hi {
                let f = order[slot];
                let own = side[&f];
                let on = |s: u32| nbrs[f as usize].iter().filter(|g| side.get(g) == Some(&s)).count();
                let k = (slot >= mid) as usize;
                match (on(own), on(1 - own)) {
                    (0, o) if o > 0 => strays[k].push(slot),
                    (1, 2) => notches[k].push(slot),
                    _ => {}
                }
            }
            let m = strays[0].len().min(strays[1].len());
            if strays[0].len() + strays[1].len() == 0 {
                break;
            }
            let pairs: Vec<(usize, usize)> = strays[0]
                .iter()
                .copied()
                .zip(strays[1].iter().copied())
                .chain(strays[0][m..].iter().copied().zip(notches[1].iter().copied()))
                .chain(notches[0].iter().copied().zip(strays[1][m..].iter().copied()))
                .collect();
            for (a, b) in pairs {
                order.swap(a, b);
                side.insert(order[a], 0);
                side.insert(order[b], 1);
            }
        }
        let l = node(centroids, nbrs, nodes, order, lo, mid);
        let r = node(centroids, nbrs, nodes, order, mid, hi);
        nodes[id] = (l, r, false);
        id as u32
    }
    let mut order: Vec<u32> = (0..centroids.len() as u32).collect();
    let mut nodes = Vec::new();
    if !order.is_empty() {
        node(centroids, nbrs, &mut nodes, &mut order, 0, centroids.len());
    }
    (nodes, order)
}

#[test]
fn tree_build_gives_the_reference_tree() {
    let meshes = [
        shapes::garment_benchmark().unwrap(),
        shapes::fixture("sleeve_torso_grid").unwrap(),
        shapes::jitter(&shapes::torus(1.0, 0.3, 40, 16).unwrap(), 0.01, 3).unwrap(),
        shapes::folded_sheet(1.0, 24).unwrap(),
        shapes::grid_box(Vec3::zeros(), Vec3::new(1.0, 2.0, 0.5), 7).unwrap(),
    ];
    for m in &meshes {
        let centroids: Vec<Vec3> = (0..m.n_faces()).map(|f| m.triangle(f).iter().sum::<Vec3>() / 3.0).collect();
        let nbrs = face_neighbours(m);
        let keys = centroid_keys(&centroids);
        let (nodes, order) = build_tree([&keys[0], &keys[1], &keys[2]], &nbrs, PAR_BUILD_DEPTH);
        let (ref_nodes, ref_order) = reference_tree(&centroids, &nbrs);
        assert_eq!(order, ref_order);
        assert_eq!(nodes.iter().map(|nd| (nd.a, nd.b, nd.leaf)).collect::<Vec<_>>(), ref_nodes);
    }
}

#[test]
fn grown_splits_make_most_nodes_disks() {
    // A sleeve pushed into a torso (grid-made): with halves grown across edges, 85% of
    // the nodes large enough to be tried are topological disks (79% with plain median
    // splits).
    let m = shapes::fixture("sleeve_torso_grid").unwrap();
    let ix = SelfIntersector::new(&m);
    let mut sizes = vec![0u32; ix.nodes.len()];
    for i in (0..ix.nodes.len()).rev() {
        let nd = ix.nodes[i];
        sizes[i] = if nd.leaf { nd.b - nd.a } else { sizes[nd.a as usize] + sizes[nd.b as usize] };
    }
    let tried: Vec<usize> = (0..ix.nodes.len()).filter(|&n| sizes[n] >= MIN_PATCH).collect();
    let disks = tried.iter().filter(|&&n| ix.tree.patch_ranges[n][0] < ix.tree.patch_ranges[n][1]).count();
    assert!(disks * 100 >= tried.len() * 83, "{disks} of {} nodes are disks", tried.len());
}

#[test]
fn boundary_segment_tests_separate_only_with_margin() {
    let seg = |ids: [u32; 2], p: [f64; 2], q: [f64; 2]| Seg2 { ids, p, q, xmin: p[0].min(q[0]) };
    let tol = 1e-9;
    // Collinear, disjoint along the line.
    assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [2.0, 0.0], [3.0, 0.0]), tol));
    // Collinear, overlapping.
    assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [0.5, 0.0], [3.0, 0.0]), tol));
    // Crossing.
    assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 1.0]), &seg([2, 3], [0.0, 1.0], [1.0, 0.0]), tol));
    // Touching at a vertex of the other (not shared): not certainly apart.
    assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([2, 3], [0.5, 0.0], [0.5, 1.0]), tol));
    // Sharing a vertex: apart unless they leave it in the same direction.
    assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [2.0, 0.0]), tol));
    assert!(segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [0.0, 1.0]), tol));
    assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([1, 2], [1.0, 0.0], [0.5, 0.0]), tol));
    assert!(!segments_apart(&seg([0, 1], [0.0, 0.0], [1.0, 0.0]), &seg([0, 1], [0.0, 0.0], [1.0, 0.0]), tol));
}

#[test]
fn ray_counts_are_winding_numbers_in_every_direction() {
    let v = |x: f64, y: f64, z: f64| Vec3::new(x, y, z);
    let big = shapes::icosphere(v(0.0, 0.0, 0.0), 1.0, 2).unwrap();
    let small = shapes::icosphere(v(0.1, 0.0, 0.0), 0.4, 2).unwrap();
    let nested = shapes::merge(&big, &small).unwrap();
    let inverted = shapes::turned_over(&big).unwrap();
    // (mesh, point, winding number there)
    let cases = [
        (&big, v(0.0, 0.0, 0.0), 1),
        (&big, v(2.0, 0.3, 0.0), 0),
        (&nested, v(0.1, 0.0, 0.0), 2),
        (&nested, v(0.0, 0.8, 0.0), 1),
        (&nested, v(0.0, 0.0, 3.0), 0),
        (&inverted, v(0.0, 0.0, 0.0), -1),
    ];
    for (mesh, origin, expect) in cases {
        let mut ix = SelfIntersector::new(mesh);
        ix.find(mesh);
        for axis in 0..3 {
            for positive in [false, true] {
                let ray = AxisRay { origin, axis, positive };
                assert_eq!(ray_winding_brute(mesh, &ray, u32::MAX, &[]), Some(expect), "{origin:?} {axis} {positive}");
                assert_eq!(ix.ray_winding(mesh, &ray, u32::MAX, &[]), Some(expect), "{origin:?} {axis} {positive}");
            }
        }
    }
}

#[test]
fn rays_through_edges_and_vertices_of_grid_meshes_count_consistently() {
    // A grid box: rays from lattice points run exactly along faces, through edges and
    // vertices; the perturbed count must still be the winding number (1 inside, 0 outside)
    // and the BVH must agree with the brute force.
    let m = shapes::grid_box(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), 4).unwrap();
    let mut ix = SelfIntersector::new(&m);
    ix.find(&m);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for _ in 0..400 {
        let q = Vec3::new(
            rng.random_range(-2..7) as f64 / 4.0,
            rng.random_range(-2..7) as f64 / 4.0,
            rng.random_range(-2..7) as f64 / 4.0,
        );
        let strictly_inside = q.iter().all(|&c| c > 0.0 && c < 1.0);
        let strictly_outside = q.iter().any(|&c| !(0.0..=1.0).contains(&c));
        for axis in 0..3 {
            for positive in [false, true] {
                let ray = AxisRay { origin: q, axis, positive };
                let w = ray_winding_brute(&m, &ray, u32::MAX, &[]);
                assert_eq!(ix.ray_winding(&m, &ray, u32::MAX, &[]), w);
                if strictly_inside {
                    assert_eq!(w, Some(1), "{q:?}");
                } else if strictly_outside {
                    assert_eq!(w, Some(0), "{q:?}");
                } else {
                    // On the surface: refused when the ray leaves through the face the
                    // origin lies on; otherwise one side or the other.
                    assert!(matches!(w, None | Some(0) | Some(1)), "{q:?} {w:?}");
                }
            }
        }
    }
}

#[test]
fn rays_count_virtual_fans_over_open_holes() {
    // A sphere with a cap of faces removed: from the centre, rays through the hole count the
    // virtual fan, so every direction gives the closed surface's winding number.
    let full = shapes::icosphere(Vec3::zeros(), 1.0, 2).unwrap();
    let keep: Vec<[u32; 3]> = full
        .faces()
        .iter()
        .copied()
        .filter(|f| f.iter().map(|&v| full.positions()[v as usize].z).sum::<f64>() / 3.0 < 0.8)
        .collect();
    let open = TriMesh::new(full.positions().to_vec(), keep).unwrap();
    let loops = open.topology().boundary_loops().to_vec();
    assert_eq!(loops.len(), 1);
    let mut ix = SelfIntersector::new(&open);
    ix.find(&open);
    let up = AxisRay { origin: Vec3::new(0.01, 0.02, 0.0), axis: 2, positive: true };
    let down = AxisRay { positive: false, ..up };
    for ray in [up, down] {
        assert_eq!(ray_winding_brute(&open, &ray, u32::MAX, &loops), Some(1));
        assert_eq!(ix.ray_winding(&open, &ray, u32::MAX, &loops), Some(1));
    }
    // Without the fan, the ray through the hole misses the surface.
    assert_eq!(ray_winding_brute(&open, &up, u32::MAX, &[]), Some(0));
}

#[test]
fn rays_from_a_face_through_an_exactly_coplanar_face_are_refused() {
    // Two overlapping triangles exactly in the plane z = x + 2y (dyadic coordinates) and a
    // third one above: from the first face's centroid, rounded off that plane, the line
    // meets the coplanar second face, on whose side the origin lies by rounding; the ray is
    // refused, from either face, through the tree or not. With the second face lifted by
    // 1e-9 it is crossed like any other.
    for lift in [0.0, 1e-9] {
        let pos = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.125, 1.25),
            Vec3::new(0.125, 0.875, 1.875),
            Vec3::new(0.125, 0.125, 0.375 + lift),
            Vec3::new(1.125, 0.25, 1.625 + lift),
            Vec3::new(0.25, 1.0, 2.25 + lift),
            Vec3::new(-1.0, -1.0, 5.0),
            Vec3::new(3.0, -1.0, 5.0),
            Vec3::new(-1.0, 3.0, 5.0),
        ];
        let m = TriMesh::new(pos, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]).unwrap();
        let mut ix = SelfIntersector::new(&m);
        ix.find(&m);
        for skip in [0u32, 1] {
            let [a, b, c] = m.triangle(skip as usize);
            let origin = (a + b + c) / 3.0;
            assert_ne!(orient3d_value(a, b, c, origin), 0.0, "the centroid is rounded off the plane");
            let ray = AxisRay { origin, axis: 2, positive: true };
            let brute = ray_winding_brute(&m, &ray, skip, &[]);
            assert_eq!(ix.ray_winding(&m, &ray, skip, &[]), brute);
            if lift == 0.0 {
                assert_eq!(brute, None, "face {skip}");
            } else {
                // Up from face 0 the ray crosses face 1 and the top face; from face 1 only
                // the top face (face 0 lies below it).
                let expect = if skip == 0 { 2 } else { 1 };
                assert_eq!(brute, Some(expect), "face {skip}");
            }
        }
    }
}

#[test]
fn normal_cones_bound_every_normal_they_hold() {
    // Unit normals scattered around random axes at random spreads, merged pairwise up a
    // balanced tree as the refit merges them: every normal of a subtree must satisfy the
    // subtree cone's bound, and cones must exist where the spread is small.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut with_cone = 0;
    for case in 0..400 {
        let axis = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
            .normalize();
        let spread = [1e-9, 1e-3, 0.1, 0.5, 1.0][case % 5];
        let units: Vec<Vec3> = (0..64)
            .map(|_| {
                let off = Vec3::new(
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                );
                (axis + off).normalize()
            })
            .collect();
        let mut level: Vec<(NormalCone, Vec<Vec3>)> =
            units.chunks(LEAF_SIZE).map(|c| (NormalCone::of_units(c, true), c.to_vec())).collect();
        while level.len() > 1 {
            level = level
                .chunks(2)
                .map(|p| {
                    let mut all = p[0].1.clone();
                    all.extend(&p[1].1);
                    (p[0].0.merge(&p[1].0), all)
                })
                .collect();
            for (cone, us) in &level {
                if let Some(d) = cone.direction() {
                    for u in us {
                        assert!(u.dot(&d) >= cone.cos, "case {case}: {} < {}", u.dot(&d), cone.cos);
                    }
                }
            }
        }
        if spread <= 0.1 {
            with_cone += level[0].0.direction().is_some() as usize;
        }
    }
    assert_eq!(with_cone, 240, "every set spread by at most 0.1 has a cone");
    assert!(NormalCone::of_units(&[Vec3::z(), -Vec3::z()], true).direction().is_none());
    assert!(NormalCone::of_units(&[Vec3::z()], false).direction().is_none());
}

/// [`disk_patches`] computed face by face for every node: the reference of the bottom-up
/// version.
fn disk_patches_by_faces(
    n_vertices: usize,
    nodes: &[TreeNode],
    slot_faces: &[[u32; 3]],
    slot_nbrs: &[[u32; 3]],
    kinds: &[u8],
) -> DiskPatches {
    let mut range = vec![[0u32; 2]; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let nd = nodes[i];
        range[i] = if nd.leaf { [nd.a, nd.b] } else { [range[nd.a as usize][0], range[nd.b as usize][1]] };
    }
    let mut out = vec![[0u32; 2]; nodes.len()];
    let mut edges: Vec<[u32; 2]> = Vec::new();
    let mut deg = vec![0u32; n_vertices];
    let mut seen = vec![u32::MAX; n_vertices];
    let mut reached_by = vec![u32::MAX; slot_faces.len()];
    let (mut verts, mut stack) = (Vec::new(), Vec::new());
    for (id, &[lo, hi]) in range.iter().enumerate() {
        let id32 = id as u32;
        let start = edges.len();
        out[id] = [start as u32; 2];
        if hi - lo < MIN_PATCH {
            continue;
        }
        // Slots are contiguous per node; `NO_FACE` is never inside.
        let inside = |slot: u32| (lo..hi).contains(&slot);
        let mut half_interior = 0usize;
        let mut manifold = true;
        verts.clear();
        for slot in lo as usize..hi as usize {
            let fv = slot_faces[slot];
            for k in 0..3 {
                let v = fv[k] as usize;
                if seen[v] != id32 {
                    seen[v] = id32;
                    verts.push(v);
                    manifold &= kinds[v] != RING_OTHER;
                }
                if inside(slot_nbrs[slot][k]) {
                    half_interior += 1;
                } else {
                    let (a, b) = (fv[(k + 1) % 3], fv[(k + 2) % 3]);
                    edges.push([a, b]);
                    deg[a as usize] += 1;
                    deg[b as usize] += 1;
                }
            }
        }
        let n_boundary = edges.len() - start;
        for &v in &verts {
            manifold &= deg[v] == 0 || deg[v] == 2;
            deg[v] = 0;
        }
        let euler = verts.len() as i64 - (half_interior / 2 + n_boundary) as i64 + (hi - lo) as i64;
        let mut disk = manifold && euler == 1 && n_boundary > 0;
        if disk {
            reached_by[lo as usize] = id32;
            stack.clear();
            stack.push(lo);
            let mut reached = 1;
            while let Some(slot) = stack.pop() {
                for g in slot_nbrs[slot as usize] {
                    if inside(g) && reached_by[g as usize] != id32 {
                        reached_by[g as usize] = id32;
                        reached += 1;
                        stack.push(g);
                    }
                }
            }
            disk = reached == hi - lo;
        }
        if disk {
            out[id] = [start as u32, edges.len() as u32];
        } else {
            edges.truncate(start);
        }
    }
    DiskPatches { ranges: out, edges, slots: range }
}

/// [`ring_kinds`] by counting, per vertex, the ring faces that hold each neighbour.
fn ring_kinds_by_counting(mesh: &TriMesh) -> Vec<u8> {
    let faces = mesh.faces();
    (0..mesh.n_vertices() as u32)
        .map(|s| {
            let ring = mesh.topology().vertex_faces(s);
            if ring.is_empty() {
                return RING_OTHER;
            }
            let mut count: Vec<(u32, u8)> = Vec::new();
            for &f in ring {
                for v in faces[f as usize] {
                    if v == s {
                        continue;
                    }
                    match count.iter_mut().find(|e| e.0 == v) {
                        Some(e) => e.1 += 1,
                        None => count.push((v, 1)),
                    }
                }
            }
            let n_once = count.iter().filter(|e| e.1 == 1).count();
            match (count.iter().any(|e| e.1 > 2), n_once) {
                (true, _) => RING_OTHER,
                (false, 0) => RING_CLOSED,
                (false, 2) => RING_OPEN,
                _ => RING_OTHER,
            }
        })
        .collect()
}

/// Two icospheres sharing one vertex (its ring is two closed fans), an open tube whose rim
/// vertex also closes a cone (an open and a closed fan), and a sheet.
fn pinched_meshes() -> Vec<TriMesh> {
    let a = shapes::icosphere(Vec3::zeros(), 1.0, 2).unwrap();
    let top = (0..a.n_vertices()).max_by(|&i, &j| a.positions()[i].z.total_cmp(&a.positions()[j].z)).unwrap();
    let shift = Vec3::new(0.0, 0.0, 2.0 * a.positions()[top].z);
    let bottom = (0..a.n_vertices()).min_by(|&i, &j| a.positions()[i].z.total_cmp(&a.positions()[j].z)).unwrap();
    // The second sphere, moved up so that its bottom vertex meets the first's top one.
    let n = a.n_vertices() as u32;
    let mut pos: Vec<Vec3> = a.positions().to_vec();
    pos.extend(a.positions().iter().map(|p| p + shift));
    let remap = |v: u32| if v == bottom as u32 { top as u32 } else { v + n };
    let mut faces: Vec<[u32; 3]> = a.faces().to_vec();
    faces.extend(a.faces().iter().map(|f| f.map(remap)));
    let spheres = TriMesh::new(pos, faces).unwrap();
    let tube = shapes::tube(0.5, 1.0, 16, 8, shapes::Caps::Open).unwrap();
    // A closed cone of 6 faces on the first rim vertex.
    let apex = 0u32;
    let mut pos: Vec<Vec3> = tube.positions().to_vec();
    let base = pos.len() as u32;
    let p0 = pos[apex as usize];
    for k in 0..6 {
        let t = k as f64 * std::f64::consts::TAU / 6.0;
        pos.push(p0 + Vec3::new(-0.2, 0.1 * t.cos(), 0.1 * t.sin()));
    }
    pos.push(p0 + Vec3::new(-0.3, 0.0, 0.0));
    let mut faces: Vec<[u32; 3]> = tube.faces().to_vec();
    for k in 0..6u32 {
        faces.push([apex, base + (k + 1) % 6, base + k]);
        faces.push([base + 6, base + k, base + (k + 1) % 6]);
    }
    let tube_cone = TriMesh::new(pos, faces).unwrap();
    // A sheet with two interior vertices far apart made one (two closed fans, linked
    // through the sheet: the sheet is no disk, though its Euler count without the pinch
    // would say so).
    let sheet = shapes::grid_sheet(1.0, 1.0, 24, 9).unwrap();
    let near = |x: f64, y: f64| {
        (0..sheet.n_vertices() as u32)
            .min_by(|&i, &j| {
                let d = |k: u32| (sheet.positions()[k as usize] - Vec3::new(x, y, 0.0)).norm();
                d(i).total_cmp(&d(j))
            })
            .unwrap()
    };
    let (p, q) = (near(0.2, 0.5), near(0.8, 0.5));
    let faces: Vec<[u32; 3]> = sheet.faces().iter().map(|f| f.map(|v| if v == q { p } else { v })).collect();
    let pinched_sheet = TriMesh::new(sheet.positions().to_vec(), faces).unwrap();
    vec![spheres, tube_cone, pinched_sheet, shapes::grid_sheet(1.0, 1.0, 12, 9).unwrap()]
}

#[test]
fn ring_kinds_match_the_neighbour_count() {
    let mut meshes = pinched_meshes();
    meshes.push(shapes::garment_benchmark().unwrap());
    for f in shapes::FIXTURES {
        meshes.push(shapes::fixture(f.name).unwrap());
    }
    for m in &meshes {
        assert_eq!(ring_kinds(m), ring_kinds_by_counting(m));
    }
    let (start, links) = ring_links(&meshes[0]);
    let pinched = ring_fans(&ring_kinds(&meshes[0]), &start, &links);
    assert_eq!(pinched.iter().filter(|&&p| p).count(), 1, "the spheres' shared vertex");
    let (start, links) = ring_links(&meshes[1]);
    assert_eq!(ring_fans(&ring_kinds(&meshes[1]), &start, &links).iter().filter(|&&p| p).count(), 1);
    let (start, links) = ring_links(&meshes[2]);
    assert_eq!(ring_fans(&ring_kinds(&meshes[2]), &start, &links).iter().filter(|&&p| p).count(), 1);
}

#[test]
fn disk_patches_bottom_up_match_the_face_by_face_count() {
    let mut meshes = pinched_meshes();
    meshes.push(shapes::garment_benchmark().unwrap());
    for f in shapes::FIXTURES {
        meshes.push(shapes::fixture(f.name).unwrap());
    }
    let mut n_disks = 0;
    for m in &meshes {
        let ix = SelfIntersector::new(m);
        let t = &ix.tree;
        let order = &t.order;
        let nbrs = face_neighbours(m);
        let mut slot_of = vec![0u32; order.len()];
        for (slot, &f) in order.iter().enumerate() {
            slot_of[f as usize] = slot as u32;
        }
        let slot_nbrs: Vec<[u32; 3]> = order
            .iter()
            .map(|&f| nbrs[f as usize].map(|g| if g == NO_FACE { NO_FACE } else { slot_of[g as usize] }))
            .collect();
        let reference = disk_patches_by_faces(m.n_vertices(), &t.nodes, &t.slot_faces, &slot_nbrs, &t.ring_kind);
        assert_eq!(reference.slots, t.node_slots);
        for (i, (&[a, b], &[c, d])) in reference.ranges.iter().zip(&t.patch_ranges).enumerate() {
            assert_eq!(reference.edges[a as usize..b as usize], t.patch_edges[c as usize..d as usize], "node {i}");
            n_disks += (a < b) as usize;
        }
    }
    assert!(n_disks > 100, "{n_disks} disks");
}

#[test]
fn radix_order_sorts_by_key_then_index() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    for n in [0usize, 1, 7, 1000, 5000] {
        // Few distinct keys (ties broken by index), and keys spread over all 64 bits.
        let small: Vec<u64> = (0..n).map(|_| rng.random_range(0..5u64) << 40).collect();
        let wide: Vec<u64> = (0..n).map(|_| rng.random::<u64>()).collect();
        for keys in [small, wide] {
            let mut expected: Vec<u32> = (0..n as u32).collect();
            expected.sort_by_key(|&i| (keys[i as usize], i));
            assert_eq!(radix_order(&keys), expected);
        }
    }
}
