//! What `identify --residuals R.csv` writes for a constraint file: one row per residual, with
//! the nominal model's and the identified model's value. Identification rows are measured
//! against their group's shape (fitted with the model, or to the nominal model's points for the
//! nominal column), held-out rows against the shape refitted to their own group's predicted
//! points; a distance group has one residual, at its first row's line (docs/formats.md).

use super::read::Group;
use super::shapes::{errors, fit, points, Shape};
use crate::HostRobot;
use std::fmt::Write;

/// The residuals file of a constraint fit: `groups` with the shapes each model has for them
/// (`None`: held out, refitted to the group's own points).
pub fn to_csv<const N: usize>(
    (nominal, before): (&HostRobot<N>, &[Shape]),
    (model, after): (&HostRobot<N>, &[Shape]),
    ident: &[Group<N>],
    held_out: &[Group<N>],
) -> String {
    let mut s = String::from("set,kind,group,line,nominal_mm,model_mm\n");
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:.6}")
        } else {
            String::new()
        }
    };
    let mut rows = |set: &str, g: &Group<N>, e0: Vec<f64>, e1: Vec<f64>| {
        for (k, (a, b)) in e0.into_iter().zip(e1).enumerate() {
            let line = g.rows.get(k).map_or(0, |r| r.line);
            let _ = writeln!(
                s,
                "{set},{},{},{line},{},{}",
                g.kind.id(),
                g.name,
                num(a),
                num(b)
            );
        }
    };
    for (k, g) in ident.iter().enumerate() {
        let e = |robot: &HostRobot<N>, shapes: &[Shape]| {
            let shape = shapes.get(k).copied().unwrap_or(Shape::None);
            errors(g, &points(robot, g), &shape)
        };
        rows("identification", g, e(nominal, before), e(model, after));
    }
    for g in held_out {
        let e = |robot: &HostRobot<N>| {
            let pts = points(robot, g);
            errors(g, &pts, &fit(g.kind, &pts))
        };
        rows("held-out", g, e(nominal), e(model));
    }
    s
}
