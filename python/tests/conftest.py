"""Shared fixtures of the `ctr` Python module tests.

Run by CTest (test `Python.pytest`) with PYTHONPATH at the build tree's module and CTR_CLI at the `ctr` command, or
by hand:  PYTHONPATH=build/python CTR_CLI=build/apps/ctr /usr/bin/python3 -m pytest python/tests
"""
import json
import math
import os
import subprocess
from pathlib import Path

import pytest

SOURCE_DIR = Path(os.environ.get("CTR_SOURCE_DIR", Path(__file__).resolve().parents[2]))
EXAMPLES = SOURCE_DIR / "examples"


def _data_dir():
    """The folder of the public data sets (med-mpd/, dupont-lab-ctr-trajectory-hjhdog1/, recordings/), looked up as
    CMake does: CTR_DATA (CTest passes the folder CMake chose), else ../shared/data beside the checkout, else data/
    in the checkout (filled by scripts/fetch-data.sh)."""
    if os.environ.get("CTR_DATA"):
        return Path(os.environ["CTR_DATA"]).absolute()
    beside = SOURCE_DIR.parent / "shared" / "data"
    return beside if beside.is_dir() else SOURCE_DIR / "data"


DATA_DIR = _data_dir()
# The data sets scripts/fetch-data.sh fetches; the others (recordings) are only in ../shared/data.
FETCHABLE = ("med-mpd", "dupont-lab-ctr-trajectory-hjhdog1")


def missing_data_message(data_set):
    """The one message for a missing data set: where it was looked for and how to get it."""
    how = ("run scripts/fetch-data.sh to fetch it" if data_set in FETCHABLE
           else "it is only in ../shared/data beside the checkout")
    return f"data set '{data_set}' not found in {DATA_DIR}: {how} (or set CTR_DATA to the folder of the data sets)"


def data_path(data_set, *parts, required=True):
    """The path of a file of a data set: DATA_DIR / data_set / parts. When the data set is missing and `required`,
    skips the calling test with missing_data_message."""
    path = DATA_DIR.joinpath(data_set, *parts)
    if required and not (DATA_DIR / data_set).is_dir():
        pytest.skip(missing_data_message(data_set))
    return path


def _find_cli():
    if os.environ.get("CTR_CLI"):
        return Path(os.environ["CTR_CLI"])
    for build in ("build", "build-py"):
        p = SOURCE_DIR / build / "apps" / "ctr"
        if p.exists():
            return p
    return None


CLI = _find_cli()


@pytest.fixture(scope="session")
def cli():
    """Runs the `ctr` command: cli(*args) -> CompletedProcess (text)."""
    if CLI is None or not CLI.exists():
        pytest.skip("the ctr CLI was not found (set CTR_CLI)")

    def run(*args, check=True):
        p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=300)
        if check and p.returncode != 0:
            raise AssertionError(f"ctr {' '.join(map(str, args))} exited {p.returncode}: {p.stderr}")
        return p

    return run


def cli_error(proc):
    """The message of a failed CLI run: its stderr line "error: MESSAGE" without the prefix."""
    lines = [l for l in proc.stderr.splitlines() if l.startswith("error: ")]
    assert lines, proc.stderr
    return lines[-1][len("error: "):]


def assert_same(a, b, path="", rel=1e-12, abs_=1e-12, ignore=()):
    """Asserts that two JSON-like values are equal (numbers to rel/abs tolerance), naming the first difference."""
    if path.split(".")[-1] in ignore:
        return
    if isinstance(a, dict) and isinstance(b, dict):
        keys_a = {k for k in a if k not in ignore}
        keys_b = {k for k in b if k not in ignore}
        assert keys_a == keys_b, f"{path}: keys differ: {sorted(keys_a ^ keys_b)}"
        for k in keys_a:
            assert_same(a[k], b[k], f"{path}.{k}", rel, abs_, ignore)
    elif isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        assert len(a) == len(b), f"{path}: lengths {len(a)} != {len(b)}"
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{k}]", rel, abs_, ignore)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None or b is None:
        assert a == b, f"{path}: {a!r} != {b!r}"
    else:
        assert math.isclose(float(a), float(b), rel_tol=rel, abs_tol=abs_), f"{path}: {a!r} != {b!r}"


def load_json(text):
    return json.loads(text)
