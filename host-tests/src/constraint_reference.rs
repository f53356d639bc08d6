//! An independent reference of the constraint fit of docs/formats.md ("Constraint
//! measurements"): sockets, planes, distances and tracker points, fitted with a plain dense
//! Levenberg–Marquardt over every unknown at once.
//!
//! It shares nothing with the command line's constraint code nor with the library's
//! identification: the session file is read here, the forward kinematics are those of
//! [`crate::reference`] (4×4 matrices), the Jacobian is by central differences of the residuals
//! themselves, and the step is the damped pseudo-inverse of the column-scaled Jacobian by a
//! dense SVD. The unknowns:
//!
//! - the model parameters asked for (steps through [`RefRobot::perturbed`]);
//! - each socket's centre `c` (3): rows `(p − c)/σ`;
//! - each plane's unit normal, as two angles of a tilt about the current normal, and its offset
//!   `d` (3): rows `(n·p − d)/σ`;
//! - distances add none: `(|p_a − p_b| − L)/σ`; tracker points neither: `(p − x)/σ`.
//!
//! The step is the minimum-norm one: a direction the data cannot determine at all (a column of
//! rounding only, an exact redundancy such as the base from distances) gets no step instead of
//! blowing up, one the data barely see (the base rotations from sockets, the overall scale
//! from sockets and planes: seen only through the residuals' own size) only a damped one.

use crate::reference::RefRobot;
use kinecal::model::param::Param;
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, Vector3};

/// σ of a row without `sigma_mm` (mm), as docs/formats.md's reader takes it.
pub const DEFAULT_SIGMA_MM: f64 = 0.01;

/// Relative singular value (unit-norm columns) below which a direction gets no step.
pub const RCOND: f64 = 1e-9;

/// The kind of a group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RefKind {
    Socket,
    Plane,
    Distance,
    Point,
}

/// One row of a group: joint readings (rad), σ (mm), the tracker point of a `point` row.
#[derive(Clone, Debug, PartialEq)]
pub struct RefRow {
    pub q: Vec<f64>,
    pub sigma_mm: f64,
    pub xyz: Option<Vector3<f64>>,
}

/// A group of rows tied by its name.
#[derive(Clone, Debug, PartialEq)]
pub struct RefGroup {
    pub kind: RefKind,
    pub name: String,
    pub rows: Vec<RefRow>,
    /// A distance group's length (mm).
    pub length_mm: Option<f64>,
}

/// Reads a constraint session (CSV with a `kind` column, joint readings in degrees, lengths in
/// mm) of a robot with `joints` joints. Groups keep the order of their first row. Only the one
/// tool point of the robot (`tool` column absent).
pub fn read_session(text: &str, joints: usize) -> Result<Vec<RefGroup>, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or("empty file")?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    if col("tool").is_some() {
        return Err("the reference reads sessions of one tool point only".into());
    }
    let kind_col = col("kind").ok_or("no kind column")?;
    let group_col = col("group").ok_or("no group column")?;
    let q_cols: Vec<usize> = (1..=joints)
        .map(|j| col(&format!("q{j}")).ok_or(format!("no q{j} column")))
        .collect::<Result<_, _>>()?;
    let (length_col, sigma_col) = (col("length_mm"), col("sigma_mm"));
    let xyz_cols = [col("x"), col("y"), col("z")];
    let mut groups: Vec<RefGroup> = Vec::new();
    for (k, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |c: Option<usize>| c.and_then(|c| cells.get(c)).filter(|s| !s.is_empty());
        let number = |c: Option<usize>| -> Result<Option<f64>, String> {
            cell(c)
                .map(|s| {
                    s.parse::<f64>()
                        .map_err(|e| format!("row {}: {s}: {e}", k + 2))
                })
                .transpose()
        };
        let kind = match cell(Some(kind_col)).copied() {
            Some("socket") => RefKind::Socket,
            Some("plane") => RefKind::Plane,
            Some("distance") => RefKind::Distance,
            Some("point") => RefKind::Point,
            other => return Err(format!("row {}: kind {other:?}", k + 2)),
        };
        let name = cell(Some(group_col))
            .ok_or("a row without group")?
            .to_string();
        let q = q_cols
            .iter()
            .map(|&c| {
                number(Some(c))?
                    .map(f64::to_radians)
                    .ok_or(format!("row {}: a missing joint reading", k + 2))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        let xyz = match (
            number(xyz_cols[0])?,
            number(xyz_cols[1])?,
            number(xyz_cols[2])?,
        ) {
            (Some(x), Some(y), Some(z)) => Some(Vector3::new(x, y, z)),
            _ => None,
        };
        let row = RefRow {
            q,
            sigma_mm: number(sigma_col)?.unwrap_or(DEFAULT_SIGMA_MM),
            xyz,
        };
        let length_mm = number(length_col)?;
        match groups.iter_mut().find(|g| g.name == name) {
            Some(g) if g.kind == kind => g.rows.push(row),
            Some(_) => return Err(format!("group {name}: two kinds")),
            None => groups.push(RefGroup {
                kind,
                name,
                rows: vec![row],
                length_mm,
            }),
        }
    }
    for g in &groups {
        let ok = match g.kind {
            RefKind::Socket | RefKind::Plane => g.rows.len() >= 4,
            RefKind::Distance => g.rows.len() == 2 && g.length_mm.is_some(),
            RefKind::Point => g.rows.iter().all(|r| r.xyz.is_some()),
        };
        if !ok {
            return Err(format!("group {}: malformed {:?} group", g.name, g.kind));
        }
    }
    Ok(groups)
}

/// A group's own unknowns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RefShape {
    /// A socket centre (mm).
    Centre(Vector3<f64>),
    /// A plane `n·p = d`, `n` of unit length.
    Plane(Vector3<f64>, f64),
    /// Distances and tracker points have none.
    None,
}

