"""Bad input raises RefusedError (a ValueError) with the command line's one-line reason."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

import kinecal


@pytest.fixture(scope="module")
def ur(ur10):
    return kinecal.Robot.from_file(ur10 / "robot.toml"), kinecal.read_csv(ur10 / "ur10_random_poses.csv")[:500]


def cli_reason(kinecal_bin, *args):
    p = subprocess.run([str(kinecal_bin), *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("kinecal: ")
    return line[len("kinecal: "):]


def after_origin(text):
    """The reason without the file name it starts with."""
    return text.split(": ", 1)[1]


def test_refused_is_value_error():
    assert issubclass(kinecal.RefusedError, ValueError)
    assert issubclass(kinecal.RefusedError, kinecal.KinecalError)


def test_metres_as_mm(ur, tmp_path, kinecal_bin, ur10):
    """Metres given as millimetres: the CLI's reason (naming the flag), word for word."""
    robot, d = ur
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.identify(robot, d.q, d.xyz / 1000.0)
    kinecal.write_csv(tmp_path / "m.csv", d.q, d.xyz / 1000.0)
    reason = cli_reason(kinecal_bin, "identify", "--robot", ur10 / "robot.toml", "--data", tmp_path / "m.csv")
    assert "look like metres" in str(e.value) and "--length-unit m" in str(e.value)
    assert after_origin(str(e.value)) == after_origin(reason)
    assert str(e.value).startswith("data: ")


def test_radians_as_degrees(ur, tmp_path, kinecal_bin, ur10):
    robot, d = ur
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.identify(robot, np.radians(d.q), d.xyz)
    kinecal.write_csv(tmp_path / "r.csv", np.radians(d.q), d.xyz)
    reason = cli_reason(kinecal_bin, "identify", "--robot", ur10 / "robot.toml", "--data", tmp_path / "r.csv")
    assert after_origin(str(e.value)) == after_origin(reason)
    assert "--angle-unit rad" in str(e.value)


def test_nan_and_magnitudes(ur):
    """NaN and absurd magnitudes: the CSV reader's descriptions, naming row and column."""
    robot, d = ur
    q = d.q.copy()
    q[3, 1] = np.nan
    with pytest.raises(kinecal.RefusedError,
                       match=r"^data:5:2: NaN or infinite value in column `q2`: NaN \(row 3 of"):
        kinecal.identify(robot, q, d.xyz)
    xyz = d.xyz.copy()
    xyz[7, 2] = 1e9
    with pytest.raises(kinecal.RefusedError,
                       match=r"^data:9:9: implausible magnitude in column `z`: .*\(row 7 of"):
        kinecal.identify(robot, d.q, xyz)
    with pytest.raises(ValueError, match="NaN or infinite value"):
        robot.fk([[0, 0, np.inf, 0, 0, 0]])


def test_shapes_and_joint_count(ur):
    robot, d = ur
    with pytest.raises(kinecal.RefusedError, match="q has 5 columns, but the robot has 6 joints"):
        kinecal.identify(robot, d.q[:, :5], d.xyz)
    with pytest.raises(kinecal.RefusedError, match="xyz has shape"):
        kinecal.identify(robot, d.q, d.xyz[:, :2])
    with pytest.raises(kinecal.RefusedError, match="xyz has shape"):
        kinecal.identify(robot, d.q, d.xyz[:-1])
    with pytest.raises(kinecal.RefusedError, match="but the robot has 6 joints"):
        robot.fk(np.zeros((4, 7)))
    with pytest.raises(kinecal.RefusedError, match="dimensions"):
        robot.fk(np.zeros((2, 2, 6)))
    with pytest.raises(kinecal.RefusedError, match="angle_unit"):
        robot.fk(np.zeros(6), angle_unit="grad")
    with pytest.raises(kinecal.RefusedError, match="column temp_c"):
        kinecal.identify(robot, d.q, d.xyz, columns={"temp_c": [1.0, 2.0]})


