#!/usr/bin/env python3
"""Calibrate the UR10 from real laser-tracker data with kinecal, in a script or a notebook.

    python python/examples/calibrate_ur10.py [DATA_DIR]

DATA_DIR holds robot.toml and ur10_random_poses.csv (default: data/ur10 of the
repository). The first 1,000 poses identify the model, the other 1,773 validate it; then
`diagnose` looks for what the geometric model misses. With matplotlib installed the residuals
are plotted (ur10_residuals.png in the current folder); without it the plots are skipped.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import kinecal


def data_dir() -> Path:
    if len(sys.argv) > 1:
        return Path(sys.argv[1])
    return Path(__file__).resolve().parents[2] / "data" / "ur10"


def main() -> int:
    d = data_dir()
    robot = kinecal.Robot.from_file(d / "robot.toml")
    data = kinecal.read_csv(d / "ur10_random_poses.csv")
    ident, valid = data[:1000], data[1000:]
    print(f"{robot.name}: {robot.joints} joints; {len(data)} poses "
          f"({len(ident)} to identify, {len(valid)} held out)")

    t = time.perf_counter()
    result = kinecal.identify(robot, ident.q, ident.xyz, validate=(valid.q, valid.xyz))
    seconds = time.perf_counter() - t
    b, a = result.before, result.after
    print(f"identify (LM) in {seconds * 1000:.0f} ms, converged: {result.converged}")
    print(f"  held-out RMS  {b['validation_rms_mm']:.3f} mm -> {a['validation_rms_mm']:.3f} mm "
          f"(max {a['validation_max_mm']:.3f} mm)")
    print(f"  unidentifiable (held at file values): {', '.join(result.unidentifiable)}")
    base = result.robot.base
    print(f"  base found at {np.round(base[0], 1)} mm, rpy {np.round(base[1], 3)} deg")

    # Residuals of the calibrated model on the held-out poses.
    residual = valid.xyz - result.robot.fk(valid.q)
    errors = np.linalg.norm(residual, axis=1)
    print(f"  held-out errors from fk: RMS {np.sqrt(np.mean(errors ** 2)):.3f} mm, "
          f"95 % below {np.percentile(errors, 95):.3f} mm")

    # diagnose keeps the last 1,773 poses out of the whole search. Its headline figures
    # (baseline/final_validation_rms_mm, each finding's validation_rms_mm) are cross-validated
    # over the 1,000 searched poses; the held-out poses' own figures are in diag.holdout.
    t = time.perf_counter()
    diag = kinecal.diagnose(robot, data.q, data.xyz, holdout=1773)
    print(f"diagnose in {time.perf_counter() - t:.1f} s")
    b, f = diag.cross_validated_rms_mm
    print(f"  cross-validated RMS (searched poses) {b:.3f} mm -> {f:.3f} mm")
    h = diag.holdout
    print(f"  held-out RMS ({h['poses']} poses, not searched) {h['geometric_rms_mm']:.3f} mm "
          f"-> {h['final_rms_mm']:.3f} mm")
    capped = " (lowered to the held-out final RMS)" if h["noise_floor_capped"] else ""
    print(f"  noise floor {diag.noise_floor_mm:.3f} mm{capped}")
    for found in diag.found:
        print(f"  found {found['effect']} on joint {found['joint']}: cross-validated "
              f"{found['validation_rms_mm']:.3f} mm")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plots")
        return 0
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for j, ax in zip((0, 1, 2), axes):
        ax.scatter(valid.q[:, j], errors, s=3)
        ax.set_xlabel(f"q{j + 1} (deg)")
        ax.set_ylabel("held-out error (mm)")
    fig.suptitle(f"UR10 after identification: held-out RMS {a['validation_rms_mm']:.3f} mm")
    fig.tight_layout()
    fig.savefig("ur10_residuals.png", dpi=110)
    print("plotted ur10_residuals.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
