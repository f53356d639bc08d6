#!/usr/bin/env python3
"""What the UR10 series leave after geometry and joint tables, and what explains it.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install numpy scipy
    /tmp/v/bin/python host-tests/scripts/ur10_residual_study.py

An independent numpy model (not kinecal's code): the nominal MDH chain of data/ur10/robot.toml,
its base found by a rigid fit and then base, the 24 MDH values and the tool point fitted by
scipy's Levenberg-Marquardt to every pose of a series (positions; some of the 33 values are
redundant, e.g. joint 1's row and the base, and the damping picks one of the equivalent fits:
only the residual is used). At that fit, linearised (the 33 values' columns refitted with
every term, so that a term cannot take over what the geometry explains): per-joint correction tables on joints 1-5 (knots
every 3.6 deg, ridge 1e-3 of the terms' mean diagonal), then each further term added to the
tables. Each is reported in-sample and held out (5-fold cross-validation over the poses, each
fold's poses predicted by the fit to the other four), 3-D RMS in mm:

- drift: the base translating in proportion to the row's place in the file (the rows' order
  as a clock: series B and D have no usable time, and series A's last rows are out of time
  order);
- backlash: each joint's angle error of +-b by the sign of its last move (row to row);
- gravity pose: joints 2-4's angle errors as sines and cosines (1st and 2nd order) of the
  links' angles against gravity, q2, q2+q3 and q2+q3+q4 (36 values; these assume joints 2-4
  parallel and horizontal, as the UR10's);
- compliance: joint 2's angle error in proportion to the moment of a downward load at the
  tool point (the catalogue's `joint-compliance`, which `diagnose` adds on series B and D; 1
  value);
- link gravity: joints 2-4's angle errors in proportion to the moments, about each of them, of
  downward loads at the origins of the joints beyond it and at the tool point (12 values: a
  compliance times point masses, the general form of `joint-compliance`, which loads the tool
  point only);
- wave generator: the best single sine of order 50-400 per turn on one joint (a harmonic
  drive's wave generator turns ~100 times per turn of the joint), against the geometry's
  residual (not after the tables; in-sample).

And the scatter of repeated poses (the joint readings rounded to the same multiples of
1e-4 rad).
"""
import collections
import csv
import os
import sys

import numpy as np
from scipy.optimize import least_squares

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data", "ur10")
# data/ur10/robot.toml: alpha, a, theta, d per joint; the tool point on the flange.
ALPHA = np.radians([0, 90, 0, 0, -90, 90])
A = np.array([0, 0, 612.7, 571.6, 0, 0.0])
THETA = np.radians([0, 180, 0, 0, 0, 180])
D = np.array([118, 0, 0, 163.9, 115.7, 92.2])
TOOL = np.array([0, 0, 109.0])
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint"]


def rpy(rx, ry, rz):
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    return (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
            @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))


def fk(x, q):
    """Tool points and the joint frames (axis, origin) of every pose; x = base (xyz mm, rpy
    rad), 24 MDH changes (alpha, a, theta, d per joint), tool point."""
    n = len(q)
    R = np.repeat(rpy(*x[3:6])[None], n, 0)
    p = np.repeat(x[:3][None], n, 0)
    frames = []
    for j in range(6):
        al, a = ALPHA[j] + x[6 + 4 * j], A[j] + x[7 + 4 * j]
        th, d = THETA[j] + x[8 + 4 * j] + q[:, j], D[j] + x[9 + 4 * j]
        p = p + R[:, :, 0] * a
        R = R @ np.array([[1, 0, 0], [0, np.cos(al), -np.sin(al)], [0, np.sin(al), np.cos(al)]])
        Rz = np.zeros((n, 3, 3))
        Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = (
            np.cos(th), -np.sin(th), np.sin(th), np.cos(th), 1)
        R = R @ Rz
        p = p + R[:, :, 2] * d
        frames.append((R[:, :, 2].copy(), p.copy()))
    return p + np.einsum("nij,j->ni", R, x[30:33]), frames


def rigid_base(model, measured):
    """Base (xyz, rpy) placing the model points on the measured ones (Kabsch)."""
    cm, cs = model.mean(0), measured.mean(0)
    U, _, Vt = np.linalg.svd((model - cm).T @ (measured - cs))
    S = np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ S @ U.T
    t = cs - R @ cm
    ry = np.arcsin(-R[2, 0])
    return np.r_[t, np.arctan2(R[2, 1], R[2, 2]), ry, np.arctan2(R[1, 0], R[0, 0])]


