//! The candidate's columns of the identification Jacobian at every pose, read off one set of
//! forward kinematics per round ([`PoseKinematics`]) and laid out block after block
//! ([`PoseColumns`]): what the linearised screen ([`crate::diagnose::cross_validation::Linearised`])
//! appends to the current model's normal equations.

use crate::diagnose::table_screen::{AlongReading, ReadingBlocks};
use kinecal::model::effects::{Effect, EffectKind};
use kinecal::{Couplings, ForwardKinematics, Measurement, Param, Robot};
use nalgebra::Vector3;
use std::sync::{Arc, OnceLock};

/// The sparse scaled columns `(column index, ∂p/∂x)` of every block of rows (one per position
/// observation, the point's then the orientation's for a 6-D one), block after block in one
/// buffer: the screen builds one set per candidate, and a vector per block would cost thousands
/// of allocations each time. Here a "pose" is one such block.
///
/// A table candidate's columns are kept as its grid and each block's reading and direction
/// ([`AlongReading`]): the screen's sums need nothing else, and the listed columns are
/// written out only when first asked for ([`Self::pose`]).
#[derive(Clone, Debug)]
pub struct PoseColumns {
    /// The listed columns (for a table: written out from `along` when first asked for).
    listed: OnceLock<Listed>,
    /// A table candidate's columns along its joint's reading direction.
    along: Option<AlongReading>,
}

/// Pose `i`'s columns are `entries[offsets[i]..offsets[i + 1]]`.
#[derive(Clone, Debug)]
struct Listed {
    offsets: Vec<usize>,
    entries: Vec<(usize, Vector3<f64>)>,
}

impl PoseColumns {
    /// No pose yet, room for `poses` poses with `entries` columns in all.
    pub fn with_capacity(poses: usize, entries: usize) -> Self {
        let mut offsets = Vec::with_capacity(poses + 1);
        offsets.push(0);
        Self::listed(Listed {
            offsets,
            entries: Vec::with_capacity(entries),
        })
    }

    /// `poses` poses without columns.
    pub fn empty(poses: usize) -> Self {
        Self::listed(Listed {
            offsets: vec![0; poses + 1],
            entries: Vec::new(),
        })
    }

    fn listed(listed: Listed) -> Self {
        Self {
            listed: OnceLock::from(listed),
            along: None,
        }
    }

    /// A table's columns, `along` its joint's reading directions.
    pub fn of_table(along: AlongReading) -> Self {
        Self {
            listed: OnceLock::new(),
            along: Some(along),
        }
    }

    /// The listed columns, written out from [`Self::along`] if not yet.
    fn entries(&self) -> &Listed {
        self.listed.get_or_init(|| {
            self.along.as_ref().map_or_else(
                || Listed {
                    offsets: vec![0],
                    entries: Vec::new(),
                },
                list_table,
            )
        })
    }

    /// Appends the next pose, with these columns (the columns are then no longer known to lie
    /// along a reading direction: [`Self::along`] is cleared).
    pub fn push_pose(&mut self, columns: impl IntoIterator<Item = (usize, Vector3<f64>)>) {
        self.entries();
        self.along = None;
        let listed = self.listed.get_mut().expect("written out above");
        listed.entries.extend(columns);
        listed.offsets.push(listed.entries.len());
    }

    /// The number of poses.
    pub fn poses(&self) -> usize {
        match (&self.along, self.listed.get()) {
            (_, Some(listed)) => listed.offsets.len() - 1,
            (Some(along), None) => along.blocks.directions.len(),
            (None, None) => 0,
        }
    }

    /// The columns of pose `i`.
    pub fn pose(&self, i: usize) -> &[(usize, Vector3<f64>)] {
        let listed = self.entries();
        &listed.entries[listed.offsets[i]..listed.offsets[i + 1]]
    }

    /// The columns as a table's along its joint's reading direction, when they were built so
    /// ([`PoseKinematics::columns`] of a table).
    pub fn along(&self) -> Option<&AlongReading> {
        self.along.as_ref()
    }
}

