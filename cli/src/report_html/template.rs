//! The page from its template (`report.html.j2`, minijinja): every value the template prints
//! is HTML-escaped (auto-escape for `.html` templates) except the figures, which are SVG text
//! drawn by plotters and marked safe here.

use super::page::Page;
use minijinja::{context, Environment, Value};

/// The template, compiled into the binary (the page needs no file at run time).
const TEMPLATE: &str = include_str!("report.html.j2");

/// Renders `page` into one self-contained HTML document.
pub fn render(page: &Page) -> anyhow::Result<String> {
    let mut env = Environment::new();
    // `.html` turns on HTML auto-escaping of everything printed.
    env.add_template("report.html", TEMPLATE)
        .map_err(|e| anyhow::anyhow!("report template: {e:#}"))?;
    let svgs: Vec<Value> = page
        .figures
        .iter()
        .map(|f| Value::from_safe_string(f.svg.clone()))
        .collect();
    let finding_svgs: Vec<Value> = page
        .findings
        .iter()
        .flat_map(|f| &f.found)
        .map(|f| Value::from_safe_string(f.svg.clone().unwrap_or_default()))
        .collect();
    let steps_svg = page
        .findings
        .as_ref()
        .and_then(|f| f.svg.clone())
        .map(Value::from_safe_string);
    let t = env
        .get_template("report.html")
        .map_err(|e| anyhow::anyhow!("report template: {e:#}"))?;
    t.render(context! {
        page => Value::from_serialize(page),
        svgs => svgs,
        finding_svgs => finding_svgs,
        steps_svg => steps_svg,
    })
    .map_err(|e| anyhow::anyhow!("report template: {e:#}"))
}
