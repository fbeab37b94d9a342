//! Exact self-intersection on hand-built configurations (the paper's Figure 4 and the
//! degenerate cases), grid-made versus jittered meshes, and rigid-motion invariance.

use proptest::prelude::*;
use senc_geom::intersect::{self_intersections, SegmentEnd, SelfIntersector};
use senc_geom::{TriMesh, Vec3};
use senc_testmesh::{grid_box, jitter, merge, rigid_transform};

fn mesh(p: &[[f64; 3]], f: &[[u32; 3]]) -> TriMesh {
    TriMesh::new(p.iter().map(|x| Vec3::new(x[0], x[1], x[2])).collect(), f.to_vec()).unwrap()
}

#[test]
fn two_crossing_triangles_give_one_segment_with_two_points() {
    // Figure 4, middle: a horizontal triangle pierced by a vertical one.
    let m = mesh(
        &[[0., 0., 0.], [2., 0., 0.], [0., 2., 0.], [0.5, 0.5, -1.], [0.5, 0.5, 1.], [1.5, -1., 0.3]],
        &[[0, 1, 2], [3, 4, 5]],
    );
    let x = self_intersections(&m);
    assert_eq!(x.segments.len(), 1);
    assert_eq!(x.points.len(), 2);
    assert!(matches!(x.segments[0].ends, [SegmentEnd::Point(_), SegmentEnd::Point(_)]));
}

#[test]
fn triangles_sharing_a_vertex_report_a_loop_vertex() {
    // Figure 4, left: the opposite edge of one triangle crosses the other.
    let m = mesh(&[[0., 0., 0.], [2., 0., 0.], [0., 2., 0.], [1.0, 0.3, -1.], [0.3, 1.0, 1.]], &[[0, 1, 2], [0, 3, 4]]);
    let x = self_intersections(&m);
    assert_eq!(x.segments.len(), 1);
    assert_eq!(x.segments[0].ends[0], SegmentEnd::LoopVertex(0));
    assert_eq!(x.points.len(), 1);
}

#[test]
fn triangles_sharing_an_edge_are_skipped() {
    let m = mesh(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.2, 0.2, 0.]], &[[0, 1, 2], [1, 0, 3]]);
    assert!(self_intersections(&m).segments.is_empty());
}

#[test]
fn degenerate_contacts_are_decided_once() {
    // Vertex exactly on a face, edge exactly through an edge, coplanar overlap: each pair
    // reports zero or one segment (never a half-crossing).
    type Case = (Vec<[f64; 3]>, Vec<[u32; 3]>);
    let cases: Vec<Case> = vec![
        // vertex of the second triangle exactly inside the first
        (
            vec![[0., 0., 0.], [2., 0., 0.], [0., 2., 0.], [0.5, 0.5, 0.], [0.5, 0.5, 1.], [1., 1., 1.]],
            vec![[0, 1, 2], [3, 4, 5]],
        ),
        // edge exactly through an edge
        (
            vec![[0., 0., 0.], [2., 0., 0.], [0., 2., 0.], [1., -1., 0.], [1., 1., 0.], [1., 0., 1.]],
            vec![[0, 1, 2], [3, 4, 5]],
        ),
        // coplanar overlapping triangles
        (
            vec![[0., 0., 0.], [2., 0., 0.], [0., 2., 0.], [0.5, 0.5, 0.], [2.5, 0.5, 0.], [0.5, 2.5, 0.]],
            vec![[0, 1, 2], [3, 4, 5]],
        ),
    ];
    for (p, f) in cases {
        let m = mesh(&p, &f);
        let x = self_intersections(&m);
        assert!(x.segments.len() <= 1);
        assert_eq!(x.n_inconsistent_pairs, 0);
        for s in &x.segments {
            assert!(matches!(s.ends, [SegmentEnd::Point(_), SegmentEnd::Point(_)]));
        }
    }
}

