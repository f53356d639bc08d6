"""kinecal from Python: kinematic calibration of robot arms, numpy in, numpy out.

The numbers are the ``kinecal`` command line's: every function calls, in memory, the application
functions the subcommand calls (numpy arrays in, typed results out, no temporary files), with
the command line's defaults and its one-line reasons on errors.

>>> import kinecal
>>> robot = kinecal.Robot.from_file("robot.toml")              # doctest: +SKIP
>>> data = kinecal.read_csv("ur10_random_poses.csv")           # doctest: +SKIP
>>> result = kinecal.identify(robot, data.q[:1000], data.xyz[:1000],
...                           validate=(data.q[1000:], data.xyz[1000:]))  # doctest: +SKIP
>>> result.after["validation_rms_mm"]                          # doctest: +SKIP

Units: millimetres and degrees, as in the files (``length_unit="m"``, ``angle_unit="rad"`` for
other data; without them, data that look like other units are refused with the command line's
reason, as :class:`RefusedError`).
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._errors import DataWarning, KinecalError, NotConvergedWarning, RefusedError

Robot = _native.Robot

__all__ = [
    "Robot",
    "Measurements",
    "IdentifyResult",
    "CommandResult",
    "identify",
    "diagnose",
    "compensate",
    "compensate_cartesian",
    "frames",
    "plan",
    "simulate",
    "check",
    "read_csv",
    "write_csv",
    "KinecalError",
    "RefusedError",
    "NotConvergedWarning",
    "DataWarning",
]

PathLike = Union[str, "os.PathLike[str]"]


# --------------------------------------------------------------------------------------------
# Measurement sets


@dataclass
class Measurements:
    """A measurement set as a file holds it: joint readings ``q`` (n, N), measured points
    ``xyz`` (n, 3) and further columns by name (``temp_c``, ``rx_deg``, ``sx_mm``, ``sweep``,
    ``x_NAME`` …; NaN = empty cell), in the file's units."""

    q: np.ndarray
    xyz: np.ndarray
    columns: Dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(np.shape(self.q)[0])

    def __getitem__(self, rows: Any) -> "Measurements":
        """The rows ``rows`` (a slice, index array or mask) of every column."""
        return Measurements(
            np.asarray(self.q)[rows],
            np.asarray(self.xyz)[rows],
            {k: np.asarray(v)[rows] for k, v in self.columns.items()},
        )

    def write(self, path: PathLike) -> None:
        """Writes the measurement CSV file (every number exactly; atomically)."""
        write_csv(path, self.q, self.xyz, self.columns)


def read_csv(path: PathLike, joints: Optional[int] = None) -> Measurements:
    """Reads a measurement CSV file (docs/formats.md) as written, no unit conversion.

    ``joints`` defaults to the largest ``qK`` of the header. A malformed file raises
    :class:`RefusedError` with the command line's ``FILE:LINE:COLUMN: reason``."""
    q, xyz, names, extra = _native.read_csv(os.fspath(path), joints)
    return Measurements(q, xyz, {n: extra[:, k].copy() for k, n in enumerate(names)})


def _columns(columns: Optional[Mapping[str, Any]], n: int) -> Tuple[List[str], Optional[np.ndarray]]:
    if not columns:
        return [], None
    names = list(columns)
    cols = []
    for name in names:
        c = np.asarray(columns[name], dtype=np.float64)
        if c.shape != (n,):
            raise RefusedError(f"column {name}: shape {c.shape}; give one value per pose ({n},)")
        cols.append(c)
    return names, np.ascontiguousarray(np.stack(cols, axis=1))


def _set(q: Any, xyz: Any, columns: Optional[Mapping[str, Any]] = None, what: str = "data"):
    """(q, xyz, extra_names, extra) for the native functions, 2-D float64 arrays."""
    q = np.asarray(q, dtype=np.float64)
    xyz = np.asarray(xyz, dtype=np.float64)
    if q.ndim == 1:
        q = q.reshape(1, -1)
    if xyz.ndim == 1:
        xyz = xyz.reshape(1, -1)
    if q.ndim != 2:
        raise RefusedError(f"{what}: q has shape {q.shape}; give (n, N): one row per pose")
    if xyz.ndim != 2:
        raise RefusedError(f"{what}: xyz has shape {xyz.shape}; give (n, 3): one row per pose")
    names, extra = _columns(columns, q.shape[0])
    return np.ascontiguousarray(q), np.ascontiguousarray(xyz), names, extra


