//! The measurement cell: laser tracker, floor, robot link capsules and obstacles, and the test
//! of whether a configuration can be measured there.
//!
//! Everything is expressed in the **robot base frame**. A configuration is feasible when
//! (Jost et al. 2017, §2.2 and §3.2):
//! - every joint reading is within its limits;
//! - the **angle of incidence** between the tool z axis (the measured frame's, `[tool] rpy_deg`
//!   turning the flange's: the reflector's central axis) and the
//!   beam from the reflector *to the tracker* is at most the tracker's limit. The reflector faces
//!   the tracker, so the sign matters: a tool pointing away from the tracker is infeasible (the
//!   paper's condition compares ⁰z with ⁰g, the beam from the reflector to the tracker);
//! - the measured point and every robot capsule are above the floor plane (the capsules'
//!   lowest surface points above `floor_z`);
//! - robot capsules do not touch each other, except those on the same or neighbouring bodies
//!   (frames adjacent in the sorted list of frames that carry capsules): joint limits keep
//!   those apart, and their capsules overlap at the joints by construction;
//! - robot capsules do not touch obstacle capsules;
//! - the **beam** (a thin capsule from the tracker to the reflector) is not cut by an obstacle
//!   or by a robot capsule. Capsules on the last joint's frame are excluded from the beam test:
//!   that body carries the reflector, so its capsules reach up to the beam's end point by
//!   construction, and the incidence limit is what keeps the beam clear of it (the beam leaves
//!   the reflector within the limit of the tool z axis, away from the flange behind it).
//!   Capsules on every other frame, the wrist included, must keep clear of the whole beam, so
//!   they must not enclose the reflector.

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::planning::capsule::{segment_distance, Capsule};
use crate::ValueStorage;
use crate::{ForwardKinematics, Frame, Real, Robot};
use heapless::Vec;
use nalgebra::Vector3;

/// A capsule fixed to a robot body: `frame` 0 is the base, `i` is joint `i`'s frame (after
/// `T_i`, so it moves with joint `i`); the end points are given in that frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkCapsule<T: Real> {
    /// The robot frame it is fixed to (0 = base, `i` = joint `i`).
    pub frame: u8,
    /// The capsule, in that frame (mm).
    pub capsule: Capsule<T>,
}

/// The laser tracker: where it stands and what it can see.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker<T: Real> {
    /// Position of the tracker head, mm, robot base frame.
    pub position: Vector3<T>,
    /// Largest angle (rad) between the tool z axis and the beam from the reflector to the tracker.
    pub max_incidence: T,
    /// Radius of the capsule that stands for the beam, mm.
    pub beam_radius: T,
}

/// Why a scene was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SceneError {
    /// More capsules than the scene's capacity.
    Capacity,
    /// A number is NaN or infinite, a radius is negative, or the incidence limit is outside
    /// (0°, 180°].
    Invalid,
}

/// The first reason a configuration is infeasible (indices into the scene's lists).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Violation {
    /// Joint `joint` (0-based) is outside its limits, or a reading is not finite.
    Limits {
        /// The joint (0-based).
        joint: u8,
    },
    /// The reflector does not face the tracker closely enough (or sits on the tracker).
    Incidence,
    /// Link capsule `link` reaches below the floor.
    Floor {
        /// Index of the link capsule.
        link: u8,
    },
    /// The measured point (the reflector on the tool) is below the floor: checked with or
    /// without link capsules, since a cell may give a floor and no capsules.
    PointBelowFloor,
    /// Link capsules `first` and `second` (of non-neighbouring bodies) touch.
    SelfCollision {
        /// Index of one link capsule.
        first: u8,
        /// Index of the other link capsule.
        second: u8,
    },
    /// Link capsule `link` touches obstacle `obstacle`.
    Obstacle {
        /// Index of the link capsule.
        link: u8,
        /// Index of the obstacle.
        obstacle: u8,
    },
    /// Link capsule `link` cuts the beam.
    BeamLink {
        /// Index of the link capsule.
        link: u8,
    },
    /// Obstacle `obstacle` cuts the beam.
    BeamObstacle {
        /// Index of the obstacle.
        obstacle: u8,
    },
    /// A link capsule names a frame the robot does not have.
    UnknownFrame {
        /// Index of the link capsule.
        link: u8,
    },
}

/// What the scene says about one configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Assessment<T: Real> {
    /// Angle of incidence (rad); π when the point coincides with the tracker.
    pub incidence: T,
    /// Smallest surface distance (mm) over every compared pair, the floor and the beam
    /// (only meaningful when no violation was found: the check stops at the first one).
    pub clearance: T,
    /// `None` when the configuration is feasible.
    pub violation: Option<Violation>,
}

impl<T: Real> Assessment<T> {
    /// True when no check failed.
    pub fn feasible(&self) -> bool {
        self.violation.is_none()
    }
}

