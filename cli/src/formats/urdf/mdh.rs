//! A URDF chain as the modified DH model of docs/formats.md "Kinematic model" (`kinecal import --urdf`), and
//! the constant transforms that relate each MDH frame to its URDF link (what `export` needs).
//!
//! At q = 0 every revolute joint's axis line is expressed in the base link (millimetres). The
//! MDH frames are then Craig's: z_i along axis i (the URDF axis direction, so q keeps the
//! URDF's sign), x_i along the common normal from axis i to axis i+1, the origin O_i where
//! that normal meets axis i; for parallel axes O_i is where the previous normal meets axis i
//! (d chosen so the normal passes through it), and so for nearly parallel axes ([`PARALLEL`],
//! [`NEARLY_PARALLEL`]), x_i then pointing to where axis i+1 meets the plane normal to z_i
//! through O_i and the tilt in the next row's beta (Hayati's convention); for the last joint
//! x_N = x_{N-1} and d_N = 0.
//! Frame 0 has z_0 = z_1, its origin at the foot of the base link's origin on axis 1 and x_0
//! the base link's x made perpendicular to z_1: so row 1 has alpha = a = 0 and `[base]` (the
//! pose of frame 0 in the base link) is the identity for the usual arm whose first axis is
//! the base's z through its origin. The tip link's origin (plus `--tool-xyz-mm` in the tip
//! frame) expressed in frame N is `[tool] xyz_mm`, its orientation `[tool] rpy_deg`. Fixed
//! joints inside the chain fold into these constant transforms.

use super::chain::Chain;
use super::parse::{rpy_of, UrdfJoint};
use crate::formats::robot_file::{deg_short, BaseSpec, JointSpec, RobotFile, ToolSpec};
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Axes closer to parallel than this (|z_i × z_i+1|, about 0.06°) take the parallel
/// convention with the tilt in the next row's `beta` (Hayati's): their common normal lies
/// about (offset / angle) away, metres to kilometres for a `rpy` of π written with 7 to 10
/// digits, and the rows would carry that length.
const PARALLEL: f64 = 1e-3;
/// Axes within this of parallel (|z_i · z_i+1|, 25°) whose common normal meets them farther
/// than [`FAR_REACH`] times the arm's extent from the joints take the parallel convention too:
/// `rpy = "3.14 0 0"` (1.6e-3 rad from π) put it metres beyond a 1.3 m arm.
const NEARLY_PARALLEL: f64 = 0.9;
/// See [`NEARLY_PARALLEL`].
const FAR_REACH: f64 = 1.0;

/// Whether the common normal of the nearly parallel axes `(p, z)` and `(q, zn)` meets them
/// farther than [`FAR_REACH`] times `extent` from the incoming foot on axis i, or from axis
/// i+1's point (mm; see [`NEARLY_PARALLEL`]).
fn far_normal(
    (p, z): (Vector3<f64>, Vector3<f64>),
    (q, zn): (Vector3<f64>, Vector3<f64>),
    (foot, extent): (Vector3<f64>, f64),
) -> bool {
    let b = z.dot(&zn);
    if b.abs() < NEARLY_PARALLEL {
        return false;
    }
    let r = p - q;
    let (dd, e) = (z.dot(&r), zn.dot(&r));
    let den = 1.0 - b * b;
    let (t, s) = ((b * e - dd) / den, (e - b * dd) / den);
    let far = FAR_REACH * extent;
    !((p + z * t - foot).norm() <= far && (zn * s).norm() <= far)
}

/// The import of a chain: the robot file and the transforms export needs (millimetres).
#[derive(Clone, Debug)]
pub struct Imported {
    pub file: RobotFile,
    /// Pose of MDH frame 0 in the base link (the nominal `[base]`).
    pub base: Isometry3<f64>,
    /// Per revolute joint i (0-based): the URDF link pose in MDH frame i, C_i = F_i⁻¹·L_i.
    pub link_in_frame: Vec<Isometry3<f64>>,
    /// Per revolute joint i: the fixed joints' transform from the previous revolute joint's
    /// child link (the base link for the first) to joint i's parent link.
    pub before: Vec<Isometry3<f64>>,
    /// The tip link's pose in the last revolute joint's child link (fixed joints after it).
    pub tip_in_last_link: Isometry3<f64>,
    /// Names of the revolute joints, base first.
    pub joint_names: Vec<String>,
}

/// `v` on the 1e-6 grid when it is within `window` of it; -0 as 0. The frame algebra leaves
/// a few ulps of noise on URDF decimals (0.675 m comes back as 674.9999999999999 mm).
fn snap_within(v: f64, window: f64) -> f64 {
    let r = (v * 1e6).round() / 1e6;
    let v = if (v - r).abs() < window { r } else { v };
    if v == 0.0 {
        0.0
    } else {
        v
    }
}

