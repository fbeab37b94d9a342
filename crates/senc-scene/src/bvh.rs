//! BVH (Biovision hierarchy) motion capture files: parsing, writing and joint rotations.
//!
//! Conventions of the format, as used by the CMU conversion and most tools: a joint's
//! channels are applied in the listed order as intrinsic rotations, so `Zrotation Yrotation
//! Xrotation` means `R = Rz(z) Ry(y) Rx(x)` (angles in degrees); a joint's global rotation
//! is its parent's times its own, and its position is the parent's position plus the
//! parent's global rotation applied to its `OFFSET`. All-zero angles give the rest pose.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::{UnitQuaternion, Vector3};
use senc_geom::Vec3;

use crate::error::SceneError;

/// One channel of a BVH joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Translation along x (file units).
    Xposition,
    /// Translation along y.
    Yposition,
    /// Translation along z.
    Zposition,
    /// Rotation about x, degrees.
    Xrotation,
    /// Rotation about y, degrees.
    Yrotation,
    /// Rotation about z, degrees.
    Zrotation,
}

impl Channel {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "Xposition" => Self::Xposition,
            "Yposition" => Self::Yposition,
            "Zposition" => Self::Zposition,
            "Xrotation" => Self::Xrotation,
            "Yrotation" => Self::Yrotation,
            "Zrotation" => Self::Zrotation,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Self::Xposition => "Xposition",
            Self::Yposition => "Yposition",
            Self::Zposition => "Zposition",
            Self::Xrotation => "Xrotation",
            Self::Yrotation => "Yrotation",
            Self::Zrotation => "Zrotation",
        }
    }

    fn rotation_axis(self) -> Option<Vector3<f64>> {
        match self {
            Self::Xrotation => Some(Vector3::x()),
            Self::Yrotation => Some(Vector3::y()),
            Self::Zrotation => Some(Vector3::z()),
            _ => None,
        }
    }
}

/// One joint of the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    /// Joint name.
    pub name: String,
    /// Parent joint index (parents precede children).
    pub parent: Option<usize>,
    /// Offset from the parent in the rest pose (file units).
    pub offset: Vec3,
    /// Channels in file order.
    pub channels: Vec<Channel>,
    /// `End Site` offset, if the joint has one.
    pub end_site: Option<Vec3>,
}

/// A parsed BVH file: hierarchy and per-frame channel values (file order, degrees for rotations).
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// Joints in file order.
    pub joints: Vec<BvhJoint>,
    /// Seconds per frame.
    pub frame_time: f64,
    /// One row of channel values per frame.
    pub frames: Vec<Vec<f64>>,
}

/// Joints a file may have (also bounds the nesting depth of the parser).
pub const MAX_JOINTS: usize = 512;

struct Tokens<'a> {
    toks: Vec<(usize, &'a str)>,
    pos: usize,
    path: PathBuf,
}

impl<'a> Tokens<'a> {
    fn err(&self, message: impl Into<String>) -> SceneError {
        let line = self.toks.get(self.pos.min(self.toks.len().saturating_sub(1))).map_or(0, |t| t.0);
        SceneError::Bvh { path: self.path.clone(), line, message: message.into() }
    }
    fn next(&mut self) -> Result<&'a str, SceneError> {
        let t = self.toks.get(self.pos).map(|t| t.1).ok_or_else(|| self.err("unexpected end of file"))?;
        self.pos += 1;
        Ok(t)
    }
    fn peek(&self) -> Option<&'a str> {
        self.toks.get(self.pos).map(|t| t.1)
    }
    fn expect(&mut self, word: &str) -> Result<(), SceneError> {
        let t = self.next()?;
        if t.eq_ignore_ascii_case(word) {
            Ok(())
        } else {
            self.pos -= 1;
            Err(self.err(format!("expected `{word}`, found `{t}`")))
        }
    }
    fn number(&mut self) -> Result<f64, SceneError> {
        let t = self.next()?;
        match t.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => {
                self.pos -= 1;
                Err(self.err(format!("expected a finite number, found `{t}`")))
            }
        }
    }
    fn line(&self) -> Option<usize> {
        self.toks.get(self.pos).map(|t| t.0)
    }
    fn vec3(&mut self) -> Result<Vec3, SceneError> {
        Ok(Vec3::new(self.number()?, self.number()?, self.number()?))
    }
}

