//! `kinecal export` on files already read: the checks that a model belongs to the nominal it is
//! exported against, and the three outputs (the URDF with calibrated joint origins, the DH
//! table, the firmware's binary model) as bytes. The command module reads the files, calls
//! these and writes what they return (docs/formats.md, "URDF export", "DH table", "Binary
//! model (.kcm)").

use crate::application::leaving_out;
use crate::formats::robot_file::{CouplingSpec, RobotFile};
use crate::formats::urdf::mdh::Imported;
use crate::formats::urdf::parse::Urdf;
use crate::formats::urdf::splice;
use crate::formats::{dh_table, firmware_model};

/// How far (mm) a model's row may lie from the nominal's for `export` and `compensate
/// --cartesian` to take it for a calibration of it (a manufacturing tolerance, as `identify`'s
/// suspicious changes).
pub const MATCH_TOLERANCE_MM: f64 = 20.0;
/// The same for angles (degrees).
pub const MATCH_TOLERANCE_DEG: f64 = 2.0;

/// Refuses (exit 2) a model whose tool point is `"unknown"`: that is a robot file to
/// calibrate from. `command` (`export`, `compensate`) would treat the flange as the tool:
/// `consequence` says what it would do.
pub fn refuse_unknown_tool(
    model: &RobotFile,
    model_origin: &str,
    (command, consequence): (&str, &str),
) -> anyhow::Result<()> {
    if model.tool_unknown() {
        crate::refuse!(
            "{model_origin}: its [tool] xyz_mm is \"unknown\", so it is a robot file to \
             calibrate from, not a calibrated model ({consequence}): {command} the model \
             identify wrote with --out, whose tool is the one found"
        );
    }
    Ok(())
}

/// Refuses `model` (named `model_origin`) when its joints are not as many as `nominal`'s (named
/// `source`), or when a row value lies further than the tolerances (mm, degrees) from
/// `nominal`'s: a calibration moves rows by millimetres and tenths of a degree, so a larger
/// difference means the model was made for another robot (or another MDH convention).
pub fn check_match(
    model: &RobotFile,
    model_origin: &str,
    nominal: &RobotFile,
    source: &str,
    (tol_mm, tol_deg): (f64, f64),
) -> anyhow::Result<()> {
    let (m, n) = (model.joints.len(), nominal.joints.len());
    if m != n {
        crate::refuse!(
            "{model_origin}: the model has {m} joints, {source} {n}: give the robot file the \
             model was calibrated from (for a URDF, the --base-link/--tip-link given to import)"
        );
    }
    if let Some(what) = mismatch(model, nominal, tol_mm, tol_deg) {
        crate::refuse!(
            "{model_origin}: not a calibration of {source}: {what} (further apart than \
             --tolerance-mm {tol_mm} / --tolerance-deg {tol_deg}): give the robot file (or the \
             URDF) the model was calibrated from, or a model identify or diagnose wrote"
        );
    }
    Ok(())
}

/// The first row value of `model` further than the tolerances from `nominal`, or the first
/// coupling they do not share, described.
pub fn mismatch(
    model: &RobotFile,
    nominal: &RobotFile,
    tol_mm: f64,
    tol_deg: f64,
) -> Option<String> {
    let wrap = |d: f64| (d + 180.0).rem_euclid(360.0) - 180.0;
    // With the tool unknown, the last joint's d and θ take up the reflector's offset along and
    // about the flange axis (crate::calibration::arm_size::moved): not compared.
    let last = nominal.joints.len().saturating_sub(1);
    // A tool stated at the flange's origin is a start as well (identify moves `d_N` by the
    // reflector's offset from it).
    let stated = nalgebra::Vector3::from(nominal.tool.xyz_mm);
    let free_end = nominal.tool_unknown() || crate::calibration::arm_size::tool_is_a_start(&stated);
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
            if free_end && i == last && (name == "d" || name == "theta") {
                continue;
            }
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
    coupling_mismatch(model, nominal)
}

