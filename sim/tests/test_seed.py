"""One default seed everywhere (sim/drive/seed.py): a test run alone, make test and make sim agree; SEED overrides it
and a bad one is refused; CI derives its seed from the commit (.ci/run) and prints it."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from sim.drive.seed import DEFAULT_SEED, run_seed

REPO = Path(__file__).resolve().parents[2]


def test_one_default_seed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SEED", raising=False)
    assert run_seed() == DEFAULT_SEED
    makefile = REPO.joinpath("Makefile").read_text()
    assert re.search(rf"^SEED \?= {DEFAULT_SEED}$", makefile, re.M), "make test's SEED default is not DEFAULT_SEED"
    assert "export WAVES SEED" in makefile  # every test of make test reads it
    for value, want in (("7", 7), (" 12 ", 12), ("", DEFAULT_SEED)):
        monkeypatch.setenv("SEED", value)
        assert run_seed() == want
    monkeypatch.setenv("SEED", "one")
    with pytest.raises(ValueError, match="SEED must be an integer, got 'one'"):
        run_seed()


def test_ci_derives_its_seed_from_the_commit(tmp_path: Path) -> None:
    """.ci/run's seed: the commit's 7 hex digits as an integer, printed with the command that reruns it; SEED given
    wins. (The script's make test is replaced by a stub that prints what it was given.)"""
    ci = REPO.joinpath(".ci", "run").read_text()
    stub = tmp_path / "make"
    stub.write_text('#!/bin/sh\necho "make $*"\n')
    stub.chmod(0o755)
    script = tmp_path / "run"
    script.write_text(ci.replace('cd "$(dirname "$0")/.."', f'cd "{REPO}"'))
    env = {"PATH": f"{tmp_path}:/usr/bin:/bin"}
    out = subprocess.run(["bash", str(script)], env=env, capture_output=True, text=True, check=True).stdout
    commit = subprocess.run(["git", "rev-parse", "--short=7", "HEAD"], cwd=REPO, capture_output=True, text=True,
                            check=True).stdout.strip()
    seed = int(commit, 16)
    assert f"CI: SEED={seed} (from the commit; rerun with: make test SEED={seed})" in out
    assert f"make test SEED={seed} PYTEST_ARGS=" in out
    out = subprocess.run(["bash", str(script)], env=env | {"SEED": "5", "PYTEST_ARGS": "--lf"}, capture_output=True,
                         text=True, check=True).stdout
    assert "CI: SEED=5 " in out and "make test SEED=5 PYTEST_ARGS=--lf" in out
