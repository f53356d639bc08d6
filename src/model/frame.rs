//! Rigid frames: three unit axes and an origin, the way a kinematics text draws them.

use crate::Real;
use nalgebra::{Matrix3, Vector3};

/// How far a frame's axes may be from orthonormal and right-handed for [`Frame::is_rotation`]:
/// on `|x|² − 1`, `|y|² − 1`, `x·y` and each component of `x × y − z`. Loose enough for axes
/// rounded to `f32` or written with six digits, tight enough to refuse a scaled or sheared frame.
pub const ROTATION_TOLERANCE: f64 = 1e-4;

/// A right-handed frame expressed in a parent frame: `x`, `y`, `z` are the columns of the
/// rotation, `o` the origin. Kept as axes because every Jacobian column is built from them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<T: Real> {
    /// Unit x axis, in the parent frame.
    pub x: Vector3<T>,
    /// Unit y axis, in the parent frame.
    pub y: Vector3<T>,
    /// Unit z axis, in the parent frame.
    pub z: Vector3<T>,
    /// Origin, in the parent frame (mm).
    pub o: Vector3<T>,
}

impl<T: Real> Default for Frame<T> {
    fn default() -> Self {
        Self::identity()
    }
}

impl<T: Real> Frame<T> {
    /// The parent frame itself: no rotation, origin at zero.
    pub fn identity() -> Self {
        Self {
            x: Vector3::x(),
            y: Vector3::y(),
            z: Vector3::z(),
            o: Vector3::zeros(),
        }
    }

    /// From a rotation matrix and a translation.
    pub fn from_parts(r: &Matrix3<T>, o: Vector3<T>) -> Self {
        Self {
            x: r.column(0).into_owned(),
            y: r.column(1).into_owned(),
            z: r.column(2).into_owned(),
            o,
        }
    }

    /// The rotation matrix `[x y z]`.
    pub fn rotation(&self) -> Matrix3<T> {
        Matrix3::from_columns(&[self.x, self.y, self.z])
    }

    /// Maps a point given in this frame to the parent frame.
    #[inline(always)]
    pub fn point(&self, p: &Vector3<T>) -> Vector3<T> {
        self.o + self.x * p.x + self.y * p.y + self.z * p.z
    }

    /// Maps a direction given in this frame to the parent frame.
    #[inline(always)]
    pub fn direction(&self, v: &Vector3<T>) -> Vector3<T> {
        self.x * v.x + self.y * v.y + self.z * v.z
    }

    /// `self · other`: `other` is expressed in `self`.
    pub fn compose(&self, other: &Frame<T>) -> Frame<T> {
        Frame {
            x: self.direction(&other.x),
            y: self.direction(&other.y),
            z: self.direction(&other.z),
            o: self.point(&other.o),
        }
    }

    /// The inverse transform (parent expressed in this frame).
    pub fn inverse(&self) -> Frame<T> {
        let rt = self.rotation().transpose();
        Frame::from_parts(&rt, -(rt * self.o))
    }

    /// Frame from a translation and fixed-axis roll (x), pitch (y), yaw (z) in radians:
    /// `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, the convention of the robot file's `rpy_deg`.
    pub fn from_xyz_rpy(xyz: [T; 3], rpy: [T; 3]) -> Self {
        let (sr, cr) = rpy[0].sincos();
        let (sp, cp) = rpy[1].sincos();
        let (sy, cy) = rpy[2].sincos();
        let r = Matrix3::new(
            cy * cp,
            cy * sp * sr - sy * cr,
            cy * sp * cr + sy * sr,
            sy * cp,
            sy * sp * sr + cy * cr,
            sy * sp * cr - cy * sr,
            -sp,
            cp * sr,
            cp * cr,
        );
        Frame::from_parts(&r, Vector3::new(xyz[0], xyz[1], xyz[2]))
    }