def write_csv(path: PathLike, q: Any, xyz: Any, columns: Optional[Mapping[str, Any]] = None) -> None:
    """Writes a measurement CSV file atomically: ``q1…qN, x, y, z`` and ``columns`` (name →
    (n,) values, NaN = empty cell), every number exactly (it reads back to the same values)."""
    q, xyz, names, extra = _set(q, xyz, columns)
    _native.write_csv(os.fspath(path), q, xyz, names, extra)


def _as_set(data: Any, what: str):
    """A measurement set given as Measurements, (q, xyz) or (q, xyz, columns)."""
    if isinstance(data, Measurements):
        return _set(data.q, data.xyz, data.columns, what)
    if isinstance(data, (tuple, list)) and len(data) in (2, 3):
        return _set(*data, what=what) if len(data) == 2 else _set(data[0], data[1], data[2], what)
    raise RefusedError(f"{what}: give Measurements, (q, xyz) or (q, xyz, columns)")


# --------------------------------------------------------------------------------------------
# identify


class IdentifyResult:
    """The result of :func:`identify`: the fields of ``kinecal identify --json`` and the
    calibrated robot.

    ``before`` / ``after``: dicts with ``identification_rms_mm``, ``validation_rms_mm``,
    ``validation_mean_mm``, ``validation_max_mm`` (…); ``parameters``: name → value (mm,
    degrees); ``unidentifiable``, ``suspicious``: names; ``converged``: whether the numbers may
    be taken as a calibration; ``robot``: the identified :class:`Robot` (what ``--out``
    writes); ``json``: the whole report as a dict."""

    def __init__(self, report: Dict[str, Any], robot: Robot, converged: bool):
        self.json: Dict[str, Any] = report
        self.robot: Robot = robot
        self.converged: bool = converged

    def __getattr__(self, name: str) -> Any:
        try:
            return self.__dict__["json"][name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def before(self) -> Dict[str, float]:
        return self.json["before"]

    @property
    def after(self) -> Dict[str, float]:
        return self.json["after"]

    @property
    def parameters(self) -> Dict[str, float]:
        return self.json["parameters"]

    @property
    def unidentifiable(self) -> List[str]:
        return self.json["unidentifiable"]

    @property
    def suspicious(self) -> List[str]:
        return self.json["suspicious"]

    def to_json(self, indent: Optional[int] = 2) -> str:
        """The report as JSON text (the keys of ``kinecal identify --json``)."""
        return json.dumps(self.json, indent=indent, sort_keys=True)

    def __repr__(self) -> str:
        b, a = self.before, self.after
        return (
            f"IdentifyResult(method={self.json['method']!r}, converged={self.converged}, "
            f"identification_rms_mm {b['identification_rms_mm']:.4g} -> "
            f"{a['identification_rms_mm']:.4g}, validation_rms_mm "
            f"{b['validation_rms_mm']} -> {a['validation_rms_mm']})"
        )


def identify(
    robot: Robot,
    q: Any,
    xyz: Any,
    *,
    columns: Optional[Mapping[str, Any]] = None,
    method: str = "lm",
    holdout: Optional[float] = None,
    split: Optional[str] = None,
    validate: Any = None,
    effects: Iterable[str] = (),
    seed: Optional[int] = None,
    fix: Iterable[str] = (),
    free: Iterable[str] = (),
    only: Iterable[str] = (),
    prior: Iterable[str] = (),
    tolerance_mm: Optional[float] = None,
    tolerance_deg: Optional[float] = None,
    stall_rms_mm: Optional[float] = None,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
    deg_weight_mm: Optional[float] = None,
    sigma_as_stated: bool = False,
    positions_only: bool = False,
    ignore_sigma: bool = False,
    warn: bool = True,
) -> IdentifyResult:
    """Fits the model of ``robot`` to the measurements (``kinecal identify``).

    ``q`` (n, N) joint readings, ``xyz`` (n, 3) measured points, ``columns`` further columns
    by name (``rx_deg``…, ``sx_mm``…, ``x_NAME``…); ``method``: ``lm``, ``pso``, ``bpnn-pso``
    or ``pso+lm``; ``holdout``: hold out poses (fraction < 1 or count), ``split`` which ones
    (``last``, ``random``, ``every:K``); ``fix``, ``free``, ``only``: parameter names or groups
    (``base``, ``tool``, ``geometry``, ``theta``, ``effects``, ``joint-table2`` …); ``prior``:
    ``["off"]`` or ``["length_mm=1", "angle_deg=0.1"]``; ``validate``: a separate measurement set (``(q, xyz)``, ``(q, xyz, columns)`` or
    :class:`Measurements`); ``effects``: ``"KIND:JOINT[:ARG]"`` as ``--effect``; the other
    options as the command line's flags (None = its default). Refused input raises
    :class:`RefusedError`; a fit that did not converge returns ``converged=False`` (and warns
    with :class:`NotConvergedWarning` unless ``warn=False``); so does a model that predicts the
    held-out poses worse than the model it started from (``held_out_worse``)."""
    data = _set(q, xyz, columns)
    val = None if validate is None else _as_set(validate, "validate")
    options = dict(
        method=method, holdout=holdout, split=split, effects=list(effects), seed=seed,
        fix=list(fix), free=list(free), only=list(only), prior=list(prior),
        tolerance_mm=tolerance_mm, tolerance_deg=tolerance_deg, stall_rms_mm=stall_rms_mm,
        length_unit=length_unit, angle_unit=angle_unit, deg_weight_mm=deg_weight_mm,
        sigma_as_stated=sigma_as_stated, positions_only=positions_only,
        ignore_sigma=ignore_sigma,
    )
    text, model, converged = _native.identify(robot, data, val, options)
    result = IdentifyResult(json.loads(text), Robot.from_toml(model, "identified model"), converged)
    if warn:
        if result.suspicious:
            warnings.warn(
                f"{', '.join(result.suspicious)} moved further than a manufacturing tolerance "
                "explains: check the units, the tool point and the robot file",
                UserWarning,
                stacklevel=2,
            )
        if not converged:
            acceptance = result.json.get("acceptance") or {}
            why = (
                acceptance.get("message")
                if result.json.get("held_out_worse")
                else f"the fit {result.json.get('stop')}"
            )
            warnings.warn(
                f"{why}; these numbers are not a calibration",
                NotConvergedWarning,
                stacklevel=2,
            )
    return result


# --------------------------------------------------------------------------------------------
# diagnose, compensate, frames, plan, simulate, check: in memory, as identify


class CommandResult:
    """The result of a subcommand: ``json`` (its ``--json`` object as a dict; keys also as
    attributes), ``converged``, and what it makes (``robot``, ``q``, ``measurements`` …)."""

    def __init__(self, report: Dict[str, Any], converged: bool, **outputs: Any):
        self.json = report
        self.converged = converged
        for k, v in outputs.items():
            setattr(self, k, v)

    def __getattr__(self, name: str) -> Any:
        try:
            return self.__dict__["json"][name]
        except KeyError:
            raise AttributeError(name) from None

    def to_json(self, indent: Optional[int] = 2) -> str:
        return json.dumps(self.json, indent=indent, sort_keys=True)

    def __repr__(self) -> str:
        keys = ", ".join(sorted(self.json)[:8])
        return f"CommandResult(converged={self.converged}, keys=[{keys}, …])"


def _warn_not_converged(converged: bool, what: str) -> None:
    if not converged:
        warnings.warn(what, NotConvergedWarning, stacklevel=3)


def diagnose(
    robot: Robot,
    q: Any,
    xyz: Any,
    *,
    columns: Optional[Mapping[str, Any]] = None,
    validate: Any = None,
    holdout: Optional[float] = None,
    seed: Optional[int] = None,
    folds: Optional[int] = None,
    alpha: Optional[float] = None,
    max_order: Optional[int] = None,
    max_effects: Optional[int] = None,
    stall_rms_mm: Optional[float] = None,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
    plots: Optional[PathLike] = None,
    warn: bool = True,
) -> CommandResult:
    """The discrepancy workflow (``kinecal diagnose``): fits the geometry, names the missing
    effects, adds them. Returns the report (``baseline_validation_rms_mm``, ``found``,
    ``final_validation_rms_mm``, ``noise_floor_mm`` …) and ``robot``, the extended model."""
    data = _set(q, xyz, columns)
    val = None if validate is None else _as_set(validate, "validate")
    # Messages and the report name the sets `data` and `validate`; nothing is written but
    # the plots.
    options = dict(
        holdout=holdout, seed=seed, folds=folds, alpha=alpha, max_order=max_order,
        max_effects=max_effects, stall_rms_mm=stall_rms_mm, length_unit=length_unit,
        angle_unit=angle_unit, plots=None if plots is None else os.fspath(plots),
    )
    text, toml, converged = _native.diagnose(robot, data, val, options)
    report = json.loads(text)
    model = None if toml is None else Robot.from_toml(toml, "model")
    if warn:
        _warn_not_converged(converged, "diagnose: the geometric model does not fit the data")
    return CommandResult(report, converged, robot=model)


def compensate(
    model: Robot,
    q_seed: Any,
    xyz: Any,
    rpy_deg: Any = None,
    *,
    iterations: Optional[int] = None,
    max_step_deg: Optional[float] = None,
    accept_mm: Optional[float] = None,
    stream: bool = False,
    f32: bool = False,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
    tool: Optional[str] = None,
    temp_c: Any = None,
) -> CommandResult:
    """Corrected joint commands (``kinecal compensate``) that bring ``model`` to the targets
    ``xyz`` (n, 3) (and orientations ``rpy_deg`` (n, 3)) from the controller's seeds
    ``q_seed`` (n, N); ``tool`` names the reflector (``[[tools]]``) the targets are for (the
    first by default); ``temp_c`` (n,) the arm's temperature at each target (°C), at which a
    model's ``thermal-expansion`` is evaluated (a targets file's ``temp_c`` column). Returns
    the report and ``q`` (n, N, in the seeds' angle unit), ``status`` (list of str),
    ``error_mm``, ``error_deg`` (n,)."""
    columns = {}
    if rpy_deg is not None:
        r = np.asarray(rpy_deg, dtype=np.float64).reshape(-1, 3)
        columns = {"rx": r[:, 0], "ry": r[:, 1], "rz": r[:, 2]}
    if temp_c is not None:
        columns["temp_c"] = np.asarray(temp_c, dtype=np.float64).reshape(-1)
    targets = _set(q_seed, xyz, columns, "targets")
    options = dict(
        iterations=iterations, max_step_deg=max_step_deg, accept_mm=accept_mm,
        stream=stream, f32=f32, length_unit=length_unit, angle_unit=angle_unit, tool=tool,
    )
    text, converged, q, status, error_mm, error_deg = _native.compensate(model, targets, options)
    return CommandResult(json.loads(text), converged, q=q, status=status, error_mm=error_mm,
                         error_deg=error_deg)


def compensate_cartesian(
    model: Robot,
    nominal: Robot,
    q_seed: Any,
    targets: Any,
    *,
    angle_unit: str = "deg",
) -> Tuple[np.ndarray, List[str]]:
    """Targets for a controller that keeps its ``nominal`` kinematics (``kinecal compensate
    --robot NOMINAL --cartesian``): for each target (n, 3: x, y, z mm; or n, 6 with rx, ry, rz in
    ``angle_unit``), the point (and orientation) that the nominal robot, placed at ``model``'s
    base, reaches at the joints that bring ``model`` to the target, from the seeds ``q_seed``
    (n, N). In memory, the same library function as the command line. Returns the targets to
    send (a failed row keeps its target) and each row's status."""
    q = np.ascontiguousarray(np.asarray(q_seed, dtype=np.float64))
    t = np.ascontiguousarray(np.asarray(targets, dtype=np.float64))
    return _native.compensate_cartesian(model, nominal, q, t, angle_unit)


def frames(
    robot: Robot,
    q: Any,
    xyz: Any,
    sweep: Any,
    *,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
) -> CommandResult:
    """Base frame and tool distances from single-joint sweeps (``kinecal frames``): ``sweep``
    (n,) names the joint (1-based) turned on each row (0 = ignored). Returns the report
    (``base``, ``tool_radial_mm``, ``tool_axial_mm``, ``circles``) and ``robot`` with
    ``[base]`` set to the pose found."""
    sweeps = _set(q, xyz, {"sweep": sweep}, "sweeps")
    text, framed = _native.frames(
        robot, sweeps, dict(length_unit=length_unit, angle_unit=angle_unit)
    )
    return CommandResult(json.loads(text), True, robot=Robot.from_toml(framed, "framed"))


def plan(
    robot: Robot,
    scene: PathLike,
    poses: int,
    criterion: str,
    work: Sequence[Sequence[float]],
    *,
    seed: Optional[int] = None,
    noise_mm: Optional[float] = None,
    pool: Optional[int] = None,
    passes: Optional[int] = None,
    no_collisions: bool = False,
    no_refine: bool = False,
) -> CommandResult:
    """Measurement pose selection (``kinecal plan``) in the cell ``scene`` (a cell TOML file):
    ``criterion`` ``random``, ``d``, ``o1``, ``a`` or ``kpi``; ``work``: working
    configurations (degrees). Returns the report (``criterion``, ``poses``, ``kpi_trace_mm2``,
    ``min_clearance_mm``, ``max_incidence_deg`` …) and ``q`` (poses, N) in degrees."""
    options = dict(
        poses=int(poses), criterion=criterion, work=[[float(v) for v in w] for w in work],
        seed=seed, noise_mm=noise_mm, pool=pool, passes=passes,
        no_collisions=no_collisions, no_refine=no_refine,
    )
    text, q = _native.plan(robot, os.fspath(scene), options)
    return CommandResult(json.loads(text), True, q=q)


def simulate(
    robot: Robot,
    poses: Optional[int] = None,
    *,
    noise_mm: Optional[float] = None,
    seed: Optional[int] = None,
    geom_errors: bool = False,
    effects: Iterable[str] = (),
    sweeps: Optional[Sequence[int]] = None,
    sweep_points: Optional[int] = None,
    sweep_span_deg: Optional[float] = None,
) -> CommandResult:
    """Measurement data from a robot with known errors (``kinecal simulate``). Returns the
    report, ``measurements`` (:class:`Measurements`) and ``truth`` (the true :class:`Robot`)."""
    options = dict(
        poses=poses, noise_mm=noise_mm, seed=seed, geom_errors=geom_errors,
        effects=list(effects), sweep_points=sweep_points, sweep_span_deg=sweep_span_deg,
        sweeps=[] if sweeps is None else [int(s) for s in sweeps],
    )
    text, (q, xyz, names, extra), truth = _native.simulate(robot, options)
    data = Measurements(q, xyz, {n: extra[:, k].copy() for k, n in enumerate(names)})
    return CommandResult(json.loads(text), True, measurements=data,
                         truth=Robot.from_toml(truth, "truth"))


def check(
    robot: Robot,
    q: Any,
    xyz: Any,
    *,
    columns: Optional[Mapping[str, Any]] = None,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
) -> CommandResult:
    """Validates a measurement set for ``robot`` (``kinecal check``): ``poses``,
    ``nominal_rms_mm`` (base fitted when the robot has none), joint ranges."""
    data = _set(q, xyz, columns)
    text, converged = _native.check(
        robot, data, dict(length_unit=length_unit, angle_unit=angle_unit)
    )
    return CommandResult(json.loads(text), converged)
