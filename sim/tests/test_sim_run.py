"""`make sim` on a tiny scene: the run finishes and the report carries the expected fields."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_sim_run_reports(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    cmd = [sys.executable, "-m", "sim.run", "--scene", "stack", "--iters", "2", "--format", "fp32",
           "--out", str(out), "--window", "4"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300)
    print(proc.stdout)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(next(out.glob("*/report.json")).read_text())
    assert report["scene"]["manifolds"] > 0 and report["scene"]["contact points"] >= report["scene"]["manifolds"]
    assert report["schedule"]["manifold-passes"] == 4 * report["scene"]["manifolds"]
    assert "float64 reference (s)" in report["solve time (this machine)"]
    assert (next(out.glob("*/report.md"))).read_text().startswith("# pgs-cosim run")


def test_sim_run_rejects_bad_input(tmp_path: Path) -> None:
    for args, word in ((["--format", "fp33"], "number format"), (["--dma", "nope"], "DMA preset"),
                       (["--scene", "nope"], "unknown scene")):
        proc = subprocess.run([sys.executable, "-m", "sim.run", "--out", str(tmp_path), *args], cwd=REPO,
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode != 0
        # pybullet's C module prints a build banner on import; everything else is one error line
        lines = [ln for ln in proc.stderr.splitlines() if not ln.startswith("pybullet build time")]
        assert len(lines) == 1 and lines[0].startswith("error:") and word in lines[0], proc.stderr
        assert not any(tmp_path.iterdir())
