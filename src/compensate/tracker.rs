//! Streaming compensation along a trajectory.

use super::config::Config;
use super::finite::all_finite;
use super::newton::{compensate, compensate_from};
use super::outcome::{CompensateError, Solution};
use super::target::Target;
use crate::ValueStorage;
use crate::{Real, Robot};

/// Streaming compensation along a trajectory: keeps the previous command and starts each cycle
/// from it, so a servo loop usually needs one or two Newton steps per cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker<T: Real, const N: usize> {
    /// Settings used by every cycle (may be changed between cycles).
    pub config: Config<T>,
    command: Option<[T; N]>,
    nominal: Option<[T; N]>,
}

impl<T: Real, const N: usize> Tracker<T, N> {
    /// A tracker with no trajectory yet: begin with [`Tracker::start`] or [`Tracker::next`].
    pub fn new(config: Config<T>) -> Self {
        Self {
            config,
            command: None,
            nominal: None,
        }
    }

    /// Forgets the trajectory (the next call starts from its seed).
    pub fn reset(&mut self) {
        self.command = None;
        self.nominal = None;
    }

    /// Starts a trajectory at the joints' current position (rad), for [`Tracker::follow`].
    pub fn start(&mut self, q: &[T; N]) -> Result<(), CompensateError<T, N>> {
        if !all_finite(q) {
            return Err(CompensateError::InvalidInput);
        }
        self.command = Some(*q);
        self.nominal = None;
        Ok(())
    }

    /// The last command returned (also after a typed error: its best safe command).
    pub fn last(&self) -> Option<&[T; N]> {
        self.command.as_ref()
    }

    /// One trajectory point with the controller's nominal inverse kinematics `nominal` for it:
    /// the step box is centred on `nominal` (the command never strays more than `max_step` from
    /// the controller's own trajectory), and the iteration starts from the previous correction
    /// carried over, `last command + (nominal − previous nominal)`, which stays good even if
    /// the nominal solution switches branch.
    pub fn next<V: ValueStorage>(
        &mut self,
        robot: &Robot<T, N, V>,
        target: &Target<T>,
        nominal: &[T; N],
    ) -> Result<Solution<T, N>, CompensateError<T, N>> {
        let mut start = *nominal;
        if let (Some(c), Some(n)) = (self.command, self.nominal) {
            for j in 0..N {
                start[j] = c[j] + (nominal[j] - n[j]);
            }
            if !all_finite(&start) {
                start = *nominal;
            }
        }
        let r = compensate_from(robot, target, nominal, &start, &self.config);
        self.remember(&r, Some(*nominal));
        r
    }

    /// One trajectory point without a nominal solution: the previous command is the seed, so
    /// the joints move at most `max_step` per cycle. Needs [`Tracker::start`] or an earlier call.
    pub fn follow<V: ValueStorage>(
        &mut self,
        robot: &Robot<T, N, V>,
        target: &Target<T>,
    ) -> Result<Solution<T, N>, CompensateError<T, N>> {
        let seed = self.command.ok_or(CompensateError::InvalidInput)?;
        let r = compensate(robot, target, &seed, &self.config);
        self.remember(&r, None);
        r
    }

    fn remember(
        &mut self,
        r: &Result<Solution<T, N>, CompensateError<T, N>>,
        nominal: Option<[T; N]>,
    ) {
        let sol = match r {
            Ok(s) => s,
            Err(e) => match e.best() {
                Some(s) => s,
                None => return,
            },
        };
        self.command = Some(sol.q);
        self.nominal = nominal;
    }
}