def load(series):
    if series == "C":
        rows = list(csv.reader(open(os.path.join(ROOT, "ur10_random_poses.csv"))))
        v = np.array([[float(c) for c in r[:9]] for r in rows[1:] if r])
        return np.radians(v[:, :6]), v[:, 6:9]
    name = {"A": "series_a/measurements_grid.csv",
            "B": "series_b/measurements_joint_configurations.csv",
            "D": "series_d/measurements_iso_cubes.csv"}[series]
    rows = list(csv.reader(open(os.path.join(ROOT, "published", name), newline=""), delimiter=";"))
    h = rows[0]
    v = np.array([[float(c.replace(",", ".")) for c in r] for r in rows[1:] if r])
    q = v[:, [h.index(c) for c in JOINTS]]
    p = v[:, [h.index(c) for c in ["measurement_x", "measurement_y", "measurement_z"]]]
    # Rows repeating an earlier row's point exactly while a joint turned 1 deg or more (the
    # rule of docs/formats.md, "Stale readings", that series B's two rows meet).
    first, keep = {}, []
    for i, row in enumerate(p):
        k = tuple(row)
        if k in first and np.abs(q[i] - q[first[k]]).max() > np.radians(1):
            continue
        first.setdefault(k, i)
        keep.append(i)
    return q[keep], p[keep]


def rms(v):
    return float(np.sqrt((v.reshape(-1, 3) ** 2).sum(1).mean()))


def residual_after(M, y, ridge=1e-3, geometric=0):
    """y less its fit by the columns of M; the ridge (relative to their mean diagonal) on the
    columns after the first `geometric`."""
    A_ = M.T @ M
    d = np.r_[np.zeros(geometric), np.ones(len(A_) - geometric)]
    w = ridge * np.mean(np.diag(A_)[geometric:]) if len(A_) > geometric else 0.0
    return y - M @ np.linalg.solve(A_ + w * np.diag(d) + 1e-12 * np.eye(len(A_)), M.T @ y)


def held_out(M, y, geometric, folds=5, seed=1):
    """3-D RMS of each pose's residual predicted by the fit to the other folds' poses."""
    n = len(y) // 3
    parts = np.array_split(np.random.default_rng(seed).permutation(n), folds)
    se = 0.0
    for test in parts:
        train = np.setdiff1d(np.arange(n), test)
        rows = lambda ii: (3 * ii[:, None] + np.arange(3)).ravel()
        A_, b = M[rows(train)], y[rows(train)]
        AtA = A_.T @ A_
        d = np.r_[np.zeros(geometric), np.ones(len(AtA) - geometric)]
        w = 1e-3 * np.mean(np.diag(AtA)[geometric:]) if len(AtA) > geometric else 0.0
        coef = np.linalg.solve(AtA + w * np.diag(d) + 1e-12 * np.eye(len(AtA)), A_.T @ b)
        se += ((y[rows(test)] - M[rows(test)] @ coef) ** 2).sum()
    return float(np.sqrt(se / n))


