"""identify from Python equals `kinecal identify --json` on the same data."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import kinecal
from conftest import CELL, assert_same


def test_ur10_validate_equals_cli_holdout(ur10, cli):
    """UR10: the first 1,000 poses identify, the rest via validate= (arrays in memory) gives
    every figure and parameter of `identify --holdout 1773` on the file, to 1e-9."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    assert d.q.shape == (2773, 6) and d.xyz.shape == (2773, 3)
    res = kinecal.identify(robot, d.q[:1000], d.xyz[:1000], validate=(d.q[1000:], d.xyz[1000:]))
    _, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data",
                 ur10 / "ur10_random_poses.csv", "--holdout", 1773, expect=0)
    assert_same(res.json, ref)
    assert res.converged is True
    assert res.json["n_identification"] == 1000 and res.json["n_validation"] == 1773
    # The attributes are the JSON's.
    assert res.after["validation_rms_mm"] == res.json["after"]["validation_rms_mm"]
    assert res.parameters == res.json["parameters"]
    assert res.unidentifiable == ref["unidentifiable"]
    assert res.suspicious == ref["suspicious"]
    # The calibrated robot explains the held-out poses as reported.
    e = np.linalg.norm(res.robot.fk(d.q[1000:]) - d.xyz[1000:], axis=1)
    assert np.sqrt(np.mean(e**2)) == pytest.approx(res.after["validation_rms_mm"], abs=1e-9)
    assert e.max() == pytest.approx(res.after["validation_max_mm"], abs=1e-9)
    # And it is what --out writes.
    assert res.robot.base_known


def test_ur10_holdout_and_validate_file(ur10, cli, tmp_path):
    """holdout= on arrays, and --validate on files written by write_csv, give the CLI's."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    a, b = d[:1500], d[1500:]
    a.write(tmp_path / "a.csv")
    b.write(tmp_path / "b.csv")
    _, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data", tmp_path / "a.csv",
                 "--validate", tmp_path / "b.csv", expect=0)
    assert_same(kinecal.identify(robot, a.q, a.xyz, validate=b).json, ref)
    _, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data",
                 ur10 / "ur10_random_poses.csv", "--holdout", 0.3, expect=0)
    assert_same(kinecal.identify(robot, d.q, d.xyz, holdout=0.3).json, ref)


def test_ur10_effects_and_fix(ur10, cli):
    """Options map to the CLI's flags: a joint table on joint 2 and a fixed parameter."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    res = kinecal.identify(robot, d.q, d.xyz, holdout=1773, effects=["joint-table:2"],
                           fix=["tool.x"], warn=False)
    _, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data",
                 ur10 / "ur10_random_poses.csv", "--holdout", 1773, "--effect", "joint-table:2",
                 "--fix", "tool.x", expect=0)
    assert_same(res.json, ref)
    assert res.after["validation_rms_mm"] < 0.49
    assert "tool.x" not in res.json["changes"]


@pytest.fixture(scope="module")
def simulated(cli, tmp_path_factory):
    """A simulated cell robot with geometric errors and a cyclic error (CLI simulate)."""
    d = tmp_path_factory.mktemp("sim")
    cli("simulate", "--robot", CELL / "robot.toml", "--poses", 300, "--noise-mm", 0.01,
        "--seed", 7, "--geom-errors", "--effect", "joint-cyclic:2:0.0004,-0.0003",
        "--out", d / "sim.csv", "--truth", d / "truth.toml", expect=0)
    return d


def test_simulated_with_effect_equals_cli(simulated, cli):
    """Simulated data, an effect requested, the pso+lm method: Python equals the CLI."""
    robot = kinecal.Robot.from_file(CELL / "robot.toml")
    d = kinecal.read_csv(simulated / "sim.csv")
    for opts, flags in [
        (dict(effects=["joint-cyclic:2"]), ["--effect", "joint-cyclic:2"]),
        (dict(method="pso+lm", seed=3), ["--method", "pso+lm", "--seed", 3]),
    ]:
        res = kinecal.identify(robot, d.q, d.xyz, holdout=100, **opts)
        _, ref = cli("identify", "--robot", CELL / "robot.toml", "--data", simulated / "sim.csv",
                     "--holdout", 100, *flags)
        assert_same(res.json, ref)
        assert res.converged == ref["converged"]


def test_not_converged_is_visible(ur10, cli):
    """A fit stopped above --stall-rms-mm: converged=False and a NotConvergedWarning, as the
    CLI's exit status 3 with converged: false."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    with pytest.warns(kinecal.NotConvergedWarning):
        res = kinecal.identify(robot, d.q[:300], d.xyz[:300], stall_rms_mm=0.01)
    assert res.converged is False and res.json["converged"] is False
    code, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data",
                    ur10 / "ur10_random_poses.csv", "--holdout", 2473, "--stall-rms-mm", 0.01)
    assert code == 3
    assert res.json["stop"] == ref["stop"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kinecal.identify(robot, d.q[:300], d.xyz[:300], stall_rms_mm=0.01, warn=False)


def test_units_flags(ur10):
    """Metres with length_unit="m" and radians with angle_unit="rad" give the millimetre and
    degree fit (to 1e-9 mm: the conversion is the CLI's)."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")[:600]
    ref = kinecal.identify(robot, d.q, d.xyz, holdout=200)
    res = kinecal.identify(robot, np.radians(d.q), d.xyz / 1000.0, holdout=200,
                           length_unit="m", angle_unit="rad")
    for k in ("identification_rms_mm", "validation_rms_mm", "validation_max_mm"):
        assert res.after[k] == pytest.approx(ref.after[k], abs=1e-9)


def test_ur10_split_only_and_prior(ur10, cli):
    """split=, only= and prior= map to the CLI's flags."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    res = kinecal.identify(robot, d.q, d.xyz, split="every:5", only=["base", "tool", "theta"],
                           prior=["length_mm=1"], warn=False)
    _, ref = cli("identify", "--robot", ur10 / "robot.toml", "--data",
                 ur10 / "ur10_random_poses.csv", "--split", "every:5", "--only",
                 "base,tool,theta", "--prior", "length_mm=1", expect=0)
    assert_same(res.json, ref)
    assert res.json["n_validation"] == 2773 // 5
    assert res.json["held_out_worse"] is False
    assert all(k.startswith(("base.", "tool.", "theta")) for k in res.json["changes"])
