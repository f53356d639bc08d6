//! Readings that did not update (docs/formats.md, "Stale readings"): a row whose measured
//! point equals an earlier row's to the last digit although the robot moved between the two
//! poses, or whose joint readings equal the row before's to the last digit although the tracker
//! saw the tool far from where it saw it then. A tracker that loses the target, or a logger
//! that misses a reading, repeats its last one; such a row pairs one pose's joints with another
//! pose's point, and one of them in a few thousand raises every held-out figure. It is left
//! out, with a warning that names its line. Joint readings are compared with the row before
//! only: a pose visited again later in a session (a cycle of an ISO 9283 test) may have drifted
//! by any amount, but no real reading repeats another's point to the last digit. For the same
//! reason a row equal to an earlier one in its joint readings, its point and every other
//! column (time, temperature, σ) is a copy (a row pasted twice, a file appended to itself),
//! not a pose measured twice: kept, it would make a noise floor of 0 mm out of the repeated
//! poses. It is left out too.

use crate::formats::measurements::Dataset;
use kinecal::forward::ForwardKinematics;
use kinecal::{Robot, ValueStorage};
use rustc_hash::{FxBuildHasher, FxHashMap, FxHasher};
use std::hash::{Hash, Hasher};

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

/// How far apart (mm) the tracker must see the tool at the same joint readings for the later row
/// to carry joint readings that did not update: a pose measured again at once lands within the
/// robot's repeatability and the tracker's noise, hundredths of a millimetre.
pub const APART_MM: f64 = 1.0;

/// What a row left out repeats of an earlier row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Repeated {
    /// The measured point, while joint `joint` (index) turned `turned_deg` between the two rows.
    Point { joint: usize, turned_deg: f64 },
    /// The joint readings, while the tracker saw the tool `apart_mm` from the earlier point.
    Joints { apart_mm: f64 },
    /// The whole row: the same joint readings and the same point (a copy).
    Row,
}

/// A row left out: its index in the dataset, the index of the (kept) row whose reading it
/// repeats, and what.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stale {
    pub index: usize,
    pub copy_of: usize,
    pub repeated: Repeated,
}

/// A 64-bit hash of a point's three coordinates (+0.0 and −0.0 alike).
fn point_hash(p: &[f64; 3]) -> u64 {
    let mut h = FxHasher::default();
    p.map(|v| (v + 0.0).to_bits()).hash(&mut h);
    h.finish()
}

/// Whether two readings are equal to the last digit (+0.0 and −0.0 alike; empty cells, NaN,
/// alike too: a copy repeats a row's other columns, `t_s`, `temp_c`, σ, empty or not).
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x + 0.0).to_bits() == (y + 0.0).to_bits())
}

/// The rows of `ds` (mm, degrees) that repeat an earlier row's measured point (`x`, `y`, `z`;
/// the columns of several named reflectors are not read) exactly while a joint turned
/// [`TURNED_DEG`] or more between the two, or `nominal` puts the tool [`MOVED_MM`] or more away
/// from that row's (the distance does not depend on the base, so a nominal model without one
/// serves); or the joint readings of the row before (the last row kept) exactly while the two
/// points are [`APART_MM`] or more apart. Only rows kept are compared with.
pub fn find<const N: usize, V: ValueStorage>(
    ds: &Dataset<N>,
    nominal: &Robot<f64, N, V>,
) -> Vec<Stale> {
    // A hash of each point kept and the first row that had it (16 bytes a row, not the
    // readings: a million-row file costs tens of MB here, freed before the fit); a hash that
    // matches is checked against the readings. The map is sized once.
    let mut first_point: FxHashMap<u64, u32> =
        FxHashMap::with_capacity_and_hasher(ds.records.len(), FxBuildHasher);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut stale: Vec<Stale> = Vec::new();
    let mut last_kept: Option<usize> = None;
    for (i, r) in ds.records.iter().enumerate() {
        // Rows of several named reflectors carry their points elsewhere (NaN here).
        if !r.xyz_mm.iter().all(|c| c.is_finite()) {
            continue;
        }
        let key = point_hash(&r.xyz_mm);
        let repeats_point = first_point
            .get(&key)
            .map(|&j| j as usize)
            .filter(|&j| same(&ds.records[j].xyz_mm, &r.xyz_mm));
        if let Some(j) = repeats_point {
            let earlier = &ds.records[j];
            let (joint, turned_deg) = r
                .q_deg
                .iter()
                .zip(earlier.q_deg)
                .map(|(a, b)| (a - b).abs())
                .enumerate()
                .fold((0, 0.0), |m, (k, d)| if d > m.1 { (k, d) } else { m });
            if same(&r.q_deg, &earlier.q_deg) && same(&r.extra, &earlier.extra) {
                stale.push(Stale {
                    index: i,
                    copy_of: j,
                    repeated: Repeated::Row,
                });
                continue;
            }
            let here = fk.compute(nominal, &r.q_deg.map(f64::to_radians));
            let there = fk.compute(nominal, &earlier.q_deg.map(f64::to_radians));
            // NaN (a reading the model cannot place) counts as not moved.
            if turned_deg >= TURNED_DEG || (here - there).norm() >= MOVED_MM {
                stale.push(Stale {
                    index: i,
                    copy_of: j,
                    repeated: Repeated::Point { joint, turned_deg },
                });
                continue;
            }
        }
        if let Some(j) = last_kept.filter(|&j| same(&ds.records[j].q_deg, &r.q_deg)) {
            let apart_mm = r
                .xyz_mm
                .iter()
                .zip(ds.records[j].xyz_mm)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            if apart_mm >= APART_MM {
                stale.push(Stale {
                    index: i,
                    copy_of: j,
                    repeated: Repeated::Joints { apart_mm },
                });
                continue;
            }
        }
        first_point.entry(key).or_insert(i as u32);
        last_kept = Some(i);
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
            let (here, there) = (line(s.index), line(s.copy_of));
            match s.repeated {
                Repeated::Point { joint, turned_deg } => format!(
                    "line {here} repeats line {there}'s point, joint {} {turned_deg:.3}° away",
                    joint + 1
                ),
                Repeated::Joints { apart_mm } => format!(
                    "line {here} repeats line {there}'s joint readings, the point {apart_mm:.3} mm \
                     away"
                ),
                Repeated::Row => format!("line {here} repeats line {there} entirely"),
            }
        })
        .collect();
    let more = if stale.len() > named.len() {
        format!("; {} more", stale.len() - named.len())
    } else {
        String::new()
    };
    let copies = stale.iter().filter(|s| s.repeated == Repeated::Row).count();
    let what = match (copies, stale.len() - copies) {
        (0, _) => "although the other reading changed",
        (_, 0) => "in the joint readings and the point alike",
        _ => "in one reading or both",
    };
    let why = match (copies, stale.len() - copies) {
        (0, _) => "readings that did not update",
        (_, 0) => {
            "copies of a row, not poses measured again (no two real readings agree to the \
                   last digit)"
        }
        _ => "readings that did not update and copies of a row",
    };
    let warning = format!(
        "warning: {origin}: {} row(s) repeat an earlier row's reading to the last digit {what} \
         ({}{more}): {why}, left out; delete them from the file or measure those poses again",
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
