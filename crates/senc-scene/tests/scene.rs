//! senc-scene integration tests: skinning, BVH round trip, resampling, configs, and the
//! committed assets (every garment valid, named holes present, no vertex inside the body).

use std::path::{Path, PathBuf};

use nalgebra::UnitQuaternion;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use senc_geom::Vec3;
use senc_scene::bvh::{BvhJoint, Channel};
use senc_scene::motion::{retarget, CMU_TO_CMU_MB};
use senc_scene::{
    skin, BodyAsset, BodyQuery, Bone, Bvh, GarmentAsset, Motion, Pose, Scene, SceneConfig, Skeleton, SkinWeights,
};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn chain_skeleton() -> Skeleton {
    Skeleton {
        bones: vec![
            Bone { name: "Hips".into(), parent: None, head: Vec3::new(0.0, 1.0, 0.0), tail: Vec3::new(0.0, 1.2, 0.0) },
            Bone {
                name: "LeftUpLeg".into(),
                parent: Some(0),
                head: Vec3::new(0.1, 1.0, 0.0),
                tail: Vec3::new(0.1, 0.5, 0.0),
            },
            Bone {
                name: "LeftLeg".into(),
                parent: Some(1),
                head: Vec3::new(0.1, 0.5, 0.0),
                tail: Vec3::new(0.1, 0.1, 0.0),
            },
            Bone {
                name: "LeftFoot".into(),
                parent: Some(2),
                head: Vec3::new(0.1, 0.1, 0.0),
                tail: Vec3::new(0.1, 0.0, 0.1),
            },
        ],
    }
}

fn random_weights(n: usize, n_bones: usize, rng: &mut ChaCha8Rng) -> SkinWeights {
    let lists: Vec<Vec<(u16, f32)>> =
        (0..n).map(|_| (0..n_bones).map(|b| (b as u16, rng.random_range(0.0f32..1.0) + 0.01)).collect()).collect();
    SkinWeights::from_lists(&lists).unwrap()
}

#[test]
fn skinning_at_identity_reproduces_rest_pose() {
    let sk = chain_skeleton();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let rest: Vec<Vec3> = (0..50).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
    let w = random_weights(rest.len(), sk.len(), &mut rng);
    w.validate(rest.len(), sk.len()).unwrap();
    let tr = sk.bone_transforms(&Pose::identity(sk.len())).unwrap();
    let out = skin(&rest, &w, &tr);
    for (a, b) in rest.iter().zip(&out) {
        assert!((a - b).norm() < 1e-12, "{a} became {b}");
    }
}

#[test]
fn skinning_a_rigid_rotation_keeps_bone_chain_connected() {
    // Rotating the thigh moves the knee (head of LeftLeg) to the rotated position, and a
    // vertex bound fully to LeftLeg at its head lands exactly there.
    let sk = chain_skeleton();
    let mut pose = Pose::identity(sk.len());
    let q = UnitQuaternion::from_axis_angle(&Vec3::x_axis(), 0.7);
    pose.rotations[1] = q;
    pose.rotations[2] = q;
    pose.rotations[3] = q;
    pose.root_translation = Vec3::new(0.0, 0.0, 0.3);
    let tr = sk.bone_transforms(&pose).unwrap();
    let knee = sk.bones[2].head;
    let w = SkinWeights::from_lists(&[vec![(2, 1.0)]]).unwrap();
    let got = skin(&[knee], &w, &tr)[0];
    let hip = sk.bones[1].head + pose.root_translation;
    let expected = hip + q * (knee - sk.bones[1].head);
    assert!((got - expected).norm() < 1e-12, "{got} vs {expected}");
}

fn random_bvh(rng: &mut ChaCha8Rng) -> Bvh {
    let zyx = vec![Channel::Zrotation, Channel::Yrotation, Channel::Xrotation];
    let joints = vec![
        BvhJoint {
            name: "Hips".into(),
            parent: None,
            offset: Vec3::zeros(),
            channels: vec![
                Channel::Xposition,
                Channel::Yposition,
                Channel::Zposition,
                Channel::Zrotation,
                Channel::Xrotation,
                Channel::Yrotation,
            ],
            end_site: None,
        },
        BvhJoint {
            name: "LeftUpLeg".into(),
            parent: Some(0),
            offset: Vec3::new(1.0, -0.2, 0.0),
            channels: zyx.clone(),
            end_site: None,
        },
        BvhJoint {
            name: "LeftLeg".into(),
            parent: Some(1),
            offset: Vec3::new(0.0, -4.0, 0.0),
            channels: zyx.clone(),
            end_site: None,
        },
        BvhJoint {
            name: "LeftFoot".into(),
            parent: Some(2),
            offset: Vec3::new(0.0, -4.0, 0.0),
            channels: zyx,
            end_site: Some(Vec3::new(0.0, -0.5, 1.0)),
        },
    ];
    let n_ch: usize = joints.iter().map(|j| j.channels.len()).sum();
    let frames = (0..7).map(|_| (0..n_ch).map(|_| rng.random_range(-180.0..180.0)).collect()).collect();
    Bvh { joints, frame_time: 1.0 / 120.0, frames }
}

