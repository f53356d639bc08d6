//! The robot file to the library's [`Robot`] and back.

use super::*;
use crate::HostRobot;

impl RobotFile {
    /// The library model (base = identity when the file has no `[base]`; see [`Self::base_known`]).
    pub fn to_robot<const N: usize>(&self) -> anyhow::Result<HostRobot<N>> {
        self.validate().map_err(|i| anyhow!("{}", i.message))?;
        if self.joints.len() != N {
            return Err(anyhow!(
                "the robot file has {} joints, expected {N}",
                self.joints.len()
            ));
        }
        let mut tilt = [None; N];
        for e in self.effects.iter().filter(|e| e.kind == AXIS_TILT) {
            if let Some(v) = e.values.first() {
                tilt[e.joint - 1] = Some(*v);
            }
        }
        let joints: [Joint<f64>; N] = std::array::from_fn(|i| {
            let j = &self.joints[i];
            let [lo, hi] = j.limits_deg.unwrap_or([-180.0, 180.0]);
            Joint {
                alpha: j.alpha_deg.to_radians(),
                a: j.a_mm,
                theta: j.theta_deg.to_radians(),
                d: j.d_mm,
                beta: tilt[i].unwrap_or_else(|| j.beta_deg.unwrap_or(0.0).to_radians()),
                lower: lo.to_radians(),
                upper: hi.to_radians(),
            }
        });
        let base = match &self.base {
            Some(b) => Frame::from_xyz_rpy(b.xyz_mm, b.rpy_deg.map(f64::to_radians)),
            None => Frame::identity(),
        };
        let tool = Vector3::from(self.tool.xyz_mm);
        let mut robot =
            Robot::new(base, joints, tool).map_err(|e| anyhow!("invalid robot: {e:?}"))?;
        for (k, t) in self.tools.iter().enumerate().skip(1) {
            robot
                .set_tool_point(k, Vector3::from(t.xyz_mm))
                .map_err(|e| anyhow!("tools `{}`: {e:?}", t.name))?;
        }
        if let Some(rpy) = self.tool.rpy_deg {
            robot
                .set_tool_axes(Frame::from_xyz_rpy([0.0; 3], rpy.map(f64::to_radians)))
                .map_err(|e| anyhow!("tool rpy_deg: {e:?}"))?;
        }
        for e in self.effects.iter().filter(|e| e.kind != AXIS_TILT) {
            let kind = EffectKind::from_id(&e.kind)
                .ok_or_else(|| anyhow!("unknown effect kind `{}`", e.kind))?;
            let j = e.joint.saturating_sub(1);
            let (start, step) = if kind == EffectKind::Thermal {
                (e.reference_c.unwrap_or(DEFAULT_REFERENCE_C), 0.0)
            } else if kind == EffectKind::Table {
                let start = e.start_deg.unwrap_or(self.limits_deg(j)[0]);
                (start.to_radians(), e.step_deg.unwrap_or(0.0).to_radians())
            } else {
                (0.0, 0.0)
            };
            robot
                .effects_mut()
                .push(kind, j, N, e.order.unwrap_or(1), start, step, &e.values)
                .map_err(|err| anyhow!("effect `{}` on joint {}: {err:?}", e.kind, e.joint))?;
        }
        for c in &self.couplings {
            robot
                .set_coupling(c.joint - 1, c.from - 1, c.ratio)
                .map_err(|err| {
                    anyhow!(
                        "coupling of joint {} from joint {}: {err:?}",
                        c.joint,
                        c.from
                    )
                })?;
        }
        Ok(robot)
    }

    /// The file of a library model. `base_known` = write `[base]`; `tilt` (0-based joints) are
    /// written as `axis-tilt` effects carrying their `beta` in rad, so a re-identification
    /// knows to free them. Angles are written with [`deg_short`], so they read back exactly.
    /// The robot's couplings become `[[couplings]]`.
    pub fn from_robot<const N: usize, V: kinecal::ValueStorage>(
        name: &str,
        robot: &Robot<f64, N, V>,
        base_known: bool,
        tilt: &[usize],
    ) -> RobotFile {
        let joints = robot
            .joints()
            .iter()
            .map(|j| JointSpec {
                alpha_deg: deg_short(j.alpha),
                a_mm: j.a,
                theta_deg: deg_short(j.theta),
                d_mm: j.d,
                beta_deg: if j.beta != 0.0 {
                    Some(deg_short(j.beta))
                } else {
                    None
                },
                limits_deg: Some([deg_short(j.lower), deg_short(j.upper)]),
            })
            .collect();
        let base = base_known.then(|| {
            let b = robot.base();
            BaseSpec {
                xyz_mm: [b.o.x, b.o.y, b.o.z],
                rpy_deg: rpy_deg_short(b),
            }
        });
        let mut effects: Vec<EffectSpec> = Vec::new();
        for (i, e) in robot.effects().iter().enumerate() {
            // The tracker's drift is the session's, not the robot's (calibration::drift).
            if e.kind == EffectKind::Drift {
                continue;
            }
            let table = e.kind == EffectKind::Table;
            let thermal = e.kind == EffectKind::Thermal;
            effects.push(EffectSpec {
                kind: e.kind.id().to_string(),
                joint: if thermal { 0 } else { e.joint as usize + 1 },
                reference_c: thermal.then_some(e.start),
                values: robot.effects().values_of(i).to_vec(),
                order: (e.kind == EffectKind::Cyclic).then_some(e.order),
                step_deg: table.then(|| deg_short(e.step)),
                start_deg: table.then(|| deg_short(e.start)),
            });
        }
        let mut tilt: Vec<usize> = tilt.iter().copied().filter(|j| *j < N).collect();
        tilt.sort_unstable();
        tilt.dedup();
        for j in tilt {
            effects.push(EffectSpec {
                kind: AXIS_TILT.to_string(),
                joint: j + 1,
                values: vec![robot.joints()[j].beta],
                order: None,
                step_deg: None,
                start_deg: None,
                reference_c: None,
            });
        }
        let points: Vec<[f64; 3]> = (0..robot.tool_point_count())
            .filter_map(|k| robot.tool_point(k).map(|p| [p.x, p.y, p.z]))
            .collect();
        // Points beyond the first are named `p2`, `p3`, … unless the caller names them
        // ([`RobotFile::with_tool_names`]).
        let tools = if points.len() > 1 {
            points
                .iter()
                .enumerate()
                .map(|(k, p)| NamedToolSpec {
                    name: format!("p{}", k + 1),
                    xyz_mm: *p,
                })
                .collect()
        } else {
            Vec::new()
        };
        RobotFile {
            name: name.to_string(),
            joints,
            tool: ToolSpec {
                xyz_mm: [robot.tool().x, robot.tool().y, robot.tool().z],
                rpy_deg: (!robot.tool_axes_identity()).then(|| rpy_deg_short(robot.tool_axes())),
                unknown: false,
            },
            tools,
            base,
            effects,
            couplings: robot
                .couplings()
                .iter()
                .map(|(joint, from, ratio)| CouplingSpec {
                    joint: joint + 1,
                    from: from + 1,
                    ratio,
                })
                .collect(),
            prior: None,
        }
    }
}

/// Loads a robot file and builds the `N`-joint model; also says whether `[base]` was given.
pub fn load_robot<const N: usize>(path: &Path) -> anyhow::Result<(RobotFile, HostRobot<N>)> {
    let file = RobotFile::load(path)?;
    let robot = file
        .to_robot::<N>()
        .map_err(|e| refused(format!("{}: {e}", path.display())))?;
    Ok((file, robot))
}
