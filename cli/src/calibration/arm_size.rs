//! The size of a fitted arm against the robot file's: no arm's links change length by a fifth,
//! so a fit that stretched or shrank them that far was fitted to points in another length unit
//! than the one stated (metres read as millimetres "calibrate" a UR10 to 0.0005 mm, its links
//! a thousandth as long) or to another robot's data. `identify` and `diagnose` report such a
//! fit as no calibration (exit 3) instead of reporting its tiny error as one; the unit stated
//! is not replaced (a unit given is never second-guessed).
//!
//! Nor does a calibration turn a joint's angle by more than a few degrees or move a link by
//! more than a few millimetres ([`moved`]: 10° and 100 mm at most, the limits by which `validate`
//! and `report` tell a model of this robot from another one). A fit that did was fitted to
//! data that do not follow the robot file's conventions: a joint whose sign or zero differs
//! in the data, joint columns in another order, or a wrong angle in the file. The geometry
//! can imitate such a mistake closely (a negated wrist joint fits to 0.7 mm with the wrist's
//! offsets turned by 180°), so the fit's small error is no evidence against it.

use crate::output::numfmt::sig;
use kinecal::Robot;

/// The largest relative change of the links' summed lengths that a calibration can make.
pub const MOST_CHANGE: f64 = 0.2;

/// Σ (|a| + |d|) over the joints' rows (mm): the arm's size without base and tool.
pub fn link_lengths<const N: usize, V: kinecal::ValueStorage>(robot: &Robot<f64, N, V>) -> f64 {
    robot.joints().iter().map(|j| j.a.abs() + j.d.abs()).sum()
}

/// The largest change of a joint's `a` or `d` (mm) a calibration makes.
pub const MOST_LENGTH_CHANGE_MM: f64 = 100.0;
/// The largest change of a joint's `α` or `θ` (degrees) a calibration makes.
pub const MOST_ANGLE_CHANGE_DEG: f64 = 10.0;

/// The first joint parameter of `fitted` that differs from `nominal`'s beyond
/// [`MOST_LENGTH_CHANGE_MM`] or [`MOST_ANGLE_CHANGE_DEG`] (angles compared modulo 360°), as
/// "theta4 differs by 178.9°"; `None` when every one is within them. The last joint's `d` and
/// `θ` are not compared: with the tool unknown they take up the reflector's offset along and
/// about the flange axis (a tool started on the axis moves `d6` by the tool's length), which
/// no convention limits.
pub fn moved<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
) -> Option<String> {
    let wrap = |a: f64| {
        (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    };
    for (j, (a, b)) in nominal.joints().iter().zip(fitted.joints()).enumerate() {
        let last = j + 1 == N;
        for (name, d) in [("a", b.a - a.a), ("d", b.d - a.d)] {
            if name == "d" && last {
                continue;
            }
            if d.is_nan() || d.abs() > MOST_LENGTH_CHANGE_MM {
                return Some(format!("{name}{} differs by {} mm", j + 1, sig(d, 4)));
            }
        }
        for (name, d) in [("alpha", b.alpha - a.alpha), ("theta", b.theta - a.theta)] {
            if name == "theta" && last {
                continue;
            }
            let d = wrap(d).to_degrees();
            if d.is_nan() || d.abs() > MOST_ANGLE_CHANGE_DEG {
                return Some(format!("{name}{} differs by {}°", j + 1, sig(d, 4)));
            }
        }
    }
    None
}

/// Why `fitted` cannot be a calibration of `nominal`, or `None`: the reason, as the rest of a
/// sentence that starts "the fit". The arm's size first ([`MOST_CHANGE`]: a unit), then one
/// joint's parameters ([`moved`]: a convention).
pub fn resized<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
) -> Option<String> {
    let (was, is) = (link_lengths(nominal), link_lengths(fitted));
    let ratio = is / was;
    if was <= 0.0 || !is.is_finite() || (ratio - 1.0).abs() <= MOST_CHANGE {
        return moved(nominal, fitted).map(|what| {
            format!(
                "moved the geometry beyond what a calibration moves ({what}; at most \
                 {MOST_ANGLE_CHANGE_DEG}° and {MOST_LENGTH_CHANGE_MM} mm): the data do not \
                 follow the robot file's conventions; check each joint's sign and zero in the \
                 data, the joint columns' order (--map), coupled joints ([[couplings]], see \
                 `kinecal check`), the base and the robot file's angles"
            )
        });
    }
    Some(format!(
        "made the arm's links {} times as long as the robot file says (Σ|a|+|d| {} → {} mm): no \
         arm changes size, so the points are in another length unit than the one stated (give \
         --length-unit, or length in the --map file), the data do not follow the robot file's \
         conventions (axes swapped or mirrored, joint columns in another order, a joint's sign) \
         or the robot file describes another robot",
        sig(ratio, 2),
        sig(was, 4),
        sig(is, 4)
    ))
}

