//! Motions from files: BVH clips written by others (`data/clips/`, see its README) are
//! retargeted onto the body's rig by joint name, resampled, aligned and led in as scene
//! motions are; malformed files and unmapped skeletons are refused with typed errors.

use std::path::{Path, PathBuf};

use senc_geom::Vec3;
use senc_scene::clip::{prepare, read_motion, retarget_clip, JointMap};
use senc_scene::{skin, BodyAsset, BodyQuery, Bvh, Motion, Pose, Scene, SceneConfig, SceneError};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn body() -> BodyAsset {
    BodyAsset::load(root().join("data/body.msgpack")).unwrap()
}

fn clip(name: &str) -> PathBuf {
    root().join("data/clips").join(name)
}

/// A fresh folder under the system's temporary directory.
fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("senc-clip-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn scene_config() -> SceneConfig {
    SceneConfig::read(root().join("configs/tshirt.toml")).unwrap()
}

/// Skinned body at every 7th frame: all finite, and the lowest vertex within `reach` (m) of
/// the rest pose's (0.10: the feet on the ground).
fn check_body_motion(body: &BodyAsset, m: &Motion, reach: f64) {
    let rest_low = body.positions.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    for f in (0..m.n_frames()).step_by(7) {
        let tr = body.skeleton.bone_transforms(&m.pose(f).unwrap()).unwrap();
        let x = skin(&body.positions, &body.weights, &tr);
        assert!(x.iter().all(|p| p.iter().all(|c| c.is_finite())), "{}: frame {f} not finite", m.name);
        let low = x.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        assert!((low - rest_low).abs() < reach, "{}: frame {f}: lowest point {low:.3} m, rest {rest_low:.3} m", m.name);
    }
}

/// Every body bone the map drives points, at every 5th frame, where its clip joint's segment
/// points (the retargeting invariant), to within f32 storage.
fn check_follows_clip(body: &BodyAsset, path: &Path, map_name: &str, m: &Motion) -> usize {
    let mut bvh = Bvh::read(path).unwrap();
    bvh.strip_namespaces(path).unwrap();
    let map = JointMap::builtin().into_iter().find(|x| x.name == map_name).unwrap();
    let src = map.sources(&bvh, &body.skeleton);
    let mut checked = 0;
    for f in (0..bvh.frames.len()).step_by(5) {
        let g = bvh.global_rotations(f);
        let pose = m.pose(f).unwrap();
        for (j, b) in body.skeleton.bones.iter().enumerate() {
            let (Some(s), Some(_)) = (src[j], b.parent) else { continue };
            let Some(d_src) = bvh.rest_direction(s) else { continue };
            let a = (g[s] * d_src).normalize();
            let t = (pose.rotations[j] * (b.tail - b.head)).normalize();
            assert!(a.dot(&t) > 1.0 - 1e-6, "{}: frame {f}, bone {}: {:.2e}", m.name, b.name, a.angle(&t));
            checked += 1;
        }
    }
    checked
}

#[test]
fn mixamo_clip_retargets_through_the_builtin_map() {
    let body = body();
    let m = read_motion(&clip("mixamo_freebvh.bvh"), &body.skeleton).unwrap();
    assert_eq!(m.name, "mixamo_freebvh");
    assert_eq!(m.n_frames(), 69);
    assert!((m.fps - 30.0).abs() < 1e-3, "{}", m.fps);
    m.check(&body.skeleton).unwrap();
    check_body_motion(&body, &m, 0.10);
    assert!(check_follows_clip(&body, &clip("mixamo_freebvh.bvh"), "mixamo", &m) > 14 * 20);
    // The spine follows Mixamo's Spine, Spine1, Spine2 (the map), not CMU's same names.
    let mut bvh = Bvh::read(clip("mixamo_freebvh.bvh")).unwrap();
    bvh.strip_namespaces(Path::new("x")).unwrap();
    let map = JointMap::builtin().into_iter().find(|m| m.name == "mixamo").unwrap();
    let src = map.sources(&bvh, &body.skeleton);
    let lower_back = body.skeleton.find("LowerBack").unwrap();
    assert_eq!(src[lower_back], bvh.find("Spine"));
    assert!(map.missing(&bvh, &body.skeleton).is_empty());
}

