"""Shared fixtures of the Python-side tests: the `wsm` binary under test (env WSM_BIN, set by
scripts/python_tests.sh) and a helper that runs it."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def wsm_bin() -> str:
    path = os.environ.get("WSM_BIN") or str(ROOT / "target" / "release" / "wsm")
    if not Path(path).is_file():
        pytest.fail(f"no wsm binary at {path}: build it (cargo build --release) or set WSM_BIN")
    return path


@pytest.fixture(scope="session")
def run_wsm(wsm_bin):
    """Run `wsm ARGS...`; returns the completed process (stdout/stderr as text). `check`
    (default True) fails the test on a non-zero exit status, showing stderr."""

    def run(*args, check=True, cwd=None, input=None):
        done = subprocess.run(
            [wsm_bin, *map(str, args)],
            capture_output=True,
            text=True,
            cwd=cwd,
            input=input,
            timeout=600,
        )
        if check and done.returncode != 0:
            pytest.fail(f"wsm {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}")
        return done

    return run


@pytest.fixture(scope="session")
def example_scene(run_wsm):
    """The scene of a bundled example as a dict."""

    def scene(name):
        return json.loads(run_wsm("example", name).stdout)

    return scene
