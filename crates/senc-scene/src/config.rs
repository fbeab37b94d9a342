//! Scene configs (TOML). A scene is the `[scene]` table of a config file, so one file can
//! also hold the training agent's `[train]` and `[model]` tables; the scene loader reads only
//! `[scene]` and refuses unknown keys inside it, naming them. Paths are relative to the
//! config file's directory. A file may extend another (`extends = "tshirt.toml"`) and
//! change only what differs ([`ConfigDocument`]).
//!
//! ```toml
//! [scene]
//! garment = "../data/garments/tshirt.msgpack"
//! body = "../data/body.msgpack"
//! close_holes = ["hem", "left_sleeve", "right_sleeve"]   # the neck stays open
//! [scene.motions]
//! train = ["../data/motions/cmu_01_01.msgpack"]
//! test = ["../data/motions/boxing_toes.msgpack"]
//! [scene.material]
//! density = 0.20022
//! thickness = 4.7e-4
//! lame_mu = 23600.0
//! lame_lambda = 44400.0
//! bending = 3.9626e-5
//! [scene.external_force]
//! gravity = [0.0, -9.81, 0.0]
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// The `[scene]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// Garment asset (MessagePack from `cargo xtask data` or `cargo xtask fit`).
    pub garment: PathBuf,
    /// Body asset.
    pub body: PathBuf,
    /// Names of the garment's boundary loops to close for self-collision (GIA); the others
    /// stay open. Names are listed in `data/README.md` per garment.
    #[serde(default)]
    pub close_holes: Vec<String>,
    /// Names of boundary loops whose vertices are pinned: they follow the skinned garment
    /// exactly (prescribed positions, no dynamics), as HOOD pins skirt waists. A skirt
    /// fitted as wide as the hips has nothing else holding it up. Default: none.
    #[serde(default)]
    pub pin: Vec<String>,
    /// Simulation frame rate, frames/s (motions are resampled to it). Default 30.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Frames blending from the rest pose (where the garment is fitted) to each motion's
    /// first frame. Default 15 (0.5 s at 30 fps).
    #[serde(default = "default_lead_in")]
    pub lead_in_frames: usize,
    /// Turn and shift each motion so that its first frame faces and stands where the rest
    /// pose does (see `Motion::aligned_to_rest_heading`), so the lead-in never spins or
    /// slides the body. Default true; false keeps the clips' world heading.
    #[serde(default = "default_true")]
    pub align_heading: bool,
    /// Time step of the first simulated step from rest, s. Default 1/30 s, one frame at 30
    /// fps. A longer first step lets the garment settle under gravity at once, but a network
    /// does not see Δt: trained on a 0.1 s first step, the skirt's first step rose 8.7 cm
    /// where the solver's sagged 1.3 cm (`reports/README.md`, the resting case).
    #[serde(default = "default_first_step")]
    pub first_step_dt: f64,
    /// Training and test motions.
    pub motions: MotionsConfig,
    /// Cloth material.
    #[serde(default)]
    pub material: MaterialConfig,
    /// Gravity and external force.
    #[serde(default)]
    pub external_force: ExternalForceConfig,
}

fn default_fps() -> f64 {
    30.0
}
fn default_true() -> bool {
    true
}
fn default_lead_in() -> usize {
    15
}
fn default_first_step() -> f64 {
    1.0 / 30.0
}

/// Motion files: `train` are seen in training, `test` never are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionsConfig {
    /// Training motions.
    pub train: Vec<PathBuf>,
    /// Test motions (unseen in training).
    #[serde(default)]
    pub test: Vec<PathBuf>,
}

/// The `[scene.material]` table as written: any of the cloth's numbers, each left out
/// taking HOOD's default, which senc-energy's `Material` holds (senc-train builds that
/// material from this table). Give either `lame_mu` and `lame_lambda` or `young` and
/// `poisson`, or neither.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    /// Area density ρ, kg/m².
    #[serde(default)]
    pub density: Option<f64>,
    /// Thickness h, m.
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Lamé μ, Pa.
    #[serde(default)]
    pub lame_mu: Option<f64>,
    /// Lamé λ, Pa.
    #[serde(default)]
    pub lame_lambda: Option<f64>,
    /// Young's modulus E, Pa (instead of the Lamé pair).
    #[serde(default)]
    pub young: Option<f64>,
    /// Poisson's ratio ν (instead of the Lamé pair), in (−1, 0.5).
    #[serde(default)]
    pub poisson: Option<f64>,
    /// Bending stiffness k_b, N·m.
    #[serde(default)]
    pub bending: Option<f64>,
}