/// The first `[[couplings]]` entry that `model` and `nominal` do not share, described.
/// Calibration never changes a coupling (its ratio is not a parameter), and one joint read
/// against another moves the tool by decimetres: a model without the nominal's coupling (or with
/// one it lacks) was calibrated from another robot file.
fn coupling_mismatch(model: &RobotFile, nominal: &RobotFile) -> Option<String> {
    let same = |a: &CouplingSpec, b: &CouplingSpec| {
        a.joint == b.joint
            && a.from == b.from
            && (a.ratio - b.ratio).abs() <= 1e-9 * a.ratio.abs().max(b.ratio.abs()).max(1.0)
    };
    let describe = |c: &CouplingSpec| {
        format!(
            "joint {} read against joint {} with ratio {}",
            c.joint, c.from, c.ratio
        )
    };
    if let Some(c) = nominal
        .couplings
        .iter()
        .find(|c| !model.couplings.iter().any(|m| same(m, c)))
    {
        return Some(format!(
            "the nominal couples {} and the model does not",
            describe(c)
        ));
    }
    model
        .couplings
        .iter()
        .find(|c| !nominal.couplings.iter().any(|n| same(n, c)))
        .map(|c| format!("the model couples {} and the nominal does not", describe(c)))
}

/// What a URDF cannot hold of `model`, named (effects other than axis tilts, couplings).
pub fn dropped(model: &RobotFile) -> Vec<String> {
    dropped_from(model, "a URDF", "a URDF joint reads its own angle only")
}

/// What a DH table cannot hold of `model`, named: effects other than axis tilts, couplings, a
/// tool orientation other than `nominal`'s (a calibrated one) and further reflectors (it holds
/// the geometric rows, the base and the tool point).
pub fn dropped_from_dh_table(model: &RobotFile, nominal: Option<&RobotFile>) -> Vec<String> {
    let mut v = dropped_from(model, "a DH table", "the table has no column for it");
    let nominal_rpy = nominal.and_then(|n| n.tool.rpy_deg).unwrap_or([0.0; 3]);
    if let Some(rpy) = model.tool.rpy_deg.filter(|r| *r != nominal_rpy) {
        v.push(format!(
            "tool orientation rpy_deg [{:.4}, {:.4}, {:.4}] (the table holds the tool point only)",
            rpy[0], rpy[1], rpy[2]
        ));
    }
    if let [first, others @ ..] = model.tools.as_slice() {
        if !others.is_empty() {
            let names: Vec<&str> = others.iter().map(|t| t.name.as_str()).collect();
            v.push(format!(
                "the [[tools]] reflectors {} (the table holds one tool point, {}'s)",
                names.join(", "),
                first.name
            ));
        }
    }
    v
}

/// The effects (but axis tilts) and couplings of `model`, each named with why `holder` (with
/// `coupling_why` for couplings) cannot hold it and how far the tool point moves without it
/// ([`leaving_out`]); with more than one, a last line for all of them together.
fn dropped_from(model: &RobotFile, holder: &str, coupling_why: &str) -> Vec<String> {
    let is_dropped = |i: usize| model.effects[i].kind != crate::formats::robot_file::AXIS_TILT;
    let cost = |effect: Option<usize>, coupling: Option<usize>| {
        let shift = leaving_out::shift(model, |i| Some(i) != effect, |i| Some(i) != coupling);
        shift.map_or(String::new(), |s| format!("; {}", s.sentence()))
    };
    let mut v: Vec<String> = (0..model.effects.len())
        .filter(|&i| is_dropped(i))
        .map(|i| {
            let e = &model.effects[i];
            // Thermal expansion acts on no joint (joint 0).
            let on = match e.joint {
                0 => String::new(),
                j => format!(" on joint {j}"),
            };
            format!(
                "effect {}{on} (non-geometric: {holder} cannot hold it{})",
                e.kind,
                cost(Some(i), None)
            )
        })
        .collect();
    v.extend(model.couplings.iter().enumerate().map(|(i, c)| {
        format!(
            "coupling of joint {} to joint {} (ratio {}: {coupling_why}{})",
            c.joint,
            c.from,
            c.ratio,
            cost(None, Some(i))
        )
    }));
    if v.len() > 1 {
        let all = leaving_out::shift(model, |i| !is_dropped(i), |_| false);
        if let Some(s) = all {
            v.push(format!(
                "all of the above together ({})",
                s.sentence().replacen("without it", "without them", 1)
            ));
        }
    }
    v
}

