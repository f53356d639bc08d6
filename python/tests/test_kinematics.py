"""fk equals an independent numpy MDH model; jacobian equals finite differences of fk."""

from __future__ import annotations

import numpy as np
import pytest

import kinecal
from conftest import CELL, mdh_fk

ROWS = np.array([
    [0.0, 0.0, 0.0, 450.0, 0.0],
    [-90.0, 150.0, -90.0, 0.0, 0.0],
    [0.0, 610.0, 0.0, 0.0, 0.3],
    [-90.0, 110.0, 0.0, 660.0, 0.0],
    [90.0, 0.0, 0.0, 0.0, 0.0],
    [-90.0, 0.0, 0.0, 100.0, 0.0],
])
TOOL = np.array([10.0, -5.0, 80.0])
BASE = ([2400.0, -900.0, -250.0], [0.5, -1.0, 135.0])


def robot(rows=ROWS, tool=TOOL, base=BASE):
    return kinecal.Robot.from_mdh(rows, tool, base_xyz_mm=base[0], base_rpy_deg=base[1],
                                  limits_deg=np.tile([-170.0, 170.0], (len(rows), 1)))


def test_fk_equals_numpy_mdh():
    """FK of 500 random poses (degrees and radians, with base and tilt) equals the numpy
    reference of docs/formats.md "Kinematic model" to 1e-9 mm; a single pose gives shape (3,)."""
    rng = np.random.default_rng(1)
    q = rng.uniform(-170, 170, size=(500, 6))
    r = robot()
    ref = mdh_fk(ROWS, TOOL, q, BASE)
    assert r.fk(q).shape == (500, 3)
    np.testing.assert_allclose(r.fk(q), ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.fk(np.radians(q), angle_unit="rad"), ref, rtol=0, atol=1e-9)
    assert r.fk(q[0]).shape == (3,)
    np.testing.assert_allclose(r.fk(q[0]), ref[0], rtol=0, atol=1e-9)


def test_fk_of_files_equals_numpy_mdh(ur10):
    """The UR10 and the cell robot as read from their files: FK equals the reference."""
    rng = np.random.default_rng(2)
    for path in (ur10 / "robot.toml", CELL / "robot.toml"):
        r = kinecal.Robot.from_file(path)
        q = rng.uniform(-150, 150, size=(100, r.joints))
        np.testing.assert_allclose(r.fk(q), mdh_fk(r.mdh, np.array(r.tool_xyz_mm), q, r.base),
                                   rtol=0, atol=1e-9)


def test_fk_equals_cli_check(cli, tmp_path):
    """The nominal RMS `kinecal check` reports for data at a known base equals the RMS of
    fk − xyz."""
    r = robot()
    rng = np.random.default_rng(3)
    q = rng.uniform(-150, 150, size=(50, 6))
    xyz = r.fk(q) + rng.normal(0, 0.5, size=(50, 3))
    r.save(tmp_path / "r.toml")
    kinecal.write_csv(tmp_path / "d.csv", q, xyz)
    _, ref = cli("check", "--robot", tmp_path / "r.toml", "--data", tmp_path / "d.csv", expect=0)
    rms = np.sqrt(np.mean(np.sum((r.fk(q) - xyz) ** 2, axis=1)))
    assert rms == pytest.approx(ref["nominal_rms_mm"], rel=1e-9)
    assert kinecal.check(r, q, xyz).json["nominal_rms_mm"] == ref["nominal_rms_mm"]


def test_jacobian_equals_finite_differences():
    """Every MDH and tool column of the identification Jacobian equals central differences of
    fk with the parameter moved in the robot description (1e-5 relative)."""
    rng = np.random.default_rng(4)
    q = rng.uniform(-150, 150, size=(20, 6))
    r = robot()
    J, names = r.jacobian(q)
    assert J.shape == (20, 3, len(names))
    assert names == r.parameter_names()
    col = {"alpha": 0, "a": 1, "theta": 2, "d": 3}
    checked = 0
    for k, name in enumerate(names):
        rows, tool = ROWS.copy(), TOOL.copy()
        if name.startswith("tool."):
            idx, h, scale = "xyz".index(name[-1]), 1e-4, 1.0
            plus, minus = tool.copy(), tool.copy()
            plus[idx] += h
            minus[idx] -= h
            fd = (robot(tool=plus).fk(q) - robot(tool=minus).fk(q)) / (2 * h)
        else:
            kind = name.rstrip("0123456789")
            j = int(name[len(kind):]) - 1
            c = col[kind]
            angle = c in (0, 2)
            h = 1e-5 if angle else 1e-4
            plus, minus = rows.copy(), rows.copy()
            plus[j, c] += h
            minus[j, c] -= h
            fd = (robot(rows=plus).fk(q) - robot(rows=minus).fk(q)) / (2 * h)
            if angle:
                fd = fd * (180.0 / np.pi)  # the Jacobian is per radian
        np.testing.assert_allclose(J[:, :, k], fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max() + 1e-7)
        checked += 1
    assert checked == 4 * 6 + 3
    one, _ = r.jacobian(q[0], params=["d4", "tool.z"])
    assert one.shape == (3, 2)
    np.testing.assert_array_equal(one, J[0][:, [names.index("d4"), names.index("tool.z")]])
