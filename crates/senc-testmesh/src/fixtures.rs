//! The named fixtures: generator calls whose reference answers are committed under
//! `tests/fixtures/` at the repository root.

use super::*;

/// A named mesh whose reference answers live in `tests/fixtures/<name>.json` at the
/// repository root (see `tests/fixtures/README.md`).
#[derive(Debug, Clone, Copy)]
pub struct Fixture {
    /// The name, also the answer file's stem.
    pub name: &'static str,
    /// Generator call and parameters, in words.
    pub description: &'static str,
    /// Whether penetration volumes are measured after closing every hole with a fan.
    pub close_holes: bool,
    make: fn() -> Result<TriMesh, ShapeError>,
}

impl Fixture {
    /// Generates the mesh.
    pub fn build(&self) -> Result<TriMesh, ShapeError> {
        (self.make)()
    }
}

/// Relative jitter of the `*_jitter` fixtures (of the bounding-box diagonal).
pub const FIXTURE_JITTER: f64 = 1e-9;
/// Seed of the `*_jitter` fixtures.
pub const FIXTURE_SEED: u64 = 7;

pub(super) fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}
pub(super) fn unit_box() -> Result<TriMesh, ShapeError> {
    grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 8)
}
pub(super) fn boxes_at(x0: f64) -> Result<TriMesh, ShapeError> {
    let b = grid_box(v(x0, 0.25, 0.125), v(x0 + 1.0, 1.25, 1.125), 8)?;
    merge(&unit_box()?, &b)
}
pub(super) fn jittered(m: Result<TriMesh, ShapeError>) -> Result<TriMesh, ShapeError> {
    jitter(&m?, FIXTURE_JITTER, FIXTURE_SEED)
}
pub(super) fn boxes_overlap_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(0.5)
}
pub(super) fn boxes_touch_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(1.0)
}
pub(super) fn boxes_apart_grid() -> Result<TriMesh, ShapeError> {
    boxes_at(1.25)
}
pub(super) fn icospheres_overlap_grid() -> Result<TriMesh, ShapeError> {
    merge(&icosphere(v(0.0, 0.0, 0.0), 1.0, 4)?, &icosphere(v(1.2, 0.0, 0.0), 1.0, 4)?)
}
pub(super) fn bent_tube_grid() -> Result<TriMesh, ShapeError> {
    bent_tube(0.1, 0.6, 135f64.to_radians(), 0.02, 64, 24)
}
pub(super) fn sleeve_torso_grid() -> Result<TriMesh, ShapeError> {
    sleeve_through_torso(&SleeveTorso::default())
}
pub(super) fn folded_sheet_grid() -> Result<TriMesh, ShapeError> {
    folded_sheet(1.0, 40)
}
pub(super) fn sphere_l5() -> Result<TriMesh, ShapeError> {
    icosphere(v(0.0, 0.0, 0.0), 1.0, 5)
}
pub(super) fn torus_bench() -> Result<TriMesh, ShapeError> {
    torus(1.0, 0.3, 128, 48)
}
/// Two equal boxes, the second shifted by half its width along x: overlap 0.5 m³ (their
/// faces at y = 0, 1 and z = 0, 1 are coplanar, hence the jitter).
pub(super) fn equal_boxes_half() -> Result<TriMesh, ShapeError> {
    let a = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 7)?;
    let b = grid_box(v(0.5, 0.0, 0.0), v(1.5, 1.0, 1.0), 7)?;
    jittered(merge(&a, &b))
}
/// A capped 24-gon tube of radius 0.2 along x through a box 0.5 thick: the tube's wall
/// inside the box is an annulus bounded by two contours; overlap = 24-gon area × 0.5.
pub(super) fn tube_through_box() -> Result<TriMesh, ShapeError> {
    let t = tube(0.2, 2.0, 24, 8, Caps::Fan)?;
    let rot = Rotation3::from_euler_angles(0.0, std::f64::consts::FRAC_PI_2, 0.0);
    let t = rigid_transform(&t, &rot, &v(-1.0, 0.0, 0.0))?;
    let b = grid_box(v(-0.2, -0.6, -0.6), v(0.3, 0.6, 0.6), 8)?;
    jittered(merge(&t, &b))
}
/// Three boxes overlapping pairwise with a common core: winding 3 there, 2 where exactly
/// two overlap. Volume |A∩B| + |A∩C| + |B∩C| − 2 |A∩B∩C|.
pub(super) fn nested_boxes() -> Result<TriMesh, ShapeError> {
    let a = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 6)?;
    let b = grid_box(v(0.3, 0.2, 0.1), v(1.3, 1.2, 1.1), 6)?;
    let c = grid_box(v(0.6, -0.27, 0.4), v(1.6, 0.73, 1.4), 6)?;
    jittered(merge(&merge(&a, &b)?, &c))
}
/// A closed tube bent back by 160° so that the second leg passes through the elbow's inner
/// wall.
pub(super) fn elbow_fold() -> Result<TriMesh, ShapeError> {
    jittered(bent_tube(0.1, 0.8, 160f64.to_radians(), 0.03, 32, 24))
}
/// A unit box whose top (z = 1) is left open, pierced by two closed boxes: one pushed in
/// through the opening without touching the walls, one through the opening and the wall
/// x = 1. With the opening fanned, the parts below it are penetrated:
/// 0.38 · 0.39 · 0.3 + 0.28 · 0.32 · 0.2 m³.
pub(super) fn open_box_pierced() -> Result<TriMesh, ShapeError> {
    let outer = grid_box(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), 1)?;
    let faces: Vec<[u32; 3]> =
        outer.faces().iter().copied().filter(|t| !t.iter().all(|&i| outer.positions()[i as usize].z == 1.0)).collect();
    let open = TriMesh::new(outer.positions().to_vec(), faces)?;
    let through_top = grid_box(v(0.23, 0.27, 0.7), v(0.61, 0.66, 1.4), 12)?;
    let through_corner = grid_box(v(0.72, 0.31, 0.8), v(1.2, 0.63, 1.3), 12)?;
    merge(&merge(&open, &through_top)?, &through_corner)
}
/// An icosphere (one subdivision) whose vertices each moved by up to 0.2 of its diagonal
/// (`jitter`, seed 36): folded through itself, with triple points where one face holds a
/// closed network of crossing chords that touches no edge of the face.
pub(super) fn crumpled_sphere() -> Result<TriMesh, ShapeError> {
    jitter(&icosphere(v(0.0, 0.0, 0.0), 1.0, 1)?, 0.2, 36)
}
/// A fan-capped octagonal tube crumpled like [`crumpled_sphere`] (0.25 of its diagonal,
/// seed 26): 168 crossing face pairs and 84 triple points.
pub(super) fn crumpled_tube() -> Result<TriMesh, ShapeError> {
    jitter(&tube(0.5, 1.5, 8, 4, Caps::Fan)?, 0.25, 26)
}

