"""`make lint` runs in `make test` too: every RTL top of the kernel's source list (rtl/pgs_kernel.f) is
`verilator --lint-only -Wall` clean."""

import re
import subprocess
import sys
from pathlib import Path

from sim.lint import rtl_files

REPO = Path(__file__).resolve().parents[1]


def test_rtl_lints_clean() -> None:
    proc = subprocess.run([sys.executable, "-m", "sim.lint"], cwd=REPO, capture_output=True, text=True, timeout=600)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    summary = re.search(r"lint: (\d+) runs over (\d+) tops, 0 with warnings/errors", proc.stdout)
    _, modules = rtl_files()
    assert summary and int(summary.group(2)) == len(modules), f"not every module of rtl/pgs_kernel.f linted: {summary}"
