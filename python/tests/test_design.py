"""ctr.design: the dict of `ctr design`'s result.json, on a small easy problem (5 mm map, 2-tube robot)."""
import pytest

import ctr

pytestmark = pytest.mark.skipif(not hasattr(ctr, "design"), reason="built without ctr::design")

ENV = """name: easy
resolution: 0.005
padding: 0.2
bounds: {min: [-0.16, -0.16, -0.02], max: [0.16, 0.16, 0.3], units: m}
obstacles:
  - points: wall.xyz
    units: m
starts:
  base: {position: [0, 0, 0], direction: [0, 0, 1], x_axis: [1, 0, 0], units: m}
targets:
  near: [0.012, 0.0, 0.085]
"""
ROBOT = """name: easy_robot
tubes:
  - {name: outer, straight_length: 0.05, curved_length: 0.03, curvature: 10, youngs_modulus: 60e9,
     poisson_ratio: 0.33, outer_diameter: 0.0016, inner_diameter: 0.0012, translation_limits: [-0.08, 0]}
  - {name: inner, straight_length: 0.09, curved_length: 0.02, curvature: 15, youngs_modulus: 60e9,
     poisson_ratio: 0.33, outer_diameter: 0.001, inner_diameter: 0.0006, translation_limits: [-0.11, -0.01]}
"""
QUERY = """name: easy
robot: robot.yaml
environment: env.yaml
start: {alpha: [0, 0], beta: [-0.075, -0.105], history: positive}
goal: {target: near, tolerance: 0.003}
mode: frictionless
planner: rrtconnect
time_limit: 2
"""


def test_design_returns_the_result_of_the_cli_and_writes_a_loadable_robot(tmp_path):
    rows = [f"-0.03 {-0.03 + 0.004 * i} {0.02 + 0.004 * k}" for i in range(16) for k in range(21)]
    (tmp_path / "wall.xyz").write_text("\n".join(rows) + "\n")
    (tmp_path / "env.yaml").write_text(ENV)
    (tmp_path / "robot.yaml").write_text(ROBOT)
    (tmp_path / "easy.yaml").write_text(QUERY)
    r = ctr.design([tmp_path / "easy.yaml"], out=tmp_path / "out", evaluations=2, population=2, probe_time=0.3,
                   finalists=2, finalist_plans=3)
    assert r["solved"], r["message"]
    assert len(r["evaluations"]) == 2
    assert r["queries"][0]["plan"]["solved"]
    # The design kept is the best finalist, planned again with 3 independent seeds (docs/design.md "Finalists").
    assert r["options"]["finalist_plans"] == 3
    assert len(r["confirmation"]["seeds"]) == 3
    assert r["confirmation"]["plans"] == 3
    assert r["confirmation"]["success_rate"] == r["confirmation"]["solved"] / 3
    assert r["confirmation"]["success_rate"] >= r["options"]["finalist_rate"]
    assert r["finalists"][0]["index"] == r["design"]["index"]
    robot = ctr.load_robot(str(tmp_path / "out" / "robot.yaml"))
    assert robot is not None
    with pytest.raises(ctr.InputError):
        ctr.design([tmp_path / "easy.yaml"], space=tmp_path / "robot.yaml")  # a robot is not a design space
