//! An independent `f64` reference of docs/formats.md, written plainly from the formulas
//! with 4×4 homogeneous matrices, and its derivatives by central differences. Joint couplings
//! (§3 `[[couplings]]`) are a plain N×N matrix applied to the corrected readings.
//!
//! It shares nothing with the library's kinematics (no `Frame`, no cached trigonometry, no
//! analytic Jacobian): the cross-check tests compare the two. Slow on purpose.

use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::Robot;
use kinecal_cli::formats::robot_file::{RobotFile, AXIS_TILT};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, Rotation3, Vector3, Vector4};

/// One MDH row with tilt (rad, mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefJoint {
    pub alpha: f64,
    pub a: f64,
    pub theta: f64,
    pub d: f64,
    pub beta: f64,
}

/// A joint correction of docs/formats.md "Effects" (`joint` 0-based, values in rad / rad per m).
#[derive(Clone, Debug, PartialEq)]
pub enum RefEffect {
    Scale {
        joint: usize,
        s: f64,
    },
    Cyclic {
        joint: usize,
        order: u32,
        a: f64,
        b: f64,
    },
    Compliance {
        joint: usize,
        k: f64,
    },
    Table {
        joint: usize,
        start: f64,
        step: f64,
        knots: Vec<f64>,
    },
}

impl RefEffect {
    fn values_mut(&mut self) -> Vec<&mut f64> {
        match self {
            RefEffect::Scale { s, .. } => vec![s],
            RefEffect::Cyclic { a, b, .. } => vec![a, b],
            RefEffect::Compliance { k, .. } => vec![k],
            RefEffect::Table { knots, .. } => knots.iter_mut().collect(),
        }
    }
}

/// A joint read relative to another (0-based): model angle of `joint` = its reading +
/// `ratio` · the reading of `from`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefCoupling {
    pub joint: usize,
    pub from: usize,
    pub ratio: f64,
}

/// The reference robot: `p = B·T_1(q_1)…T_N(q_N)·tool`.
#[derive(Clone, Debug, PartialEq)]
pub struct RefRobot {
    /// Base pose in the measurement frame.
    pub base: Matrix4<f64>,
    pub joints: Vec<RefJoint>,
    pub tool: Vector3<f64>,
    /// Further tool points (reflectors 2, 3, …), flange frame.
    pub more_tools: Vec<Vector3<f64>>,
    /// Orientation of the measured frame in the flange frame (`[tool] rpy_deg`).
    pub tool_axes: Matrix3<f64>,
    /// In the order of the library's effect list (its value numbering follows this order).
    pub effects: Vec<RefEffect>,
    /// Joint couplings: model angles = C · (corrected readings), C = I + Σ ratio·e_joint·e_fromᵀ.
    pub couplings: Vec<RefCoupling>,
}

/// Rotation about x by `t` (homogeneous).
pub fn rx(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
/// Rotation about y by `t`.
pub fn ry(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        c, 0.0, s, 0.0, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
/// Rotation about z by `t`.
pub fn rz(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
/// Translation along x by `a`.
pub fn tx(a: f64) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m[(0, 3)] = a;
    m
}
/// Translation along z by `d`.
pub fn tz(d: f64) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m[(2, 3)] = d;
    m
}

/// Homogeneous pose from a translation and fixed-axis roll, pitch, yaw (rad):
/// `R = Rz(yaw)·Ry(pitch)·Rx(roll)`.
pub fn pose_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Matrix4<f64> {
    let mut m = rz(rpy[2]) * ry(rpy[1]) * rx(rpy[0]);
    m[(0, 3)] = xyz[0];
    m[(1, 3)] = xyz[1];
    m[(2, 3)] = xyz[2];
    m
}

/// Piecewise-linear interpolation through `knots` at `start + k·step`, constant beyond the ends.
pub fn table_value(start: f64, step: f64, knots: &[f64], q: f64) -> f64 {
    let n = knots.len();
    if n == 0 {
        return 0.0;
    }
    if q <= start {
        return knots[0];
    }
    let last = start + step * (n - 1) as f64;
    if q >= last {
        return knots[n - 1];
    }
    for k in 0..n - 1 {
        let lo = start + step * k as f64;
        let hi = start + step * (k + 1) as f64;
        if q >= lo && q <= hi {
            let w = (q - lo) / step;
            return knots[k] * (1.0 - w) + knots[k + 1] * w;
        }
    }
    knots[n - 1]
}

fn translation(m: &Matrix4<f64>) -> Vector3<f64> {
    Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)])
}

