//! Base frame and tool distances from single-joint sweeps (the circle-point method of Gao et
//! al. 2018 §2.2; the definitions are in [`kinecal::frames::circle_point`]): the application
//! behind `kinecal frames`.
//!
//! The measurement file has an extra column `sweep` naming the joint (1-based) turned on each
//! row; rows with an empty cell or 0 there are ignored. Joints 1 and 2 give the base pose,
//! the last two joints the tool's radial and axial distances from the flange axis.
//!
//! In memory, [`find`] on sweeps already read (the Python package calls it on arrays) returns
//! the report and the robot file with the base found; [`from_files`] reads the files, calls it
//! and writes that robot file.

mod axes_agree;
mod stray_rows;
mod tracker_slip;

use crate::formats::measurements::Dataset;
use crate::formats::origin::Origin;
use crate::formats::robot_file::{deg_exact, load_robot, BaseSpec, RobotFile};
use crate::formats::units::UnitArgs;
use crate::reports::frames::{CircleReport, FittedCircle, FramesReport, OnAxis, ToolReport};
use crate::reports::FrameReport;
use crate::simulation::sweeps::{SweepSet, SWEEP_COLUMN};
use crate::with_joints;
use crate::HostRobot;
use kinecal::frames::circle::Circle;
use kinecal::frames::circle_point::{
    base_from_sweeps, tool_from_sweeps, AxialMethod, FramesError, JointAxis, ToolEstimate,
};
use nalgebra::Vector3;
use std::path::Path;

/// A sweep shorter than this (degrees of joint travel) gets a warning.
pub const MIN_SPAN_DEG: f64 = 30.0;
/// Points farther than this (RMS, mm) from their circle: not a clean single-joint rotation.
pub const MAX_RMS_MM: f64 = 0.1;
/// Axis direction less certain than this (one standard deviation, degrees): too noisy or too
/// short for the 0.01° the base frame should reach.
pub const MAX_SD_NORMAL_DEG: f64 = 0.003;
/// Circle centre less certain than this (one standard deviation, mm).
pub const MAX_SD_CENTRE_MM: f64 = 0.03;

/// Finds the base frame and the tool distances from the sweep file `data` (in `units`) for
/// the robot file `robot` (its `[base]`, if any, is ignored); with `out`, writes the robot
/// file with `[base]` set to the pose found (never over `robot` or `data`). Warnings about
/// doubtful sweeps are in the report, not printed.
pub fn from_files(
    robot: &Path,
    data: &Path,
    units: &UnitArgs,
    out: Option<&Path>,
) -> anyhow::Result<FramesReport> {
    if let Some(out) = out {
        crate::output::atomic::refuse_overwriting_inputs(
            "--out",
            out,
            &[("robot", robot), ("sweep data", data)],
        )?;
    }
    let n = RobotFile::load(robot)?.joint_count();
    with_joints!(n, N => from_files_with_joints::<N>(robot, data, units, out))
}

fn from_files_with_joints<const N: usize>(
    robot_path: &Path,
    data_path: &Path,
    units: &UnitArgs,
    out: Option<&Path>,
) -> anyhow::Result<FramesReport> {
    let (file, robot): (RobotFile, HostRobot<N>) = load_robot::<N>(robot_path)?;
    let data = crate::formats::loading::load_sweeps(data_path, units, &robot)?;
    let mut found = find(&file, &robot, &data, &Origin::file(data_path))?;
    if let Some(out) = out {
        found.framed.save(out)?;
        found.report.out = Some(out.display().to_string());
    }
    Ok(found.report)
}

fn group<const N: usize>(origin: &Origin, data: &Dataset<N>) -> anyhow::Result<SweepSet<N>> {
    match SweepSet::from_dataset(data) {
        Ok(Some(s)) => Ok(s),
        Ok(None) => crate::refuse!(
            "{origin}:1:1: no `{SWEEP_COLUMN}` column (the joint swept on each row, 1 to {N})"
        ),
        Err(bad) => {
            let col = origin.column(SWEEP_COLUMN).unwrap_or(1);
            crate::refuse!(
                "{origin}:{}:{col}: `{SWEEP_COLUMN}` must name a joint 1 to {N}, got {}",
                bad.line,
                bad.value
            )
        }
    }
}

