"""diagnose(...) returns the same dict as `ctr diagnose --json` writes."""
import math
import threading

import pytest

import numpy as np

import ctr
from conftest import DATA_DIR, EXAMPLES, assert_same, load_json

TIMING = ("seconds",)


def test_diagnose_equals_cli(cli, tmp_path):
    rec = DATA_DIR / "recordings" / "pub_friction_sweep_B.csv"
    robot_yaml = DATA_DIR / "recordings" / "pub_friction_sweep_B.robot.yaml"
    if not rec.exists():
        rec = EXAMPLES / "recordings" / "friction_masked_B.csv"
        robot_yaml = EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"
    out, robot_out = tmp_path / "d.json", tmp_path / "found.yaml"
    cli("diagnose", "--robot", robot_yaml, "--recording", rec, "--json", out, "--quiet", "--robot-out", robot_out)
    expected = load_json(out.read_text())
    robot = ctr.load_robot(str(robot_yaml))
    messages = []
    got = ctr.diagnose(robot, rec, progress=messages.append, robot_out=str(tmp_path / "found_py.yaml"))
    assert_same(got, expected, ignore=TIMING)
    # --robot-out: the robot the diagnosis found, the same from Python; it loads, with the fitted friction
    assert (tmp_path / "found_py.yaml").read_text() == robot_out.read_text()
    found = ctr.load_robot(str(robot_out))
    fitted = [e for e in expected["final"]["effects"] if e["effect"] == "boundary_friction"]
    assert "boundary_friction" in expected["verdict"] and fitted
    assert found.friction["boundary"] == pytest.approx(fitted[0]["mu"], rel=1e-12)
    assert "95 %" in robot_out.read_text() and "friction.boundary" in robot_out.read_text()
    cli("fk", "--robot", robot_out)
    assert messages and all(isinstance(m, str) for m in messages)
    assert got["verdict"] == expected["verdict"]
    # rejected one-parameter candidates say how large they would have had to be to be seen
    limits = [f["detection_limit"] for f in got["findings"] if not f["accepted"] and "detection_limit" in f]
    assert limits and all(v > 0 for v in limits)

    # a loaded recording gives the same answer, and the Markdown report comes along on request
    recording = ctr.load_recording(rec)
    assert recording.alpha.shape == (recording.rows, 2) and recording.tip_position.shape[1] in (0, 3)
    got2, report = ctr.diagnose(robot, recording, with_report=True)
    assert_same(got2, expected, ignore=TIMING)
    assert "boundary_friction" in report