#[test]
fn bvh_write_then_read_round_trips_joint_angles() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let bvh = random_bvh(&mut rng);
    let text = bvh.to_bvh_string();
    let back = Bvh::parse(&text, Path::new("<test>")).unwrap();
    assert_eq!(back.joints, bvh.joints);
    assert_eq!(back.frames.len(), bvh.frames.len());
    for (a, b) in back.frames.iter().zip(&bvh.frames) {
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x, y, "angle changed in the round trip");
        }
    }
    // and the rotations they mean
    for f in 0..bvh.frames.len() {
        for (qa, qb) in back.global_rotations(f).iter().zip(bvh.global_rotations(f)) {
            assert!(qa.angle_to(&qb) < 1e-12);
        }
    }
}

#[test]
fn bvh_channel_order_is_intrinsic() {
    // Z 90 then X 90: R = Rz(90) Rx(90) maps +y to +x? Rx(90) y = z; Rz(90) z = z. So +y -> +z.
    let text = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 2 Zrotation Xrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n90 90\n";
    let b = Bvh::parse(text, Path::new("<t>")).unwrap();
    let v = b.global_rotations(0)[0] * Vec3::y();
    assert!((v - Vec3::z()).norm() < 1e-12, "{v}");
}

#[test]
fn bvh_errors_name_the_line() {
    let text = "HIERARCHY\nROOT A\n{\nOFFSET 0 zero 0\n}\n";
    let e = Bvh::parse(text, Path::new("x.bvh")).unwrap_err().to_string();
    assert!(e.contains("line 4") && e.contains("zero"), "{e}");
}

#[test]
fn resampling_keeps_clip_duration() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut bvh = random_bvh(&mut rng);
    bvh.frames = (0..241)
        .map(|k| {
            let t = k as f64 / 120.0;
            let mut row = vec![t, 0.9, 0.0, 0.0, 0.0, 0.0];
            row.extend((0..9).map(|c| 30.0 * (t * 2.0 + c as f64).sin()));
            row
        })
        .collect();
    let m = retarget(&bvh, &chain_skeleton(), CMU_TO_CMU_MB, true, "test").unwrap();
    assert!((m.duration() - 2.0).abs() < 1e-12);
    for fps in [30.0, 25.0, 100.0 / 3.0] {
        let r = m.resample(fps).unwrap();
        assert!((r.duration() - m.duration()).abs() < 1.0 / fps, "{} vs {}", r.duration(), m.duration());
        // frame k of the 30 fps clip is frame 4k of the 120 fps one
        if fps == 30.0 {
            assert_eq!(r.n_frames(), 61);
            let (a, b) = (r.pose(10).unwrap(), m.pose(40).unwrap());
            for (x, y) in a.rotations.iter().zip(&b.rotations) {
                assert!(x.angle_to(y) < 1e-5);
            }
        }
    }
}

#[test]
fn lead_in_starts_at_rest() {
    let sk = chain_skeleton();
    let q = UnitQuaternion::from_axis_angle(&Vec3::x_axis(), 1.0);
    let pose = Pose { rotations: vec![q; 4], root_translation: Vec3::new(0.0, 0.0, 1.0) };
    let names = sk.bones.iter().map(|b| b.name.clone()).collect();
    let m = Motion::from_poses("m", 30.0, names, &[pose.clone(), pose]).with_lead_in(10).unwrap();
    assert_eq!(m.n_frames(), 12);
    assert_eq!(m.pose(0).unwrap(), Pose::identity(4));
    assert!(m.pose(10).unwrap().rotations[0].angle_to(&q) < 1e-6);
}