def study(series):
    q, p = load(series)
    n = len(q)
    x = np.zeros(33)
    x[30:33] = TOOL
    x[:6] = rigid_base(fk(x, q)[0], p)
    scale = np.r_[[1000] * 3, [1] * 3, np.tile([1e-3, 1, 1e-3, 1], 6), [1] * 3]
    x = least_squares(lambda x: (fk(x, q)[0] - p).ravel(), x, method="lm", x_scale=scale).x
    tip, frames = fk(x, q)
    r = (p - tip).ravel()
    # The 33 values' columns (central differences in the scaled values), as an orthonormal
    # basis of what they can change: the redundant directions (joint 1's row and the base, ...)
    # dropped, so that no fold's fit is singular.
    Jg = np.stack([((fk(x + h, q)[0] - fk(x - h, q)[0]) / (2e-6)).ravel()
                   for h in np.eye(33) * scale * 1e-6], 1)
    U, sv, _ = np.linalg.svd(Jg, full_matrices=False)
    Jg = U[:, sv > 1e-9 * sv[0]]
    ng = Jg.shape[1]

    def both(F):  # in-sample and held-out RMS with the geometry refitted beside F
        M = np.hstack([Jg, F]) if F is not None else Jg
        return rms(residual_after(M, r, geometric=ng)), held_out(M, r, ng)
    G = np.stack([np.cross(z, tip - o) for z, o in frames], 1)  # n x joint x 3: dp/dq_j

    def along(j, w):  # joint j's angle error w (n x k) as columns of the 3n rows
        return (G[:, j, :][:, None, :] * w[:, :, None]).transpose(0, 2, 1).reshape(3 * n, -1)

    def hats(j, pitch=np.radians(3.6)):
        u = (q[:, j] - q[:, j].min()) / pitch
        k = np.floor(u).astype(int)
        H = np.zeros((n, k.max() + 2))
        H[np.arange(n), k] = 1 - (u - k)
        H[np.arange(n), k + 1] = u - k
        return H

    T = np.hstack([along(j, hats(j)) for j in range(5)])
    g_in, g_out = both(None)
    t_in, t_out = both(T)
    print(f"series {series}: {n} poses (in-sample / held out, mm); geometry {g_in:.4f} / "
          f"{g_out:.4f}, + tables on joints 1-5 {t_in:.4f} / {t_out:.4f} ({t_out / g_out:.3f}x)")
    print(f"  the geometric fit's largest residual: {np.abs(r.reshape(-1, 3)).max(0).max():.2f} "
          f"mm on one axis, {np.linalg.norm(r.reshape(-1, 3), axis=1).max():.2f} mm 3-D")
    clock = np.arange(n) / n
    drift = np.tile(np.eye(3), (n, 1)) * np.repeat(clock, 3)[:, None]
    moved = np.sign(np.vstack([np.zeros(6), np.diff(q, axis=0)]))
    backlash = np.hstack([along(j, moved[:, j:j + 1]) for j in range(5)])
    links = [q[:, 1], q[:, 1] + q[:, 2], q[:, 1] + q[:, 2] + q[:, 3]]
    gravity = np.hstack([along(j, np.stack([f(k * phi) for phi in links for k in (1, 2)
                                            for f in (np.sin, np.cos)], 1)) for j in (1, 2, 3)])
    # Downward loads (the base frame's -z, tilted by the fitted base) at the origins of the
    # joints beyond j and at the tool point, their moments about axis j in m.
    down = -rpy(*x[3:6])[:, 2]
    link = np.hstack([along(j, np.stack([np.cross(frames[j][0], o - frames[j][1]) @ down / 1000
                                         for o in [f[1] for f in frames[j + 1:]] + [tip]], 1))
                      for j in (1, 2, 3)])
    compliance = link[:, [4]]  # joint 2, the tool point's moment only: `joint-compliance`
    for name, F in [("drift", drift), ("backlash", backlash), ("gravity pose", gravity),
                    ("compliance, joint 2", compliance), ("link gravity", link)]:
        f_in, f_out = both(np.hstack([T, F]))
        print(f"  + {name} ({F.shape[1]} values): {f_in:.4f} / {f_out:.4f} mm "
              f"({f_out / g_out:.3f}x)")
    for j in range(6):
        best = max((1 - rms(residual_after(along(j, np.stack([np.sin(m * q[:, j]),
                                                              np.cos(m * q[:, j])], 1)), r)) ** 2
                    / rms(r) ** 2, m) for m in range(50, 401))
        print(f"  wave generator, joint {j + 1}: order {best[1]} explains {100 * best[0]:.1f} % "
              f"of the geometry's squared error")
    groups = collections.defaultdict(list)
    for i, row in enumerate(np.round(q / 1e-4).astype(int)):
        groups[tuple(row)].append(i)
    rep = [g for g in groups.values() if len(g) > 1]
    if rep:
        ss = sum(((p[g] - p[g].mean(0)) ** 2).sum() for g in rep)
        dof = sum(len(g) - 1 for g in rep)
        print(f"  repeated poses: {sum(map(len, rep))} rows in {len(rep)} groups scatter by "
              f"{np.sqrt(ss / dof):.4f} mm (3-D RMS)")


if __name__ == "__main__":
    for s in sys.argv[1:] or ["A", "B", "C", "D"]:
        study(s)
