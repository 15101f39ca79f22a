"""Friction: sweeps, simulate, the hysteresis state object and the friction band, against `ctr sweep` / `simulate`."""
import copy
import csv
import io
import math
import pickle

import numpy as np
import pytest

import ctr
from conftest import EXAMPLES

PAIR_B = EXAMPLES / "robots" / "tube_pair_B.yaml"
BETA = [-0.018, -0.018]


def read_csv(text):
    rows = list(csv.DictReader(io.StringIO(text)))
    return {k: np.array([float(r[k]) if r[k] != "" else math.nan for r in rows]) for k in rows[0]}


@pytest.mark.parametrize("mode", ["stick-slip", "paper"])
def test_sweep_equals_cli(cli, mode):
    out = cli("sweep", "--robot", PAIR_B, "--tube", "2", "--from", "0", "--to", "360deg", "--step", "30deg",
              "--both-directions", "--boundary-friction", "0.12", "--friction-mode", mode, "--beta", "-0.018,-0.018")
    expected = read_csv(out.stdout)
    robot = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    sw = ctr.sweep(robot, 2, 0.0, 2 * math.pi, math.radians(30), both_directions=True, beta=BETA,
                   options=ctr.FrictionOptions(mode=mode))
    k = len(expected["alpha_1"])
    assert sw["twist"].shape == (k, 1) and sw["angle"].shape == (k,)
    for i in (1, 2):
        assert np.array_equal(sw["alpha"][:, i - 1], expected[f"alpha_{i}"])
        assert np.array_equal(sw["beta"][:, i - 1], expected[f"beta_{i}"])
    assert np.allclose(sw["twist"][:, 0], expected["twist_2"], rtol=1e-12, atol=1e-13)
    for d, c in enumerate("xyz"):
        assert np.allclose(sw["tip_position"][:, d], expected[f"tip_{c}"], rtol=1e-12, atol=1e-13)
        assert np.allclose(sw["tip_tangent"][:, d], expected[f"tip_t{c}"], rtol=1e-12, atol=1e-13)
    assert np.array_equal(sw["direction"], expected["direction"])
    assert np.array_equal(sw["stable"], expected["stable"] == 1)
    assert np.array_equal(sw["converged"], expected["converged"] == 1)
    assert np.array_equal(sw["snapped"], expected["snapped"] == 1)
    if mode == "stick-slip":  # the envelope: going up and coming back differ at 180 deg
        up, down = sw["twist"][6, 0], sw["twist"][-7, 0]
        assert sw["angle"][6] == sw["angle"][-7] and abs(down - up) > math.radians(30)


def test_simulate_equals_cli(cli, tmp_path):
    angles = np.radians([0, 40, 80, 120, 160, 120, 80, 40, 0])
    act = tmp_path / "act.csv"
    act.write_text("alpha_1,alpha_2,beta_1,beta_2\n" +
                   "".join(f"0,{a!r},-0.018,-0.018\n" for a in angles))
    rec = tmp_path / "rec.csv"
    cli("simulate", "--robot", PAIR_B, "--actuation", act, "--out", rec, "--boundary-friction", "0.12")
    expected = read_csv(rec.read_text())
    robot = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    alpha = np.column_stack([np.zeros_like(angles), angles])
    sim = ctr.simulate(robot, alpha, np.tile(BETA, (len(angles), 1)), keep_states=True)
    assert np.allclose(sim["twist"][:, 0], expected["twist_2"], rtol=1e-12, atol=1e-13)
    for d, c in enumerate("xyz"):
        assert np.allclose(sim["tip_position"][:, d], expected[f"tip_{c}"], rtol=1e-12, atol=1e-13)
    assert len(sim["states"]) == len(angles) and all(s.valid for s in sim["states"])
    assert sim["failure"] == ["none"] * len(angles)  # why a row failed, as a value (ctr::Failure)


def test_hysteresis_state_is_a_python_value():
    robot = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    r = ctr.initial_state(robot, [0, 0], BETA)
    assert r.converged and r.state.valid and r.state.contacts
    up = r
    for a in np.radians(np.arange(10, 181, 10)):
        up = ctr.step(robot, up.state, [0, a])  # beta kept from the state
    assert np.array_equal(up.state.beta, BETA)
    branch = copy.copy(up.state)
    # same command, different history -> different shape
    down = ctr.step(robot, up.state, [0, math.radians(270)])
    down = ctr.step(robot, down.state, [0, math.pi])
    assert abs(down.solution.twist[0] - up.solution.twist[0]) > math.radians(20)
    # the copy is independent, and a pickled state continues exactly like the original
    again = ctr.step(robot, branch, [0, math.radians(200)])
    restored = pickle.loads(pickle.dumps(branch))
    assert restored.contacts == branch.contacts
    again2 = ctr.step(robot, restored, [0, math.radians(200)])
    assert np.array_equal(again.solution.twist, again2.solution.twist)
    # also with the planner's settings, where a step extrapolates from the state's warm-start memory
    fo = ctr.FrictionOptions()
    fo.kinematics.extrapolate_warm_start = True
    fo.kinematics.tolerance = 1e-8
    path = ctr.step(robot, branch, [0, math.radians(185)], options=fo)
    path = ctr.step(robot, path.state, [0, math.radians(190)], options=fo)
    restored = pickle.loads(pickle.dumps(path.state))
    a = ctr.step(robot, path.state, [0, math.radians(195)], options=fo)
    b = ctr.step(robot, restored, [0, math.radians(195)], options=fo)
    assert np.array_equal(a.solution.twist, b.solution.twist)
    assert np.array_equal(a.solution.tip_position, b.solution.tip_position)
    assert {"mode", "torque", "bound", "relative_twist"} <= set(up.state.contacts[0])
    assert up.state.contacts[0]["mode"] in ("stick", "slip_positive", "slip_negative")
    with pytest.raises(ValueError, match="not initialised"):
        ctr.step(robot, ctr.HysteresisState(), [0, 1])