impl MaterialConfig {
    /// Checks that the stiffness is given as one complete pair (or not at all) and that
    /// every number given is finite and in its range.
    pub fn validate(&self) -> Result<(), SceneError> {
        match (self.lame_mu, self.lame_lambda, self.young, self.poisson) {
            (None, None, None, None) | (Some(_), Some(_), None, None) | (None, None, Some(_), Some(_)) => {}
            _ => {
                return Err(SceneError::Invalid(
                    "material: give both lame_mu and lame_lambda, or both young and poisson, not a mix".into(),
                ))
            }
        }
        let positive = [
            ("density", self.density),
            ("thickness", self.thickness),
            ("bending", self.bending),
            ("lame_mu", self.lame_mu),
            ("young", self.young),
        ];
        for (k, v) in positive {
            if let Some(v) = v.filter(|v| !(*v > 0.0 && v.is_finite())) {
                return Err(SceneError::Invalid(format!("material.{k} = {v} must be a positive number")));
            }
        }
        if let Some(la) = self.lame_lambda.filter(|la| !(*la >= 0.0 && la.is_finite())) {
            return Err(SceneError::Invalid(format!("material.lame_lambda = {la} must be a non-negative number")));
        }
        if let Some(nu) = self.poisson.filter(|nu| !(*nu > -1.0 && *nu < 0.5)) {
            return Err(SceneError::Invalid(format!("material.poisson = {nu} must lie in (-1, 0.5)")));
        }
        Ok(())
    }
}

/// Gravity and an external acceleration (wind-like), m/s².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalForceConfig {
    /// Gravity g, m/s². Default (0, −9.81, 0).
    #[serde(default = "d_gravity")]
    pub gravity: [f64; 3],
    /// Fixed external acceleration a_ext, m/s². Default zero.
    #[serde(default)]
    pub acceleration: [f64; 3],
    /// SENC samples a_ext per sequence with magnitude uniform in [0, random_max] and a
    /// uniform direction; 0 disables sampling. Default 0.
    #[serde(default)]
    pub random_max: f64,
}

fn d_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

impl Default for ExternalForceConfig {
    fn default() -> Self {
        Self { gravity: d_gravity(), acceleration: [0.0; 3], random_max: 0.0 }
    }
}

impl SceneConfig {
    /// Parses the `[scene]` table of TOML text (other top-level tables are left to their
    /// owners). `path` names the source in errors, and an `extends` in the text is read
    /// relative to its directory (see [`ConfigDocument`]).
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        Self::from_document(&ConfigDocument::parse(text, path, SCENE_PATH_KEYS)?)
    }

    /// The `[scene]` table of a resolved document; relative paths stay as written.
    pub fn from_document(doc: &ConfigDocument) -> Result<Self, SceneError> {
        let err = |m: String| SceneError::Config { path: doc.path.clone(), message: m };
        let scene = doc.table.get("scene").cloned().ok_or_else(|| err("no [scene] table".into()))?;
        let cfg: SceneConfig = scene.try_into().map_err(|e: toml::de::Error| err(format!("[scene]: {e}")))?;
        cfg.validate().map_err(|e| err(e.to_string()))?;
        Ok(cfg)
    }

    /// Reads a config file (with its `extends` chain); relative paths inside are resolved
    /// against its directory.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        Ok(Self::from_document(&ConfigDocument::read(path.as_ref(), SCENE_PATH_KEYS)?)?.resolved_against(path.as_ref()))
    }

    /// This config with its relative paths joined to the directory of `config_file`.
    fn resolved_against(mut self, config_file: &Path) -> Self {
        let dir = config_file.parent().unwrap_or(Path::new("."));
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = dir.join(&*p);
            }
        };
        fix(&mut self.garment);
        fix(&mut self.body);
        self.motions.train.iter_mut().for_each(fix);
        self.motions.test.iter_mut().for_each(fix);
        self
    }

    /// Checks numbers and the train/test split (no motion in both).
    pub fn validate(&self) -> Result<(), SceneError> {
        self.material.validate()?;
        if !(self.fps > 0.0 && self.fps.is_finite()) {
            return Err(SceneError::Invalid(format!("fps = {} must be positive", self.fps)));
        }
        if !(self.first_step_dt > 0.0 && self.first_step_dt.is_finite()) {
            return Err(SceneError::Invalid(format!("first_step_dt = {} must be positive", self.first_step_dt)));
        }
        if self.motions.train.is_empty() {
            return Err(SceneError::Invalid("motions.train is empty; give at least one training motion".into()));
        }
        if let Some(p) = self.motions.test.iter().find(|p| self.motions.train.contains(p)) {
            return Err(SceneError::Invalid(format!(
                "motion {} is both in motions.train and motions.test; test motions must be unseen",
                p.display()
            )));
        }
        let e = &self.external_force;
        if e.gravity.iter().chain(&e.acceleration).any(|x| !x.is_finite()) || !(e.random_max >= 0.0) {
            return Err(SceneError::Invalid("external_force values must be finite, random_max >= 0".into()));
        }
        Ok(())
    }
}

