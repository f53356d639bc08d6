//! The pace of a `t_s` column: a tracker measures a robot's pose in seconds (the arm moves,
//! settles, the tracker averages), so a session's rows are about 1 to 60 s apart. A column
//! whose rows are a median of milliseconds or of hours apart is in another unit than seconds
//! (milliseconds read as seconds make 400 poses a 41-day session; hours, a 1-second one), and
//! everything read per second (the base-drift velocity, diagnose's drift) is off by that
//! factor: the simulated 0.525 mm per hour came out as 0.000525 and as 1,890. Minutes read as
//! seconds make a median step of a fraction of a second between poses the arm moved to, which
//! no arm settles in. The model is not affected, so it is a warning.

/// `t_s` beyond this (s, 1973 since 1970) are dates: one clock for every session.
pub const DATED_S: f64 = 1e8;

/// A median step between rows shorter than this (s), in a session shorter than
/// [`SHORTEST_SESSION_S`], is not a tracker's pace: several readings of one pose (0.1 s apart)
/// or a stream are, but those take minutes in all.
pub const FASTEST_STEP_S: f64 = 0.2;
/// A whole session (first to last `t_s`) shorter than this (s) with rows a median of less than
/// [`FASTEST_STEP_S`] apart: hours or minutes read as seconds (400 poses in 1 s).
pub const SHORTEST_SESSION_S: f64 = 120.0;
/// A median step between rows longer than this (s) is not a tracker's pace (a study of one
/// pose every 12 minutes is).
pub const SLOWEST_STEP_S: f64 = 3600.0;
/// A median step longer than this (s) in a session of relative times longer than
/// [`LONGEST_SESSION_S`]: milliseconds read as seconds (a pose every 2.5 s makes 400 poses an
/// 11-day session).
pub const SLOW_STEP_S: f64 = 300.0;
/// See [`SLOW_STEP_S`]: two days.
pub const LONGEST_SESSION_S: f64 = 172_800.0;

/// A row whose joints moved more than this (degrees, any joint) from the row before took the
/// arm a move and a settling: at least [`SETTLED_STEP_S`] (a stream of a moving arm logged at
/// 10 Hz moves a joint by a few degrees from row to row, repeated readings of a pose not at
/// all; 20° in 0.1 s is 200° per second).
pub const MOVE_DEG: f64 = 20.0;
/// See [`MOVE_DEG`]: the median step (s) between such rows below this is minutes or hours
/// read as seconds (150 poses over an hour logged in minutes: 0.4 "s" apart; 300 over eight
/// hours: 1.6 "s"). The real UR10 series A (`data/ur10/published`, its rows' dates) takes a
/// median of 16 s, and at least 12 s, from one pose to the next after such a move.
pub const SETTLED_STEP_S: f64 = 2.0;

/// Fewer forward steps than this tell no pace.
pub const MIN_STEPS: usize = 10;

/// The warning for `times` (`t_s` of the rows in file order, seconds as read) whose median
/// forward step lies below [`FASTEST_STEP_S`] over a session (the forward steps summed) shorter
/// than [`SHORTEST_SESSION_S`], or above [`SLOWEST_STEP_S`], or whose rows after a move of the
/// arm ([`MOVE_DEG`]: `moved[i]` for row `i + 1`) are a median of less than
/// [`SETTLED_STEP_S`] apart; `origin` names the file.
pub fn warning(times: &[f64], moved: &[bool], origin: &str) -> Option<String> {
    let mut steps: Vec<f64> = times
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if steps.len() < MIN_STEPS {
        return None;
    }
    let mut after_moves: Vec<f64> = times
        .windows(2)
        .zip(moved)
        .filter(|(_, &m)| m)
        .map(|(w, _)| w[1] - w[0])
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    after_moves.sort_by(f64::total_cmp);
    // The median step after the arm's moves, when it is too short to have settled.
    let unsettled = (after_moves.len() >= MIN_STEPS)
        .then(|| after_moves[after_moves.len() / 2])
        .filter(|m| *m < SETTLED_STEP_S);
    let span = steps.iter().sum::<f64>();
    // Dates (Unix times) are one clock for several days' sessions.
    let dated = times.iter().any(|t| t.abs() > DATED_S);
    steps.sort_by(f64::total_cmp);
    let median = steps[steps.len() / 2];
    let sig = crate::output::numfmt::sig;
    let median = unsettled.unwrap_or(median);
    let unit = if (median < FASTEST_STEP_S && span < SHORTEST_SESSION_S) || unsettled.is_some() {
        "hours or minutes"
    } else if median > SLOWEST_STEP_S
        || (median > SLOW_STEP_S && span > LONGEST_SESSION_S && !dated)
    {
        "milliseconds"
    } else {
        return None;
    };
    Some(format!(
        "warning: {origin}: t_s advances a median of {} s {}, where a tracker measures a \
         pose in about 1 to 60 s: if t_s is in {unit}, give it in seconds; the drift per hour \
         (base-drift, diagnose) is read from it",
        sig(median, 3),
        if unsettled.is_some() {
            "from one pose of the arm to the next"
        } else {
            "from row to row"
        }
    ))
}
