//! `kinecal frames`: base frame and tool distances from single-joint sweeps.

/// Arguments of `kinecal frames` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal frames` is not implemented yet")
}
