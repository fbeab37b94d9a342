//! `cargo xtask energy`: the energy of a predicted frame, term by term, in joules.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use senc_energy::{EnergyConfig, EnergyModel};
use senc_geom::obj::{read_obj, ObjData};
use senc_geom::{TriMesh, Vec3};

/// Arguments of `cargo xtask energy`.
#[derive(clap::Args)]
pub struct Args {
    /// Rest mesh of the garment (OBJ).
    #[arg(long)]
    pub garment: PathBuf,
    /// The predicted positions x[t+1] (OBJ with the rest mesh's faces).
    #[arg(long)]
    pub state: PathBuf,
    /// x[t] (without it there is no inertia term).
    #[arg(long)]
    pub prev: Option<PathBuf>,
    /// x[t-1] (default: x[t], i.e. at rest).
    #[arg(long)]
    pub prev2: Option<PathBuf>,
    /// Body mesh at t (and at t+1 unless --body-next is given).
    #[arg(long)]
    pub body: Option<PathBuf>,
    /// Body at t+1 for a moving body (OBJ with the body's vertices and faces).
    #[arg(long)]
    pub body_next: Option<PathBuf>,
    /// Energy config, TOML (or JSON with a .json extension): the fields of senc-energy's
    /// `EnergyConfig`; missing fields take its defaults (HOOD's material).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Print one JSON object: the present terms and `total`.
    #[arg(long)]
    pub json: bool,
}

/// Positions of an OBJ that must have the vertices and faces of `mesh` (a moved copy of it);
/// `what` names the file in errors, `of` the mesh it must match.
fn read_moved(path: &Path, mesh: &TriMesh, what: &str, of: &str) -> Result<Vec<Vec3>> {
    let data = ObjData::read(path).with_context(|| format!("reading {what} {}", path.display()))?;
    if data.positions.len() != mesh.n_vertices() || data.faces != mesh.faces() {
        bail!(
            "{what} {} has {} vertices and {} faces but the {of} has {} and {}; it must be the {of}'s mesh moved",
            path.display(),
            data.positions.len(),
            data.faces.len(),
            mesh.n_vertices(),
            mesh.n_faces()
        );
    }
    Ok(data.positions)
}

fn read_state(path: &Path, rest: &TriMesh, what: &str) -> Result<Vec<Vec3>> {
    read_moved(path, rest, what, "garment")
}

fn read_config(path: &Path) -> Result<EnergyConfig> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading config {}", path.display()))?;
    let config = if path.extension().is_some_and(|e| e == "json") {
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("config {}: {e}", path.display()))?
    } else {
        toml::from_str(&text)
            .map_err(|e| anyhow::anyhow!("config {}: {}", path.display(), e.to_string().replace('\n', " ")))?
    };
    Ok(config)
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    let rest = read_obj(&args.garment).with_context(|| format!("reading garment {}", args.garment.display()))?;
    let mut config = match &args.config {
        Some(p) => read_config(p)?,
        None => EnergyConfig::default(),
    };
    let next = read_state(&args.state, &rest, "state")?;
    let cur = match &args.prev {
        Some(p) => read_state(p, &rest, "--prev")?,
        None => {
            // No history: no inertia term.
            config.inertia = false;
            next.clone()
        }
    };
    let prev = match &args.prev2 {
        Some(p) => read_state(p, &rest, "--prev2")?,
        None => cur.clone(),
    };
    if args.prev2.is_some() && args.prev.is_none() {
        bail!("--prev2 needs --prev");
    }
    let body = match &args.body {
        Some(p) => Some(read_obj(p).with_context(|| format!("reading body {}", p.display()))?),
        None => None,
    };
    let body_next = match (&args.body_next, &body) {
        (None, _) => None,
        (Some(_), None) => bail!("--body-next needs --body (the body at t)"),
        (Some(p), Some(b)) => Some(read_moved(p, b, "--body-next", "body")?),
    };
    let model = EnergyModel::new(&rest, &config, body.as_ref())?;
    let frame = model.frame(
        &cur,
        &prev,
        body.as_ref().map(|b| (b.positions(), body_next.as_deref().unwrap_or(b.positions()))),
    )?;
    let breakdown = frame.evaluate(&next, None)?;
    if args.json {
        let mut obj = serde_json::Map::new();
        for (name, e) in &breakdown.terms {
            obj.insert((*name).to_string(), serde_json::json!(e));
        }
        obj.insert("total".into(), serde_json::json!(breakdown.total));
        println!("{}", serde_json::Value::Object(obj));
    } else {
        for (name, e) in &breakdown.terms {
            println!("{name:>16}  {e:>14.6e} J");
        }
        println!("{:>16}  {:>14.6e} J", "total", breakdown.total);
    }
    Ok(())
}
