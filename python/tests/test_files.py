"""Robot TOML and measurement CSV: write → read round trips."""

from __future__ import annotations

import numpy as np

import kinecal
from conftest import CELL


def test_robot_toml_round_trip(tmp_path, ur10):
    """from_file → save → from_file gives the same description; so does to_toml/from_toml,
    and a robot built from MDH rows keeps every number exactly."""
    for path in (ur10 / "robot.toml", CELL / "robot.toml"):
        r = kinecal.Robot.from_file(path)
        r.save(tmp_path / "r.toml")
        back = kinecal.Robot.from_file(tmp_path / "r.toml")
        assert back == r
        assert back.to_toml() == r.to_toml()
        assert kinecal.Robot.from_toml(r.to_toml()) == r
        np.testing.assert_array_equal(back.mdh, r.mdh)
    rng = np.random.default_rng(5)
    rows = np.column_stack([rng.uniform(-90, 90, 6), rng.uniform(0, 700, 6),
                            rng.uniform(-90, 90, 6), rng.uniform(0, 700, 6), np.zeros(6)])
    r = kinecal.Robot.from_mdh(rows, [0.1, 0.2, 100.3], base_xyz_mm=[1.0, 2.0, 3.0],
                               base_rpy_deg=[0.1, 0.2, 0.3], name="random")
    r.save(tmp_path / "m.toml")
    back = kinecal.Robot.from_file(tmp_path / "m.toml")
    np.testing.assert_array_equal(back.mdh, rows)
    assert back.base == ([1.0, 2.0, 3.0], [0.1, 0.2, 0.3]) and back.name == "random"


def test_identified_model_round_trip(tmp_path, ur10):
    """The identified robot saved and read back predicts exactly the same points."""
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")[:400]
    res = kinecal.identify(robot, d.q, d.xyz)
    res.robot.save(tmp_path / "model.toml")
    back = kinecal.Robot.from_file(tmp_path / "model.toml")
    np.testing.assert_array_equal(back.fk(d.q), res.robot.fk(d.q))


def test_csv_round_trip(tmp_path, ur10):
    """read_csv → write → read_csv gives the same arrays bit for bit (extra columns and empty
    cells included), also for random numbers with 17 significant digits."""
    d = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    d.write(tmp_path / "a.csv")
    back = kinecal.read_csv(tmp_path / "a.csv")
    np.testing.assert_array_equal(back.q, d.q)
    np.testing.assert_array_equal(back.xyz, d.xyz)
    np.testing.assert_array_equal(back.columns["temp_c"], d.columns["temp_c"])
    rng = np.random.default_rng(6)
    q = rng.uniform(-180, 180, size=(200, 6))
    xyz = rng.uniform(-3000, 3000, size=(200, 3))
    extra = rng.normal(size=200)
    extra[::7] = np.nan
    kinecal.write_csv(tmp_path / "b.csv", q, xyz, {"temp_c": extra})
    back = kinecal.read_csv(tmp_path / "b.csv", joints=6)
    np.testing.assert_array_equal(back.q, q)
    np.testing.assert_array_equal(back.xyz, xyz)
    np.testing.assert_array_equal(back.columns["temp_c"], extra)  # NaN == empty cell