/// A length (mm) snapped within 1e-9 mm.
fn snap(v: f64) -> f64 {
    snap_within(v, 1e-9)
}

/// Degrees of `rad` snapped within 1e-11° (2e-13 rad: below 1e-9 mm at a 2 m lever; the
/// frames are rebuilt from the values written, so only that tilt of an axis is lost).
fn deg(rad: f64) -> f64 {
    snap_within(deg_short(rad), 1e-11)
}

/// A joint limit in degrees, snapped within 1e-9° (`3.22885911619` rad reads as 185°): limits
/// bound the poses, they do not enter the kinematics.
fn limit_deg(rad: f64) -> f64 {
    snap_within(deg_short(rad), 1e-9)
}

/// A URDF origin in millimetres.
pub fn origin_mm(j: &UrdfJoint) -> Isometry3<f64> {
    let mut o = j.origin();
    o.translation.vector *= 1000.0;
    o
}

/// One MDH row at q = 0: Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta)·Tz(d) (radians, millimetres).
pub fn row_transform(alpha: f64, a: f64, beta: f64, theta: f64, d: f64) -> Isometry3<f64> {
    let rx = Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(alpha, 0.0, 0.0),
    );
    let tx = Isometry3::from_parts(Translation3::new(a, 0.0, 0.0), UnitQuaternion::identity());
    let ry = Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(0.0, beta, 0.0),
    );
    let rz = Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(0.0, 0.0, theta),
    );
    let tz = Isometry3::from_parts(Translation3::new(0.0, 0.0, d), UnitQuaternion::identity());
    rx * tx * ry * rz * tz
}