impl RefRobot {
    /// From a robot file, independently of the library's conversion (degrees → radians here,
    /// tables starting at the joint's lower limit unless `start_deg` is given).
    pub fn from_file(f: &RobotFile) -> RefRobot {
        let mut joints: Vec<RefJoint> = f
            .joints
            .iter()
            .map(|j| RefJoint {
                alpha: j.alpha_deg.to_radians(),
                a: j.a_mm,
                theta: j.theta_deg.to_radians(),
                d: j.d_mm,
                beta: j.beta_deg.unwrap_or(0.0).to_radians(),
            })
            .collect();
        let base = match &f.base {
            Some(b) => pose_xyz_rpy(b.xyz_mm, b.rpy_deg.map(f64::to_radians)),
            None => Matrix4::identity(),
        };
        let mut effects = Vec::new();
        for e in &f.effects {
            let j = e.joint - 1;
            match e.kind.as_str() {
                AXIS_TILT => {
                    if let Some(b) = e.values.first() {
                        joints[j].beta = *b;
                    }
                }
                "joint-scale" => effects.push(RefEffect::Scale {
                    joint: j,
                    s: e.values[0],
                }),
                "joint-compliance" => effects.push(RefEffect::Compliance {
                    joint: j,
                    k: e.values[0],
                }),
                "joint-cyclic" => effects.push(RefEffect::Cyclic {
                    joint: j,
                    order: e.order.unwrap_or(1) as u32,
                    a: e.values[0],
                    b: e.values[1],
                }),
                "joint-table" => effects.push(RefEffect::Table {
                    joint: j,
                    start: e.start_deg.unwrap_or(f.limits_deg(j)[0]).to_radians(),
                    step: e.step_deg.unwrap_or(1.0).to_radians(),
                    knots: e.values.clone(),
                }),
                _ => {}
            }
        }
        let couplings = f
            .couplings
            .iter()
            .map(|c| RefCoupling {
                joint: c.joint - 1,
                from: c.from - 1,
                ratio: c.ratio,
            })
            .collect();
        let tool_axes = match f.tool.rpy_deg {
            Some(rpy) => pose_xyz_rpy([0.0; 3], rpy.map(f64::to_radians))
                .fixed_view::<3, 3>(0, 0)
                .into_owned(),
            None => Matrix3::identity(),
        };
        RefRobot {
            base,
            joints,
            tool: Vector3::from(f.tool.xyz_mm),
            more_tools: Vec::new(),
            tool_axes,
            effects,
            couplings,
        }
    }

