//! `kinecal diagnose`: the discrepancy workflow.

/// Arguments of `kinecal diagnose` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal diagnose` is not implemented yet")
}
