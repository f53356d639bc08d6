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
    "DiagnoseResult",
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


def _words(value: Any) -> List[Any]:
    """A list option (``fix``, ``free``, ``only``, ``prior``, ``effects`` …): a single string is
    one item (``fix="theta1"`` is ``fix=["theta1"]``), not a list of its characters."""
    if value is None:
        return []
    if isinstance(value, (str, bytes)):
        return [value.decode() if isinstance(value, bytes) else value]
    return list(value)


def _locate_temperatures(e: KinecalError, sets: Sequence[Tuple[str, Any]]) -> KinecalError:
    """A refusal for want of a temperature on every row (a thermal-expansion term), with the
    first row of each set whose ``temp_c`` is NaN named as the other refusals name cells
    (``data:LINE``, row i on line i + 2 of the file the arrays make, and the row)."""
    text = str(e)
    if "temp_c" not in text or "every row" not in text:
        return e
    where = []
    for name, columns in sets:
        t = None if not columns else columns.get("temp_c")
        if t is None:
            continue
        rows = np.flatnonzero(~np.isfinite(np.asarray(t, dtype=np.float64).reshape(-1)))
        if rows.size:
            where.append(
                f"{name}:{rows[0] + 2}: no temp_c (NaN; row {rows[0]} of the arrays, "
                f"{rows.size} such row{'s' if rows.size > 1 else ''})"
            )
    if not where:
        return e
    return type(e)(f"{text}; {'; '.join(where)}")


