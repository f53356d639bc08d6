"""Shared fixtures: the repository, the `kinecal` binary built from this tree (the reference
every figure is compared with), the UR10 series and helpers to run the command line."""

from __future__ import annotations

import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _kinecal_bin() -> Path:
    env = os.environ.get("KINECAL_BIN")
    if env:
        return Path(env)
    for profile in ("release", "debug"):
        p = REPO / "target" / profile / "kinecal"
        if p.exists():
            return p
    pytest.exit(
        "no kinecal binary: build it (cargo build --release --bin kinecal) or set KINECAL_BIN",
        returncode=2,
    )


@pytest.fixture(scope="session")
def kinecal_bin() -> Path:
    return _kinecal_bin()


@pytest.fixture(scope="session")
def cli(kinecal_bin):
    """`cli(*args)` -> (exit status, JSON dict) of `kinecal --json args…`."""

    def run(*args, expect=None):
        p = subprocess.run(
            [str(kinecal_bin), "--json", *map(str, args)],
            capture_output=True,
            text=True,
            check=False,
        )
        out = json.loads(p.stdout) if p.stdout.strip() else {}
        if expect is not None:
            assert p.returncode == expect, (p.returncode, p.stderr)
        return p.returncode, out

    return run


def ur10_dir() -> Path:
    env = os.environ.get("KINECAL_UR10")
    return Path(env) if env else REPO / "data" / "ur10"


@pytest.fixture(scope="session")
def ur10() -> Path:
    d = ur10_dir()
    assert (d / "ur10_random_poses.csv").exists(), f"UR10 series not found at {d} (KINECAL_UR10)"
    return d


CELL = REPO / "examples" / "cell"

# Keys whose values differ between two runs or name files.
VOLATILE = {"seconds", "out", "plots", "robot", "data", "validate", "model", "targets", "scene", "truth"}


def assert_same(a, b, path="", tol=1e-9):
    """`a` (Python) equals `b` (command line) key by key: numbers to `tol` (relative above 1),
    integers, strings and booleans exactly; volatile keys (timings, paths) skipped."""
    if isinstance(b, dict):
        assert isinstance(a, dict), path
        assert set(a) == set(b), (path, set(a) ^ set(b))
        for k in b:
            if k in VOLATILE or "seconds" in k:
                continue
            assert_same(a[k], b[k], f"{path}.{k}", tol)
    elif isinstance(b, list):
        assert isinstance(a, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{i}]", tol)
    elif isinstance(b, bool) or isinstance(b, str) or b is None:
        assert a == b, (path, a, b)
    elif isinstance(b, int) and isinstance(a, int):
        assert a == b, (path, a, b)
    else:
        assert math.isclose(a, b, rel_tol=tol, abs_tol=tol), (path, a, b)


def mdh_fk(mdh: np.ndarray, tool: np.ndarray, q_deg: np.ndarray, base=None) -> np.ndarray:
    """Independent forward kinematics of docs/formats.md "Kinematic model" with 4×4 matrices in numpy:
    p = B · Π Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta + q)·Tz(d) · tool."""

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])

    def ry(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])

    def tr(x, y, z):
        m = np.eye(4)
        m[:3, 3] = (x, y, z)
        return m

    b = np.eye(4)
    if base is not None:
        (x, y, z), (r, p, w) = base
        b = tr(x, y, z) @ rz(np.radians(w)) @ ry(np.radians(p)) @ rx(np.radians(r))
    out = []
    for q in np.atleast_2d(q_deg):
        t = b.copy()
        for (al, a, th, d, be), qi in zip(mdh, q):
            t = t @ rx(np.radians(al)) @ tr(a, 0, 0) @ ry(np.radians(be)) @ rz(np.radians(th + qi)) @ tr(0, 0, d)
        out.append((t @ np.append(tool, 1.0))[:3])
    return np.array(out)