/// The refusal (exit 2) of sweeps the library could not use: every [`FramesError`] is about
/// the data, so the user sweeps again.
fn explain(e: FramesError, what: &str) -> anyhow::Error {
    let why = match e {
        FramesError::Circle(kinecal::frames::circle::CircleError::TooFewPoints) => {
            "too few points (at least 4 per sweep)".to_string()
        }
        FramesError::Circle(kinecal::frames::circle::CircleError::Degenerate) => {
            "the points lie on a line or coincide".to_string()
        }
        FramesError::Circle(kinecal::frames::circle::CircleError::NotFinite)
        | FramesError::NotFinite => "non-finite values".to_string(),
        FramesError::Shape => "inconsistent sweep data".to_string(),
        FramesError::NoRotation => "the swept joint's readings do not change".to_string(),
        FramesError::OtherJointMoved(j) => {
            format!("joint {} moved during the sweep (more than 0.057°)", j + 1)
        }
        FramesError::CoupledJointMoved(j) => {
            // Input refused (exit 2): the sweep is not a single rotation of the model.
            return crate::refused(format!(
                "{what}: joint {} is coupled to the swept joint ([[couplings]]), so its model angle turned too and the points are not on a circle; sweep again moving joint {}'s reading by -ratio x the swept joint's change so that its model angle stays fixed (as `kinecal simulate --sweeps` does)",
                j + 1,
                j + 1
            ));
        }
        FramesError::ParallelAxes => {
            "the axes are parallel, so the base height is undetermined".to_string()
        }
        FramesError::Coincident => "the axes coincide".to_string(),
    };
    crate::refused(format!("{what}: {why}; sweep again"))
}