/// A clip that starts in motion: the lead-in leaves the rest pose at rest and arrives at
/// the clip's first frame moving as the clip moves (a smoothstep to the first frame would
/// arrive at a standstill and jump to full speed in one frame). A one-frame clip leads in
/// as a smoothstep.
#[test]
fn lead_in_arrives_with_the_clips_velocity() {
    let sk = chain_skeleton();
    let names: Vec<String> = sk.bones.iter().map(|b| b.name.clone()).collect();
    let (w, u) = (Vec3::new(0.04, -0.03, 0.05), Vec3::new(0.06, 0.0, -0.04)); // per frame
    let q0 = UnitQuaternion::from_axis_angle(&Vec3::x_axis(), 0.8);
    let poses: Vec<Pose> = (0..6)
        .map(|f| {
            let q = q0 * UnitQuaternion::from_scaled_axis(w * f as f64);
            Pose { rotations: vec![q; 4], root_translation: Vec3::new(0.3, 0.9, -0.2) + u * f as f64 }
        })
        .collect();
    let clip = Motion::from_poses("m", 30.0, names.clone(), &poses);
    let n = 15;
    let m = clip.with_lead_in(n).unwrap();
    assert_eq!(m.n_frames(), n + 6);
    assert_eq!(m.pose(0).unwrap(), Pose::identity(4));
    // Motions store f32.
    assert!(m.pose(n).unwrap().rotations[0].angle_to(&poses[0].rotations[0]) < 1e-6);
    // Velocities per frame: rotation vector of bone 0 and root translation.
    let vel = |a: &Pose, b: &Pose| {
        ((a.rotations[0].inverse() * b.rotations[0]).scaled_axis(), b.root_translation - a.root_translation)
    };
    let p = |f: usize| m.pose(f).unwrap();
    let (w_start, u_start) = vel(&p(0), &p(1));
    let (w_last, u_last) = vel(&p(n - 1), &p(n));
    let (w_clip, u_clip) = vel(&p(n), &p(n + 1));
    assert!((w_clip - w).norm() < 1e-6 && (u_clip - u).norm() < 1e-6);
    // The smoothstep to a standstill, for comparison.
    let smooth = |k: usize| {
        let a = k as f64 / n as f64;
        senc_scene::motion::blend(&Pose::identity(4), &poses[0], a * a * (3.0 - 2.0 * a))
    };
    let (w_smooth, u_smooth) = vel(&smooth(n - 1), &poses[0]);
    let (dw, du) = ((w_last - w).norm(), (u_last - u).norm());
    let (dw_smooth, du_smooth) = ((w_smooth - w).norm(), (u_smooth - u).norm());
    assert!(dw < 0.3 * dw_smooth && du < 0.3 * du_smooth, "velocity jump {dw}, {du} against {dw_smooth}, {du_smooth}");
    assert!(du < 0.25 * u.norm(), "root velocity jump {du} m/frame against the clip's {}", u.norm());
    // It starts at rest: the first step is as small as the smoothstep's.
    let (w_s0, u_s0) = vel(&smooth(0), &smooth(1));
    assert!(w_start.norm() < 2.0 * w_s0.norm() + 1e-3 && u_start.norm() < 2.0 * u_s0.norm() + 1e-3);

    let one = Motion::from_poses("one", 30.0, names, &poses[..1]).with_lead_in(n).unwrap();
    for k in 0..=n {
        let (a, b) = (one.pose(k).unwrap(), smooth(k));
        assert!(a.rotations[0].angle_to(&b.rotations[0]) < 1e-6, "frame {k}");
        assert!((a.root_translation - b.root_translation).norm() < 1e-6, "frame {k}");
    }
}