def test_too_few_poses_and_bad_options(ur, kinecal_bin, ur10, tmp_path):
    robot, d = ur
    kinecal.write_csv(tmp_path / "few.csv", d.q[:4], d.xyz[:4])
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.identify(robot, d.q[:4], d.xyz[:4])
    reason = cli_reason(kinecal_bin, "identify", "--robot", ur10 / "robot.toml", "--data", tmp_path / "few.csv")
    assert after_origin(str(e.value)) == after_origin(reason)
    with pytest.raises(kinecal.RefusedError, match="--fix d9: not a parameter"):
        kinecal.identify(robot, d.q, d.xyz, fix=["d9"])
    with pytest.raises(kinecal.RefusedError, match="--holdout"):
        kinecal.identify(robot, d.q, d.xyz, holdout=-1.0)
    with pytest.raises(kinecal.RefusedError, match=r"^--method newton: give one of lm, pso, bpnn-pso, pso\+lm$"):
        kinecal.identify(robot, d.q, d.xyz, method="newton")
    with pytest.raises(kinecal.RefusedError, match=r"^--split sometimes: give last, random or every:K"):
        kinecal.identify(robot, d.q, d.xyz, holdout=0.2, split="sometimes")
    with pytest.raises(kinecal.RefusedError, match=r"^--length-unit inch: give one of mm, m$"):
        kinecal.check(robot, d.q, d.xyz, length_unit="inch")
    with pytest.raises(kinecal.RefusedError, match=r"^--effect "):
        kinecal.identify(robot, d.q, d.xyz, effects=["wobble:2"])
    # A value of the wrong type is refused naming the option, not run with a default.
    with pytest.raises(kinecal.RefusedError, match=r"^identify: .*seed"):
        kinecal.identify(robot, d.q, d.xyz, seed="seven")
    with pytest.raises(kinecal.RefusedError, match=r"^diagnose: .*folds"):
        kinecal.diagnose(robot, d.q, d.xyz, folds=-2)
    with pytest.raises(kinecal.RefusedError, match="cannot be used with"):
        kinecal.identify(robot, d.q, d.xyz, holdout=10, validate=(d.q, d.xyz))


def test_files(tmp_path, kinecal_bin, ur10):
    """Missing and malformed files: the CLI's reasons, naming file, line and column."""
    missing = tmp_path / "missing.toml"
    with pytest.raises(kinecal.RefusedError, match="cannot read"):
        kinecal.Robot.from_file(missing)
    with pytest.raises(kinecal.RefusedError, match="cannot read"):
        kinecal.read_csv(tmp_path / "missing.csv", joints=6)
    bad = tmp_path / "bad.toml"
    bad.write_text((ur10 / "robot.toml").read_text().replace("a_mm = 612.7", "a_mm = \"x\""))
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.Robot.from_file(bad)
    reason = cli_reason(kinecal_bin, "check", "--robot", bad, "--data", ur10 / "ur10_random_poses.csv")
    assert str(e.value) == reason
    csv = tmp_path / "bad.csv"
    csv.write_text("q1,q2,q3,q4,q5,q6,x,y,z\n1,2,3,4,5,6,7,8,9\n1,2,x,4,5,6,7,8,9\n")
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.read_csv(csv)
    reason = cli_reason(kinecal_bin, "check", "--robot", ur10 / "robot.toml", "--data", csv)
    assert str(e.value) == reason and ":3:" in reason
    with pytest.raises(kinecal.RefusedError, match="rows: 3 columns"):
        kinecal.Robot.from_mdh(np.zeros((6, 3)), [0, 0, 0])


def test_bad_options_of_the_producers(ur, tmp_path):
    """The producers' options are typed: a word the command line would refuse is refused
    naming its flag, a value of the wrong type naming the option; nothing runs."""
    robot, d = ur
    with pytest.raises(kinecal.RefusedError, match=r"^--criterion best: give one of random, d, o1, a, kpi$"):
        kinecal.plan(robot, tmp_path / "no-scene.toml", 10, "best", [[0.0] * 6])
    with pytest.raises(kinecal.RefusedError, match=r"^plan: pool: "):
        kinecal.plan(robot, tmp_path / "no-scene.toml", 10, "kpi", [[0.0] * 6], pool=-5)
    with pytest.raises(kinecal.RefusedError, match=r"^simulate: seed: "):
        kinecal.simulate(robot, 10, seed=1.5)
    with pytest.raises(kinecal.RefusedError, match=r"^--angle-unit grad: give one of deg, rad$"):
        kinecal.compensate(robot, d.q[:3], d.xyz[:3], angle_unit="grad")
    with pytest.raises(kinecal.RefusedError, match=r"^compensate: iterations: "):
        kinecal.compensate(robot, d.q[:3], d.xyz[:3], iterations=1000)
