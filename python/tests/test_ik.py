"""Inverse kinematics: ctr.ik / ctr.ik_path against `ctr ik`, answers checked by forward kinematics (ctr.solve) and
the friction-aware commands by the stateful model (ctr.step / ctr.simulate)."""
import math

import numpy as np
import pytest

import ctr
from conftest import EXAMPLES, assert_same, cli_error, load_json

DUPONT = EXAMPLES / "robots" / "dupont_lab_3tube.yaml"
START = dict(alpha=[0.0, 0.5, -1.0], beta=[0.0, -0.017, -0.09])


def arg(v):
    return ",".join(repr(float(x)) for x in v)


def circle(centre_tip, points, radius=0.005):
    a = np.linspace(0.0, 2 * math.pi, points)
    return centre_tip + radius * np.column_stack([np.cos(a) - 1.0, np.sin(a), np.zeros_like(a)])


def test_ik_equals_cli_and_checks_out_by_forward_kinematics(cli):
    robot = ctr.load_robot(str(DUPONT))
    target = ctr.solve(robot, alpha=[0.3, 0.9, -1.2], beta=[-0.01, -0.02, -0.1]).tip_position
    d = ctr.ik(robot, target)
    assert d["reached"] and d["tip_error"] <= 1e-5
    assert isinstance(d["alpha"], np.ndarray) and d["alpha"].shape == (3,)
    s = ctr.solve(robot, alpha=d["alpha"], beta=d["beta"])
    assert np.linalg.norm(s.tip_position - target) <= 1e-5 + 1e-9
    assert np.allclose(d["closest"], s.tip_position, atol=1e-9)
    expected = load_json(cli("ik", "--robot", DUPONT, "--target", arg(target), "--json", "-").stdout)
    got = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items() if k != "solution"}
    assert_same(got, expected, rel=1e-9, abs_=1e-12)


def test_ik_warm_start_and_direction():
    robot = ctr.load_robot(str(DUPONT))
    s = ctr.solve(robot, alpha=[0.2, 0.6, -0.8], beta=[-0.002, -0.019, -0.095])
    d = ctr.ik(robot, s.tip_position, direction=s.tip_tangent, direction_weight=0.02, **START)
    assert d["reached"] and d["direction_error"] <= 0.01
    check = ctr.solve(robot, alpha=d["alpha"], beta=d["beta"])
    assert math.acos(min(1.0, float(check.tip_tangent @ s.tip_tangent))) <= 0.01 + 1e-6


def test_unreachable_target_gives_the_closest_point(cli):
    robot = ctr.load_robot(str(DUPONT))
    d = ctr.ik(robot, [0.0, 0.0, 1.0], options=ctr.IkOptions(restarts=2))
    assert not d["reached"] and d["status"] == "not reached" and d["tip_error"] > 0.5
    assert "not reached" in d["message"]
    p = cli("ik", "--robot", DUPONT, "--target", "0,0,1", "--restarts", "2", "--json", "-", check=False)
    assert p.returncode == 1
    assert load_json(p.stdout)["tip_error"] == pytest.approx(d["tip_error"], rel=1e-12)
    assert "not reached" in cli_error(p)