/// A measurement cell with room for `C` link capsules and `O` obstacles.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene<T: Real, const C: usize, const O: usize> {
    tracker: Tracker<T>,
    cos_max: T,
    floor_z: Option<T>,
    links: Vec<LinkCapsule<T>, C>,
    /// Rank of each link capsule's frame among the distinct frames that carry capsules.
    body: [u8; C],
    obstacles: Vec<Capsule<T>, O>,
}

impl<T: Real, const C: usize, const O: usize> Scene<T, C, O> {
    /// A cell with a tracker and optionally a floor plane, no capsules yet.
    pub fn new(tracker: Tracker<T>, floor_z: Option<T>) -> Result<Self, SceneError> {
        let ok = tracker.position.iter().all(|v| v.finite())
            && tracker.beam_radius.finite()
            && tracker.beam_radius >= T::zero()
            && tracker.max_incidence > T::zero()
            && tracker.max_incidence <= T::pi()
            && floor_z.is_none_or(|z| z.finite());
        if !ok {
            return Err(SceneError::Invalid);
        }
        Ok(Self {
            tracker,
            cos_max: tracker.max_incidence.cos(),
            floor_z,
            links: Vec::new(),
            body: [0; C],
            obstacles: Vec::new(),
        })
    }

    /// The tracker.
    pub fn tracker(&self) -> &Tracker<T> {
        &self.tracker
    }
    /// Height of the floor plane (mm, robot base frame), if the cell has one.
    pub fn floor_z(&self) -> Option<T> {
        self.floor_z
    }
    /// The capsules fixed to the robot, in the order added.
    pub fn link_capsules(&self) -> &[LinkCapsule<T>] {
        &self.links
    }
    /// The obstacles (robot base frame), in the order added.
    pub fn obstacles(&self) -> &[Capsule<T>] {
        &self.obstacles
    }

    /// Adds a capsule fixed to robot frame `frame` (0 = base, i = joint i).
    pub fn add_link_capsule(&mut self, frame: u8, capsule: Capsule<T>) -> Result<(), SceneError> {
        if !capsule.is_valid() {
            return Err(SceneError::Invalid);
        }
        self.links
            .push(LinkCapsule { frame, capsule })
            .map_err(|_| SceneError::Capacity)?;
        // Rank = number of distinct capsule frames below this one's.
        for i in 0..self.links.len() {
            let f = self.links[i].frame;
            let mut seen = [false; 256];
            let mut rank = 0u8;
            for l in self.links.iter() {
                if l.frame < f && !seen[l.frame as usize] {
                    seen[l.frame as usize] = true;
                    rank += 1;
                }
            }
            if let Some(b) = self.body.get_mut(i) {
                *b = rank;
            }
        }
        Ok(())
    }

    /// Adds an obstacle capsule (robot base frame).
    pub fn add_obstacle(&mut self, capsule: Capsule<T>) -> Result<(), SceneError> {
        if !capsule.is_valid() {
            return Err(SceneError::Invalid);
        }
        self.obstacles
            .push(capsule)
            .map_err(|_| SceneError::Capacity)
    }

    /// True when link capsules `i` and `j` are compared for self-collision: they sit on bodies
    /// that are neither the same nor neighbours in the sorted list of capsule-carrying frames.
    pub fn compared(&self, i: usize, j: usize) -> bool {
        match (self.body.get(i), self.body.get(j)) {
            (Some(a), Some(b)) => a.abs_diff(*b) >= 2,
            _ => false,
        }
    }

    /// Angle of incidence (rad) of a reflector at `point` with axis `z` (base frame).
    pub fn incidence(&self, point: &Vector3<T>, z: &Vector3<T>) -> T {
        let (c, _) = self.cos_incidence(point, z);
        c.acos()
    }

    /// Cosine of the incidence angle (clamped to [−1, 1]) and the beam length.
    fn cos_incidence(&self, point: &Vector3<T>, z: &Vector3<T>) -> (T, T) {
        let g = self.tracker.position - point;
        let len = g.norm();
        let zn = z.norm();
        if !(len > T::zero()) || !(zn > T::zero()) {
            return (-T::one(), len);
        }
        let c = g.dot(z) / (len * zn);
        (c.max(-T::one()).min(T::one()), len)
    }