impl RefShape {
    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        match self {
            RefShape::None => 0,
            _ => 3,
        }
    }

    /// The shape moved by `delta` (its [`Self::unknowns`] entries): a centre by the three
    /// entries; a plane's normal turned by the angles `delta[0]`, `delta[1]` towards two
    /// directions normal to it, its offset by `delta[2]`.
    pub fn moved(&self, delta: &[f64]) -> RefShape {
        match *self {
            RefShape::Centre(c) => RefShape::Centre(c + Vector3::new(delta[0], delta[1], delta[2])),
            RefShape::Plane(n, d) => {
                let (t1, t2) = normal_directions(&n);
                let (a, b) = (delta[0], delta[1]);
                let m = n * (a.cos() * b.cos()) + t1 * (a.sin() * b.cos()) + t2 * b.sin();
                RefShape::Plane(m.normalize(), d + delta[2])
            }
            RefShape::None => RefShape::None,
        }
    }
}

/// Two unit vectors normal to `n` and to each other.
fn normal_directions(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let k = n.iamin();
    let e = Vector3::from_fn(|i, _| if i == k { 1.0 } else { 0.0 });
    let t1 = n.cross(&e).normalize();
    (t1, n.cross(&t1).normalize())
}

/// The socket centre (the mean) or the least-squares plane (normal along the smallest
/// principal direction) of the points `pts`.
pub fn shape_through(kind: RefKind, pts: &[Vector3<f64>]) -> RefShape {
    let mean = pts.iter().sum::<Vector3<f64>>() / pts.len().max(1) as f64;
    match kind {
        RefKind::Socket => RefShape::Centre(mean),
        RefKind::Plane => {
            let mut m = Matrix3::zeros();
            for p in pts {
                m += (p - mean) * (p - mean).transpose();
            }
            let svd = m.svd(true, false);
            let k = svd.singular_values.imin();
            let n = svd
                .u
                .expect("U requested")
                .column(k)
                .into_owned()
                .normalize();
            RefShape::Plane(n, n.dot(&mean))
        }
        _ => RefShape::None,
    }
}

/// The shape of each group through the points `robot` predicts.
pub fn shapes_through(robot: &RefRobot, groups: &[RefGroup]) -> Vec<RefShape> {
    groups
        .iter()
        .map(|g| {
            let pts: Vec<Vector3<f64>> = g.rows.iter().map(|r| robot.point(&r.q)).collect();
            shape_through(g.kind, &pts)
        })
        .collect()
}

/// Number of residual rows of a group.
fn group_rows(g: &RefGroup) -> usize {
    match g.kind {
        RefKind::Socket | RefKind::Point => 3 * g.rows.len(),
        RefKind::Plane => g.rows.len(),
        RefKind::Distance => 1,
    }
}

