#!/usr/bin/env python3
"""Resolved-rate teleoperation of a 3-tube robot with boundary friction, with the `ctr` Python module (docs/ik.md).

The tip follows a 10 mm circle at a 1 kHz servo rate (2 s per turn). Each period is one warm inverse-kinematics update
(a resolved-rate step dq = J^+ dx with the exact tip Jacobian). The robot is the stateful stick-slip model of the
Dupont-lab 3-tube robot with mu' = 0.1: the commands are replayed through it (ctr.simulate) and its tip is the
measurement. A friction-blind controller (frictionless inverse kinematics) leaves the tip lagging by millimetres; the
friction-aware one (ctr.ik_path: the stateful step inverted from the robot's hysteresis state) keeps it within 10 um.
Then the same loop with a 50 mN tip force: a force-blind controller, one aiming at p* - C F (C: the tip compliance of
ctr.tip_jacobian at the start), and one inverting the model under the force.

Usage: PYTHONPATH=build/python /usr/bin/python3 examples/python/teleoperation.py [--out teleoperation.png]
       [--points 2000]
"""
import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import ctr  # noqa: E402

ROBOT = Path(__file__).resolve().parents[1] / "robots" / "dupont_lab_3tube.yaml"
START = dict(alpha=[0.0, 0.5, -1.0], beta=[0.0, -0.017, -0.09])


def replay(robot, start_rows, alpha, beta, targets):
    """Tips of the commands stepped through the stateful model after the start rows, and their errors."""
    a0, b0 = start_rows
    sim = ctr.simulate(robot, np.vstack([a0, alpha]), np.vstack([b0, beta]))
    tips = sim["tip_position"][len(a0):]
    return tips, np.linalg.norm(tips - targets, axis=1)


def rms(e):
    return float(np.sqrt(np.mean(e ** 2)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="teleoperation.png", help="PNG to write")
    ap.add_argument("--points", type=int, default=2000, help="servo periods per turn (1 ms each)")
    args = ap.parse_args()

    free = ctr.load_robot(str(ROBOT))
    robot = free.with_friction(boundary=0.1)
    start_tip = ctr.solve(free, **START).tip_position
    angle = np.linspace(0.0, 2 * math.pi, args.points + 1)
    targets = start_tip + 0.005 * np.column_stack([np.cos(angle) - 1.0, np.sin(angle), np.zeros_like(angle)])
    time = 1e-3 * np.arange(len(targets))

    # The robot at rest on the first target (its frictionless inverse kinematics from START).
    first = ctr.ik(free, targets[0], **START)
    a0, b0 = first["alpha"], first["beta"]

    # Friction-blind vs friction-aware: ik_path follows both (the blind commands in rows['friction']).
    path = ctr.ik_path(robot, targets, alpha=a0, beta=b0)
    rows, start_rows = path["rows"], path["friction"]["start_commands"]
    aware_tips, aware_err = replay(robot, start_rows, rows["alpha"], rows["beta"], targets)
    blind_tips, blind_err = replay(robot, start_rows, rows["friction"]["blind_alpha"], rows["friction"]["blind_beta"],
                                   targets)
    print(f"circle: {len(targets)} targets, 10 mm diameter, mu' = 0.1")
    print(f"friction-blind commands: tip RMS {rms(blind_err) * 1e3:.4f} mm (max {blind_err.max() * 1e3:.4f} mm)")
    print(f"friction-aware commands: tip RMS {rms(aware_err) * 1e3:.4f} mm (max {aware_err.max() * 1e3:.4f} mm), "
          f"{path['reached_count']} of {path['targets']} reached; ratio {rms(blind_err) / rms(aware_err):.0f}x")

    # The same loop with a tip force.
    force = np.array([-0.05, 0.0, 0.0])
    pressed = robot.with_loads(tip_force=force)
    compliance = ctr.tip_jacobian(free, ctr.solve(free, a0, b0)).compliance[:3, :3]
    deflection = compliance @ force
    blind_f = ctr.ik_path(robot, targets, alpha=a0, beta=b0, compare_blind=False)
    shifted = ctr.ik_path(robot, targets - deflection, alpha=a0, beta=b0, compare_blind=False)
    loaded = ctr.ik_path(pressed, targets, alpha=a0, beta=b0, compare_blind=False)
    errors = {}
    for name, p in (("force-blind", blind_f), ("compliance C F", shifted), ("loaded model", loaded)):
        errors[name] = replay(pressed, p["friction"]["start_commands"], p["rows"]["alpha"], p["rows"]["beta"],
                              targets)[1]
    print(f"tip force {np.linalg.norm(force) * 1e3:.0f} mN: compliance C F = {np.linalg.norm(deflection) * 1e3:.3f} "
          f"mm at the start")
    print("  " + "; ".join(f"{k}: tip RMS {rms(e) * 1e3:.4f} mm" for k, e in errors.items()))

    fig, ax = plt.subplots(1, 3, figsize=(17, 5.2))
    ax[0].plot(targets[:, 0] * 1e3, targets[:, 1] * 1e3, "k--", lw=1, label="target")
    ax[0].plot(blind_tips[:, 0] * 1e3, blind_tips[:, 1] * 1e3, color="tab:red", label="friction-blind")
    ax[0].plot(aware_tips[:, 0] * 1e3, aware_tips[:, 1] * 1e3, color="tab:green", lw=1, label="friction-aware")
    ax[0].set(xlabel="x (mm)", ylabel="y (mm)", title="tip path (mu' = 0.1)", aspect="equal")
    ax[0].legend()
    ax[1].plot(time, blind_err * 1e3, color="tab:red", label=f"friction-blind (RMS {rms(blind_err) * 1e3:.2f} mm)")
    ax[1].plot(time, aware_err * 1e3, color="tab:green",
               label=f"friction-aware (RMS {rms(aware_err) * 1e3:.4f} mm)")
    ax[1].set(xlabel="time (s)", ylabel="tip error (mm)", title="tip error through the stick-slip model")
    ax[1].legend()
    colours = {"force-blind": "tab:red", "compliance C F": "tab:orange", "loaded model": "tab:green"}
    for name, e in errors.items():
        ax[2].semilogy(time, np.maximum(e, 1e-9) * 1e3, color=colours[name], label=f"{name} (RMS {rms(e) * 1e3:.4f} mm)")
    ax[2].set(xlabel="time (s)", ylabel="tip error (mm, log)",
              title=f"with a {np.linalg.norm(force) * 1e3:.0f} mN tip force (friction-aware)")
    ax[2].legend()
    fig.tight_layout()
    out = Path(args.out)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
