"""`make sim` on a tiny scene: the run finishes and the report carries the expected fields."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_sim_run_reports(tmp_path: Path) -> None:
    """`make sim` on the stack: the RTL kernel runs (the build is shared with test_pgs_kernel), 0 differing bits,
    and the report carries every section the README describes."""
    out = tmp_path / "sim"
    cmd = [sys.executable, "-m", "sim.run", "--scene", "stack", "--iters", "2", "--format", "fp32",
           "--out", str(out), "--converged-budget", "20"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=1200)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    report = json.loads(next(out.glob("*/report.json")).read_text())
    assert report["scene"]["manifolds"] > 0 and report["scene"]["contact points"] >= report["scene"]["manifolds"]
    assert report["schedule"]["manifold-passes"] == 4 * report["scene"]["manifolds"]
    bits = report["bit-exactness (RTL kernel against the golden model, same format)"]
    assert bits["bits differing from the golden model (must be 0)"] == 0 and bits["first mismatch"] == "none"
    assert bits["trace records compared"] == report["schedule"]["manifold-passes"]
    speed = report["kernel speed (RTL in Verilator)"]
    assert speed["kernel cycles (ap_start to ap_done)"] >= report["schedule"]["manifold-passes"]
    assert speed["co-simulation speed (simulated cycles per wall second)"] > 0
    roof = report["roofline (lower bounds for this configuration)"]
    assert roof["measured cycles"] >= max(v for k, v in roof.items() if k.endswith("floor (cycles)"))
    err = report["error (velocities after the step; dynamic bodies)"]
    assert any(k.startswith("RTL kernel vs float64") for k in err)
    assert any("residual after the converged solve" in k for k in err)
    assert "thesis ZCU102 fp32 (127,000 manifolds, 275 MHz)" in report["comparison with the thesis and with software solvers"]
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
