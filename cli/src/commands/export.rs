//! `kinecal export`: a calibrated model back into the robot's URDF (origins of the chain
//! joints rewritten, the tool point appended), or as a table of nominal and calibrated MDH
//! parameters (`--format dh-table`), or as the binary model firmware loads (`--format
//! firmware`). docs/formats.md, "URDF export", "DH table", "Binary model (.kcm)".

use super::import::{import_chain, read_urdf};
use crate::formats::robot_file::RobotFile;
use crate::formats::urdf::splice;
use crate::formats::{dh_table, firmware_model};
use crate::output::atomic::{refuse_overwriting_inputs, write_atomic};
use crate::reports::{path_text, ExportReport};
use anyhow::Context;
use std::path::PathBuf;

/// Output format of `kinecal export`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// The URDF given with --urdf, chain joint origins calibrated, tool frame added.
    Urdf,
    /// One row per parameter: parameter, unit, nominal, calibrated, delta (CSV, or JSON for
    /// an --out ending in .json).
    DhTable,
    /// The binary model firmware loads (`kc_robot_load`): rows, base, tools, effects,
    /// couplings; version and CRC-32 (docs/formats.md, "Binary model (.kcm)").
    Firmware,
}

/// Arguments of `kinecal export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The calibrated model (robot file, e.g. from `identify --out`).
    #[arg(long)]
    pub model: PathBuf,
    /// What to write.
    #[arg(long, value_enum, default_value_t = Format::Urdf)]
    pub format: Format,
    /// The URDF the model was imported from (required for --format urdf; for dh-table it
    /// gives the nominal column when --robot is not given).
    #[arg(long)]
    pub urdf: Option<PathBuf>,
    /// dh-table: the nominal robot file (nominal and delta columns).
    #[arg(long)]
    pub robot: Option<PathBuf>,
    /// First link of the chain, as given to `import` (default: the root link).
    #[arg(long)]
    pub base_link: Option<String>,
    /// Last link of the chain, as given to `import` (default as in `import`).
    #[arg(long)]
    pub tip_link: Option<String>,
    /// File to write (a URDF; for dh-table .csv, or .json for JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// A model row further than this from the nominal (the URDF's import, or --robot) is
    /// taken for a model of another robot or convention and refused (a manufacturing
    /// tolerance, as in `identify`).
    #[arg(long, default_value_t = 20.0)]
    pub tolerance_mm: f64,
    /// The same for angles, degrees.
    #[arg(long, default_value_t = 2.0)]
    pub tolerance_deg: f64,
}

/// The first row value of `model` further than the tolerances from `nominal`, described:
/// a calibration moves rows by millimetres and tenths of a degree, so a larger difference
/// means the model was made for another robot (or another MDH convention) than this file.
fn mismatch(model: &RobotFile, nominal: &RobotFile, tol_mm: f64, tol_deg: f64) -> Option<String> {
    let wrap = |d: f64| (d + 180.0).rem_euclid(360.0) - 180.0;
    for (i, (m, n)) in model.joints.iter().zip(&nominal.joints).enumerate() {
        let rows = [
            ("alpha", m.alpha_deg, n.alpha_deg, true),
            ("a", m.a_mm, n.a_mm, false),
            ("theta", m.theta_deg, n.theta_deg, true),
            ("d", m.d_mm, n.d_mm, false),
            (
                "beta",
                m.beta_deg.unwrap_or(0.0),
                n.beta_deg.unwrap_or(0.0),
                true,
            ),
        ];
        for (name, mv, nv, angle) in rows {
            let (diff, tol, unit) = if angle {
                (wrap(mv - nv).abs(), tol_deg, "°")
            } else {
                ((mv - nv).abs(), tol_mm, " mm")
            };
            if diff > tol || diff.is_nan() {
                return Some(format!(
                    "{name}{} is {mv:.3}{unit} in the model and {nv:.3}{unit} in the nominal",
                    i + 1
                ));
            }
        }
    }
    None
}

/// What a URDF cannot hold, named; each is also warned about on stderr.
fn dropped(model: &RobotFile) -> Vec<String> {
    let mut v: Vec<String> = model
        .effects
        .iter()
        .filter(|e| e.kind != crate::formats::robot_file::AXIS_TILT)
        .map(|e| {
            format!(
                "effect {} on joint {} (non-geometric: a URDF cannot hold it)",
                e.kind, e.joint
            )
        })
        .collect();
    v.extend(model.couplings.iter().map(|c| {
        format!(
            "coupling of joint {} to joint {} (ratio {}: a URDF joint reads its own angle only)",
            c.joint, c.from, c.ratio
        )
    }));
    v
}