def test_friction_aware_command_checked_by_the_stateful_step(cli):
    robot = ctr.load_robot(str(DUPONT)).with_friction(boundary=0.1)
    target = ctr.solve(robot, alpha=[0.1, 0.3, -0.7], beta=START["beta"]).tip_position
    d = ctr.ik(robot, target, history="positive", **START)
    assert d["reached"]
    f = d["friction"]
    assert f["blind_tip_error"] > 5e-5 and f["alpha_difference"] > 1e-3
    # Replay: the rows that make the start state, then the command, through the stateful model (the command is one
    # large move, executed straight: the path is known).
    a0, b0 = f["start_commands"]
    sim = ctr.simulate(robot, np.vstack([a0, d["alpha"]]), np.vstack([b0, d["beta"]]), branch="path")
    assert np.linalg.norm(sim["tip_position"][-1] - target) <= 1e-5 + 1e-9
    # The same from the state object: ctr.step of the command from the start state.
    start = ctr.simulate(robot, a0, b0, keep_states=True)["states"][-1]  # at rest at the first row, then the approach
    r = ctr.step(robot, start, d["alpha"], d["beta"])
    assert np.linalg.norm(r.solution.tip_position - target) <= 1e-5 + 1e-9
    assert ctr.ik(robot, target, state=start)["alpha"] == pytest.approx(d["alpha"], abs=1e-12)
    expected = load_json(cli("ik", "--robot", DUPONT, "--boundary-friction", "0.1", "--history", "positive",
                             "--from-alpha", arg(START["alpha"]), "--from-beta", arg(START["beta"]), "--target",
                             arg(target), "--json", "-").stdout)
    got = {k: v for k, v in d.items() if k not in ("solution", "state")}
    got["friction"] = {k: v for k, v in got["friction"].items() if k != "start_commands"}
    got = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in got.items()}
    got["friction"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in got["friction"].items()}
    assert_same(got, expected, rel=1e-9, abs_=1e-12)


def test_ik_path_circle_with_friction(cli, tmp_path):
    robot = ctr.load_robot(str(DUPONT)).with_friction(boundary=0.1)
    tip = ctr.solve(robot, **START).tip_position
    targets = circle(tip, 60)
    p = ctr.ik_path(robot, targets, **START)
    rows = p["rows"]
    assert p["reached"] and p["reached_count"] == 60 and rows["alpha"].shape == (60, 3)
    assert rows["tip_error"].shape == (60,) and rows["closest"].shape == (60, 3)
    blind = rows["friction"]["blind_tip_error"]
    assert math.sqrt(np.mean(blind ** 2)) > 5 * p["tip_error_rms"]
    # The commands replayed through the stateful model (ctr.simulate from the start rows).
    a0, b0 = p["friction"]["start_commands"]
    sim = ctr.simulate(robot, np.vstack([a0, rows["alpha"]]), np.vstack([b0, rows["beta"]]))
    err = np.linalg.norm(sim["tip_position"][len(a0):] - targets, axis=1)
    assert err.max() <= 1e-5 + 1e-9
    # The same as `ctr ik --targets`.
    csv = tmp_path / "t.csv"
    csv.write_text("tip_x,tip_y,tip_z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in targets))
    expected = load_json(cli("ik", "--robot", DUPONT, "--boundary-friction", "0.1", "--from-alpha",
                             arg(START["alpha"]), "--from-beta", arg(START["beta"]), "--targets", csv, "--json",
                             "-").stdout)
    assert p["tip_error_rms"] == pytest.approx(expected["tip_error_rms"], rel=1e-9)
    assert np.allclose(rows["alpha"], [r["alpha"] for r in expected["rows"]], rtol=0, atol=1e-12)
    assert np.allclose(blind, [r["friction"]["blind_tip_error"] for r in expected["rows"]], rtol=1e-9, atol=1e-15)


def test_frictionless_path_and_bad_input():
    robot = ctr.load_robot(str(DUPONT))
    tip = ctr.solve(robot, **START).tip_position
    p = ctr.ik_path(robot, circle(tip, 40), **START)
    assert p["reached"] and "friction" not in p and "state" not in p
    steps = np.abs(np.diff(p["rows"]["alpha"], axis=0)).max()
    assert steps < 0.05  # a servo loop: no jumps
    with pytest.raises(ValueError, match="target"):
        ctr.ik(robot, [0.0, 0.1])
    with pytest.raises(ValueError, match="history"):
        ctr.ik(robot.with_friction(boundary=0.1), tip, history="sideways")
    with pytest.raises(ValueError, match="directions"):
        ctr.ik_path(robot, circle(tip, 5), directions=np.zeros((4, 3)))
    assert repr(ctr.IkOptions(tolerance=2e-5)).startswith("IkOptions(tolerance=2e-05")