fn boxes(offset: Vec3, n: usize) -> TriMesh {
    let a = grid_box(Vec3::zeros(), Vec3::repeat(1.0), n).unwrap();
    merge(&a, &grid_box(offset, offset + Vec3::repeat(1.0), n).unwrap()).unwrap()
}

#[test]
fn every_point_is_shared_by_two_segments_on_closed_meshes() {
    // Paths stay connected: on a closed mesh each (edge, face) point ends exactly two
    // segments, grid-made (exact degeneracies) or jittered.
    for m in [boxes(Vec3::new(0.5, 0.5, 0.5), 4), jitter(&boxes(Vec3::new(0.5, 0.5, 0.5), 4), 1e-9, 1).unwrap()] {
        let x = self_intersections(&m);
        assert!(!x.segments.is_empty());
        let mut count = vec![0; x.points.len()];
        for s in &x.segments {
            for e in s.ends {
                if let SegmentEnd::Point(i) = e {
                    count[i as usize] += 1;
                }
            }
        }
        assert!(count.iter().all(|&c| c == 2), "{count:?}");
    }
}

#[test]
fn refit_gives_the_same_answer_as_rebuild() {
    let m = boxes(Vec3::new(0.3, 0.2, 0.1), 3);
    let moved = boxes(Vec3::new(0.35, 0.25, 0.05), 3);
    let mut ix = SelfIntersector::new(&m);
    let _ = ix.find(&m);
    assert_eq!(ix.find(&moved), self_intersections(&moved));
}

#[test]
fn a_tree_shared_through_the_topology_gives_the_same_answer_as_a_fresh_one() {
    // The first intersector builds the topology's tree at these positions; a mesh with the
    // same topology at other positions reuses it.
    let m = boxes(Vec3::new(0.3, 0.2, 0.1), 3);
    let first = self_intersections(&m);
    let moved = boxes(Vec3::new(0.35, 0.25, 0.05), 3).positions().to_vec();
    let shared = m.with_positions(moved.clone()).unwrap();
    let fresh = TriMesh::new(moved, m.faces().to_vec()).unwrap();
    let expected = self_intersections(&fresh);
    assert_ne!(first, expected);
    assert_eq!(SelfIntersector::new(&shared).find(&shared), expected);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn rigid_motion_keeps_the_crossing_set(ax in -3.0f64..3.0, ay in -3.0f64..3.0, az in -3.0f64..3.0, t in -5.0f64..5.0, seed in 0u64..1000) {
        let m = jitter(&boxes(Vec3::new(0.4, 0.3, 0.2), 2), 1e-4, seed).unwrap();
        let rot = nalgebra::Rotation3::from_euler_angles(ax, ay, az);
        let moved = rigid_transform(&m, &rot, &Vec3::new(t, -t, 0.5 * t)).unwrap();
        prop_assert_eq!(self_intersections(&m).face_pairs(), self_intersections(&moved).face_pairs());
    }

    #[test]
    fn random_triangle_soups_never_panic(coords in proptest::collection::vec(-1.0f64..1.0, 36), snap in proptest::bool::ANY) {
        // Four random triangles, optionally snapped to a coarse grid (exact degeneracies).
        let c: Vec<f64> = if snap { coords.iter().map(|x| (x * 2.0).round() / 2.0).collect() } else { coords };
        let p: Vec<Vec3> = c.chunks(3).map(|v| Vec3::new(v[0], v[1], v[2])).collect();
        let f: Vec<[u32; 3]> = (0..4).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        if let Ok(m) = TriMesh::new(p, f) {
            let x = self_intersections(&m);
            prop_assert_eq!(x.n_inconsistent_pairs, 0);
        }
    }
}

#[test]
fn output_does_not_depend_on_the_thread_count() {
    let m = senc_testmesh::fixture("sleeve_torso_jitter").unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| self_intersections(&m));
    let four = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap().install(|| self_intersections(&m));
    assert!(!one.segments.is_empty());
    assert_eq!(one, four);
}
