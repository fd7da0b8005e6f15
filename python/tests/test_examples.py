"""The examples in examples/python run (their --quick form) and say what they found."""

import pathlib
import subprocess
import sys

import pytest

from conftest import ROOT

EXAMPLES = sorted((ROOT / "examples" / "python").glob("*.py"))


def test_there_are_three_examples():
    assert {p.stem for p in EXAMPLES} >= {"priority_sweep", "ior_sweep", "mirage_fan"}


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs(example, tmp_path):
    run = subprocess.run(
        [sys.executable, str(example), "--quick", "--out", str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip(), "the example printed nothing"
    # Either a plot was written or the example said why not.
    plotted = any(p.suffix == ".png" for p in tmp_path.iterdir())
    assert plotted or "matplotlib is not installed" in run.stdout