    /// Copies the numbers of a library model (nothing else is shared).
    pub fn from_robot<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> RefRobot {
        let b = r.base();
        let mut base = Matrix4::identity();
        for (c, v) in [b.x, b.y, b.z, b.o].iter().enumerate() {
            for row in 0..3 {
                base[(row, c)] = v[row];
            }
        }
        let joints = r
            .joints()
            .iter()
            .map(|j| RefJoint {
                alpha: j.alpha,
                a: j.a,
                theta: j.theta,
                d: j.d,
                beta: j.beta,
            })
            .collect();
        let effects = r
            .effects()
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let v = r.effects().values_of(i);
                let joint = e.joint as usize;
                match e.kind {
                    EffectKind::Scale => RefEffect::Scale { joint, s: v[0] },
                    EffectKind::Cyclic => RefEffect::Cyclic {
                        joint,
                        order: e.order as u32,
                        a: v[0],
                        b: v[1],
                    },
                    EffectKind::Compliance => RefEffect::Compliance { joint, k: v[0] },
                    EffectKind::Table => RefEffect::Table {
                        joint,
                        start: e.start,
                        step: e.step,
                        knots: v.to_vec(),
                    },
                    // The reference evaluates at the term's reference temperature, where the
                    // expansion changes no length: a correction of zero.
                    EffectKind::Thermal => RefEffect::Scale { joint, s: 0.0 },
                    // Likewise at the base-drift term's reference time: no translation.
                    EffectKind::Drift => RefEffect::Scale { joint, s: 0.0 },
                }
            })
            .collect();
        let couplings = r
            .couplings()
            .iter()
            .map(|(joint, from, ratio)| RefCoupling { joint, from, ratio })
            .collect();
        let a = r.tool_axes();
        RefRobot {
            base,
            joints,
            tool: *r.tool(),
            more_tools: (1..r.tool_point_count())
                .filter_map(|k| r.tool_point(k).copied())
                .collect(),
            tool_axes: Matrix3::from_columns(&[a.x, a.y, a.z]),
            effects,
            couplings,
        }
    }

    /// `T_i(q) = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta + q)·Tz(d)`.
    pub fn link(&self, i: usize, q: f64) -> Matrix4<f64> {
        let j = &self.joints[i];
        rx(j.alpha) * tx(j.a) * ry(j.beta) * rz(j.theta + q) * tz(j.d)
    }

    /// Joint frames `T_1…T_i` in the robot base frame (no `B`), at the given geometric angles.
    pub fn frames_in_base(&self, q: &[f64]) -> Vec<Matrix4<f64>> {
        let mut t = Matrix4::identity();
        (0..self.joints.len())
            .map(|i| {
                t *= self.link(i, q[i]);
                t
            })
            .collect()
    }

    /// The point in the robot base frame at the given geometric angles (no corrections).
    fn point_in_base(&self, q: &[f64]) -> Vector3<f64> {
        let frames = self.frames_in_base(q);
        let last = frames.last().copied().unwrap_or_else(Matrix4::identity);
        (last * Vector4::new(self.tool.x, self.tool.y, self.tool.z, 1.0)).xyz()
    }

    /// Lever arms tau_j (m) of a unit downward force at the point about each joint axis, from
    /// the geometry at the angles `q` (the readings' model angles, without corrections):
    /// `((z_j × (p − o_j)) · g) / 1000`, g = (0, 0, −1), base frame.
    pub fn lever_arms(&self, q: &[f64]) -> Vec<f64> {
        let frames = self.frames_in_base(q);
        let p = self.point_in_base(q);
        let g = Vector3::new(0.0, 0.0, -1.0);
        frames
            .iter()
            .map(|f| {
                let z = Vector3::new(f[(0, 2)], f[(1, 2)], f[(2, 2)]);
                z.cross(&(p - translation(f))).dot(&g) / 1000.0
            })
            .collect()
    }

    /// The coupling matrix C (N×N): model angles = C · readings.
    pub fn coupling_matrix(&self) -> DMatrix<f64> {
        let n = self.joints.len();
        let mut c = DMatrix::identity(n, n);
        for k in &self.couplings {
            c[(k.joint, k.from)] += k.ratio;
        }
        c
    }

    /// Model angles of (corrected) readings: `C · r`.
    pub fn coupled(&self, r: &[f64]) -> Vec<f64> {
        let v = self.coupling_matrix() * DVector::from_column_slice(r);
        v.iter().copied().collect()
    }

    /// The angles the geometry sees: readings plus every correction, through the couplings.
    pub fn corrected(&self, q: &[f64]) -> Vec<f64> {
        let tau = if self
            .effects
            .iter()
            .any(|e| matches!(e, RefEffect::Compliance { .. }))
        {
            self.lever_arms(&self.coupled(q))
        } else {
            vec![0.0; q.len()]
        };
        let mut out = q.to_vec();
        for e in &self.effects {
            match e {
                RefEffect::Scale { joint, s } => out[*joint] += s * q[*joint],
                RefEffect::Cyclic { joint, order, a, b } => {
                    let n = *order as f64;
                    out[*joint] += a * (n * q[*joint]).sin() + b * (n * q[*joint]).cos();
                }
                RefEffect::Compliance { joint, k } => out[*joint] += k * tau[*joint],
                RefEffect::Table {
                    joint,
                    start,
                    step,
                    knots,
                } => out[*joint] += table_value(*start, *step, knots, q[*joint]),
            }
        }
        self.coupled(&out)
    }

    /// The full chain `B·T_1…T_N` at readings `q` (corrections applied).
    pub fn flange(&self, q: &[f64]) -> Matrix4<f64> {
        let qg = self.corrected(q);
        let mut t = self.base;
        for (i, qi) in qg.iter().enumerate() {
            t *= self.link(i, *qi);
        }
        t
    }

    /// The measured point `p(q)`, mm, measurement frame.
    pub fn point(&self, q: &[f64]) -> Vector3<f64> {
        (self.flange(q) * Vector4::new(self.tool.x, self.tool.y, self.tool.z, 1.0)).xyz()
    }

    /// Tool point `k` (0: `tool`, then `more_tools`) at `q`, mm, measurement frame.
    pub fn point_at(&self, q: &[f64], k: usize) -> Vector3<f64> {
        let t = if k == 0 {
            self.tool
        } else {
            self.more_tools[k - 1]
        };
        (self.flange(q) * Vector4::new(t.x, t.y, t.z, 1.0)).xyz()
    }

    /// The flange orientation in the measurement frame.
    pub fn flange_rotation(&self, q: &[f64]) -> Matrix3<f64> {
        self.flange(q).fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// The measured frame's orientation in the measurement frame: flange · tool axes.
    pub fn tool_rotation(&self, q: &[f64]) -> Matrix3<f64> {
        self.flange_rotation(q) * self.tool_axes
    }

    /// The model value behind a library effect value number `k`.
    fn effect_value_mut(&mut self, k: usize) -> Option<&mut f64> {
        self.effects.iter_mut().flat_map(|e| e.values_mut()).nth(k)
    }

    /// A copy with parameter `p` moved by `h` (rad, mm, or the effect value's unit). Base
    /// rotations are rotation-vector steps about the base origin in the measurement frame,
    /// the library's convention for `base.rx/ry/rz`.
    pub fn perturbed(&self, p: Param, h: f64) -> RefRobot {
        let mut r = self.clone();
        let rot = |axis: Vector3<f64>, r: &mut RefRobot| {
            let m = Rotation3::from_scaled_axis(axis * h).into_inner();
            let old = r.base.fixed_view::<3, 3>(0, 0).into_owned();
            r.base.fixed_view_mut::<3, 3>(0, 0).copy_from(&(m * old));
        };
        match p {
            Param::BaseX => r.base[(0, 3)] += h,
            Param::BaseY => r.base[(1, 3)] += h,
            Param::BaseZ => r.base[(2, 3)] += h,
            Param::BaseRx => rot(Vector3::x(), &mut r),
            Param::BaseRy => rot(Vector3::y(), &mut r),
            Param::BaseRz => rot(Vector3::z(), &mut r),
            Param::Alpha(i) => r.joints[i as usize].alpha += h,
            Param::A(i) => r.joints[i as usize].a += h,
            Param::Theta(i) => r.joints[i as usize].theta += h,
            Param::D(i) => r.joints[i as usize].d += h,
            Param::Beta(i) => r.joints[i as usize].beta += h,
            Param::ToolX => r.tool.x += h,
            Param::ToolY => r.tool.y += h,
            Param::ToolZ => r.tool.z += h,
            Param::ToolPoint(k, a) => r.more_tools[k as usize - 1][a as usize] += h,
            // Rotation-vector steps in the flange frame: R_tool ← exp(h·axis)·R_tool.
            Param::ToolRx | Param::ToolRy | Param::ToolRz => {
                let axis = match p {
                    Param::ToolRx => Vector3::x(),
                    Param::ToolRy => Vector3::y(),
                    _ => Vector3::z(),
                };
                r.tool_axes = Rotation3::from_scaled_axis(axis * h).into_inner() * r.tool_axes;
            }
            Param::Effect(k) => {
                if let Some(v) = r.effect_value_mut(k as usize) {
                    *v += h;
                }
            }
        }
        r
    }

    /// `∂p/∂param` by the five-point central difference: step 1 mm for lengths (p is affine
    /// in them, so the difference is exact), 1e-3 for angles and effect values (truncation
    /// O(h⁴) ≈ 1e-10 mm per unit, rounding ≈ 1e-8).
    pub fn dp_dparam(&self, q: &[f64], p: Param) -> Vector3<f64> {
        let h = if p.is_length() { 1.0 } else { 1e-3 };
        let f = |s: f64| self.perturbed(p, s * h).point(q);
        (f(-2.0) - f(2.0) + (f(1.0) - f(-1.0)) * 8.0) / (12.0 * h)
    }

    /// `∂p/∂q_j` by the five-point central difference (step 1e-3 rad).
    pub fn dp_dq(&self, q: &[f64], j: usize) -> Vector3<f64> {
        let h = 1e-3;
        let f = |s: f64| {
            let mut qq = q.to_vec();
            qq[j] += s * h;
            self.point(&qq)
        };
        (f(-2.0) - f(2.0) + (f(1.0) - f(-1.0)) * 8.0) / (12.0 * h)
    }

    /// Angular velocity of the tool orientation per unit `q_j` (rotation vector per rad), by
    /// central differences of `R(q + h)·R(q − h)ᵀ`.
    pub fn dr_dq(&self, q: &[f64], j: usize) -> Vector3<f64> {
        let h = 1e-4;
        let mut qp = q.to_vec();
        let mut qm = q.to_vec();
        qp[j] += h;
        qm[j] -= h;
        let r = self.tool_rotation(&qp) * self.tool_rotation(&qm).transpose();
        // Logarithm of a small rotation from its skew part (acos of the trace loses half
        // the digits near the identity).
        let v = Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        ) * 0.5;
        let s = v.norm();
        let w = if s > 0.0 { v * (s.asin() / s) } else { v };
        w / (2.0 * h)
    }
}

