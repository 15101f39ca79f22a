#!/usr/bin/env python3
"""Twist envelope of the paper's tube pairs (Lock & Dupont 2011, Figs. 11-12) with the `ctr` Python module.

The inner tube is rotated from 0 to 360 deg and back with the outer tube held (both at beta = -18 mm, straight parts
inside the actuation unit). Stick-slip friction at the outer tube's distal end (mu' = 0.12, docs/friction.md) makes
the twist depend on the direction of rotation: the increasing and decreasing branches enclose an envelope, largest
near 180 deg. The friction band (every equilibrium reachable under some history, computed directly at each angle) is
shaded: its edges are the two branches. The frictionless S-curve is drawn for comparison.

Usage: PYTHONPATH=build/python /usr/bin/python3 examples/python/twist_envelope.py [--out twist_envelope.png]
"""
import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import ctr  # noqa: E402

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
BETA = [-0.018, -0.018]


def envelope(robot, mu, step_deg):
    """Sweeps of one tube pair: frictionless, stick-slip up and back, and the friction band at each angle."""
    friction = robot.with_friction(boundary=mu)
    frictionless = robot.with_friction(boundary=0.0)
    step = math.radians(step_deg)
    sweep = ctr.sweep(friction, 2, 0.0, 2 * math.pi, step, both_directions=True, beta=BETA)
    free = ctr.sweep(frictionless, 2, 0.0, 2 * math.pi, step, beta=BETA)
    if not (sweep["converged"].all() and free["converged"].all()):
        raise SystemExit(f"{robot.name}: some steps did not converge")
    k = len(free["angle"])  # up = rows [0, k), back = rows [k-1, 2k-1) in reverse
    band = [ctr.friction_band(friction, [0.0, a], BETA, interior_samples=0) for a in free["angle"]]
    return {
        "angle": np.degrees(free["angle"]),
        "frictionless": np.degrees(free["twist"][:, 0]),
        "up": np.degrees(sweep["twist"][:k, 0]),
        "down": np.degrees(sweep["twist"][k - 1:, 0][::-1]),
        "band_min": np.degrees([b.twist_min[0] for b in band]),
        "band_max": np.degrees([b.twist_max[0] for b in band]),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="twist_envelope.png", help="PNG to write")
    ap.add_argument("--mu", type=float, default=0.12, help="lumped friction coefficient mu'")
    ap.add_argument("--step", type=float, default=5.0, help="rotation step of the sweeps (deg)")
    args = ap.parse_args()

    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharey=True, constrained_layout=True)
    for ax, (fig_no, name) in zip(axes, [(11, "tube_pair_A"), (12, "tube_pair_B")]):
        robot = ctr.load_robot(str(ROBOTS / f"{name}.yaml"))
        e = envelope(robot, args.mu, args.step)
        ax.fill_between(e["angle"], e["band_min"], e["band_max"], color="0.85", label="friction band (any history)")
        ax.plot(e["angle"], e["frictionless"], "k-", lw=1.5, label="frictionless")
        ax.plot(e["angle"], e["up"], "-", color="tab:red", lw=1.8, label="stick-slip, increasing")
        ax.plot(e["angle"], e["down"], "-", color="tab:blue", lw=1.8, label="stick-slip, decreasing")
        i180 = int(np.argmin(np.abs(e["angle"] - 180.0)))
        width = e["down"][i180] - e["up"][i180]
        print(f"{name}: envelope width at 180 deg = {width:.1f} deg (mu' = {args.mu:g})")
        ax.set_title(f"Fig. {fig_no} style: {name}, mu' = {args.mu:g} (width at 180 deg: {width:.0f} deg)")
        ax.set_xlabel("inner tube base angle alpha_2 (deg)")
        ax.set_xlim(0, 360)
        ax.set_xticks(range(0, 361, 60))
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("relative twist at the distal end of tube 1 (deg)")
    axes[1].legend(loc="upper left", fontsize=8)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