/// The keys of the `[scene]` table that hold file paths (relative to the config file).
pub const SCENE_PATH_KEYS: &[&str] = &["scene.garment", "scene.body", "scene.motions.train", "scene.motions.test"];

/// The top-level key naming the config file a config extends.
pub const EXTENDS: &str = "extends";

/// A config file as one TOML table, with its `extends` chain resolved.
///
/// A file may say `extends = "base.toml"` at top level (relative to the file): the base is
/// read (itself possibly extending another file), and this file's tables are merged into it
/// deeply: a table merges key by key, any other value (arrays included) replaces the base's.
/// A cycle of `extends` is refused. Relative paths of a base in another directory (at the
/// dotted keys of `path_keys`, each a string or an array of strings) are rewritten to be
/// relative to this file, so the merged table reads as if it had been written here.
/// Command-line overrides ([`ConfigDocument::set`]) apply to the merged table.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigDocument {
    /// The file (relative paths in `table` are relative to its directory).
    pub path: PathBuf,
    /// Every table of the file and its bases, merged; no `extends` key remains.
    pub table: toml::Table,
}

impl ConfigDocument {
    /// Reads `path` and the files it extends.
    pub fn read(path: &Path, path_keys: &[&str]) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
        Self::parse(&text, path, path_keys)
    }

    /// Parses `text` as the content of the file `path` (an `extends` in it is read
    /// relative to `path`'s directory).
    pub fn parse(text: &str, path: &Path, path_keys: &[&str]) -> Result<Self, SceneError> {
        let mut chain = vec![canonical(path)];
        let table = resolve(parse_table(text, path)?, path, path_keys, &mut chain)?;
        Ok(Self { path: path.to_path_buf(), table })
    }

    /// Sets the value at a dotted key from `key=value` (the value in TOML syntax: `100`,
    /// `2.5e-4`, `"text"`, `[1, 2]`), creating tables on the way. Whether the key exists is
    /// checked by the table's reader, which refuses unknown keys.
    pub fn set(&mut self, assignment: &str) -> Result<(), SceneError> {
        let err = |m: String| SceneError::Config { path: self.path.clone(), message: m };
        let Some((key, value)) = assignment.split_once('=') else {
            return Err(err(format!("override `{assignment}`: write it as key=value, e.g. train.seed=1")));
        };
        let (key, value) = (key.trim(), value.trim());
        let parts: Vec<&str> = key.split('.').map(str::trim).collect();
        if parts.iter().any(|p| p.is_empty()) || parts[0] == EXTENDS {
            return Err(err(format!("override `{assignment}`: `{key}` is not a dotted key like train.seed")));
        }
        let parsed: toml::Table = toml::from_str(&format!("v = {value}")).map_err(|_| {
            err(format!(
                "override `{assignment}`: `{value}` is not a TOML value (numbers as 1 or 2.5, strings in quotes: \"text\")"
            ))
        })?;
        let value = parsed.get("v").cloned().ok_or_else(|| err(format!("override `{assignment}`: no value")))?;
        let (last, tables) = parts.split_last().expect("at least one part");
        let mut t = &mut self.table;
        for (i, part) in tables.iter().enumerate() {
            let entry = t.entry(part.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
            t = entry.as_table_mut().ok_or_else(|| {
                err(format!("override `{assignment}`: `{}` is a value, not a table", parts[..=i].join(".")))
            })?;
        }
        t.insert(last.to_string(), value);
        Ok(())
    }

    /// The same document saved as the file `path`: relative paths (at `path_keys`) are
    /// rewritten to be relative to `path`'s directory (absolute where no relative path
    /// leads there).
    pub fn moved_to(&self, path: &Path, path_keys: &[&str]) -> Self {
        let from = absolute_dir(&self.path);
        let to = absolute_dir(path);
        let mut table = self.table.clone();
        map_paths(&mut table, path_keys, &|p: &Path| relative_path(&normalize(&from.join(p)), &to));
        Self { path: path.to_path_buf(), table }
    }

    /// The merged table as TOML text (no `extends`).
    pub fn to_toml(&self) -> String {
        toml::to_string(&self.table).unwrap_or_default()
    }
}

