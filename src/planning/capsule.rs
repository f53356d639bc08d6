//! Capsules (swept spheres) and the segment–segment distance they need.
//!
//! Robot links, obstacles and the tracker's laser beam are approximated by capsules, as in
//! Jost et al. 2017 after Bosscher & Hedman: two capsules are apart exactly when the distance
//! between their axis segments exceeds the sum of their radii. The segment distance follows
//! Lumelsky (1985): the degenerate cases (a segment that is a point, parallel segments) are
//! treated first, so the general formula never divides by a vanishing denominator.

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::{Frame, Real};
use nalgebra::Vector3;

/// Closest points of two segments: the distance and the parameters `s`, `t ∈ [0, 1]` of the
/// closest points `p0 + s·(p1 − p0)` and `q0 + t·(q1 − q0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest<T: Real> {
    /// Distance between the closest points (mm).
    pub distance: T,
    /// Parameter of the closest point on the first segment.
    pub s: T,
    /// Parameter of the closest point on the second segment.
    pub t: T,
}

fn clamp01<T: Real>(x: T) -> T {
    if x > T::one() {
        T::one()
    } else if x > T::zero() {
        x
    } else {
        // Also maps NaN to 0, so a bad input cannot spread through the parameters.
        T::zero()
    }
}

/// Distance between the segments `[p0, p1]` and `[q0, q1]` (Lumelsky 1985).
///
/// Robust for segments that degenerate to points and for parallel or collinear segments
/// (then one of the equally close pairs is returned). Non-finite input gives a non-finite
/// distance, never a panic.
pub fn segment_distance<T: Real>(
    p0: &Vector3<T>,
    p1: &Vector3<T>,
    q0: &Vector3<T>,
    q1: &Vector3<T>,
) -> Closest<T> {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    // A segment shorter than rounding noise relative to the scene is a point.
    let scale = a.max(e).max(r.norm_squared()).max(T::one());
    let tiny = T::EPS * T::EPS * scale;
    let (s, t);
    if a <= tiny && e <= tiny {
        s = T::zero();
        t = T::zero();
    } else if a <= tiny {
        s = T::zero();
        t = clamp01(f / e);
    } else {
        let c = d1.dot(&r);
        if e <= tiny {
            t = T::zero();
            s = clamp01(-c / a);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            // Parallel (sin² of the angle below rounding): any s works, start at p0.
            let s0 = if denom > T::EPS * a * e {
                clamp01((b * f - c * e) / denom)
            } else {
                T::zero()
            };
            let t0 = (b * s0 + f) / e;
            if t0 < T::zero() {
                t = T::zero();
                s = clamp01(-c / a);
            } else if t0 > T::one() {
                t = T::one();
                s = clamp01((b - c) / a);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    let distance = ((p0 + d1 * s) - (q0 + d2 * t)).norm();
    Closest { distance, s, t }
}

/// A capsule: all points within `radius` of the segment `[a, b]` (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule<T: Real> {
    /// One end of the segment.
    pub a: Vector3<T>,
    /// The other end of the segment.
    pub b: Vector3<T>,
    /// Radius around the segment (≥ 0).
    pub radius: T,
}

impl<T: Real> Capsule<T> {
    /// The capsule of radius `radius` around `[a, b]` (not checked: see [`Capsule::is_valid`]).
    pub fn new(a: Vector3<T>, b: Vector3<T>, radius: T) -> Self {
        Self { a, b, radius }
    }

    /// True when every number is finite and the radius is not negative.
    pub fn is_valid(&self) -> bool {
        self.a.iter().chain(self.b.iter()).all(|v| v.finite())
            && self.radius.finite()
            && self.radius >= T::zero()
    }

    /// The same capsule with its end points mapped from `frame` to the frame's parent.
    pub fn placed(&self, frame: &Frame<T>) -> Self {
        Self {
            a: frame.point(&self.a),
            b: frame.point(&self.b),
            radius: self.radius,
        }
    }

    /// Surface-to-surface distance (negative when the capsules overlap, by the depth along the
    /// closest axis points).
    pub fn clearance(&self, other: &Capsule<T>) -> T {
        segment_distance(&self.a, &self.b, &other.a, &other.b).distance - self.radius - other.radius
    }

    /// Height of the capsule's lowest surface point above the plane `z = floor_z`
    /// (negative when it reaches below).
    pub fn clearance_above(&self, floor_z: T) -> T {
        self.a.z.min(self.b.z) - floor_z - self.radius
    }
}
