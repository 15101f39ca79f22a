"""Robot, solve, backbone and frictionless sweeps: the module against the `ctr fk` command."""
import copy
import csv
import io
import math
import pickle

import numpy as np
import pytest

import ctr
from conftest import EXAMPLES, assert_same, load_json

PAIR_B = EXAMPLES / "robots" / "tube_pair_B.yaml"
THREE = EXAMPLES / "robots" / "three_tube_generic.yaml"


def test_robot_from_yaml_and_dict_round_trip():
    r = ctr.load_robot(PAIR_B)  # str or os.PathLike
    assert r.name == "tube_pair_B" and r.size == 2 and len(r) == 2
    d = r.to_dict()
    assert d["tubes"][0]["curvature"] == pytest.approx(1 / 0.154, rel=1e-9)
    r2 = ctr.Robot(d)
    assert r2.to_yaml() == r.to_yaml()
    assert ctr.robot_from_dict(d).to_dict() == d
    # numpy values are accepted in dicts
    d["tubes"][1]["bending_stiffness"] = np.float64(0.05)
    d["tubes"][1]["rotation_limits"] = np.array([-3.0, 3.0])
    r3 = ctr.Robot(d)
    assert r3.tubes[1]["bending_stiffness"] == 0.05
    assert list(r3.tubes[1]["rotation_limits"]) == [-3.0, 3.0]
    assert pickle.loads(pickle.dumps(r)).to_yaml() == r.to_yaml()
    f = r.with_friction(boundary=0.12)
    assert f.friction == {"boundary": 0.12, "distributed": 0.0}
    assert r.friction["boundary"] == 0.0


@pytest.mark.parametrize(
    "robot,alpha,beta,cli_alpha,cli_beta",
    [
        (PAIR_B, [0.0, math.pi / 2], [-0.018, -0.018], "0,90deg", "-0.018,-0.018"),
        (PAIR_B, [0.3, 2.5], [-0.03, -0.03], "0.3,2.5", "-0.03,-0.03"),
        (THREE, None, None, None, None),
        (THREE, [0.2, 1.0, -0.5], None, "0.2,1.0,-0.5", None),
    ],
)
def test_solve_equals_cli_fk(cli, robot, alpha, beta, cli_alpha, cli_beta):
    args = ["fk", "--robot", robot, "--json"]
    if cli_alpha:
        args += ["--alpha", cli_alpha]
    if cli_beta:
        args += ["--beta", cli_beta]
    expected = load_json(cli(*args).stdout)
    r = ctr.load_robot(str(robot))
    s = ctr.solve(r, alpha, beta)
    assert s.converged and s.status == "converged"
    assert_same(s.to_dict(), expected)
    # the arrays are the same numbers
    assert np.array_equal(s.tip_position, np.array(expected["tip_position"]))
    assert np.array_equal(s.twist, np.array(expected["twist"]))
    assert s.tip_pose.shape == (4, 4) and np.allclose(s.tip_pose[:3, 2], s.tip_tangent)


def test_backbone_equals_cli_shape(cli, tmp_path):
    out = tmp_path / "shape.csv"
    cli("fk", "--robot", PAIR_B, "--alpha", "0,120deg", "--beta", "-0.03,-0.03", "--shape", out,
        "--shape-step", "0.002")
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    expected = np.array([[float(r[k]) for k in ("s", "x", "y", "z")] for r in rows])
    s = ctr.solve(ctr.load_robot(str(PAIR_B)), [0, math.radians(120)], [-0.03, -0.03])
    b = s.resample(0.002)
    assert b["position"].shape == (len(rows), 3)
    assert np.allclose(b["s"], expected[:, 0], rtol=0, atol=1e-15)
    assert np.allclose(b["position"], expected[:, 1:], rtol=0, atol=1e-15)
    nodes = s.backbone
    n = len(nodes["s"])
    assert nodes["frame"].shape == (n, 3, 3) and nodes["theta"].shape == (n, 2) and nodes["u0"].shape == (n, 2)
    assert np.allclose(nodes["position"][-1], s.tip_position)
    assert nodes["s"][-1] == pytest.approx(s.tip_arc_length)


