//! Circles in space from measured points: the circle-point method's building block.
//!
//! A tracker target on a link that turns about one joint traces a circle whose normal through
//! the centre is the joint's axis. The fit runs in three stages so it needs no starting guess:
//! the plane by least squares (smallest eigenvector of the scatter matrix), the circle in that
//! plane by the algebraic Kåsa fit (linear, but biased on short arcs), then Levenberg–Marquardt
//! on the true geometric distances, which removes the bias and refines the plane as well.
//! The last stage's Jacobian also gives standard deviations, so callers can tell a sweep that is
//! too short or too noisy from one they can trust.
//!
//! ```
//! use kinecal::frames::circle::fit_circle;
//! use nalgebra::Vector3;
//!
//! // A reflector 250 mm from a joint axis through (1000, -200, 300) along z, turned over
//! // 100° in 10° steps (a short arc: the Kåsa stage alone would be biased on noisy data).
//! let points: Vec<Vector3<f64>> = (0..=10)
//!     .map(|k| {
//!         let t = (10.0 * k as f64).to_radians();
//!         Vector3::new(1000.0 + 250.0 * t.cos(), -200.0 + 250.0 * t.sin(), 300.0)
//!     })
//!     .collect();
//! let c = fit_circle(&points).unwrap();
//! assert!((c.centre - Vector3::new(1000.0, -200.0, 300.0)).norm() < 1e-6);
//! assert!((c.radius - 250.0).abs() < 1e-6);
//! assert!((c.normal.z.abs() - 1.0).abs() < 1e-9); // the axis, up to its sign
//! assert!(c.rms < 1e-6);
//! assert_eq!(c.points, 11);
//!
//! // Three points cannot give a noise estimate.
//! assert!(fit_circle(&points[..3]).is_err());
//! ```

use crate::num::linalg::{cholesky, cholesky_solve, symmetric_eigen, Square};
use crate::Real;
use nalgebra::Vector3;

/// Fewest points [`fit_circle`] accepts: 6 unknowns, 2 residuals per point, and at least one
/// residual left over to estimate the noise.
pub const MIN_POINTS: usize = 4;

/// Why a circle could not be fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CircleError {
    /// Fewer than [`MIN_POINTS`] points.
    TooFewPoints,
    /// A coordinate is NaN or infinite.
    NotFinite,
    /// The points coincide or lie on a straight line: no circle through them.
    Degenerate,
}

/// A circle in space with the quality of its fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle<T: Real> {
    /// Centre of the circle (mm).
    pub centre: Vector3<T>,
    /// Unit normal of the circle's plane; its sign is arbitrary here (a joint axis orients it).
    pub normal: Vector3<T>,
    /// Radius (mm).
    pub radius: T,
    /// RMS geometric distance of the points from the circle (mm).
    pub rms: T,
    /// Standard deviation of the centre (mm, root of the trace of its 3 × 3 covariance),
    /// estimated from the residuals.
    pub sd_centre: T,
    /// Standard deviation of the normal's direction (rad, tilt in any direction).
    pub sd_normal: T,
    /// Standard deviation of the radius (mm).
    pub sd_radius: T,
    /// Number of points fitted.
    pub points: usize,
}

impl<T: Real> Circle<T> {
    /// Geometric distance of `p` from the circle: `√(h² + (ρ − r)²)` with `h` the height above
    /// the plane and `ρ` the distance from the normal through the centre.
    pub fn distance(&self, p: &Vector3<T>) -> T {
        let d = p - self.centre;
        let h = d.dot(&self.normal);
        let rho = (d - self.normal * h).norm();
        (h * h + (rho - self.radius) * (rho - self.radius)).sqrt()
    }
}

/// Fits a circle to `points` (see the module documentation for the method).
pub fn fit_circle<T: Real>(points: &[Vector3<T>]) -> Result<Circle<T>, CircleError> {
    fit_circle_with(points.len(), |i| points.get(i).copied().unwrap_or_default())
}