#[test]
fn heading_alignment_faces_the_rest_pose_and_keeps_relative_motion() {
    let sk = chain_skeleton();
    let names: Vec<String> = sk.bones.iter().map(|b| b.name.clone()).collect();
    // Facing backwards (yaw 180° plus a forward lean), 1 m to the side, then walking.
    let yaw = UnitQuaternion::from_axis_angle(&Vec3::y_axis(), 2.9);
    let lean = UnitQuaternion::from_axis_angle(&Vec3::x_axis(), 0.3);
    let bend = UnitQuaternion::from_axis_angle(&Vec3::z_axis(), 0.7);
    let p0 = Pose { rotations: vec![yaw * lean, yaw * bend, yaw, yaw], root_translation: Vec3::new(1.0, 0.1, -2.0) };
    let p1 = Pose { rotations: p0.rotations.clone(), root_translation: Vec3::new(1.3, 0.1, -2.4) };
    let m = Motion::from_poses("m", 30.0, names, &[p0, p1]);
    let a = m.aligned_to_rest_heading();
    let (a0, a1) = (a.pose(0).unwrap(), a.pose(1).unwrap());
    // The first frame's root keeps its lean but no yaw, and stands at the rest position.
    assert!(a0.rotations[0].angle_to(&lean) < 1e-6, "{:?}", a0.rotations[0]);
    assert!(a0.root_translation.x.abs() < 1e-6 && a0.root_translation.z.abs() < 1e-6);
    assert!((a0.root_translation.y - 0.1).abs() < 1e-6);
    // Relative motion survives: the step length and the bones' relative rotations.
    let step = (a1.root_translation - a0.root_translation).norm();
    assert!((step - 0.5).abs() < 1e-6, "{step}");
    let rel = |p: &Pose| p.rotations[0].inverse() * p.rotations[1];
    assert!(rel(&a0).angle_to(&rel(&m.pose(0).unwrap())) < 1e-6);
    // Already aligned: nothing changes.
    let again = a.aligned_to_rest_heading();
    assert!(again.pose(1).unwrap().rotations[0].angle_to(&a1.rotations[0]) < 1e-6);
}

