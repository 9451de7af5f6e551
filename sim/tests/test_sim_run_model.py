"""`make sim MODE=model` (the cycle model's estimate without Verilator) and the cycle model's section beside an
RTL run of `make sim` (models/timing/cycle_model.py against the kernel, every retire cycle)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SECTION = "cycle model (models/timing/cycle_model.py)"


def _run(tmp: Path, *extra: str) -> dict:
    cmd = [sys.executable, "-m", "sim.run", "--scene", "stack", "--iters", "1", "--out", str(tmp),
           "--converged-budget", "5", *extra]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=1200)
    print(proc.stdout[-3000:])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return json.loads(next(tmp.glob("*/report.json")).read_text())


def test_mode_model_reports_the_estimate_and_the_errors_against_the_exact_reference(tmp_path: Path) -> None:
    report = _run(tmp_path, "--mode", "model")
    model = report[SECTION]
    assert model["model: kernel cycles"] > model["model: manifold-passes"] == 2 * 10
    assert model["model: DONE starts at cycle"] + 2 == model["model: kernel cycles"]
    assert not any(k.startswith("bit-exactness") or k.startswith("kernel speed") for k in report)
    err = report["error (velocities after the step; dynamic bodies)"]
    assert err["fp32 golden model vs exact reference (rounding + iteration error): max |dv| (m/s)"] > 0
    assert err["exact reference residual, contact phase: normal LCP |min(lam K, e)| max (m/s)"] < 1e-9


def test_rtl_run_reports_model_against_rtl(tmp_path: Path) -> None:
    """Deterministic streams (make sim's default): every retire cycle equals the model's."""
    report = _run(tmp_path)
    section = report[f"{SECTION} vs RTL"]
    rtl = report["kernel speed (RTL in Verilator)"]["kernel cycles (ap_start to ap_done)"]
    assert section["model: kernel cycles"] == rtl
    assert section["model vs RTL cycles"].startswith(f"model {rtl:,} vs RTL {rtl:,} cycles (+0, +0.000%); retire "
                                                     "cycles: 20 of 20 exact")
    assert section["model vs RTL: first difference"] == "none"


def test_mode_model_knows_the_impulses_in_the_records(tmp_path: Path) -> None:
    """`IMPULSE_STORE=records` reaches the cycle model and the resource model: no impulse RAM in the fit, the run
    named for it."""
    report = _run(tmp_path, "--mode", "model", "--impulse-store", "records")
    fit = report["fit on the platform (resource estimate of this configuration)"]
    assert "impulses with the records" in fit["configuration"]
    assert any(k.startswith("verdict") and v.startswith("FITS") for k, v in fit.items())
    assert next(tmp_path.glob("*-impulses-in-records/report.json"))


def test_mode_model_knows_the_tangents_derived_on_chip(tmp_path: Path) -> None:
    """`TANGENTS=chip` reaches the cycle model (the one-beat friction record, the deeper pipe) and the resource model:
    the run named for it, the fit with the derived-tangent friction pipe."""
    report = _run(tmp_path, "--mode", "model", "--impulse-store", "records", "--tangents", "chip")
    fit = report["fit on the platform (resource estimate of this configuration)"]
    assert "tangent basis derived on chip" in fit["configuration"]
    assert next(tmp_path.glob("*-impulses-in-records-tangents-on-chip/report.json"))


def test_mode_model_knows_the_scene_inertia(tmp_path: Path) -> None:
    """`INERTIA=scene` on the stack's cubes (isotropic: the scalar mode) reaches the cycle model (the 15-word body
    record: 4 beats of 128 bits in place of 5, a shorter LOAD) and the resource model (the 1-word build), the run
    named for it."""
    base = _run(tmp_path / "build", "--mode", "model")
    scene = _run(tmp_path / "scene", "--mode", "model", "--inertia", "scene")
    assert "1-word inverse inertia" in scene["fit on the platform (resource estimate of this configuration)"][
        "configuration"]
    nb = int(str(scene["scene"]["bodies"]).replace(",", ""))  # one beat fewer per body-in record
    solve = "model: SOLVE starts at cycle"
    assert base[SECTION][solve] - scene[SECTION][solve] == nb
    assert next((tmp_path / "scene").glob("*-scene-inertia/report.json"))