/// The weighted residual rows of group `g` under `robot` and `shape`, appended to `out`.
pub fn group_residuals(robot: &RefRobot, g: &RefGroup, shape: &RefShape, out: &mut Vec<f64>) {
    match (g.kind, shape) {
        (RefKind::Socket, RefShape::Centre(c)) => {
            for r in &g.rows {
                let e = (robot.point(&r.q) - c) / r.sigma_mm;
                out.extend(e.iter());
            }
        }
        (RefKind::Plane, RefShape::Plane(n, d)) => {
            for r in &g.rows {
                out.push((n.dot(&robot.point(&r.q)) - d) / r.sigma_mm);
            }
        }
        (RefKind::Distance, _) => {
            let (a, b) = (&g.rows[0], &g.rows[1]);
            let len = (robot.point(&a.q) - robot.point(&b.q)).norm();
            out.push((len - g.length_mm.unwrap_or(f64::NAN)) / a.sigma_mm);
        }
        (RefKind::Point, _) => {
            for r in &g.rows {
                let x = r.xyz.unwrap_or(Vector3::repeat(f64::NAN));
                out.extend(((robot.point(&r.q) - x) / r.sigma_mm).iter());
            }
        }
        _ => panic!("group {}: shape {shape:?} does not fit its kind", g.name),
    }
}

/// Every group's weighted residual rows, in order.
pub fn residuals(robot: &RefRobot, groups: &[RefGroup], shapes: &[RefShape]) -> DVector<f64> {
    let mut out = Vec::with_capacity(groups.iter().map(group_rows).sum());
    for (g, s) in groups.iter().zip(shapes) {
        group_residuals(robot, g, s, &mut out);
    }
    DVector::from_vec(out)
}

/// Central-difference step of a model parameter: lengths in mm, angles in rad.
fn step_of(p: Param) -> f64 {
    if p.is_length() {
        1e-2
    } else {
        1e-5
    }
}

/// The Jacobian of [`residuals`] by central differences: the model parameters `params` first,
/// then each shape's unknowns in group order (only its own group's rows depend on them).
pub fn jacobian(
    robot: &RefRobot,
    params: &[Param],
    groups: &[RefGroup],
    shapes: &[RefShape],
) -> DMatrix<f64> {
    let m: usize = groups.iter().map(group_rows).sum();
    let nk: usize = shapes.iter().map(RefShape::unknowns).sum();
    let mut j = DMatrix::zeros(m, params.len() + nk);
    for (c, &p) in params.iter().enumerate() {
        let h = step_of(p);
        let plus = residuals(&robot.perturbed(p, h), groups, shapes);
        let minus = residuals(&robot.perturbed(p, -h), groups, shapes);
        j.set_column(c, &((plus - minus) / (2.0 * h)));
    }
    let (mut row, mut c) = (0, params.len());
    for (g, s) in groups.iter().zip(shapes) {
        let h = match s {
            RefShape::Centre(_) => [1e-2; 3],
            _ => [1e-6, 1e-6, 1e-2],
        };
        for k in 0..s.unknowns() {
            let mut d = [0.0; 3];
            d[k] = h[k];
            let (mut plus, mut minus) = (Vec::new(), Vec::new());
            group_residuals(robot, g, &s.moved(&d), &mut plus);
            d[k] = -h[k];
            group_residuals(robot, g, &s.moved(&d), &mut minus);
            for (i, (a, b)) in plus.iter().zip(&minus).enumerate() {
                j[(row + i, c)] = (a - b) / (2.0 * h[k]);
            }
            c += 1;
        }
        row += group_rows(g);
    }
    j
}

/// The result of [`constraint_fit`].
#[derive(Clone, Debug)]
pub struct ConstraintFit {
    pub robot: RefRobot,
    pub shapes: Vec<RefShape>,
    /// Σ of squared weighted residuals at the start and at the end.
    pub start_cost: f64,
    pub cost: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Whether the iteration stopped on a converged step (not on its limit).
    pub converged: bool,
    /// Singular values of the column-scaled Jacobian (model and shapes) of the last step,
    /// largest first.
    pub singular_values: Vec<f64>,
}