/// A stated tool point shorter than this (mm) that the data put where its coordinates read as
/// metres would be ([`TOOL_SLIP_MARGIN`]) was written in metres.
pub const TOOL_METRES_MM: f64 = 2.0;
/// A coordinate of the stated tool point at least this far from the flange (mm) whose fitted
/// value is its negative ([`TOOL_SLIP_MARGIN`]) had its sign flipped.
pub const TOOL_SIGN_MM: f64 = 10.0;
/// How close (relative) the fitted tool point comes to the slip's reading of the stated one:
/// the real UR10 reflector sits 93 mm from the flange where its file says 109 mm (15 %).
pub const TOOL_SLIP_MARGIN: f64 = 0.3;

/// Whether a stated tool point is only a start: one at the flange's origin (as many robot files
/// without a measured tool state it), which a fit moves by the whole reflector offset (the last
/// joint's `d` takes up its part along the flange axis), not a measured offset to hold it to.
pub fn tool_is_a_start(stated: &nalgebra::Vector3<f64>) -> bool {
    stated.norm() == 0.0
}

/// Why a tool point `fitted` settled on cannot be the one `nominal` states, written right:
/// the rest of a sentence that starts "the fit", or `None`. Only for tool points the robot
/// file states (an unknown tool is started from the data); `names` are the `[[tools]]` names
/// (empty for one `[tool]`). Each point is compared in the nominal flange frame, with the last
/// joint's `d` and `θ` (which take up the tool's offset along and about the flange axis,
/// [`moved`]) moved back onto it. Two slips are named, each only when the fitted point lies
/// where the slip puts it, within [`TOOL_SLIP_MARGIN`]: a point under [`TOOL_METRES_MM`] that
/// lies as far out as its coordinates read in metres (`[0, 0, 0.109]` fitted at 93 mm), and a
/// coordinate of at least [`TOOL_SIGN_MM`] fitted at its negative (z; or x or y, where joint
/// N's zero turned by 180° in the data looks the same, and is named too); then any point
/// other than the flange's origin (a start) fitted more than [`MOST_LENGTH_CHANGE_MM`] from the
/// stated one, once a reversed flange axis ([`axis_reversed`]) is ruled out. The geometry
/// imitates either exactly (UR10's real data fit to the same 0.47 mm with the tool in metres,
/// `d6` 93 mm longer), so the fit's error is no evidence against them.
pub fn tool_slip<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
    names: &[String],
) -> Option<String> {
    let fmt = point_text;
    flange_points(nominal, fitted)
        .into_iter()
        .enumerate()
        .find_map(|(k, (stated, found))| {
            let was = stated.norm();
            if !(was.is_finite() && found.norm().is_finite()) {
                return None;
            }
            let (entry, unknown) = match names.get(k) {
                Some(n) => (format!("[[tools]] {n:?}'s xyz_mm"), ""),
                None => (
                    "[tool] xyz_mm".to_string(),
                    " (or write xyz_mm = \"unknown\" to have it fitted)",
                ),
            };
            let as_metres = stated * 1000.0;
            if was > 0.0
                && was < TOOL_METRES_MM
                && (found - as_metres).norm() <= TOOL_SLIP_MARGIN * as_metres.norm()
            {
                return Some(format!(
                    "put the tool point {} mm from the flange ({} mm), where the robot file's \
                 {entry} = {} puts it if read in metres: it is written in metres; give it in \
                 millimetres{unknown}",
                    sig(found.norm(), 4),
                    fmt(&found),
                    fmt(&stated)
                ));
            }
            let flipped: Vec<usize> = (0..3)
                .filter(|&i| {
                    stated[i].abs() >= TOOL_SIGN_MM
                        && (found[i] + stated[i]).abs() <= TOOL_SLIP_MARGIN * stated[i].abs()
                })
                .collect();
            let axes: Vec<&str> = flipped.iter().map(|&i| ["x", "y", "z"][i]).collect();
            if !flipped.is_empty() {
                let zero = if flipped.iter().any(|&i| i < 2) {
                    format!(", or joint {N}'s zero in the data is 180° from the robot file's")
                } else {
                    String::new()
                };
                return Some(format!(
                    "put the tool point at {} mm in the flange frame, the robot file's {entry} = \
                     {} with the other sign in {}: that sign is flipped in the robot file{zero}; \
                     correct it{unknown}",
                    fmt(&found),
                    fmt(&stated),
                    axes.join(", ")
                ));
            }
            // The axis reversed in the data ([`axis_reversed`]), after a flipped sign of z.
            let last_d = nominal.joints().last().map_or(0.0, |j| j.d);
            if let Some(why) = reversed::<N>(last_d + stated.z, last_d + found.z) {
                return Some(why);
            }
            let off = (found - stated).norm();
            (!tool_is_a_start(&stated) && off > MOST_LENGTH_CHANGE_MM).then(|| {
                format!(
                    "put the tool point {} mm from where the robot file's {entry} = {} puts it \
                     (at {} mm in the flange frame; a stated tool moves {MOST_LENGTH_CHANGE_MM} \
                     mm at most): the data do not follow the robot file's conventions (a \
                     joint's zero or sign) or were measured with another tool; check the data's \
                     joints and the tool point{unknown}",
                    sig(off, 4),
                    fmt(&stated),
                    fmt(&found)
                )
            })
        })
}