fn parse_table(text: &str, path: &Path) -> Result<toml::Table, SceneError> {
    toml::from_str(text).map_err(|e| SceneError::Config { path: path.to_path_buf(), message: e.to_string() })
}

fn canonical(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| normalize(&std::env::current_dir().unwrap_or_default().join(path)))
}

/// Resolves the `extends` of `table` (the file `path`); `chain` holds the files on the way.
fn resolve(
    mut table: toml::Table,
    path: &Path,
    path_keys: &[&str],
    chain: &mut Vec<PathBuf>,
) -> Result<toml::Table, SceneError> {
    let err = |m: String| SceneError::Config { path: path.to_path_buf(), message: m };
    let base_name = match table.remove(EXTENDS) {
        None => return Ok(table),
        Some(toml::Value::String(s)) => PathBuf::from(s),
        Some(v) => return Err(err(format!("{EXTENDS} = {v}: give the base config's file name as a string"))),
    };
    let base_path = path.parent().unwrap_or(Path::new(".")).join(&base_name);
    let key = canonical(&base_path);
    if chain.contains(&key) {
        let names: Vec<String> = chain.iter().chain([&key]).map(|p| p.display().to_string()).collect();
        return Err(err(format!("{EXTENDS} forms a cycle: {}", names.join(" -> "))));
    }
    chain.push(key);
    let text = std::fs::read_to_string(&base_path)
        .map_err(|e| err(format!("{EXTENDS} = {:?}: cannot read {}: {e}", base_name, base_path.display())))?;
    let mut base = resolve(parse_table(&text, &base_path)?, &base_path, path_keys, chain)?;
    if let Some(dir) = base_name.parent().filter(|d| !d.as_os_str().is_empty()) {
        map_paths(&mut base, path_keys, &|p: &Path| dir.join(p));
    }
    merge(&mut base, table);
    Ok(base)
}

/// Merges `over` into `base`: tables key by key, everything else replaced.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// Applies `f` to every relative path at the dotted `keys` of `table`.
fn map_paths(table: &mut toml::Table, keys: &[&str], f: &dyn Fn(&Path) -> PathBuf) {
    let fix = |v: &mut toml::Value| {
        if let toml::Value::String(s) = v {
            if Path::new(s.as_str()).is_relative() {
                *s = f(Path::new(s.as_str())).to_string_lossy().replace('\\', "/");
            }
        }
    };
    for key in keys {
        let parts: Vec<&str> = key.split('.').collect();
        let (last, tables) = parts.split_last().expect("non-empty key");
        let mut t = Some(&mut *table);
        for part in tables {
            t = t.and_then(|t| t.get_mut(*part)).and_then(|v| v.as_table_mut());
        }
        match t.and_then(|t| t.get_mut(*last)) {
            Some(toml::Value::Array(items)) => items.iter_mut().for_each(fix),
            Some(v) => fix(v),
            None => {}
        }
    }
}

/// The absolute, lexically normalised directory of a file.
fn absolute_dir(file: &Path) -> PathBuf {
    let dir = file.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    canonical(dir)
}