    /// Checks the configuration whose forward kinematics is in `fk` (computed with `robot`;
    /// any base pose: frames are mapped back into the robot base frame). With `collisions`
    /// false only the joint limits and the incidence angle are checked (clearance is then
    /// reported as +∞), which is what a design "without collision avoidance" uses.
    ///
    /// Stops at the first violation; when there is none, `clearance` is the smallest of all
    /// compared surface distances.
    pub fn check<const N: usize, V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        fk: &ForwardKinematics<T, N>,
        collisions: bool,
    ) -> Assessment<T> {
        let mut out = Assessment {
            incidence: T::pi(),
            clearance: T::max_value().unwrap_or(T::one()),
            violation: None,
        };
        for (i, (q, j)) in fk.q.iter().zip(robot.joints().iter()).enumerate() {
            if !(*q >= j.lower && *q <= j.upper) {
                out.violation = Some(Violation::Limits { joint: i as u8 });
                return out;
            }
        }
        if N == 0 {
            out.violation = Some(Violation::Incidence);
            return out;
        }
        let to_base = fk.base.inverse();
        let rel = |f: &Frame<T>| to_base.compose(f);
        let point = to_base.point(&fk.point);
        // The measured frame's z axis (the reflector's), not the flange's: a tool turned by
        // `[tool] rpy_deg` faces the tracker along its own axis.
        let tool = rel(&fk.tool_pose(robot));
        let (c, _) = self.cos_incidence(&point, &tool.z);
        out.incidence = c.acos();
        if !(c >= self.cos_max) {
            out.violation = Some(Violation::Incidence);
            return out;
        }
        if !collisions {
            return out;
        }
        match self.collision_clearance(fk, &point, true) {
            Ok(min) => out.clearance = min,
            Err(v) => out.violation = Some(v),
        }
        out
    }

    /// Smallest signed surface distance (mm) over every compared pair of capsules, the floor
    /// and the beam at the configuration in `fk`, without stopping at the first collision
    /// (negative = the deepest penetration): how far a pose is from colliding, or how badly it
    /// collides. Joint limits and incidence are not looked at. A capsule on an unknown frame
    /// gives −∞.
    pub fn clearance<const N: usize>(&self, fk: &ForwardKinematics<T, N>) -> T {
        let point = fk.base.inverse().point(&fk.point);
        match self.collision_clearance(fk, &point, false) {
            Ok(min) => min,
            Err(_) => -T::max_value().unwrap_or(T::one()),
        }
    }

    /// The collision part of [`Scene::check`]; with `stop` the first violation is returned
    /// as an error, otherwise only an unknown frame is.
    fn collision_clearance<const N: usize>(
        &self,
        fk: &ForwardKinematics<T, N>,
        point: &Vector3<T>,
        stop: bool,
    ) -> Result<T, Violation> {
        let to_base = fk.base.inverse();
        let rel = |f: &Frame<T>| to_base.compose(f);
        let point = *point;
        let mut min = T::max_value().unwrap_or(T::one());
        let mut hit = |d: T, v: Violation| -> Result<(), Violation> {
            if stop && !(d > T::zero()) {
                return Err(v);
            }
            min = min.min(d);
            Ok(())
        };
        // Place the link capsules (frame 0 = base = identity in the base frame).
        let mut placed = [Capsule::new(Vector3::zeros(), Vector3::zeros(), T::zero()); C];
        for (k, (l, p)) in self.links.iter().zip(placed.iter_mut()).enumerate() {
            let f = l.frame as usize;
            *p = if f == 0 {
                l.capsule
            } else if f <= N {
                l.capsule.placed(&rel(&fk.frames[f - 1]))
            } else {
                return Err(Violation::UnknownFrame { link: k as u8 });
            };
        }
        let placed = &placed[..self.links.len()];
        if let Some(z) = self.floor_z {
            hit(point.z - z, Violation::PointBelowFloor)?;
            for (k, p) in placed.iter().enumerate() {
                let d = p.clearance_above(z);
                hit(d, Violation::Floor { link: k as u8 })?;
            }
        }
        for i in 0..placed.len() {
            for j in i + 1..placed.len() {
                if self.compared(i, j) {
                    let d = placed[i].clearance(&placed[j]);
                    hit(
                        d,
                        Violation::SelfCollision {
                            first: i as u8,
                            second: j as u8,
                        },
                    )?;
                }
            }
        }
        for (i, p) in placed.iter().enumerate() {
            for (j, o) in self.obstacles.iter().enumerate() {
                let d = p.clearance(o);
                hit(
                    d,
                    Violation::Obstacle {
                        link: i as u8,
                        obstacle: j as u8,
                    },
                )?;
            }
        }
        let beam = Capsule::new(self.tracker.position, point, self.tracker.beam_radius);
        for (j, o) in self.obstacles.iter().enumerate() {
            let d = beam.clearance(o);
            hit(d, Violation::BeamObstacle { obstacle: j as u8 })?;
        }
        for (i, (p, l)) in placed.iter().zip(self.links.iter()).enumerate() {
            if l.frame as usize == N {
                continue;
            }
            let d =
                segment_distance(&beam.a, &beam.b, &p.a, &p.b).distance - beam.radius - p.radius;
            hit(d, Violation::BeamLink { link: i as u8 })?;
        }
        Ok(min)
    }
}
