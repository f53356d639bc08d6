"""What a notebook user meets: unreached compensation targets, orientation units, held-out
and cross-validated figures, temperatures in fk, warnings, list options given as one string,
row numbers in messages and diagnose's options (each against the command line)."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import kinecal
from conftest import CELL, REPO, assert_same

THERMAL = "thermal-expansion:0:1.2e-5"


@pytest.fixture(scope="module")
def cell():
    return kinecal.Robot.from_file(CELL / "robot.toml")


@pytest.fixture(scope="module")
def warm(cli, tmp_path_factory):
    """A warm-up (15 → 35 °C) of the cell robot with thermal expansion, no noise: the CLI's
    measurements and true robot."""
    d = tmp_path_factory.mktemp("warm")
    _, rep = cli("simulate", "--robot", CELL / "robot.toml", "--poses", 120, "--seed", 4,
                 "--temperature", "15:35", "--effect", THERMAL, "--out", d / "d.csv",
                 "--truth", d / "truth.toml", expect=0)
    return d, rep


def stderr_of(kinecal_bin, *args):
    p = subprocess.run([str(kinecal_bin), *map(str, args)], capture_output=True, text=True)
    return p.returncode, p.stderr.strip().splitlines()


# ------------------------------------------------------------------------------------------
# 1. Targets not reached: the command line's exit 3 as NotConvergedWarning with its error


def test_unreached_targets_warn_with_the_cli_error(cell, kinecal_bin, tmp_path):
    rng = np.random.default_rng(3)
    seeds = rng.uniform(-60, 60, size=(10, cell.joints))
    targets = cell.fk(seeds) + [60.0, 0.0, 0.0]  # beyond the 2° a correction may move
    kinecal.write_csv(tmp_path / "t.csv", seeds, targets)
    code, lines = stderr_of(kinecal_bin, "compensate", "--model", CELL / "robot.toml",
                            "--targets", tmp_path / "t.csv", "--out", tmp_path / "q.csv")
    assert code == 3
    error = next(line for line in lines if line.startswith("error: "))[len("error: "):]
    assert "do not send them" in error
    with pytest.warns(kinecal.NotConvergedWarning) as w:
        r = kinecal.compensate(cell, seeds, targets)
    assert not r.converged and r.json["failed"] == 10
    assert all(s != "ok" for s in r.status)
    message = str(w[0].message).splitlines()
    assert message[0] == error
    hints = [line for line in lines if line.startswith("hint:")]
    assert message[1:] == hints and r.json["hint"] == (hints[0] if hints else None)
    # warn=False silences it; the result says the same.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not kinecal.compensate(cell, seeds, targets, warn=False).converged
    # A reached set does not warn.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert kinecal.compensate(cell, seeds, cell.fk(seeds) + 0.1).converged


def test_unreached_cartesian_targets_warn(cell):
    rng = np.random.default_rng(5)
    seeds = rng.uniform(-60, 60, size=(4, cell.joints))
    far = cell.fk(seeds) + [60.0, 0.0, 0.0]
    with pytest.warns(kinecal.NotConvergedWarning,
                      match="4 of 4 targets were not reached.*keep the target"):
        sent, status = kinecal.compensate_cartesian(cell, cell, seeds, far)
    assert all(s != "ok" for s in status)
    np.testing.assert_array_equal(sent, far)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, status = kinecal.compensate_cartesian(cell, cell, seeds, cell.fk(seeds))
    assert status == ["ok"] * 4


# ------------------------------------------------------------------------------------------
# 2. Orientations in angle_unit: `rpy`, and `rpy_deg` as before


def test_rpy_follows_angle_unit(cell):
    rng = np.random.default_rng(6)
    q = rng.uniform(-50, 50, size=(5, cell.joints))
    q[:, 4] = rng.uniform(20, 60, 5)  # away from the wrist singularity
    seeds = q + 0.3
    # Pose targets: the model's tool point and orientation at q (so the answer is q).
    xyz = cell.fk(q)
    rpy = _tool_rpy(cell, q)
    a = kinecal.compensate(cell, seeds, xyz, rpy)
    b = kinecal.compensate(cell, seeds, xyz, rpy_deg=rpy)
    np.testing.assert_array_equal(a.q, b.q)
    assert a.status == ["ok"] * 5 and np.abs(a.q - q).max() < 1e-6
    # Radians: rpy in radians with the seeds in radians gives the same commands.
    r = kinecal.compensate(cell, np.radians(seeds), xyz, np.radians(rpy), angle_unit="rad")
    assert r.status == ["ok"] * 5
    np.testing.assert_allclose(np.degrees(r.q), a.q, atol=1e-9)
    # rpy_deg with angle_unit="rad" is read in radians too, as before, and warns that it is.
    with pytest.warns(kinecal.DataWarning, match="rpy_deg is read in angle_unit, here radians"):
        old = kinecal.compensate(cell, np.radians(seeds), xyz, rpy_deg=np.radians(rpy),
                                 angle_unit="rad")
    np.testing.assert_array_equal(old.q, r.q)
    with pytest.raises(kinecal.RefusedError, match="give the orientations once"):
        kinecal.compensate(cell, seeds, xyz, rpy, rpy_deg=rpy)


def _tool_rpy(robot, q):
    """Fixed-axis roll, pitch, yaw (degrees) of the tool frame at q, from the MDH rows
    (independent of kinecal's code: docs/formats.md's chain)."""
    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    def ry(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    base = robot.base
    out = []
    for qq in q:
        m = np.eye(3)
        if base is not None:
            r, p, w = np.radians(base[1])
            m = rz(w) @ ry(p) @ rx(r)
        for (al, _a, th, _d, be), qi in zip(robot.mdh, qq):
            m = m @ rx(np.radians(al)) @ ry(np.radians(be)) @ rz(np.radians(th + qi))
        out.append(np.degrees([np.arctan2(m[2, 1], m[2, 2]), np.arcsin(-m[2, 0]),
                               np.arctan2(m[1, 0], m[0, 0])]))
    return np.array(out)


# ------------------------------------------------------------------------------------------
# 3. diagnose: held-out and cross-validated figures, labelled


def test_diagnose_names_held_out_and_cross_validated(cell, cli, tmp_path):
    res = kinecal.simulate(cell, 300, noise_mm=0.005, seed=11, geom_errors=True,
                           effects="joint-cyclic:2:0.0005,-0.0004")
    d = res.measurements
    diag = kinecal.diagnose(cell, d.q, d.xyz, holdout=60)
    assert isinstance(diag, kinecal.DiagnoseResult)
    h = diag.holdout
    assert diag.held_out_rms_mm == (h["geometric_rms_mm"], h["final_rms_mm"])
    assert diag.cross_validated_rms_mm == (diag.baseline_validation_rms_mm,
                                           diag.final_validation_rms_mm)
    # The held-out figure is the extended model's error on the last 60 poses.
    e = np.linalg.norm(d.xyz[-60:] - diag.robot.fk(d.q[-60:]), axis=1)
    assert abs(np.sqrt(np.mean(e ** 2)) - h["final_rms_mm"]) < 1e-6
    text = repr(diag)
    assert f"held-out (60 poses) RMS {h['geometric_rms_mm']:.4g}" in text
    assert f"cross-validated RMS {diag.baseline_validation_rms_mm:.4g}" in text
    # The command line's text report, held-out lines included.
    assert "held-out poses (60), not searched" in diag.text
    assert "cross-validated RMS" in diag.text
    # Without held-out poses there are none.
    assert kinecal.diagnose(cell, d.q[:150], d.xyz[:150], max_effects=1).held_out_rms_mm is None


def test_example_prints_held_out_figures_from_holdout(ur10, tmp_path):
    """The shipped example labels diagnose's figures: cross-validated from the headline keys,
    held-out from ``holdout`` (its numbers equal a direct call's)."""
    p = subprocess.run([sys.executable, str(REPO / "python" / "examples" / "calibrate_ur10.py"),
                        str(ur10)], capture_output=True, text=True, cwd=tmp_path, check=True)
    robot = kinecal.Robot.from_file(ur10 / "robot.toml")
    data = kinecal.read_csv(ur10 / "ur10_random_poses.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        diag = kinecal.diagnose(robot, data.q, data.xyz, holdout=1773)
    h = diag.holdout
    out = p.stdout
    assert (f"held-out RMS (1773 poses, not searched) {h['geometric_rms_mm']:.3f} mm -> "
            f"{h['final_rms_mm']:.3f} mm") in out
    b, f = diag.cross_validated_rms_mm
    assert f"cross-validated RMS (searched poses) {b:.3f} mm -> {f:.3f} mm" in out
    # No diagnose figure is called held-out but the holdout's.
    diag_lines = out[out.index("diagnose in"):]
    for line in diag_lines.splitlines():
        if "held-out" in line:
            assert "holdout" in line or "1773 poses" in line or "held-out final" in line, line


# ------------------------------------------------------------------------------------------
# 4. fk and jacobian at the arm's temperature


def test_fk_at_temperature_equals_simulated_truth(warm):
    d, _ = warm
    truth = kinecal.Robot.from_file(d / "truth.toml")
    m = kinecal.read_csv(d / "d.csv")
    t = m.columns["temp_c"]
    assert t.min() < 16 and t.max() > 34
    at = truth.fk(m.q, temp_c=t)
    assert np.abs(at - m.xyz).max() < 1e-4  # the file's digits: no noise was simulated
    with pytest.warns(kinecal.DataWarning, match="thermal expansion and no temp_c"):
        ref = truth.fk(m.q)
    assert np.abs(ref - m.xyz).max() > 0.05  # 1.2e-5/K × 10 K × a metre
    # One temperature for every pose, and one pose.
    np.testing.assert_array_equal(truth.fk(m.q[:3], temp_c=t[0]),
                                  truth.fk(m.q[:3], temp_c=np.full(3, t[0])))
    np.testing.assert_array_equal(truth.fk(m.q[0], temp_c=t[0]), at[0])
    # A robot without the term takes temp_c and does not warn.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plain = kinecal.Robot.from_file(CELL / "robot.toml")
        np.testing.assert_array_equal(plain.fk(m.q, temp_c=t), plain.fk(m.q))
    bad = t.copy()
    bad[4] = np.nan
    with pytest.raises(kinecal.RefusedError, match="temp_c: row 4: NaN"):
        truth.fk(m.q, temp_c=bad)
    with pytest.raises(kinecal.RefusedError, match="temp_c: 2 values for 120 poses"):
        truth.fk(m.q, temp_c=t[:2])


def test_jacobian_at_temperature(warm):
    """The thermal coefficient's column is d p / d c = (p(T) − p(T0)) / c exactly (lengths
    scale by 1 + c·(T − T0)); the geometric columns scale with the arm."""
    d, _ = warm
    truth = kinecal.Robot.from_file(d / "truth.toml")
    m = kinecal.read_csv(d / "d.csv")
    q, t = m.q[:8], m.columns["temp_c"][:8]
    J, names = truth.jacobian(q, temp_c=t)
    k = next(i for i, n in enumerate(names) if "thermal" in n)
    with pytest.warns(kinecal.DataWarning):
        p0 = truth.fk(q)
        J0, _ = truth.jacobian(q)
    c = 1.2e-5
    np.testing.assert_allclose(J[:, :, k], (truth.fk(q, temp_c=t) - p0) / c, rtol=1e-6,
                               atol=1e-6)
    assert np.abs(J[:, :, k] - J0[:, :, k]).max() > 1.0


def test_simulate_temperature_equals_cli(cell, warm):
    d, rep = warm
    res = kinecal.simulate(cell, 120, seed=4, temperature=(15, 35), effects=THERMAL)
    assert_same(res.json, rep)
    ref = kinecal.read_csv(d / "d.csv")
    np.testing.assert_array_equal(res.measurements.xyz, ref.xyz)
    np.testing.assert_array_equal(res.measurements.columns["temp_c"], ref.columns["temp_c"])
    with pytest.raises(kinecal.RefusedError, match="--temperature"):
        kinecal.simulate(cell, 10, temperature=(15, 5000))


# ------------------------------------------------------------------------------------------
# 5. compensate's temperature warning as a DataWarning


def test_compensate_temperature_warning_is_a_data_warning(warm, kinecal_bin, tmp_path):
    d, _ = warm
    truth = kinecal.Robot.from_file(d / "truth.toml")
    m = kinecal.read_csv(d / "d.csv")
    kinecal.write_csv(tmp_path / "t.csv", m.q[:5], m.xyz[:5])
    code, lines = stderr_of(kinecal_bin, "compensate", "--model", d / "truth.toml", "--targets",
                            tmp_path / "t.csv", "--out", tmp_path / "q.csv")
    assert code == 0
    cli_warning = next(line for line in lines if "no temp_c value" in line)
    with pytest.warns(kinecal.DataWarning) as w:
        r = kinecal.compensate(truth, m.q[:5], m.xyz[:5])
    texts = [str(x.message) for x in w if x.category is kinecal.DataWarning]
    expected = cli_warning[len("warning: "):].replace(str(tmp_path / "t.csv"), "targets")
    assert expected in texts
    assert r.json["temperature_warning"] == expected
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kinecal.compensate(truth, m.q[:5], m.xyz[:5], temp_c=m.columns["temp_c"][:5])


# ------------------------------------------------------------------------------------------
# 6. A list option given as one string is one item


def test_one_string_is_one_item(cell):
    res = kinecal.simulate(cell, 150, noise_mm=0.005, seed=3, geom_errors=True)
    d = res.measurements
    for kw in ({"fix": "theta1"}, {"only": "base"}, {"effects": "joint-cyclic:2"},
               {"free": "geometry"}):
        one = kinecal.identify(cell, d.q, d.xyz, warn=False, **kw)
        listed = kinecal.identify(cell, d.q, d.xyz, warn=False,
                                  **{k: [v] for k, v in kw.items()})
        assert_same(one.json, listed.json)
    fixed = kinecal.identify(cell, d.q, d.xyz, fix="theta1", warn=False)
    assert "theta1" not in fixed.parameters or fixed.parameters["theta1"] == pytest.approx(
        cell.mdh[0, 2])
    J, names = cell.jacobian(d.q[:2], params="d2")
    assert names == ["d2"] and J.shape == (2, 3, 1)
    a = kinecal.simulate(cell, 5, effects="joint-cyclic:2:0.001,0")
    b = kinecal.simulate(cell, 5, effects=["joint-cyclic:2:0.001,0"])
    np.testing.assert_array_equal(a.measurements.xyz, b.measurements.xyz)


# ------------------------------------------------------------------------------------------
# 7. Rows named as the command line names the lines of the file the arrays make


def test_rows_numbered_as_the_cli_numbers_lines(cell, kinecal_bin, tmp_path):
    rng = np.random.default_rng(2)
    q = rng.uniform(-60, 60, size=(6, cell.joints))
    xyz = cell.fk(q)
    bad = q.copy()
    bad[3, 1] = np.nan
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.check(cell, bad, xyz)
    # The same cell in a file: line 5 (row 3 + header + 1), column 2.
    rows = ["q1,q2,q3,q4,q5,q6,x,y,z"] + [
        ",".join("nan" if np.isnan(v) else repr(float(v)) for v in (*a, *b))
        for a, b in zip(bad, xyz)]
    (tmp_path / "d.csv").write_text("\n".join(rows) + "\n")
    code, lines = stderr_of(kinecal_bin, "check", "--robot", CELL / "robot.toml", "--data",
                            tmp_path / "d.csv")
    assert code == 2
    cli = lines[-1][len("kinecal: "):].replace(str(tmp_path / "d.csv"), "data")
    assert cli.startswith("data:5:2: NaN or infinite value in column `q2`")
    assert str(e.value).startswith("data:5:2: NaN or infinite value in column `q2`")
    assert "(row 3 of the arrays)" in str(e.value)


def test_nan_temperature_is_located(cell, warm):
    d, _ = warm
    m = kinecal.read_csv(d / "d.csv")
    t = m.columns["temp_c"].copy()
    t[4] = np.nan
    with pytest.raises(kinecal.RefusedError) as e:
        kinecal.identify(cell, m.q, m.xyz, columns={"temp_c": t}, effects="thermal-expansion:0",
                         warn=False)
    assert "every row" in str(e.value)
    assert re.search(r"data:6: no temp_c \(NaN; row 4 of the arrays, 1 such row\)", str(e.value))


# ------------------------------------------------------------------------------------------
# 8. diagnose's options: the command line's flags


def test_diagnose_split_and_sigma_options_equal_cli(cell, cli, tmp_path):
    res = kinecal.simulate(cell, 200, noise_mm=0.005, seed=7, geom_errors=True)
    d = res.measurements
    s = np.full(len(d), 0.01)
    s0 = s.copy()
    s0[0] = 0.0
    cols = {"sx_mm": s0, "sy_mm": s, "sz_mm": s}
    kinecal.write_csv(tmp_path / "d.csv", d.q, d.xyz, cols)
    with pytest.raises(kinecal.RefusedError, match="--ignore-sigma"):
        kinecal.diagnose(cell, d.q, d.xyz, columns=cols, max_effects=1)
    py = kinecal.diagnose(cell, d.q, d.xyz, columns=cols, holdout=40, split="every:5",
                          ignore_sigma=True, max_effects=1)
    code, ref = cli("diagnose", "--robot", CELL / "robot.toml", "--data", tmp_path / "d.csv",
                    "--holdout", 40, "--split", "every:5", "--ignore-sigma", "--max-effects", 1,
                    "--out", tmp_path / "ext.toml")
    assert code in (0, 3)
    assert_same(py.json, ref)
    assert py.holdout["poses"] == 40


def test_diagnose_positions_only_equals_cli(ur10, cli, tmp_path):
    text = (ur10 / "robot.toml").read_text()
    text = re.sub(r"(\[tool\]\n(?:[^\[\n][^\n]*\n)*?xyz_mm = [^\n]*\n)", r"\1rpy_deg = [0.0, 0.0, 0.0]\n",
                  text, count=1)
    (tmp_path / "robot.toml").write_text(text)
    robot = kinecal.Robot.from_file(tmp_path / "robot.toml")
    m = kinecal.read_csv(ur10 / "ur10_random_poses_6d.csv")[:300]
    m.write(tmp_path / "d.csv")
    py = kinecal.diagnose(robot, m.q, m.xyz, columns=m.columns, positions_only=True,
                          max_effects=1, warn=False)
    code, ref = cli("diagnose", "--robot", tmp_path / "robot.toml", "--data", tmp_path / "d.csv",
                    "--positions-only", "--max-effects", 1, "--out", tmp_path / "a.toml")
    assert_same(py.json, ref)
    assert py.figures_include_orientations is False
    both = kinecal.diagnose(robot, m.q, m.xyz, columns=m.columns, max_effects=1,
                            deg_weight_mm=50.0, warn=False)
    code, ref = cli("diagnose", "--robot", tmp_path / "robot.toml", "--data", tmp_path / "d.csv",
                    "--deg-weight-mm", 50, "--max-effects", 1, "--out", tmp_path / "b.toml")
    assert_same(both.json, ref)
    assert both.figures_include_orientations is True


def test_diagnose_no_calibration_warns_with_the_cli_reason(ur10, kinecal_bin, tmp_path):
    """Joint 6 logged with the other sign: the command line exits 3 naming the joint's
    readings; the package warns with that reason, not with "the geometry does not fit"."""
    text = (ur10 / "robot.toml").read_text().replace(
        "xyz_mm = [0.0, 0.0, 109.0]", "xyz_mm = [3.0, 0.0, 109.0]")
    text += "\n[base]\nxyz_mm = [400.0, -3000.0, 100.0]\nrpy_deg = [0.2, 0.1, -60.0]\n"
    robot = kinecal.Robot.from_toml(text, "placed")
    sim = kinecal.simulate(robot, 300, noise_mm=0.02, seed=2, geom_errors=True).measurements
    q = sim.q.copy()
    q[:, 5] = -q[:, 5]
    (tmp_path / "robot.toml").write_text((ur10 / "robot.toml").read_text())
    kinecal.write_csv(tmp_path / "d.csv", q, sim.xyz)
    code, lines = stderr_of(kinecal_bin, "diagnose", "--robot", tmp_path / "robot.toml",
                            "--data", tmp_path / "d.csv", "--holdout", 0.3)
    assert code == 3
    error = next(line for line in lines if line.startswith("error: "))
    assert "joint 6's readings do not follow" in error
    unplaced = kinecal.Robot.from_file(tmp_path / "robot.toml")
    with pytest.warns(kinecal.NotConvergedWarning) as w:
        r = kinecal.diagnose(unplaced, q, sim.xyz, holdout=0.3)
    assert not r.converged
    message = str(w[0].message)
    assert "joint 6's readings do not follow" in message, message
    assert "does not fit" not in message
    # The same session with the sign right: no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert kinecal.diagnose(unplaced, sim.q, sim.xyz, holdout=0.3).converged
