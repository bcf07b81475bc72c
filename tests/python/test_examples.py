"""The Python examples (examples/python/) run to the end at small budgets, and say what they
should: the figure is written, the Sobol indices are finite, and no local L-BFGS-B maximum
beats wsm's worst scenario."""

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("wsm", reason="the wsm package is not installed (pip install crates/python)")

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "python"


def run(script, *args, cwd=None):
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True, timeout=600, cwd=cwd
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_tunnel_worst_writes_its_table_and_figure(tmp_path):
    out = run("tunnel_worst.py", "--budget", "60", "--out", tmp_path)
    assert "change %" in out and "phi3" in out
    figure = tmp_path / "tunnel_worst.png"
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sobol_indices_on_the_evaluator():
    out = run("sobol_importance.py", "--samples", "8")
    assert "S1" in out and "contacts[fault_high].slip_limit" in out


def test_lbfgsb_finds_no_larger_maximum_than_wsm():
    out = run("lbfgsb_vs_worst.py", "--budget", "120")
    assert "wsm ≥ L-BFGS-B" in out and "False" not in out