/// One observation for the reference solver: joint readings (rad), which tool point
/// (0: `tool`, then `more_tools`), the measured point (mm) with its per-coordinate weights, and
/// for a 6-D observation the measured orientation of the tool frame with its weight (per rad).
#[derive(Clone, Debug, PartialEq)]
pub struct RefObservation {
    pub q: Vec<f64>,
    pub tool: usize,
    pub point: Vector3<f64>,
    pub weight: Vector3<f64>,
    pub orientation: Option<Matrix3<f64>>,
    pub orientation_weight: f64,
}

/// Rotation vector of `measured · predictedᵀ` by nalgebra's logarithm (`acos` of the trace for
/// the angle, the skew part for the axis). The angle's error is the trace's rounding over
/// sin θ: with the rotations' own rounding (~1e-15 off orthogonal after a chain of products)
/// about 1e-11 rad at θ = 1e-4, and below ~1e-8 rad the angle is lost (`acos(1)`): fine for
/// residuals of noisy orientations, not for telling two nearly equal rotations apart (see
/// [`small_angle`]). When rounding puts the trace above 3 (`acos` NaN), the skew part itself.
pub fn rotation_residual(measured: &Matrix3<f64>, predicted: &Matrix3<f64>) -> Vector3<f64> {
    let r = measured * predicted.transpose();
    let v = Rotation3::from_matrix_unchecked(r).scaled_axis();
    if v.iter().all(|x| x.is_finite()) {
        v
    } else {
        Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        ) * 0.5
    }
}