def test_solve_sweep_and_options():
    r = ctr.load_robot(str(PAIR_B))
    angles = np.radians(np.arange(0, 181, 30))
    alpha = np.column_stack([np.zeros_like(angles), angles])
    sw = ctr.solve_sweep(r, alpha, [-0.018, -0.018])
    assert sw["twist"].shape == (len(angles), 1) and sw["tip_position"].shape == (len(angles), 3)
    assert sw["converged"].all()
    for k, a in enumerate(angles):
        s = ctr.solve(r, [0, a], [-0.018, -0.018])
        assert np.allclose(sw["tip_position"][k], s.tip_position, atol=1e-9)
    o = ctr.KinematicsOptions(record_backbone=False, max_step=0.005)
    assert o.max_step == 0.005 and "max_step=0.005" in repr(o)
    s = ctr.solve(r, [0, 1.0], [-0.018, -0.018], options=o)
    assert s.backbone["s"].size == 0
    with pytest.raises(TypeError, match="unknown field 'max_stepp'"):
        ctr.KinematicsOptions(max_stepp=1)
    # One set of step sizes for every follower: FollowOptions, the `follow` of the kinematics and friction options.
    assert ctr.KinematicsOptions().follow.max_rotation_step == pytest.approx(0.035)
    assert ctr.FrictionOptions().follow.max_rotation_step == pytest.approx(0.0175)
    assert not ctr.FrictionOptions().follow.judge_stability
    fine = ctr.KinematicsOptions(follow=ctr.FollowOptions(max_rotation_step=0.01, snap_threshold=0.4))
    assert fine.follow.max_rotation_step == 0.01 and "snap_threshold=0.4" in repr(fine)
    s2 = ctr.solve(r, [0, 1.0], [-0.018, -0.018], warm=s)
    assert np.allclose(s2.tip_position, s.tip_position, atol=1e-9)
    assert copy.deepcopy(s2).twist[0] == s2.twist[0]


def test_default_configuration_and_admissibility():
    r = ctr.load_robot(str(THREE))
    alpha, beta = ctr.default_configuration(r)
    assert np.all(alpha == 0) and beta.shape == (3,)
    ok, msg = ctr.check_admissible(r, alpha, beta)
    assert ok and msg == ""
    ok, msg = ctr.check_admissible(r, alpha, [0.01, 0, 0])
    assert not ok and "beta" in msg
    a, b = ctr.sample_configurations(r, 5, seed=3)
    assert a.shape == (5, 3) and all(ctr.check_admissible(r, a[k], b[k])[0] for k in range(5))
    sites = ctr.contact_sites(r)
    assert sites and {"kind", "tube", "outer", "inner", "s"} <= set(sites[0])


def test_loads_equal_cli_and_jacobian_matches_differences(cli, tmp_path):
    """External loads (robot YAML `loads:`, Robot.with_loads) and the exact tip Jacobian / compliance."""
    text = PAIR_B.read_text() + "loads:\n  gravity: [0, -9.81, 0]\n  tip_force: [0.05, 0, 0]\n"
    text = text.replace("    inner_diameter: 2.55e-3", "    inner_diameter: 2.55e-3\n    linear_density: 0.02")
    path = tmp_path / "loaded.yaml"
    path.write_text(text)
    expected = load_json(cli("fk", "--robot", path, "--alpha", "0,1.2", "--beta", "-0.018,-0.018", "--json").stdout)
    r = ctr.load_robot(str(path))
    assert r.loads == {"gravity": [0.0, -9.81, 0.0], "tip_force": [0.05, 0.0, 0.0], "tip_moment": [0.0, 0.0, 0.0]}
    assert r.tubes[0]["linear_density"] == 0.02 and ctr.Robot(r.to_dict()).to_yaml() == r.to_yaml()
    s = ctr.solve(r, [0, 1.2], [-0.018, -0.018])
    assert_same(s.to_dict(), expected)
    assert s.loaded and np.linalg.norm(s.base_force) > 0.05
    free = ctr.solve(r.with_loads(gravity=[0, 0, 0], tip_force=[0, 0, 0]), [0, 1.2], [-0.018, -0.018])
    assert not free.loaded and np.linalg.norm(free.tip_position - s.tip_position) > 1e-4

    j = ctr.tip_jacobian(r, s)
    assert j.ok and j.actuation.shape == (6, 4) and j.compliance.shape == (6, 6)
    h = 1e-6
    plus = ctr.solve(r, [0, 1.2 + h], [-0.018, -0.018], warm=s).tip_position
    minus = ctr.solve(r, [0, 1.2 - h], [-0.018, -0.018], warm=s).tip_position
    assert np.allclose(j.actuation[:3, 1], (plus - minus) / (2 * h), rtol=1e-5, atol=1e-8)
    fx = r.with_loads(tip_force=[0.05 + h, 0, 0])
    fm = r.with_loads(tip_force=[0.05 - h, 0, 0])
    d = (ctr.solve(fx, [0, 1.2], [-0.018, -0.018], warm=s).tip_position -
         ctr.solve(fm, [0, 1.2], [-0.018, -0.018], warm=s).tip_position) / (2 * h)
    assert np.allclose(j.compliance[:3, 0], d, rtol=1e-5, atol=1e-8)
    with pytest.raises(ValueError):
        ctr.tip_jacobian(ctr.load_robot(str(THREE)), s)