    /// Roll, pitch, yaw (radians) of this frame's rotation, inverse of [`Frame::from_xyz_rpy`].
    /// At pitch = ±90° roll is set to 0 and yaw carries the whole rotation about z.
    pub fn rpy(&self) -> [T; 3] {
        let r20 = self.x.z;
        let one = T::one();
        let s = if r20 > one {
            one
        } else if r20 < -one {
            -one
        } else {
            r20
        };
        let pitch = -s.asin();
        let cp = pitch.cos();
        if cp > T::of(1e-9) {
            let roll = self.y.z.atan2(self.z.z);
            let yaw = self.x.y.atan2(self.x.x);
            [roll, pitch, yaw]
        } else {
            [T::zero(), pitch, (-self.y.x).atan2(self.y.y)]
        }
    }

    /// Rotates the frame about its own origin by the rotation vector `w` given in the parent
    /// frame (`R ← exp([w]×)·R`): the update identification applies to the base pose.
    pub fn rotate_in_parent(&mut self, w: &Vector3<T>) {
        let angle = w.norm();
        if angle <= T::zero() || !angle.finite() {
            return;
        }
        let k = w / angle;
        let (s, c) = angle.sincos();
        let rot = |v: &Vector3<T>| -> Vector3<T> {
            // Rodrigues' formula.
            *v * c + k.cross(v) * s + k * (k.dot(v) * (T::one() - c))
        };
        self.x = rot(&self.x);
        self.y = rot(&self.y);
        self.z = rot(&self.z);
        self.orthonormalize();
    }

    /// Removes accumulated rounding from the axes (Gram–Schmidt, keeps `z` then `x`).
    pub fn orthonormalize(&mut self) {
        let zn = self.z.norm();
        if zn > T::zero() {
            self.z /= zn;
        }
        self.x -= self.z * self.z.dot(&self.x);
        let xn = self.x.norm();
        if xn > T::zero() {
            self.x /= xn;
        }
        self.y = self.z.cross(&self.x);
    }

    /// True when the axes are finite, orthonormal and right-handed (a rotation, `det = +1`)
    /// within [`ROTATION_TOLERANCE`]; NaN or infinite axes give false.
    pub fn is_rotation(&self) -> bool {
        let tol = T::of(ROTATION_TOLERANCE);
        let h = self.x.cross(&self.y) - self.z;
        [
            self.x.norm_squared() - T::one(),
            self.y.norm_squared() - T::one(),
            self.x.dot(&self.y),
            h.x,
            h.y,
            h.z,
        ]
        .iter()
        .all(|e| e.abs() <= tol)
    }

    /// Casts to another scalar type; `None` when a component is not finite in `U` (an `f64`
    /// origin beyond `f32`'s range, or a non-finite frame).
    pub fn cast<U: Real>(&self) -> Option<Frame<U>> {
        let f = self.cast_unchecked::<U>();
        [f.x, f.y, f.z, f.o]
            .iter()
            .all(|v| v.iter().all(|c| c.finite()))
            .then_some(f)
    }

    /// Casts without checking (the caller checks the result).
    pub(crate) fn cast_unchecked<U: Real>(&self) -> Frame<U> {
        let c = |v: &Vector3<T>| {
            Vector3::new(
                U::of(v.x.to_f64()),
                U::of(v.y.to_f64()),
                U::of(v.z.to_f64()),
            )
        };
        Frame {
            x: c(&self.x),
            y: c(&self.y),
            z: c(&self.z),
            o: c(&self.o),
        }
    }
}

/// `(sin θ · axis, cos θ)` of the rotation `R_a · R_bᵀ` that takes frame `b`'s orientation to
/// frame `a`'s: the cheap form of the orientation error (no trigonometry, no square root).
pub fn orientation_sin_cos<T: Real>(a: &Frame<T>, b: &Frame<T>) -> (Vector3<T>, T) {
    let r = a.rotation() * b.rotation().transpose();
    let half = T::of(0.5);
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) * half;
    (v, (r.trace() - T::one()) * half)
}

/// Rotation vector (axis × angle) of `R_a · R_bᵀ`: the small orientation error that takes
/// frame `b`'s orientation to frame `a`'s, in the parent frame.
pub fn orientation_error<T: Real>(a: &Frame<T>, b: &Frame<T>) -> Vector3<T> {
    let (v, c) = orientation_sin_cos(a, b);
    let s = v.norm();
    if s <= T::of(1e-12) {
        return v;
    }
    let angle = s.atan2(c);
    v * (angle / s)
}