/// [`fit_circle`] over `n` points read through `point(i)`, `i < n`: fits points stored inside
/// other records (for example measurements) without copying them.
pub fn fit_circle_with<T: Real, F: Fn(usize) -> Vector3<T>>(
    n: usize,
    point: F,
) -> Result<Circle<T>, CircleError> {
    if n < MIN_POINTS {
        return Err(CircleError::TooFewPoints);
    }
    // Centroid, and everything after relative to it and scaled by the RMS spread, so f32
    // keeps its digits on tracker coordinates metres from the origin.
    let nt = T::of(n as f64);
    let mut centroid = Vector3::zeros();
    for i in 0..n {
        let p = point(i);
        if !p.iter().all(|c| c.finite()) {
            return Err(CircleError::NotFinite);
        }
        centroid += p;
    }
    centroid /= nt;
    let mut scatter: Square<T, 3> = [[T::zero(); 3]; 3];
    for i in 0..n {
        let d = point(i) - centroid;
        for (r, row) in scatter.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v += d[r] * d[c];
            }
        }
    }
    let spread2 = (scatter[0][0] + scatter[1][1] + scatter[2][2]) / nt;
    if !(spread2 > T::zero()) || !spread2.finite() {
        return Err(CircleError::Degenerate);
    }
    let s = spread2.sqrt();
    let mut values = [T::zero(); 3];
    let mut vectors: Square<T, 3> = [[T::zero(); 3]; 3];
    symmetric_eigen(&mut scatter, 3, &mut values, &mut vectors)
        .map_err(|_| CircleError::Degenerate)?;
    let column = |k: usize| Vector3::new(vectors[0][k], vectors[1][k], vectors[2][k]);
    // Ascending eigenvalues: normal = smallest; in-plane axes = the other two.
    if !(values[1] > T::EPS * T::of(100.0) * values[2]) {
        return Err(CircleError::Degenerate);
    }
    let normal = unit(column(0)).ok_or(CircleError::Degenerate)?;
    let e1 = unit(column(2)).ok_or(CircleError::Degenerate)?;
    let e2 = normal.cross(&e1);

    let scaled = |i: usize| (point(i) - centroid) / s;
    let (c2, r) = kasa(n, &scaled, &e1, &e2)?;
    let start = Params {
        c: e1 * c2[0] + e2 * c2[1],
        n: normal,
        r,
    };
    let (best, cost, jtj) = refine(n, &scaled, start);

    // Standard deviations from σ²·(JᵀJ)⁻¹ with σ² from the residuals (2 per point).
    let inf = T::of(f64::INFINITY);
    let dof = 2 * n - 6;
    let sigma2 = cost / T::of(dof as f64);
    let mut sd = [inf; 6];
    let mut l = jtj;
    if cholesky(&mut l, 6).is_ok() {
        for (k, sdk) in sd.iter_mut().enumerate() {
            let mut e = [T::zero(); 6];
            e[k] = T::one();
            if cholesky_solve(&l, 6, &mut e).is_ok() {
                *sdk = (sigma2 * e[k]).max(T::zero());
            }
        }
    }
    Ok(Circle {
        centre: centroid + best.c * s,
        normal: best.n,
        radius: best.r * s,
        rms: (cost / nt).sqrt() * s,
        sd_centre: (sd[0] + sd[1] + sd[2]).sqrt() * s,
        sd_normal: (sd[3] + sd[4]).sqrt(),
        sd_radius: sd[5].sqrt() * s,
        points: n,
    })
}

/// `v / |v|`, or `None` for a zero or non-finite vector.
pub(crate) fn unit<T: Real>(v: Vector3<T>) -> Option<Vector3<T>> {
    let l = v.norm();
    if l > T::zero() && l.finite() {
        Some(v / l)
    } else {
        None
    }
}

/// Kåsa's algebraic fit in the plane spanned by `e1`, `e2`: least squares of
/// `u² + v² = A·u + B·v + C`, centre `(A/2, B/2)`, `r² = C + (A² + B²)/4`.
fn kasa<T: Real, F: Fn(usize) -> Vector3<T>>(
    n: usize,
    p: &F,
    e1: &Vector3<T>,
    e2: &Vector3<T>,
) -> Result<([T; 2], T), CircleError> {
    let mut a: Square<T, 3> = [[T::zero(); 3]; 3];
    let mut b = [T::zero(); 3];
    for i in 0..n {
        let d = p(i);
        let (u, v) = (d.dot(e1), d.dot(e2));
        let row = [u, v, T::one()];
        let z = u * u + v * v;
        for r in 0..3 {
            for c in 0..3 {
                a[r][c] += row[r] * row[c];
            }
            b[r] += row[r] * z;
        }
    }
    cholesky(&mut a, 3).map_err(|_| CircleError::Degenerate)?;
    cholesky_solve(&a, 3, &mut b).map_err(|_| CircleError::Degenerate)?;
    let half = T::of(0.5);
    let (cu, cv) = (b[0] * half, b[1] * half);
    let r2 = b[2] + cu * cu + cv * cv;
    if !(r2 > T::zero()) || !r2.finite() {
        return Err(CircleError::Degenerate);
    }
    Ok(([cu, cv], r2.sqrt()))
}

