"""Bad input raises ctr.InputError (a ValueError) with the CLI's message: file, line and key."""
import numpy as np
import pytest

import ctr
from conftest import EXAMPLES, cli_error

PAIR_B = EXAMPLES / "robots" / "tube_pair_B.yaml"
GOOD_TUBE = """  - name: {name}
    straight_length: 0.018
    curved_length: 0.15
    curvature: 6.49
    bending_stiffness: {ei}
    poisson_ratio: 0.6
"""


def robot_text(ei_inner="0.0511", extra=""):
    return ("name: bad\ntubes:\n" + GOOD_TUBE.format(name="outer", ei="0.0334") +
            GOOD_TUBE.format(name="inner", ei=ei_inner) + extra)


@pytest.mark.parametrize("name,text,parts", [
    ("malformed", "name: bad\ntubes: [\n  - {name: outer\n", ["bad.yaml:", "YAML"]),
    ("bad_value", robot_text(ei_inner="-1"), ["bad.yaml:13", "bending_stiffness", "inner"]),
    ("unknown_key", robot_text(extra="frictoin: {boundary: 0.1}\n"), ["bad.yaml:15", "frictoin"]),
    ("wrong_type", robot_text(ei_inner="stiff"), ["bad.yaml:13", "bending_stiffness"]),
])
def test_bad_robot_file(cli, tmp_path, name, text, parts):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    proc = cli("fk", "--robot", path, check=False)
    assert proc.returncode == 2
    with pytest.raises(ctr.InputError) as e:
        ctr.load_robot(str(path))
    assert str(e.value) == cli_error(proc)
    for p in parts:
        assert p in str(e.value)
    assert isinstance(e.value, ValueError)
    assert e.value.file == str(path) and e.value.line > 0
    assert str(e.value).startswith(f"{path}:{e.value.line}: ")
    if name == "bad_value":
        assert e.value.key == "bending_stiffness" and "tube 'inner'" in e.value.message


def test_missing_file(cli, tmp_path):
    missing = tmp_path / "nope.yaml"
    proc = cli("fk", "--robot", missing, check=False)
    with pytest.raises(ctr.InputError) as e:
        ctr.load_robot(str(missing))
    assert str(e.value) == cli_error(proc) and e.value.line == 0


def test_bad_robot_dict():
    d = ctr.load_robot(str(PAIR_B)).to_dict()
    d["tubes"][1]["bending_stiffness"] = -1.0
    with pytest.raises(ctr.InputError) as e:
        ctr.Robot(d)
    assert e.value.file == "<robot dict>" and e.value.key == "bending_stiffness" and e.value.line == 0
    assert str(e.value).startswith("<robot dict>: key 'bending_stiffness': tube 'inner' (2)")
    d = ctr.load_robot(str(PAIR_B)).to_dict()
    d["tubes"][0]["curvatur"] = 1.0
    with pytest.raises(ctr.InputError, match="curvatur"):
        ctr.Robot(d)
    with pytest.raises(TypeError, match="robot dict"):
        ctr.Robot({"name": "x", "tubes": [object()]})


def test_inadmissible_configuration(cli):
    proc = cli("fk", "--robot", PAIR_B, "--alpha", "0,0", "--beta", "-0.018,-0.03", check=False)
    assert proc.returncode == 2
    robot = ctr.load_robot(str(PAIR_B))
    with pytest.raises(ValueError) as e:
        ctr.solve(robot, [0, 0], [-0.018, -0.03])
    # the CLI names its option (--beta), the module its argument (beta); the rest is the same
    assert "-" + str(e.value) == cli_error(proc).replace("--beta", "-beta")
    with pytest.raises(ValueError, match="alpha: 3 values given, robot 'tube_pair_B' has 2 tubes"):
        ctr.solve(robot, [0, 0, 0])
    with pytest.raises(ValueError, match="not a finite number"):
        ctr.solve(robot, [0, np.nan])


def test_bad_query_environment_and_recording(cli, tmp_path):
    q = tmp_path / "q.yaml"
    text = (EXAMPLES / "queries" / "proc_intracardiac.yaml").read_text()
    q.write_text(text.replace("robot: ../robots/", f"robot: {EXAMPLES}/robots/")
                 .replace("environment: ../environments/", f"environment: {EXAMPLES}/environments/")
                 .replace("time_limit: 20", "time_limt: 20"))
    proc = cli("plan", q, check=False)
    with pytest.raises(ctr.InputError) as e:
        ctr.load_query(str(q))
    assert str(e.value) == cli_error(proc) and "time_limt" in str(e.value)

    env = tmp_path / "env.yaml"
    env.write_text((EXAMPLES / "environments" / "proc_intracardiac.yaml").read_text() + "colour: red\n")
    proc = cli("env", "info", env, check=False)
    with pytest.raises(ctr.InputError) as e:
        ctr.load_environment(str(env))
    assert str(e.value) == cli_error(proc) and "colour" in str(e.value)

    rec = tmp_path / "rec.csv"
    rows = (EXAMPLES / "recordings" / "friction_masked_B.csv").read_text().splitlines()
    rec.write_text("\n".join(rows[:3]) + "\n")
    proc = cli("diagnose", "--robot", EXAMPLES / "recordings" / "friction_masked_B.robot.yaml", "--recording", rec,
               "--json", tmp_path / "d.json", check=False)
    robot = ctr.load_robot(str(EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"))
    with pytest.raises(ctr.InputError) as e:
        ctr.diagnose(robot, str(rec))
    assert str(e.value) == cli_error(proc) and "at least 8" in str(e.value)
