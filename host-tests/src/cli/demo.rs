//! `kinecal demo`: the BPNN-PSO paper's simulation end to end.

/// Arguments of `kinecal demo` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal demo` is not implemented yet")
}