def test_diagnose_releases_the_gil():
    """A Python thread keeps running while diagnose works in another one."""
    robot = ctr.load_robot(str(EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"))
    rec = ctr.load_recording(str(EXAMPLES / "recordings" / "friction_masked_B.csv"))
    done = threading.Event()
    ticks = []

    def work():
        ctr.diagnose(robot, rec, candidates=["boundary_friction"], max_effects=1, threads=1)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks.append(float(np.sum(np.arange(1000.0))))
        done.wait(0.001)
    t.join()
    assert len(ticks) > 5


def test_diagnose_decimates_to_max_rows():
    """max_rows from Python: the 73-row recording with max_rows=30 uses one row in 3 (25 rows); a negative value
    raises."""
    robot = ctr.load_robot(str(EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"))
    rec = ctr.load_recording(str(EXAMPLES / "recordings" / "friction_masked_B.csv"))
    got = ctr.diagnose(robot, rec, candidates=["boundary_friction"], max_effects=1, threads=1, max_rows=30)
    assert got["stride"] == 3 and got["rows"] == 25
    assert ctr.diagnose(robot, rec, candidates=["boundary_friction"], max_effects=0, threads=1)["stride"] == 1
    with pytest.raises(ValueError, match="max_rows"):
        ctr.diagnose(robot, rec, max_rows=-1)


def test_diagnose_takes_the_noise_and_the_branch_rule():
    """--noise and --branch from Python: the noise is reported as given, the rule as asked (path by default); bad
    values raise ('auto' with the reason it is not offered)."""
    robot = ctr.load_robot(str(EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"))
    rec = ctr.load_recording(str(EXAMPLES / "recordings" / "friction_masked_B.csv"))
    got = ctr.diagnose(robot, rec, candidates=["boundary_friction"], max_effects=1, threads=1,
                       noise="twist=0.5deg", branch="rest")
    assert got["noise"]["twist"]["source"] == "given"
    assert abs(got["noise"]["twist"]["sigma"] - math.radians(0.5)) < 1e-12
    assert got["branch_rule"] == "rest"
    assert "branch_ambiguous_rows" in got and got["outlier_rows"] == []
    default = ctr.diagnose(robot, rec, candidates=["boundary_friction"], max_effects=0, threads=1)
    assert default["branch_rule"] == "path"
    with pytest.raises(ValueError, match="auto"):
        ctr.diagnose(robot, rec, branch="auto")
    with pytest.raises(ValueError, match="noise"):
        ctr.diagnose(robot, rec, noise="twist=-1deg")
    with pytest.raises(ValueError, match="branch"):
        ctr.diagnose(robot, rec, branch="sideways")


def test_diagnose_calibrates_like_the_cli(cli, tmp_path):
    """calibrate=True is `ctr diagnose --calibrate`: the same dict."""
    robot_yaml = EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"
    rec = EXAMPLES / "recordings" / "friction_masked_B.csv"
    out = tmp_path / "c.json"
    cli("diagnose", "--robot", robot_yaml, "--recording", rec, "--json", out, "--quiet", "--calibrate",
        "--candidates", "precurvature,torsional_stiffness,actuator_offset", "--max-effects", "1", "--threads", "1")
    expected = load_json(out.read_text())
    got = ctr.diagnose(ctr.load_robot(str(robot_yaml)), rec, calibrate=True, max_effects=1, threads=1,
                       candidates=["precurvature", "torsional_stiffness", "actuator_offset"])
    assert_same(got, expected, ignore=TIMING)


def test_diagnose_takes_a_list_of_recordings(cli, tmp_path):
    """A list of recordings of one robot is diagnosed together: the same dict as `ctr diagnose --recording A
    --recording B --json`, each recording's own diagnosis inside it; --robot-out the same from both."""
    robot_yaml = EXAMPLES / "recordings" / "friction_masked_B.robot.yaml"
    text = (EXAMPLES / "recordings" / "friction_masked_B.csv").read_text()
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(text)
    b.write_text(text)
    opts = ("--candidates", "boundary_friction", "--max-effects", "1", "--threads", "1")
    out, robot_out = tmp_path / "d.json", tmp_path / "found.yaml"
    cli("diagnose", "--robot", robot_yaml, "--recording", a, "--recording", b, "--json", out, "--quiet",
        "--robot-out", robot_out, *opts)
    expected = load_json(out.read_text())
    robot = ctr.load_robot(str(robot_yaml))
    got = ctr.diagnose(robot, [str(a), str(b)], candidates=["boundary_friction"], max_effects=1, threads=1,
                       robot_out=str(tmp_path / "found_py.yaml"))
    assert_same(got, expected, ignore=TIMING)
    assert (tmp_path / "found_py.yaml").read_text() == robot_out.read_text()
    assert [r["file"] for r in got["recordings"]] == [str(a), str(b)]
    single = ctr.diagnose(robot, str(a), candidates=["boundary_friction"], max_effects=1, threads=1)
    assert_same(got["recordings"][0]["diagnosis"], single, ignore=TIMING)
    assert all(e["agreement"] in ("shared", "differs", "one_recording", "of_the_recording") for e in got["effects"])
    with pytest.raises(ValueError, match="at least two"):
        ctr.diagnose(robot, [str(a)])
    with pytest.raises(ValueError, match="with_report"):
        ctr.diagnose(robot, [str(a), str(b)], with_report=True)
