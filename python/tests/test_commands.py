"""diagnose, compensate, frames, plan, simulate and check from Python (in memory) equal the
CLI's JSON (and output files) on the same inputs."""

from __future__ import annotations

import numpy as np
import pytest

import kinecal
from conftest import CELL, assert_same


@pytest.fixture(scope="module")
def cell():
    return kinecal.Robot.from_file(CELL / "robot.toml")


@pytest.fixture(scope="module")
def sim(cli, tmp_path_factory):
    """300 poses of the cell robot with geometric errors and a cyclic error on joint 2."""
    d = tmp_path_factory.mktemp("sim")
    _, rep = cli("simulate", "--robot", CELL / "robot.toml", "--poses", 300, "--noise-mm", 0.005,
                 "--seed", 11, "--geom-errors", "--effect", "joint-cyclic:2:0.0005,-0.0004",
                 "--out", d / "sim.csv", "--truth", d / "truth.toml", expect=0)
    return d, rep


def test_simulate_equals_cli(cell, sim):
    """simulate() writes the same measurements and truth as the CLI with the same seed."""
    d, rep = sim
    res = kinecal.simulate(cell, 300, noise_mm=0.005, seed=11, geom_errors=True,
                           effects=["joint-cyclic:2:0.0005,-0.0004"])
    assert_same(res.json, rep)
    ref = kinecal.read_csv(d / "sim.csv")
    np.testing.assert_array_equal(res.measurements.q, ref.q)
    np.testing.assert_array_equal(res.measurements.xyz, ref.xyz)
    assert res.truth == kinecal.Robot.from_file(d / "truth.toml")


def test_diagnose_equals_cli(cell, sim, cli, tmp_path):
    """The discrepancy workflow on arrays equals `kinecal diagnose --json` on the file, finds
    the simulated cyclic error on joint 2, and its extended model equals --out's."""
    d, _ = sim
    data = kinecal.read_csv(d / "sim.csv")
    res = kinecal.diagnose(cell, data.q, data.xyz, holdout=60)
    code, ref = cli("diagnose", "--robot", CELL / "robot.toml", "--data", d / "sim.csv",
                    "--holdout", 60, "--out", tmp_path / "ext.toml")
    assert code == 0
    assert_same(res.json, ref)
    found = [(f["effect"], f["joint"]) for f in res.found]
    assert ("joint-cyclic", 2) in found
    assert res.final_validation_rms_mm < res.baseline_validation_rms_mm
    assert res.robot == kinecal.Robot.from_file(tmp_path / "ext.toml")


def test_compensate_equals_cli(sim, cli, tmp_path):
    """Corrected commands for targets from the true robot: the JSON, the commands, the status
    and the errors equal the CLI's output file."""
    d, _ = sim
    truth = kinecal.Robot.from_file(d / "truth.toml")
    rng = np.random.default_rng(8)
    seeds = rng.uniform(-60, 60, size=(40, truth.joints))
    targets = truth.fk(seeds) + rng.normal(0, 0.3, size=(40, 3))
    kinecal.write_csv(tmp_path / "t.csv", seeds, targets)
    res = kinecal.compensate(truth, seeds, targets)
    code, ref = cli("compensate", "--model", d / "truth.toml", "--targets", tmp_path / "t.csv",
                    "--out", tmp_path / "q.csv")
    assert code == 0, ref
    assert_same(res.json, ref)
    import csv

    with open(tmp_path / "q.csv") as f:
        rows = list(csv.DictReader(f))
    # The commands unrounded: the file's 9 decimals of a degree are theirs, digit for digit.
    assert [[f"{v:.9f}" for v in q] for q in res.q] == [
        [r[f"q{j + 1}"] for j in range(truth.joints)] for r in rows]
    assert res.status == [r["status"] for r in rows]
    # The file's errors have 4 significant digits.
    np.testing.assert_allclose(res.error_mm, [float(r["error_mm"]) for r in rows], rtol=5e-4)
    np.testing.assert_allclose(res.error_deg, [float(r["error_deg"]) for r in rows], rtol=5e-4)
    # The commands bring the model to the targets.
    assert np.abs(truth.fk(res.q) - targets).max() < 0.01


def test_compensate_takes_the_arm_s_temperature(sim, cli, tmp_path):
    """A model with thermal expansion: ``temp_c`` per target equals the CLI with a targets file's
    ``temp_c`` column (it was not taken, and the report warned that none was given); the
    commands differ from those at the reference temperature by the links' growth."""
    d, _ = sim
    text = (d / "truth.toml").read_text() + (
        '\n[[effects]]\nkind = "thermal-expansion"\njoint = 0\nvalues = [1.2e-5]\n'
        "reference_c = 20.0\n")
    (tmp_path / "warm.toml").write_text(text)
    warm = kinecal.Robot.from_file(tmp_path / "warm.toml")
    rng = np.random.default_rng(9)
    seeds = rng.uniform(-60, 60, size=(20, warm.joints))
    targets = warm.fk(seeds) + rng.normal(0, 0.3, size=(20, 3))
    temp = np.full(20, 35.0)
    kinecal.write_csv(tmp_path / "t.csv", seeds, targets, {"temp_c": temp})
    res = kinecal.compensate(warm, seeds, targets, temp_c=temp)
    code, ref = cli("compensate", "--model", tmp_path / "warm.toml", "--targets",
                    tmp_path / "t.csv", "--out", tmp_path / "q.csv")
    assert code == 0, ref
    assert_same(res.json, ref)
    assert res.json.get("temperature_warning") is None
    cold = kinecal.compensate(warm, seeds, targets)
    assert cold.json.get("temperature_warning")
    assert np.abs(res.q - cold.q).max() > 1e-4


