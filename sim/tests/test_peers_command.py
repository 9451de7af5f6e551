"""`make peers`: the FPGA designs and the peers on one small frame, one table (rows present, figures finite, ratios
consistent), its files, and bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
THESIS_FP32 = "thesis ZCU102 fp32"


@pytest.fixture(scope="module")
def table(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path, str]:
    out = tmp_path_factory.mktemp("peers")
    proc = subprocess.run([sys.executable, "-m", "sim.peers", "--scene", "stack", "--runs", "1", "--out", str(out)],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    run = next(out.glob("stack*"))
    return json.loads((run / "peers.json").read_text()), run, proc.stdout


def test_every_kind_of_row_is_present(table) -> None:
    report, _, _ = table
    designs = [r["design"] for r in report["rows"]]
    groups = [r["group"] for r in report["rows"]]
    assert designs[:2] == [THESIS_FP32, "thesis ZCU102 fp16"]
    assert sum(d.startswith("ours: window kernel") for d in designs) == 2
    assert any(d.startswith("Bullet's batched PGS in Warp") for d in designs)
    assert sum(d.startswith("MuJoCo PGS") for d in designs) == 2
    assert groups.count("anchor") >= 5 and groups.count("FPGA") == 4
    warp = next(r for r in report["rows"] if r["design"].startswith("Bullet's batched"))
    assert warp["extra"]["bit_exact"] and "1 thread" in warp["where"]


def test_figures_are_finite_and_the_errors_against_the_exact_reference(table) -> None:
    report, _, _ = table
    for r in report["rows"]:
        if r["group"] == "anchor":
            assert "NOT MEASURED HERE" in r["how"] and r["error"] is None
            continue
        assert r["ms"] is not None and math.isfinite(r["ms"]) and r["ms"] > 0, r
        assert isinstance(r["error"], dict), r  # an exact reference exists for the stack
        assert all(math.isfinite(v) and v >= 0 for v in r["error"].values())
    ours = [r for r in report["rows"] if r["design"].startswith("ours")]
    assert all(r["fit"].startswith("FITS") for r in ours)


def test_ratios_are_against_the_thesis_and_the_best_measured_peer(table) -> None:
    report, _, _ = table
    rows = [r for r in report["rows"] if r["ms"] is not None]
    thesis = next(r["ms"] for r in rows if r["design"] == THESIS_FP32)
    best = min(r["ms"] for r in rows if r["measured"])
    for r in rows:
        assert r["vs_thesis"] == pytest.approx(thesis / r["ms"], rel=1e-12)
        assert r["vs_best_peer"] == pytest.approx(best / r["ms"], rel=1e-12)
    assert any(r["measured"] and r["vs_best_peer"] == pytest.approx(1.0) for r in rows)


def test_the_table_the_plot_and_the_machine_are_written(table) -> None:
    report, run, stdout = table
    md = (run / "peers.md").read_text()
    assert md.count("\n| ") == len(report["rows"]) + 1  # header + one line a row
    assert (run / "peers.png").stat().st_size > 10_000
    assert "machine:" in report["heading"] and "cores" in report["heading"]
    assert "| FPGA | thesis ZCU102 fp32 |" in stdout


def test_bad_input_is_one_line_and_writes_nothing(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "sim.peers", "--scene", "stack", "--iters", "0", "--out",
                           str(tmp_path / "p")], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stderr.strip().splitlines()[-1] == "error: --iters must be >= 1, got 0"
    assert not (tmp_path / "p").exists()


def test_a_mujoco_model_beyond_the_memory_cap_is_not_started() -> None:
    """The arena a MuJoCo model needs (its broadphase's share quadratic in the bodies) is checked against the child's
    address-space cap before any child starts."""
    from models import scenes
    from models.setup.constraints import body_table, setup_constraints
    from models.golden.contact_solver import SolverParams
    from models.golden.integrator import IntegrationParams
    from sim import peers
    from sim.compare.exact_error import NoExactReference

    frame, label = scenes.load_scene("stack", "", 1)
    bodies = body_table(frame)
    step = peers.Step(frame, label, bodies, setup_constraints(frame, bodies), SolverParams(), IntegrationParams(),
                      NoExactReference("not needed"))
    out = peers.run_mujoco_point(peers.MujocoPoint("unused.npz", 0, 4, 0.0, 1), step, 60.0, 1.0)
    assert out.facts is None and out.final is None
    assert out.failure.startswith("not run: its arena needs 0.1 GB") and "above the 1 GB cap" in out.failure