/// The angle (rad) between two nearly equal rotations, from the skew part of `a·bᵀ`
/// (`asin |v|`: good to rounding, ~1e-16, at any small angle; valid below π/2).
pub fn small_angle(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let r = a * b.transpose();
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) * 0.5;
    v.norm().min(1.0).asin()
}

/// The result of [`ref_fit`].
#[derive(Clone, Debug)]
pub struct RefFit {
    pub robot: RefRobot,
    /// Σ of squared weighted residuals at `robot`.
    pub cost: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Singular values of the column-scaled Jacobian at the end, largest first (the smallest
    /// over the largest says how well the parameters are determined).
    pub singular_values: Vec<f64>,
}

impl RefRobot {
    /// Tool point `k` in the flange frame.
    pub fn tool_point(&self, k: usize) -> Vector3<f64> {
        if k == 0 {
            self.tool
        } else {
            self.more_tools[k - 1]
        }
    }

    /// The weighted residual rows of one observation, appended to `out`: `w ⊙ (p_m − p)`, then
    /// for a 6-D observation `w_rot · log(R_m · R(q)ᵀ)`.
    pub fn residual_into(&self, m: &RefObservation, out: &mut Vec<f64>) {
        let f = self.flange(&m.q);
        let t = self.tool_point(m.tool);
        let p = (f * Vector4::new(t.x, t.y, t.z, 1.0)).xyz();
        let r = (m.point - p).component_mul(&m.weight);
        out.extend(r.iter());
        if let Some(rm) = &m.orientation {
            let rp = f.fixed_view::<3, 3>(0, 0).into_owned() * self.tool_axes;
            let v = rotation_residual(rm, &rp) * m.orientation_weight;
            out.extend(v.iter());
        }
    }

    /// Every observation's weighted residual rows, in order.
    pub fn residuals(&self, data: &[RefObservation]) -> DVector<f64> {
        let mut out = Vec::with_capacity(6 * data.len());
        for m in data {
            self.residual_into(m, &mut out);
        }
        DVector::from_vec(out)
    }

    /// Σ of squared weighted residuals.
    pub fn cost(&self, data: &[RefObservation]) -> f64 {
        self.residuals(data).norm_squared()
    }

    /// `∂p_k/∂param` of tool point `k` by the five-point central difference (steps as
    /// [`Self::dp_dparam`]).
    pub fn dp_dparam_at(&self, q: &[f64], p: Param, k: usize) -> Vector3<f64> {
        let h = if p.is_length() { 1.0 } else { 1e-3 };
        let f = |s: f64| self.perturbed(p, s * h).point_at(q, k);
        (f(-2.0) - f(2.0) + (f(1.0) - f(-1.0)) * 8.0) / (12.0 * h)
    }

