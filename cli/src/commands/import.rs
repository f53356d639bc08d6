//! `kinecal import --urdf`: the serial chain of a URDF as an MDH robot file
//! (docs/formats.md, "import --urdf"; the conversion is [`crate::formats::urdf::mdh`]).

use crate::formats::urdf::mdh::{self, Imported};
use crate::formats::urdf::{chain, parse::Urdf};
use crate::output::atomic::refuse_overwriting_inputs;
use crate::reports::{path_text, ImportReport};
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Arguments of `kinecal import`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Plain URDF file (expand a xacro file first: `xacro F.urdf.xacro > F.urdf`).
    #[arg(long)]
    pub urdf: PathBuf,
    /// First link of the chain; the robot's base frame (default: the URDF's root link).
    #[arg(long)]
    pub base_link: Option<String>,
    /// Last link of the chain; the tool point is its origin (default: the single leaf after
    /// the last revolute joint; refused, naming the candidates, when there are several).
    #[arg(long)]
    pub tip_link: Option<String>,
    /// Tool point in the tip link's frame, millimetres (`x,y,z`; default 0,0,0).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub tool_xyz_mm: Option<Vec<f64>>,
    /// Write `[base]` (the pose of MDH frame 0 in the base link): for measurements taken in
    /// the base link's frame. Without it the base is unknown (a tracker sees the robot in its
    /// own frame) and `check`, `identify` estimate it from the data.
    #[arg(long)]
    pub with_base: bool,
    /// Robot file (TOML) to write.
    #[arg(long)]
    pub out: PathBuf,
}

/// Largest URDF read (a robot description is kilobytes to a few megabytes; meshes are
/// separate files).
const MAX_URDF_BYTES: u64 = 64 << 20;

/// Reads a URDF file (refused with exit status 2 when it cannot be read or parsed, or is
/// larger than `MAX_URDF_BYTES`: never read whole before that is known).
pub fn read_urdf(path: &Path) -> anyhow::Result<(String, Urdf)> {
    let text = crate::formats::read_text_limited(path, MAX_URDF_BYTES, "a URDF file")?;
    let urdf = Urdf::parse(&text, &path.display().to_string())?;
    Ok((text, urdf))
}

/// Imports the chain of `urdf` between the links (the library entry point of the command).
pub fn import_chain(
    urdf: &Urdf,
    path: &Path,
    base: Option<&str>,
    tip: Option<&str>,
    tool_mm: [f64; 3],
) -> anyhow::Result<(Imported, String, String, Vec<String>)> {
    let ch = chain::find(urdf, base, tip, &path.display().to_string())?;
    let name = if urdf.name.is_empty() {
        "URDF import".to_string()
    } else {
        format!("{} (from URDF)", urdf.name)
    };
    let imported = mdh::import(&ch, tool_mm, &name);
    let fixed = ch
        .joints
        .iter()
        .filter(|j| !j.is_revolute())
        .map(|j| j.name.clone())
        .collect();
    imported.file.validate().map_err(|e| {
        crate::refused(format!(
            "{}: the imported robot: {}",
            path.display(),
            e.message
        ))
    })?;
    Ok((imported, ch.base, ch.tip, fixed))
}

/// Runs `kinecal import`.
pub fn run(args: &Args) -> anyhow::Result<ImportReport> {
    refuse_overwriting_inputs("--out", &args.out, &[("URDF", &args.urdf)])?;
    let tool = match &args.tool_xyz_mm {
        Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => [v[0], v[1], v[2]],
        Some(_) => crate::refuse!("--tool-xyz-mm needs three finite numbers x,y,z"),
        None => [0.0; 3],
    };
    let (_, urdf) = read_urdf(&args.urdf)?;
    let (mut imp, base_link, tip_link, fixed_folded) = import_chain(
        &urdf,
        &args.urdf,
        args.base_link.as_deref(),
        args.tip_link.as_deref(),
        tool,
    )?;
    let base = imp.file.base.clone();
    if !args.with_base {
        imp.file.base = None;
    }
    imp.file
        .save(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let base = base.unwrap_or(crate::formats::robot_file::BaseSpec {
        xyz_mm: [0.0; 3],
        rpy_deg: [0.0; 3],
    });
    Ok(ImportReport {
        urdf: path_text(&args.urdf),
        out: path_text(&args.out),
        base_link,
        tip_link,
        joints: imp.file.joints.len(),
        joint_names: imp.joint_names.clone(),
        fixed_folded,
        tool_xyz_mm: imp.file.tool.xyz_mm,
        base_xyz_mm: base.xyz_mm,
        base_rpy_deg: base.rpy_deg,
        base_written: args.with_base,
    })
}
