//! Bar lengths off by one constant (a ball's diameter, a certificate's end-to-end length for
//! the centre-to-centre one): unlike a common factor ([`super::bar_scale`]) a constant is not
//! a scale of the arm when the bars differ in length, so the fit cannot meet it and leaves
//! length errors that share it. All 30 bars 0.2 mm long left χ²/dof 3.99 (the warning is at
//! 4) and a model 0.19 mm off, with exit 0 and warnings about a moved tracker or two named
//! lines. At the fit, linearised, a common offset of the distance groups' lengths is added to
//! the model and shape columns; when it lowers the cost by more than [`MIN_SHARE`] of it and
//! its t-statistic against the remaining residual exceeds [`MIN_T`], the warning names it.

use super::read::{Group, Kind};
use crate::output::numfmt::sig;
use crate::HostRobot;
use kinecal::Param;
use nalgebra::DVector;

/// The offset must take at least this share of the fit's cost...
pub const MIN_SHARE: f64 = 0.2;
/// ... and be this many standard errors from zero (the remaining residual's scale, so a
/// misstated σ does not matter).
pub const MIN_T: f64 = 5.0;
/// Fewer distance groups than this tell no common offset.
pub const MIN_GROUPS: usize = 8;

/// The warning (without "warning: ") when `groups`' distance lengths share an offset at the fit
/// `robot` (its `estimated` parameters), or `None`.
pub fn warning<const N: usize>(
    robot: &HostRobot<N>,
    estimated: &[Param],
    groups: &[Group<N>],
) -> Option<String> {
    let distances = groups.iter().filter(|g| g.kind == Kind::Distance).count();
    if distances < MIN_GROUPS {
        return None;
    }
    let shapes = super::fit::shapes_of(robot, groups);
    let (r, jac) = super::system::evaluate(robot, groups, &shapes, estimated, true).ok()?;
    // The offset's column: residual (|p_a − p_b| − (L + δ)) / σ moves by −1/σ per mm of δ.
    let mut o = DVector::zeros(r.len());
    let mut row = 0;
    for g in groups {
        match g.kind {
            Kind::Distance => {
                o[row] = -1.0 / g.rows[0].sigma_mm;
                row += 1;
            }
            Kind::Plane => row += g.rows.len(),
            Kind::Socket | Kind::Point => row += 3 * g.rows.len(),
        }
    }
    // What of it the model and the shapes cannot take up.
    let svd = jac.clone().svd(true, false);
    let u = svd.u?;
    let tol = svd.singular_values.max() * 1e-10;
    let mut o_perp = o.clone();
    for (k, s) in svd.singular_values.iter().enumerate() {
        if *s > tol {
            let uk = u.column(k);
            o_perp -= uk * uk.dot(&o);
        }
    }
    let oo = o_perp.norm_squared();
    if oo.is_nan() || oo <= 0.0 {
        return None;
    }
    let cost = r.norm_squared();
    let delta = -o_perp.dot(&r) / oo;
    let gain = o_perp.dot(&r).powi(2) / oo;
    let rank = svd.singular_values.iter().filter(|s| **s > tol).count();
    let dof = r.len().saturating_sub(rank + 1).max(1) as f64;
    let left = ((cost - gain).max(0.0) / dof).max(f64::MIN_POSITIVE);
    let t = (gain / left).sqrt();
    (gain > MIN_SHARE * cost && t > MIN_T && delta.is_finite()).then(|| {
        format!(
            "the {distances} distance groups' length errors share a constant: every length_mm \
             {} mm {} would fit them with {} % less squared error ({} standard errors): check \
             that length_mm is each bar's centre-to-centre length (a ball's diameter or an \
             end-to-end length adds a constant)",
            sig(delta.abs(), 2),
            if delta > 0.0 { "longer" } else { "shorter" },
            sig(100.0 * gain / cost, 2),
            sig(t, 2)
        )
    })
}