#[test]
fn mocapbank_clip_picks_its_map_and_prepares_like_scene_motions() {
    let body = body();
    let m = read_motion(&clip("mocapbank_150.bvh"), &body.skeleton).unwrap();
    assert_eq!(m.n_frames(), 150);
    check_body_motion(&body, &m, 0.10);
    assert!(check_follows_clip(&body, &clip("mocapbank_150.bvh"), "mocapbank", &m) > 30 * 15);
    let cfg = scene_config();
    let p = prepare(m.clone(), &cfg).unwrap();
    assert_eq!(p.n_frames(), cfg.lead_in_frames + 150, "already at 30 fps: only the lead-in is added");
    assert_eq!(p.pose(0).unwrap(), Pose::identity(body.skeleton.len()));
    // Aligned: the first clip frame's root stands at the rest position, facing +z.
    let first = p.pose(cfg.lead_in_frames).unwrap();
    let t = first.root_translation;
    assert!(t.x.abs() < 1e-4 && t.z.abs() < 1e-4, "{t}");
    let f = first.rotations[0] * Vec3::z();
    assert!(f.x.atan2(f.z).abs() < 1e-3, "heading {}", f.x.atan2(f.z));
    check_body_motion(&body, &p, 0.10);
}

#[test]
fn a_clip_played_three_times_faster_resamples_to_a_third() {
    let body = body();
    let path = clip("mocapbank_150.bvh");
    let bvh = Bvh::read(&path).unwrap();
    let mut fast = bvh.clone();
    fast.frame_time /= 3.0;
    let dir = scratch("fast");
    let fast_path = dir.join("mocapbank_fast.bvh");
    std::fs::write(&fast_path, fast.to_bvh_string()).unwrap();
    let cfg = SceneConfig { lead_in_frames: 0, align_heading: false, ..scene_config() };
    let slow = prepare(read_motion(&path, &body.skeleton).unwrap(), &cfg).unwrap();
    let quick = prepare(read_motion(&fast_path, &body.skeleton).unwrap(), &cfg).unwrap();
    assert!((quick.fps - 30.0).abs() < 1e-9);
    assert_eq!(quick.n_frames(), (slow.duration() / 3.0 * 30.0 + 1e-6).floor() as usize + 1);
    // Frame k of the fast clip is frame 3k of the normal one (to the file's rounding of the
    // frame time, 0.033333 s: 0.001 frames by frame 120).
    for k in [0, 5, 17, 40] {
        let (a, b) = (quick.pose(k).unwrap(), slow.pose(3 * k).unwrap());
        for (qa, qb) in a.rotations.iter().zip(&b.rotations) {
            assert!(qa.angle_to(qb) < 1e-3, "frame {k}: {}", qa.angle_to(qb));
        }
        assert!((a.root_translation - b.root_translation).norm() < 1e-3);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The mocapbank clip with its header changed by `edit`, parsed.
fn edited(edit: impl Fn(&str) -> String) -> Result<Bvh, SceneError> {
    let text = std::fs::read_to_string(clip("mocapbank_150.bvh")).unwrap();
    Bvh::parse(&edit(&text), Path::new("edited.bvh"))
}

fn bvh_message(r: Result<Bvh, SceneError>) -> String {
    match r {
        Err(e @ SceneError::Bvh { .. }) => e.to_string(),
        other => panic!("expected a BVH error, got {other:?}"),
    }
}

#[test]
fn malformed_bvh_files_are_typed_errors_that_say_what_is_wrong() {
    // Truncated in the middle of the frames.
    let e = bvh_message(edited(|t| t[..t.len() * 2 / 3].to_string()));
    assert!(e.contains("values, but the hierarchy declares") || e.contains("truncated"), "{e}");
    // Truncated at a line end: fewer frames than announced.
    let e = bvh_message(edited(|t| t.lines().take(120).collect::<Vec<_>>().join("\n")));
    assert!(e.contains("ends after") && e.contains("of the 150 frames"), "{e}");
    // Truncated in the hierarchy.
    let e = bvh_message(edited(|t| t[..400].to_string()));
    assert!(e.contains("unexpected end of file"), "{e}");
    // A joint that declares one channel more than it lists.
    let e = bvh_message(edited(|t| {
        t.replacen("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 4 Zrotation Xrotation Yrotation", 1)
    }));
    assert!(e.contains("not a channel name"), "{e}");
    // An impossible channel count.
    let e = bvh_message(edited(|t| t.replacen("CHANNELS 3", "CHANNELS 9", 1)));
    assert!(e.contains("0 to 6 channels"), "{e}");
    // A frame with one value missing.
    let e = bvh_message(edited(|t| {
        let mut lines: Vec<String> = t.lines().map(String::from).collect();
        let k = lines.iter().position(|l| l.starts_with("Frame Time")).unwrap() + 3;
        let cut = lines[k].trim_end().rsplit_once(' ').unwrap().0.to_string();
        lines[k] = cut;
        lines.join("\n")
    }));
    assert!(e.contains("frame 2 has") && e.contains("values, but the hierarchy declares"), "{e}");
    // NaN and infinity in the frames or offsets.
    let e = bvh_message(edited(|t| t.replacen("-44.0003", "NaN", 1)));
    assert!(e.contains("finite number") && e.contains("NaN"), "{e}");
    let e = bvh_message(edited(|t| t.replacen("OFFSET -0.1728", "OFFSET inf", 1)));
    assert!(e.contains("finite number"), "{e}");
    // Frame count and frame time.
    let e = bvh_message(edited(|t| t.replacen("Frames:\t150", "Frames:\t-3", 1)));
    assert!(e.contains("non-negative integer"), "{e}");
    let e = bvh_message(edited(|t| t.replacen("Frame Time:\t0.033333", "Frame Time:\t0", 1)));
    assert!(e.contains("frame time must be positive"), "{e}");
    // Complete frames after the announced ones are left out; anything else after them is
    // refused.
    let fewer = edited(|t| t.replacen("Frames:\t150", "Frames:\t149", 1)).unwrap();
    assert_eq!(fewer.frames.len(), 149);
    let e = bvh_message(edited(|t| format!("{}\n1.0 2.0", t.trim_end())));
    assert!(e.contains("values follow the 150 frames"), "{e}");
    let e = bvh_message(edited(|t| format!("{}\nEND", t.trim_end())));
    assert!(e.contains("values follow the 150 frames"), "{e}");
    // Absurd frame counts neither allocate nor panic.
    let e = bvh_message(edited(|t| t.replacen("Frames:\t150", "Frames:\t1e18", 1)));
    assert!(e.contains("ends after 150"), "{e}");
    // Nesting past the joint limit.
    let deep = format!("HIERARCHY\nROOT A\n{}", "{\nOFFSET 0 0 0\nJOINT B\n".repeat(600));
    let e = bvh_message(Bvh::parse(&deep, Path::new("deep.bvh")));
    assert!(e.contains("more than 512 joints"), "{e}");
}

#[test]
fn unknown_skeletons_name_the_undriven_bones_and_a_map_file_fixes_them() {
    let body = body();
    let dir = scratch("unmapped");
    // MocapBank's joints renamed (as another exporter might): no built-in map drives them.
    let text = std::fs::read_to_string(clip("mocapbank_150.bvh")).unwrap();
    let renamed =
        ["Hips", "Chest2", "Chest", "Collar", "Shoulder", "Elbow", "Wrist", "Neck", "Head", "Hip", "Knee", "Ankle"]
            .iter()
            .fold(text.clone(), |t, j| {
                t.replace(&format!(" {j}"), &format!(" x{j}"))
                    .replace(&format!("Left{j}"), &format!("xLeft{j}"))
                    .replace(&format!("Right{j}"), &format!("xRight{j}"))
            });
    let path = dir.join("renamed.bvh");
    std::fs::write(&path, &renamed).unwrap();
    let err = read_motion(&path, &body.skeleton).unwrap_err();
    match &err {
        SceneError::UnmappedJoints { missing, joints, .. } => {
            assert!(
                missing.contains(&"LeftForeArm".to_string()) && missing.contains(&"Hips".to_string()),
                "{missing:?}"
            );
            assert!(joints.contains(&"xLeftElbow".to_string()), "{joints:?}");
        }
        other => panic!("expected UnmappedJoints, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("renamed.joints.toml") && msg.contains("LeftForeArm"), "{msg}");
    // A map file beside the clip: the MocapBank table with the new names.
    let map: String = [
        ("Hips", "xHips"),
        ("LowerBack", "xChest"),
        ("Spine1", "xChest2"),
        ("Neck", "xNeck"),
        ("Head", "xHead"),
        ("LeftShoulder", "xLeftCollar"),
        ("LeftArm", "xLeftShoulder"),
        ("LeftForeArm", "xLeftElbow"),
        ("LeftHand", "xLeftWrist"),
        ("RightShoulder", "xRightCollar"),
        ("RightArm", "xRightShoulder"),
        ("RightForeArm", "xRightElbow"),
        ("RightHand", "xRightWrist"),
        ("LeftUpLeg", "xLeftHip"),
        ("LeftLeg", "xLeftKnee"),
        ("LeftFoot", "xLeftAnkle"),
        ("RightUpLeg", "xRightHip"),
        ("RightLeg", "xRightKnee"),
        ("RightFoot", "xRightAnkle"),
    ]
    .iter()
    .map(|(b, j)| format!("{b} = \"{j}\"\n"))
    .collect();
    std::fs::write(dir.join("renamed.joints.toml"), format!("[joints]\n{map}")).unwrap();
    let mapped = read_motion(&path, &body.skeleton).unwrap();
    let reference = read_motion(&clip("mocapbank_150.bvh"), &body.skeleton).unwrap();
    assert_eq!(mapped.rotations, reference.rotations, "the map file reproduces the built-in map");
    // A map naming a joint the clip lacks, a bone the rig lacks, or an unknown key.
    std::fs::write(dir.join("renamed.joints.toml"), format!("[joints]\n{map}LeftHand = \"LeftPalm\"\n")).unwrap();
    assert!(read_motion(&path, &body.skeleton).is_err(), "a repeated TOML key is refused");
    std::fs::write(dir.join("renamed.joints.toml"), "[joints]\nHips = \"Pelvis\"\n").unwrap();
    let e = read_motion(&path, &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::JointMap { .. }) && e.to_string().contains("\"Pelvis\""), "{e}");
    std::fs::write(dir.join("renamed.joints.toml"), "[joints]\nTail = \"xHips\"\n").unwrap();
    let e = read_motion(&path, &body.skeleton).unwrap_err();
    assert!(e.to_string().contains("no bone \"Tail\""), "{e}");
    std::fs::write(dir.join("renamed.joints.toml"), "same_name = true\n").unwrap();
    let e = read_motion(&path, &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::JointMap { .. }) && e.to_string().contains("same_name"), "{e}");
    // An explicit map wins over the file.
    let explicit = JointMap::parse(&format!("[joints]\n{map}"), Path::new("explicit")).unwrap();
    let bvh = Bvh::read(&path).unwrap();
    assert_eq!(retarget_clip(&bvh, &path, &body.skeleton, Some(&explicit)).unwrap().rotations, reference.rotations);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn clips_whose_zero_pose_does_not_stand_upright_are_refused() {
    let body = body();
    let dir = scratch("zup");
    // The MocapBank clip with every offset turned 90° about x, (y, z) -> (-z, y), as a Z-up
    // exporter writes it: its zero pose lies along +z.
    let text = std::fs::read_to_string(clip("mocapbank_150.bvh")).unwrap();
    let turned: Vec<String> = text
        .lines()
        .map(|l| match l.trim_start().strip_prefix("OFFSET") {
            Some(rest) => {
                let v: Vec<f64> = rest.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("OFFSET {} {} {}", v[0], -v[2], v[1])
            }
            None => l.to_string(),
        })
        .collect();
    let p = dir.join("zup.bvh");
    std::fs::write(&p, turned.join("\n")).unwrap();
    let e = read_motion(&p, &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::Clip { .. }) && e.to_string().contains("does not stand Y-up"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn files_that_are_not_clips_are_refused() {
    let body = body();
    let e = read_motion(Path::new("/nonexistent/walk.bvh"), &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }), "{e}");
    let e = read_motion(&root().join("data/README.md"), &body.skeleton).unwrap_err();
    assert!(e.to_string().contains("give a .bvh clip or a .msgpack"), "{e}");
    let dir = scratch("empty");
    let p = dir.join("empty.bvh");
    std::fs::write(&p, "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n").unwrap();
    let e = read_motion(&p, &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::Clip { .. }) && e.to_string().contains("no frames"), "{e}");
    // Namespaces that hide a clash.
    let p2 = dir.join("clash.bvh");
    std::fs::write(&p2, "HIERARCHY\nROOT a:Hips\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\nJOINT b:Hips\n{\nOFFSET 0 1 0\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0\n").unwrap();
    let e = read_motion(&p2, &body.skeleton).unwrap_err();
    assert!(matches!(e, SceneError::Clip { .. }) && e.to_string().contains("two joints are called Hips"), "{e}");
    // Legs of near-zero length scale the root translation past f32: refused, not stored.
    let mut bvh = Bvh::read(clip("mocapbank_150.bvh")).unwrap();
    for j in ["LeftKnee", "LeftAnkle"] {
        let k = bvh.find(j).unwrap();
        bvh.joints[k].offset *= 1e-150;
    }
    let p3 = dir.join("tiny_legs.bvh");
    std::fs::write(&p3, bvh.to_bvh_string()).unwrap();
    let e = read_motion(&p3, &body.skeleton).unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    std::fs::write(dir.join("empty.bvh"), "").unwrap();
    assert!(matches!(read_motion(&p, &body.skeleton), Err(SceneError::Bvh { .. })));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scene_motions_are_names_or_files() {
    let dir = scratch("scene");
    let cfg = root().join("configs/tshirt.toml");
    let text = std::fs::read_to_string(&cfg).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    // The copy lives elsewhere: its training recipe (the base it extends) is not needed.
    table.remove("extends");
    let scene = table["scene"].as_table_mut().unwrap();
    let abs = |p: &str| root().join("configs").join(p).display().to_string();
    for key in ["garment", "body"] {
        let v = abs(scene[key].as_str().unwrap());
        scene.insert(key.into(), v.into());
    }
    let mut motions = toml::Table::new();
    // A built-in name, a clip relative to the config's folder, a clip by absolute path.
    std::fs::copy(clip("mixamo_freebvh.bvh"), dir.join("walk.bvh")).unwrap();
    motions.insert("train".into(), toml::Value::Array(vec!["cmu_01_01".into(), "walk.bvh".into()]));
    motions.insert("test".into(), toml::Value::Array(vec![clip("mocapbank_150.bvh").display().to_string().into()]));
    scene.insert("motions".into(), motions.into());
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml::to_string(&table).unwrap()).unwrap();
    let s = Scene::load(&path).unwrap();
    let names: Vec<&str> = s.train.iter().chain(&s.test).map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["cmu_01_01", "walk", "mocapbank_150"]);
    let lead = s.config.lead_in_frames;
    assert_eq!(s.train[1].n_frames(), lead + 69);
    for m in s.train.iter().chain(&s.test) {
        assert_eq!(m.pose(0).unwrap(), Pose::identity(s.body.skeleton.len()), "{}: starts at rest", m.name);
        // Frame 0 is the rest pose, where the garment is fitted: nothing inside the body.
        let st = s.initial_state(m).unwrap();
        let q = BodyQuery::new(&st.body, &s.body.faces).unwrap();
        assert!(q.inside(&st.x).is_empty(), "{}", m.name);
    }
    // resolve_motion: a scene name, a file, a built-in name; anything else names the choices.
    assert_eq!(s.resolve_motion("walk").unwrap(), s.train[1]);
    let from_file = s.resolve_motion(&clip("mixamo_freebvh.bvh").display().to_string()).unwrap();
    assert_eq!(from_file.rotations, s.train[1].rotations);
    assert_eq!(s.resolve_motion("boxing_toes").unwrap().name, "boxing_toes");
    let e = s.resolve_motion("moonwalk").unwrap_err();
    match &e {
        SceneError::NoSuchMotion { scene, builtin, .. } => {
            assert!(scene.contains(&"walk".to_string()) && builtin.contains(&"cmu_01_03".to_string()), "{e}");
        }
        other => panic!("expected NoSuchMotion, got {other:?}"),
    }
    // A config naming a motion that does not exist says so.
    let mut bad = toml::Table::new();
    bad.insert("train".into(), toml::Value::Array(vec!["cmu_99_99".into()]));
    table["scene"].as_table_mut().unwrap().insert("motions".into(), bad.into());
    std::fs::write(&path, toml::to_string(&table).unwrap()).unwrap();
    let r = Scene::load(&path);
    assert!(matches!(&r, Err(SceneError::NoSuchMotion { name, .. }) if name.ends_with("cmu_99_99")), "{r:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The DeepMimic clips in `data/clips/deepmimic/` (24, 30 and 60 fps, converted by
/// `tools/clips/deepmimic2bvh.py`) read through the joint map beside each file, resample
/// to the scene's 30 fps, and skin to a finite body whose lowest point stays within 10 cm
/// of the rest pose's on the walks and within 60 cm on the rest (jumps, kicks, spins).
#[test]
fn deepmimic_clips_read_through_their_joint_maps_and_resample_to_the_scene() {
    let body = body();
    let cfg = scene_config();
    let dir = root().join("data/clips/deepmimic");
    let mut clips: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "bvh"))
        .collect();
    clips.sort();
    assert_eq!(clips.len(), 14, "{clips:?}");
    for path in &clips {
        assert!(JointMap::beside(path).is_some(), "{}: no joint map beside it", path.display());
        let bvh = Bvh::read(path).unwrap();
        let m = read_motion(path, &body.skeleton).unwrap();
        m.check(&body.skeleton).unwrap();
        let p = prepare(m, &cfg).unwrap();
        let clip_frames = p.n_frames() - cfg.lead_in_frames;
        let expected = (bvh.frames.len() as f64 * cfg.fps * bvh.frame_time).round() as usize;
        assert!(clip_frames.abs_diff(expected) <= 1, "{}: {clip_frames} frames, expected {expected}", path.display());
        // Walks keep a foot down; dances, kicks, jumps and spins leave the ground or crouch.
        let walk = path.file_name().is_some_and(|n| n.to_string_lossy().contains("walk"));
        check_body_motion(&body, &p, if walk { 0.10 } else { 0.60 });
        // The lead-in arrives moving as the clip moves: the root's last lead-in step is
        // close to the clip's first step (a lead-in to a standstill would end with a step of
        // almost zero, then jump to the clip's speed).
        let lead = cfg.lead_in_frames;
        let root = |f: usize| p.pose(f).unwrap().root_translation;
        let (step_in, step_clip) = (root(lead) - root(lead - 1), root(lead + 1) - root(lead));
        let jump = (step_in - step_clip).norm();
        assert!(
            jump <= 0.35 * step_clip.norm() + 2e-3,
            "{}: the root's speed jumps by {jump} m/frame at the lead-in's end (the clip's step {} m)",
            path.display(),
            step_clip.norm()
        );
    }
}