/// Runs `kinecal export`.
pub fn run(args: &Args, json: bool) -> anyhow::Result<ExportReport> {
    let mut inputs = vec![("model", args.model.as_path())];
    if let Some(u) = &args.urdf {
        inputs.push(("URDF", u.as_path()));
    }
    if let Some(r) = &args.robot {
        inputs.push(("robot", r.as_path()));
    }
    refuse_overwriting_inputs("--out", &args.out, &inputs)?;
    for (flag, v) in [
        ("--tolerance-mm", args.tolerance_mm),
        ("--tolerance-deg", args.tolerance_deg),
    ] {
        crate::check_positive(flag, v, 1e6)?;
    }
    let model = RobotFile::load(&args.model)?;
    let check_match = |nominal: &RobotFile, source: &std::path::Path| -> anyhow::Result<()> {
        if let Some(what) = mismatch(&model, nominal, args.tolerance_mm, args.tolerance_deg) {
            crate::refuse!(
                "{}: not a calibration of {}: {what} (further apart than --tolerance-mm {} / \
                 --tolerance-deg {}): export the model into the file it was imported from",
                args.model.display(),
                source.display(),
                args.tolerance_mm,
                args.tolerance_deg
            );
        }
        Ok(())
    };
    let nominal_import = |path: &PathBuf| -> anyhow::Result<_> {
        let (text, urdf) = read_urdf(path)?;
        let (imp, _, tip, _) = import_chain(
            &urdf,
            path,
            args.base_link.as_deref(),
            args.tip_link.as_deref(),
            [0.0; 3],
        )?;
        if imp.file.joints.len() != model.joints.len() {
            crate::refuse!(
                "{}: the model has {} joints, the URDF chain {}: pass the --base-link/--tip-link \
                 given to import",
                args.model.display(),
                model.joints.len(),
                imp.file.joints.len()
            );
        }
        check_match(&imp.file, path)?;
        Ok((text, urdf, imp, tip))
    };
    match args.format {
        Format::Firmware => {
            let bytes = firmware_model::encode(&model)
                .map_err(|e| crate::refused(format!("{}: {e}", args.model.display())))?;
            write_atomic(&args.out, &bytes)
                .with_context(|| format!("cannot write {}", args.out.display()))?;
            Ok(ExportReport {
                format: "firmware".into(),
                out: path_text(&args.out),
                joints_rewritten: Vec::new(),
                dropped: Vec::new(),
                rows: 0,
                bytes: Some(bytes.len()),
            })
        }
        Format::Urdf => {
            let Some(path) = &args.urdf else {
                crate::refuse!("export --format urdf needs --urdf F.urdf (the file the model was imported from)");
            };
            let (text, urdf, imp, tip) = nominal_import(path)?;
            if urdf.links.iter().any(|l| l == splice::TOOL_LINK)
                || urdf.joints.iter().any(|j| j.name == splice::TOOL_JOINT)
            {
                crate::refuse!(
                    "{}: already has a link '{}' (written by an earlier export?): export into \
                     the original URDF",
                    path.display(),
                    splice::TOOL_LINK
                );
            }
            let dropped = dropped(&model);
            for d in &dropped {
                eprintln!("warning: not exported: {d}");
            }
            let out = splice::export(
                &text,
                &urdf,
                &imp,
                &model,
                &tip,
                &path.display().to_string(),
            )?;
            // What is written must read back as XML: a splice the file's text defeats is
            // refused rather than written.
            if let Err(e) = roxmltree::Document::parse(&out) {
                crate::refuse!(
                    "{}: the exported URDF would not be well-formed XML ({e}); nothing written: \
                     rewrite the chain joints' <origin> elements plainly (xyz=\"…\" rpy=\"…\") \
                     and export again",
                    path.display()
                );
            }
            write_atomic(&args.out, out.as_bytes())
                .with_context(|| format!("cannot write {}", args.out.display()))?;
            Ok(ExportReport {
                format: "urdf".into(),
                out: path_text(&args.out),
                joints_rewritten: imp.joint_names.clone(),
                dropped,
                rows: 0,
                bytes: None,
            })
        }
        Format::DhTable => {
            let nominal = match (&args.robot, &args.urdf) {
                (Some(r), _) => {
                    let f = RobotFile::load(r)?;
                    if f.joints.len() != model.joints.len() {
                        crate::refuse!(
                            "{}: {} joints, the model {}",
                            r.display(),
                            f.joints.len(),
                            model.joints.len()
                        );
                    }
                    check_match(&f, r)?;
                    Some(f)
                }
                (None, Some(u)) => Some(nominal_import(u)?.2.file),
                (None, None) => {
                    eprintln!("warning: no nominal given: pass --robot R.toml for the nominal and delta columns");
                    None
                }
            };
            let rows = dh_table::table(&model, nominal.as_ref());
            let as_json = json
                || args
                    .out
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("json"));
            let text = if as_json {
                dh_table::to_json(&rows)
            } else {
                dh_table::to_csv(&rows)
            };
            write_atomic(&args.out, text.as_bytes())
                .with_context(|| format!("cannot write {}", args.out.display()))?;
            Ok(ExportReport {
                format: "dh-table".into(),
                out: path_text(&args.out),
                joints_rewritten: Vec::new(),
                dropped: Vec::new(),
                rows: rows.len(),
                bytes: None,
            })
        }
    }
}
