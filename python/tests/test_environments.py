"""Environments: load, info, shape check and clearance against `ctr env info` / `ctr env check`."""
import numpy as np
import pytest

import ctr
from conftest import EXAMPLES, assert_same, load_json

ENV = EXAMPLES / "environments" / "proc_intracardiac.yaml"
ROBOT = EXAMPLES / "robots" / "proc_intracardiac.yaml"


@pytest.fixture(scope="module")
def env():
    return ctr.load_environment(ENV)


def test_info_equals_cli(cli, env):
    expected = load_json(cli("env", "info", ENV, "--json").stdout)
    assert_same(env.info(), expected, ignore=("build_seconds",))
    lo, hi = env.bounds
    assert lo.shape == (3,) and np.all(hi > lo)
    assert env.base_pose.shape == (4, 4) and set(env.targets) == {t["name"] for t in expected["targets"]}
    centres, sizes = env.occupied_voxels()
    assert centres.shape == (len(sizes), 3) and len(sizes) == expected["occupied_leaves"]
    assert np.all(env.is_obstacle(centres[:50]))


@pytest.mark.parametrize("alpha,beta,extra", [
    ("0,0,0", "-0.10,-0.16,-0.21", []),
    ("0.5,2.0,-1.0", "-0.06,-0.10,-0.14", ["--margin", "0.0005", "--max-distance", "0.01"]),
])
def test_check_equals_cli(cli, env, alpha, beta, extra):
    expected = load_json(cli("env", "check", ENV, "--robot", ROBOT, "--alpha", alpha, "--beta", beta, "--json",
                             *extra).stdout)
    robot = ctr.load_robot(str(ROBOT))
    a = [float(x) for x in alpha.split(",")]
    b = [float(x) for x in beta.split(",")]
    kw = {}
    if extra:
        kw = {"margin": float(extra[1]), "max_distance": float(extra[3])}
    got = ctr.check_shape(env, robot, a, b, **kw)
    assert_same(got, expected, ignore=("timing_us",))
    # the same through a reusable checker
    checker = ctr.CollisionChecker(env, robot, **kw)
    s = ctr.solve(robot, a, b)
    assert checker.check(s)["collision"] == expected["collision"]
    assert checker.clearance(s)["clearance"] == pytest.approx(expected["clearance"], abs=1e-12)
