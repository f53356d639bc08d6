//! What a measurement file observed in each pose (docs/formats.md): the point (`x`, `y`, `z`),
//! or several reflectors' points (`x_NAME`, `y_NAME`, `z_NAME`, an empty cell where one was
//! not seen), the probe's orientation (`rx_deg`, `ry_deg`, `rz_deg`) and the tracker's 1-σ
//! (`sx_mm`, `sy_mm`, `sz_mm`, `srot_deg`), turned into the library's weighted observations.
//!
//! **Weights** (docs/formats.md "Observations"): with σ columns every residual is divided by
//! its σ (a χ² with one unit per reading); without them positions count in millimetres and
//! orientations in degrees times `--deg-weight-mm` (default 17.45: a degree weighs the arc it
//! moves a point 1 m away). A file with σ for some rows and not others is refused, as is a
//! file with orientations and position σ but no `srot_deg`: the two kinds of residual would be
//! in different units.

use crate::formats::measurements::{Dataset, Record};
use crate::formats::robot_file::RobotFile;
use kinecal::{Frame, Measurement};
use nalgebra::Vector3;

/// Mm per degree that the default weighting gives an orientation residual: the arc a degree
/// moves a point 1 m away.
pub const DEFAULT_DEG_WEIGHT_MM: f64 = 1000.0 * std::f64::consts::PI / 180.0;

/// How orientation and σ columns are used (`identify`, `diagnose`, `check`).
#[derive(clap::Args, Debug, Clone, PartialEq, Default)]
pub struct ObservationArgs {
    /// Weight of an orientation residual without σ columns: millimetres per degree. Without
    /// it, the weighting is found from the data (each kind of residual by its own scatter).
    #[arg(long)]
    pub deg_weight_mm: Option<f64>,
    /// Weigh by the file's σ exactly as stated, without the error floor that the fit adds when
    /// the residuals are larger than the σ explain.
    #[arg(long)]
    pub sigma_as_stated: bool,
    /// Use positions only, even when the file has rx_deg, ry_deg, rz_deg.
    #[arg(long)]
    pub positions_only: bool,
    /// Weigh every reading the same, even when the file has sx_mm, sy_mm, sz_mm, srot_deg.
    #[arg(long)]
    pub ignore_sigma: bool,
}

/// One measured pose: where its observations (one per reflector seen) are in the
/// observation list of its set ([`Observed::measurements`], or the identification or
/// held-out list of a split), and its line. Poses are ranges into one list, not a list each:
/// a million poses are then one allocation, not a million.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pose {
    /// Index of the pose's first observation.
    pub first: u32,
    /// How many observations it has (at least one).
    pub count: u32,
    /// The pose's line in its file (1-based, header included).
    pub line: u32,
}

impl Pose {
    /// The pose's observations in `all`, the observation list its [`Pose::first`] indexes.
    pub fn of<'a, T>(&self, all: &'a [T]) -> &'a [T] {
        let first = self.first as usize;
        all.get(first..first + self.count as usize).unwrap_or(&[])
    }
}

/// The poses of a file and what kind of observations they are.
#[derive(Clone, Debug, PartialEq)]
pub struct Observed<const N: usize> {
    /// Every observation, pose after pose.
    pub measurements: Vec<Measurement<f64, N>>,
    /// The poses, in file order (ranges into `measurements`).
    pub poses: Vec<Pose>,
    /// Point names (`[[tools]]`), empty for one `[tool]`.
    pub names: Vec<String>,
    /// Orientation observed (6-D).
    pub six_d: bool,
    /// Weighted by the file's σ (residuals in units of σ).
    pub sigma: bool,
}

/// The pose (index into `poses`) of every observation of the list `poses` index.
pub fn pose_of(poses: &[Pose]) -> Vec<usize> {
    poses
        .iter()
        .enumerate()
        .flat_map(|(k, p)| std::iter::repeat_n(k, p.count as usize))
        .collect()
}