def test_compensate_for_a_named_reflector_equals_cli(sim, cli, tmp_path):
    """A model of three reflectors: ``tool="B"`` takes the targets as B's points, as
    ``kinecal compensate --tool B`` does, and the commands bring B (not A) to them."""
    import re

    d, _ = sim
    text = re.sub(r"\[tool\]\nxyz_mm = [^\n]*\n", "", (d / "truth.toml").read_text())
    points = {"A": (0.0, 0.0, 100.0), "B": (60.0, 0.0, 80.0), "C": (0.0, -60.0, 80.0)}
    for name, p in points.items():
        text += f'\n[[tools]]\nname = "{name}"\nxyz_mm = [{p[0]}, {p[1]}, {p[2]}]\n'
    (tmp_path / "m.toml").write_text(text)
    model = kinecal.Robot.from_file(tmp_path / "m.toml")
    rng = np.random.default_rng(10)
    seeds = rng.uniform(-60, 60, size=(20, model.joints))
    # The targets of B: the robot with B's point as its only tool, at the seeds moved 0.2°.
    (tmp_path / "b.toml").write_text(
        re.sub(r"xyz_mm = [^\n]*", "xyz_mm = [60.0, 0.0, 80.0]", (d / "truth.toml").read_text(),
               count=1))
    only_b = kinecal.Robot.from_file(tmp_path / "b.toml")
    targets = only_b.fk(seeds + 0.2)
    kinecal.write_csv(tmp_path / "t.csv", seeds, targets)
    res = kinecal.compensate(model, seeds, targets, tool="B")
    code, ref = cli("compensate", "--model", tmp_path / "m.toml", "--targets", tmp_path / "t.csv",
                    "--tool", "B", "--out", tmp_path / "q.csv")
    assert code == 0, ref
    assert_same(res.json, ref)
    assert res.status == ["ok"] * 20
    np.testing.assert_allclose(only_b.fk(res.q), targets, atol=0.01)
    with pytest.raises(Exception, match="no reflector of that name"):
        kinecal.compensate(model, seeds, targets, tool="D")


def test_compensate_cartesian_equals_cli(cell, sim, cli, tmp_path):
    """Targets for a controller that keeps the nominal kinematics: Python's in-memory route
    equals `kinecal compensate --robot NOMINAL --cartesian` row for row, and the sent targets,
    driven through the nominal robot's own compensation, bring the true robot to the targets."""
    d, _ = sim
    truth = kinecal.Robot.from_file(d / "truth.toml")
    rng = np.random.default_rng(9)
    seeds = rng.uniform(-60, 60, size=(30, truth.joints))
    targets = truth.fk(seeds) + rng.normal(0, 0.3, size=(30, 3))
    kinecal.write_csv(tmp_path / "t.csv", seeds, targets)
    sent, status = kinecal.compensate_cartesian(truth, cell, seeds, targets)
    code, ref = cli("compensate", "--model", d / "truth.toml", "--robot", CELL / "robot.toml",
                    "--cartesian", "--targets", tmp_path / "t.csv", "--out", tmp_path / "c.csv")
    assert code == 0, ref
    import csv

    with open(tmp_path / "c.csv") as f:
        rows = list(csv.DictReader(f))
    np.testing.assert_allclose(
        sent, np.array([[float(r[k]) for k in ("x", "y", "z")] for r in rows]), atol=1e-5)
    assert status == [r["status"] for r in rows]
    ok = [i for i, s in enumerate(status) if s == "ok"]
    assert len(ok) >= 25, status
    # The nominal controller's joints for the sent targets put the true robot on the targets.
    q = kinecal.compensate(cell, seeds[ok], sent[ok]).q
    assert np.abs(truth.fk(q) - targets[ok]).max() < 0.01
    # A nominal robot the model is no calibration of (a link 100 mm longer) is refused, as
    # the command line and `export` refuse it.
    import re

    text = (CELL / "robot.toml").read_text()
    first_a = re.search(r"a_mm = ([-0-9.]+)", text.split("[[joints]]", 2)[2])
    assert first_a, text
    longer = text.replace(first_a.group(0), f"a_mm = {float(first_a.group(1)) + 100.0}", 1)
    assert longer != text
    (tmp_path / "longer.toml").write_text(longer)
    other = kinecal.Robot.from_file(tmp_path / "longer.toml")
    with pytest.raises(kinecal.RefusedError, match="not a calibration of nominal"):
        kinecal.compensate_cartesian(truth, other, seeds, targets)


