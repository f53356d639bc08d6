//! The robot file's values checked: finite, plausible, in millimetres, joints and effects
//! that exist ([`RobotFile::validate`]).

use super::*;

/// A robot file whose every length is below this (mm) is refused as one written in metres: the
/// smallest arms calibrated with a tracker have links of tens of millimetres.
pub const METRES_SUSPECT_MM: f64 = 10.0;

fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// Why a length of the file (mm) is implausible, if it is: beyond ±[`crate::MAX_LENGTH_MM`]
/// no robot cell is (a file in micrometres or a typo).
fn implausible_length(key: &str, v: f64) -> Option<String> {
    (v.abs() > crate::MAX_LENGTH_MM).then(|| {
        format!(
            "{key} = {} is implausible: lengths are millimetres within ±{} (100 m)",
            crate::number_text(v),
            crate::MAX_LENGTH_MM
        )
    })
}

/// Why an angle of the file (degrees) is implausible, if it is: beyond ±`max`.
fn implausible_angle(key: &str, v: f64, max: f64) -> Option<String> {
    (v.abs() > max).then(|| {
        format!(
            "{key} = {} is implausible: angles are degrees within ±{max}",
            crate::number_text(v)
        )
    })
}

impl RobotFile {
    /// Why the file's lengths read as metres, if they do: the largest link length, offset and
    /// tool coordinate below [`METRES_SUSPECT_MM`] (a 0.612 that should be 612 mm) is no arm
    /// measured with a tracker, and fitting it to millimetre data is no calibration (the units
    /// door of the measurement files, for robot files).
    fn lengths_in_metres(&self) -> Option<String> {
        let mut largest: Option<(String, f64)> = None;
        let mut see = |key: String, v: f64| {
            if v.is_finite() && largest.as_ref().is_none_or(|(_, m)| v.abs() > *m) {
                largest = Some((key, v.abs()));
            }
        };
        for (i, j) in self.joints.iter().enumerate() {
            see(format!("a{}", i + 1), j.a_mm);
            see(format!("d{}", i + 1), j.d_mm);
        }
        if !self.tool.unknown {
            for (a, v) in ["x", "y", "z"].iter().zip(self.tool.xyz_mm) {
                see(format!("tool {a}"), v);
            }
        }
        for t in &self.tools {
            for (a, v) in ["x", "y", "z"].iter().zip(t.xyz_mm) {
                see(format!("{} {a}", t.name), v);
            }
        }
        let (key, v) = largest?;
        (v > 0.0 && v < METRES_SUSPECT_MM).then(|| {
            format!(
                "every length is below {METRES_SUSPECT_MM} mm (the largest, {key}, is {}): robot files are in millimetres and this one reads as metres; multiply its lengths (a_mm, d_mm, xyz_mm) by 1000",
                crate::number_text(v)
            )
        })
    }

    /// The reason to refuse joint limits written in radians: every joint states `limits_deg`,
    /// all within ±2π (+0.01 for a rounded 6.2832) and some half a degree or more from zero.
    /// No arm's joints all stop within ±6.3°; ±6.283 is ±360° in radians.
    fn limits_in_radians(&self) -> Option<String> {
        let limits: Vec<[f64; 2]> = self
            .joints
            .iter()
            .map(|j| j.limits_deg)
            .collect::<Option<_>>()?;
        let most = limits.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        (0.5..=std::f64::consts::TAU + 0.01)
            .contains(&most)
            .then(|| {
                let [lo, hi] = limits[0];
                format!(
                    "every joint's limits_deg lies within ±{most:.3}° (joint 1: [{}, {}]): robot \
                 files are in degrees and these read as radians; multiply them by 180/π \
                 (±6.283 is ±360°)",
                    crate::number_text(lo),
                    crate::number_text(hi)
                )
            })
    }

