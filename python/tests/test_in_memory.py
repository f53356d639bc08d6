"""diagnose, compensate, frames, plan, simulate and check run in memory: no temporary file and
no file at all but what the caller asks for (diagnose's plots), and their refusals name the
sets as the command line names a file written by write_csv (line and column included)."""

from __future__ import annotations

import subprocess
import tempfile

import numpy as np
import pytest

import kinecal
from conftest import CELL


def test_no_file_helpers_left():
    """The temporary-file route is gone from the package and from the native module."""
    for name in ("_Files", "_read_rows", "_joints_of", "tempfile"):
        assert not hasattr(kinecal, name), name
    assert not hasattr(kinecal._native, "run")
    for name in ("check", "diagnose", "compensate", "frames", "plan", "simulate"):
        assert callable(getattr(kinecal._native, name)), name


@pytest.fixture
def no_files(monkeypatch, tmp_path):
    """Every way of making a temporary file raises, and the working directory is an empty
    folder: a result written under a placeholder name (`model`, `commands`, `plan`,
    `simulated`, `truth`, `framed`) would land there."""

    def refuse(*args, **kwargs):
        raise AssertionError("a temporary file or folder was made")

    for name in ("mkstemp", "mkdtemp", "TemporaryDirectory", "NamedTemporaryFile",
                 "TemporaryFile", "SpooledTemporaryFile"):
        monkeypatch.setattr(tempfile, name, refuse)
    work = tmp_path / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    return work


def test_six_commands_make_no_files(no_files, tmp_path):
    cell = kinecal.Robot.from_file(CELL / "robot.toml")
    sim = kinecal.simulate(cell, 150, noise_mm=0.005, seed=5, geom_errors=True,
                           effects=["joint-cyclic:2:0.0005,-0.0004"])
    d = sim.measurements
    assert d.q.shape == (150, 6) and sim.truth.joints == 6
    assert kinecal.check(cell, d.q, d.xyz).poses == 150
    diag = kinecal.diagnose(cell, d.q, d.xyz, holdout=30, max_effects=1, warn=False)
    assert diag.holdout["poses"] == 30
    comp = kinecal.compensate(sim.truth, d.q[:5], d.xyz[:5])
    assert comp.q.shape == (5, 6) and len(comp.status) == 5
    sw = kinecal.simulate(cell, sweeps=[1, 2, 5, 6], noise_mm=0.002, seed=4).measurements
    framed = kinecal.frames(cell, sw.q, sw.xyz, sw.columns["sweep"])
    assert framed.robot.base_known
    p = kinecal.plan(cell, CELL / "scene.toml", 10, "d", [[0, -60, 90, 0, 30, 0]], pool=100,
                     passes=2, seed=1)
    assert p.q.shape == (10, 6)
    # Fewer equations than the directions a design is to determine: refused, not predicted.
    with pytest.raises(kinecal.RefusedError, match="plan at least"):
        kinecal.plan(cell, CELL / "scene.toml", 3, "d", [[0, -60, 90, 0, 30, 0]], pool=100)
    assert list(no_files.iterdir()) == []
    # The plots are the caller's output: written into the folder it names, nothing else.
    plots = tmp_path / "plots"
    res = kinecal.diagnose(cell, d.q, d.xyz, holdout=30, max_effects=1, plots=plots, warn=False)
    assert res.plots and all(str(plots) in f for f in res.plots)
    assert sorted(p.name for p in plots.iterdir()) == sorted(f.split("/")[-1] for f in res.plots)
    assert list(no_files.iterdir()) == []


def cli_reason(kinecal_bin, *args):
    p = subprocess.run([str(kinecal_bin), *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("kinecal: ")
    return line[len("kinecal: "):]


def test_refusals_name_the_sets(kinecal_bin, tmp_path):
    """A refusal names the set as the report does (`targets`, `sweeps`, `data`) where the
    command line names its file, with the same line and column as in the file write_csv
    writes for the arrays."""
    cell = kinecal.Robot.from_file(CELL / "robot.toml")
    robot = CELL / "robot.toml"
    rng = np.random.default_rng(1)
    q = rng.uniform(-60, 60, size=(4, 6))
    xyz = cell.fk(q)

    # A pose target without a finite rz on its first row: line 2, column 12.
    rpy = np.tile([180.0, 0.0, 90.0], (4, 1))
    rpy[0, 2] = np.nan
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.compensate(cell, q, xyz, rpy)
    kinecal.write_csv(tmp_path / "t.csv", q, xyz, {"rx": rpy[:, 0], "ry": rpy[:, 1], "rz": rpy[:, 2]})
    reason = cli_reason(kinecal_bin, "compensate", "--model", robot, "--targets", tmp_path / "t.csv",
                        "--out", tmp_path / "q.csv")
    assert str(e.value) == reason.replace(str(tmp_path / "t.csv"), "targets")
    assert str(e.value).startswith("targets:2:12: ")

    # A sweep column naming a joint the robot lacks.
    sweep = np.full(4, 9.0)
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.frames(cell, q, xyz, sweep)
    kinecal.write_csv(tmp_path / "s.csv", q, xyz, {"sweep": sweep})
    reason = cli_reason(kinecal_bin, "frames", "--robot", robot, "--data", tmp_path / "s.csv")
    assert str(e.value) == reason.replace(str(tmp_path / "s.csv"), "sweeps")
    assert str(e.value).startswith("sweeps:")

    # No poses at all.
    empty = np.zeros((0, 6)), np.zeros((0, 3))
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.check(cell, *empty)
    kinecal.write_csv(tmp_path / "e.csv", *empty)
    reason = cli_reason(kinecal_bin, "check", "--robot", robot, "--data", tmp_path / "e.csv")
    assert str(e.value) == reason.replace(str(tmp_path / "e.csv"), "data")
    with pytest.raises(kinecal.RefusedError, match="^data: "):
        kinecal.diagnose(cell, *empty)

    # Options are checked as the command line checks them.
    with pytest.raises(kinecal.RefusedError, match="--max-step-deg"):
        kinecal.compensate(cell, q, xyz, max_step_deg=0.0)
    with pytest.raises(kinecal.RefusedError, match="--poses"):
        kinecal.plan(cell, CELL / "scene.toml", 0, "d", [[0, -60, 90, 0, 30, 0]])
    with pytest.raises(kinecal.RefusedError, match="--effect"):
        kinecal.simulate(cell, 10, effects=["joint-cyclic:9:0.1,0.1"])
    with pytest.raises(kinecal.RefusedError, match="--folds"):
        kinecal.diagnose(cell, q, xyz, folds=1)