#[derive(Clone, Copy)]
struct Params<T: Real> {
    c: Vector3<T>,
    n: Vector3<T>,
    r: T,
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
pub(crate) fn basis<T: Real>(n: &Vector3<T>) -> (Vector3<T>, Vector3<T>) {
    let helper = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
        Vector3::x()
    } else if n.y.abs() <= n.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let e1 = unit(helper - n * n.dot(&helper)).unwrap_or(Vector3::x());
    (e1, n.cross(&e1))
}

/// Sum of squared residuals (`h`, `ρ − r` per point) and, when `normal` is given, the
/// Gauss–Newton normal equations in the local parameters (δc, tilt about e1/e2 of the basis, δr).
fn evaluate<T: Real, F: Fn(usize) -> Vector3<T>>(
    n: usize,
    p: &F,
    x: &Params<T>,
    normal: Option<(&mut Square<T, 6>, &mut [T; 6])>,
) -> T {
    let (e1, e2) = basis(&x.n);
    let mut cost = T::zero();
    let mut ne = normal;
    for i in 0..n {
        let d = p(i) - x.c;
        let h = d.dot(&x.n);
        let w = d - x.n * h;
        let rho = w.norm();
        let wh = if rho > T::zero() { w / rho } else { e1 };
        let er = rho - x.r;
        cost += h * h + er * er;
        if let Some((jtj, jte)) = ne.as_mut() {
            let jh = [-x.n.x, -x.n.y, -x.n.z, d.dot(&e1), d.dot(&e2), T::zero()];
            let jr = [
                -wh.x,
                -wh.y,
                -wh.z,
                -h * wh.dot(&e1),
                -h * wh.dot(&e2),
                -T::one(),
            ];
            for r in 0..6 {
                for c in 0..6 {
                    jtj[r][c] += jh[r] * jh[c] + jr[r] * jr[c];
                }
                jte[r] += jh[r] * h + jr[r] * er;
            }
        }
    }
    cost
}

fn apply<T: Real>(x: &Params<T>, d: &[T; 6]) -> Option<Params<T>> {
    let (e1, e2) = basis(&x.n);
    let n = unit(x.n + e1 * d[3] + e2 * d[4])?;
    let r = x.r + d[5];
    let c = x.c + Vector3::new(d[0], d[1], d[2]);
    if !(r > T::zero()) || !c.iter().all(|v| v.finite()) {
        return None;
    }
    Some(Params { c, n, r })
}

/// Levenberg–Marquardt on the geometric residuals; returns the solution, its cost and the
/// undamped `JᵀJ` there (for the covariance).
fn refine<T: Real, F: Fn(usize) -> Vector3<T>>(
    n: usize,
    p: &F,
    start: Params<T>,
) -> (Params<T>, T, Square<T, 6>) {
    let mut x = start;
    let mut jtj: Square<T, 6> = [[T::zero(); 6]; 6];
    let mut jte = [T::zero(); 6];
    let mut cost = evaluate(n, p, &x, Some((&mut jtj, &mut jte)));
    let mut lambda = T::of(1e-3);
    let tiny = T::EPS * T::EPS * T::of(n as f64);
    for _ in 0..200 {
        if !(cost > tiny) {
            break;
        }
        let mut a = jtj;
        for (k, row) in a.iter_mut().enumerate() {
            row[k] += lambda * (jtj[k][k] + T::EPS);
        }
        let mut step = jte.map(|v| -v);
        let solved = cholesky(&mut a, 6).is_ok() && cholesky_solve(&a, 6, &mut step).is_ok();
        let candidate = if solved { apply(&x, &step) } else { None };
        let Some(cand) = candidate else {
            lambda *= T::of(10.0);
            if lambda > T::of(1e12) {
                break;
            }
            continue;
        };
        let mut jtj2: Square<T, 6> = [[T::zero(); 6]; 6];
        let mut jte2 = [T::zero(); 6];
        let c2 = evaluate(n, p, &cand, Some((&mut jtj2, &mut jte2)));
        if c2.finite() && c2 < cost {
            let gain = cost - c2;
            x = cand;
            jtj = jtj2;
            jte = jte2;
            let old = cost;
            cost = c2;
            lambda = (lambda / T::of(3.0)).max(T::of(1e-12));
            let small =
                step.iter().fold(T::zero(), |m, v| m.max(v.abs())) < T::EPS.sqrt() * T::of(1e-2);
            if gain <= old * T::EPS * T::of(64.0) || small {
                break;
            }
        } else {
            lambda *= T::of(4.0);
            if lambda > T::of(1e12) {
                break;
            }
        }
    }
    (x, cost, jtj)
}