    /// The rotation vector the tool frame turns by per unit `param`, by central differences of
    /// `R(param + h)·R(param − h)ᵀ` (h = 1e-4; lengths too, where it is zero).
    pub fn dr_dparam(&self, q: &[f64], p: Param) -> Vector3<f64> {
        let h = 1e-4;
        let r = self.perturbed(p, h).tool_rotation(q)
            * self.perturbed(p, -h).tool_rotation(q).transpose();
        // The small rotation's logarithm from its skew part (as `dr_dq`).
        let v = Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        ) * 0.5;
        let s = v.norm();
        let w = if s > 0.0 { v * (s.asin() / s) } else { v };
        w / (2.0 * h)
    }

    /// A copy with every parameter of `params` moved by its entry of `delta`, one after the
    /// other through [`Self::perturbed`].
    pub fn stepped(&self, params: &[Param], delta: &[f64]) -> RefRobot {
        let mut r = self.clone();
        for (p, d) in params.iter().zip(delta) {
            r = r.perturbed(*p, *d);
        }
        r
    }

    /// Jacobian of [`Self::residuals`] by five-point central differences of the residuals
    /// themselves: step 1 mm for lengths (the residual is affine in each), 1e-3 for angles and
    /// effect values (truncation O(h⁴)).
    pub fn residual_jacobian(&self, params: &[Param], data: &[RefObservation]) -> DMatrix<f64> {
        let m = self.residuals(data).len();
        let mut j = DMatrix::zeros(m, params.len());
        for (c, p) in params.iter().enumerate() {
            let h = if p.is_length() { 1.0 } else { 1e-3 };
            let f = |s: f64| self.perturbed(*p, s * h).residuals(data);
            let col = (f(-2.0) - f(2.0) + (f(1.0) - f(-1.0)) * 8.0) / (12.0 * h);
            j.set_column(c, &col);
        }
        j
    }
}

/// The reference solver: weighted least squares over `params` from `start`, Levenberg–
/// Marquardt on the dense normal equations of [`RefRobot::residual_jacobian`] (columns scaled
/// to unit norm, damping `λ·I` on the scaled system, solved by SVD), stopping when a step
/// changes the residual by less than 1e-9 of its norm (or after 200 steps).
pub fn ref_fit(start: &RefRobot, params: &[Param], data: &[RefObservation]) -> RefFit {
    let n = params.len();
    let mut robot = start.clone();
    let mut r = robot.residuals(data);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut singular_values = Vec::new();
    for _ in 0..200 {
        let j = robot.residual_jacobian(params, data);
        let scale: Vec<f64> = (0..n)
            .map(|c| {
                let s = j.column(c).norm();
                if s > 0.0 {
                    1.0 / s
                } else {
                    1.0
                }
            })
            .collect();
        let mut js = j.clone();
        for (c, s) in scale.iter().enumerate() {
            js.column_mut(c).scale_mut(*s);
        }
        singular_values = js
            .clone()
            .svd(false, false)
            .singular_values
            .iter()
            .copied()
            .collect();
        singular_values.sort_by(|a, b| b.total_cmp(a));
        let jtj = js.transpose() * &js;
        let g = js.transpose() * &r;
        let mut accepted = false;
        let mut tiny = false;
        while lambda < 1e12 {
            let a = &jtj + DMatrix::identity(n, n) * lambda;
            let u = a.svd(true, true).solve(&(-&g), 0.0).expect("svd solve");
            let change = (&js * &u).norm();
            let delta: Vec<f64> = u.iter().zip(&scale).map(|(u, s)| u * s).collect();
            let cand = robot.stepped(params, &delta);
            let rc = cand.residuals(data);
            let cc = rc.norm_squared();
            if change <= 1e-9 * cost.sqrt() {
                // Converged: take the last (tiny) step when it does not raise the cost.
                if cc <= cost {
                    robot = cand;
                    r = rc;
                    cost = cc;
                }
                tiny = true;
                break;
            }
            if cc < cost {
                robot = cand;
                r = rc;
                cost = cc;
                lambda = (lambda * 0.1).max(1e-15);
                accepted = true;
                iterations += 1;
                break;
            }
            lambda *= 10.0;
        }
        if tiny || !accepted {
            break;
        }
    }
    RefFit {
        robot,
        cost,
        iterations,
        singular_values,
    }
}
