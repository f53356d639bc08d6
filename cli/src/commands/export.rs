//! `kinecal export`: a calibrated model back into the robot's URDF (origins of the chain
//! joints rewritten, the tool point appended), or as a table of nominal and calibrated MDH
//! parameters (`--format dh-table`), or as the binary model firmware loads (`--format
//! firmware`). docs/formats.md, "URDF export", "DH table", "Binary model (.kcm)".

use super::import::{import_chain, read_urdf};
use crate::application::export;
use crate::formats::robot_file::RobotFile;
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
    /// The nominal robot file: a model further from it than a calibration moves is refused
    /// (dh-table, firmware); dh-table also writes its nominal and delta columns.
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
    #[arg(long, default_value_t = crate::application::export::MATCH_TOLERANCE_MM)]
    pub tolerance_mm: f64,
    /// The same for angles, degrees.
    #[arg(long, default_value_t = crate::application::export::MATCH_TOLERANCE_DEG)]
    pub tolerance_deg: f64,
}

/// Runs `kinecal export`: reads the model (and the URDF or nominal robot file), calls
/// [`crate::application::export`] and writes its output.
pub fn run(args: &Args, json: bool) -> anyhow::Result<ExportReport> {
    let mut inputs = vec![("model", args.model.as_path())];
    inputs.extend(args.urdf.as_deref().map(|u| ("URDF", u)));
    inputs.extend(args.robot.as_deref().map(|r| ("robot", r)));
    refuse_overwriting_inputs("--out", &args.out, &inputs)?;
    let tol = (args.tolerance_mm, args.tolerance_deg);
    crate::check_positive("--tolerance-mm", tol.0, 1e6)?;
    crate::check_positive("--tolerance-deg", tol.1, 1e6)?;
    let model = RobotFile::load(&args.model)?;
    let model_origin = args.model.display().to_string();
    let flange = "it would be written with the tool at the flange";
    export::refuse_unknown_tool(&model, &model_origin, ("export", flange))?;
    let nominal_import = |path: &PathBuf| -> anyhow::Result<_> {
        let (text, urdf) = read_urdf(path)?;
        let (base, tip) = (args.base_link.as_deref(), args.tip_link.as_deref());
        let (imp, _, tip, _) = import_chain(&urdf, path, base, tip, [0.0; 3])?;
        export::check_match(&model, &model_origin, &imp.file, &path_text(path), tol)?;
        Ok((text, urdf, imp, tip))
    };
    let out = path_text(&args.out);
    let mut report = ExportReport {
        out,
        ..ExportReport::default()
    };
    // The nominal robot file of --robot, the model refused when further from it than a
    // calibration moves.
    let nominal_of = |r: &std::path::Path| -> anyhow::Result<RobotFile> {
        let f = RobotFile::load(r)?;
        export::check_match(&model, &model_origin, &f, &path_text(r), tol)?;
        Ok(f)
    };
    let bytes = match args.format {
        Format::Firmware => {
            // The blob goes to the controller: checked against --robot as the DH table is.
            if let Some(r) = &args.robot {
                nominal_of(r)?;
            }
            for w in export::firmware_warnings(&model, &model_origin) {
                eprintln!("warning: {w}");
            }
            let bytes = export::firmware(&model, &model_origin)?;
            (report.format, report.bytes) = ("firmware".into(), Some(bytes.len()));
            bytes
        }
        Format::Urdf => {
            let Some(path) = &args.urdf else {
                crate::refuse!("export --format urdf needs --urdf F.urdf (the file the model was imported from)");
            };
            let (text, urdf, imp, tip) = nominal_import(path)?;
            let dropped = export::dropped(&model);
            for d in &dropped {
                eprintln!("warning: not exported: {d}");
            }
            let out = export::urdf((&text, &urdf), &imp, &model, &tip, &path_text(path))?;
            report.format = "urdf".into();
            (report.joints_rewritten, report.dropped) = (imp.joint_names.clone(), dropped);
            out.into_bytes()
        }
        Format::DhTable => {
            let nominal = match (&args.robot, &args.urdf) {
                (Some(r), _) => Some(nominal_of(r)?),
                (None, Some(u)) => Some(nominal_import(u)?.2.file),
                (None, None) => {
                    eprintln!("warning: no nominal given: pass --robot R.toml for the nominal and delta columns");
                    None
                }
            };
            let as_json = json
                || args
                    .out
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("json"));
            let (text, rows) = export::dh_table(&model, nominal.as_ref(), as_json);
            let dropped = export::dropped_from_dh_table(&model, nominal.as_ref());
            for d in &dropped {
                eprintln!("warning: not exported: {d}");
            }
            (report.format, report.rows, report.dropped) = ("dh-table".into(), rows, dropped);
            text.into_bytes()
        }
    };
    write_atomic(&args.out, &bytes)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    Ok(report)
}
