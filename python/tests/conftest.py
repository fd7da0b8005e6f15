"""Shared fixtures: the repository's scenes and the `snell` command line the
Python results are compared with."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


def _snell_binary():
    """The CLI to compare against: $SNELL_BIN, else the newest build in the
    target directory (`cargo test` builds target/debug/snell)."""
    if os.environ.get("SNELL_BIN"):
        return pathlib.Path(os.environ["SNELL_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    found = [p for p in (target / "release" / "snell", target / "debug" / "snell") if p.is_file()]
    if not found:
        raise RuntimeError(
            f"no snell binary in {target}/release or {target}/debug: run `cargo build` or set SNELL_BIN"
        )
    return max(found, key=lambda p: p.stat().st_mtime)


@pytest.fixture(scope="session")
def cli():
    """Run `snell ARGS...` from the repository root; returns the completed process."""
    binary = _snell_binary()

    def run(*args, check=True):
        return subprocess.run(
            [str(binary), *map(str, args)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=check,
        )

    return run


@pytest.fixture(scope="session")
def scenes():
    return SCENES
