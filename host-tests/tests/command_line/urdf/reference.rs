//! The independent reference: each URDF joint composed as origin·Rot(axis, q), its own matrices.

use super::*;

fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn rot_y(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A homogeneous transform in millimetres from a rotation and a translation in metres.
fn homogeneous(r: Matrix3<f64>, xyz_m: [f64; 3]) -> Matrix4<f64> {
    let mut t = Matrix4::identity();
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    t[(0, 3)] = xyz_m[0] * 1000.0;
    t[(1, 3)] = xyz_m[1] * 1000.0;
    t[(2, 3)] = xyz_m[2] * 1000.0;
    t
}

/// URDF `<origin>`: Rz(yaw)·Ry(pitch)·Rx(roll), then the translation.
pub(super) fn origin(p: &urdf_rs::Pose) -> Matrix4<f64> {
    let r = p.rpy.0;
    homogeneous(rot_z(r[2]) * rot_y(r[1]) * rot_x(r[0]), p.xyz.0)
}

/// The reference chain from `base` to `tip`: joints base first.
pub(super) struct RefChain {
    joints: Vec<urdf_rs::Joint>,
}

impl RefChain {
    pub(super) fn new(text: &str, base: &str, tip: &str) -> RefChain {
        let robot = urdf_rs::read_from_string(text).expect("urdf-rs reads the file");
        let mut joints = Vec::new();
        let mut link = tip.to_string();
        while link != base {
            let j = robot
                .joints
                .iter()
                .find(|j| j.child.link == link)
                .unwrap_or_else(|| panic!("no joint has child {link}"))
                .clone();
            link = j.parent.link.clone();
            joints.push(j);
        }
        joints.reverse();
        RefChain { joints }
    }

    pub(super) fn movable(&self) -> Vec<&urdf_rs::Joint> {
        self.joints
            .iter()
            .filter(|j| !matches!(j.joint_type, urdf_rs::JointType::Fixed))
            .collect()
    }

    /// Pose of the tip link in the base link (mm) at joint angles `q` (radians, movable joints
    /// in chain order).
    pub(super) fn pose(&self, q: &[f64]) -> Matrix4<f64> {
        let mut t = Matrix4::identity();
        let mut k = 0;
        for j in &self.joints {
            t *= origin(&j.origin);
            if !matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                let axis = Unit::new_normalize(Vector3::from(j.axis.xyz.0));
                let r = Rotation3::from_axis_angle(&axis, q[k]).into_inner();
                t *= homogeneous(r, [0.0; 3]);
                k += 1;
            }
        }
        t
    }

    /// Joint limits (radians); continuous joints ±π.
    pub(super) fn limits(&self) -> Vec<[f64; 2]> {
        self.movable()
            .iter()
            .map(|j| match j.joint_type {
                urdf_rs::JointType::Revolute => [j.limit.lower, j.limit.upper],
                _ => [-std::f64::consts::PI, std::f64::consts::PI],
            })
            .collect()
    }
}

pub(super) fn point_of(t: &Matrix4<f64>, p_mm: [f64; 3]) -> Vector3<f64> {
    (t * Vector4::new(p_mm[0], p_mm[1], p_mm[2], 1.0)).xyz()
}

pub(super) fn rotation_of(t: &Matrix4<f64>) -> Matrix3<f64> {
    t.fixed_view::<3, 3>(0, 0).into_owned()
}

/// The angle between two rotations (radians).
pub(super) fn angle_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let m = a.transpose() * b;
    let c = ((m.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    let s = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
    .norm()
        / 2.0;
    s.atan2(c)
}
