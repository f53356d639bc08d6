//! `kinecal study`: the measurement-planning study of Jost et al. 2017 (90 manipulators).

/// Arguments of `kinecal study`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(_args: &Args, _json: bool) -> anyhow::Result<serde_json::Value> {
    anyhow::bail!("`kinecal study` is not implemented yet")
}
