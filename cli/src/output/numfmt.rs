//! Numbers for people: significant digits instead of fixed decimals, so that 0.0178 → 0.0174 mm
//! does not print as "0.018 → 0.018", and never `inf` or `NaN` inside a sentence. (Robot files
//! are written with the shortest round-tripping decimals: `robot_file::deg_short`.)

/// `x` with `digits` significant digits (at least 1), in plain notation for magnitudes between
/// 1e-4 and 1e6 and in scientific notation outside; `-` for a value that is not finite.
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return "-".to_string();
    }
    let digits = digits.max(1);
    if x == 0.0 {
        return "0".to_string();
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{:.*e}", digits - 1, x);
    }
    // Round first: 9.9996 to 4 digits is 10.00, one decimal fewer than the magnitude says.
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    let rounded: f64 = format!("{x:.decimals$}").parse().unwrap_or(x);
    let mag2 = if rounded == 0.0 {
        mag
    } else {
        rounded.abs().log10().floor() as i32
    };
    let decimals = (digits as i32 - 1 - mag2).max(0) as usize;
    format!("{rounded:.decimals$}")
}