def test_frames_equals_cli(cell, cli, tmp_path):
    """Base frame from simulated sweeps: JSON and the framed robot equal the CLI's."""
    cli("simulate", "--robot", CELL / "robot.toml", "--sweeps", "1,2,5,6", "--noise-mm", 0.002,
        "--seed", 4, "--out", tmp_path / "s.csv", expect=0)
    s = kinecal.read_csv(tmp_path / "s.csv")
    res = kinecal.frames(cell, s.q, s.xyz, s.columns["sweep"])
    code, ref = cli("frames", "--robot", CELL / "robot.toml", "--data", tmp_path / "s.csv",
                    "--out", tmp_path / "framed.toml")
    assert code == 0
    assert_same(res.json, ref)
    assert res.robot == kinecal.Robot.from_file(tmp_path / "framed.toml")
    assert set(res.json) >= {"base", "tool_radial_mm", "tool_axial_mm", "circles"}


def test_plan_equals_cli(cell, cli, tmp_path):
    """A small D-optimal plan: JSON and the planned poses equal the CLI's."""
    work = [[0, -60, 90, 0, 30, 0], [20, -80, 120, 10, -30, 45]]
    res = kinecal.plan(cell, CELL / "scene.toml", 12, "d", work, pool=300, passes=5, seed=2)
    code, ref = cli("plan", "--robot", CELL / "robot.toml", "--scene", CELL / "scene.toml",
                    "--poses", 12, "--criterion", "d", "--work=0,-60,90,0,30,0",
                    "--work=20,-80,120,10,-30,45", "--pool", 300, "--passes", 5, "--seed", 2,
                    "--out", tmp_path / "p.csv")
    assert code == 0, ref
    assert_same(res.json, ref)
    import csv

    with open(tmp_path / "p.csv") as f:
        rows = list(csv.DictReader(f))
    # The poses unrounded: the file's 9 decimals of a degree are theirs, digit for digit.
    assert [[f"{v:.9f}" for v in q] for q in res.q] == [
        [r[f"q{j}"] for j in range(1, 7)] for r in rows]
    assert res.q.shape == (12, 6)


def test_check_equals_cli(cell, sim, cli):
    """check on arrays equals `kinecal check --json` on the file (base fitted: the cell robot
    has none), and on the true robot (base known)."""
    d, _ = sim
    data = kinecal.read_csv(d / "sim.csv")
    for robot, path in [(cell, CELL / "robot.toml"), (None, d / "truth.toml")]:
        robot = robot or kinecal.Robot.from_file(path)
        res = kinecal.check(robot, data.q, data.xyz)
        code, ref = cli("check", "--robot", path, "--data", d / "sim.csv")
        assert code == 0, ref
        assert_same(res.json, ref)
        assert res.robot == "robot" and res.data == "data"


def test_diagnose_validate_and_6d_equal_cli(ur10, cli, tmp_path):
    """diagnose with a validation set (arrays; the CLI's --validate file written by write_csv)
    on 6-D UR10 data with stated σ: the fit to all observations included, equal to the CLI."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses_6d.csv")
    a, b = d[:300], d[300:400]
    a.write(tmp_path / "a.csv")
    b.write(tmp_path / "b.csv")
    res = kinecal.diagnose(robot, a.q, a.xyz, columns=a.columns, validate=b, max_effects=1)
    code, ref = cli("diagnose", "--robot", ur10 / "robot.toml", "--data", tmp_path / "a.csv",
                    "--validate", tmp_path / "b.csv", "--max-effects", 1,
                    "--out", tmp_path / "ext.toml")
    assert code in (0, 3), ref
    assert_same(res.json, ref)
    assert "observations" in res.json and res.json["holdout"]["poses"] == 100
    if "out" in ref:
        assert res.robot == kinecal.Robot.from_file(tmp_path / "ext.toml")


def test_the_command_lines_warnings_are_python_warnings(sim, tmp_path):
    """What the command line prints on stderr comes to Python as ``kinecal.DataWarning``:
    here a model of three reflectors given targets without ``tool=`` (the targets are taken
    as the first reflector's, and the warning names the others). Nothing is printed."""
    import re
    import warnings

    d, _ = sim
    text = re.sub(r"\[tool\]\nxyz_mm = [^\n]*\n", "", (d / "truth.toml").read_text())
    for name, p in {"A": (0.0, 0.0, 100.0), "B": (60.0, 0.0, 80.0)}.items():
        text += f'\n[[tools]]\nname = "{name}"\nxyz_mm = [{p[0]}, {p[1]}, {p[2]}]\n'
    (tmp_path / "m.toml").write_text(text)
    model = kinecal.Robot.from_file(tmp_path / "m.toml")
    seeds = np.random.default_rng(11).uniform(-60, 60, size=(10, model.joints))
    targets = model.fk(seeds + 0.2)
    with pytest.warns(kinecal.DataWarning, match="--tool NAME"):
        res = kinecal.compensate(model, seeds, targets)
    assert res.json["reflector"] == "A"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kinecal.compensate(model, seeds, targets, tool="A")