/// A table's listed columns: at each block only the two knots around its reading can be
/// non-zero, `d · φ_k / scale_k` (`d` the block's weighted column of the corrected reading),
/// as [`ForwardKinematics::column`] would compute them without asking it for every knot of a
/// table of up to 200.
fn list_table(along: &AlongReading) -> Listed {
    let blocks = along.blocks.directions.len();
    let mut offsets = Vec::with_capacity(blocks + 1);
    offsets.push(0);
    let mut entries = Vec::with_capacity(2 * blocks);
    let (e, scale) = (&along.table, &along.scales);
    for (d, &q) in along.blocks.directions.iter().zip(&along.blocks.readings) {
        let (seg, w) = e.segment(q);
        entries.extend(
            [(seg, 1.0 - w), (seg + 1, w)]
                .into_iter()
                .filter(|&(_, phi)| phi != 0.0)
                .filter_map(|(k, phi)| non_zero(k, d * (phi / scale[k]))),
        );
        offsets.push(entries.len());
    }
    Listed { offsets, entries }
}

/// The scaled columns of `params` at every pose of `data` for `robot` (for a candidate: the
/// robot with the candidate added at zero values, so the points are the current model's).
pub fn candidate_columns<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
    data: &[Measurement<f64, N>],
) -> PoseColumns {
    PoseKinematics::new(robot, data).columns(robot, params)
}

/// The forward kinematics of every pose at one model, computed once for the whole screen of a
/// round.
///
/// A candidate joins the model at zero values, so the candidate robot's frames and points are
/// the model's own: only its Jacobian columns are new, and [`ForwardKinematics::column`] reads
/// them off the frames (plus the candidate's effect definition). The frames are computed with
/// the lever arms (a zero compliance term is added when the model has none, which changes no
/// angle), so that a compliance candidate's columns can be read off them too.
#[derive(Clone, Debug)]
pub struct PoseKinematics<const N: usize> {
    poses: Vec<ForwardKinematics<f64, N>>,
    /// Each observation's point weights (None: unit) and, for a 6-D one, its orientation's.
    weights: Vec<(Option<Vector3<f64>>, Option<f64>)>,
    /// Per joint, its reading directions and readings at every block, formed at the first
    /// table on it: they depend only on the frames and the couplings, the same for every
    /// candidate added at zero values.
    along: Vec<OnceLock<Arc<ReadingBlocks>>>,
    /// The couplings of the model the frames were computed for (a robot with others gets its
    /// own reading blocks, not the shared ones).
    couplings: Couplings<f64, N>,
}

impl<const N: usize> PoseKinematics<N> {
    pub fn new<V: kinecal::ValueStorage>(
        robot: &Robot<f64, N, V>,
        data: &[Measurement<f64, N>],
    ) -> Self {
        let probe = with_lever_arms(robot);
        let mut fk = ForwardKinematics::new();
        let poses = data
            .iter()
            .map(|m| {
                fk.compute_at(&probe, &m.q, m.tool as usize, m.conditions());
                fk
            })
            .collect();
        let weights = data
            .iter()
            .map(|m| {
                (
                    (m.weight != Vector3::repeat(1.0)).then_some(m.weight),
                    m.orientation.map(|_| m.orientation_weight),
                )
            })
            .collect();
        Self {
            poses,
            weights,
            along: (0..N).map(|_| OnceLock::new()).collect(),
            couplings: *robot.couplings(),
        }
    }

    /// The non-zero scaled columns of `params` at every observation for `robot` (the model
    /// the frames were computed for, possibly with a candidate added at zero values), weighted
    /// as [`crate::diagnose::linear::Problem::pose_rows`] weighs them: one block per position
    /// observation, the point's then the orientation's for a 6-D one.
    pub fn columns<V: kinecal::ValueStorage>(
        &self,
        robot: &Robot<f64, N, V>,
        params: &[Param],
    ) -> PoseColumns {
        let reach = robot.reach();
        let scale: Vec<f64> = params.iter().map(|p| p.scale(reach)).collect();
        let table = table_of(robot, params);
        if let Some(e) = table {
            return self.table_columns(robot, e, &scale);
        }
        let mut out = PoseColumns::with_capacity(self.poses.len(), params.len() * self.poses.len());
        for (fk, (w, wo)) in self.poses.iter().zip(&self.weights) {
            let point = |c: Vector3<f64>| w.map_or(c, |w| c.component_mul(&w));
            out.push_pose(
                params
                    .iter()
                    .enumerate()
                    .filter_map(|(k, p)| non_zero(k, point(fk.column(robot, *p).ok()? / scale[k]))),
            );
            let Some(wo) = *wo else { continue };
            out.push_pose(params.iter().enumerate().filter_map(|(k, p)| {
                non_zero(k, fk.rotation_column(robot, *p).ok()? * (wo / scale[k]))
            }));
        }
        out
    }

