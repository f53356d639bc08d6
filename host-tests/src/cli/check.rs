//! `kinecal check`: validates a robot file and a measurement file.

/// Arguments of `kinecal check` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal check` is not implemented yet")
}
