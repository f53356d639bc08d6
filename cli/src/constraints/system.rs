//! The weighted residuals of a constraint session and their Jacobian, model columns from the
//! library's analytic identification columns (`ForwardKinematics::column`), nuisance columns
//! (socket centres, planes) after them:
//!
//! - socket row: `(p − c) / σ` (3 rows), ∂/∂c = −I/σ;
//! - plane row: `(n·p − d) / σ`, ∂/∂(tilt along t₁, t₂) = p·t₁/σ, p·t₂/σ, ∂/∂d = −1/σ;
//! - distance group: `(|p_a − p_b| − L) / σ`, model columns `u·(J_a − J_b)/σ`, u the unit
//!   vector from b to a;
//! - point row: `(p − x) / σ` (3 rows).

use super::read::{Group, Kind, Row};
use super::shapes::{tangents, Shape};
use crate::HostRobot;
use kinecal::{ForwardKinematics, Param};
use nalgebra::{DMatrix, DVector, Vector3};

/// Number of residual rows of `groups`.
pub fn rows<const N: usize>(groups: &[Group<N>]) -> usize {
    groups
        .iter()
        .map(|g| match g.kind {
            Kind::Socket | Kind::Point => 3 * g.rows.len(),
            Kind::Plane => g.rows.len(),
            Kind::Distance => 1,
        })
        .sum()
}

/// Weighted residuals and, with `jacobian`, their Jacobian (model columns for `params` first,
/// then each shape's unknowns in group order).
pub fn evaluate<const N: usize>(
    robot: &HostRobot<N>,
    groups: &[Group<N>],
    shapes: &[Shape],
    params: &[Param],
    jacobian: bool,
) -> anyhow::Result<(DVector<f64>, DMatrix<f64>)> {
    let m = rows(groups);
    let np = params.len();
    let nk: usize = shapes.iter().map(Shape::unknowns).sum();
    let mut r = DVector::zeros(m);
    let mut jac = if jacobian {
        DMatrix::zeros(m, np + nk)
    } else {
        DMatrix::zeros(0, 0)
    };
    let mut fk = ForwardKinematics::<f64, N>::new();
    // Point and model columns of one row, at its temperature.
    let mut at = |rw: &Row<N>| -> anyhow::Result<(Vector3<f64>, Vec<Vector3<f64>>)> {
        let p = fk
            .compute_at(robot, &rw.q, rw.tool, rw.temp_c)
            .ok_or_else(|| anyhow::anyhow!("tool point {} is not in the robot file", rw.tool))?;
        let cols = if jacobian {
            params
                .iter()
                .map(|&k| fk.column(robot, k))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| anyhow::anyhow!("Jacobian column: {e:?}"))?
        } else {
            Vec::new()
        };
        Ok((p, cols))
    };
    let (mut row, mut nuisance) = (0, np);
    for (g, shape) in groups.iter().zip(shapes) {
        match (g.kind, shape) {
            (Kind::Socket, Shape::Centre(c)) => {
                for rw in &g.rows {
                    let w = 1.0 / rw.sigma_mm;
                    let (p, cols) = at(rw)?;
                    for a in 0..3 {
                        r[row + a] = (p[a] - c[a]) * w;
                        if jacobian {
                            for (k, col) in cols.iter().enumerate() {
                                jac[(row + a, k)] = col[a] * w;
                            }
                            jac[(row + a, nuisance + a)] = -w;
                        }
                    }
                    row += 3;
                }
            }
            (Kind::Plane, Shape::Plane(n, d)) => {
                let (t1, t2) = tangents(n);
                for rw in &g.rows {
                    let w = 1.0 / rw.sigma_mm;
                    let (p, cols) = at(rw)?;
                    r[row] = (n.dot(&p) - d) * w;
                    if jacobian {
                        for (k, col) in cols.iter().enumerate() {
                            jac[(row, k)] = n.dot(col) * w;
                        }
                        jac[(row, nuisance)] = t1.dot(&p) * w;
                        jac[(row, nuisance + 1)] = t2.dot(&p) * w;
                        jac[(row, nuisance + 2)] = -w;
                    }
                    row += 1;
                }
            }
            (Kind::Distance, _) => {
                let (a, b) = (&g.rows[0], &g.rows[1]);
                let w = 1.0 / a.sigma_mm;
                let (pa, ca) = at(a)?;
                let (pb, cb) = at(b)?;
                let v = pa - pb;
                let len = v.norm();
                r[row] = (len - g.length_mm.unwrap_or(f64::NAN)) * w;
                if jacobian && len > 0.0 {
                    let u = v / len;
                    for k in 0..np {
                        jac[(row, k)] = u.dot(&(ca[k] - cb[k])) * w;
                    }
                }
                row += 1;
            }
            (Kind::Point, _) => {
                for rw in &g.rows {
                    let w = 1.0 / rw.sigma_mm;
                    let (p, cols) = at(rw)?;
                    let x = rw.xyz.unwrap_or([f64::NAN; 3]);
                    for a in 0..3 {
                        r[row + a] = (p[a] - x[a]) * w;
                        if jacobian {
                            for (k, col) in cols.iter().enumerate() {
                                jac[(row + a, k)] = col[a] * w;
                            }
                        }
                    }
                    row += 3;
                }
            }
            _ => anyhow::bail!("group `{}`: its shape does not match its kind", g.name),
        }
        nuisance += shape.unknowns();
    }
    Ok((r, jac))
}

/// `shapes` moved by the nuisance step `delta` (in the order of [`evaluate`]'s columns): a
/// centre by its three entries, a plane's normal tilted along its tangents and renormalised,
/// its offset shifted.
pub fn step_shapes(shapes: &[Shape], delta: &[f64]) -> Vec<Shape> {
    let mut k = 0;
    shapes
        .iter()
        .map(|s| {
            let out = match s {
                Shape::Centre(c) => {
                    Shape::Centre(c + Vector3::new(delta[k], delta[k + 1], delta[k + 2]))
                }
                Shape::Plane(n, d) => {
                    let (t1, t2) = tangents(n);
                    Shape::Plane(
                        (n + t1 * delta[k] + t2 * delta[k + 1]).normalize(),
                        d + delta[k + 2],
                    )
                }
                Shape::None => Shape::None,
            };
            k += s.unknowns();
            out
        })
        .collect()
}