    /// [`Self::columns`] of table `e`'s knots (`scale` per knot), along the joint's reading
    /// direction ([`PoseColumns::of_table`]): each block's weighted column of the corrected
    /// reading and its reading.
    fn table_columns<V: kinecal::ValueStorage>(
        &self,
        robot: &Robot<f64, N, V>,
        e: &Effect<f64>,
        scale: &[f64],
    ) -> PoseColumns {
        let j = e.joint as usize;
        let along = AlongReading {
            blocks: if *robot.couplings() == self.couplings {
                Arc::clone(self.along[j].get_or_init(|| Arc::new(self.reading_blocks(robot, j))))
            } else {
                Arc::new(self.reading_blocks(robot, j))
            },
            table: *e,
            scales: scale.to_vec(),
        };
        PoseColumns::of_table(along)
    }

    /// Joint `j`'s weighted reading column and reading at every block of rows.
    fn reading_blocks<V: kinecal::ValueStorage>(
        &self,
        robot: &Robot<f64, N, V>,
        j: usize,
    ) -> ReadingBlocks {
        let blocks = self.blocks();
        let mut out = ReadingBlocks {
            directions: Vec::with_capacity(blocks),
            readings: Vec::with_capacity(blocks),
        };
        for (fk, (w, wo)) in self.poses.iter().zip(&self.weights) {
            let jc = fk.reading_column(robot, j);
            out.directions.push(w.map_or(jc, |w| jc.component_mul(&w)));
            out.readings.push(fk.q[j]);
            if let Some(wo) = *wo {
                out.directions
                    .push(fk.reading_rotation_column(robot, j) * wo);
                out.readings.push(fk.q[j]);
            }
        }
        out
    }

    /// The number of blocks of rows: one per position observation, two per 6-D one.
    fn blocks(&self) -> usize {
        self.poses.len() + self.weights.iter().filter(|(_, wo)| wo.is_some()).count()
    }
}

/// `robot` with the lever arms in its forward kinematics: itself when a compliance term needs
/// them, otherwise with a zero compliance term on the first joint. (When there is no room for
/// one, no compliance candidate fits either, so no column needs them.)
fn with_lever_arms<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
) -> Robot<f64, N, V> {
    let mut probe = robot.clone();
    if N > 0 && !robot.effects().needs_lever_arms() {
        let _ = probe
            .effects_mut()
            .push(EffectKind::Compliance, 0, N, 1, 0.0, 0.0, &[0.0]);
    }
    probe
}

/// The table of `robot` whose knots are exactly `params` (in order), if they are one.
fn table_of<'r, const N: usize, V: kinecal::ValueStorage>(
    robot: &'r Robot<f64, N, V>,
    params: &[Param],
) -> Option<&'r Effect<f64>> {
    let Some(Param::Effect(first)) = params.first() else {
        return None;
    };
    let e = robot
        .effects()
        .iter()
        .find(|e| e.kind == EffectKind::Table && e.first == *first)?;
    let knots = (e.first..e.first + e.len).map(Param::Effect);
    (knots.eq(params.iter().copied()) && (e.joint as usize) < N).then_some(e)
}

/// `(k, c)` unless the column `c` is zero (a pose that does not excite the parameter).
fn non_zero(k: usize, c: Vector3<f64>) -> Option<(usize, Vector3<f64>)> {
    (c.norm_squared() > 0.0).then_some((k, c))
}
