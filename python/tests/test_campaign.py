"""Benchmark campaigns from Python: load_campaign, shards, run_campaign and merge_campaign against `ctr bench merge`
(the same library calls), and benchmark() of one query.

Run in a process of its own (CTest `Python.pytest_campaign`): the runs reseed OMPL, which would change the random
sequence of test_planner.py's comparison with a fresh `ctr plan`.
"""
import json

import pytest

import ctr
from conftest import EXAMPLES, cli_error

CAMPAIGN = EXAMPLES / "campaigns" / "intracardiac_tiny.yaml"
QUERY = EXAMPLES / "queries" / "proc_intracardiac.yaml"


def test_load_campaign_units_and_shards():
    c = ctr.load_campaign(str(CAMPAIGN))
    assert c.name == "intracardiac_tiny" and c.modes == ["exact"] and c.runs_per_seed == 1
    assert sorted(c.planners) == ["kpiece", "rrt"] and sorted(c.seeds) == [1, 2, 3] and c.time_limit == 1.0
    assert [q["name"] for q in c.queries] == ["proc_intracardiac"]
    units = c.units()
    assert len(units) == 6 and len({u["id"] for u in units}) == 6
    assert units[0]["id"] == "proc_intracardiac/exact/kpiece/seed-1"
    parts = [c.shard(f"{i}/4") for i in range(4)]
    assert parts == [c.shard((i, 4)) for i in range(4)]
    assert sorted(u["id"] for p in parts for u in p) == sorted(u["id"] for u in units)
    assert max(map(len, parts)) - min(map(len, parts)) <= 1
    for bad in ("4/4", "1", "a/b", (2, 2), (-1, 3)):
        with pytest.raises(ValueError):
            c.shard(bad)
    assert ctr.is_campaign_file(str(CAMPAIGN)) and not ctr.is_campaign_file(str(QUERY))
    assert json.loads(c.to_json())["fingerprint"] == c.fingerprint


def test_bad_campaign_names_file_and_key(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text(f"queries: [{QUERY}]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1, 1]\ntime_limit: 1\n")
    with pytest.raises(ctr.InputError, match=r"seeds\[1\]"):
        ctr.load_campaign(str(f))


def test_run_and_merge_equal_the_command(cli, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    ra = ctr.run_campaign(str(CAMPAIGN), str(a), shard="0/2")
    assert ra["shard"] == "0/2" and ra["units"] == 3 and len(ra["units_run"]) == 3 and ra["units_kept"] == 0
    again = ctr.run_campaign(ctr.load_campaign(str(CAMPAIGN)), str(a), shard=(0, 2))
    assert again["units_run"] == [] and again["units_kept"] == 3

    with pytest.raises(ctr.InputError, match="missing: "):
        ctr.merge_campaign([str(a)], str(tmp_path / "partial"))
    partial = ctr.merge_campaign([str(a)], str(tmp_path / "partial"), allow_incomplete=True)
    assert not partial["complete"] and len(partial["missing"]) == 3 and partial["runs"] == 3

    ctr.run_campaign(str(CAMPAIGN), str(b), shard=(1, 2))
    summary = ctr.merge_campaign([str(a), str(b)], str(tmp_path / "py"))
    assert summary["complete"] and summary["runs"] == 6 and len(summary["run_outcomes"]) == 6
    assert (tmp_path / "py" / "benchmark.db").is_file()
    assert summary == json.loads((tmp_path / "py" / "summary.json").read_text())
    # `ctr bench merge` of the same records gives the same summary.
    cli("bench", "merge", a, b, "--out", tmp_path / "cli", "--quiet")
    assert summary == json.loads((tmp_path / "cli" / "summary.json").read_text())

    # A folder of another campaign is refused with the message of `ctr bench`.
    other = tmp_path / "other.yaml"
    other.write_text(f"queries: [{QUERY}]\nplanners: [rrt]\nmodes: [exact]\nseeds: [9]\ntime_limit: 0.5\n")
    with pytest.raises(ctr.InputError, match="another campaign") as e:
        ctr.run_campaign(str(other), str(a))
    p = cli("bench", other, "--out", a, check=False)
    assert p.returncode == 2 and cli_error(p) == str(e.value)


def test_benchmark_one_query(tmp_path):
    q = ctr.load_query(str(QUERY))
    r = ctr.benchmark(q, planners=["rrt", "kpiece"], runs=2, time_limit=0.5, out=str(tmp_path))
    assert [row["planner"] for row in r["rows"]] == ["KPIECE1", "RRT"]  # OMPL's names, sorted
    assert all(row["runs"] == 2 and 0.0 <= row["planner_success_rate"] <= 1.0 for row in r["rows"])
    assert json.loads((tmp_path / "summary.json").read_text()) == r["rows"]
    assert (tmp_path / "proc_intracardiac_exact.log").is_file() and r["log"].endswith("proc_intracardiac_exact.log")
    with pytest.raises(ValueError, match="unknown planner 'no_such_planner'"):
        ctr.benchmark(q, planners=["no_such_planner"], runs=1, time_limit=0.5, out=str(tmp_path / "x"))
    assert not (tmp_path / "x").exists(), "nothing written for a bad call"
