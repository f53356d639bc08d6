//! `kinecal compensate`: joint commands that bring the identified robot to target points.

/// Arguments of `kinecal compensate` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal compensate` is not implemented yet")
}
