//! Simulated readings of several named reflectors (a robot file with `[[tools]]`): each row
//! gets every reflector's point, in the `x_NAME`, `y_NAME`, `z_NAME` columns that
//! `identify` reads (docs/formats.md, "Several reflectors").

use crate::formats::measurements::{Dataset, TEMPERATURE_COLUMN, TIME_COLUMN, XYZ_DECIMALS};
use crate::simulation::Streams;
use crate::HostRobot;
use anyhow::{anyhow, Result};
use kinecal::ForwardKinematics;
use rand::RngExt;
use rand_distr::StandardNormal;

/// `data` (rows of the first reflector, as simulated) with the points of every reflector of
/// `truth` named `names`, each with Gaussian noise of `noise_mm` per axis: the `x`, `y`, `z`
/// cells emptied (the file is then written without them) and `x_NAME`, `y_NAME`, `z_NAME`
/// columns added. The temperature and time of a row, if carried, are those the point is seen at.
pub fn named_points<const N: usize>(
    truth: &HostRobot<N>,
    data: &Dataset<N>,
    names: &[String],
    noise_mm: f64,
    seed: u64,
) -> Result<Dataset<N>> {
    if names.len() != truth.tool_point_count() {
        return Err(anyhow!(
            "{} reflector names for {} tool points",
            names.len(),
            truth.tool_point_count()
        ));
    }
    let column = |name: &str| data.extra_names.iter().position(|c| c == name);
    let (temp, time) = (column(TEMPERATURE_COLUMN), column(TIME_COLUMN));
    // A stream of its own: the first reflector's noise is not that of a one-tool simulation.
    let mut noise = Streams::new(seed).noise;
    noise.jump();
    let mut out = data.clone();
    for n in names {
        out.extra_names
            .extend(["x", "y", "z"].map(|a| format!("{a}_{n}")));
    }
    let mut fk = ForwardKinematics::<f64, N>::new();
    for r in &mut out.records {
        fk.temp_c = temp.and_then(|k| r.extra.get(k).copied());
        fk.time_s = time.and_then(|k| r.extra.get(k).copied());
        let q = r.q_deg.map(f64::to_radians);
        for k in 0..names.len() {
            let p = fk
                .compute_point(truth, &q, k)
                .ok_or_else(|| anyhow!("no tool point {k}"))?;
            for v in p.iter() {
                let e: f64 = if noise_mm > 0.0 {
                    noise.sample::<f64, _>(StandardNormal) * noise_mm
                } else {
                    0.0
                };
                // As `x`, `y`, `z` are written (`XYZ_DECIMALS`).
                let scale = 10f64.powi(XYZ_DECIMALS as i32);
                r.extra.push(((v + e) * scale).round() / scale);
            }
        }
        r.xyz_mm = [f64::NAN; 3];
    }
    Ok(out)
}
