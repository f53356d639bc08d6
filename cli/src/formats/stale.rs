//! Tracker readings that did not update (docs/formats.md, "Stale readings"): a row whose
//! measured point equals an earlier row's to the last digit although the robot moved between
//! the two poses. A tracker that loses the target, or a logger that misses a reading, repeats
//! the last point; such a row carries another pose's point, and one of them in a few thousand
//! raises every held-out figure. It is left out, with a warning that names its line.

use crate::formats::measurements::Dataset;
use kinecal::forward::ForwardKinematics;
use kinecal::{Robot, ValueStorage};
use std::collections::HashMap;

/// How far (mm, by the nominal model) the tool must move between two rows for the same measured
/// point to be a stale reading rather than one pose measured twice. A pose repeated within the
/// robot's repeatability moves it by hundredths of a millimetre; a tracker's last digit is a
/// micrometre or finer, so two real readings of poses this far apart never agree in all three
/// coordinates.
pub const MOVED_MM: f64 = 0.1;

/// How far (degrees) one joint must turn between two rows for the same measured point to be a
/// stale reading, wherever the model puts the tool: the same target reached in another
/// configuration (elbow up and down) lands within the robot's error of the first, which is never
/// the tracker's last digit in all three coordinates.
pub const TURNED_DEG: f64 = 1.0;

/// A row left out: its index in the dataset, the index of the earlier row whose point it
/// repeats, and the joint that turned most between the two (index, degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stale {
    pub index: usize,
    pub copy_of: usize,
    pub joint: usize,
    pub turned_deg: f64,
}

/// The rows of `ds` (mm, degrees) whose measured point repeats an earlier row's exactly while a
/// joint turned [`TURNED_DEG`] or more between the two, or `nominal` puts the tool [`MOVED_MM`]
/// or more away from that row's (the distance does not depend on the base, so a nominal model
/// without one serves).
pub fn find<const N: usize, V: ValueStorage>(
    ds: &Dataset<N>,
    nominal: &Robot<f64, N, V>,
) -> Vec<Stale> {
    let mut first: HashMap<[u64; 3], usize> = HashMap::new();
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut stale = Vec::new();
    for (i, r) in ds.records.iter().enumerate() {
        // +0.0 and −0.0 are the same reading.
        let key = r.xyz_mm.map(|c| (c + 0.0).to_bits());
        let Some(&j) = first.get(&key) else {
            first.insert(key, i);
            continue;
        };
        let earlier = &ds.records[j];
        let (joint, turned_deg) = r
            .q_deg
            .iter()
            .zip(earlier.q_deg)
            .map(|(a, b)| (a - b).abs())
            .enumerate()
            .fold((0, 0.0), |m, (k, d)| if d > m.1 { (k, d) } else { m });
        let here = fk.compute(nominal, &r.q_deg.map(f64::to_radians));
        let there = fk.compute(nominal, &earlier.q_deg.map(f64::to_radians));
        // NaN (a reading the model cannot place) counts as not moved.
        if turned_deg >= TURNED_DEG || (here - there).norm() >= MOVED_MM {
            stale.push(Stale {
                index: i,
                copy_of: j,
                joint,
                turned_deg,
            });
        }
    }
    stale
}

/// `ds` without its stale rows ([`find`]), and the warning that names them (`origin`: the
/// file's name in it); `None` when there are none.
pub fn leave_out<const N: usize, V: ValueStorage>(
    mut ds: Dataset<N>,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> (Dataset<N>, Option<String>) {
    let stale = find(&ds, nominal);
    if stale.is_empty() {
        return (ds, None);
    }
    let line = |i: usize| ds.records[i].line;
    let named: Vec<String> = stale
        .iter()
        .take(5)
        .map(|s| {
            format!(
                "line {} repeats line {}, joint {} {:.3}° away",
                line(s.index),
                line(s.copy_of),
                s.joint + 1,
                s.turned_deg
            )
        })
        .collect();
    let more = if stale.len() > named.len() {
        format!("; {} more", stale.len() - named.len())
    } else {
        String::new()
    };
    let warning = format!(
        "warning: {origin}: {} row(s) repeat an earlier row's measured point to the last digit \
         although the robot moved ({}{more}): readings the tracker did not update, left out; \
         delete them from the file or measure those poses again",
        stale.len(),
        named.join("; ")
    );
    let mut drop = vec![false; ds.records.len()];
    for s in &stale {
        drop[s.index] = true;
    }
    let mut k = 0;
    ds.records.retain(|_| {
        k += 1;
        !drop[k - 1]
    });
    (ds, Some(warning))
}
