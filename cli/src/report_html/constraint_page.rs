//! The page of `kinecal report` on a constraint file (`constraint_report.html.j2`, minijinja,
//! HTML-escaped but for the figure): the verdict, the sources, per kind the identification
//! and held-out figures, the fitted shapes, the parameters the model changed and what the
//! constraints cannot determine.

use crate::constraints::report::ConstraintReportSummary;
use crate::output::numfmt::sig;
use minijinja::{context, Environment, Value};

/// The template, compiled into the binary.
const TEMPLATE: &str = include_str!("constraint_report.html.j2");

/// Renders the page of the robot file named `robot` from `summary`, with `sources` (label,
/// value) and a histogram of the identification rows' errors (mm) before and after.
pub fn render(
    robot: &str,
    sources: &[(String, String)],
    summary: &ConstraintReportSummary,
    (before, after): (&[f64], &[f64]),
) -> anyhow::Result<String> {
    let svg = super::plots::histogram_of(
        "Identification rows: error against the fitted shapes",
        &[
            ("nominal robot".to_string(), before),
            ("calibrated model".to_string(), after),
        ],
        ("error (mm)", "rows"),
    )?;
    let mut env = Environment::new();
    env.add_filter("sig", |x: f64| sig(x, 4));
    env.add_template("constraint_report.html", TEMPLATE)
        .map_err(|e| anyhow::anyhow!("report template: {e:#}"))?;
    let t = env
        .get_template("constraint_report.html")
        .map_err(|e| anyhow::anyhow!("report template: {e:#}"))?;
    t.render(context! {
        robot => robot,
        sources => sources,
        s => Value::from_serialize(summary),
        histogram => Value::from_safe_string(svg),
    })
    .map_err(|e| anyhow::anyhow!("report template: {e:#}"))
}