/// The file line of every observation of the list `poses` index.
pub fn line_of(poses: &[Pose]) -> Vec<u32> {
    poses
        .iter()
        .flat_map(|p| std::iter::repeat_n(p.line, p.count as usize))
        .collect()
}

impl<const N: usize> Observed<N> {
    /// Every observation, pose after pose (a copy).
    pub fn all(&self) -> Vec<Measurement<f64, N>> {
        self.measurements.clone()
    }

    /// The observations of pose `k`.
    pub fn observations(&self, k: usize) -> &[Measurement<f64, N>] {
        self.poses.get(k).map_or(&[], |p| p.of(&self.measurements))
    }

    /// The same kind of observations without any pose (what a split leaves behind).
    pub fn kind(&self) -> Self {
        Self {
            measurements: Vec::new(),
            poses: Vec::new(),
            names: self.names.clone(),
            six_d: self.six_d,
            sigma: self.sigma,
        }
    }

    /// Splits the poses: those with `held[k]` (the held-out set) and the others (the
    /// identification set), each in file order and with its own observation list. In place:
    /// the identification set keeps this list, so only the held-out observations are copied.
    pub fn split(mut self, held: &[bool]) -> (Self, Self) {
        let mut valid = self.kind();
        let mut kept = 0usize;
        let mut ident_poses = Vec::new();
        for (k, p) in self.poses.iter().enumerate() {
            let range = p.first as usize..(p.first + p.count) as usize;
            if held.get(k).copied().unwrap_or(false) {
                valid.poses.push(Pose {
                    first: valid.measurements.len() as u32,
                    ..*p
                });
                valid
                    .measurements
                    .extend_from_slice(&self.measurements[range]);
            } else {
                ident_poses.push(Pose {
                    first: kept as u32,
                    ..*p
                });
                if range.start != kept {
                    self.measurements.copy_within(range, kept);
                }
                kept += p.count as usize;
            }
        }
        self.measurements.truncate(kept);
        self.measurements.shrink_to_fit();
        self.poses = ident_poses;
        (self, valid)
    }
}

/// Column index of `name` in the dataset's extra columns.
fn col<const N: usize>(ds: &Dataset<N>, name: &str) -> Option<usize> {
    ds.extra_names.iter().position(|n| n == name)
}

/// The lowest and highest `temp_c` (°C) read as a temperature: no robot is calibrated colder
/// or warmer. Warmer than [`crate::formats::loading::WARM_C`] is warned about (a room logged
/// in degrees Fahrenheit reads 65–80; read as °C, a thermal-expansion term would be referred
/// to 70 °C and fitted to a spread 1.8 times too wide).
pub const MIN_TEMP_C: f64 = kinecal::compensate::MIN_TEMP_C;
pub const MAX_TEMP_C: f64 = kinecal::compensate::MAX_TEMP_C;

