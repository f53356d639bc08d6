//! The page model: everything the template shows, as text already formatted (significant
//! digits as `identify` prints them), so the template only lays it out.

use super::findings::Findings;
use serde::Serialize;

/// One cell of a statistics table: the printed number and the key the tests find it by
/// (`after.validation.total.rms`).
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub key: String,
    pub text: String,
}

/// One row of the accuracy table: a model on a set along one axis.
#[derive(Clone, Debug, Serialize)]
pub struct StatRow {
    /// `before` or `after`.
    pub model: String,
    /// `x`, `y`, `z`, `total` (distance) or `orientation` (degrees).
    pub axis: String,
    pub unit: String,
    /// RMS, mean, largest, 95th percentile.
    pub cells: Vec<Cell>,
}

/// The accuracy of both models on one set of poses.
#[derive(Clone, Debug, Serialize)]
pub struct SetTable {
    /// `identification` or `validation`.
    pub key: String,
    pub title: String,
    pub poses: usize,
    pub rows: Vec<StatRow>,
}

/// Joint coverage of the data (degrees).
#[derive(Clone, Debug, Serialize)]
pub struct JointRange {
    pub joint: usize,
    pub identification: String,
    pub validation: String,
    pub limits: String,
}

/// The data set.
#[derive(Clone, Debug, Serialize)]
pub struct DataSet {
    pub identification_poses: usize,
    pub validation_poses: usize,
    pub observations: usize,
    pub points: Vec<String>,
    pub kind: String,
    pub units: String,
    pub base: String,
    pub joints: Vec<JointRange>,
}

/// A line of the ISO 9283 table.
#[derive(Clone, Debug, Serialize)]
pub struct IsoRow {
    pub set: String,
    pub model: String,
    pub cells: Vec<Cell>,
    pub repeated: usize,
}

/// One repeated pose (ISO 9283 AP and RP).
#[derive(Clone, Debug, Serialize)]
pub struct IsoRepeat {
    pub set: String,
    pub rows: String,
    pub approaches: usize,
    pub ap: String,
    pub ap_xyz: String,
    pub rp: String,
}

/// A parameter row as printed.
#[derive(Clone, Debug, Serialize)]
pub struct ParamLine {
    pub name: String,
    pub unit: String,
    pub nominal: String,
    pub calibrated: String,
    pub change: String,
    pub sigma: String,
    /// `estimated`, `held` or `fixed`.
    pub status: String,
    pub reason: String,
}

/// One figure: its inline SVG and caption.
#[derive(Clone, Debug, Serialize)]
pub struct Figure {
    pub id: String,
    /// Inlined by the template module (not serialised: the template would escape it).
    #[serde(skip)]
    pub svg: String,
    pub caption: String,
}

/// Reflector residuals (several reflectors).
#[derive(Clone, Debug, Serialize)]
pub struct PointLine {
    pub name: String,
    pub observations: String,
    pub cells: Vec<Cell>,
}

/// One robot's row of the section's table.
#[derive(Clone, Debug, Serialize)]
pub struct ValidationRow {
    /// `model` or `nominal`.
    pub model: String,
    /// RMS, mean, largest, 95 % of the distance; RMS per axis; orientation RMS (degrees).
    pub cells: Vec<Cell>,
}

/// The validation section (`report --validate-json`, [`super::validation`]) as the page shows
/// it.
#[derive(Clone, Debug, Serialize)]
pub struct Validation {
    pub source: String,
    pub data_file: String,
    pub model_file: String,
    pub register: String,
    pub registered: String,
    pub poses: usize,
    /// The verdict is bad: the model is worse than the nominal robot, neither describes the
    /// session (`data_mismatch`), the robot changed since calibration, or the session holds
    /// wrong readings.
    pub worse_than_nominal: bool,
    /// The verdict is bad for another reason than the model being worse than the nominal
    /// robot: the page repeats the verdict alone.
    pub other_verdict: bool,
    /// Neither robot describes the session (the validation report's `data_mismatch`).
    pub data_mismatch: bool,
    pub verdict: String,
    pub rows: Vec<ValidationRow>,
    /// Several reflectors: name, model RMS, nominal RMS.
    pub points: Vec<[Cell; 3]>,
}

/// The whole page.
#[derive(Clone, Debug, Serialize)]
pub struct Page {
    pub title: String,
    pub robot_name: String,
    pub model_name: String,
    pub sources: Vec<(String, String)>,
    pub headline: String,
    pub verdict: String,
    pub converged: bool,
    pub warnings: Vec<String>,
    pub data: DataSet,
    pub sets: Vec<SetTable>,
    pub points: Vec<PointLine>,
    pub figures: Vec<Figure>,
    pub iso: Vec<IsoRow>,
    pub iso_repeats: Vec<IsoRepeat>,
    pub iso_note: String,
    pub params: Vec<ParamLine>,
    pub estimated: usize,
    pub held: Vec<ParamLine>,
    pub correlations: Vec<[String; 3]>,
    pub fit_note: String,
    pub findings: Option<Findings>,
    /// The model on another session (`report --validate-json`).
    pub validation: Option<Validation>,
}
