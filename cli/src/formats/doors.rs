//! The checks a measurement file passes after the units door (docs/formats.md, "The
//! convention check" and "Base"): the order of its angles ([`crate::formats::convention`]) and,
//! when the robot file states a base, where that base puts the data
//! ([`crate::formats::placement`]).

use crate::formats::measurements::Dataset;
use crate::formats::rotation_order::RotationOrder;
use kinecal::Robot;
use std::path::Path;

/// Refuses (exit 2) a measurement file (in mm and degrees) whose angles compose in another
/// order than the one assumed, or that a stated base misplaces. `stated`: the file's angles as
/// written (degrees), the order the map gives them and the map file, for a file read with
/// `--map`; without, the angles are the file's `rx_deg`, `ry_deg`, `rz_deg` in kinecal's order.
pub fn measurements<const N: usize, const V: usize>(
    ds: &Dataset<N>,
    stated: Option<(&[[f64; 3]], RotationOrder, &Path)>,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    origin: &str,
) -> anyhow::Result<()> {
    let q: Vec<[f64; N]> = ds.records.iter().map(|r| r.q_deg).collect();
    let (angles, assumed, map) = match stated {
        Some((a, o, m)) => (a.to_vec(), o, Some(m)),
        None => {
            let cols = ["rx_deg", "ry_deg", "rz_deg"].map(|c| ds.extra(c));
            match cols {
                [Some(x), Some(y), Some(z)] => (
                    (0..ds.len()).map(|i| [x[i], y[i], z[i]]).collect(),
                    RotationOrder::KINECAL,
                    None,
                ),
                _ => (Vec::new(), RotationOrder::KINECAL, None),
            }
        }
    };
    if angles.len() == q.len() {
        if let Some(m) = crate::formats::convention::check(&q, &angles, assumed, nominal) {
            crate::refuse!("{}", m.message(origin, map));
        }
    }
    if base_known {
        if let Some(p) = crate::formats::placement::check(ds, nominal) {
            crate::refuse!("{}", p.message(origin));
        }
    }
    Ok(())
}
