#!/usr/bin/env python3
"""Independent LM identification with scipy (MINPACK), for comparison with `kinecal identify`.

Usage: scipy_lm.py ROBOT.toml IDENT.csv VALID.csv
Fits alpha, a, theta, d of every joint and the tool point (base from the robot file, identity
when absent) from the nominal model, written plainly from docs/formats.md "Kinematic model" with 4x4 matrices.
Prints one JSON line: validation RMS (mm), seconds, function evaluations.
"""
import csv, json, sys, time, tomllib
import numpy as np
from scipy.optimize import least_squares


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def tr(x, y, z):
    m = np.eye(4)
    m[:3, 3] = [x, y, z]
    return m


def base_matrix(robot):
    b = robot.get("base")
    if not b:
        return np.eye(4)
    r, p, y = np.radians(b["rpy_deg"])
    return tr(*b["xyz_mm"]) @ rz(y) @ ry(p) @ rx(r)


def fk(params, betas, base, q):
    n = len(betas)
    t = base.copy()
    for i in range(n):
        al, a, th, d = params[4 * i: 4 * i + 4]
        t = t @ rx(al) @ tr(a, 0, 0) @ ry(betas[i]) @ rz(th + q[i]) @ tr(0, 0, d)
    tool = params[4 * n: 4 * n + 3]
    return (t @ np.array([*tool, 1.0]))[:3]


def load(path, n):
    rows = [r for r in csv.DictReader(l for l in open(path) if l.strip() and not l.startswith("#"))]
    q = np.radians([[float(r[f"q{i+1}"]) for i in range(n)] for r in rows])
    p = np.array([[float(r[k]) for k in "xyz"] for r in rows])
    return q, p


def main():
    robot = tomllib.load(open(sys.argv[1], "rb"))
    joints = robot["joints"]
    n = len(joints)
    x0 = []
    for j in joints:
        x0 += [np.radians(j["alpha_deg"]), j["a_mm"], np.radians(j["theta_deg"]), j["d_mm"]]
    x0 += list(robot["tool"]["xyz_mm"])
    x0 = np.array(x0)
    betas = [np.radians(j.get("beta_deg", 0.0)) for j in joints]
    base = base_matrix(robot)
    qi, pi = load(sys.argv[2], n)
    qv, pv = load(sys.argv[3], n)
    scale = np.array([1000.0 if (k < 4 * n and k % 2 == 0) else 1.0 for k in range(len(x0))])

    def res(u, q, p):
        x = x0 + u / scale
        return np.concatenate([fk(x, betas, base, qq) - pp for qq, pp in zip(q, p)])

    t0 = time.perf_counter()
    sol = least_squares(res, np.zeros_like(x0), args=(qi, pi), method="lm", x_scale=1.0)
    dt = time.perf_counter() - t0
    r = res(sol.x, qv, pv).reshape(-1, 3)
    rms = float(np.sqrt(np.mean(np.sum(r * r, axis=1))))
    print(json.dumps({"validation_rms_mm": rms, "seconds": dt, "nfev": int(sol.nfev)}))


if __name__ == "__main__":
    main()