/// A frame from its origin, x and z axes (orthonormal up to rounding).
fn frame(o: Vector3<f64>, x: Vector3<f64>, z: Vector3<f64>) -> Isometry3<f64> {
    let y = z.cross(&x);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Isometry3::from_parts(
        Translation3::from(o),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// x made perpendicular to z and unit; `fallback` when x is (nearly) along z.
fn perpendicular(x: Vector3<f64>, z: Vector3<f64>, fallback: Vector3<f64>) -> Vector3<f64> {
    let p = x - z * x.dot(&z);
    if p.norm() > 1e-6 {
        p.normalize()
    } else {
        let f = fallback - z * fallback.dot(&z);
        if f.norm() > 1e-6 {
            f.normalize()
        } else {
            z.cross(&Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| z.cross(&Vector3::y()).normalize())
        }
    }
}

/// The MDH row (alpha, a, beta, theta, d) of `m` = F_{i-1}⁻¹·F_i.
fn row_of(m: &Isometry3<f64>) -> [f64; 5] {
    let r = m.rotation.to_rotation_matrix();
    let r = r.matrix();
    let z = r.column(2);
    let beta = z[0].atan2((z[1] * z[1] + z[2] * z[2]).sqrt());
    let alpha = (-z[1]).atan2(z[2]);
    let pre = UnitQuaternion::from_euler_angles(alpha, 0.0, 0.0)
        * UnitQuaternion::from_euler_angles(0.0, beta, 0.0);
    let rz = (pre.inverse() * m.rotation).to_rotation_matrix();
    let theta = rz.matrix()[(1, 0)].atan2(rz.matrix()[(0, 0)]);
    // t = a·e_x + d·z: least squares in (a, d).
    let t = m.translation.vector;
    let zx = z[0];
    let tz = t.dot(&Vector3::new(z[0], z[1], z[2]));
    let det = 1.0 - zx * zx;
    let a = (t.x - zx * tz) / det;
    let d = (tz - zx * t.x) / det;
    [alpha, a, beta, theta, d]
}

/// Converts the chain (see the module documentation). `tool_mm` is the tool point in the tip
/// link frame (millimetres); `name` the robot file's name.
pub fn import(chain: &Chain, tool_mm: [f64; 3], name: &str) -> Imported {
    // Walk the chain at q = 0: link poses in the base link (mm).
    let mut cur = Isometry3::identity();
    let mut last_link = Isometry3::identity();
    let mut lines: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::new();
    let mut links: Vec<Isometry3<f64>> = Vec::new();
    let mut before = Vec::new();
    let mut revolute: Vec<&UrdfJoint> = Vec::new();
    for j in &chain.joints {
        if j.is_revolute() {
            before.push(last_link.inverse() * cur);
        }
        cur *= origin_mm(j);
        if j.is_revolute() {
            lines.push((cur.translation.vector, cur.rotation * j.unit_axis()));
            links.push(cur);
            last_link = cur;
            revolute.push(j);
        }
    }
    let tip = cur;
    let n = lines.len();
    // Frame 0.
    let (p1, z1) = lines[0];
    let o0 = p1 - z1 * p1.dot(&z1);
    let x0 = perpendicular(Vector3::x(), z1, Vector3::y());
    let f0 = frame(o0, x0, z1);
    // The base as the file will hold it (snapped), and frame 0 rebuilt from it.
    let [br, bp, by] = rpy_of(&f0.rotation);
    let base = BaseSpec {
        xyz_mm: [
            snap(f0.translation.x),
            snap(f0.translation.y),
            snap(f0.translation.z),
        ],
        rpy_deg: [deg(br), deg(bp), deg(by)],
    };
    let f0 = Isometry3::from_parts(
        Translation3::from(Vector3::from(base.xyz_mm)),
        UnitQuaternion::from_euler_angles(
            base.rpy_deg[0].to_radians(),
            base.rpy_deg[1].to_radians(),
            base.rpy_deg[2].to_radians(),
        ),
    );
    // The arm's extent: the farthest joint from the tip (at least 100 mm).
    let extent = lines
        .iter()
        .map(|(p, _)| (p - tip.translation.vector).norm())
        .fold(100.0f64, f64::max);
    let mut frames: Vec<Isometry3<f64>> = Vec::with_capacity(n);
    let mut foot = o0; // where the incoming normal meets axis i
    let mut x_prev = x0;
    for i in 0..n {
        let (p, z) = lines[i];
        let (o, x, next_foot) = if i + 1 < n {
            let (q, zn) = lines[i + 1];
            let c = z.cross(&zn);
            if c.norm() < PARALLEL || far_normal((p, z), (q, zn), (foot, extent)) {
                // (Nearly) parallel: x_i from the incoming foot to where axis i+1 meets the
                // plane through it normal to z_i (exactly the normal for parallel axes; the
                // tilt goes into the next row's beta).
                let o = foot;
                let w = (q - o) - zn * ((q - o).dot(&z) / zn.dot(&z));
                let x = perpendicular(w, z, x_prev);
                let x = if w.norm() > 1e-9 {
                    x
                } else {
                    perpendicular(x_prev, z, x)
                };
                (o, x, o + x * w.dot(&x))
            } else {
                let r = p - q;
                let b = z.dot(&zn);
                let (dd, e) = (z.dot(&r), zn.dot(&r));
                let den = 1.0 - b * b;
                let t = (b * e - dd) / den;
                let s = (e - b * dd) / den;
                let o = p + z * t;
                let qq = q + zn * s;
                let mut x = c.normalize();
                let w = qq - o;
                if (w.norm() > 1e-9 && w.dot(&x) < 0.0)
                    || (w.norm() <= 1e-9 && x.dot(&x_prev) < 0.0)
                {
                    x = -x;
                }
                (o, x, o + x * w.dot(&x))
            }
        } else {
            (foot, perpendicular(x_prev, z, Vector3::x()), foot)
        };
        frames.push(frame(o, x, z));
        foot = next_foot;
        x_prev = x;
    }
    // Rows, then the frames rebuilt from the rows (what the model computes).
    let mut joints = Vec::with_capacity(n);
    let mut f = f0;
    let mut link_in_frame = Vec::with_capacity(n);
    let mut prev = f0;
    for i in 0..n {
        let [alpha, a, beta, theta, d] = row_of(&(prev.inverse() * frames[i]));
        let beta = if beta.abs() < 1e-14 { 0.0 } else { beta };
        let (alpha_deg, theta_deg, beta_deg) = (deg(alpha), deg(theta), deg(beta));
        let (a, d) = (snap(a), snap(d));
        f *= row_transform(
            alpha_deg.to_radians(),
            a,
            beta_deg.to_radians(),
            theta_deg.to_radians(),
            d,
        );
        link_in_frame.push(f.inverse() * links[i]);
        prev = frames[i];
        let j = revolute[i];
        joints.push(JointSpec {
            alpha_deg,
            a_mm: a,
            theta_deg,
            d_mm: d,
            beta_deg: (beta_deg != 0.0).then_some(beta_deg),
            limits_deg: match (j.kind.as_str(), j.limits) {
                ("revolute", Some([lo, hi])) if lo < hi => Some([limit_deg(lo), limit_deg(hi)]),
                _ => None,
            },
        });
    }
    let tip_in_last_link = links[n - 1].inverse() * tip;
    let tool = f.inverse() * tip;
    let point = tool.transform_point(&Point3::from(tool_mm));
    let [r, p, y] = rpy_of(&tool.rotation);
    let file = RobotFile {
        name: name.to_string(),
        joints,
        tool: ToolSpec {
            xyz_mm: [snap(point.x), snap(point.y), snap(point.z)],
            rpy_deg: Some([deg(r), deg(p), deg(y)]),
            unknown: false,
        },
        tools: Vec::new(),
        base: Some(base),
        effects: Vec::new(),
        couplings: Vec::new(),
        prior: None,
    };
    Imported {
        file,
        base: f0,
        link_in_frame,
        before,
        tip_in_last_link,
        joint_names: revolute.iter().map(|j| j.name.clone()).collect(),
    }
}