#[test]
fn config_refuses_unknown_keys_naming_them() {
    let base = "[scene]\ngarment = \"g\"\nbody = \"b\"\n[scene.motions]\ntrain = [\"a\"]\n";
    SceneConfig::parse(base, Path::new("c.toml")).unwrap();
    let bad = format!("{base}[scene.material]\ndensty = 0.2\n");
    let e = SceneConfig::parse(&bad, Path::new("c.toml")).unwrap_err().to_string();
    assert!(e.contains("densty"), "{e}");
    let bad = "[scene]\ngarment = \"g\"\nbody = \"b\"\nwind = 3\n[scene.motions]\ntrain = [\"a\"]\n";
    let e = SceneConfig::parse(bad, Path::new("c.toml")).unwrap_err().to_string();
    assert!(e.contains("wind"), "{e}");
    // other top-level tables belong to other crates and are left alone
    SceneConfig::parse(&format!("{base}[train]\nsteps = 3\n"), Path::new("c.toml")).unwrap();
    // a test motion may not also be a training motion
    let e = SceneConfig::parse(&base.replace("train = [\"a\"]", "train = [\"a\"]\ntest = [\"a\"]"), Path::new("c"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unseen"), "{e}");
}

#[test]
fn material_tables_give_one_stiffness_pair_in_range() {
    use senc_scene::config::MaterialConfig;
    MaterialConfig { young: Some(1000.0), poisson: Some(0.25), ..Default::default() }.validate().unwrap();
    MaterialConfig::default().validate().unwrap();
    let mixed = MaterialConfig { young: Some(1000.0), lame_mu: Some(3.0), ..Default::default() };
    assert!(mixed.validate().unwrap_err().to_string().contains("not a mix"));
    let half = MaterialConfig { lame_mu: Some(3.0), ..Default::default() };
    assert!(half.validate().unwrap_err().to_string().contains("not a mix"));
    let nu = MaterialConfig { young: Some(1000.0), poisson: Some(0.5), ..Default::default() };
    assert!(nu.validate().unwrap_err().to_string().contains("poisson"));
    let rho = MaterialConfig { density: Some(f64::NAN), ..Default::default() };
    assert!(rho.validate().unwrap_err().to_string().contains("density"));
}

const GARMENTS: &[(&str, &[&str])] = &[
    ("tshirt", &["hem", "left_sleeve", "neck", "right_sleeve"]),
    ("skirt", &["hem", "waist"]),
    ("longsleeve", &["hem", "left_sleeve", "neck", "right_sleeve"]),
    ("dress", &["hem", "left_sleeve", "neck", "right_sleeve"]),
    ("pants", &["left_leg", "right_leg", "waist"]),
];

#[test]
fn committed_garments_are_valid_named_and_outside_the_body() {
    let body = BodyAsset::load(root().join("data/body.msgpack")).unwrap();
    let q = BodyQuery::new(&body.positions, &body.faces).unwrap();
    for (name, loops) in GARMENTS {
        let g = GarmentAsset::load(root().join(format!("data/garments/{name}.msgpack"))).unwrap();
        let mesh = g.mesh().unwrap();
        g.weights.validate(mesh.n_vertices(), body.skeleton.len()).unwrap();
        let mut names = g.loop_names();
        names.sort();
        assert_eq!(names, *loops, "{name}");
        assert_eq!(g.loop_indices().unwrap().len(), mesh.topology().boundary_loops().len(), "{name}: unnamed loops");
        let inside = q.inside(&g.positions);
        assert!(
            inside.is_empty(),
            "{name}: {} vertices inside the body, e.g. {:?}",
            inside.len(),
            &inside[..inside.len().min(5)]
        );
        let through = senc_scene::build::face_points_inside(&g.positions, &g.faces, &q);
        assert_eq!(through, 0, "{name}: faces through the body");
    }
}

#[test]
fn configs_load_and_frame_zero_is_outside_the_body() {
    for cfg in ["tshirt", "skirt", "longsleeve", "pants", "dress"] {
        let scene = Scene::load(root().join(format!("configs/{cfg}.toml"))).unwrap();
        assert!(!scene.train.is_empty() && !scene.test.is_empty(), "{cfg}: needs a train/test split");
        for m in scene.train.iter().chain(&scene.test) {
            assert!(
                scene.train.iter().filter(|t| t.name == m.name).count()
                    + scene.test.iter().filter(|t| t.name == m.name).count()
                    == 1
            );
        }
        scene.hole_selection().unwrap();
        let m = &scene.test[0];
        let st = scene.initial_state(m).unwrap();
        assert_eq!(st.x, st.x_prev);
        assert_eq!(st.body, st.body_prev);
        let q = BodyQuery::new(&st.body, &scene.body.faces).unwrap();
        let inside = q.inside(&st.x);
        assert!(inside.is_empty(), "{cfg}: {} garment vertices inside the body at frame 0", inside.len());
    }
}

/// A clip that starts with a T-pose frame, then moves smoothly: the T-pose frame is dropped,
/// and nothing else is. A clip that moves fast everywhere, and one with no jump, stay whole.
#[test]
fn leading_jumps_are_dropped_and_nothing_else() {
    let sk = chain_skeleton();
    let names: Vec<String> = sk.bones.iter().map(|b| b.name.clone()).collect();
    let pose = |a: f64| Pose {
        rotations: vec![UnitQuaternion::from_axis_angle(&Vec3::z_axis(), a); 4],
        root_translation: Vec3::new(0.01 * a, 0.0, 0.0),
    };
    let smooth: Vec<Pose> = (0..40).map(|k| pose(0.02 * k as f64)).collect();
    let mut t_pose = smooth.clone();
    t_pose[0] = pose(1.5);
    let m = Motion::from_poses("t", 30.0, names.clone(), &t_pose).without_leading_jumps();
    assert_eq!(m.n_frames(), 39);
    assert!(m.pose(0).unwrap().rotations[0].angle_to(&t_pose[1].rotations[0]) < 1e-6);
    let m = Motion::from_poses("s", 30.0, names.clone(), &smooth);
    assert_eq!(m.without_leading_jumps(), m);
    // 0.7 rad every frame: fast, but no frame stands out.
    let fast: Vec<Pose> = (0..40).map(|k| pose(0.7 * k as f64)).collect();
    let m = Motion::from_poses("f", 30.0, names.clone(), &fast);
    assert_eq!(m.without_leading_jumps(), m);
    // A root that teleports after two frames.
    let mut teleport = smooth.clone();
    for p in &mut teleport[2..] {
        p.root_translation.x += 1.0;
    }
    let m = Motion::from_poses("r", 30.0, names, &teleport).without_leading_jumps();
    assert_eq!(m.n_frames(), 38);
}

/// The committed CMU training clips start with a T-pose frame; as scenes prepare them, the
/// body moves no more from the lead-in's last frame to the clip's next than within the
/// lead-in.
#[test]
fn cmu_clips_lead_in_without_a_jump() {
    let scene = Scene::load(root().join("configs/tshirt.toml")).unwrap();
    let lead = scene.config.lead_in_frames;
    for m in &scene.train {
        let step = |f: usize| {
            let (a, b) = (scene.body_at(m, f).unwrap(), scene.body_at(m, f + 1).unwrap());
            a.iter().zip(&b).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max)
        };
        let within = (lead / 2..lead).map(step).fold(0.0, f64::max);
        let across = step(lead);
        assert!(across < 0.1, "{}: the body jumps {across} m at the end of the lead-in (within it {within} m)", m.name);
    }
}