/// The URDF `text` (parsed: `urdf`, named `origin`; its chain imported as `imported`, ending at
/// `tip`) with the chain's joint origins calibrated and the tool frame added. Refuses a URDF
/// that already has the tool link (an earlier export) and a result that is not well-formed XML.
pub fn urdf(
    (text, urdf): (&str, &Urdf),
    imported: &Imported,
    model: &RobotFile,
    tip: &str,
    origin: &str,
) -> anyhow::Result<String> {
    if urdf.links.iter().any(|l| l == splice::TOOL_LINK)
        || urdf.joints.iter().any(|j| j.name == splice::TOOL_JOINT)
    {
        crate::refuse!(
            "{origin}: already has a link '{}' (written by an earlier export?): export into \
             the original URDF",
            splice::TOOL_LINK
        );
    }
    let out = splice::export(text, urdf, imported, model, tip, origin)?;
    // What is written must read back as XML: a splice the file's text defeats is refused
    // rather than written.
    if let Err(e) = roxmltree::Document::parse(&out) {
        crate::refuse!(
            "{origin}: the exported URDF would not be well-formed XML ({e}); nothing written: \
             rewrite the chain joints' <origin> elements plainly (xyz=\"…\" rpy=\"…\") and \
             export again"
        );
    }
    Ok(out)
}

/// The DH table of `model` against `nominal` (nominal and delta columns when given), as JSON
/// or CSV, and its row count.
pub fn dh_table(model: &RobotFile, nominal: Option<&RobotFile>, as_json: bool) -> (String, usize) {
    let rows = dh_table::table(model, nominal);
    let text = if as_json {
        dh_table::to_json(&rows)
    } else {
        dh_table::to_csv(&rows)
    };
    (text, rows.len())
}

/// The C ABI's robots (`kc_robot_load`): 6 or 7 joints.
pub const C_ABI_JOINTS: [usize; 2] = [6, 7];
/// The effect values a C ABI robot holds (`KC_MAX_EFFECT_VALUES` of include/kinecal_types.h).
pub const C_ABI_EFFECT_VALUES: usize = 1024;

/// The warnings of a firmware export: a model the C ABI cannot load (another joint count, or
/// more effect values than it holds: its `kc_robot_load` refuses it; a Rust firmware decodes it
/// with room of its own), and [`warm_reference`].
pub fn firmware_warnings(model: &RobotFile, origin: &str) -> Vec<String> {
    let n = model.joint_count();
    let joints = (!C_ABI_JOINTS.contains(&n)).then(|| {
        format!(
            "{origin} has {n} joints: the C ABI's kc_robot_load holds 6 or 7 and refuses this \
             blob (a Rust firmware decodes it with kinecal::io::model_blob::decode for a {n}-joint robot)"
        )
    });
    let values: usize = model.effects.iter().map(|e| e.values.len()).sum();
    let room = (values > C_ABI_EFFECT_VALUES).then(|| {
        format!(
            "{origin} has {values} effect values: the C ABI's kc_robot_load holds \
             {C_ABI_EFFECT_VALUES} and refuses this blob (coarser joint tables fit it; a Rust \
             firmware decodes it with room of its own)"
        )
    });
    joints
        .into_iter()
        .chain(room)
        .chain(warm_reference(model, origin))
        .collect()
}

/// The warning for a model whose thermal expansion is referred to a temperature no room has
/// (above [`crate::formats::loading::WARM_C`]): the firmware feeds the expansion the °C of its
/// sensor, so such a model was fitted to a `temp_c` column in °F and expands wrongly there.
pub fn warm_reference(model: &RobotFile, origin: &str) -> Option<String> {
    let t = model
        .effects
        .iter()
        .filter_map(|e| e.reference_c)
        .find(|t| *t > crate::formats::loading::WARM_C)?;
    Some(format!(
        "{origin}: the thermal expansion's reference_c is {t} °C: the controller feeds its \
         sensor's °C; a model fitted to a temp_c column in °F expands wrongly there: convert the \
         column, (F − 32) × 5/9, and calibrate again"
    ))
}

/// The binary model firmware loads (`kc_robot_load`); `origin` names the model in a refusal.
pub fn firmware(model: &RobotFile, origin: &str) -> anyhow::Result<Vec<u8>> {
    firmware_model::encode(model).map_err(|e| crate::refused(format!("{origin}: {e}")))
}