    /// Checks every value: finite numbers, `lower < upper`, 2 to 8 joints, effects on existing
    /// joints with the right number of values.
    pub fn validate(&self) -> Result<(), Issue> {
        let issue = |place, message: String| Err(Issue { place, message });
        let n = self.joints.len();
        if !(2..=8).contains(&n) {
            return issue(
                Place::Joints,
                format!("the robot has {n} joints; 2 to 8 are supported"),
            );
        }
        for (i, j) in self.joints.iter().enumerate() {
            let p = Place::Joint(i);
            if !finite(&[
                j.alpha_deg,
                j.a_mm,
                j.theta_deg,
                j.d_mm,
                j.beta_deg.unwrap_or(0.0),
            ]) {
                return issue(
                    p,
                    format!("joint {}: parameters must be finite numbers", i + 1),
                );
            }
            for (key, v) in [("a_mm", j.a_mm), ("d_mm", j.d_mm)] {
                if let Some(m) = implausible_length(key, v) {
                    return issue(p, format!("joint {}: {m}", i + 1));
                }
            }
            for (key, v) in [
                ("alpha_deg", j.alpha_deg),
                ("theta_deg", j.theta_deg),
                ("beta_deg", j.beta_deg.unwrap_or(0.0)),
            ] {
                if let Some(m) = implausible_angle(key, v, crate::MAX_ANGLE_DEG) {
                    return issue(p, format!("joint {}: {m}", i + 1));
                }
            }
            if let Some([lo, hi]) = j.limits_deg {
                if !finite(&[lo, hi]) || lo >= hi {
                    return issue(p, format!("joint {}: limits_deg must be finite with lower < upper, got [{lo}, {hi}]", i + 1));
                }
                for v in [lo, hi] {
                    if let Some(m) = implausible_angle("limits_deg", v, crate::MAX_JOINT_LIMIT_DEG)
                    {
                        return issue(p, format!("joint {}: {m}", i + 1));
                    }
                }
            }
        }
        if let Some(m) = self.lengths_in_metres() {
            return issue(Place::Joints, m);
        }
        if let Some(m) = self.limits_in_radians() {
            return issue(Place::Joints, m);
        }
        if !self.tool.rpy_deg.is_none_or(|r| finite(&r)) {
            return issue(Place::Tool, "tool: rpy_deg must be finite numbers".into());
        }
        if let Some(m) = self
            .tool
            .rpy_deg
            .iter()
            .flatten()
            .find_map(|v| implausible_angle("rpy_deg", *v, crate::MAX_ANGLE_DEG))
        {
            return issue(Place::Tool, format!("tool: {m}"));
        }
        if !finite(&self.tool.xyz_mm) {
            return issue(Place::Tool, "tool: xyz_mm must be finite numbers".into());
        }
        if let Some(m) = self
            .tool
            .xyz_mm
            .iter()
            .find_map(|v| implausible_length("xyz_mm", *v))
        {
            return issue(Place::Tool, format!("tool: {m}"));
        }
        if self.tools.len() > MAX_TOOL_POINTS {
            return issue(
                Place::Tools(MAX_TOOL_POINTS),
                format!(
                    "{} [[tools]]: at most {MAX_TOOL_POINTS} reflectors per tool are supported",
                    self.tools.len()
                ),
            );
        }
        for (i, t) in self.tools.iter().enumerate() {
            let p = Place::Tools(i);
            let name_ok = !t.name.is_empty()
                && t.name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !name_ok {
                return issue(
                    p,
                    format!("tools: name `{}` must be letters, digits or `_`", t.name),
                );
            }
            if self.tools[..i].iter().any(|o| o.name == t.name) {
                return issue(p, format!("tools: name `{}` is given twice", t.name));
            }
            if !finite(&t.xyz_mm) {
                return issue(
                    p,
                    format!("tools `{}`: xyz_mm must be finite numbers", t.name),
                );
            }
            if let Some(m) = t
                .xyz_mm
                .iter()
                .find_map(|v| implausible_length("xyz_mm", *v))
            {
                return issue(p, format!("tools `{}`: {m}", t.name));
            }
        }
        if let Some(b) = &self.base {
            if !finite(&b.xyz_mm) || !finite(&b.rpy_deg) {
                return issue(
                    Place::Base,
                    "base: xyz_mm and rpy_deg must be finite numbers".into(),
                );
            }
            let bad = b
                .xyz_mm
                .iter()
                .find_map(|v| implausible_length("xyz_mm", *v))
                .or_else(|| {
                    b.rpy_deg
                        .iter()
                        .find_map(|v| implausible_angle("rpy_deg", *v, crate::MAX_ANGLE_DEG))
                });
            if let Some(m) = bad {
                return issue(Place::Base, format!("base: {m}"));
            }
        }
        let mut total = 0usize;
        let mut seen: Vec<(String, usize, u16)> = Vec::new();
        for (i, e) in self.effects.iter().enumerate() {
            let p = Place::Effect(i);
            let what = format!("effect `{}` on joint {}", e.kind, e.joint);
            let thermal = e.kind == THERMAL;
            if e.kind == kinecal::EffectKind::Drift.id() {
                return issue(
                    p,
                    format!("{what}: base-drift is a tracker's drift during one session, not part of a robot: identify and diagnose estimate it from the data's t_s (--effect base-drift) and do not write it"),
                );
            }
            if thermal {
                if e.joint != 0 {
                    return issue(
                        p,
                        format!("{what}: thermal-expansion acts on no joint: give joint = 0"),
                    );
                }
                if e.values.len() != 1 || !finite(&e.values) || e.values[0].abs() >= 1e-2 {
                    return issue(
                        p,
                        format!("{what}: expected 1 value [c], a finite expansion per kelvin below 1e-2 in magnitude (steel ≈ 1.2e-5)"),
                    );
                }
                if e.reference_c
                    .is_some_and(|t| !(t.is_finite() && t.abs() <= 1e3))
                {
                    return issue(
                        p,
                        format!("{what}: reference_c must be a temperature in °C"),
                    );
                }
            } else if e.reference_c.is_some() {
                return issue(
                    p,
                    format!("{what}: reference_c applies to thermal-expansion only"),
                );
            }
            if !thermal && (e.joint < 1 || e.joint > n) {
                return issue(p, format!("{what}: joint must be 1 to {n}"));
            }
            if !finite(&e.values) {
                return issue(p, format!("{what}: values must be finite numbers"));
            }
            if let Some(v) = e.values.iter().find(|v| v.abs() > crate::MAX_EFFECT_VALUE) {
                return issue(
                    p,
                    format!(
                        "{what}: value {} is implausible (effect values are at most {} in magnitude: a scale, radians, or radians per metre)",
                        crate::number_text(*v),
                        crate::MAX_EFFECT_VALUE
                    ),
                );
            }
            if e.kind == "joint-table" && e.values.len() > crate::MAX_TABLE_KNOTS {
                return issue(
                    p,
                    format!("{what}: at most {} knots", crate::MAX_TABLE_KNOTS),
                );
            }
            if e.order.is_some_and(|o| o > crate::MAX_CYCLIC_ORDER) {
                return issue(
                    p,
                    format!("{what}: order must be at most {}", crate::MAX_CYCLIC_ORDER),
                );
            }
            let count_ok = match e.kind.as_str() {
                "joint-scale" | "joint-compliance" => e.values.len() == 1,
                "joint-cyclic" => e.values.len() == 2,
                "joint-table" => e.values.len() >= 2,
                AXIS_TILT => e.values.len() <= 1,
                THERMAL => e.values.len() == 1,
                other => {
                    return issue(
                        p,
                        format!(
                            "unknown effect kind `{other}` (expected joint-scale, joint-cyclic, joint-compliance, joint-table, axis-tilt or thermal-expansion)"
                        ),
                    )
                }
            };
            if !count_ok {
                let want = match e.kind.as_str() {
                    "joint-cyclic" => "2 values [a, b]",
                    "joint-table" => "at least 2 knot values",
                    AXIS_TILT => "no value or 1 value [beta]",
                    _ => "1 value",
                };
                return issue(
                    p,
                    format!("{what}: expected {want}, got {}", e.values.len()),
                );
            }
            if e.order.is_some() && e.kind != "joint-cyclic" {
                return issue(p, format!("{what}: `order` applies to joint-cyclic only"));
            }
            if e.order == Some(0) {
                return issue(p, format!("{what}: order must be at least 1"));
            }
            if e.kind == "joint-table" {
                match e.step_deg {
                    Some(s)
                        if s.is_finite() && (crate::MIN_TABLE_STEP_DEG..=360.0).contains(&s) => {}
                    Some(s) => {
                        return issue(
                            p,
                            format!(
                                "{what}: step_deg must be {} to 360 degrees, got {s}",
                                crate::MIN_TABLE_STEP_DEG
                            ),
                        )
                    }
                    None => {
                        return issue(p, format!("{what}: step_deg is required for joint-table"))
                    }
                }
                // A table starts where the data's readings do, and a data file's readings may
                // reach the reader's bound: a table fitted to them reads back.
                if e.start_deg
                    .is_some_and(|s| !(s.is_finite() && s.abs() <= crate::MAX_TABLE_START_DEG))
                {
                    return issue(
                        p,
                        format!(
                            "{what}: start_deg must be a finite angle within ±{} degrees",
                            crate::number_text(crate::MAX_TABLE_START_DEG)
                        ),
                    );
                }
            } else if e.step_deg.is_some() || e.start_deg.is_some() {
                return issue(
                    p,
                    format!("{what}: step_deg/start_deg apply to joint-table only"),
                );
            }
            let key = (e.kind.clone(), e.joint, e.order.unwrap_or(1));
            if seen.contains(&key) {
                return issue(p, format!("{what}: the same effect is given twice"));
            }
            seen.push(key);
            if e.kind != AXIS_TILT {
                total += e.values.len();
            }
        }
        for (i, c) in self.couplings.iter().enumerate() {
            let p = Place::Coupling(i);
            let what = format!("coupling of joint {} from joint {}", c.joint, c.from);
            if i >= MAX_COUPLINGS {
                return issue(
                    p,
                    format!("{what}: at most {MAX_COUPLINGS} couplings are supported"),
                );
            }
            if c.joint < 1 || c.joint > n || c.from < 1 || c.from > n {
                return issue(p, format!("{what}: joint and from must be 1 to {n}"));
            }
            if c.joint == c.from {
                return issue(p, format!("{what}: a joint cannot be coupled to itself"));
            }
            if !(c.ratio.is_finite() && c.ratio.abs() <= crate::MAX_COUPLING_RATIO) {
                return issue(
                    p,
                    format!(
                        "{what}: ratio must be a finite number within ±{}, got {}",
                        crate::MAX_COUPLING_RATIO,
                        c.ratio
                    ),
                );
            }
            let earlier = &self.couplings[..i];
            if earlier.iter().any(|o| o.joint == c.joint) {
                return issue(p, format!("{what}: joint {} is coupled twice", c.joint));
            }
            let chained = self
                .couplings
                .iter()
                .enumerate()
                .any(|(k, o)| k != i && (o.joint == c.from || o.from == c.joint));
            if chained {
                return issue(
                    p,
                    format!("{what}: chained couplings are not supported (a coupled joint cannot be the `from` of another coupling)"),
                );
            }
        }
        let n_eff = self.effects.iter().filter(|e| e.kind != AXIS_TILT).count();
        if n_eff > MAX_EFFECTS || total > VCAP {
            return issue(
                Place::File,
                format!("too many effects: {n_eff} effects with {total} values (at most {MAX_EFFECTS} and {VCAP})"),
            );
        }
        Ok(())
    }
}