def _columns_of(data: Any) -> Optional[Mapping[str, Any]]:
    if isinstance(data, Measurements):
        return data.columns
    if isinstance(data, (tuple, list)) and len(data) == 3:
        return data[2]
    return None


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
    (``base``, ``tool``, ``geometry``, ``theta``, ``effects``, ``joint-table2`` …; a list, or
    one name as a string); ``prior``:
    ``["off"]`` or ``["length_mm=1", "angle_deg=0.1"]``; ``validate``: a separate measurement set (``(q, xyz)``, ``(q, xyz, columns)`` or
    :class:`Measurements`); ``effects``: ``"KIND:JOINT[:ARG]"`` as ``--effect``; the other
    options as the command line's flags (None = its default). Refused input raises
    :class:`RefusedError`; a fit that did not converge returns ``converged=False`` (and warns
    with :class:`NotConvergedWarning` unless ``warn=False``); so does a model that predicts the
    held-out poses worse than the model it started from (``held_out_worse``)."""
    data = _set(q, xyz, columns)
    val = None if validate is None else _as_set(validate, "validate")
    options = dict(
        method=method, holdout=holdout, split=split, effects=_words(effects), seed=seed,
        fix=_words(fix), free=_words(free), only=_words(only), prior=_words(prior),
        tolerance_mm=tolerance_mm, tolerance_deg=tolerance_deg, stall_rms_mm=stall_rms_mm,
        length_unit=length_unit, angle_unit=angle_unit, deg_weight_mm=deg_weight_mm,
        sigma_as_stated=sigma_as_stated, positions_only=positions_only,
        ignore_sigma=ignore_sigma,
    )
    try:
        text, model, converged = _native.identify(robot, data, val, options)
    except RefusedError as e:
        located = _locate_temperatures(e, [("data", columns), ("validate", _columns_of(validate))])
        if located is e:
            raise
        raise located from None
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


class DiagnoseResult(CommandResult):
    """The result of :func:`diagnose`: the keys of ``kinecal diagnose --json`` as attributes,
    ``json``, ``robot`` (the extended model; None when it predicts the held-out poses worse),
    ``converged`` and ``text`` (the report as the command line prints it without ``--json``).

    Two kinds of error figures, not to be confused:

    * **cross-validated** (k-fold over the poses the search used; the search's yardstick):
      ``baseline_validation_rms_mm``, ``final_validation_rms_mm``, each ``found[i]``'s
      ``validation_rms_mm`` and ``before_validation_rms_mm``, the rounds' figures, ``summary``
      and ``sentences`` ("cross-validated RMS …"). ``validation`` in these keys means
      cross-validated, whereas :func:`identify`'s ``validation_rms_mm`` is held-out.
      :attr:`cross_validated_rms_mm` is ``(baseline, final)``.
    * **held-out** (poses kept out of the whole search: ``holdout=`` or ``validate=``): the dict
      ``holdout`` (``poses``, ``start_rms_mm`` the nominal robot, ``geometric_rms_mm`` the
      starting model refitted, ``final_rms_mm`` the extended model, ``noise_floor_capped``);
      :attr:`held_out_rms_mm` is ``(geometric, final)``, None without held-out poses.

    ``noise_floor_mm``: with ``holdout["noise_floor_capped"]`` it was lowered to the held-out
    final RMS (their errors are the noise plus the model's), so "final ≈ noise floor" on the
    held-out poses then holds by construction and is no evidence."""

    @property
    def cross_validated_rms_mm(self) -> Tuple[float, float]:
        """``(baseline, final)``: the cross-validated RMS (mm) of the starting model and of the
        extended model over the searched poses (``baseline_validation_rms_mm``,
        ``final_validation_rms_mm``)."""
        return (self.json["baseline_validation_rms_mm"], self.json["final_validation_rms_mm"])

    @property
    def held_out_rms_mm(self) -> Optional[Tuple[float, float]]:
        """``(geometric, final)``: the RMS (mm) on the held-out poses of the starting model
        refitted and of the extended model (``holdout``); None without held-out poses."""
        h = self.json.get("holdout")
        return None if h is None else (h["geometric_rms_mm"], h["final_rms_mm"])

    def __repr__(self) -> str:
        b, f = self.cross_validated_rms_mm
        parts = [
            f"found={len(self.json.get('found') or [])}",
            f"cross-validated RMS {b:.4g} -> {f:.4g} mm",
        ]
        h = self.json.get("holdout")
        if h is not None:
            parts.append(
                f"held-out ({h['poses']} poses) RMS {h['geometric_rms_mm']:.4g} -> "
                f"{h['final_rms_mm']:.4g} mm"
            )
        floor = self.json.get("noise_floor_mm")
        if floor is not None:
            capped = " (capped at the held-out final RMS)" if h and h["noise_floor_capped"] else ""
            parts.append(f"noise floor {floor:.4g} mm{capped}")
        return f"DiagnoseResult(converged={self.converged}, {', '.join(parts)})"


def diagnose(
    robot: Robot,
    q: Any,
    xyz: Any,
    *,
    columns: Optional[Mapping[str, Any]] = None,
    validate: Any = None,
    holdout: Optional[float] = None,
    split: Optional[str] = None,
    seed: Optional[int] = None,
    folds: Optional[int] = None,
    alpha: Optional[float] = None,
    max_order: Optional[int] = None,
    max_effects: Optional[int] = None,
    stall_rms_mm: Optional[float] = None,
    length_unit: Optional[str] = None,
    angle_unit: Optional[str] = None,
    deg_weight_mm: Optional[float] = None,
    sigma_as_stated: bool = False,
    positions_only: bool = False,
    ignore_sigma: bool = False,
    plots: Optional[PathLike] = None,
    warn: bool = True,
) -> DiagnoseResult:
    """The discrepancy workflow (``kinecal diagnose``): fits the geometry, names the missing
    effects, adds them. Returns a :class:`DiagnoseResult`: the report (``found``,
    ``baseline_validation_rms_mm`` and ``final_validation_rms_mm`` cross-validated,
    ``holdout`` the held-out poses' figures, ``noise_floor_mm`` …) and ``robot``, the extended
    model. ``holdout`` / ``split`` / ``validate`` keep poses out of the whole search as in
    :func:`identify`; ``positions_only``, ``ignore_sigma``, ``sigma_as_stated``,
    ``deg_weight_mm``: how orientation and σ columns are used, as ``--positions-only`` …"""
    data = _set(q, xyz, columns)
    val = None if validate is None else _as_set(validate, "validate")
    # Messages and the report name the sets `data` and `validate`; nothing is written but
    # the plots.
    options = dict(
        holdout=holdout, split=split, seed=seed, folds=folds, alpha=alpha, max_order=max_order,
        max_effects=max_effects, stall_rms_mm=stall_rms_mm, length_unit=length_unit,
        angle_unit=angle_unit, plots=None if plots is None else os.fspath(plots),
        deg_weight_mm=deg_weight_mm, sigma_as_stated=sigma_as_stated,
        positions_only=positions_only, ignore_sigma=ignore_sigma,
    )
    try:
        text, toml, converged, printed = _native.diagnose(robot, data, val, options)
    except RefusedError as e:
        located = _locate_temperatures(e, [("data", columns), ("validate", _columns_of(validate))])
        if located is e:
            raise
        raise located from None
    report = json.loads(text)
    model = None if toml is None else Robot.from_toml(toml, "model")
    if warn:
        # The command line's reasons in its order: the geometric fit (resized, stalled), a
        # refusal the data need, then the held-out verdict (its message says whether the model
        # is not determined across the joint ranges or predicts the held-out poses worse).
        acceptance = report.get("acceptance") or {}
        if report.get("resized"):
            why = f"the geometric fit {report['resized']}"
        elif report.get("converged") is False:
            why = "the geometric model does not fit the data"
        elif report.get("unexplained"):
            why = report["unexplained"]
        elif acceptance.get("message"):
            why = acceptance["message"]
        else:
            why = "the model predicts the held-out poses worse than the nominal robot"
        _warn_not_converged(converged, f"diagnose: {why}")
    return DiagnoseResult(report, converged, robot=model, text=printed)


def _unreached(failed: int, targets: int, hint: Optional[str], cartesian: bool = False) -> str:
    """The command line's error for targets not reached (``kinecal compensate`` exits 3), and
    its hint when the targets look given in another frame."""
    text = _native.unreached_error(failed, targets, cartesian) or ""
    return text if not hint else f"{text}\n{hint}"


def compensate(
    model: Robot,
    q_seed: Any,
    xyz: Any,
    rpy: Any = None,
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
    rpy_deg: Any = None,
    warn: bool = True,
) -> CommandResult:
    """Corrected joint commands (``kinecal compensate``) that bring ``model`` to the targets
    ``xyz`` (n, 3) (and orientations ``rpy`` (n, 3): fixed-axis roll, pitch, yaw) from the
    controller's seeds ``q_seed`` (n, N).

    Units: ``rpy`` is in ``angle_unit``, as the seeds are (degrees by default; radians with
    ``angle_unit="rad"``), as ``--angle-unit`` covers a targets file's ``rx``, ``ry``, ``rz``.
    ``rpy_deg=`` is the former name of ``rpy`` and still works, with the same meaning: it too
    is read in ``angle_unit`` (radians with ``angle_unit="rad"``, which warns with
    :class:`DataWarning` since the name says degrees). ``tool`` names the reflector
    (``[[tools]]``) the targets are for (the first by default); ``temp_c`` (n,) the arm's
    temperature at each target (°C), at which a model's ``thermal-expansion`` is evaluated (a
    targets file's ``temp_c`` column; a model with the term and targets without it warn with
    :class:`DataWarning`, as the command line prints ``warning: …``).

    Returns the report and ``q`` (n, N, in the seeds' angle unit), ``status`` (list of str),
    ``error_mm``, ``error_deg`` (n,), ``converged`` (every target reached).

    Targets not reached (a status other than ``ok``): the command line writes their rows (the
    best command found, with a failure status) and exits 3, "do not send them". Like every
    exit-3 outcome in this package (:func:`identify`'s and :func:`diagnose`'s fits that did not
    converge) the result is returned with ``converged=False`` and a
    :class:`NotConvergedWarning` carrying the command line's error (and its hint), unless
    ``warn=False``; only refused input (exit 2, nothing written) raises. Keep the rows whose
    ``status`` is ``ok``, or make it an exception with
    ``warnings.simplefilter("error", kinecal.NotConvergedWarning)``."""
    if rpy_deg is not None:
        if rpy is not None:
            raise RefusedError("compensate: give the orientations once, as rpy= (rpy_deg= is its "
                               "former name)")
        rpy = rpy_deg
        if angle_unit == "rad":
            warnings.warn(
                "compensate: rpy_deg is read in angle_unit, here radians (angle_unit=\"rad\" "
                "covers the orientations as --angle-unit covers a targets file's rx, ry, rz): "
                "pass them as rpy= in radians",
                DataWarning,
                stacklevel=2,
            )
    columns = {}
    if rpy is not None:
        r = np.asarray(rpy, dtype=np.float64).reshape(-1, 3)
        columns = {"rx": r[:, 0], "ry": r[:, 1], "rz": r[:, 2]}
    if temp_c is not None:
        columns["temp_c"] = np.asarray(temp_c, dtype=np.float64).reshape(-1)
    targets = _set(q_seed, xyz, columns, "targets")
    options = dict(
        iterations=iterations, max_step_deg=max_step_deg, accept_mm=accept_mm,
        stream=stream, f32=f32, length_unit=length_unit, angle_unit=angle_unit, tool=tool,
    )
    text, converged, q, status, error_mm, error_deg = _native.compensate(model, targets, options)
    report = json.loads(text)
    if warn and not converged:
        warnings.warn(
            _unreached(report["failed"], report["targets"], report.get("hint")),
            NotConvergedWarning,
            stacklevel=2,
        )
    return CommandResult(report, converged, q=q, status=status, error_mm=error_mm,
                         error_deg=error_deg)


def compensate_cartesian(
    model: Robot,
    nominal: Robot,
    q_seed: Any,
    targets: Any,
    *,
    angle_unit: str = "deg",
    temp_c: Any = None,
    warn: bool = True,
) -> Tuple[np.ndarray, List[str]]:
    """Targets for a controller that keeps its ``nominal`` kinematics (``kinecal compensate
    --robot NOMINAL --cartesian``): for each target (n, 3: x, y, z mm; or n, 6 with rx, ry, rz in
    ``angle_unit``), the point (and orientation) that the nominal robot, placed at ``model``'s
    base, reaches at the joints that bring ``model`` to the target, from the seeds ``q_seed``
    (n, N); ``temp_c`` (°C, one value or one per target) the arm's temperature, at which a
    model's ``thermal-expansion`` is evaluated (without it, at its reference temperature, and
    :class:`DataWarning` says so). In memory, the same library function as the command line.
    Returns the targets to send (a failed row keeps its target) and each row's status. Rows
    not reached: the command line exits 3 ("do not send them"); here, as for
    :func:`compensate`, a :class:`NotConvergedWarning` carries its error (``warn=False`` to
    silence)."""
    q = np.ascontiguousarray(np.asarray(q_seed, dtype=np.float64))
    t = np.ascontiguousarray(np.asarray(targets, dtype=np.float64))
    sent, status = _native.compensate_cartesian(model, nominal, q, t, angle_unit, temp_c)
    failed = sum(1 for s in status if s != "ok")
    if warn and failed:
        warnings.warn(_unreached(failed, len(status), None, cartesian=True), NotConvergedWarning,
                      stacklevel=2)
    return sent, status


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
    work = [work] if len(work) and np.ndim(work[0]) == 0 else work  # one configuration
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
    temperature: Optional[Tuple[float, float]] = None,
    session_s: Optional[float] = None,
) -> CommandResult:
    """Measurement data from a robot with known errors (``kinecal simulate``): ``effects``
    ``"KIND:JOINT:V1[,V2…]"`` as ``--effect`` (a list, or one as a string), ``temperature``
    ``(from_c, to_c)`` an arm warming linearly over the poses (a ``temp_c`` column, as
    ``--temperature FROM:TO``), ``session_s`` the poses' time span (a ``t_s`` column). Returns
    the report, ``measurements`` (:class:`Measurements`) and ``truth`` (the true
    :class:`Robot`)."""
    if isinstance(sweeps, (int, np.integer)):
        sweeps = [sweeps]
    options = dict(
        poses=poses, noise_mm=noise_mm, seed=seed, geom_errors=geom_errors,
        effects=_words(effects), sweep_points=sweep_points, sweep_span_deg=sweep_span_deg,
        sweeps=[] if sweeps is None else [int(s) for s in sweeps],
        temperature=None if temperature is None else tuple(float(t) for t in temperature),
        session_s=session_s,
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