/// The observations of `ds` (already in mm and degrees) for the robot `file`. Refused (exit 2)
/// with a one-line reason naming the file, line and column for what cannot be right.
pub fn observe<const N: usize>(
    ds: &Dataset<N>,
    file: &RobotFile,
    args: &ObservationArgs,
    origin: &str,
) -> anyhow::Result<Observed<N>> {
    let deg_weight_mm = args.deg_weight_mm.unwrap_or(DEFAULT_DEG_WEIGHT_MM);
    if !(deg_weight_mm.is_finite() && deg_weight_mm > 0.0 && deg_weight_mm <= 1e6) {
        crate::refuse!(
            "--deg-weight-mm {deg_weight_mm}: give a positive number of millimetres per degree"
        );
    }
    let names = file.tool_names();
    let rot = ["rx_deg", "ry_deg", "rz_deg"].map(|c| col(ds, c));
    let six_d = rot.iter().any(Option::is_some) && !args.positions_only;
    if six_d && rot.iter().any(Option::is_none) {
        crate::refuse!("{origin}: orientation needs all of rx_deg, ry_deg, rz_deg");
    }
    let sig = ["sx_mm", "sy_mm", "sz_mm"].map(|c| col(ds, c));
    // One isotropic angular σ, or one per axis (`srx_deg`, `sry_deg`, `srz_deg`: their RMS,
    // as a map's per-axis σ are read).
    let srot = col(ds, "srot_deg");
    let sr_axes = ["srx_deg", "sry_deg", "srz_deg"].map(|c| col(ds, c));
    let given = sr_axes.iter().filter(|c| c.is_some()).count();
    if given > 0 && (given < 3 || srot.is_some()) {
        crate::refuse!(
            "{origin}: an angular σ is one srot_deg or all of srx_deg, sry_deg, srz_deg: give \
             one of the two"
        );
    }
    let srot_of = |get: &dyn Fn(usize) -> f64| -> f64 {
        match (srot, sr_axes) {
            (Some(c), _) => get(c),
            (None, [Some(a), Some(b), Some(c)]) => {
                ((get(a).powi(2) + get(b).powi(2) + get(c).powi(2)) / 3.0).sqrt()
            }
            _ => f64::NAN,
        }
    };
    let has_srot = srot.is_some() || given == 3;
    let has_sig = sig.iter().any(Option::is_some) && !args.ignore_sigma;
    if has_sig && sig.iter().any(Option::is_none) {
        crate::refuse!("{origin}: position uncertainty needs all of sx_mm, sy_mm, sz_mm");
    }
    if has_sig {
        for (c, name) in sig.iter().zip(["sx_mm", "sy_mm", "sz_mm"]) {
            let Some(k) = *c else { continue };
            let column: Vec<(u64, f64)> = ds
                .records
                .iter()
                .map(|r| {
                    (
                        u64::from(r.line),
                        r.extra.get(k).copied().unwrap_or(f64::NAN),
                    )
                })
                .collect();
            crate::formats::tiny_sigma::refuse_tiny(&column, name, origin)?;
        }
    }
    if six_d && has_sig && !has_srot {
        crate::refuse!(
            "{origin}: sx_mm, sy_mm, sz_mm but no srot_deg for the orientation: add it, or give \
             --ignore-sigma (or --positions-only)"
        );
    }
    if six_d && names.len() > 1 {
        crate::refuse!(
            "{origin}: rx_deg, ry_deg, rz_deg with several [[tools]]: the orientation is of one \
             measured frame; give one [tool] with its rpy_deg, or --positions-only"
        );
    }
    let first_nan = ds
        .records
        .iter()
        .any(|r| r.xyz_mm.iter().any(|v| v.is_nan()));
    // One `[[tools]]` entry names its reflector too: its x_NAME… columns are read when the
    // file has no x, y, z.
    let named = names.len() > 1 || (names.len() == 1 && first_nan);
    let points: Vec<[usize; 3]> = if named {
        let mut v = Vec::new();
        for n in &names {
            let c = ["x", "y", "z"].map(|a| col(ds, &format!("{a}_{n}")));
            match c {
                [Some(x), Some(y), Some(z)] => v.push([x, y, z]),
                _ => crate::refuse!(
                    "{origin}: the robot file names the reflector `{n}` but the file lacks \
                     x_{n}, y_{n} or z_{n}"
                ),
            }
        }
        v
    } else {
        Vec::new()
    };
    if !named && first_nan {
        crate::refuse!(
            "{origin}: the file has no x, y, z (x_NAME… columns?): name the reflectors with \
             [[tools]] in the robot file"
        );
    }
    // The arm's temperature, for a model with a thermal-expansion term (an empty cell: none).
    let temp = col(ds, crate::formats::measurements::TEMPERATURE_COLUMN);
    // The time, for a model with a base-drift term (an empty cell: none).
    let time = col(ds, crate::formats::measurements::TIME_COLUMN);
    const MAX_TIME: f64 = kinecal::model::effects::MAX_DRIFT_TIME;
    // One record's observations (one, or one per reflector seen), onto `obs`; the refusal
    // names the line.
    let observe_record =
        |r: &Record<N>, obs: &mut Vec<Measurement<f64, N>>| -> anyhow::Result<()> {
            let at = |c: &str| format!("{origin}:{}: {c}", r.line);
            let get = |k: usize| r.extra.get(k).copied().unwrap_or(f64::NAN);
            let weight = if has_sig {
                let s = sig.map(|c| c.map_or(f64::NAN, get));
                if let Some(k) = s.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
                    crate::refuse!(
                        "{}: a 1-σ must be a positive number, got {} (or give --ignore-sigma)",
                        at(["sx_mm", "sy_mm", "sz_mm"][k]),
                        cell_text(s[k])
                    );
                }
                Vector3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2])
            } else {
                Vector3::repeat(1.0)
            };
            let orientation = if six_d {
                let a = rot.map(|c| c.map_or(f64::NAN, get));
                if let Some(k) = a.iter().position(|v| v.is_nan()) {
                    crate::refuse!(
                        "{}: empty (or not a number): a file with rx_deg, ry_deg, rz_deg needs \
                         an orientation on every row; fill it in, leave the row out, or fit the \
                         positions alone with --positions-only",
                        at(["rx_deg", "ry_deg", "rz_deg"][k])
                    );
                }
                if let Some(k) = a.iter().position(|v| !v.is_finite() || v.abs() > 1e4) {
                    crate::refuse!(
                        "{}: not an angle in degrees: {}",
                        at(["rx_deg", "ry_deg", "rz_deg"][k]),
                        a[k]
                    );
                }
                let w = if has_sig {
                    let s = srot_of(&get);
                    if !(s.is_finite() && s > 0.0) {
                        crate::refuse!(
                            "{}: a 1-σ must be a positive number, got {} (or give --ignore-sigma)",
                            at("srot_deg"),
                            cell_text(s)
                        );
                    }
                    1.0 / s.to_radians()
                } else {
                    deg_weight_mm.to_degrees()
                };
                Some((Frame::from_xyz_rpy([0.0; 3], a.map(f64::to_radians)), w))
            } else {
                None
            };
            let q = r.q_deg.map(f64::to_radians);
            let temp_c = temp.map(get).filter(|t| !t.is_nan());
            if let Some(t) = temp_c.filter(|t| !(MIN_TEMP_C..=MAX_TEMP_C).contains(t)) {
                crate::refuse!(
                    "{}: {t} °C is not the temperature of a robot being calibrated ({MIN_TEMP_C} \
                     to {MAX_TEMP_C} °C): give °C (from degrees Fahrenheit: (F − 32) × 5/9), \
                     or leave the column out",
                    at("temp_c")
                );
            }
            let time_s = time.map(get).filter(|t| !t.is_nan());
            if let Some(t) = time_s.filter(|t| t.abs() > MAX_TIME) {
                crate::refuse!(
                    "{}: not a time in seconds: {t} (a date and time written as digits? read \
                     the file with --map and its pattern in [units] time, docs/formats.md \
                     \"Files in other layouts\"; milliseconds? divide by 1000)",
                    at("t_s")
                );
            }
            if named {
                for (k, c) in points.iter().enumerate() {
                    let p = c.map(get);
                    let seen = p.iter().filter(|v| v.is_finite()).count();
                    if seen == 0 {
                        continue;
                    }
                    if seen < 3 {
                        crate::refuse!(
                        "{}: reflector `{}` has some coordinates and not others: leave all three \
                         cells empty where it was not seen",
                        at(&format!("x_{}", names[k])),
                        names[k]
                    );
                    }
                    if let Some(v) = p.iter().find(|v| v.abs() > 1e6) {
                        crate::refuse!(
                            "{}: {v} is not a position in millimetres",
                            at(&format!("x_{}", names[k]))
                        );
                    }
                    let mut m = Measurement::new(q, Vector3::from(p));
                    m.tool = k as u8;
                    m.weight = weight;
                    m.temp_c = temp_c;
                    m.time_s = time_s;
                    if let (1, Some((o, w))) = (points.len(), orientation) {
                        m.orientation = Some(o);
                        m.orientation_weight = w;
                    }
                    obs.push(m);
                }
            } else {
                let mut m = Measurement::new(q, Vector3::from(r.xyz_mm));
                m.weight = weight;
                m.temp_c = temp_c;
                m.time_s = time_s;
                if let Some((o, w)) = orientation {
                    m.orientation = Some(o);
                    m.orientation_weight = w;
                }
                obs.push(m);
            }
            Ok(())
        };
    let (measurements, poses) = if named || ds.records.len() < PARALLEL_MIN_RECORDS {
        let mut poses = Vec::with_capacity(ds.records.len());
        let mut measurements = Vec::with_capacity(ds.records.len());
        for r in &ds.records {
            let first = measurements.len();
            observe_record(r, &mut measurements)?;
            let count = measurements.len() - first;
            // Only a pose with several reflectors can see none of them (dropped below).
            if count > 0 {
                poses.push(Pose {
                    first: first as u32,
                    count: count as u32,
                    line: r.line,
                });
            }
        }
        (measurements, poses)
    } else {
        observe_each_once(&ds.records, observe_record)?
    };
    if named {
        for (k, n) in names.iter().enumerate() {
            if !measurements.iter().any(|m| m.tool as usize == k) {
                crate::refuse!(
                    "{origin}: reflector `{n}` was never seen (x_{n} empty on every row): \
                     remove it from [[tools]]"
                );
            }
        }
    }
    Ok(Observed {
        measurements,
        poses,
        names,
        six_d,
        sigma: has_sig,
    })
}

