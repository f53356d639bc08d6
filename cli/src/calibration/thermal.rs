//! The `thermal-expansion` term on the command line and in identification: every length of
//! the model scales by `1 + c·(T − T0)` at a row's `temp_c` (`docs/formats.md#effects`).
//!
//! The reference temperature `T0` of a term `--effect` adds (or a robot file's whose
//! coefficient is 0) is the identification data's mean temperature unless given
//! (`--effect thermal-expansion:0:T0`, or `reference_c` in the robot file): at the mean, `c`
//! and the lengths hardly trade with each other, and the identified lengths are the arm's at
//! the temperature it usually works at. A robot file's term with a coefficient and no
//! `reference_c` means 20 °C, in `identify` as in every other command.

use super::EffectRequest;
use crate::formats::robot_file::{RobotFile, THERMAL};
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{Measurement, Robot};

/// `--effect thermal-expansion`, `thermal-expansion:0` or `thermal-expansion:0:T0` (°C);
/// `None` for any other effect.
pub fn parse_request(s: &str) -> Option<anyhow::Result<EffectRequest>> {
    let rest = s.strip_prefix(THERMAL)?;
    if !(rest.is_empty() || rest.starts_with(':')) {
        return None;
    }
    let parts: Vec<&str> = rest.split(':').skip(1).collect();
    let bad = || {
        anyhow::anyhow!(
            "--effect {s}: expected thermal-expansion, thermal-expansion:0 or thermal-expansion:0:T0 \
             (it acts on no joint: joint 0; T0 the reference temperature in °C, default the data's mean)"
        )
    };
    let r = match parts.as_slice() {
        [] => Ok(None),
        ["0"] => Ok(None),
        ["0", t] => match t.parse::<f64>() {
            Ok(t) if t.is_finite() && t.abs() <= 1e3 => Ok(Some(t)),
            _ => Err(bad()),
        },
        _ => Err(bad()),
    };
    Some(r.map(|arg| EffectRequest {
        kind: THERMAL.to_string(),
        joint: 0,
        arg,
    }))
}

/// The largest thermal expansion (per kelvin) a calibration accepts: four times aluminium's
/// 2.3e-5, eight times steel's 1.2e-5.
pub const MOST_EXPANSION_PER_K: f64 = 1e-4;
/// The most negative one: carbon-fibre composites come near −1e-6 per kelvin; no arm's links
/// shrink by more as they warm.
pub const MOST_SHRINK_PER_K: f64 = -5e-6;

/// Why the thermal-expansion coefficient of `fitted` cannot be an arm's: the rest of a
/// sentence that starts "the fit", or `None` (also without the term). A temperature column
/// that does not follow the arm (rows in another order than their temperatures: the simulated
/// warm-up read in reverse fitted −1.22e-5 per kelvin with exit 0) gives a coefficient no arm
/// has.
///
/// Only when the data determine the coefficient (more than twice its 1-σ `sigma` from zero,
/// per kelvin): a steel arm measured over 1 K fits −27 ± 24 ppm per kelvin, which the data do
/// not determine ([`undetermined`] warns), while the real UR10's air temperature fits
/// 131 ± 23. Without a σ (constraint sessions give none yet) nothing tells, and nothing is
/// refused.
pub fn implausible<const N: usize, V: kinecal::ValueStorage>(
    fitted: &Robot<f64, N, V>,
    sigma: Option<f64>,
) -> Option<String> {
    let (_, c, _) = fitted.effects().thermal()?;
    let ppm = crate::output::numfmt::sig(c * 1e6, 3);
    if !c.is_finite() {
        return None;
    }
    let s = sigma.filter(|s| s.is_finite())?;
    if c.abs() <= 2.0 * s {
        return None;
    }
    if c < MOST_SHRINK_PER_K {
        Some(format!(
            "put the thermal expansion at {ppm} ppm per kelvin: the links would shrink as they \
             warm, by more than the {} ppm per kelvin of any arm's material; the temp_c column \
             does not follow the arm's temperature (another sensor's column, or temperatures \
             not in their rows): check it, or drop --effect thermal-expansion",
            crate::output::numfmt::sig(-MOST_SHRINK_PER_K * 1e6, 3)
        ))
    } else if c > MOST_EXPANSION_PER_K {
        Some(format!(
            "put the thermal expansion at {ppm} ppm per kelvin, beyond the {} ppm of any arm's \
             material: the temp_c column does not follow the arm's temperature, or varies too \
             little to tell: check it, or drop --effect thermal-expansion",
            crate::output::numfmt::sig(MOST_EXPANSION_PER_K * 1e6, 3)
        ))
    } else {
        None
    }
}

/// Whether `c` (per kelvin) lies within [`MOST_SHRINK_PER_K`]..[`MOST_EXPANSION_PER_K`], the
/// range of arms' materials (or is no number, which other checks refuse).
pub fn within_materials(c: f64) -> bool {
    (MOST_SHRINK_PER_K..=MOST_EXPANSION_PER_K).contains(&c) || !c.is_finite()
}

/// The warning for a fitted coefficient `c` (per kelvin, 1-σ `sigma`) outside
/// [`MOST_SHRINK_PER_K`]..[`MOST_EXPANSION_PER_K`] that [`implausible`] did not refuse (shown
/// only for a fit it did not refuse): the data do not determine it.
pub fn undetermined(c: f64, sigma: Option<f64>) -> Option<String> {
    let sig = crate::output::numfmt::sig;
    if within_materials(c) {
        return None;
    }
    Some(format!(
        "warning: the thermal expansion fitted, {}{} ppm per kelvin, lies outside the {} to {} \
         ppm of an arm's material, and the data do not determine it: the temperatures vary \
         too little; measure while the arm warms through several kelvin, or drop --effect \
         thermal-expansion",
        sig(c * 1e6, 3),
        sigma.map_or(String::new(), |s| format!(" ± {}", sig(s * 1e6, 2))),
        sig(MOST_SHRINK_PER_K * 1e6, 2),
        sig(MOST_EXPANSION_PER_K * 1e6, 3)
    ))
}

