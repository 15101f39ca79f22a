#!/usr/bin/env python3
"""Plan a query with the `ctr` Python module, then plot the replayed tip path in the anatomy and its clearance.

The planner validates states with the friction-aware model and replays the path through the stateful friction model
before calling it solved (docs/planning.md). Left: the anatomy's occupied voxels near the path, the tip path coloured
by clearance, the target and the robot's final shape. Right: clearance of the robot along the replayed path.

Usage: PYTHONPATH=build/python /usr/bin/python3 examples/python/plan_and_plot.py \
           [examples/queries/proc_intracardiac.yaml] [--out plan.png] [--time 20] [--planner rrt]
"""
import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import ctr  # noqa: E402

QUERY = Path(__file__).resolve().parents[1] / "queries" / "proc_intracardiac.yaml"


def to_world(pose, points):
    return points @ pose[:3, :3].T + pose[:3, 3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("query", nargs="?", default=str(QUERY), help="query YAML (docs/planning.md)")
    ap.add_argument("--out", default="plan.png", help="PNG to write")
    ap.add_argument("--time", type=float, help="time limit (s); default: the query's")
    ap.add_argument("--planner", help="planner; default: the query's")
    args = ap.parse_args()

    query = ctr.load_query(args.query)
    if args.time:
        query.time_limit = args.time
    if args.planner:
        query.planner = args.planner
    planner = ctr.CtrPlanner(query)
    print(f"planning '{query.name}' ({query.mode}, {query.planner}, {query.time_limit:g} s)...")
    result = planner.solve()
    print(json.dumps(result.to_dict(), indent=2))
    replay = result.replay
    if len(replay) == 0:
        raise SystemExit(f"no path to plot: {result.message}")

    env = planner.environment
    pose = env.base_pose
    tips = replay.tip_positions()  # world frame (m)
    clearance = replay.clearance
    # The robot's final shape: a zero-length step from the last replayed state, with the backbone recorded.
    options = ctr.FrictionOptions(kinematics=ctr.KinematicsOptions(record_backbone=True))
    final = ctr.step(planner.robot, replay.states[-1], options=options).solution
    shape = to_world(pose, final.backbone["position"])
    # Anatomy: the occupied voxels within 8 mm of the tip path or the final shape (subsampled for the plot).
    pts = np.vstack([tips, shape])
    centres, _ = env.occupied_voxels(pts.min(axis=0) - 0.008, pts.max(axis=0) + 0.008)
    near = pts[:: max(1, len(pts) // 400)]
    dist = np.min(np.linalg.norm(centres[:, None, :] - near[None, :, :], axis=2), axis=1)
    centres = centres[dist < 0.008]
    rng = np.random.default_rng(0)
    if len(centres) > 5000:
        centres = centres[rng.choice(len(centres), 5000, replace=False)]

    fig = plt.figure(figsize=(13, 5.5), constrained_layout=True)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    mm = 1e3
    ax.scatter(*(centres.T * mm), s=2, c="0.55", alpha=0.12, depthshade=False,
               label="anatomy within 8 mm (occupied voxels)")
    path = ax.scatter(*(tips.T * mm), c=clearance * mm, cmap="viridis", s=6, label="tip path (replayed)")
    ax.plot(*(shape.T * mm), "-", color="tab:red", lw=2.5, label="final shape")
    ax.scatter(*(tips[0] * mm), color="k", marker="o", s=40, label="start tip")
    goal_spec = planner.query.tip_goal  # as planned: a named target resolved in the environment
    if goal_spec is not None:
        goal = goal_spec["position"]
        ax.scatter(*(goal * mm), color="tab:orange", marker="*", s=160, label=f"target ({query.target_name or 'goal'})")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    lo, hi = pts.min(axis=0) * mm - 8, pts.max(axis=0) * mm + 8
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_title(f"{query.name}: {'solved' if result.solved else 'NOT solved'} ({result.planner}, "
                 f"{result.planning_time:.2f} s)")
    ax.legend(loc="upper left", fontsize=7)
    ax.set_box_aspect((1, 1, 1))
    fig.colorbar(path, ax=ax, shrink=0.6, pad=0.12, label="tip path: clearance (mm)")

    ax2 = fig.add_subplot(1, 2, 2)
    step = np.arange(len(clearance))
    ax2.plot(step, clearance * mm, color="tab:green", lw=1.5, label="clearance")
    k = int(np.argmin(clearance))
    ax2.plot(step[k], clearance[k] * mm, "v", color="tab:red", label=f"minimum {clearance[k] * mm:.3f} mm")
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("replay step")
    ax2.set_ylabel("clearance to the anatomy (mm)")
    ax2.set_title(f"replay: {replay.steps} steps, tip error {replay.tip_error * mm:.2f} mm, "
                  f"{'collision-free' if replay.collision_free else 'COLLIDES'}")
    ax2.grid(True, alpha=0.3)
    ax2.legend()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0 if result.solved else 1


if __name__ == "__main__":
    raise SystemExit(main())