def test_friction_band_is_the_sweep_envelope():
    robot = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    sw = ctr.sweep(robot, 2, 0.0, 2 * math.pi, math.radians(30), both_directions=True, beta=BETA)
    band = ctr.friction_band(robot, [0, math.pi], BETA, interior_samples=0)
    assert band.converged and len(band.shapes) == 3  # frictionless + 2 vertices (one contact)
    up, down = sw["twist"][6, 0], sw["twist"][-7, 0]
    assert band.twist_min[0] == pytest.approx(min(up, down), abs=1e-6)
    assert band.twist_max[0] == pytest.approx(max(up, down), abs=1e-6)
    assert band.tip_positions.shape == (3, 3) and band.torque_fractions.shape == (3, 1)
    assert band.tip_spread > 0.005


def test_friction_band_names_its_sites_and_follows_a_path():
    robot = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    band = ctr.friction_band(robot, [0, 2.0], BETA, interior_samples=0)
    assert len(band.sites) == band.torque_fractions.shape[1] == 1
    site = band.sites[0]
    assert site["outer"] == 1 and site["inner"] == 2 and site["s"] > 0
    # Walking the band along a path: each shape stays on the branch of the shape with the same torque fractions, so
    # with small steps it is the band solved cold wherever the cold solve has one branch (away from the snap).
    prev = band
    for a in [2.05, 2.1, 2.15, 2.2]:
        prev = ctr.friction_band(robot, [0, a], BETA, interior_samples=0, follow=prev)
        cold = ctr.friction_band(robot, [0, a], BETA, interior_samples=0)
        assert prev.converged and len(prev.shapes) == len(cold.shapes)
        assert np.allclose(prev.tip_positions, cold.tip_positions, atol=1e-9)
        assert np.allclose(prev.torque_fractions, cold.torque_fractions)


def test_uniqueness_certificate_for_every_rotation_and_around_a_band():
    pair = ctr.load_robot(str(PAIR_B)).with_friction(boundary=0.12)
    c = ctr.uniqueness_certificate(pair, [0, 1.0], BETA)
    assert c["certified"] and c["status"] == "certified" and 0 < c["interaction"] < 0.98
    lung = ctr.load_robot(str(EXAMPLES / "robots" / "medmpd_lung.yaml")).with_friction(boundary=0.1)
    q = ([0.0, 1.2, -0.7], [-0.06, -0.14, -0.2])
    everywhere = ctr.uniqueness_certificate(lung, *q)
    assert everywhere["status"] == "interacting" and everywhere["interaction"] > 1
    band = ctr.friction_band(lung, *q, interior_samples=0)
    around = ctr.uniqueness_certificate(lung, band=band)
    assert around["certified"] and around["interaction"] < everywhere["interaction"]
    bare = ctr.KinematicsOptions()
    bare.record_tube_states = False
    with pytest.raises(ValueError, match="angles"):
        ctr.uniqueness_certificate(lung, band=ctr.friction_band(lung, *q, interior_samples=0, kinematics=bare))


def test_drives_of_the_robot_description_are_state(tmp_path):
    """A robot with an actuation block: the tubes sit at the joints of the commands, the plays are part of the
    state (copied, pickled) and a reversal within a play does not move the tubes."""
    text = PAIR_B.read_text().replace(
        "    inner_diameter: 1.97e-3\n",
        "    inner_diameter: 1.97e-3\n    actuation:\n      rotation: {offset: 0.05, play: 0.3}\n")
    f = tmp_path / "driven.yaml"
    f.write_text(text)
    robot = ctr.load_robot(str(f)).with_friction(boundary=0.12)
    r = ctr.initial_state(robot, [0, 0], BETA)
    r = ctr.step(robot, r.state, [0, 1.0])  # beta kept from the state's command
    st = r.state
    assert st.alpha[1] == pytest.approx(1.0 - 0.15 + 0.05, abs=1e-14)
    assert np.array_equal(st.command[0], [0, 1.0]) and np.array_equal(st.command[1], BETA)
    assert st.plays[0][1] == pytest.approx(0.85, abs=1e-14) and math.isnan(st.plays[0][0])
    back = pickle.loads(pickle.dumps(st))
    assert np.array_equal(back.command[0], st.command[0])
    assert np.array_equal(back.plays[0], st.plays[0], equal_nan=True)
    a, b = ctr.step(robot, st, [0, 0.8]), ctr.step(robot, back, [0, 0.8])
    assert np.array_equal(a.solution.tip_position, b.solution.tip_position)
    assert np.linalg.norm(a.solution.tip_position - r.solution.tip_position) < 1e-9  # within the play: no motion
    # the inverse kinematics answers with the commands that compensate the drives (offset here: plays centred)
    ik = ctr.ik(robot.with_friction(boundary=0.0), list(r.solution.tip_position), alpha=[0, 0.9], beta=BETA)
    assert ik["reached"]
    assert ik["alpha"][1] - ik["drives"]["joint_alpha"][1] == pytest.approx(-0.05, abs=1e-12)
    assert ik["drives"]["alpha_difference"] == pytest.approx(0.05, abs=1e-12)
    # the description as a dict keeps the drives (ctr.Robot(dict) gives the same robot back)
    d = robot.to_dict()
    assert d["tubes"][1]["actuation"]["rotation"] == {"offset": 0.05, "play": 0.3}
    assert "actuation" not in d["tubes"][0]
    assert ctr.Robot(d).to_dict() == d