/// `path` without `.` and with each `..` applied to the component before it.
fn normalize(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// `target` (absolute, normalised) relative to the directory `dir` (absolute, normalised);
/// `target` itself when they share no root.
fn relative_path(target: &Path, dir: &Path) -> PathBuf {
    let (t, d): (Vec<_>, Vec<_>) = (target.components().collect(), dir.components().collect());
    let common = t.iter().zip(&d).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return target.to_path_buf();
    }
    let mut out: PathBuf = d[common..].iter().map(|_| "..").collect();
    out.extend(&t[common..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        p
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("senc-config-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn extends_merges_tables_deeply_and_rebases_paths() {
        let d = tmp("extends");
        write(
            &d,
            "base.toml",
            "[scene]\ngarment = \"../data/g.msgpack\"\nbody = \"/abs/b.msgpack\"\n[scene.motions]\n\
             train = [\"../data/a.msgpack\"]\n[train]\nseed = 0\nphase1_iterations = 10\n",
        );
        let top = write(&d, "sub/top.toml", "extends = \"../base.toml\"\n[train]\nseed = 3\n");
        let doc = ConfigDocument::read(&top, SCENE_PATH_KEYS).unwrap();
        let train = doc.table["train"].as_table().unwrap();
        assert_eq!(train["seed"].as_integer(), Some(3));
        assert_eq!(train["phase1_iterations"].as_integer(), Some(10), "kept from the base");
        assert!(!doc.table.contains_key(EXTENDS));
        let scene = SceneConfig::from_document(&doc).unwrap();
        assert_eq!(scene.garment, Path::new("../../data/g.msgpack"));
        assert_eq!(scene.body, Path::new("/abs/b.msgpack"));
        assert_eq!(scene.motions.train, vec![PathBuf::from("../../data/a.msgpack")]);
        // Resolved against the top file, the rebased path is the base's own.
        let read = SceneConfig::read(&top).unwrap();
        assert_eq!(normalize(&read.garment), normalize(&d.join("../data/g.msgpack")));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn extends_refuses_cycles_and_missing_bases() {
        let d = tmp("cycle");
        let a = write(&d, "a.toml", "extends = \"b.toml\"\n");
        write(&d, "b.toml", "extends = \"a.toml\"\n");
        let e = ConfigDocument::read(&a, SCENE_PATH_KEYS).unwrap_err().to_string();
        assert!(e.contains("cycle"), "{e}");
        let own = write(&d, "self.toml", "extends = \"self.toml\"\n");
        assert!(ConfigDocument::read(&own, SCENE_PATH_KEYS).unwrap_err().to_string().contains("cycle"));
        let m = write(&d, "m.toml", "extends = \"missing.toml\"\n");
        let e = ConfigDocument::read(&m, SCENE_PATH_KEYS).unwrap_err().to_string();
        assert!(e.contains("missing.toml"), "{e}");
        let n = write(&d, "n.toml", "extends = 3\n");
        assert!(ConfigDocument::read(&n, SCENE_PATH_KEYS).unwrap_err().to_string().contains("string"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn set_parses_toml_values_at_dotted_keys() {
        let mut doc = ConfigDocument::parse("[train]\nseed = 0\n", Path::new("c.toml"), &[]).unwrap();
        doc.set("train.seed=4").unwrap();
        doc.set("train.phase2_iterations = 100").unwrap();
        doc.set("energy.self_collision.weight=0.0").unwrap();
        doc.set("model.self_edges=\"none\"").unwrap();
        assert_eq!(doc.table["train"]["seed"].as_integer(), Some(4));
        assert_eq!(doc.table["train"]["phase2_iterations"].as_integer(), Some(100));
        assert_eq!(doc.table["energy"]["self_collision"]["weight"].as_float(), Some(0.0));
        assert_eq!(doc.table["model"]["self_edges"].as_str(), Some("none"));
        for bad in ["train.seed", "train.seed=", "=3", "train..seed=1", "train.seed=not toml", "train.seed.x=1"] {
            let e = doc.set(bad).unwrap_err().to_string();
            assert!(e.contains("override"), "{bad}: {e}");
        }
    }

    #[test]
    fn moved_documents_keep_pointing_at_the_same_files() {
        let doc = ConfigDocument::parse(
            "[scene]\ngarment = \"../data/g.msgpack\"\n[scene.motions]\ntrain = [\"m.msgpack\"]\n",
            Path::new("/r/configs/c.toml"),
            SCENE_PATH_KEYS,
        )
        .unwrap();
        let moved = doc.moved_to(Path::new("/r/runs/x/config.toml"), SCENE_PATH_KEYS);
        assert_eq!(moved.table["scene"]["garment"].as_str(), Some("../../data/g.msgpack"));
        assert_eq!(moved.table["scene"]["motions"]["train"][0].as_str(), Some("../../configs/m.msgpack"));
        let again = ConfigDocument::parse(&moved.to_toml(), &moved.path, SCENE_PATH_KEYS).unwrap();
        assert_eq!(again.table, moved.table);
    }
}