impl ConstraintFit {
    /// RMS of the unweighted row errors (mm) as docs/formats.md counts them: a socket row's
    /// distance to its centre, a plane row's distance to its plane, a distance group's length
    /// error, a tracker row's distance to its point.
    pub fn rms_mm(&self, groups: &[RefGroup]) -> f64 {
        row_rms_mm(&self.robot, groups, &self.shapes)
    }
}

/// RMS of the row errors (mm) of `groups` under `robot` and `shapes` (see
/// [`ConstraintFit::rms_mm`]).
pub fn row_rms_mm(robot: &RefRobot, groups: &[RefGroup], shapes: &[RefShape]) -> f64 {
    let mut e = Vec::new();
    for (g, s) in groups.iter().zip(shapes) {
        let mut r = Vec::new();
        group_residuals(robot, g, s, &mut r);
        let sigma = g.rows[0].sigma_mm;
        match g.kind {
            RefKind::Socket | RefKind::Point => {
                for (k, c) in r.chunks(3).enumerate() {
                    e.push(Vector3::new(c[0], c[1], c[2]).norm() * g.rows[k].sigma_mm);
                }
            }
            RefKind::Plane => e.extend(r.iter().zip(&g.rows).map(|(x, w)| x * w.sigma_mm)),
            RefKind::Distance => e.push(r[0] * sigma),
        }
    }
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

/// `robot` and `shapes` moved together by the rigid motion `x ↦ rot·x + t` of the measurement
/// frame (the base carried along, socket centres and planes moved with it): every predicted
/// point moves the same way, so no socket, plane or distance row changes.
pub fn rigidly_moved(
    robot: &RefRobot,
    shapes: &[RefShape],
    rot: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> (RefRobot, Vec<RefShape>) {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(rot);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(t);
    let mut r = robot.clone();
    r.base = m * robot.base;
    let moved = shapes
        .iter()
        .map(|s| match *s {
            RefShape::Centre(c) => RefShape::Centre(rot * c + t),
            RefShape::Plane(n, d) => RefShape::Plane(rot * n, d + (rot * n).dot(t)),
            RefShape::None => RefShape::None,
        })
        .collect();
    (r, moved)
}

/// `robot` and `shapes` with every length multiplied by `k` (base translation, `a`, `d`, tool
/// points, socket centres, plane offsets): every predicted point is multiplied by `k`, so
/// socket and plane rows scale by `k` while a distance row is off by `(k − 1)·L`.
pub fn scaled(robot: &RefRobot, shapes: &[RefShape], k: f64) -> (RefRobot, Vec<RefShape>) {
    let mut r = robot.clone();
    for i in 0..3 {
        r.base[(i, 3)] *= k;
    }
    for j in &mut r.joints {
        j.a *= k;
        j.d *= k;
    }
    r.tool *= k;
    for t in &mut r.more_tools {
        *t *= k;
    }
    let s = shapes
        .iter()
        .map(|s| match *s {
            RefShape::Centre(c) => RefShape::Centre(c * k),
            RefShape::Plane(n, d) => RefShape::Plane(n, d * k),
            RefShape::None => RefShape::None,
        })
        .collect();
    (r, s)
}

/// The unit of a model parameter in the column scaling's test for a negligible column: 1 mm,
/// or 1 rad at a reach of a metre.
fn unit_of(p: Param) -> f64 {
    if p.is_length() {
        1.0
    } else {
        1000.0
    }
}

/// Fits `params` of `start` and every group's shape to `groups`: Levenberg–Marquardt on all
/// unknowns at once, shapes started through the points `start` predicts. The step solves the
/// damped least-squares problem of the column-scaled Jacobian `J̃ = J·D⁻¹` by its SVD,
/// `δ̃ = −Σ sₖ/(sₖ² + λ) vₖ uₖᵀ r` over the singular values above [`RCOND`] of the largest,
/// `δ = D⁻¹ δ̃`; λ shrinks tenfold on a step that lowers the cost and grows tenfold on one that
/// does not. Stops when a step lowers the cost by less than 1e-12 of it, when no step lowers
/// it, or after 200 steps.
pub fn constraint_fit(start: &RefRobot, params: &[Param], groups: &[RefGroup]) -> ConstraintFit {
    let np = params.len();
    let mut robot = start.clone();
    let mut shapes = shapes_through(&robot, groups);
    let mut r = residuals(&robot, groups, &shapes);
    let mut cost = r.norm_squared();
    let start_cost = cost;
    let mut lambda = 1e-3;
    let (mut iterations, mut converged) = (0, false);
    let mut singular_values = Vec::new();
    for _ in 0..200 {
        let mut j = jacobian(&robot, params, groups, &shapes);
        // Unit-norm columns, except a column that is rounding next to the largest (in mm per
        // mm, or per rad at a metre): it stays zero rather than become unit-norm noise.
        let units: Vec<f64> = params
            .iter()
            .map(|&p| unit_of(p))
            .chain(shapes.iter().flat_map(|s| match s {
                RefShape::Plane(..) => vec![1000.0, 1000.0, 1.0],
                _ => vec![1.0; s.unknowns()],
            }))
            .collect();
        let norms: Vec<f64> = j.column_iter().map(|c| c.norm()).collect();
        let largest = norms
            .iter()
            .zip(&units)
            .fold(0.0, |m: f64, (n, u)| m.max(n / u));
        let scale: Vec<f64> = norms
            .iter()
            .zip(&units)
            .map(|(&n, u)| if n / u > 1e-9 * largest { n } else { 0.0 })
            .collect();
        for (mut c, s) in j.column_iter_mut().zip(&scale) {
            if *s > 0.0 {
                c /= *s;
            } else {
                c.fill(0.0);
            }
        }
        let svd = j.svd(true, true);
        singular_values = svd.singular_values.iter().copied().collect();
        singular_values.sort_by(|a, b| b.total_cmp(a));
        let (u, vt) = (svd.u.expect("U requested"), svd.v_t.expect("V requested"));
        let s = &svd.singular_values;
        let smax = s.max();
        let ur = u.transpose() * &r;
        let mut stepped = false;
        while lambda < 1e16 {
            let mut dt = DVector::zeros(scale.len());
            for k in 0..s.len() {
                if s[k] > RCOND * smax {
                    dt -= vt.row(k).transpose() * (s[k] / (s[k] * s[k] + lambda) * ur[k]);
                }
            }
            let delta: Vec<f64> = dt
                .iter()
                .zip(&scale)
                .map(|(d, s)| if *s > 0.0 { d / s } else { 0.0 })
                .collect();
            let trial = robot.stepped(params, &delta[..np]);
            let mut k = np;
            let trial_shapes: Vec<RefShape> = shapes
                .iter()
                .map(|s| {
                    let moved = s.moved(&delta[k..k + s.unknowns()]);
                    k += s.unknowns();
                    moved
                })
                .collect();
            let tr = residuals(&trial, groups, &trial_shapes);
            let tc = tr.norm_squared();
            if tc.is_finite() && tc < cost {
                let drop = (cost - tc) / cost.max(f64::MIN_POSITIVE);
                robot = trial;
                shapes = trial_shapes;
                r = tr;
                cost = tc;
                lambda = (lambda / 10.0).max(1e-12);
                iterations += 1;
                stepped = true;
                converged = drop < 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !stepped {
            converged = true;
        }
        if converged {
            break;
        }
    }
    ConstraintFit {
        robot,
        shapes,
        start_cost,
        cost,
        iterations,
        converged,
        singular_values,
    }
}

/// RMS distance (mm) between the points `a` and `b` (pairwise) after the rigid transform
/// (and, with `scale`, the uniform scale) that best maps `a` onto `b` (Kabsch/Umeyama).
pub fn aligned_rms(a: &[Vector3<f64>], b: &[Vector3<f64>], scale: bool) -> f64 {
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (pa, pb) in a.iter().zip(b) {
        h += (pb - cb) * (pa - ca).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.expect("U requested"), svd.v_t.expect("V requested"));
    let d = (u * vt).determinant().signum();
    let rot = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt;
    let k = if scale {
        let sv = svd.singular_values;
        (sv[0] + sv[1] + d * sv[2]) / a.iter().map(|p| (p - ca).norm_squared()).sum::<f64>()
    } else {
        1.0
    };
    let e: f64 = a
        .iter()
        .zip(b)
        .map(|(pa, pb)| (cb + k * rot * (pa - ca) - pb).norm_squared())
        .sum();
    (e / n).sqrt()
}