/// The joint (1-based) that turned over the rows of `sweep` while the joint it names did not
/// (its readings span less than a degree: an encoder's jitter): the one whose readings span
/// the most, when that is more than a degree.
fn turned_instead<const N: usize>(
    sweep: &kinecal::frames::circle_point::Sweep<'_, f64, N>,
) -> Option<usize> {
    let span = |j: usize| {
        let (lo, hi) = sweep
            .q
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[j]), hi.max(q[j]))
            });
        (hi - lo).to_degrees()
    };
    let (k, most) = (0..N)
        .map(|j| (j, span(j)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (k != sweep.joint && span(sweep.joint) < 1.0 && most > 1.0).then_some(k + 1)
}

fn circle_report(
    joint: usize,
    c: &Circle<f64>,
    line_dir: Option<&Vector3<f64>>,
    span_deg: f64,
) -> CircleReport {
    let n = line_dir.copied().unwrap_or(c.normal);
    CircleReport::Fitted(FittedCircle {
        joint: joint + 1,
        points: c.points,
        radius_mm: c.radius,
        rms_mm: c.rms,
        span_deg,
        centre_mm: [c.centre.x, c.centre.y, c.centre.z],
        axis: [n.x, n.y, n.z],
        sd_centre_mm: c.sd_centre,
        sd_axis_deg: c.sd_normal.to_degrees(),
        sd_radius_mm: c.sd_radius,
    })
}

/// Warnings about one fitted sweep. The axis-direction and centre limits apply to the base
/// sweeps (joints 1 and 2), whose axes become the base frame; the tool only needs the wrist
/// axis's position to [`MAX_SD_CENTRE_MM`] × 2.
fn judge(joint: usize, a: &JointAxis<f64>, warnings: &mut Vec<String>) {
    let span = a.span.to_degrees();
    let c = &a.circle;
    let j = joint + 1;
    if span < MIN_SPAN_DEG {
        warnings.push(format!(
            "sweep of joint {j} covers only {span:.1}° (< {MIN_SPAN_DEG}°): too short to trust"
        ));
    }
    if c.rms > MAX_RMS_MM {
        warnings.push(format!(
            "sweep of joint {j}: points are {:.3} mm RMS off their circle (> {MAX_RMS_MM} mm): another joint moved, or the tracker is noisy",
            c.rms
        ));
    }
    let sdn = c.sd_normal.to_degrees();
    let sig = crate::output::numfmt::sig;
    if joint < 2 {
        // Base sweeps: both the axis direction and its position become the base frame.
        if sdn > MAX_SD_NORMAL_DEG || c.sd_centre > MAX_SD_CENTRE_MM {
            warnings.push(format!(
                "sweep of joint {j} is too noisy or too short to trust: axis ±{}°, centre ±{} mm (the base frame needs ≤ {}° and ≤ {} mm)",
                sig(sdn, 2),
                sig(c.sd_centre, 2),
                sig(MAX_SD_NORMAL_DEG, 1),
                sig(MAX_SD_CENTRE_MM, 1)
            ));
        }
    } else if c.sd_centre > 2.0 * MAX_SD_CENTRE_MM {
        // Wrist and flange sweeps: only the axis's position enters the tool distances, so
        // there is no limit on its direction.
        warnings.push(format!(
            "sweep of joint {j} is too noisy or too short to trust: centre ±{} mm (the tool distances need ≤ {} mm; the axis direction, ±{}°, does not enter them)",
            sig(c.sd_centre, 2),
            sig(2.0 * MAX_SD_CENTRE_MM, 1),
            sig(sdn, 2)
        ));
    }
}

/// What [`find`] found: the report (`out` unset) and the robot file with `[base]` set to the
/// pose found (what `--out` writes).
#[derive(Clone, Debug, PartialEq)]
pub struct Found {
    pub report: FramesReport,
    pub framed: RobotFile,
}

/// Finds the base frame and the tool distances from the sweeps `data` (in mm and degrees,
/// through the sweeps door of [`crate::formats::loading`]; named by `origin` in messages)
/// for the robot file `file` and its model `robot` (its base is ignored). Doubtful sweeps are
/// warnings in the report; sweeps the method cannot use are refused (exit 2).
pub fn find<const N: usize>(
    file: &RobotFile,
    robot: &HostRobot<N>,
    data: &Dataset<N>,
    origin: &Origin,
) -> anyhow::Result<Found> {
    let sweeps = group(origin, data)?;
    if let Some(why) = stray_rows::strays(robot, data, &origin.to_string()) {
        crate::refuse!("{why}");
    }

    let mut warnings = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    let mut circles = Vec::new();

    // Every sweep's circle, for the report (the flange sweep's once the tool is known: a point
    // on the flange axis does not move, and has no circle).
    for j in 0..N - 1 {
        if let Some(s) = sweeps.get(j) {
            if let Some(k) = turned_instead(&s) {
                crate::refuse!(
                    "{origin}: sweep of joint {}: its rows' `{SWEEP_COLUMN}` names joint {} but \
                     joint {k} turned on them: correct the {SWEEP_COLUMN} column",
                    j + 1,
                    j + 1
                );
            }
            let a = s
                .axis()
                .map_err(|e| explain(e, &format!("{origin}: sweep of joint {}", j + 1)))?;
            judge(j, &a, &mut warnings);
            circles.push(circle_report(
                j,
                &a.circle,
                Some(&a.line.direction),
                a.span.to_degrees(),
            ));
        }
    }

    let (Some(s1), Some(s2)) = (sweeps.get(0), sweeps.get(1)) else {
        crate::refuse!("{origin}: the base frame needs a sweep of joint 1 and one of joint 2 (column `{SWEEP_COLUMN}`)");
    };
    let base = base_from_sweeps(robot, &s1, &s2).map_err(|e| {
        explain(
            e,
            &format!("{origin}: base frame from the sweeps of joints 1 and 2"),
        )
    })?;
    let b = base.base;
    let mut placed = robot.clone();
    if placed.set_base(b).is_ok() {
        let stated_tool = !file.tool_unknown();
        let why = match axes_agree::compared(&placed, &sweeps) {
            Err(why) => Some(why),
            // Nothing further to compare: the points at the stated tool tell.
            Ok(0) if stated_tool => axes_agree::points_off(&placed, &sweeps),
            Ok(_) => None,
        };
        if let Some(why) = why {
            // Mirrored or scaled points contradict the file too, for another reason.
            let why = tracker_slip::slip(robot, &sweeps).unwrap_or(why);
            crate::refuse!("{origin}: {why}");
        }
    }
    let xyz = [b.o.x, b.o.y, b.o.z];
    let rpy = b.rpy().map(deg_exact);

    let tool: Option<ToolEstimate<f64>> = match sweeps.get(N - 2) {
        Some(w) => Some(
            tool_from_sweeps(robot, &w, sweeps.get(N - 1).as_ref()).map_err(|e| {
                explain(
                    e,
                    &format!(
                        "{origin}: tool distances from the sweeps of joints {} and {N}",
                        N - 1
                    ),
                )
            })?,
        ),
        None => {
            warnings.push(format!(
                "no sweep of joint {}: tool distances not measured",
                N - 1
            ));
            None
        }
    };
    let mut tool_report = None;
    if let Some(t) = &tool {
        if !t.radial_resolved && t.radial.is_some() {
            notes.push(format!(
                "sweep of joint {N} moves the point by no more than the noise: it is on the flange axis (radial {:.4} mm)",
                t.radial.unwrap_or(0.0)
            ));
        }
        if t.radial.is_none() {
            warnings.push(format!("no sweep of joint {N}: tool_radial_mm not measured and tool_axial_mm assumes the point is on the flange axis"));
        }
        if t.method == AxialMethod::WristRadius && t.radial.is_some() {
            warnings.push(format!(
                "sweeps of joints {} and {N} were not taken with the same arm pose: tool_axial_mm assumes the point is on the flange axis",
                N - 1
            ));
        }
        let method = match t.method {
            AxialMethod::FlangeAxis => "flange-axis",
            AxialMethod::CentreToWristAxis => "centre-to-wrist-axis",
            AxialMethod::WristRadius => "wrist-radius",
        };
        if let Some(f) = &t.flange {
            judge(N - 1, f, &mut warnings);
            circles.push(circle_report(
                N - 1,
                &f.circle,
                Some(&f.line.direction),
                f.span.to_degrees(),
            ));
        } else if let (Some(s), Some(r)) = (sweeps.get(N - 1), t.radial) {
            circles.push(CircleReport::OnAxis(OnAxis {
                joint: N,
                points: s.points.len(),
                radius_mm: r,
                rms_mm: None,
                resolved: false,
            }));
        }
        let last = robot.joints()[N - 1];
        tool_report = Some(ToolReport {
            method: method.to_string(),
            radial_resolved: t.radial_resolved,
            nominal_radial_mm: robot.tool().x.hypot(robot.tool().y),
            nominal_axial_mm: last.d + robot.tool().z,
        });
    }

    let mut framed = file.clone();
    framed.base = Some(BaseSpec {
        xyz_mm: xyz,
        rpy_deg: rpy,
    });

    let report = FramesReport {
        robot: file.name.clone(),
        base: FrameReport {
            xyz_mm: xyz,
            rpy_deg: rpy,
        },
        tool_radial_mm: tool.as_ref().and_then(|t| t.radial),
        tool_axial_mm: tool.as_ref().map(|t| t.axial),
        tool: tool_report,
        circles,
        axis_distance_mm: base.common_normal.distance,
        // The nominal model's common normal of axes 1 and 2 (row 2's a), for comparison.
        nominal_axis_distance_mm: robot.joints()[1].a.abs(),
        axis_angle_deg: base
            .axis1
            .line
            .direction
            .angle(&base.axis2.line.direction)
            .to_degrees(),
        warnings,
        notes,
        out: None,
    };
    Ok(Found { report, framed })
}