/// Every named fixture and benchmark mesh. Grid-made ones (`*_grid`) have exact
/// degeneracies; each `*_jitter` twin is the same mesh after
/// `jitter(mesh, FIXTURE_JITTER, FIXTURE_SEED)`.
pub const FIXTURES: &[Fixture] = &[
    Fixture {
        name: "boxes_overlap_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((0.5,0.25,0.125),(1.5,1.25,1.125),8)); overlap 0.5*0.75*0.875 = 0.328125 m^3",
        close_holes: false,
        make: boxes_overlap_grid,
    },
    Fixture {
        name: "boxes_overlap_jitter",
        description: "boxes_overlap_grid jittered",
        close_holes: false,
        make: || jittered(boxes_overlap_grid()),
    },
    Fixture {
        name: "boxes_touch_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((1,0.25,0.125),(2,1.25,1.125),8)); coplanar contact at x=1, volume 0",
        close_holes: false,
        make: boxes_touch_grid,
    },
    Fixture {
        name: "boxes_touch_jitter",
        description: "boxes_touch_grid jittered",
        close_holes: false,
        make: || jittered(boxes_touch_grid()),
    },
    Fixture {
        name: "boxes_apart_grid",
        description: "merge(grid_box((0,0,0),(1,1,1),8), grid_box((1.25,0.25,0.125),(2.25,1.25,1.125),8)); 0.25 m gap, volume 0",
        close_holes: false,
        make: boxes_apart_grid,
    },
    Fixture {
        name: "boxes_apart_jitter",
        description: "boxes_apart_grid jittered",
        close_holes: false,
        make: || jittered(boxes_apart_grid()),
    },
    Fixture {
        name: "icospheres_overlap_grid",
        description: "merge(icosphere((0,0,0),1,4), icosphere((1.2,0,0),1,4)); 10,240 faces",
        close_holes: false,
        make: icospheres_overlap_grid,
    },
    Fixture {
        name: "icospheres_overlap_jitter",
        description: "icospheres_overlap_grid jittered",
        close_holes: false,
        make: || jittered(icospheres_overlap_grid()),
    },
    Fixture {
        name: "bent_tube_grid",
        description: "bent_tube(radius 0.1, leg_length 0.6, bend 135 deg, offset 0.02, n_around 64, n_along_per_leg 24); 6,272 faces",
        close_holes: false,
        make: bent_tube_grid,
    },
    Fixture {
        name: "bent_tube_jitter",
        description: "bent_tube_grid jittered",
        close_holes: false,
        make: || jittered(bent_tube_grid()),
    },
    Fixture {
        name: "sleeve_torso_grid",
        description: "sleeve_through_torso(&SleeveTorso::default()); 7,168 faces, 4 holes closed by fans for volumes",
        close_holes: true,
        make: sleeve_torso_grid,
    },
    Fixture {
        name: "sleeve_torso_jitter",
        description: "sleeve_torso_grid jittered",
        close_holes: true,
        make: || jittered(sleeve_torso_grid()),
    },
    Fixture {
        name: "folded_sheet_grid",
        description: "folded_sheet(size 1, n 40); 6,400 faces, open sheet (face pairs only, no volume)",
        close_holes: false,
        make: folded_sheet_grid,
    },
    Fixture {
        name: "folded_sheet_jitter",
        description: "folded_sheet_grid jittered",
        close_holes: false,
        make: || jittered(folded_sheet_grid()),
    },
    Fixture {
        name: "garment_benchmark",
        description: "garment_benchmark(); 13,152 faces, sleeve pressed 2 cm into torso, 4 holes closed by fans for volumes",
        close_holes: true,
        make: garment_benchmark,
    },
    Fixture {
        name: "sphere_l5",
        description: "icosphere((0,0,0),1,5); 20,480 faces, no crossings (benchmark)",
        close_holes: false,
        make: sphere_l5,
    },
    Fixture {
        name: "torus_bench",
        description: "torus(1, 0.3, 128, 48); 12,288 faces, no crossings (benchmark)",
        close_holes: false,
        make: torus_bench,
    },
    Fixture {
        name: "equal_boxes_half",
        description: "merge(grid_box((0,0,0),(1,1,1),7), grid_box((0.5,0,0),(1.5,1,1),7)) jittered; overlap 0.5 m^3",
        close_holes: false,
        make: equal_boxes_half,
    },
    Fixture {
        name: "tube_through_box",
        description: "tube(0.2, 2, 24, 8, fan caps) along x from -1 to 1, merged with grid_box((-0.2,-0.6,-0.6),(0.3,0.6,0.6),8), jittered; overlap 24-gon area x 0.5 = 0.06 m^3",
        close_holes: false,
        make: tube_through_box,
    },
    Fixture {
        name: "nested_boxes",
        description: "unit grid boxes (n 6) at (0,0,0), (0.3,0.2,0.1), (0.6,-0.27,0.4), jittered (no face plane through another box's lattice); winding 3 in the common core",
        close_holes: false,
        make: nested_boxes,
    },
    Fixture {
        name: "elbow_fold",
        description: "bent_tube(radius 0.1, leg 0.8, bend 160 deg, offset 0.03, n_around 32, n_along_per_leg 24) jittered",
        close_holes: false,
        make: elbow_fold,
    },
    Fixture {
        name: "open_box_pierced",
        description: "grid_box((0,0,0),(1,1,1),1) with its top open, pierced through the opening by grid_box((0.23,0.27,0.7),(0.61,0.66,1.4),12) and through opening and wall x=1 by grid_box((0.72,0.31,0.8),(1.2,0.63,1.3),12); volume with the opening fanned 0.38*0.39*0.3 + 0.28*0.32*0.2 m^3",
        close_holes: true,
        make: open_box_pierced,
    },
    Fixture {
        name: "crumpled_sphere",
        description: "icosphere((0,0,0), 1, 1 subdivision), every vertex moved by jitter(rel 0.2, seed 36): folded through itself, 3 triple points",
        close_holes: false,
        make: crumpled_sphere,
    },
    Fixture {
        name: "crumpled_tube",
        description: "tube(0.5, 1.5, 8, 4, fan caps), every vertex moved by jitter(rel 0.25, seed 26): 168 crossing face pairs, 84 triple points",
        close_holes: false,
        make: crumpled_tube,
    },
];

/// Generates the named fixture (see [`FIXTURES`]).
pub fn fixture(name: &str) -> Result<TriMesh, ShapeError> {
    FIXTURES
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| ShapeError::UnknownFixture { name: name.to_owned() })?
        .build()
}