/// The warning for a coefficient `c` (per kelvin) fitted to a constraint session (which gives
/// it no σ yet, so [`implausible`] cannot refuse it) outside
/// [`MOST_SHRINK_PER_K`]..[`MOST_EXPANSION_PER_K`]: the temperatures reversed fitted −23.7
/// ppm per kelvin to a simulated warm-up of 23.
pub fn outside_materials(c: f64) -> Option<String> {
    let sig = crate::output::numfmt::sig;
    if within_materials(c) {
        return None;
    }
    Some(format!(
        "warning: the thermal expansion fitted, {} ppm per kelvin, lies outside the {} to {} \
         ppm of an arm's material (a constraint session gives it no σ, so this is not refused): \
         the temp_c column does not follow the arm's temperature (rows not in their \
         temperatures' order, another sensor, °F), or varies too little: check it, or drop \
         --effect thermal-expansion",
        sig(c * 1e6, 3),
        sig(MOST_SHRINK_PER_K * 1e6, 2),
        sig(MOST_EXPANSION_PER_K * 1e6, 3)
    ))
}

/// Fewer rows than this carrying a temperature change cannot tell an expansion from those
/// rows' own errors.
pub const MIN_WARMER_ROWS: usize = 5;
/// Temperatures within this (K) of each other are one temperature: a sensor's resolution.
pub const SAME_TEMPERATURE_K: f64 = 0.05;

/// The refusal of a thermal term whose temperature change rests on fewer than
/// [`MIN_WARMER_ROWS`] rows: those at least a quarter of the largest difference from the
/// median temperature. One row at 45 °C among rows at 21.00 °C fitted 7.4 ± 3.2 ppm per kelvin
/// from that row alone, with exit 0. `None` for temperatures that vary on enough rows, or not
/// at all (the term is then held: no observation moves with it).
pub fn too_few_rows<const N: usize>(data: &[Measurement<f64, N>]) -> Option<String> {
    let t: Vec<f64> = data.iter().filter_map(|m| m.temp_c).collect();
    if t.len() != data.len() || t.is_empty() {
        return None;
    }
    let median = super::stats::quantile(&t, 0.5);
    let far = t.iter().map(|v| (v - median).abs()).fold(0.0, f64::max);
    if far.is_nan() || far <= SAME_TEMPERATURE_K {
        return None;
    }
    let carrying = t
        .iter()
        .filter(|v| (*v - median).abs() >= far / 4.0)
        .count();
    (carrying < MIN_WARMER_ROWS).then(|| {
        format!(
            "--effect thermal-expansion: temp_c differs from the median {} °C on only {carrying} \
             of {} rows (by up to {} K): the coefficient would be fitted to those rows alone; \
             check their temperatures, or measure while the arm's temperature changes",
            crate::output::numfmt::sig(median, 4),
            t.len(),
            crate::output::numfmt::sig(far, 3)
        )
    })
}

/// Mean temperature (°C) of `data` when every observation has one.
pub fn mean_temperature<const N: usize>(data: &[Measurement<f64, N>]) -> Option<f64> {
    let t: Vec<f64> = data.iter().map(|m| m.temp_c).collect::<Option<_>>()?;
    (!t.is_empty()).then(|| t.iter().sum::<f64>() / t.len() as f64)
}

/// Adds a thermal-expansion term at `c = 0` to `robot`, its reference `req.arg` or the mean
/// temperature of `data`; returns its parameter. Refused without a temperature on every row.
pub fn add<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    req: &EffectRequest,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Vec<Param>> {
    let Some(mean) = mean_temperature(data) else {
        crate::refuse!(
            "--effect thermal-expansion: the data need a temp_c column with the arm's \
             temperature (°C) on every row"
        );
    };
    if robot.effects().thermal().is_some() {
        crate::refuse!("--effect thermal-expansion: the robot file has the term already");
    }
    if let Some(why) = too_few_rows(data) {
        crate::refuse!("{why}");
    }
    let reference = req.arg.unwrap_or(mean);
    let first = robot.effects().values().len();
    robot
        .effects_mut()
        .push(EffectKind::Thermal, 0, N, 1, reference, 0.0, &[0.0])
        .map_err(|e| anyhow::anyhow!("cannot add thermal-expansion: {e:?}"))?;
    Ok(vec![Param::Effect(first as u16)])
}

impl RobotFile {
    /// Gives a thermal-expansion term without `reference_c` and with a zero coefficient the
    /// reference `mean` (°C, the identification data's mean temperature, where the coefficient
    /// is least confounded with the lengths); true when it did (the model must be rebuilt). A
    /// term with a coefficient keeps the reference every other command reads it with (20 °C):
    /// referred to the mean, the file's robot would be another one (`identify`'s "before" on
    /// data simulated from the file was 0.158 mm where `check` found 5e-9 mm).
    pub fn with_thermal_reference(&mut self, mean: Option<f64>) -> bool {
        let Some(mean) = mean else {
            return false;
        };
        let mut changed = false;
        for e in self.effects.iter_mut() {
            if e.kind == THERMAL && e.reference_c.is_none() && e.values.iter().all(|v| *v == 0.0) {
                e.reference_c = Some(mean);
                changed = true;
            }
        }
        changed
    }
}