/// Fewer records than this are observed on the calling thread.
const PARALLEL_MIN_RECORDS: usize = 1 << 14;

/// The observations of records that give exactly one each (one tool point), on several
/// threads ([`crate::compute::parallel::map_parts`]) straight into the list's final place:
/// the list of a million poses is written once, and is never held twice. The refusal is the
/// first record's that is refused, as one pass in order would give.
fn observe_each_once<const N: usize>(
    records: &[Record<N>],
    observe_record: impl Fn(&Record<N>, &mut Vec<Measurement<f64, N>>) -> anyhow::Result<()> + Sync,
) -> anyhow::Result<(Vec<Measurement<f64, N>>, Vec<Pose>)> {
    let n = records.len();
    let mut measurements: Vec<Measurement<f64, N>> = crate::compute::huge_pages::with_capacity(n);
    let slots = &mut measurements.spare_capacity_mut()[..n];
    let parts = crate::compute::parallel::PARTS;
    let size = n.div_ceil(parts).max(1);
    let mut jobs: Vec<_> = records.chunks(size).zip(slots.chunks_mut(size)).collect();
    let done = crate::compute::parallel::map_each_mut(&mut jobs, |(part, slots)| {
        let mut one = Vec::with_capacity(1);
        for (r, slot) in part.iter().zip(slots.iter_mut()) {
            one.clear();
            observe_record(r, &mut one)?;
            match one.as_slice() {
                [m] => {
                    slot.write(*m);
                }
                _ => anyhow::bail!("line {}: not one observation", r.line),
            }
        }
        Ok(())
    });
    done.into_iter().collect::<anyhow::Result<()>>()?;
    // SAFETY: every job wrote every slot of its chunk (a job that did not returned an error
    // above), and the chunks cover the first `n` slots of the capacity exactly once.
    unsafe { measurements.set_len(n) };
    let poses = records
        .iter()
        .enumerate()
        .map(|(k, r)| Pose {
            first: k as u32,
            count: 1,
            line: r.line,
        })
        .collect();
    Ok((measurements, poses))
}

/// A cell's value as a message shows it: an empty or non-numeric cell (read as NaN) as "an
/// empty cell".
fn cell_text(v: f64) -> String {
    if v.is_nan() {
        "an empty cell (or not a number)".to_string()
    } else {
        v.to_string()
    }
}
