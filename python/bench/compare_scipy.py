#!/usr/bin/env python3
"""kinecal.identify against a pybotics-style calibration with scipy, on the same UR10 data,
in one run.

    python python/bench/compare_scipy.py [DATA_DIR] [--quick]

The scipy calibration is what pybotics (and most notebooks) do: a numpy modified-DH forward
kinematics evaluated pose by pose, position errors as the residual vector, and
``scipy.optimize.least_squares`` (its defaults: trust-region reflective, a 2-point numerical
Jacobian) over the same parameters kinecal estimates (the base pose, the identifiable MDH
parameters and the tool point; kinecal's identifiability analysis names the ones to hold),
started from the same nominal model with the base placed by point-set registration (Kabsch).
A second scipy row evaluates the FK of all poses at once (numpy-vectorised), the fastest plain
numpy gets. Both report the RMS error on the 1,773 held-out poses.
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

import kinecal

JOINT_KEYS = ("alpha", "a", "theta", "d")


def data_dir() -> Path:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if args:
        return Path(args[0])
    return Path(__file__).resolve().parents[2] / "data" / "ur10"


# ---- pybotics-style model: parameter vector, FK per pose ------------------------------------

def rot_rpy(r, p, y):
    """R = Rz(y)·Ry(p)·Rx(r) (docs/formats.md "Kinematic model")."""
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def mdh_transform(alpha, a, theta, d):
    """Rx(alpha)·Tx(a)·Rz(theta)·Tz(d), as pybotics' MDH link."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array([
        [ct, -st, 0, a],
        [st * ca, ct * ca, -sa, -d * sa],
        [st * sa, ct * sa, ca, d * ca],
        [0, 0, 0, 1.0],
    ])


def unpack(x):
    base = np.eye(4)
    base[:3, :3] = rot_rpy(*x[3:6])
    base[:3, 3] = x[:3]
    mdh = x[6:30].reshape(6, 4)
    tool = x[30:33]
    return base, mdh, tool


def fk_pose(x, q):
    """pybotics-style: one pose, a 4×4 chain."""
    base, mdh, tool = unpack(x)
    t = base
    for (alpha, a, theta, d), qi in zip(mdh, q):
        t = t @ mdh_transform(alpha, a, theta + qi, d)
    return t[:3, :3] @ tool + t[:3, 3]


def fk_all(x, q):
    """The same model, all poses at once (numpy broadcasting)."""
    base, mdh, tool = unpack(x)
    n = len(q)
    t = np.broadcast_to(base, (n, 4, 4)).copy()
    for j, (alpha, a, theta, d) in enumerate(mdh):
        ca, sa = np.cos(alpha), np.sin(alpha)
        th = theta + q[:, j]
        ct, st = np.cos(th), np.sin(th)
        m = np.zeros((n, 4, 4))
        m[:, 0, 0], m[:, 0, 1], m[:, 0, 3] = ct, -st, a
        m[:, 1, 0], m[:, 1, 1], m[:, 1, 2], m[:, 1, 3] = st * ca, ct * ca, -sa, -d * sa
        m[:, 2, 0], m[:, 2, 1], m[:, 2, 2], m[:, 2, 3] = st * sa, ct * sa, ca, d * ca
        m[:, 3, 3] = 1.0
        t = t @ m
    return np.einsum("nij,j->ni", t[:, :3, :3], tool) + t[:, :3, 3]


def kabsch(model_pts, measured):
    """The rigid placement (R, t) of model points onto measured points."""
    cm, cd = model_pts.mean(0), measured.mean(0)
    h = (model_pts - cm).T @ (measured - cd)
    u, _, vt = np.linalg.svd(h)
    s = np.diag([1, 1, np.sign(np.linalg.det(vt.T @ u.T))])
    r = vt.T @ s @ u.T
    return r, cd - r @ cm


def nominal_vector(robot, q_ident, xyz_ident):
    mdh = robot.mdh
    x = np.zeros(33)
    x[6:30] = np.column_stack([np.radians(mdh[:, 0]), mdh[:, 1], np.radians(mdh[:, 2]), mdh[:, 3]]).ravel()
    x[30:33] = robot.tool_xyz_mm
    x[3:6] = 0.0
    pts = fk_all(x, q_ident)
    r, t = kabsch(pts, xyz_ident)
    x[:3] = t
    # rpy of r (R = Rz·Ry·Rx)
    x[4] = -np.arcsin(np.clip(r[2, 0], -1, 1))
    x[3] = np.arctan2(r[2, 1], r[2, 2])
    x[5] = np.arctan2(r[1, 0], r[0, 0])
    return x


def index_of(name):
    base = {"base.x": 0, "base.y": 1, "base.z": 2, "base.rx": 3, "base.ry": 4, "base.rz": 5}
    if name in base:
        return base[name]
    if name.startswith("tool."):
        return 30 + "xyz".index(name[-1])
    kind = name.rstrip("0123456789")
    return 6 + (int(name[len(kind):]) - 1) * 4 + JOINT_KEYS.index(kind)


def scipy_calibrate(x0, free, q, xyz, vectorised):
    def residuals(p):
        x = x0.copy()
        x[free] = p
        if vectorised:
            pred = fk_all(x, q)
        else:
            pred = np.array([fk_pose(x, qi) for qi in q])
        return (pred - xyz).ravel()

    t = time.perf_counter()
    sol = least_squares(residuals, x0[free])
    seconds = time.perf_counter() - t
    x = x0.copy()
    x[free] = sol.x
    # Model evaluations of all poses: the residual calls and the Jacobian's (one per column).
    return x, seconds, sol.nfev + sol.njev * len(free)


def rms(e):
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))


def main() -> int:
    quick = "--quick" in sys.argv
    d = data_dir()
    robot = kinecal.Robot.from_file(d / "robot.toml")
    data = kinecal.read_csv(d / "ur10_random_poses.csv")
    ident, valid = data[:1000], data[1000:]

    # kinecal: the median of 5 runs.
    times = []
    for _ in range(5):
        t = time.perf_counter()
        res = kinecal.identify(robot, ident.q, ident.xyz, validate=(valid.q, valid.xyz))
        times.append(time.perf_counter() - t)
    k_time = float(np.median(times))
    k_rms = res.after["validation_rms_mm"]
    free_names = [n for n in res.json["changes"] if n not in res.unidentifiable]
    free = np.array([index_of(n) for n in free_names])

    q_i, q_v = np.radians(ident.q), np.radians(valid.q)
    x0 = nominal_vector(robot, q_i, ident.xyz)
    print(f"UR10, {len(ident)} poses identify, {len(valid)} held out; {len(free)} parameters "
          f"(kinecal's estimated set); {platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()}")
    print(f"nominal held-out RMS (base by Kabsch): {rms(fk_all(x0, q_v) - valid.xyz):.4f} mm")
    rows = [("kinecal.identify (LM)", k_time, k_rms, res.json["evaluations"])]
    for vectorised in ([True] if quick else [False, True]):
        x, s, nfev = scipy_calibrate(x0, free, q_i, ident.xyz, vectorised)
        label = ("scipy least_squares, numpy FK all poses at once" if vectorised
                 else "scipy least_squares, numpy FK per pose (pybotics-style)")
        rows.append((label, s, rms(fk_all(x, q_v) - valid.xyz), nfev))
    print()
    print("| method | time | held-out RMS (mm) | evaluations | slower than kinecal |")
    print("|---|---:|---:|---:|---:|")
    for label, s, r, n in rows:
        print(f"| {label} | {s:.3g} s | {r:.4f} | {n} | {s / k_time:,.0f}× |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