impl Bvh {
    /// Reads and parses a file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parses BVH text; `path` only names the source in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let toks: Vec<(usize, &str)> =
            text.lines().enumerate().flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t))).collect();
        let mut t = Tokens { toks, pos: 0, path: path.to_owned() };
        t.expect("HIERARCHY")?;
        t.expect("ROOT")?;
        let mut joints = Vec::new();
        Self::parse_joint(&mut t, None, &mut joints)?;
        t.expect("MOTION")?;
        t.expect("Frames:")?;
        let n_frames = t.number()?;
        if n_frames < 0.0 || n_frames.fract() != 0.0 {
            return Err(t.err("frame count is not a non-negative integer"));
        }
        t.expect("Frame")?;
        t.expect("Time:")?;
        let frame_time = t.number()?;
        if !(frame_time > 0.0) {
            return Err(t.err("frame time must be positive"));
        }
        let n_channels: usize = joints.iter().map(|j: &BvhJoint| j.channels.len()).sum();
        // One frame per line, with exactly one value per channel.
        let n_frames = n_frames as usize;
        let mut frames = Vec::with_capacity(n_frames.min(1 << 16));
        for k in 0..n_frames {
            let Some(line) = t.line() else {
                return Err(t.err(format!(
                    "the file ends after {k} of the {n_frames} frames its header announces (truncated?)"
                )));
            };
            let mut row = Vec::with_capacity(n_channels);
            while t.line() == Some(line) {
                row.push(t.number()?);
            }
            if row.len() != n_channels {
                t.pos -= 1;
                return Err(t.err(format!(
                    "frame {k} has {} values, but the hierarchy declares {n_channels} channels",
                    row.len()
                )));
            }
            frames.push(row);
        }
        // Exported files often hold a frame or two more than their header counts (CMU's
        // Boxing_Toes); complete frames past the count are left out, anything else refused.
        while let Some(line) = t.line() {
            let mut values = 0;
            while t.line() == Some(line) && t.peek().is_some_and(|v| v.parse::<f64>().is_ok_and(f64::is_finite)) {
                t.pos += 1;
                values += 1;
            }
            if values != n_channels || t.line() == Some(line) {
                return Err(t.err(format!(
                    "values follow the {n_frames} frames the header announces and are not a frame of {n_channels} numbers"
                )));
            }
        }
        Ok(Self { joints, frame_time, frames })
    }

    fn parse_joint(t: &mut Tokens<'_>, parent: Option<usize>, joints: &mut Vec<BvhJoint>) -> Result<(), SceneError> {
        if joints.len() >= MAX_JOINTS {
            return Err(t.err(format!("more than {MAX_JOINTS} joints")));
        }
        let name = t.next()?.to_string();
        t.expect("{")?;
        t.expect("OFFSET")?;
        let offset = t.vec3()?;
        let mut channels = Vec::new();
        if t.peek() == Some("CHANNELS") {
            t.next()?;
            let n = t.number()?;
            if !(0.0..=6.0).contains(&n) || n.fract() != 0.0 {
                t.pos -= 1;
                return Err(t.err(format!("a joint has 0 to 6 channels, found `CHANNELS {n}`")));
            }
            for _ in 0..n as usize {
                let c = t.next()?;
                let ch = Channel::parse(c).ok_or_else(|| {
                    t.pos -= 1;
                    t.err(format!(
                        "`{c}` is not a channel name (Xposition ... Zrotation); is the CHANNELS count right?"
                    ))
                })?;
                if channels.contains(&ch) {
                    return Err(t.err(format!("channel `{c}` appears twice in one joint")));
                }
                channels.push(ch);
            }
        }
        let me = joints.len();
        joints.push(BvhJoint { name, parent, offset, channels, end_site: None });
        loop {
            match t.next()? {
                "}" => return Ok(()),
                "JOINT" => Self::parse_joint(t, Some(me), joints)?,
                "End" => {
                    t.expect("Site")?;
                    t.expect("{")?;
                    t.expect("OFFSET")?;
                    joints[me].end_site = Some(t.vec3()?);
                    t.expect("}")?;
                }
                other => {
                    t.pos -= 1;
                    return Err(t.err(format!("expected `JOINT`, `End Site` or `}}`, found `{other}`")));
                }
            }
        }
    }

    /// Drops namespace prefixes from joint names (`mixamorig:Hips` becomes `Hips`), as
    /// exporters add them; an error when two joints would then share a name.
    pub fn strip_namespaces(&mut self, path: &Path) -> Result<(), SceneError> {
        for j in &mut self.joints {
            if let Some((_, bare)) = j.name.rsplit_once(':') {
                j.name = bare.to_string();
            }
        }
        for (k, j) in self.joints.iter().enumerate() {
            if self.joints[..k].iter().any(|o| o.name == j.name) {
                return Err(SceneError::Clip {
                    path: path.to_owned(),
                    message: format!("two joints are called {}", j.name),
                });
            }
        }
        Ok(())
    }

    /// BVH text of this motion (shortest round-trip number formatting).
    pub fn to_bvh_string(&self) -> String {
        let mut s = String::from("HIERARCHY\n");
        self.write_joint(&mut s, 0, 0);
        let _ = writeln!(s, "MOTION\nFrames: {}\nFrame Time: {}", self.frames.len(), self.frame_time);
        for row in &self.frames {
            let line: Vec<String> = row.iter().map(|x| format!("{x}")).collect();
            let _ = writeln!(s, "{}", line.join(" "));
        }
        s
    }

    fn write_joint(&self, s: &mut String, j: usize, depth: usize) {
        let ind = "\t".repeat(depth);
        let jt = &self.joints[j];
        let kw = if jt.parent.is_none() { "ROOT" } else { "JOINT" };
        let _ = writeln!(s, "{ind}{kw} {}\n{ind}{{", jt.name);
        let o = jt.offset;
        let _ = writeln!(s, "{ind}\tOFFSET {} {} {}", o.x, o.y, o.z);
        if !jt.channels.is_empty() {
            let names: Vec<&str> = jt.channels.iter().map(|c| c.name()).collect();
            let _ = writeln!(s, "{ind}\tCHANNELS {} {}", names.len(), names.join(" "));
        }
        for (c, child) in self.joints.iter().enumerate() {
            if child.parent == Some(j) {
                self.write_joint(s, c, depth + 1);
            }
        }
        if let Some(e) = jt.end_site {
            let _ = writeln!(s, "{ind}\tEnd Site\n{ind}\t{{\n{ind}\t\tOFFSET {} {} {}\n{ind}\t}}", e.x, e.y, e.z);
        }
        let _ = writeln!(s, "{ind}}}");
    }

    /// Index of the first channel of joint `j` in a frame row.
    pub fn channel_start(&self, j: usize) -> usize {
        self.joints[..j].iter().map(|x| x.channels.len()).sum()
    }

    /// Index of the joint called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Duration of the clip, s: `(n_frames − 1) · frame_time`.
    pub fn duration(&self) -> f64 {
        self.frames.len().saturating_sub(1) as f64 * self.frame_time
    }

    /// The local rotation of joint `j` at `frame` (channels composed in file order).
    pub fn local_rotation(&self, frame: usize, j: usize) -> UnitQuaternion<f64> {
        let start = self.channel_start(j);
        let row = &self.frames[frame];
        let mut q = UnitQuaternion::identity();
        for (k, c) in self.joints[j].channels.iter().enumerate() {
            if let Some(axis) = c.rotation_axis() {
                let a = nalgebra::Unit::new_unchecked(axis);
                q *= UnitQuaternion::from_axis_angle(&a, row[start + k].to_radians());
            }
        }
        q
    }

    /// Global rotation of every joint at `frame`.
    pub fn global_rotations(&self, frame: usize) -> Vec<UnitQuaternion<f64>> {
        let mut out: Vec<UnitQuaternion<f64>> = Vec::with_capacity(self.joints.len());
        for j in 0..self.joints.len() {
            let local = self.local_rotation(frame, j);
            out.push(match self.joints[j].parent {
                Some(p) => out[p] * local,
                None => local,
            });
        }
        out
    }

    /// Position of the root at `frame` (file units): its offset plus its position channels.
    pub fn root_position(&self, frame: usize) -> Vec3 {
        let mut p = self.joints[0].offset;
        let row = &self.frames[frame];
        for (k, c) in self.joints[0].channels.iter().enumerate() {
            match c {
                Channel::Xposition => p.x += row[k],
                Channel::Yposition => p.y += row[k],
                Channel::Zposition => p.z += row[k],
                _ => {}
            }
        }
        p
    }

    /// Joint positions at `frame` (file units).
    pub fn joint_positions(&self, frame: usize) -> Vec<Vec3> {
        let g = self.global_rotations(frame);
        let mut out: Vec<Vec3> = Vec::with_capacity(self.joints.len());
        for jt in &self.joints {
            out.push(match jt.parent {
                Some(p) => out[p] + g[p] * jt.offset,
                None => self.root_position(frame),
            });
        }
        out
    }

    /// Rest direction of joint `j`'s segment: the offset of its first child with a non-zero
    /// offset, else its end site; `None` when it has neither.
    pub fn rest_direction(&self, j: usize) -> Option<Vec3> {
        let child = self.joints.iter().filter(|c| c.parent == Some(j)).map(|c| c.offset).find(|o| o.norm() > 1e-9);
        child.or(self.joints[j].end_site).filter(|o| o.norm() > 1e-9)
    }
}