/// Why the tool points `fitted` settled on lie on the other side of the last joint's origin
/// than `nominal` puts them (`d_N + z` of the other sign, at least [`TOOL_SIGN_MM`] either
/// way), or `None`: the flange axis points the other way in the data, a joint before it turned
/// by 180° (UR10 rows with q5 + 180° fit to 0.6 mm with `d6` at −310 mm, or at −185 mm with the
/// tool stated at the flange). No reflector sits behind the wrist, so this holds for tools
/// stated, started at the flange or unknown (`tool_stated` false: the robot file's point is
/// taken at the flange, since the start `nominal` holds came from the same data).
pub fn axis_reversed<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
    tool_stated: bool,
) -> Option<String> {
    let last_d = nominal.joints().last()?.d;
    flange_points(nominal, fitted)
        .into_iter()
        .find_map(|(stated, found)| {
            let stated_z = if tool_stated { stated.z } else { 0.0 };
            reversed::<N>(last_d + stated_z, last_d + found.z)
        })
}

/// [`axis_reversed`] for one point: `along` and `fitted_along` its `d_N + z` (mm) as the file
/// puts it and as the fit does.
fn reversed<const N: usize>(along: f64, fitted_along: f64) -> Option<String> {
    (along.abs() >= TOOL_SIGN_MM
        && fitted_along.abs() >= TOOL_SIGN_MM
        && along.signum() != fitted_along.signum())
    .then(|| {
        format!(
            "put the tool point {} mm along joint {N}'s axis from its origin, on the other side \
             of it than the robot file's {} mm (d{N} + the tool's z): the axis points the other \
             way in the data, so a joint before it is turned by 180° (its zero in the data \
             differs from the robot file's by 180°, as a wrist joint's can) or its sign is \
             flipped; check the joints' zeros and signs in the data (--map)",
            sig(fitted_along, 4),
            sig(along, 4)
        )
    })
}

/// A point as `[x, y, z]` with four significant digits (mm).
pub fn point_text(v: &nalgebra::Vector3<f64>) -> String {
    format!("[{}, {}, {}]", sig(v.x, 4), sig(v.y, 4), sig(v.z, 4))
}

/// Each tool point as `nominal` states it and as `fitted` puts it, both in the nominal flange
/// frame: the fitted point is moved back by the last joint's change of `d` and `θ` (which take
/// up a tool's offset along and about the flange axis, [`moved`]). Indexed as the tool points;
/// a point may not be finite.
pub fn flange_points<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
) -> Vec<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)> {
    let (Some(a), Some(b)) = (nominal.joints().last(), fitted.joints().last()) else {
        return Vec::new();
    };
    let (s, c) = (b.theta - a.theta).sin_cos();
    let points = nominal.tool_point_count().min(fitted.tool_point_count());
    (0..points)
        .map_while(|k| {
            let (stated, t) = (*nominal.tool_point(k)?, fitted.tool_point(k)?);
            let found =
                nalgebra::Vector3::new(c * t.x - s * t.y, s * t.x + c * t.y, t.z + (b.d - a.d));
            Some((stated, found))
        })
        .collect()
}
