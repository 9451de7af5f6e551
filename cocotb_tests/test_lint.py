"""`make lint` runs in `make test` too: every RTL top is `verilator --lint-only -Wall` clean."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_rtl_lints_clean() -> None:
    proc = subprocess.run([sys.executable, "-m", "sim.lint"], cwd=REPO, capture_output=True, text=True, timeout=600)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
