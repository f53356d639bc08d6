//! Angles in the robot file: degrees that read back as the same radians, and the base's
//! roll/pitch/yaw written short.

use kinecal::Frame;

/// Degrees of an angle in radians, chosen among the nearest `f64`s so that
/// `deg_exact(r).to_radians() == r` whenever such a value exists (it almost always does).
pub fn deg_exact(rad: f64) -> f64 {
    let d0 = rad.to_degrees();
    if !d0.is_finite() || d0.to_radians() == rad {
        return d0;
    }
    let step = |x: f64, up: bool| -> f64 {
        // Next representable value towards +inf (up) or -inf.
        if x == 0.0 {
            return if up {
                f64::from_bits(1)
            } else {
                -f64::from_bits(1)
            };
        }
        let b = x.to_bits();
        let away = (x > 0.0) == up;
        f64::from_bits(if away { b + 1 } else { b - 1 })
    };
    let (mut lo, mut hi) = (d0, d0);
    for _ in 0..8 {
        lo = step(lo, false);
        hi = step(hi, true);
        if lo.to_radians() == rad {
            return lo;
        }
        if hi.to_radians() == rad {
            return hi;
        }
    }
    d0
}

/// Degrees of an angle in radians as the user would write them: the `f64` with the shortest
/// decimal form among those `d` with `d.to_radians() == rad` (so `(-60f64).to_radians()` gives
/// back `-60.0`, not `-59.99999999999999`), trying increasing precision. Keeps the guarantee of
/// [`deg_exact`] (which it falls back on): the value reads back as the same radians.
pub fn deg_short(rad: f64) -> f64 {
    let d0 = deg_exact(rad);
    if !d0.is_finite() || d0 == 0.0 {
        return d0;
    }
    for digits in 1..=17usize {
        // The nearest `digits`-significant-digit decimal, and its neighbours one unit of the
        // last digit either side (the set of exact values is a few ulps wide, so the shortest
        // decimal in it is one of these).
        let text = format!("{:.*e}", digits - 1, d0);
        let Some((mantissa, exp)) = text.split_once('e') else {
            continue;
        };
        let (Ok(m), Ok(e)) = (mantissa.parse::<f64>(), exp.parse::<i32>()) else {
            continue;
        };
        let unit = 10f64.powi(digits as i32 - 1);
        let m_int = (m * unit).round();
        let mut best: Option<f64> = None;
        for k in [0.0, -1.0, 1.0] {
            let cand: Option<f64> = format!("{}e{}", m_int + k, e - (digits as i32 - 1))
                .parse()
                .ok();
            if let Some(c) = cand {
                if c.to_radians() == rad && best.is_none_or(|b| (c - d0).abs() < (b - d0).abs()) {
                    best = Some(c);
                }
            }
        }
        if let Some(b) = best {
            return b;
        }
    }
    d0
}

/// Roll, pitch, yaw (degrees) of a base pose as the user would write them: the shortest
/// decimals (same number of significant digits for the three) from which
/// [`Frame::from_xyz_rpy`] rebuilds exactly this rotation, so a `[base]` read from a file is
/// written back as given (`1.0`, not `0.9999999999999998`). Falls back on [`deg_short`] of
/// each angle (an identified base's rotation, which no short decimals reproduce).
pub fn rpy_deg_short(base: &Frame<f64>) -> [f64; 3] {
    let rpy = base.rpy();
    let fallback = rpy.map(deg_short);
    if !fallback.iter().all(|v| v.is_finite()) {
        return fallback;
    }
    let xyz = [base.o.x, base.o.y, base.o.z];
    let same = |deg: [f64; 3]| {
        let f = Frame::from_xyz_rpy(xyz, deg.map(f64::to_radians));
        f.x == base.x && f.y == base.y && f.z == base.z
    };
    for digits in 1..=17usize {
        let cand = fallback.map(|d| {
            if d == 0.0 {
                0.0
            } else {
                format!("{:.*e}", digits - 1, d).parse().unwrap_or(d)
            }
        });
        if same(cand) {
            return cand;
        }
    }
    fallback
}
